"""The video-database app driven from Python, with the same calls the front end makes.

The database is the quick water starter (two small clips, ~150 fragments; built once
per test session in the private cache, seconds), the photo the stream shrunk to 160
pixels: a run takes about a second.
"""

import datetime as dt
import io
import json
import threading
import time

import ipywidgets as W
import numpy as np
import pytest
from PIL import Image

from fluidnb import data
from fluidnb.sketch import save_strokes
from fluidnb.videodb import AnimateParams, starter_database
from fluidnb.widgets import VideoDBApp
from fluidnb.widgets import _canvas as canvas_module
from fluidnb.widgets import _videodb as module
from fluidnb.widgets import _videodb_database as dbchoice
from fluidnb.widgets._common import jpeg
from fluidnb.widgets._player import _PREVIEW_QUALITY
from tests.support.frontend import canvas_event, client_ready, mouse_drag

ROW = 62  # a band across the stream photo at 160 px (125 x 160)
STROKE = [[ROW, 15], [ROW, 80], [ROW, 145]]


@pytest.fixture(scope="module")
def db():
    return starter_database("water", quick=True)


@pytest.fixture
def app(db):
    a = VideoDBApp("stream", size=160, db=db)
    a.panel.set("candidates", 30)
    a.run_on_rest = True  # as in a notebook: the clip follows when the values rest
    yield a
    a.close()


def drag_on(app, points, tool, layer):
    """Select a tool and drag through image (row, col) points as the browser would."""
    app.select(tool, layer)
    mouse_drag(app.canvas, [app.canvas.to_canvas(*p) for p in points])


def draw_scene(app):
    """Matte band, a left-to-right stroke and a speed patch, all through mouse events."""
    app.canvas.brush_radius = 22
    drag_on(app, [[ROW, 10], [ROW, 150]], "brush", "matte")
    drag_on(app, STROKE, "stroke", "flow")
    app._speed.value = 2.5
    app.canvas.brush_radius = 8
    drag_on(app, [[ROW, 60], [ROW, 100]], "brush", "speed")


def test_the_panel_has_the_papers_sliders_with_symbols_and_equations(app):
    controls = app.panel.controls
    assert set(controls) == {
        "sigma",
        "lam",
        "rho",
        "candidates",
        "shutter",
        "tau",
        "loop",
        "rendering",  # issue 24: flow (beyond the paper) or paper, and the flow's two
        "travel",
        "detail",
    }
    defaults = AnimateParams()
    assert (defaults.sigma, defaults.lam, defaults.rho) == (100.0, 0.01, 1e4)
    for name, eq in (("sigma", "Eq. (2)"), ("lam", "Eq. (4)"), ("rho", "Eq. (6)")):
        control = controls[name]
        assert type(control).__name__ == "FloatLogSlider"
        assert control.value == getattr(defaults, name)
        assert eq in control.tooltip
        # the paper's symbol, as Unicode (Voila offline shows LaTeX raw; issue 22)
        assert {"sigma": "σ", "lam": "λ", "rho": "ρ"}[name] in control.description
    # N belongs to the database: shown beside the panel, not a slider.
    assert "N = <b>32</b>" in app._n_label.value


# The decades the lessons' sweeps use (07b, sec. 7: 0.01-100 x the paper's values;
# its exercise 3: sigma up to 1e6) and lambda up to 10 (issue 22, point 5).
DECADES = {"sigma": (1.0, 1e6), "lam": (1e-4, 10.0), "rho": (1e2, 1e6)}


@pytest.mark.parametrize("name", DECADES)
def test_sigma_lambda_rho_are_live_log_sliders_over_the_lessons_decades(app, name):
    control = app.panel.controls[name]
    lo, hi = DECADES[name]
    assert 10**control.min <= lo * 1.0001
    assert 10**control.max >= hi / 1.0001
    # The browser snaps a value to min + n * step: the paper's value must lie on it.
    default = getattr(AnimateParams(), name)
    n = (np.log10(default) - control.min) / control.step
    assert abs(n - round(n)) < 1e-6
    assert control.continuous_update  # values reach the kernel while the slider moves


def test_the_layout_puts_the_map_beside_the_canvas_and_the_papers_symbols_first(app):
    # Issue 22, point 3: canvas | clip and map | compact panel; no fixed 450 px
    # controls column (at 1280 px it wrapped under the canvas).
    assert app.controls_width != "450px"
    columns = app._columns.children
    assert columns[0].children[0] is app.canvas
    views = columns[1]
    shown = [w for box in views.children for w in box.children]
    assert shown.index(app.player) < shown.index(app.map)
    assert app.map.width == app.player.display_width
    # sigma, lambda, rho and K open at the top of the panel; the rest folded.
    first, *folded = app.panel.groups.items()
    assert first[1] == ["sigma", "lam", "rho", "candidates"]
    assert [f for _, names in folded for f in names][:3] == ["shutter", "tau", "loop"]
    assert app.panel.accordion.selected_index is None


def test_matte_brush_and_eraser_from_mouse_events(app):
    assert app.canvas.tool == "brush"
    assert app.canvas.layer == "matte"
    app.canvas.brush_radius = 10
    mouse_drag(app.canvas, [app.canvas.to_canvas(ROW, c) for c in (20, 80, 140)])
    matte = app.matte()
    assert matte.dtype == np.float32
    assert set(np.unique(matte)) == {0.0, 1.0}
    assert matte[ROW, 20:141].all()
    assert not matte[ROW + 15 :].any()
    drag_on(app, [[ROW, 80]], "eraser", "matte")
    assert not app.matte()[ROW, 80]
    assert app.matte()[ROW, 30]
    app.canvas.undo("matte")
    assert app.matte()[ROW, 80]


