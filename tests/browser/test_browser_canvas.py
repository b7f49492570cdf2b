"""DrawingCanvas in JupyterLab: strokes, brush and points drawn with the real mouse.

The kernel reports every layer to ``state.json`` after each change; the tests compare
what it received with where the mouse went, mapped through the canvas's on-screen
size (the canvas may be displayed scaled).
"""

import numpy as np
import pytest

from tests.browser.helpers import assert_visible, at, canvas_rgba, drag, poll, to_image

pytestmark = pytest.mark.browser

SHAPE = (96, 128)  # (H, W) of the test image

CANVAS = """\
from fluidnb.widgets import DrawingCanvas

img = np.linspace(0.1, 0.9, 128)[None, :] * np.linspace(0.6, 1.0, 96)[:, None]
c = DrawingCanvas(img, {layers}, display_size={size})
{extra}

def report(_=None):
    layers = {{}}
    for name, layer in c.layers.items():
        if layer.kind == "strokes":
            layers[name] = [s.tolist() for s in c.get_strokes(name)]
        elif layer.kind == "paint":
            layers[name] = np.argwhere(c.get_mask(name)).tolist()
        else:
            layers[name] = c.get_points(name).tolist()
    dump("state.json", {{"version": c.version, "tool": c.tool, "layers": layers}})

c.observe(report, "version")
c.observe(report, "tool")
report()
c
"""


def open_canvas(notebook, page, layers, size=512, extra=""):
    nb = notebook([CANVAS.format(layers=layers, size=size, extra=extra)])
    canvas = page.locator(".fluidnb-canvas")
    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()
    assert_visible(box)
    return nb, canvas, box


def is_marker(rgba):
    """Whether a pixel has the points layer's yellow."""
    r, g, b, _ = rgba
    return r > 200 and g > 180 and b < 120


def pick_tool(page, nb, tool):
    page.locator(".fluidnb-tools button", has_text=tool).click()
    nb.state("state.json", lambda s: s["tool"] == tool)


def test_stroke_endpoints_and_direction(notebook, page, shot):
    # A 1024-pixel canvas in a 600-pixel-wide widget: the browser scales it down, so
    # the mapping from screen to image pixels is really exercised.
    nb, canvas, box = open_canvas(
        notebook, page, 'strokes=["flow"]', size=1024, extra='c.layout.width = "600px"'
    )
    assert box["width"] < 1024 * 0.9, f"canvas is not displayed scaled: {box}"
    start, end = at(box, 0.15, 0.3), at(box, 0.85, 0.7)
    drag(page, start, end, steps=20)

    state = nb.state("state.json", lambda s: len(s["layers"]["flow"]) == 1)
    stroke = np.array(state["layers"]["flow"][0])
    assert len(stroke) >= 10, f"the kernel saw too few mouse moves: {len(stroke)} points"
    np.testing.assert_allclose(stroke[0], to_image(box, start, SHAPE), atol=1.5)
    np.testing.assert_allclose(stroke[-1], to_image(box, end, SHAPE), atol=1.5)
    # Drawn left to right and downwards: columns and rows increase along the stroke.
    assert np.all(np.diff(stroke[:, 1]) >= -0.5), stroke[:, 1]
    assert np.all(np.diff(stroke[:, 0]) >= -0.5), stroke[:, 0]
    assert stroke[-1, 1] - stroke[0, 1] > 0.6 * SHAPE[1]

    # The stroke is drawn where the mouse went (cyan over the grey image).
    mid = ((start[0] + end[0]) / 2, (start[1] + end[1]) / 2)
    away = at(box, 0.15, 0.8)
    best = max(canvas_rgba(canvas, [mid], radius=3)[0], key=lambda p: p[2] - p[0])
    assert best[2] - best[0] > 60, f"no stroke colour at the stroke's middle: {best}"
    r2, _, b2, _ = canvas_rgba(canvas, [away])[0]
    assert abs(b2 - r2) < 40, f"unexpected colour away from the stroke: {(r2, b2)}"
    shot(page.locator(".fluidnb-drawing"))


