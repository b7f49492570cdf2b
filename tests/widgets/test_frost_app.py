"""The frost app driven from Python, with the same calls the front end makes."""

import time

import numpy as np
import pytest

from fluidnb import data
from fluidnb.frost import FrostParams, grow
from fluidnb.widgets import FrostApp
from tests.support.frontend import mouse_drag

START_RC = (48.0, 45.0)


@pytest.fixture
def app():
    image = data.sample("leaf", size=128)  # 96 x 128
    a = FrostApp(image, params=FrostParams(beta=0.6, spacing=3.0), seed=1)
    a.min_interval = 0.0
    yield a
    a.close()


def paint_and_start(app):
    """Paint a band with the brush through the canvas's mouse handlers; click a start point."""
    c = app.canvas
    c.select("brush", "region")
    c.brush_radius = 22
    mouse_drag(c, [c.to_canvas(48, 25), c.to_canvas(48, 100)])
    c.select("points", "starts")
    mouse_drag(c, [c.to_canvas(*START_RC)])
    app.wait_preview()
    return c.get_mask("region")


def ice_area(clip, base, region):
    changed = np.abs(clip.frames - base).sum(axis=-1) > 0.05
    return changed[:, region].mean(axis=1)


def test_nothing_drawn_says_what_to_do(app):
    app.wait_preview()
    assert "region is empty" in app.status
    app.canvas.paint([[48, 60]], radius=20, layer="region")
    app.wait_preview()
    assert "no start point" in app.status
    assert "points tool" in app.status
    assert app.player.clip is None


def test_paint_start_preview_follows_rth_and_run_grows_frost_from_the_start(app):
    region = paint_and_start(app)
    assert region.sum() > 2000
    assert app.canvas.get_points("starts").shape == (1, 2)
    first = app.player.clip
    assert first is not None
    assert first.metadata["preview"] is True
    app.panel.set("rth", 0.8)
    app.wait_preview()
    assert app.player.clip is not first
    assert app.player.clip.metadata["params"]["rth"] == 0.8

    clip = app.run(timeout=120)
    assert "done" in app.status, app.status
    assert clip.shape == app.image.shape[:2]
    meta = clip.metadata
    assert meta["method"] == "frost"
    assert meta["params"]["rth"] == 0.8
    assert meta["seed"] == 1
    area = ice_area(clip, app.image, region)
    assert area[0] < 0.02
    assert area[-1] > 0.5
    assert np.all(np.diff(area) >= -0.02)  # it grows
    # The first visible frost is around the start point.
    k = next(i for i, a in enumerate(area) if a > 0.01)
    changed = np.abs(clip.frames[k] - app.image).sum(-1) > 0.05
    rows, cols = np.nonzero(changed & region)
    assert np.hypot(rows.mean() - START_RC[0], cols.mean() - START_RC[1]) < 10
    assert app.frost_result.end_frame == meta["end_frame"]


def test_optimise_button_fills_the_table_live_and_sets_beta(app):
    paint_and_start(app)
    app.panel.set("target", 150)
    seen = []
    app.table.observe(lambda change: seen.append(change["new"]), "value")
    assert app.optimise()
    assert not app.optimise()  # one computation at a time
    app.wait(120)
    result = app.optimised
    assert result is not None
    assert result.target == 150
    assert app.panel.params.beta == pytest.approx(result.beta)
    # The table grew one row at a time while the optimiser ran.
    rows_seen = [v.count("<tr>") - 1 for v in seen]
    assert rows_seen[-1] == len(result.steps)
    assert sorted(set(rows_seen)) == list(range(1, len(result.steps) + 1))
    assert "end frame" in app.table.value
    assert f"{result.steps[0].beta:.6f}" in app.table.value
    word = "converged" if result.converged else "not converged"
    assert app.status.startswith(word)
    assert not app._optimise_button.disabled or app.running


def test_optimise_with_steepest_and_cancel(app):
    paint_and_start(app)
    app._solver.value = "steepest"
    app._eta.value = 3e-6
    app.panel.set("target", 150)
    assert app.optimise()
    app.cancel()
    app.wait(120)
    assert "cancel" in app.status or app.optimised is not None
    # The drawing is untouched either way.
    assert app.canvas.get_points("starts").tolist() == [list(START_RC)]