def test_stroke_shows_its_arrow_while_dragging_and_the_quiver_follows(app, monkeypatch):
    app.canvas.brush_radius = 22
    drag_on(app, [[ROW, 10], [ROW, 150]], "brush", "matte")
    assert app.quiver_segments == 0
    heads = []
    real = canvas_module.arrow_heads  # the canvas draws every stroke's head, live ones too
    monkeypatch.setattr(
        canvas_module, "arrow_heads", lambda *a, **k: heads.append(a) or real(*a, **k)
    )
    app.select("stroke", "flow")
    c = app.canvas
    canvas_event(c, "mouse_down", *c.to_canvas(ROW, 15))
    canvas_event(c, "mouse_move", *c.to_canvas(ROW, 50))
    canvas_event(c, "mouse_move", *c.to_canvas(ROW, 90))
    # Before the release: the live stroke is drawn with an arrow head at its end.
    assert heads, "no arrow head drawn on the stroke in progress"
    x, y = c.to_canvas(ROW, 90)
    np.testing.assert_allclose(heads[-1][0][-1], [x, y])
    canvas_event(c, "mouse_up", *c.to_canvas(ROW, 145))
    assert len(app.strokes()) == 1
    # The quiver: unit field pointing right, arrows only over the matte.
    field = app.direction_field()
    np.testing.assert_allclose(field[ROW, 80], [0, 1], atol=1e-3)
    assert app.quiver_segments > 10
    first = app.quiver_segments
    # A second stroke elsewhere, downwards: the field bends there; undo restores it.
    app.canvas.brush_radius = 15
    drag_on(app, [[15, 120], [110, 120]], "brush", "matte")
    drag_on(app, [[20, 130], [105, 130]], "stroke", "flow")
    assert app.direction_field()[60, 130, 0] > 0.5  # dy > 0: downwards
    assert app.quiver_segments > first
    app.canvas.undo("flow")
    np.testing.assert_allclose(app.direction_field()[ROW, 80], [0, 1], atol=1e-3)
    app._show_quiver.value = False
    assert app.quiver_segments == 0
    app._show_quiver.value = True
    assert app.quiver_segments > 0
    app._clear_buttons["flow"].click()
    assert app.strokes() == []
    assert app.quiver_segments == 0


def test_speed_brush_paints_px_per_frame_and_the_matte_brush_stays_binary(app):
    app.select("brush", "speed")
    assert app._speed.layout.display == ""  # the px/frame slider shows for speed
    shown = [w for box in app.canvas.children if isinstance(box, W.HBox) for w in box.children]
    assert app.canvas._value_slider not in shown  # its browser view would snap the value
    app._speed.value = 3.0
    app.canvas.brush_radius = 6
    mouse_drag(app.canvas, [app.canvas.to_canvas(ROW, c) for c in (40, 90)])
    speed = app.speed_map()
    assert speed.dtype == np.float32
    assert speed[ROW, 40:91] == pytest.approx(3.0)
    assert set(np.unique(speed)) == {0.0, np.float32(3.0)}
    # Back on the matte, the brush paints "inside" whatever the speed slider says.
    app.select("brush", "matte")
    assert app._speed.layout.display == "none"
    mouse_drag(app.canvas, [app.canvas.to_canvas(ROW, 60)])
    assert app.matte()[ROW, 60] == 1.0
    app.paint_speed([[20, 20]], speed=0.5, radius=3)
    assert app.speed_map()[20, 20] == pytest.approx(0.5)
    assert app.speed_map()[ROW, 40] == pytest.approx(3.0)
    with pytest.raises(ValueError, match="speed must be in"):
        app.paint_speed([[20, 20]], speed=50)


def test_run_moves_the_photo_inside_the_matte_only(app):
    draw_scene(app)
    clip = app.run(timeout=120)
    assert "done" in app.status, app.status
    assert app.player.clip is clip
    frames = clip.frames
    assert frames.shape == (24, 125, 160, 3)  # N = 32 frames, 8 cross-faded for the loop
    assert clip.metadata["method"] == "videodb"
    assert clip.metadata["params"]["candidates"] == 30
    inside = app.matte() > 0
    change = np.abs(np.diff(frames, axis=0)).max(axis=-1)  # (T - 1, H, W)
    assert change[:, inside].mean() > 2e-3, "the fluid does not move"
    assert (change[:, ~inside] == 0).all(), "pixels outside the matte move"
    np.testing.assert_array_equal(
        frames[:, ~inside], np.broadcast_to(app.photo[~inside], frames[:, ~inside].shape)
    )
    assert (app.retrievals, app.resolves, app.renders) == (1, 0, 1)
    # The views: map with one colour per source clip used, a legend, the energy plot.
    a = app.assignment
    assert app.map.assignment is a
    names = {app.assignment.db.clips[k]["name"] for k in a.db.clip_of(a.fragments)}
    assert all(name in app.map.legend.value for name in names)
    picture = app.map.picture()
    assert picture.shape == (app.map.canvas.height, app.map.canvas.width, 3)
    assert "fluidnb-vdb-energy-plot" in app.energy.value
    assert f"data-icm='{a.solution.icm_energy:.6g}'" in app.energy.value
    assert not app._render_button.disabled
    assert not app._use_speed_button.disabled
    # The drawn direction was honoured: every assigned fragment moves rightwards.
    assert (a.db.mean_motion[a.fragments][:, 1] > 0).all()


