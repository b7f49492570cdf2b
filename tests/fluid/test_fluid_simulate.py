"""simulate(), Simulation save/load, presets and the colour map."""

import numpy as np
import pytest

from fluidnb import Cancelled, CancelToken, Clip
from fluidnb.fluid import (
    FluidParams,
    FluidState,
    Simulation,
    divergence,
    flame_preset,
    project,
    simulate,
    smoke_preset,
    step,
    temperature_to_rgb,
)


def test_simulate_returns_every_frame_and_matches_step():
    params = FluidParams()
    sim = simulate(params, 5, shape=(24, 20), seed=3)
    assert sim.velocity.shape == (5, 24, 20, 2)
    assert sim.temperature.shape == sim.density.shape == (5, 24, 20)
    assert sim.shape == (24, 20)
    assert len(sim) == 5
    assert sim.seed == 3
    g = np.random.default_rng(3)
    s = FluidState.zeros((24, 20), params)
    for k in range(5):
        s = step(s, params, rng=g)
        np.testing.assert_array_equal(sim.temperature[k], s.temperature.astype(np.float32))
    assert sim.timings["steps_per_second"] > 0


def test_same_seed_same_frames_other_seed_other_frames():
    params = FluidParams(source_flicker=0.8)
    a = simulate(params, 6, shape=(20, 20), seed=1)
    b = simulate(params, 6, shape=(20, 20), seed=1)
    c = simulate(params, 6, shape=(20, 20), seed=2)
    for name in ("velocity", "temperature", "density"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.temperature, c.temperature)


@pytest.mark.parametrize("seed", [None, "generator"])
def test_the_recorded_seed_remakes_the_run(seed):
    params = FluidParams(source_flicker=0.8)
    if seed == "generator":
        seed = np.random.default_rng(4)
    a = simulate(params, 4, shape=(16, 16), seed=seed)
    assert isinstance(a.seed, int)
    assert a.to_clip().metadata["seed"] == a.seed
    b = simulate(params, 4, shape=(16, 16), seed=a.seed)
    np.testing.assert_array_equal(a.temperature, b.temperature)


def test_substeps_split_the_frame():
    params = FluidParams(source_flicker=0)
    sim = simulate(params, 3, shape=(16, 16), substeps=4)
    sub = params.replace(dt=0.25)
    s = FluidState.zeros((16, 16), params)
    for _ in range(12):
        s = step(s, sub)
    np.testing.assert_array_equal(sim.temperature[-1], s.temperature.astype(np.float32))


def test_progress_every_frame_and_cancellation():
    seen = []
    simulate(FluidParams(), 4, shape=(12, 12), seed=0, progress=lambda f, m: seen.append(f))
    assert seen == [0.0, 0.25, 0.5, 0.75, 1.0]
    token = CancelToken()

    def cancel_at_half(f, m):
        if f >= 0.5:
            token.cancel()
        token(f, m)

    with pytest.raises(Cancelled):
        simulate(FluidParams(), 10, shape=(12, 12), seed=0, progress=cancel_at_half)


def test_save_and_load_round_trip(tmp_path):
    sim = simulate(FluidParams(epsilon=0.1, boundary="closed"), 3, shape=(10, 14), seed=5)
    path = sim.save(tmp_path / "run.npz")
    back = Simulation.load(path)
    for name in ("velocity", "temperature", "density"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sim, name))
    assert back.params == sim.params
    assert back.seed == 5
    assert back.substeps == 1
    with np.load(path, allow_pickle=False) as z:  # plain arrays, no pickle
        assert set(z.files) == {"velocity", "temperature", "density", "metadata"}
    with pytest.raises(ValueError, match="npz"):
        sim.save(tmp_path / "run.gif")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a saved Simulation"):
        Simulation.load(tmp_path / "bad.npz")


def test_state_resumes_a_run():
    sim = simulate(FluidParams(), 3, shape=(12, 12), seed=0)
    s = sim.state(-1)
    assert s.frame == 3
    assert s.shape == (12, 12)
    assert np.abs(divergence(s.velocity)).max() < 1e-5  # float32 storage
    more = simulate(FluidParams(), 2, seed=1, initial=s)
    assert more.shape == (12, 12)


