"""The fire app in JupyterLab: change a slider, run, frames appear and differ."""

import numpy as np
import pytest

from tests.browser.helpers import (
    ANOTHER_FRAME,
    drag_slider,
    img_rgba,
    open_app,
    pause,
    poll,
    shown_frame,
)

pytestmark = pytest.mark.browser

APP = """\
from fluidnb.widgets import FireApp

app = FireApp(quick=True, display_size=256)

def report_clip(change):
    clip = change["new"]
    if clip is None:
        return
    frames = clip.frames
    dump("clip.json", {
        "n": len(clip),
        "weight": clip.metadata["params"]["weight"],
        "step_change": [float(np.abs(b - a).mean()) for a, b in zip(frames[:-1], frames[1:])],
        "first_last": float(np.abs(frames[-1] - frames[0]).mean()),
        "bright": float(frames.mean()),
        "peak": float(frames.max()),
    })

app.player.observe(report_clip, "clip")
app
"""


def test_slider_run_frames_appear_and_differ(notebook, page, shot):
    nb, app, _, _ = open_app(notebook, page, [APP])
    weight = drag_slider(page, page.locator(".fluidnb-param-weight"), 0.85)
    assert 0.7 < weight <= 1.0

    page.locator(".fluidnb-app .fluidnb-run").click()
    # The run's clip (not a one-keyframe preview of the same weight, which may come first).
    result = nb.state(
        "clip.json", lambda s: abs(s["weight"] - weight) < 1e-3 and s["n"] > 1, timeout=120
    )
    assert result["n"] >= 8
    # A flame on black: mostly dark, with bright fire in it.
    assert result["peak"] > 0.6, "the fire clip is black"
    assert result["bright"] > 0.005
    # The flame moves: consecutive frames differ, and the clip does not stand still.
    assert np.mean(np.array(result["step_change"]) > 1e-4) > 0.8
    assert result["first_last"] > 1e-3
    page.locator(".fluidnb-app .fluidnb-status", has_text="done").wait_for(timeout=30_000)

    # The frames appear in the player, and scrubbing shows another one.
    frame = page.locator(".fluidnb-app .fluidnb-player .fluidnb-frame").first
    frame.scroll_into_view_if_needed()
    poll("the first frame to show", lambda: img_rgba(frame) is not None)
    pause(page, ".fluidnb-app .fluidnb-app-player")
    src0 = shown_frame(frame)
    scrub = page.locator(".fluidnb-app .fluidnb-frame-slider").first
    scrub.focus()
    page.keyboard.press("Home" if src0.split(":")[1] != "0" else "End")
    page.wait_for_function(ANOTHER_FRAME, arg=[frame.element_handle(), src0], timeout=10_000)
    shot(app)