def test_moving_sigma_resolves_from_the_kept_tables(app, monkeypatch):
    calls = []
    real = module.assign
    monkeypatch.setattr(module, "assign", lambda *a, **k: calls.append(1) or real(*a, **k))
    app.run_on_rest = False  # Render is pressed below (the render at rest: further down)
    draw_scene(app)
    app.run(timeout=120)
    first = app.assignment
    arrows, energy = app.map.motion_segments(), app.energy.value
    for sigma in (300.0, 1e3, 3e3, 1e4):  # a drag: several values, the latest wins
        app.panel.set("sigma", sigma)
    app.wait_resolve()
    a = app.assignment
    assert a is not first
    assert a.params.sigma == 1e4
    assert a.tables is first.tables  # re-combined, not recomputed
    np.testing.assert_array_equal(a.candidates, first.candidates)
    assert len(calls) == 1
    assert app.retrievals == 1
    assert 1 <= app.resolves <= 4
    assert (a.labels != first.labels).any()
    assert "re-solved from the kept tables" in app.status
    # The assignment view changed with it.
    assert app.map.assignment is a
    assert not np.array_equal(app.map.motion_segments(), arrows)
    assert app.energy.value != energy
    # Render makes the clip of this assignment, still without a new retrieval.
    clip = app.render_clip(timeout=120)
    assert clip.metadata["params"]["sigma"] == 1e4
    assert clip.metadata["energy"] == pytest.approx(a.solution.energy)
    assert (len(calls), app.retrievals, app.renders) == (1, 1, 2)
    # Candidates need a new retrieval: said, and Run does it.
    app.panel.set("candidates", 20)
    assert "press Run" in app.status
    app.run(timeout=120)
    assert len(calls) == 2
    assert app.assignment.candidates.shape[1] == 20


def test_use_the_results_speed_map_fills_the_speed_layer(app):
    with pytest.raises(ValueError, match="press Run first"):
        app.use_result_speed()
    draw_scene(app)
    app.run(timeout=120)
    before = app.speed_map()
    loaded = app.use_result_speed()
    speed = app.speed_map()
    inside = app.matte() > 0
    expected = np.where(inside, app.assignment.speed_map(), 0)
    np.testing.assert_allclose(speed, expected, atol=1e-5)
    assert (speed[~inside] == 0).all()
    assert speed[inside].max() > 0.3
    np.testing.assert_array_equal(loaded, speed)
    assert (app.canvas.tool, app.canvas.layer) == ("brush", "speed")
    assert "speed layer now holds the result's speed" in app.status
    app.canvas.undo("speed")
    np.testing.assert_array_equal(app.speed_map(), before)


def test_cancel_stops_the_run_and_keeps_everything(app):
    draw_scene(app)
    drawn = (app.matte(), app.strokes(), app.speed_map())
    assert app.start()
    app.cancel()
    app.wait(60)
    assert "cancelled" in app.status
    assert app.assignment is None
    assert app.player.clip is None
    assert app.retrievals == 0
    np.testing.assert_array_equal(app.matte(), drawn[0])
    np.testing.assert_array_equal(app.strokes()[0], drawn[1][0])
    np.testing.assert_array_equal(app.speed_map(), drawn[2])
    assert not app._run_button.disabled
    assert app._cancel_button.disabled
    assert app.run(timeout=120) is not None  # and it runs afterwards


def test_cancel_lands_while_the_library_works(app, monkeypatch):
    started = threading.Event()

    def slow_assign(*args, progress=None, **kwargs):
        started.set()
        while True:  # reports progress like the library; Cancel raises in it
            progress(0.5, "working")
            threading.Event().wait(0.01)

    monkeypatch.setattr(module, "assign", slow_assign)
    draw_scene(app)
    assert app.start()
    assert started.wait(30)
    assert app.running
    app.cancel()
    app.wait(10)
    assert not app.running
    assert "cancelled" in app.status


def test_an_empty_matte_says_so_and_loses_nothing(app):
    drag_on(app, STROKE, "stroke", "flow")
    app.paint_speed([[ROW, 50], [ROW, 90]], speed=2.0, radius=5)
    strokes, speed, version = app.strokes(), app.speed_map(), app.canvas.version
    app._run_button.click()
    assert not app.running
    assert "matte is empty" in app.status
    assert "brush" in app.status
    assert app.start() is False
    assert len(app.strokes()) == 1
    np.testing.assert_array_equal(app.strokes()[0], strokes[0])
    np.testing.assert_array_equal(app.speed_map(), speed)
    assert app.canvas.version == version
    assert app.retrievals == 0


def test_a_bad_database_folder_is_said_and_nothing_is_lost(app, tmp_path):
    draw_scene(app)
    app.set_database(tmp_path / "nowhere")
    assert app._db_pick.value == "folder"
    assert "read from the database" in app._n_label.value
    app.run(timeout=30)
    assert "does not exist" in app.status
    assert app.matte().any()
    assert len(app.strokes()) == 1