def test_flame_preset_makes_a_rising_flame():
    pre = flame_preset()
    assert pre.shape == (128, 128)
    assert pre.params.boundary == "open_top"
    sim = flame_preset().simulate(40, seed=0)
    hot = sim.temperature[-1] > 0.3
    rows = np.nonzero(hot.any(axis=1))[0]
    assert rows.min() < 100  # the flame has left the source (at row ~118)
    assert flame_preset(epsilon=0).params.epsilon == 0


@pytest.mark.parametrize("shape", [(16, 24), (128, 192)])
def test_smoke_preset_sizes_and_variants(shape):
    a = smoke_preset(shape)
    assert a.shape == shape
    assert a.params.boundary == "closed"
    b = smoke_preset(shape, source_x=0.3, wind=0.02)
    assert b.params.source_x == 0.3
    assert b.params.wind != 0
    assert b.params != a.params


def test_smoke_plumes_differ_and_rise_at_the_coarse_size():
    a = smoke_preset((16, 24)).simulate(60, seed=0)
    b = smoke_preset((16, 24), source_x=0.3, wind=0.03).simulate(60, seed=0)
    assert not np.allclose(a.density[-1], b.density[-1])
    yy = np.arange(16)[:, None]
    d = a.density[-1]
    assert (d * yy).sum() / d.sum() < 13  # above the source row (~14)


def test_to_clip_and_colour_map():
    sim = simulate(FluidParams(density_rate=0.3), 3, shape=(12, 16), seed=0)
    clip = sim.to_clip()
    assert isinstance(clip, Clip)
    assert clip.is_color
    assert clip.n_frames == 3
    assert clip.metadata["method"] == "fluid"
    grey = sim.to_clip("density")
    assert not grey.is_color
    rgb = temperature_to_rgb(np.linspace(-1, 2, 7).reshape(1, 7))
    assert rgb.dtype == np.float32
    assert rgb.min() >= 0
    assert rgb.max() <= 1
    np.testing.assert_array_equal(rgb[0, 0], 0)
    lum = rgb.sum(axis=-1)[0]
    assert np.all(np.diff(lum) >= 0)
    with pytest.raises(ValueError, match="T_max"):
        temperature_to_rgb(np.zeros((2, 2)), T_amb=1.0, T_max=1.0)
    with pytest.raises(ValueError, match="field"):
        sim.to_clip("pressure")


def test_bad_inputs_name_the_parameter():
    with pytest.raises(ValueError, match="n_frames"):
        simulate(FluidParams(), 0)
    with pytest.raises(ValueError, match="params"):
        simulate({"dt": 1}, 3)
    with pytest.raises(ValueError, match="substeps"):
        simulate(FluidParams(), 3, substeps=0)
    with pytest.raises(ValueError, match="shape"):
        simulate(FluidParams(), 3, shape=(8, 8, 8))
    with pytest.raises(ValueError, match="initial"):
        simulate(FluidParams(), 3, initial=np.zeros((8, 8)))
    with pytest.raises(ValueError, match="source_x"):
        smoke_preset((16, 24), source_x=1.5)
    with pytest.raises(ValueError, match="progress"):
        simulate(FluidParams(), 3, shape=(8, 8), progress="bar")


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"kappa_b": 1e12}, "kappa_b"),
        ({"source_T": 1e30}, "source_T"),
        ({"wind": -1e6}, "wind"),
        ({"epsilon": 5.0}, "epsilon"),
        ({"epsilon": 1.5, "dt": 2.0}, "epsilon"),
    ],
)
def test_forces_that_outrun_the_grid_are_refused(changes, name):
    # kappa_b = 1e12 or source_T = 1e30 ran to 1e11 px/frame (or infinity).
    with pytest.raises(ValueError, match=name):
        FluidParams(**changes)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        # Each was accepted before and ran to huge or unbounded values.
        ({"density_rate": 1e30}, r"density_rate must be in \[0, 100\], got 1e\+30"),
        ({"C_r": 1e30}, r"C_r must be in \[0, 100\], got 1e\+30"),
        ({"kappa_b": 1e12, "dt": 1e-6}, r"kappa_b must be in \[0, 100\], got 1e\+12"),
        ({"epsilon": 1e30, "dt": 1e-30}, r"epsilon must be in \[0, 100\], got 1e\+30"),
        ({"wind": 1e30, "source_T": 0.0}, r"wind must be in \[-100, 100\], got 1e\+30"),
        ({"kappa_b": 0.0, "source_T": 1e30}, r"source_T must be in \[-10000, 10000\]"),
        ({"T_amb": -1e300, "source_T": 0.0}, r"T_amb must be in \[-10000, 10000\], got -1e"),
    ],
)
def test_every_parameter_has_a_range_that_keeps_the_run_finite(changes, message):
    with pytest.raises(ValueError, match=message):
        FluidParams(**changes)