def test_setters_preload_a_region_and_starts():
    image = data.sample("leaf", size=128)
    region = np.zeros(image.shape[:2], bool)
    region[20:76, 30:100] = True
    a = FrostApp(image, region=region, starts=[[48, 60]], params=FrostParams(beta=0.6, spacing=3))
    try:
        a.min_interval = 0.0
        a.wait_preview()
        assert a.player.clip is not None, a.status
        assert np.array_equal(a.canvas.get_mask("region"), region)
        with pytest.raises(ValueError, match="same height and width"):
            a.set_region(region[:10])
    finally:
        a.close()


def test_the_app_says_up_front_how_long_the_papers_gamma_takes_and_fits_gamma_to_the_target(app):
    paint_and_start(app)
    app.panel.set("gamma", 0.005)  # the paper's value: far too slow for a painted region
    app.panel.set("target", 120)
    app.wait_preview()
    est = app.estimate
    assert est is not None
    assert est.likely > 3 * 120  # far beyond the target
    lattice, cells = app._lattice(3.0)
    end = grow(lattice, cells, app.panel.params.replace(max_frames=5000), seed=app.seed).end_frame
    assert est.low <= end <= est.high  # (436 here, the likely frame 450)
    # The estimate at once (with how sure it is), the run's own end frame once the
    # values rest (the automaton run without drawing, after the preview).
    app._show_length(app.panel.params)
    text = app.length.value
    assert f"{est.likely:,.0f}" in text
    assert f"likely {est.low:,.0f}–{est.high:,.0f}: 90 % of measured runs" in text
    assert f"at most {est.frames:,.0f}" in text
    assert "ends near the target 120" in text
    app.warm(app.panel.params)
    assert f"this run ends at frame <b>{end:,}</b>" in app.length.value
    # A later target: a smaller gamma (issue 36: it suggested a larger one).
    assert est.likely_gamma_for(2 * round(est.likely)) < app.panel.params.gamma
    assert "Use γ for 120 frames" in app._gamma_button.description
    app._gamma_button.click()
    app.wait(120)
    fit = app.gamma_fit
    assert fit is not None, app.status
    assert fit.gamma > 0.02
    assert app.panel.params.gamma == pytest.approx(fit.gamma)
    assert "ends at frame" in app.status
    clip = app.run(timeout=120)
    assert abs(clip.metadata["end_frame"] - 120) <= 0.1 * 120


def test_the_clip_plays_at_the_panels_fps_and_the_status_tells_its_length(app):
    # Issue 22, point 6: the fps slider said 24, the clip played at 8, and the
    # status gave neither the clip's length nor its fps.
    paint_and_start(app)
    app.panel.set("fps", 12.0)
    clip = app.run(timeout=120)
    end = clip.metadata["end_frame"]
    assert end is not None
    assert clip.fps == app.panel.params.fps == 12.0
    assert clip.n_frames == end + 1  # every frame of the growth, in real time
    assert clip.metadata["every"] == 1
    assert f"frost ended at frame {end}" in app.status
    assert f"{clip.n_frames} frames at 12 fps = {clip.n_frames / 12:.1f} s" in app.status
    # The estimate above the run speaks the same units: frames at the panel's fps.
    assert "at 12 fps" in app.length.value
    # After the run the Length line says the frame it ended at, with no slider moved
    # (it kept the estimate and "the exact frame follows when the sliders rest").
    assert f"this run ends at frame <b>{end:,}</b>" in app.length.value
    # Once the values rest, the Length line says the run's own end frame (the
    # automaton without drawing, the same seed): the frame the run ended at.
    deadline = time.monotonic() + 30
    while f"this run ends at frame <b>{end:,}</b>" not in app.length.value:
        assert time.monotonic() < deadline, app.length.value
        app.wait_preview()  # a newer preview stops a dry run: once none waits, it ends
        app.warm(app.panel.params)  # (what the preview's worker does once they rest)


def test_a_long_run_is_drawn_smaller_then_thinned_and_the_status_says_so():
    from fluidnb.widgets._frost import _RUN_BYTES, _RUN_MIN_SIZE, _run_size

    assert _run_size(100, (360, 480), 480) == (480, 1)  # 100 x 2 MB fits
    side, every = _run_size(400, (360, 480), 480)
    assert every == 1
    assert _RUN_MIN_SIZE <= side < 480
    assert 400 * 12 * side * side * 0.75 <= _RUN_BYTES
    side, every = _run_size(5000, (360, 480), 480)
    assert side == _RUN_MIN_SIZE
    assert every > 1
    assert -(-5000 // every) * 12 * side * side * 0.75 <= _RUN_BYTES