def test_a_database_folder_opens_and_shows_its_N(app, db):
    app.set_database(db.path)
    opened = app.database()
    assert opened.n_fragments == db.n_fragments
    assert f"{db.n_fragments} fragments" in app._n_label.value


def test_strokes_save_and_load_round_trip_in_the_output_folder(app, tmp_path, monkeypatch):
    # Issue 22, point 8: files go to the output folder (fluidnb-output/, which git
    # ignores), not among the notebooks, and the status line says where; point 7: the
    # count reads "1 stroke".
    monkeypatch.chdir(tmp_path)  # the kernel's working directory: the notebook's folder
    monkeypatch.delenv("FLUIDNB_OUTPUT_DIR", raising=False)
    drag_on(app, STROKE, "stroke", "flow")
    app._save_button.click()
    assert not (tmp_path / "strokes.json").exists()
    assert (tmp_path / "fluidnb-output" / "strokes.json").exists()
    assert app.status == "saved 1 stroke to fluidnb-output/strokes.json", app.status
    drag_on(app, [[100, 150], [100, 20]], "stroke", "flow")
    strokes = app.strokes()
    app._strokes_file.value = "flow.json"
    app._save_button.click()
    assert app.status == "saved 2 strokes to fluidnb-output/flow.json", app.status
    saved = json.loads((tmp_path / "fluidnb-output" / "flow.json").read_text())
    assert saved["format"] == "fluidnb.strokes"
    assert saved["shape"] == [125, 160]
    app._clear_buttons["flow"].click()
    assert app.strokes() == []
    app._load_button.click()
    assert app.status == "loaded 2 strokes from fluidnb-output/flow.json", app.status
    for got, want in zip(app.strokes(), strokes):
        np.testing.assert_allclose(got, want)
    assert app.quiver_segments > 0
    # A path with its folder is taken as it is.
    (tmp_path / "mine").mkdir()
    app.save_strokes("mine/flow.json")
    assert (tmp_path / "mine" / "flow.json").exists()
    assert app.status == "saved 2 strokes to mine/flow.json", app.status
    # Strokes drawn on another image size are refused, in words; nothing is lost.
    save_strokes(tmp_path / "fluidnb-output" / "other.json", [[[1, 1], [5, 5]]], (40, 40))
    app._strokes_file.value = "other.json"
    app._load_button.click()
    assert "40 x 40 image" in app.status
    assert len(app.strokes()) == 2
    app._strokes_file.value = "missing.json"
    app._load_button.click()
    assert "no such file" in app.status
    assert len(app.strokes()) == 2


def test_a_click_on_the_map_shows_the_database_fragment(app):
    draw_scene(app)
    app.run(timeout=120)
    a = app.assignment
    i = len(a.target) // 2
    r, c = a.target.positions[i] + 24
    s = app.map.scale
    canvas_event(app.map, "mouse_down", (c + 0.5) * s, (r + 0.5) * s)
    assert app.map.selected == i
    info = app.state()["selected"]
    assert info["fragment"] == int(a.fragments[i])
    assert info["clip_name"] in app.map.caption.value
    strip = Image.open(io.BytesIO(app.map.strip.value))
    assert strip.size == (5 * 60 + 4 * 4, 60)  # the mean image and four frames
    # A re-solve refreshes the shown fragment with the new assignment's choice.
    app.panel.set("sigma", 1e4)
    app.wait_resolve()
    assert app.state()["selected"]["fragment"] == int(app.assignment.fragments[i])
    # Headless, the same: a place no fragment covers shows nothing.
    assert app.pick_fragment(124, 80) is None
    assert app.map.selected == i
    j = len(a.target) - 1
    assert app.pick_fragment(*(a.target.positions[j] + 24))["index"] == j
    assert app.map.selected == j
    client_ready(app.map)  # a new front end (Voila, a reload) gets the map redrawn


def test_choosing_the_fire_photo_takes_its_matte_and_database():
    app = VideoDBApp("stream", size=128, quick=True)
    try:
        assert app._db_pick.value == "water"
        assert app.panel.params.tau == 0.0
        app.draw_stroke([[40, 10], [40, 100]])
        app._photo_pick.value = "fire"
        assert app.photo_name == "fire"
        assert app.photo.shape == (128, 61, 3)
        # An RGBA cut-out: its alpha is the matte (soft edge kept for the run).
        alpha = data.sample("fire", size=128, return_alpha=True)[1]
        np.testing.assert_array_equal(app.canvas.get_mask("matte"), alpha > 0.5)
        assert 0 < app.matte()[alpha > 0.5].min() <= 1
        assert app.strokes() == []  # a new photo, a new drawing
        assert app._db_pick.value == "fire"
        assert app.panel.params.tau == 0.5  # fire moves its outline (Sec. 6)
        assert "N = <b>32</b>" in app._n_label.value
    finally:
        app.close()


def upload(name, content):
    """One file as the FileUpload widget holds it after the browser sends it."""
    return {
        "name": name,
        "type": "image/png",
        "size": len(content),
        "content": memoryview(content),
        "last_modified": dt.datetime(2026, 1, 1, tzinfo=dt.timezone.utc),
    }