def test_the_far_corners_of_the_ranges_stay_finite():
    from fluidnb.fluid._params import MAX_RATE, MAX_TEMPERATURE

    hot = 2 * MAX_TEMPERATURE * 1.5  # source_T - T_amb, with the flicker
    params = FluidParams(
        T_amb=-MAX_TEMPERATURE,
        source_T=MAX_TEMPERATURE,
        kappa_b=16.0 / hot,  # the strongest push check() allows
        wind=-16.0 / hot,
        epsilon=2.0,
        C_r=MAX_RATE,
        density_rate=MAX_RATE,
        source_radius=0.5,
    )
    sim = simulate(params, 60, shape=(32, 32), seed=0)
    for a in (sim.velocity, sim.temperature, sim.density):
        assert np.all(np.isfinite(a))
    assert sim.temperature.max() <= params.T_amb + hot
    assert sim.density.max() <= MAX_RATE * 60 * (1 + 1e-12)


def test_warmup_is_bounded_like_the_frames():
    # warmup=10**7 ran for minutes (the frames are bounded by the memory they take).
    with pytest.raises(
        ValueError, match=r"warmup must be an integer in \[0, 10000\], got 10000000"
    ):
        simulate(FluidParams(), 3, shape=(8, 8), warmup=10**7)
    with pytest.raises(ValueError, match="warmup"):
        simulate(FluidParams(), 3, shape=(8, 8), warmup=-1)
    assert simulate(FluidParams(), 1, shape=(8, 8), seed=0, warmup=10_000).n_frames == 1


def test_the_strongest_allowed_forces_keep_the_flow_bounded():
    from fluidnb.fluid._params import MAX_EPSILON_DT, MAX_PUSH_PX

    params = FluidParams(
        kappa_b=MAX_PUSH_PX / 1.5, source_flicker=0.5, epsilon=MAX_EPSILON_DT, dt=1.0
    )
    sim = simulate(params, 120, shape=(48, 48), seed=0)
    assert np.all(np.isfinite(sim.velocity))
    assert np.abs(sim.velocity).max() < 200  # px/frame: a few grid heights at most


def test_a_run_too_large_for_memory_is_refused_and_told_what_fits(monkeypatch):
    from fluidnb.fluid import _simulate

    monkeypatch.setattr(_simulate, "_available_bytes", lambda: 8 * 2**30)
    with pytest.raises(ValueError, match=r"n_frames=120 .* at most \d+ frames fit.* about \d+x\d+"):
        simulate(FluidParams(), 120, shape=(4096, 4096), seed=0)
    with pytest.raises(ValueError, match="method='fast'"):
        project(np.zeros((1024, 1024, 2)), method="lu")


def test_a_failed_save_keeps_the_file_that_was_there(tmp_path, monkeypatch):
    first = simulate(FluidParams(), 2, shape=(10, 12), seed=1)
    path = tmp_path / "run.npz"
    first.save(path)
    before = path.read_bytes()

    def disk_full(file, **arrays):
        with open(file, "wb") as f:
            f.write(b"half a zip")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "savez", disk_full)
    with pytest.raises(OSError, match=r"run\.npz.*No space left"):
        simulate(FluidParams(), 3, shape=(10, 12), seed=2).save(path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]  # no partial left
