"""The flicker app in JupyterLab: paint a region, move a slider, frames change inside only."""

import numpy as np
import pytest

from tests.browser.helpers import (
    ANOTHER_FRAME,
    at,
    drag,
    drag_slider,
    open_app,
    shown_frame,
    to_image,
)

pytestmark = pytest.mark.browser

APP = """\
from fluidnb.widgets import FlickerApp

app = FlickerApp(quick=True, display_size=384)
shape = app.image.shape[:2]

def report_region(_=None):
    dump("region.json", {"cells": np.argwhere(app.canvas.get_mask("region")).tolist(),
                         "shape": list(shape), "radius": app.canvas.brush_radius})

def report_clip(change):
    clip = change["new"]
    if clip is None:
        return
    mask = app.canvas.get_mask("region")
    info = {"n": len(clip), "shape": list(clip.shape),
            "azimuth": clip.metadata["params"]["azimuth"], "full": clip.shape == shape}
    if clip.shape == shape and mask.any():
        image = app.image if app.image.ndim == 3 else app.image[..., None]
        frames = clip.frames if clip.frames.ndim == 4 else clip.frames[..., None]
        outside = frames[:, ~mask]
        info["outside_identical"] = bool(
            np.array_equal(outside, np.broadcast_to(image[~mask], outside.shape))
        )
        info["inside_changes"] = float(np.abs(frames[:, mask] - frames[:1, mask]).max())
    seen.append([info["azimuth"], info["full"]])  # every clip shown, in order
    dump("clip.json", {**info, "seen": seen})

seen = []
app.canvas.observe(report_region, "version")
app.player.observe(report_clip, "clip")
report_region()
app
"""


def test_paint_region_move_slider_frames_change_only_inside(notebook, page, shot):
    nb, app, _, box = open_app(notebook, page, [APP])
    first = nb.state("clip.json", lambda s: s["n"] > 1)  # the first live preview

    # The app opens with the brush on the "region" layer: paint a band on the left.
    start, end = at(box, 0.12, 0.5), at(box, 0.42, 0.55)
    drag(page, start, end, steps=15)
    region = nb.state("region.json", lambda s: len(s["cells"]) > 20)
    cells = np.array(region["cells"], float)
    p0 = np.array(to_image(box, start, region["shape"]))
    p1 = np.array(to_image(box, end, region["shape"]))
    # Every painted pixel lies within the brush radius of the drag path.
    t = np.clip((cells - p0) @ (p1 - p0) / ((p1 - p0) @ (p1 - p0)), 0, 1)
    dist = np.linalg.norm(cells - (p0 + t[:, None] * (p1 - p0)), axis=1)
    assert dist.max() <= region["radius"] + 1.5
    src0 = shown_frame(page.locator(".fluidnb-app .fluidnb-frame"))

    # Unfold the light's group and move its azimuth: the live preview follows.
    page.locator(".fluidnb-app .fluidnb-param-groups").get_by_text("light and relief").click()
    shown = drag_slider(page, page.locator(".fluidnb-param-azimuth"), 0.9)
    assert shown != first["azimuth"]
    # The player follows: a clip of the new azimuth comes -- its preview, or, where the
    # preview was slower than the values' rest, the full result that replaces it (the
    # held-slider preview is test_browser_live's).
    nb.state("clip.json", lambda s: any(abs(a - shown) < 0.5 for a, _ in s["seen"]))
    frame = page.locator(".fluidnb-app .fluidnb-frame")
    page.wait_for_function(ANOTHER_FRAME, arg=[frame.element_handle(), src0])

    # Full render: every frame changes inside the painted region, never outside it.
    page.locator(".fluidnb-app .fluidnb-run").click()
    done = nb.state("clip.json", lambda s: s["full"], timeout=60)
    assert done["outside_identical"] is True
    assert done["inside_changes"] > 0.01
    assert abs(done["azimuth"] - shown) < 0.5
    page.locator(".fluidnb-app .fluidnb-status", has_text="done").wait_for()
    shot(app)