def test_an_uploaded_rgba_cut_out_brings_its_matte():
    app = VideoDBApp("stream", size=128, quick=True)
    try:
        rgba = np.zeros((90, 120, 4), np.uint8)
        rgba[..., :3] = 120
        rgba[20:70, 30:100, 3] = 255
        buf = io.BytesIO()
        Image.fromarray(rgba).save(buf, format="png")
        app._upload.value = (upload("cut.png", buf.getvalue()),)
        assert app.photo_name == "upload"
        assert app._photo_pick.value == "upload"
        assert app.photo.shape == (90, 120, 3)
        assert app.canvas.get_mask("matte").sum() == 50 * 70
        app._upload.value = (upload("junk.png", b"not an image"),)
        assert "could not read the upload" in app.status
        assert app.photo.shape == (90, 120, 3)
    finally:
        app.close()


def png(image):
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="png")
    return buf.getvalue()


def test_an_upload_after_another_photo_shows_the_upload_and_keeps_the_database():
    # Issue 22, point 1: giving the photo menu its "upload" option reset it to its
    # first photo, which loaded the stream (and the water database) over the upload.
    app = VideoDBApp("stream", size=128, quick=True)
    try:
        app.set_photo("clouds")
        assert (app.photo_name, app._db_pick.value) == ("clouds", "smoke")
        picks = []
        app._photo_pick.on_pick(picks.append)
        green = np.zeros((96, 120, 3), np.uint8)
        green[..., 1] = 200
        assert app.set_photo(green)
        assert app.photo_name == "upload"
        assert app._photo_pick.value == "upload"
        assert picks == ["upload"]  # the app never heard of the menu's passing reset
        np.testing.assert_allclose(app.photo, green / 255.0, atol=1e-6)
        assert app.canvas.image.shape == (96, 120, 3)
        assert app._db_pick.value == "smoke"  # an upload keeps the chosen database
        assert app.status.startswith("photo: your upload, 120 x 96 pixels")
        # ... and says so, with a first guess from the photo's colours (issue 36: a lake
        # photo silently kept the smoke database picked for the clouds).
        assert "using the smoke starter database" in app.status
        assert "it looks like water" in app.status
        assert "choose the water database" in app.status
        # The same through the upload button, after picking the fire photo.
        app._photo_pick.value = "fire"
        assert (app.photo_name, app._db_pick.value) == ("fire", "fire")
        blue = np.zeros((64, 80, 3), np.uint8)
        blue[..., 2] = 200
        app._upload.value = (upload("blue.png", png(blue)),)
        assert app.photo_name == "upload"
        assert app._photo_pick.value == "upload"
        assert app.photo.shape == (64, 80, 3)
        assert app.photo[..., 2].min() > 0.75
        assert app._db_pick.value == "fire"
        assert "using the fire starter database: it looks like water" in app.status
        # A photo is one pick away again, and "upload" leaves the menu with it.
        app._photo_pick.value = "lake"
        assert app.photo_name == "lake"
        assert "upload" not in app._photo_pick.options
    finally:
        app.close()


def test_a_given_database_joins_the_menu_without_a_passing_pick(db):
    app = VideoDBApp("clouds", size=128, quick=True)
    try:
        assert app._db_pick.value == "smoke"
        seen = []
        app._db_pick.on_pick(seen.append)
        app.set_database(db)
        assert app._db_pick.value == "given"
        assert seen == ["given"]  # not "water" (the first option) on the way
        assert app.database() is db
    finally:
        app.close()


def drag_sigma(app, values, pause=0.0):
    """A drag of the sigma slider: its values one after the other, as the browser sends."""
    for value in values:
        app.panel.set("sigma", value)
        if pause:
            threading.Event().wait(pause)