def test_brush_paints_along_the_drag(notebook, page, shot):
    nb, canvas, box = open_canvas(notebook, page, 'strokes=["flow"], masks=["region"]')
    pick_tool(page, nb, "brush")
    radius = 6.0  # the canvas's default brush radius, in image pixels
    start, end = at(box, 0.25, 0.5), at(box, 0.7, 0.55)
    drag(page, start, end, steps=15)

    state = nb.state("state.json", lambda s: len(s["layers"]["region"]) > 0)
    painted = np.array(state["layers"]["region"], float)  # (row, col) of painted pixels
    p0, p1 = np.array(to_image(box, start, SHAPE)), np.array(to_image(box, end, SHAPE))

    def dist_to_path(pts):
        d = p1 - p0
        t = np.clip(((pts - p0) @ d) / (d @ d), 0, 1)
        return np.linalg.norm(pts - (p0 + t[:, None] * d), axis=1)

    far = painted[dist_to_path(painted) > radius + 1.5]
    assert len(far) == 0, f"{len(far)} painted pixels far from the drag, e.g. {far[:5].tolist()}"
    rows, cols = np.mgrid[: SHAPE[0], : SHAPE[1]]
    grid = np.stack([rows.ravel(), cols.ravel()], 1).astype(float)
    core = {tuple(p) for p in grid[dist_to_path(grid) < radius - 1.5].astype(int).tolist()}
    missing = core - {tuple(p) for p in painted.astype(int).tolist()}
    assert not missing, (
        f"{len(missing)} pixels on the drag path unpainted, e.g. {list(missing)[:5]}"
    )

    # The paint shows on the canvas (orange over grey) and nowhere else.
    mid = ((start[0] + end[0]) / 2, (start[1] + end[1]) / 2)
    (r, _, b, _), (r2, _, b2, _) = canvas_rgba(canvas, [mid, at(box, 0.5, 0.1)])
    assert r - b > 60, f"no paint colour at the drag's middle: {(r, b)}"
    assert abs(r2 - b2) < 40, f"paint colour far from the drag: {(r2, b2)}"
    shot(page.locator(".fluidnb-drawing"))


def test_points_add_and_remove(notebook, page, shot):
    nb, canvas, box = open_canvas(notebook, page, 'strokes=["flow"], points=["seeds"]')
    pick_tool(page, nb, "points")
    first, second = at(box, 0.3, 0.4), at(box, 0.7, 0.65)
    page.mouse.click(*first)
    nb.state("state.json", lambda s: len(s["layers"]["seeds"]) == 1)
    page.mouse.click(*second)
    pts = np.array(
        nb.state("state.json", lambda s: len(s["layers"]["seeds"]) == 2)["layers"]["seeds"]
    )
    np.testing.assert_allclose(pts[0], to_image(box, first, SHAPE), atol=1.5)
    np.testing.assert_allclose(pts[1], to_image(box, second, SHAPE), atol=1.5)
    assert is_marker(canvas_rgba(canvas, [first])[0]), "no point marker drawn at the click"
    shot(page.locator(".fluidnb-drawing"), "two-points")

    # The element screenshot may have scrolled the page: measure again.
    first = at(canvas.bounding_box(), 0.3, 0.4)
    page.mouse.click(first[0] + 2, first[1] - 2)  # near the first point: removes it
    state = nb.state("state.json", lambda s: len(s["layers"]["seeds"]) != 2)
    assert state["layers"]["seeds"] == pts[1:].tolist()
    # The redraw may reach the page a moment after the kernel's state file.
    poll("the removed point to vanish", lambda: not is_marker(canvas_rgba(canvas, [first])[0]))
    shot(page.locator(".fluidnb-drawing"))
