"""Every app at 1400 x 900, as a lecturer sees it: after Run, the canvas (what the user
draws on) and the player's picture (what it made) are both in view without scrolling,
and so are Run and the status line (issue 22, point 3)."""

import json
from pathlib import Path

import pytest

from tests.browser.helpers import img_rgba, inside, notebook_view, poll

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
VIEWPORT = {"width": 1400, "height": 900}


def lesson_cells(name, starts):
    """Code cells of a lesson, each the first that starts with one of ``starts``.

    The test runs the lesson's own app code; found by what the cells begin with, not
    by position, so questions added between them do not shift it.
    """
    cells = json.loads((ROOT / "notebooks" / name).read_text())["cells"]
    code = ["".join(c["source"]) for c in cells if c["cell_type"] == "code"]
    return [next(src for src in code if src.startswith(start)) for start in starts]


APPS = {
    "flicker": [
        """\
from fluidnb.widgets import FlickerApp
app = FlickerApp(quick=True)
h, w = app.image.shape[:2]
app.canvas.paint([[0.62 * h, 0.05 * w], [0.62 * h, 0.55 * w]], radius=0.1 * h)
app
"""
    ],
    "frost": [
        """\
from fluidnb.widgets import FrostApp
app = FrostApp(quick=True)
h, w = app.image.shape[:2]
app.canvas.paint([[0.5 * h, 0.2 * w], [0.5 * h, 0.8 * w]], radius=0.2 * h)
app.canvas.click([0.5 * h, 0.5 * w], layer="starts")
app.panel.set("beta", 0.6)
app
"""
    ],
    "fire": [
        """\
from fluidnb.widgets import FireApp
app = FireApp(quick=True, n_frames=8)
app
"""
    ],
    "turbulence": [
        """\
import os
os.environ["FLUIDNB_CACHE_DIR"] = os.path.abspath("cache")  # the kernel's own cache
from fluidnb.widgets import TurbulenceApp
app = TurbulenceApp(n_frames=8)
app
"""
    ],
    # The drawing-tools lesson's app, from the lesson itself (set-up, canvas, app).
    "drawing": [
        "import os\nos.environ['FLUIDNB_QUICK'] = '1'\n",
        *lesson_cells(
            "01_drawing_tools.ipynb",
            ["import os\n", "canvas = DrawingCanvas(", "from dataclasses import dataclass"],
        ),
    ],
}


@pytest.mark.parametrize("name", APPS)
def test_the_canvas_and_the_result_are_in_view_together(name, notebook, page, shot):
    page.set_viewport_size(VIEWPORT)
    notebook(APPS[name])
    app = page.locator(".fluidnb-app")
    app.wait_for()
    page.locator(".fluidnb-app .fluidnb-run").click()
    status = page.locator(".fluidnb-app .fluidnb-status")
    poll(
        "the run to end",
        lambda: any(w in status.inner_text() for w in ("done", "ended")),
        timeout=120,
    )
    frame = page.locator(".fluidnb-app .fluidnb-player .fluidnb-frame").first
    poll("the clip's first frame", lambda: img_rgba(frame) is not None)
    # The app's top at the top of the notebook's view: one position, no scrolling after.
    app.evaluate("el => el.scrollIntoView({block: 'start'})")
    page.wait_for_timeout(300)
    view = notebook_view(page)  # what is visible of the notebook
    assert view["width"] > 1200, view  # the page really is 1400 wide
    shot(page, f"{name}-viewport")
    inside(frame.bounding_box(), view, "the player's picture")
    if name != "turbulence":  # the turbulence app has no canvas: flows are its input
        inside(page.locator(".fluidnb-app .fluidnb-canvas").bounding_box(), view, "the canvas")
    else:
        inside(page.locator(".fluidnb-app .fluidnb-param-strategy").bounding_box(), view, "search")
    inside(page.locator(".fluidnb-app .fluidnb-run").bounding_box(), view, "Run")
    inside(status.bounding_box(), view, "the status line")
    # The first parameter slider is in view too (the compact panel beside the result).
    first = page.locator(".fluidnb-app .fluidnb-panel .widget-slider").first
    inside(first.bounding_box(), view, "the first slider")
