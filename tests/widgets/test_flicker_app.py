"""The flicker app driven from Python, with the same calls the front end makes."""

import numpy as np
import pytest
from scipy import ndimage

from fluidnb import Clip, data
from fluidnb.flicker import FlickerParams
from fluidnb.widgets import FlickerApp


@pytest.fixture
def app():
    photo = data.sample("ripples", size=96)
    a = FlickerApp(photo, quick=True, seed=1)
    a.min_interval = 0.0
    a.wait_preview()
    yield a
    a.close()


def painted(app):
    h, w = app.image.shape[:2]
    app.canvas.paint([[0.5 * h, 0.25 * w], [0.5 * h, 0.6 * w]], radius=0.12 * h, layer="region")
    app.wait_preview()
    return app.canvas.get_mask("region")


def preview_outside(app, mask):
    """Preview pixels clear of the painted region (by one preview pixel of margin)."""
    clip = app.player.clip
    small = np.zeros(clip.shape, bool)
    scale = max(app.image.shape[:2]) / max(clip.shape)
    rows, cols = np.nonzero(mask)
    small[(rows / scale).astype(int), (cols / scale).astype(int)] = True
    return ~ndimage.binary_dilation(small, iterations=2)


def test_empty_canvas_animates_the_whole_image(app):
    clip = app.player.clip
    assert isinstance(clip, Clip)
    assert clip.n_frames == 16
    assert max(clip.shape) == app.preview_size
    moving = np.abs(clip.frames - clip.frames[0]).max(axis=(0, -1)) > 0
    assert moving.mean() > 0.5
    assert app.region() is None


def test_painting_a_region_limits_the_preview_to_it(app):
    mask = painted(app)
    clip = app.player.clip
    frames = clip.frames
    outside = preview_outside(app, mask)
    assert outside.any()
    for frame in frames[1:]:
        assert np.array_equal(frame[outside], frames[0][outside])
    assert np.abs(frames - frames[0]).max(axis=(0, -1))[~outside].max() > 0.02


def test_moving_a_slider_changes_the_preview(app):
    painted(app)
    before = app.player.clip.frames.copy()
    app.panel.set("mapping", "plane")
    app.wait_preview()
    plane = app.player.clip
    assert plane.metadata["params"]["mapping"] == "plane"
    assert not np.array_equal(plane.frames, before)
    app.panel.set("f0", 2)
    app.wait_preview()
    assert app.player.clip.metadata["params"]["f0"] == 2
    assert not np.array_equal(app.player.clip.frames, plane.frames)
    # The noise seed is a control too.
    app.panel.set("mapping", "convex")
    app.wait_preview()
    first = app.player.clip.frames.copy()
    app._new_noise.click()
    app.wait_preview()
    assert app.seed == 2
    assert not np.array_equal(app.player.clip.frames, first)


def test_run_renders_the_full_size_clip_and_keeps_outside_pixels(app):
    mask = painted(app)
    app.panel.set("beta", 0.0)
    # Let the preview this change asked for land first: a preview finishing after the
    # run would take the player over again (the app shell shows the latest clip).
    app.wait_preview()
    clip = app.run(timeout=60)
    assert app.player.clip is clip
    assert clip.shape == app.image.shape[:2]
    assert clip.n_frames == app.panel.params.T
    assert clip.metadata["seed"] == 1
    for frame in clip.frames:
        assert np.array_equal(frame[~mask], app.image[~mask])
    assert np.abs(clip.frames - app.image).max(axis=(0, -1))[mask].max() > 0.02
    # Without noise frame 0 is the photo.
    np.testing.assert_allclose(clip.frames[0], app.image, atol=1e-5)
    assert "done" in app.status


def test_invalid_combination_is_explained_and_run_refused(app):
    app.panel.set("f0", 7)
    app.wait_preview()  # so its "preview (...)" line cannot overwrite the message below
    with pytest.raises(ValueError, match="f0 must be < T/2"):
        app.panel.set("T", 12)
    assert not app.panel.valid
    assert app._run_button.disabled
    assert not app.start()
    assert "f0 must be < T/2" in app.status
    app.panel.set("T", 64)
    assert app.panel.valid
    assert app.panel.params == FlickerParams(T=64, f0=7)


def test_analysis_figure_for_the_probe_pixel(app):
    painted(app)
    h, w = app.image.shape[:2]
    app.canvas.click([h // 2, w // 2], layer="probe")
    assert app.probe() == (h // 2, w // 2)
    png = app.show_analysis()
    assert png[:4] == b"\x89PNG"
    assert app.analysis.value == png


def test_a_flow_stroke_sets_the_velocity_and_its_reverse_reverses_the_motion(app):
    h, w = app.image.shape[:2]
    app.panel.set("beta", 0.0)
    app.panel.set("f0", 2)
    app.panel.set("mapping", "flow")
    app.wait_preview()
    assert "draw a stroke along the flow" in app.status  # nothing drawn yet
    # 8 px to the right in one loop of T = 16 frames: 0.5 px/frame.
    app.canvas.draw_stroke([[h / 2, w / 2 - 4], [h / 2, w / 2 + 4]], layer="flow")
    app.wait_preview()
    clip = app.player.clip
    np.testing.assert_allclose(clip.metadata["velocity"], [0.0, 0.5])
    app.canvas.draw_stroke([[h / 2, w / 2 + 4], [h / 2, w / 2 - 4]], layer="flow")
    app.wait_preview()
    assert app.player.clip.metadata["velocity"] == [0.0, -0.5]
    # The full run uses the same (last) stroke, and the loop closes.
    run = app.run(timeout=60)
    assert run.metadata["velocity"] == [0.0, -0.5]
    assert run.metadata["params"]["mapping"] == "flow"
    np.testing.assert_allclose(run.frames[0], app.image, atol=1e-5)
