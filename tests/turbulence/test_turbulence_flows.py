"""Flows, their files, and the cached sample pair (made by fluidnb.fluid)."""

import numpy as np
import pytest

from fluidnb.fields import downsample
from fluidnb.fluid import FluidParams, simulate
from fluidnb.turbulence import Flow, _flows, cache_dir, sample_flows


def test_the_sample_pair_has_the_papers_grids_and_differs_from_the_source():
    target, source = sample_flows(12, scale=2)
    assert (target.shape, source.shape) == ((12, 8), (96, 64))
    assert source.dx / target.dx == 1 / 8
    assert target.n_frames == source.n_frames == 12
    assert target.mask(0.1).any()
    assert source.mask(0.1).any()
    # An independent scene, not the source downsampled: the search has work to do.
    coarse = np.stack([downsample(v, 8, vector=True) for v in source.velocity])
    assert np.abs(coarse - target.velocity).mean() > 0.2 * np.abs(target.velocity).mean()


def test_the_sample_pair_is_cached_in_memory_and_on_disk(tmp_path, monkeypatch):
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_flows, "_MEMORY", {})
    assert cache_dir() == tmp_path
    first = sample_flows(3, scale=2)
    assert sample_flows(3, scale=2) is first
    (file,) = tmp_path.glob("turbulence-sample-*.npz")
    monkeypatch.setattr(_flows, "_MEMORY", {})
    monkeypatch.setattr(_flows, "_simulate_pair", lambda *a: pytest.fail("not from disk"))
    again = sample_flows(3, scale=2)
    np.testing.assert_array_equal(again[1].velocity, first[1].velocity)
    # A corrupt cache file is simulated afresh, not an error.
    file.write_bytes(b"not a zip")
    monkeypatch.setattr(_flows, "_MEMORY", {})
    monkeypatch.undo()
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_flows, "_MEMORY", {})
    np.testing.assert_array_equal(sample_flows(3, scale=2)[0].density, first[0].density)


def test_flows_round_trip_and_read_simulations(tmp_path):
    g = np.random.default_rng(0)
    flow = Flow(g.normal(size=(4, 6, 5, 2)), g.random((4, 6, 5)), 0.5)
    back = Flow.load(flow.save(tmp_path / "f.npz"))
    np.testing.assert_array_equal(back.velocity, flow.velocity)
    assert back.dx == 0.5
    assert repr(back) == "Flow(4 frames, 6 x 5, dx=0.5)"
    sim = simulate(FluidParams(density_rate=0.2), 3, shape=(12, 8), seed=0)
    from_sim = Flow.load(sim.save(str(tmp_path / "sim.npz")))
    np.testing.assert_allclose(from_sim.velocity, sim.centred_velocity())
    assert from_sim.dx == 0.5  # 4 units across 8 cells


def test_bad_files_and_arguments_get_clear_errors(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"junk")
    with pytest.raises(ValueError, match="not a saved Flow or Simulation"):
        Flow.load(bad)
    with pytest.raises(ValueError, match=r"must end in \.npz"):
        Flow(np.zeros((1, 2, 2, 2)), np.zeros((1, 2, 2)), 1.0).save(tmp_path / "x.gif")
    with pytest.raises(ValueError, match="scale"):
        sample_flows(5, scale=3)
    with pytest.raises(ValueError, match="select nothing"):
        Flow(np.zeros((2, 2, 2, 2)), np.zeros((2, 2, 2)), 1.0).frames(5, 9)
