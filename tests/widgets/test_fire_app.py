"""The fire app driven from Python, with the same calls the front end makes."""

import datetime as dt
import io

import numpy as np
import pytest
from PIL import Image

from fluidnb import data, to_uint8
from fluidnb.fields import resize
from fluidnb.fire import FireParams
from fluidnb.widgets import FireApp
from fluidnb.widgets._fire import FireAppParams, comparison_clip


@pytest.fixture
def app():
    a = FireApp(quick=True, seed=1)
    yield a
    a.close()


def test_the_panel_offers_the_specs_controls():
    app = FireApp(quick=True)
    try:
        assert set(app.panel.controls) == {
            "kappa_b",
            "epsilon",
            "C_r",
            "source_radius",
            "source_T",
            "interval",
            "overlap",
            "weight",
            # beyond the spec's list: the two parameters issue 16 added to the synthesis
            "coherence",
            "cutoff",
            # and issue 35's: the clip's frame rate and the keyframes' size
            "fps",
            "output_size",
        }
        params = app.panel.params
        assert isinstance(params, FireAppParams)
        assert params.fire() == FireParams(output_size=128)  # quick: 128-px keyframes
        assert app.panel.controls["fps"].value == 24
    finally:
        app.close()
    app = FireApp()  # not quick: the library's defaults, 256 px at 24 fps
    try:
        assert app.panel.params.fire() == FireParams()
    finally:
        app.close()


def test_run_makes_fire_with_the_panels_parameters(app):
    app.panel.set("weight", 0.8)
    app.panel.set("interval", 6)
    app.panel.set("epsilon", 0.2)
    app.panel.set("coherence", 0.5)
    app.panel.set("cutoff", 0.3)
    clip = app.run(timeout=120)
    assert clip.n_frames == 46  # 16 simulation frames at 24 fps
    assert clip.shape == (128, 128)
    assert clip.fps == 24
    meta = clip.metadata
    assert meta["method"] == "fire"
    assert meta["params"]["weight"] == 0.8
    assert meta["params"]["interval"] == 6
    assert meta["params"]["coherence"] == 0.5
    assert meta["params"]["cutoff"] == 0.3
    assert app.fire_result.simulation.params.epsilon == 0.2
    assert app.player.clip is clip
    # Shown at its own size, never enlarged (before: 64 px shown at 384).
    assert app.player.display_width == 128
    assert app.player.view.display_width == 128
    # Side by side on the 64 x 64 grid, one frame per simulation frame:
    # temperature | keyframe | fire (every third clip frame, at 24 fps).
    assert app.compare.clip.shape == (64, 192)
    assert app.compare.clip.n_frames == 16
    assert app.compare.display_width == 192
    fires = app.compare.clip.frames[..., 128:, :]
    np.testing.assert_allclose(fires, [resize(f, (64, 64)) for f in clip.frames[::3]], atol=1e-5)
    assert "done" in app.status


def test_paper_defaults_sets_the_papers_set_up_one_click_away(app):
    app.panel.set("weight", 0.9)
    app._paper.click()
    params = app.panel.params
    assert (params.fps, params.output_size, params.weight) == (8, 0, FireParams().weight)
    assert "paper" in app.status
    clip = app.run(timeout=120)
    # The paper's set-up: keyframes on the 64 x 64 grid, one frame per simulation frame.
    assert (clip.n_frames, clip.shape, clip.fps) == (16, (64, 64), 8)
    assert app.player.display_width == 64


def test_same_seed_same_clip(app):
    a = app.run(timeout=120)
    b = app.run(timeout=120)
    np.testing.assert_array_equal(a.frames, b.frames)


def test_a_painted_matte_replaces_the_photos_own(app):
    assert app.matte() is app.photo_matte
    h, w = app.photo.shape[:2]
    app.canvas.paint([[0.3 * h, 0.5 * w], [0.9 * h, 0.5 * w]], radius=0.15 * w, layer="matte")
    matte = app.matte()
    assert matte.dtype == np.float32
    assert set(np.unique(matte)) == {0.0, 1.0}
    assert app.run(timeout=120).n_frames == 46


def upload(name, content):
    """One file as the FileUpload widget holds it after the browser sends it."""
    return {
        "name": name,
        "type": "image/png",
        "size": len(content),
        "content": memoryview(content),
        "last_modified": dt.datetime(2026, 1, 1, tzinfo=dt.timezone.utc),
    }


def test_choosing_a_sample_and_uploading_a_photo(app):
    app._sample.value = "flame"
    assert app.photo_matte is not None
    assert app.canvas.image.shape == app.photo.shape
    photo = data.sample("fire", size=50)
    buf = io.BytesIO()
    Image.fromarray(to_uint8(photo)).save(buf, format="png")
    app._upload.value = (upload("f.png", buf.getvalue()),)
    assert app.photo.shape == photo.shape
    assert app.photo_matte is None  # an RGB upload: its luminance is the alpha
    app._upload.value = (upload("x.png", b"not an image"),)
    assert "could not read" in app.status
    assert app.photo.shape == photo.shape  # the previous photo is kept


