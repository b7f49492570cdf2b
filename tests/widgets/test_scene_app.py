"""The scene app driven from Python: layers, painting, run, per-layer cache, scene files."""

import numpy as np
import pytest

from fluidnb.fire import FireParams
from fluidnb.flicker import FlickerParams
from fluidnb.frost import FrostParams
from fluidnb.scene import load_scene
from fluidnb.widgets import SceneApp
from tests.support.frontend import mouse_drag
from tests.widgets.test_slider_sweep import sweep

# Small and quick, as in tests/scene: every layer in a few seconds on 2 cores.
FLICKER = FlickerParams(T=12, fps=8.0)
FROST = FrostParams(spacing=3.0, gamma=0.05, target=40, max_frames=60)
FIRE = FireParams(output_size=48, interval=4)


@pytest.fixture
def app():
    a = SceneApp(quick=True)  # the lake at 96 px: 54 x 96
    a.min_interval = 0.0
    yield a
    a.close()


def band(shape, r0, r1, c0, c1):
    h, w = shape
    m = np.zeros((h, w), bool)
    m[int(r0 * h) : int(r1 * h), int(c0 * w) : int(c1 * w)] = True
    return m


def two_layers(app):
    """A flicker band painted with the mouse on the water, frost set in the top left."""
    app.add_layer("flicker", params=FLICKER)
    c = app.canvas
    h, w = app.scene.shape
    mouse_drag(c, [c.to_canvas(0.75 * h, 2), c.to_canvas(0.75 * h, w - 3)])
    app.add_layer("frost", band(app.scene.shape, 0.0, 0.4, 0.0, 0.3), params=FROST)
    return app


def test_paint_goes_to_the_selected_layer_and_run_composites_them(app, tmp_path):
    two_layers(app)
    state = app.state()
    assert [x["name"] for x in state["layers"]] == ["flicker", "frost"]
    assert state["selected"] == "frost"
    flicker_region = app._entry("flicker").region > 0.5
    frost_region = app._entry("frost").region > 0.5
    assert flicker_region.sum() > 200  # the mouse painted a band...
    assert not flicker_region[: int(0.5 * app.scene.shape[0])].any()  # ...where it was dragged
    # Selecting a layer shows its own region on the canvas, and its own panel.
    assert np.array_equal(app.canvas.get_mask("region"), frost_region)
    assert type(app.panel.params) is FrostParams
    app.select_layer("flicker")
    assert np.array_equal(app.canvas.get_mask("region"), flicker_region)
    assert app.panel.params == FLICKER

    clip = app.run(timeout=300)
    assert clip is app.player.clip
    assert [x["name"] for x in clip.metadata["layers"]] == ["flicker", "frost"]
    photo = app.scene.photo
    outside = ~(flicker_region | frost_region)
    for frame in clip.frames:
        assert np.array_equal(frame[outside], photo[outside])
    moved = np.abs(clip.frames - photo).max(axis=-1)
    assert moved[:, flicker_region].max() > 0.02  # the water flickers
    assert moved[-1, frost_region].mean() > moved[0, frost_region].mean()  # the frost grows
    assert "rendered: flicker, frost" in app.status
    # The shell's export writes the composite (the status line says where).
    app.player.export_dir = tmp_path
    gif = app.player.export("gif")
    assert gif.parent == tmp_path
    assert gif.name.startswith("fluidnb-scene-")
    assert gif.stat().st_size > 1000
    assert "saved" in app.status


