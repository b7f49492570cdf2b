"""The turbulence app driven from Python, with the same calls the front end makes."""

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.turbulence import Flow, TurbulenceParams, sample_flows
from fluidnb.widgets import TurbulenceApp

FRAMES = 6  # quick sizes, few frames: each run takes a second or two


@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    # The sample flows are simulated once per test session, into a temporary cache.
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


@pytest.fixture
def app(tmp_path):
    a = TurbulenceApp(n_frames=FRAMES, export_dir=tmp_path)
    yield a
    a.close()


def test_the_panel_offers_the_specs_controls(app):
    assert {"B", "b", "alpha", "beta", "strategy", "m0", "interval"} <= set(app.panel.controls)
    assert app.panel.params == TurbulenceParams()
    assert app._size.value == "quick"
    assert app.status == ""
    # Before any run the table shows the paper's Table 1, our columns empty.
    assert "0.1145" not in app.table.value  # shown in ms
    assert "114.5" in app.table.value
    assert "9.2×" in app.table.value  # the paper's adaptive speedup
    assert app.rows == {}


def test_sizes_set_the_frames():
    a = TurbulenceApp()
    try:
        assert a._frames.value == 40
        a._size.value = "paper"
        assert a._frames.value == 200
        a._size.value = "quick"
        assert a._frames.value == 40
    finally:
        a.close()
    with pytest.raises(ValueError, match="size must be one of quick, paper"):
        TurbulenceApp(size="huge")


def test_run_shows_the_renders_and_adds_its_row(app):
    app.panel.set("strategy", "exhaustive")
    clip = app.run(timeout=300)
    assert isinstance(clip, Clip)
    assert clip.n_frames == FRAMES
    h, w = 96, 64
    gap = 2
    assert clip.shape == (h, 3 * w + 2 * gap)
    assert clip.metadata["method"] == "turbulence"
    assert clip.metadata["params"]["strategy"] == "exhaustive"
    assert app.player.clip is clip
    vort = app.vorticity.clip
    assert vort.frames.shape == (FRAMES, h, 3 * w + 2 * gap, 3)
    # The dye is carried: the frames move, and the synthesised panel is not blank.
    synth = clip.frames[:, :, -w:]
    assert synth.max() > 0.5
    assert np.abs(np.diff(synth, axis=0)).mean() > 1e-4
    # The two players follow each other.
    app.player.show(3)
    assert app.vorticity.frame == 3
    row = app.rows["exhaustive"]
    assert row["relative_error"] == 0.0
    assert row["absolute_error"] == 0.0
    assert row["seconds_per_frame"] > 0
    assert "exhaustive:" in app.status
    assert "relative error 0.0000" in app.status
    assert "data-strategy='exhaustive' class='fluidnb-latest'" in app.table.value
    assert "synthesised (exhaustive)" in app._headers[0].value


def test_a_second_strategy_adds_a_row_with_a_speedup(app):
    app.panel.set("strategy", "exhaustive")
    app.run(timeout=300)
    app.panel.set("strategy", "interval")
    app.panel.set("interval", 4)
    app.run(timeout=300)
    assert set(app.rows) == {"exhaustive", "interval 4"}
    assert app.rows["interval 4"]["relative_error"] >= 0
    rows = {r["strategy"]: r for r in app.table_rows()}
    assert rows["interval 4"]["speedup"] > 0
    assert rows["interval 4"]["paper_seconds"] == 0.0098
    assert app.synthesis.params.interval == 4
    assert "interval 4:" in app.status
    # Running the same search again updates its row rather than adding one.
    app.run(timeout=300)
    assert set(app.rows) == {"exhaustive", "interval 4"}


def test_changing_the_common_settings_restarts_the_table(app):
    app.run(timeout=300)
    assert set(app.rows) == {"adaptive"}
    app.panel.set("beta", 0.0)
    app.panel.set("strategy", "exact-fft")
    app.run(timeout=300)
    assert set(app.rows) == {"exact-fft"}
    assert "the table restarted" in app.table.value
    assert "beta=0" in app.table.value