def test_an_upload_shows_the_upload_and_the_menu_says_so(app):
    # Issue 22, point 1: changing a menu's options must not pick its first entry.
    app._sample.value = "flame"
    flame = app.photo.copy()
    picked = []
    app._sample.on_pick(picked.append)
    # What the status line said (the live preview of the upload may say more after it).
    said = []
    app.observe(lambda change: said.append(change["new"]), "status")
    green = np.zeros((40, 60, 3), np.float32)
    green[..., 1] = 1.0
    buf = io.BytesIO()
    Image.fromarray(to_uint8(green)).save(buf, format="png")
    app._upload.value = (upload("green.png", buf.getvalue()),)
    np.testing.assert_array_equal(app.photo, green)
    np.testing.assert_array_equal(app.canvas.image, green)
    assert app.photo_name == "upload"
    assert app._sample.value == "upload"
    assert picked == ["upload"]  # never "fire" (the first option) on the way
    assert any("upload" in text for text in said)
    # The sample is one pick away again, and "upload" leaves the menu with the upload.
    app._sample.value = "flame"
    np.testing.assert_array_equal(app.photo, flame)
    assert app._sample.options == ("fire", "flame")
    app.set_photo(green)
    app.set_photo(green[:, :50])  # a second upload keeps the menu on "upload"
    assert app.photo.shape == (40, 50, 3)
    assert app._sample.value == "upload"


def test_a_sample_name_given_at_start_is_the_menus_choice():
    app = FireApp("flame", quick=True)
    try:
        assert app.photo_name == app._sample.value == "flame"
    finally:
        app.close()
    app = FireApp(np.zeros((32, 32, 3)), quick=True)
    try:
        assert app.photo_name == app._sample.value == "upload"
    finally:
        app.close()


def test_invalid_combination_disables_run_and_says_why(app):
    app.panel.set("interval", 4)
    with pytest.raises(ValueError, match="overlap must be < interval"):
        app.panel.set("overlap", 4)
    assert not app.panel.valid
    assert "overlap" in app.panel.message
    assert app.start() is False


def test_cancel_stops_the_run_and_keeps_the_drawing(app):
    app.canvas.paint([[20, 20]], radius=5, layer="matte")
    before = app.canvas.get_mask("matte").copy()
    app._frames.value = 200  # long enough that Cancel lands mid-run
    assert app.start()
    app.cancel()
    app.wait(timeout=60)
    assert "cancelled" in app.status
    assert app.result is None
    np.testing.assert_array_equal(app.canvas.get_mask("matte"), before)


def test_comparison_clip_shows_the_keyframe_in_effect(app):
    app.panel.set("interval", 4)
    app.run(timeout=120)
    res = app.fire_result
    comp = comparison_clip(res)
    # Keyframe 1 starts at simulation frame 2 (clip frame 6): frames 0-1 show keyframe 0.
    assert res.starts[1] == 6
    key = [resize(k, (64, 64)) for k in res.keyframes[:2]]
    np.testing.assert_allclose(comp.frames[1, :, 64:128], key[0], atol=1e-5)
    np.testing.assert_allclose(comp.frames[2, :, 64:128], key[1], atol=1e-5)


def test_an_uploaded_rgba_cutout_is_matted_by_its_alpha(app):
    # A cut-out whose clear pixels hold random colour: before, the fire was a solid
    # rectangle of that colour.
    rgb, alpha = data.sample("fire", size=64, return_alpha=True)
    straight = np.clip(rgb / np.maximum(alpha[..., None], 1e-6), 0, 1)
    junk = np.random.default_rng(0).random(rgb.shape)
    straight = np.where(alpha[..., None] > 0, straight, junk)
    buf = io.BytesIO()
    Image.fromarray(to_uint8(np.dstack([straight, alpha])), mode="RGBA").save(buf, format="png")
    app._upload.value = (upload("cut.png", buf.getvalue()),)
    np.testing.assert_allclose(app.photo_matte, alpha, atol=1 / 255)
    # the canvas shows the cut-out over black, not its junk colour
    assert app.canvas.image[alpha == 0].max() == 0
    app._paper.click()  # the paper's set-up: the clip on the simulation's grid
    clip = app.run(timeout=120)
    cold = app.fire_result.target == 0
    assert cold.mean() > 0.3
    assert (clip.frames @ np.array([0.2126, 0.7152, 0.0722]))[cold].mean() < 0.02


def test_the_live_preview_is_a_photo_shown_smoothed(app):
    # Issue 36: the 48 x 48 keyframe, enlarged 5x, showed as a mosaic of square cells.
    app.panel.set("weight", 0.4)
    app.wait_preview(60)
    clip = app.preview_player.clip
    assert clip.shape == (48, 48)
    assert clip.metadata["smooth"] is True
    assert app.preview_player.view.smooth  # the page draws it smoothed