def test_only_the_changed_layer_renders_again(app):
    two_layers(app)
    first = app.run(timeout=300)
    assert app.scene.renders == 2
    app.select_layer("flicker")
    app.panel.set("kappa", 2.0 * FLICKER.kappa)  # a slider of the flicker layer only
    assert app._entry("flicker").params.kappa == 2.0 * FLICKER.kappa
    assert app._entry("frost").params == FROST
    second = app.run(timeout=300)
    assert app.scene.renders == 3
    seconds = {x["name"]: x["seconds"] for x in second.metadata["layers"]}
    assert seconds["frost"] == "cached"
    assert seconds["flicker"] != "cached"
    assert "from the cache: 1" in app.status
    frost = app._entry("frost").region > 0.5
    assert np.array_equal(first.frames[:, frost], second.frames[:, frost])
    # Hiding a layer renders nothing again: the other one is in the cache.
    app.toggle_layer("flicker")
    third = app.run(timeout=300)
    assert app.scene.renders == 3
    assert [x["name"] for x in third.metadata["layers"]] == ["frost"]
    flicker = app._entry("flicker").region > 0.5
    only = flicker & ~frost
    assert np.array_equal(
        third.frames[:, only], np.broadcast_to(app.scene.photo[only], (len(third), only.sum(), 3))
    )


def test_the_preview_is_the_selected_layer_alone_and_follows_its_sliders(app):
    two_layers(app)
    app.select_layer("flicker")
    app.wait_preview(120)
    clip = app.player.clip
    assert clip is not None
    assert clip.metadata["preview"] is True
    assert max(clip.shape) <= 128
    assert [x["name"] for x in clip.metadata["layers"]] == ["flicker"]
    app.panel.set("T", 16)  # 12 -> 16 frames
    app.wait_preview(120)
    again = app.player.clip
    assert again is not clip
    assert again.metadata["layers"][0]["frames"] == 16


def test_reorder_hide_remove(app):
    two_layers(app)
    app.add_layer("fire", band(app.scene.shape, 0.5, 0.7, 0.7, 0.8), params=FIRE)
    names = lambda: [x["name"] for x in app.state()["layers"]]  # noqa: E731
    assert names() == ["flicker", "frost", "fire"]
    # The list shows the top layer first.
    assert [v for _, v in app._list.options] == ["fire", "frost", "flicker"]
    app.move_layer("fire", -1)
    assert names() == ["flicker", "fire", "frost"]
    app.move_layer("flicker", -1)  # already at the bottom: stays
    assert names() == ["flicker", "fire", "frost"]
    app._list.value = "frost"  # a pick in the list selects
    assert app.selected == "frost"
    app._up.click()  # already on top
    app._down.click()
    assert names() == ["flicker", "frost", "fire"]
    app._hide.click()
    assert app.state()["layers"][1]["visible"] is False
    assert "hidden" in dict((v, k) for k, v in app._list.options)["frost"]
    app._remove.click()
    assert names() == ["flicker", "fire"]
    assert app.selected == "flicker"
    assert app.add_layer("fire") == "fire 2"


def test_save_and_load_round_trip(app, tmp_path):
    two_layers(app)
    app._entry("flicker").region[0, 0] = 0.3  # a soft edge survives (as 8-bit grey)
    app.select_layer("frost")
    app.canvas.click([5.0, 5.0], layer="starts")
    path = app.save(tmp_path / "scene")
    assert (path / "scene.json").is_file()
    assert "saved the scene (2 layers)" in app.status
    other = SceneApp("stream", quick=True)
    try:
        other.load(path)
        assert [
            (x["name"], x["kind"], x["params"], x["starts"]) for x in other.state()["layers"]
        ] == [(x["name"], x["kind"], x["params"], x["starts"]) for x in app.state()["layers"]]
        for name in ("flicker", "frost"):
            np.testing.assert_allclose(
                other._entry(name).region, app._entry(name).region, atol=0.5 / 255
            )
        np.testing.assert_allclose(other.scene.photo, app.scene.photo, atol=0.5 / 255 + 1e-6)
        assert other.state()["selected"] == "frost"
        assert other.photo_input.menu.value == "upload"
        clip = other.run(timeout=300)
        assert [x["name"] for x in clip.metadata["layers"]] == ["flicker", "frost"]
    finally:
        other.close()
    assert len(load_scene(path).layers) == 2