def test_compare_fills_table_1(app):
    rows = app.compare_all(timeout=600)
    assert set(rows) == {
        "exhaustive",
        "interval 2",
        "interval 4",
        "interval 8",
        "adaptive",
        "exact-fft",
        "exact-bounds",
    }
    table = {r["strategy"]: r for r in app.table_rows()}
    assert table["exhaustive"]["speedup"] == 1.0
    for label in ("exact-fft", "exact-bounds"):
        assert table[label]["relative_error"] == 0.0
    assert table["interval 8"]["relative_error"] >= table["exhaustive"]["relative_error"]
    assert "compared 7 searches" in app.status
    assert "adaptive:" in app.status
    # The players show the panel's own strategy (adaptive).
    assert app.synthesis.params == app.panel.params
    assert app.player.clip.n_frames == FRAMES
    assert "<td>—</td>" not in app.table.value  # every row has our figures


def test_bad_settings_say_why_and_keep_the_sliders(app):
    app.panel.set("B", 12)  # 12 does not divide the 96 x 64 source grid
    assert "B must divide the source grid (96, 64), got B = 12" in app.status
    assert app.start() is False
    assert app.panel.controls["B"].value == 12
    app.panel.set("B", 16)
    assert app.status == ""
    app.panel.set("b", 2)  # b must exceed B dX/dx = 2
    assert "b must be > B dX/dx" in app.status
    assert app.start() is False
    assert app.compare_all() == {}
    assert app.panel.controls["b"].value == 2
    app.panel.set("b", 4)
    # A field's own rule (m0 a power of 2) is the panel's message, Run refused too.
    with pytest.raises(ValueError, match="m0 must be a power of 2"):
        app.panel.set("m0", 3)
    assert app.start() is False
    assert "m0 must be a power of 2" in app.status
    assert app.panel.controls["m0"].value == 3


def test_a_problem_found_in_the_run_is_shown(tmp_path):
    target, source = sample_flows(FRAMES, scale=2)
    smokeless = Flow(target.velocity, np.zeros_like(target.density), target.dx)
    app = TurbulenceApp(smokeless, source, export_dir=tmp_path)
    try:
        app.panel.set("D_th", 0.2)
        assert app.check() == ""  # the grids are fine: found only when the flows are read
        app.wait_preview()  # the live preview reads them, and says so at once
        app.run(timeout=300)
        assert "the target mask (density > D_th = 0.2) is empty" in app.status
        assert app.panel.params.D_th == 0.2
        assert app.result is None
        assert not app._run_button.disabled
    finally:
        app.close()


def test_the_check_uses_the_chosen_sizes_grid(app):
    app.panel.set("B", 12)
    assert "(96, 64)" in app.status
    app._size.value = "paper"
    assert "B must divide the source grid (192, 128), got B = 12" in app.status


def test_cancel_stops_the_run_and_keeps_the_settings(app):
    app.panel.set("strategy", "exhaustive")
    app._frames.value = 60  # long enough that Cancel lands mid-run
    assert app.start()
    app.cancel()
    app.wait(timeout=120)
    assert "cancelled" in app.status
    assert app.result is None
    assert app.rows == {}
    assert app.panel.params.strategy == "exhaustive"
    assert not app._compare_button.disabled
    assert app.run(timeout=300) is not None  # and it runs again afterwards


def test_your_own_flows(tmp_path):
    target, source = sample_flows(FRAMES, scale=2)
    app = TurbulenceApp(target, source, n_frames=4, export_dir=tmp_path)
    try:
        with pytest.raises(ValueError, match="press Run first"):
            app.save_flow(tmp_path / "none.npz")
        assert app._size.value == "yours"
        assert app._frames.max == FRAMES
        clip = app.run(timeout=300)
        assert clip.n_frames == 4
        out = app.save_flow(tmp_path / "synth.npz")
        flow = Flow.load(out)
        assert flow.shape == source.shape
        assert flow.n_frames == 4
        assert app.player.export("gif").exists()
        assert app.vorticity.export("gif").name.startswith("fluidnb-turbulence")
    finally:
        app.close()
    with pytest.raises(ValueError, match="give both target and source"):
        TurbulenceApp(target)
    with pytest.raises(ValueError, match=r"source must be a fluidnb\.turbulence\.Flow"):
        TurbulenceApp(target, "source.npz")