def test_dragging_sigma_shows_the_map_and_a_preview_then_the_clip_when_it_rests(app, monkeypatch):
    # Issue 25: every value of a drag re-solves (latest wins), redraws the map and
    # shows a small preview frame; the clip is rendered once the slider rests.
    import fluidnb.widgets._videodb as module

    made = []  # the previews' pictures (the player gets them as JPEG)
    real = module.preview_frame
    monkeypatch.setattr(
        module, "preview_frame", lambda *a, **k: made.append(real(*a, **k)) or made[-1]
    )
    if "rendering" in app.panel.controls:  # the paper's, whose frames the test compares
        app.panel.set("rendering", "paper")
    app.panel.set("loop", 0)  # every fragment at its own frame t (no loop, no stagger)
    draw_scene(app)
    app.run(timeout=120)
    app.wait_resolve()
    first_clip, renders = app.result, app.renders
    assert app.previews == 0
    assert app.player.clip is app.result
    # While the values rested after the run, the candidates' mean images were read for
    # the previews: a drag reads one frame per new fragment, no mean image.
    cache = app._preview_cache[1]
    means = next(v for k, v in cache.items() if isinstance(k, tuple) and "mean" in k[0])
    assert set(means) == set(np.unique(app.assignment.candidates).tolist())
    app.settle = 30.0  # no render while we look at the previews
    drag_sigma(app, [300.0, 1e3, 3e3, 1e4])
    app.wait_resolve()
    a = app.assignment
    assert a.params.sigma == 1e4
    assert app.map.assignment is a  # the map shows the latest
    assert app.previews >= 1
    assert app.player.clip.metadata["preview"]
    shown = Image.open(io.BytesIO(app.player._encode(0)))
    assert shown.size == (80, 63)  # one frame at half the photo's 160 x 125
    assert "preview" in app.player.info.value
    assert "σ = 1e+04" in app.player.info.value
    assert app.renders == renders
    assert app.result is first_clip
    assert "re-solved from the kept tables" in app.status
    # A second request for the same values (a preview read them while their own request
    # still waited, as in a fast drag) makes nothing again and keeps the note.
    previews = app.previews
    app.request_preview()
    app.wait_resolve()
    assert app.previews == previews
    assert "re-solved from the kept tables" in app.status
    # The preview is one frame of what the render will make (the last picture made
    # is the one shown, as JPEG).
    preview = made[-1]
    assert np.abs(np.asarray(shown, np.float32) / 255 - preview).mean() < 0.03
    # (Exactly that frame: a preview goes to the page at the player's preview quality.)
    assert app.player._encode(0) == jpeg(preview, quality=_PREVIEW_QUALITY)
    # The slider rests: the clip of sigma = 1e4 is rendered and plays in its place.
    app.settle = 0.05
    drag_sigma(app, [1e4 * 1.0001])  # one more value (its re-solve schedules the render)
    app.wait_live()
    assert app.renders == renders + 1
    clip = app.result
    assert clip is not first_clip
    assert clip.metadata["params"]["sigma"] == pytest.approx(1e4, rel=1e-3)
    assert clip.metadata["energy"] == pytest.approx(app.assignment.solution.energy)
    assert app.player.clip is clip
    assert app.status.startswith("rendered in"), app.status
    assert "preview" not in app.player.info.value
    # The preview was that frame at half size (block means of 2 x 2 pixels).
    half = clip.frames[app.assignment.db.params.N // 2][:124].reshape(62, 2, 80, 2, 3)
    error = np.abs(half.mean(axis=(1, 3)) - preview[:62]).mean()
    moved = np.abs(
        half.mean(axis=(1, 3)) - app.photo[:124].reshape(62, 2, 80, 2, 3).mean(axis=(1, 3))
    ).mean()
    assert error < 0.25 * moved, (error, moved)
    assert app.retrievals == 1  # all of it from the kept tables


def test_a_rendering_setting_renders_again_when_it_rests(app, monkeypatch):
    draw_scene(app)
    app.run(timeout=120)
    app.wait_resolve()
    app.settle = 0.05
    renders, resolves = app.renders, app.resolves
    shown = []
    real = module.render

    def watched(*args, **kwargs):  # what the player shows while the clip renders
        shown.append(app.player.info.value)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "render", watched)
    app.panel.set("shutter", 2.0)
    app.wait_live()
    assert app.renders == renders + 1
    assert app.resolves == resolves  # the assignment stays
    assert app.result.metadata["params"]["shutter"] == 2.0
    # A first frame with the new setting is on screen before the clip is made.
    assert len(shown) == 1
    assert "preview" in shown[0]
    assert "preview" not in app.player.info.value


def test_a_new_value_stops_the_render_of_the_old_one(app, monkeypatch):
    draw_scene(app)
    app.run(timeout=120)
    app.wait_resolve()
    started = threading.Event()
    real = module.render

    def slow_render(a, params, progress=None, **kwargs):
        if a.params.sigma == 1e3:  # the first value's render: slow, cancellable
            started.set()
            while True:
                progress(0.5, "working")
                threading.Event().wait(0.01)
        return real(a, params, progress=progress, **kwargs)

    monkeypatch.setattr(module, "render", slow_render)
    app.settle = 0.05
    drag_sigma(app, [1e3])
    assert started.wait(30), "the render on release did not start"
    assert app.running
    drag_sigma(app, [3e3])  # the slider moves again: that render is obsolete
    app.wait_live()
    assert not app.running
    assert app.result.metadata["params"]["sigma"] == 3e3
    assert "cancelled" not in app.status
    assert app.status.startswith("rendered in"), app.status


def test_cancel_during_a_render_on_release_is_the_users(app, monkeypatch):
    draw_scene(app)
    app.run(timeout=120)
    app.wait_resolve()
    started = threading.Event()

    def slow_render(a, params, progress=None, **kwargs):
        started.set()
        while True:
            progress(0.5, "working")
            threading.Event().wait(0.01)

    monkeypatch.setattr(module, "render", slow_render)
    app.settle = 0.05
    drag_sigma(app, [1e3])
    assert started.wait(30)
    app.cancel()
    app.wait(10)
    assert "cancelled" in app.status
    assert app.assignment.params.sigma == 1e3  # the re-solve stays; Render makes its clip


def test_the_rendering_switch_is_a_toggle_bound_to_its_field(db):
    # The library's AnimateParams.rendering ("flow" or "paper"); until it lands, a
    # subclass with the same field stands in for it.
    from dataclasses import dataclass

    from fluidnb import param

    if "rendering" in AnimateParams.specs():
        params = AnimateParams()
    else:

        @dataclass(frozen=True)
        class WithRendering(AnimateParams):
            rendering: str = param("flow", choices=("flow", "paper"), doc="how frames are made")

        params = WithRendering()
    app = VideoDBApp("stream", size=128, db=db, params=params)
    try:
        toggle = app._rendering
        assert isinstance(toggle, W.ToggleButtons)
        assert list(toggle.options) == ["flow", "paper"]
        assert toggle.value == params.rendering
        assert app.panel.controls["rendering"].layout.display == "none"  # the toggle shows it
        toggle.value = "paper"
        assert app.panel.params.rendering == "paper"
        app.panel.reset()
        assert toggle.value == "flow"
    finally:
        app.close()