def test_bad_input_is_refused_and_keeps_the_drawing(app, tmp_path):
    two_layers(app)
    before = app.state()
    regions = {e.name: e.region.copy() for e in app.entries}
    with pytest.raises(ValueError, match=r"kind must be one of .* got 'smoke'"):
        app.add_layer("smoke")
    with pytest.raises(ValueError, match=r"name 'frost' is taken"):
        app.add_layer("fire", name="frost")
    with pytest.raises(ValueError, match=r"params of a fire layer must be a FireParams"):
        app.add_layer("fire", params=FLICKER)
    with pytest.raises(ValueError, match=r"region must be .* of the photo's size \(54, 96\)"):
        app.set_region(np.ones((10, 10), bool))
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "scene.json").write_text('{"format": "fluidnb.scene", "version": 99}')
    with pytest.raises(ValueError, match="scene version 99"):
        app.load(tmp_path / "bad")
    # The Load button says it in the status line; nothing changed.
    app._folder.value = str(tmp_path / "nowhere")
    app._load.click()
    assert "has no scene.json" in app.status
    assert app.state()["layers"] == before["layers"]
    for e in app.entries:
        assert np.array_equal(e.region, regions[e.name])
    # A layer with no region: Run says which one; the others are kept.
    app.add_layer("fire", params=FIRE)
    assert app.run(timeout=60) is None
    assert "layer 'fire': region is empty" in app.status
    assert [x["painted"] for x in app.state()["layers"]][:2] == [
        x["painted"] for x in before["layers"]
    ]
    # Saving keeps the painted layers and says which one was left out.
    app.save(tmp_path / "part")
    assert "2 layers; not painted, left out: fire" in app.status
    assert [x.name for x in load_scene(tmp_path / "part").layers] == ["flicker", "frost"]


def test_a_drawing_made_before_any_layer_becomes_the_first_layers_region(app):
    app.canvas.paint([[40, 10], [40, 80]], radius=5, layer="region")
    painted = app.canvas.get_mask("region").copy()
    app.add_layer("flicker")
    assert np.array_equal(app._entry("flicker").region > 0.5, painted)
    app.add_layer("frost")  # a new layer starts empty; the first one keeps its region
    assert not app.canvas.get_mask("region").any()
    app.select_layer("flicker")
    assert np.array_equal(app.canvas.get_mask("region"), painted)


def test_a_new_photo_keeps_the_layers(app):
    two_layers(app)
    painted = app.state()["layers"][0]["painted"]
    app.set_photo("stream")
    assert app.state()["photo"] == "stream"
    assert app.canvas.image.shape[:2] == app.scene.shape
    after = app.state()["layers"][0]["painted"]
    scale = np.prod(app.scene.shape) / (54 * 96)
    assert after == pytest.approx(painted * scale, rel=0.2)
    # An upload too small to work on is said; the photo and the layers stay.
    app.photo_input._on_photo(np.zeros((4, 4, 3), np.float32))
    assert "photo must be at least 8 x 8 pixels" in app.status
    assert app.state()["photo"] == "stream"
    assert app.state()["layers"][0]["painted"] == after


def test_run_follows_the_selected_layers_panel(app):
    two_layers(app)
    app.select_layer("flicker")
    with pytest.raises(ValueError, match="f0 must be < T/2"):
        app.panel.set("f0", 7)  # T = 12: refused, the panel says so
    assert app._run_button.disabled
    assert app._entry("flicker").params == FLICKER  # the layer keeps its last valid values
    app.select_layer("frost")
    assert not app._run_button.disabled
    app.select_layer("flicker")
    assert app.panel.params == FLICKER


def test_a_frost_layer_on_the_scenes_defaults_shows_its_fitted_gamma_after_a_run(app):
    app.add_layer("frost", band(app.scene.shape, 0.0, 0.5, 0.0, 0.4))  # no params: defaults
    paper = app.panel.params.gamma
    clip = app.run(timeout=300)
    used = app.scene.cache[next(reversed(app.scene.cache))].clip.metadata["params"]["gamma"]
    assert used != paper  # the scene fitted gamma to the target
    assert app.panel.params.gamma == used
    assert app._entry("frost").params is None  # still the defaults: nothing re-renders
    app.add_layer("flicker", band(app.scene.shape, 0.7, 0.9, 0.0, 1.0), params=FLICKER)
    app.select_layer("frost")
    assert app.panel.params.gamma == used
    app.panel.set("beta", 0.5)  # a slider moved starts from the fitted gamma
    assert app._entry("frost").params.gamma == used
    assert app._entry("frost").params.beta == 0.5
    assert len(clip) > 1


