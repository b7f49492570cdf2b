"""The frost app in JupyterLab: paint a region, click a start point, move rth, run."""

import numpy as np
import pytest

from tests.browser.helpers import at, drag_slider, open_app, to_image

pytestmark = pytest.mark.browser

APP = """\
from fluidnb.widgets import FrostApp

app = FrostApp(quick=True, display_size=384)
app.panel.set("beta", 0.6)  # quick growth, so the full run stays short

def report_inputs(_=None):
    dump("inputs.json", {
        "region": int(app.canvas.get_mask("region").sum()),
        "starts": app.canvas.get_points("starts").tolist(),
        "tool": app.canvas.tool,
        "shape": list(app.image.shape[:2]),
    })

def report_clip(change):
    clip = change["new"]
    if clip is None or clip.metadata.get("preview"):
        return
    image = app.image
    if clip.shape != image.shape[:2]:
        return
    changed = np.abs(clip.frames - image[None]).max(axis=-1) > 0.05
    region = app.canvas.get_mask("region")
    first = next(i for i, f in enumerate(changed) if f.any())
    rows, cols = np.nonzero(changed[first])
    dump("clip.json", {
        "rth": clip.metadata["params"]["rth"],
        "area": changed.reshape(len(clip), -1).sum(axis=1).tolist(),
        "outside": int(changed[:, ~region].sum()),
        "first_centre": [float(rows.mean()), float(cols.mean())],
    })

app.canvas.observe(report_inputs, "version")
app.canvas.observe(report_inputs, "tool")
app.player.observe(report_clip, "clip")
report_inputs()
app
"""


def test_paint_start_rth_run_frost_grows_from_the_start(notebook, page, shot):
    nb, app, _, box = open_app(notebook, page, [APP])

    # Paint the region (the brush is the first tool), twice for a wide band.
    for fy in (0.42, 0.58):
        page.mouse.move(*at(box, 0.15, fy))
        page.mouse.down()
        page.mouse.move(*at(box, 0.85, fy), steps=12)
        page.mouse.up()
    nb.state("inputs.json", lambda s: s["region"] > 500)

    # Click a start point with the points tool.
    page.locator(".fluidnb-app .fluidnb-tools button", has_text="points").click()
    nb.state("inputs.json", lambda s: s["tool"] == "points")
    start_xy = at(box, 0.5, 0.5)
    page.mouse.click(*start_xy)
    inputs = nb.state("inputs.json", lambda s: len(s["starts"]) == 1)
    start_rc = np.array(to_image(box, start_xy, inputs["shape"]))
    np.testing.assert_allclose(inputs["starts"][0], start_rc, atol=1.5)

    # Move rth to about 0.4.
    rth = drag_slider(page, page.locator(".fluidnb-param-rth"), 0.4, steps=6)
    assert 0.2 < rth < 0.6

    page.locator(".fluidnb-app .fluidnb-run").click()
    result = nb.state("clip.json", lambda s: abs(s["rth"] - rth) < 1e-3, timeout=90)
    area = np.array(result["area"])
    assert area[0] == 0 or area[0] < 0.05 * area[-1]
    # Every frame of the growth is drawn: thin fresh ice may flicker across the
    # 0.05 threshold by a few pixels, but the frost never shrinks.
    assert np.diff(area).min() >= -0.01 * area[-1], "frost shrank between frames"
    assert area[-1] > 400, "frost did not spread"
    assert result["outside"] == 0, "frost appeared outside the painted region"
    # The first frost appears at the start point.
    assert np.linalg.norm(np.array(result["first_centre"]) - start_rc) < 6
    page.locator(".fluidnb-app .fluidnb-status", has_text="done").wait_for(timeout=30_000)
    shot(app)