def test_a_starter_database_built_on_first_use_fills_most_of_the_bar(db, monkeypatch, tmp_path):
    # Issue 22, point 4: the first Run builds the starter database (minutes at full
    # size); its progress must move the bar, not creep within its first 15 %.
    seen = []

    def building(kind, *, quick=None, progress=None):
        for f in (0.0, 0.5, 1.0):
            progress(f, f"building the {kind} database")
            seen.append(app.progress.value)
        return db

    monkeypatch.setattr(dbchoice, "starter_database", building)
    monkeypatch.setattr(dbchoice, "starter_path", lambda kind, quick=None: tmp_path / "none")
    app = VideoDBApp("stream", size=160, db="water", quick=True)
    try:
        app.panel.set("candidates", 20)
        app.paint_matte([[ROW, 10], [ROW, 150]], radius=22)
        assert app.run(timeout=120) is not None
        assert seen == pytest.approx([0.0, 0.4, 0.8])
        # Once built (cached), the database is quick to open: a thin slice of the bar.
        seen.clear()
        monkeypatch.setattr(dbchoice, "starter_path", lambda kind, quick=None: tmp_path)
        app.databases._opened.clear()
        app.run(timeout=120)
        assert seen == pytest.approx([0.0, 0.075, 0.15])
    finally:
        app.close()


def test_render_shows_the_first_frames_while_the_rest_are_made(app, monkeypatch):
    # The player gets the clip a few frames at a time (render's on_frames), keeps
    # playing, and the finished clip is the same frames with its metadata.
    from fluidnb.videodb.rendering import _render

    draw_scene(app)
    app.run(timeout=120)
    app.player.play(True)
    monkeypatch.setattr(_render, "CHUNK", 2)
    seen = []
    real = app.player.stream

    def stream(clip, ready):
        seen.append((clip, ready, app.player.playing))
        real(clip, ready)

    monkeypatch.setattr(app.player, "stream", stream)
    clip = app.render_clip(timeout=120)
    assert len(seen) == (len(clip) + 1) // 2
    assert [r for _, r, _ in seen] == [min(2 * k, len(clip)) for k in range(1, len(seen) + 1)]
    assert all(c is seen[0][0] for c, _, _ in seen)
    np.testing.assert_array_equal(seen[0][0].frames, clip.frames)
    assert app.player.clip is clip
    assert app.player.playing  # from the first frames to the end, it never stopped
    assert not app.player._gif.disabled


def test_cancel_while_frames_stream_in_puts_the_last_clip_back(app, monkeypatch):
    from fluidnb.videodb.rendering import _render

    draw_scene(app)
    first = app.run(timeout=120)
    monkeypatch.setattr(_render, "CHUNK", 1)
    real = app.player.stream

    def stream(clip, ready):
        real(clip, ready)
        if ready == 2:
            app.cancel()  # the user's Cancel, two frames in

    monkeypatch.setattr(app.player, "stream", stream)
    app.panel.set("detail", 0.5)  # a rendering setting: the next clip differs
    app.render_clip(timeout=120)
    assert "cancelled" in app.status
    assert app.player.clip is first
    assert app.result is first
    assert not app.player._gif.disabled


def test_a_resolve_rebuilds_the_new_fragments_while_the_values_rest(app, monkeypatch):
    # After the map and the preview, the re-solve's worker rebuilds the fragments the
    # new assignment brings; the render that follows reads none.
    from fluidnb.videodb.database import _frames

    draw_scene(app)
    app.run(timeout=120)
    app.settle = 1e9  # no render on rest here: Render is pressed below
    app.wait_resolve()
    app.panel.set("sigma", app.assignment.params.sigma * 10)
    app.wait_resolve()

    def no_reads(*args):
        raise AssertionError("a fragment was rebuilt at Render")

    monkeypatch.setattr(_frames, "_rebuild_clip", no_reads)
    clip = app.render_clip(timeout=120)
    assert app.status.startswith("rendered in"), app.status
    assert clip.metadata["params"]["sigma"] == app.assignment.params.sigma


def test_a_drag_prefetches_only_once_the_values_rest(app, monkeypatch):
    # A prefetch for every value of a drag would hold the re-solve's worker while the
    # next value waits for its map: it waits until the values rest (warm_after).
    import fluidnb.widgets._videodb as module

    draw_scene(app)
    app.run(timeout=120)
    app.settle = 1e9
    app.wait_resolve()
    fetched = []
    real = module.prefetch
    monkeypatch.setattr(
        module, "prefetch", lambda a, *x, **k: fetched.append(a) or real(a, *x, **k)
    )
    sigma = app.assignment.params.sigma
    app.warm_after = 0.3
    # A value every 50 ms: each is re-solved, none rests long enough to be prefetched.
    drag_sigma(app, [sigma * f for f in (2, 4, 8, 16)], pause=0.05)
    app.wait_resolve()
    assert app.resolves >= 2
    assert fetched == [app.assignment]  # only the last value's, once it rested
    assert app.assignment.params.sigma == sigma * 16