@pytest.mark.parametrize("kind", ["water", "flicker", "fire", "frost"])
def test_every_slider_of_a_layers_panel_keeps_run_enabled(app, kind):
    # The fire layer's panel is over FireParams alone (not the fire app's): its own
    # sweep. The sliders' values as the browser sends them (tests/widgets/test_slider_sweep).
    app.add_layer(kind, band(app.scene.shape, 0.3, 0.9, 0.1, 0.9))
    assert sweep(app, run=False) >= 5 * 4
    assert app._entry(kind).params == app.panel.params  # the sweep's last: the start
    app.wait_preview(120)  # (not into the interpreter's exit)


# ---------------------------------------------------------------- a large photo (issue 39)
def test_a_large_photo_is_painted_at_full_size_previewed_small_and_exported_full(tmp_path):
    # The app works on a proxy (the photo shrunk to `size`) while the canvas keeps
    # every region at the photo's full size; Export renders full size, streamed. A
    # small "full" size keeps the test quick: 90 x 160, proxy 36 x 64.
    from fluidnb import Clip
    from fluidnb.data import sample
    from fluidnb.scene import Layer, Scene, render

    photo = sample("lake", size=160)
    app = SceneApp(photo, size=64, quick=True)
    app.min_interval = 0.0
    try:
        assert app.canvas.image.shape[:2] == app.full_shape == (90, 160)
        assert app.scene.shape == (36, 64)
        assert "preview at 64 x 36 of 160 x 90; Export renders full size" in app.status
        assert "Export renders full size" in app._sizes.value
        app.add_layer("flicker", params=FLICKER)
        c = app.canvas
        mouse_drag(c, [c.to_canvas(65, 4), c.to_canvas(65, 155)])  # full-size pixels
        region = app._entry("flicker").region
        assert region.shape == (90, 160)
        assert (region > 0.5).sum() > 1000
        clip = app.run(timeout=300)
        assert clip.frames.shape[1:3] == (36, 64)  # Run renders the proxy
        assert "preview at 64 x 36 of 160 x 90" in app.status
        # The scene Export renders: each layer as painted, at full size.
        full = app.full_scene()
        assert full.shape == (90, 160)
        assert np.array_equal(full.layer("flicker").region, region)
        path = app.export(tmp_path / "scene.npz", timeout=300)
        assert path == app.exported
        assert path.name == "scene.npz"
        assert "exported" in app.status
        assert "160 x 90 (full size)" in app.status
        saved = Clip.load(path)
        built = render(Scene(photo, [Layer("flicker", region, FLICKER)], size=None))
        assert saved.frames.shape == built.frames.shape == (len(clip), 90, 160, 3)
        assert np.array_equal(saved.frames, built.frames)
        # Bad input: said, nothing exported.
        with pytest.raises(ValueError, match=r"path must end in \.mp4, \.gif or \.npz"):
            app.export(tmp_path / "scene.txt")
        app._export_path.value = str(tmp_path / "scene.txt")
        app._export.click()
        assert "path must end in .mp4" in app.status
        app.add_layer("fire", params=FIRE)  # not painted
        with pytest.raises(ValueError, match="layer 'fire': region is empty"):
            app.export(tmp_path / "again.npz")
        assert not (tmp_path / "again.npz").exists()
    finally:
        app.close()


def test_sizes_refuse_bad_input():
    with pytest.raises(ValueError, match=r"full_size must be >= size \(64\)"):
        SceneApp(quick=True, size=64, full_size=32)
    with pytest.raises(ValueError, match="size must be >= 8 pixels"):
        SceneApp(quick=True, size=4)
