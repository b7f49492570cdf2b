import numpy as np
import pytest

from fluidnb.widgets import DrawingCanvas
from tests.support.frontend import canvas_event, client_ready, mouse_drag

IMG = np.linspace(0, 1, 48 * 64, dtype=np.float32).reshape(48, 64)


def make(**kw):
    layers = {"strokes": ["flow"], "masks": ["region"], "maps": ["speed"], "points": ["seeds"]}
    layers.update(kw)
    return DrawingCanvas(IMG, **layers)


@pytest.mark.parametrize("scale", [1.0, 2.5, 0.75])
def test_stroke_from_frontend_events_maps_to_image_pixels(scale):
    c = make(scale=scale)
    c.select("stroke")
    # Canvas pixel x = (col + 0.5) * scale: pixel centres map back exactly.
    path = [((col + 0.5) * scale, (10 + 0.5) * scale) for col in (4, 12, 20, 30)]
    mouse_drag(c, path)
    (stroke,) = c.get_strokes("flow")
    assert np.allclose(stroke, [[10, 4], [10, 12], [10, 20], [10, 30]])
    assert c.canvas.width == round(64 * scale)


def test_display_size_sets_scale_and_canvas_size():
    c = make(display_size=512)
    assert c.scale == pytest.approx(8.0)
    assert (c.canvas.width, c.canvas.height) == (512, 384)
    x, y = c.to_canvas(3, 7)
    assert c.to_image(x, y) == pytest.approx((3, 7))


def test_strokes_outside_are_clamped_and_dots_ignored():
    c = make(scale=2)
    c.select("stroke")
    mouse_drag(c, [(-50, 10), (500, 10)])
    (stroke,) = c.get_strokes()
    assert stroke[:, 1].min() == 0
    assert stroke[:, 1].max() == 63
    mouse_drag(c, [(20, 20), (20, 20)])  # a click is not a stroke
    assert len(c.get_strokes()) == 1


def test_brush_paints_mask_and_eraser_erases():
    c = make(scale=2)
    c.select("brush", "region")
    c.brush_radius = 3
    mouse_drag(c, [(2 * 10 + 1, 2 * 20 + 1), (2 * 40 + 1, 2 * 20 + 1)])
    mask = c.get_mask("region")
    assert mask.dtype == bool
    assert mask[20, 10:41].all()
    assert not mask[:16].any()
    assert not mask[25:].any()
    c.select("eraser", "region")
    mouse_drag(c, [(2 * 25 + 1, 2 * 20 + 1), (2 * 25 + 1, 2 * 20 + 1)])
    assert not c.get_mask("region")[20, 25]
    assert c.get_mask("region")[20, 12]


def test_scalar_map_value_and_fill():
    c = make()
    c.paint([[5, 5], [5, 30]], radius=2, value=0.4, layer="speed")
    speed = c.get_map("speed")
    assert speed.dtype == np.float32
    assert speed[5, 10] == pytest.approx(0.4)
    assert set(np.unique(speed)) <= {0.0, np.float32(0.4)}
    c.fill([40, 60], value=0.9, layer="speed")
    speed = c.get_map("speed")
    assert speed[40, 60] == pytest.approx(0.9)
    assert speed[5, 10] == pytest.approx(0.4)  # a separate region keeps its value


def test_points_click_adds_and_click_again_removes():
    c = make(scale=4)
    c.select("points")
    canvas_event(c, "mouse_down", 4 * 10.5, 4 * 5.5)
    canvas_event(c, "mouse_up", 4 * 10.5, 4 * 5.5)
    canvas_event(c, "mouse_down", 4 * 30.5, 4 * 20.5)
    canvas_event(c, "mouse_up", 4 * 30.5, 4 * 20.5)
    assert c.get_points().tolist() == [[5, 10], [20, 30]]
    canvas_event(c, "mouse_down", 4 * 10.7, 4 * 5.6)  # near the first: removes it
    assert c.get_points().tolist() == [[20, 30]]


def test_undo_takes_back_the_last_action_whichever_layer_it_was_on():
    # Issue 22, point 7: the Undo button undid only the active layer's actions.
    c = make()
    c.draw_stroke([[1, 1], [1, 20]])
    c.paint([[10, 10]], radius=2, layer="region")
    c.select("stroke")  # the active layer is now "flow", the last action was on "region"
    c._undo.click()
    assert not c.get_mask("region").any()
    assert len(c.get_strokes()) == 1
    assert "undid the last change to region" in c.caption
    assert c.undo() == "flow"
    assert c.get_strokes() == []
    assert c.undo() is None
    assert "nothing to undo" in c.caption
    c.set_strokes([[[2, 2], [2, 30]]])  # setters and clears are actions too
    c.clear("region")
    c.paint([[10, 10]], radius=2, layer="region")
    c.clear("flow")
    assert c.undo() == "flow"
    assert len(c.get_strokes()) == 1
    with pytest.raises(ValueError, match="layer must be one of"):
        c.undo("nope")


def test_the_caption_says_what_the_last_change_was():
    # Issue 22, point 7: "cleared flow" stayed after strokes were loaded.
    c = make()
    c.draw_stroke([[1, 1], [1, 20]])
    c.clear("flow")
    assert c.caption == "cleared flow"
    c.set_strokes([[[2, 2], [2, 30]], [[5, 2], [5, 30]]], "flow")
    assert c.caption == "flow: 2 strokes"
    c.set_strokes([[[2, 2], [2, 30]]], "flow")
    assert c.caption == "flow: 1 stroke"
    c.set_points([[4, 4]])
    assert c.caption == "seeds: 1 point"
    c.drag([[6, 6]], tool="stroke")  # a click with the stroke tool draws nothing
    assert "not a stroke" in c.caption
    assert "not a stroke" in c.status.value