def test_the_map_follows_the_preview_frame_and_gives_way_to_a_newer_value(app, monkeypatch):
    # Issue 36: sent beside a preview's frame, the map's picture and marks, the energy
    # plot and the counters reached the page first and the frame waited for them. The
    # frame goes first; the rest follows it -- in a kernel only after map_pause, and not
    # while a newer value waits (its preview comes first), unless a long drag has left
    # the map map_every seconds behind.
    draw_scene(app)
    app.run(timeout=120)
    app.settle = 1e9
    app.wait_resolve()
    events = []
    send = app.player.view.send
    app.player.view.send = lambda content, buffers=None: (
        events.append(("frame", content["clip"])) or send(content, buffers)
    )
    set_assignment = app.map.set_assignment
    monkeypatch.setattr(
        app.map, "set_assignment", lambda a: events.append(("map", a)) or set_assignment(a)
    )
    app.energy.observe(lambda _: events.append(("energy",)), "value")
    resolves = app.resolves
    sigma = app.assignment.params.sigma
    app.panel.set("sigma", sigma * 10)
    app.wait_resolve()
    assert app.resolves == resolves + 1
    a = app.assignment
    assert [e[0] for e in events] == ["frame", "energy", "map"]
    assert app.player.view.tell_drawn  # (the page says when the frame is drawn)
    assert events[-1] == ("map", a)
    assert f"re-solves <b class='fluidnb-vdb-resolves'>{resolves + 1}</b>" in app.stats.value
    # In a kernel, with a newer value waiting: the map gives way to its preview.
    monkeypatch.setattr(type(app), "in_kernel", property(lambda self: True))
    waiting = [True]
    monkeypatch.setattr(app, "preview_pending", lambda: waiting[0])
    app.map_pause, app.map_every = 0.05, 1e9
    del events[:]
    app.assignment = b = a.resolve(sigma=sigma * 100)
    app._follow_map()
    assert events == []
    app.map_every = 0.0  # a drag that never pauses: the map follows at least this often,
    started = time.monotonic()
    app._follow_map()
    assert events[-1] == ("map", b)
    # ... still after its frame is drawn (here: no page, so after map_pause).
    assert time.monotonic() - started >= app.map_pause
    app._follow_map()  # (shown already: not again)
    assert [e for e in events if e[0] == "map"] == [("map", b)]
    # No newer value: it follows once the page has drawn the frame (the page says so)...
    waiting[0] = False
    app.map_pause = 60.0
    app.assignment = c = a.resolve(sigma=sigma * 1000)
    player = app.preview_player
    player._message(None, {"type": "drawn", "clip": player.view.clip_id}, [])
    started = time.monotonic()
    app._follow_map()
    assert events[-1] == ("map", c)
    assert time.monotonic() - started < app.map_pause  # (it did not wait for the page)
    # ... or after map_pause seconds without its word (no page open, say).
    app.map_pause = 0.05
    app.assignment = d = a.resolve(sigma=sigma * 3000)
    shown = app._preview_clip(d, app.panel.params, "")
    player.show_timed(shown, {"changed": 1.0, "started": 2.0, "made": 3.0})
    started = time.monotonic()
    app._follow_map()
    assert events[-1] == ("map", d)
    assert time.monotonic() - started >= app.map_pause


def test_a_held_slider_previews_the_float32_solve_and_its_release_solves_in_float64(
    app, monkeypatch
):
    # Issue 36: the full re-solve was two thirds of a preview's CPU. While a slider is
    # held the full solve runs on float32 smoothness (what these values give, not a
    # warm start that stays near where the drag began); the release (and Render)
    # solve in float64, so the map at rest and the clip are the reference solve's.
    from fluidnb.videodb import Assignment

    draw_scene(app)
    app.run(timeout=120)
    app.settle = 1e9
    app.wait_resolve()
    calls = []
    real = Assignment.resolve

    def resolve(self, **values):
        calls.append(values.get("dtype"))
        return real(self, **values)

    monkeypatch.setattr(Assignment, "resolve", resolve)
    sigma = app.assignment.params.sigma
    app._live.held = True  # the page says: a slider is held
    app.panel.set("sigma", sigma * 10)
    app.wait_resolve()
    assert calls == [np.float32]
    assert "in float32" in app.status
    rough = app.assignment
    assert app.map.assignment is rough  # the map follows the preview
    # The float32 solve is the float64 one up to near-ties (tables within 2 ulp of
    # float32): the same energy, most labels the same (1 of 24 differs here).
    reference = real(app._base, sigma=sigma * 10)
    assert rough.solution.energy == pytest.approx(reference.solution.energy, rel=1e-5)
    assert (rough.labels == reference.labels).mean() >= 0.9
    app._live.held = False  # let go: the same values, solved in float64
    app.wait_resolve()
    assert calls[-1] is None
    assert app.assignment is not rough
    assert app.assignment.params.sigma == sigma * 10
    assert app.map.assignment is app.assignment
    assert "from the kept tables" in app.status
    # Without a held slider (the keyboard, code): the float64 solve at once.
    app.panel.set("sigma", sigma * 100)
    app.wait_resolve()
    assert calls[-1] is None
    # Render with a held slider's solve never let go of (a lost release): float64 first.
    app._live.held = True
    app.panel.set("sigma", sigma * 1000)
    app.wait_resolve()
    assert calls[-1] is np.float32
    clip = app.render_clip(timeout=120)
    assert calls[-1] is None
    assert app.assignment is not app._rough
    assert clip.metadata["params"]["sigma"] == pytest.approx(sigma * 1000)
    assert clip.metadata["energy"] == pytest.approx(app.assignment.solution.energy)