def test_undo_and_clear_per_layer():
    c = make()
    c.draw_stroke([[1, 1], [1, 20]])
    c.draw_stroke([[3, 1], [3, 20]])
    c.paint([[10, 10]], radius=2, layer="region")
    c.undo("flow")
    assert len(c.get_strokes()) == 1
    assert c.get_mask("region").any()
    c.clear("region")
    assert not c.get_mask("region").any()
    assert len(c.get_strokes()) == 1
    c.undo("region")  # clearing is undoable too
    assert c.get_mask("region").any()
    c.undo("flow")
    c.undo("flow")  # nothing left: says so, no error
    assert c.get_strokes() == []
    assert "nothing to undo" in c.status.value


def test_setters_and_getters_round_trip_and_copy():
    c = make()
    mask = np.zeros((48, 64), bool)
    mask[10:20, 5:15] = True
    c.set_mask(mask, "region")
    got = c.get_mask("region")
    assert np.array_equal(got, mask)
    got[:] = False  # a copy: the canvas keeps its own
    assert c.get_mask("region").sum() == 100
    c.set_strokes([np.array([[1.0, 2.0], [3.0, 4.0]])])
    assert np.array_equal(c.get_strokes()[0], [[1, 2], [3, 4]])
    c.set_points([[1, 2], [3, 4]])
    assert c.get_points().tolist() == [[1, 2], [3, 4]]
    speed = np.full((48, 64), 0.25, np.float32)
    c.set_map(speed, "speed")
    assert np.array_equal(c.get_map("speed"), speed)


def test_bad_input_is_refused_and_drawing_kept():
    c = make()
    c.draw_stroke([[1, 1], [1, 20]])
    before = c.version
    with pytest.raises(ValueError, match=r"region must have the image's shape \(48, 64\)"):
        c.set_mask(np.ones((10, 10)), "region")
    with pytest.raises(ValueError, match="outside the image"):
        c.set_points([[100, 1]])
    with pytest.raises(ValueError, match="region contains 48 NaN"):
        c.set_mask(np.where(np.eye(48, 64) > 0, np.nan, 0.0), "region")
    with pytest.raises(ValueError, match="no paint layer named 'flow'"):
        c.get_mask("flow")
    with pytest.raises(ValueError, match="tool must be one of"):
        c.tool = "spray"
    with pytest.raises(ValueError, match="layer 'seeds' cannot take the brush tool"):
        c.select("brush", "seeds")
    assert len(c.get_strokes()) == 1
    assert c.version == before


def test_tools_without_layers_are_refused():
    c = DrawingCanvas(IMG, masks=["region"])
    assert c._tool_buttons.options == ("brush", "eraser", "fill")
    with pytest.raises(ValueError, match="no layer to act on"):
        c.select("stroke")
    with pytest.raises(ValueError, match="at least one layer"):
        DrawingCanvas(IMG)


def test_version_counts_changes_for_observers():
    c = make()
    seen = []
    c.observe(lambda ch: seen.append(ch["new"]), "version")
    c.draw_stroke([[1, 1], [1, 20]])
    c.paint([[10, 10]], layer="region")
    assert len(seen) == 2


def test_client_ready_redraws_the_canvas(monkeypatch):
    # Spy on the class before the canvas exists, so the callback under test is the one
    # DrawingCanvas registers itself (a new front end, e.g. Voila, must get a redraw).
    redrawn = []
    original = DrawingCanvas.redraw

    def spy(self):
        redrawn.append(self)
        original(self)

    monkeypatch.setattr(DrawingCanvas, "redraw", spy)
    c = make()
    assert redrawn == [c]  # drawn once when made
    client_ready(c)
    assert redrawn == [c, c]


def test_show_segments_overlay_and_image_replacement():
    from fluidnb.sketch import direction_field, quiver_segments

    c = make()
    c.draw_stroke([[20, 2], [20, 60]])
    field = direction_field(c.get_strokes(), IMG.shape)
    c.show_segments(quiver_segments(field, step=8, length=6))
    c.show_segments(None)
    c.set_image(IMG[::-1])
    with pytest.raises(ValueError, match="image must keep the canvas's size"):
        c.set_image(np.zeros((5, 5)))
    assert len(c.get_strokes()) == 1


def test_changing_the_tool_never_moves_the_canvas():
    # The brush's sliders hide for the points tool; were their row to vanish, the
    # picture would jump up under the mouse between two clicks.
    c = make()
    sliders = (c._value_slider, c._radius_slider)
    for tool in ("brush", "points", "stroke", "fill", "eraser", "brush"):
        c.select(tool)
        assert all(s.layout.display != "none" for s in sliders), tool
    c.select("points")
    assert all(s.layout.visibility == "hidden" for s in sliders)
    c.select("brush")
    assert all(s.layout.visibility == "visible" for s in sliders)
    # A canvas with no brush layer never shows them.
    only = DrawingCanvas(IMG, strokes=["flow"])
    assert all(s.layout.display == "none" for s in (only._value_slider, only._radius_slider))
