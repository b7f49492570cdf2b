"""Reiter's automaton with the random threshold: the spec's invariants."""

import numpy as np
import pytest

from fluidnb.frost import FrostParams, HexLattice, grow, step
from fluidnb.frost._reference import grow_reference


def rotation_maps(lat, center):
    """Index maps of the 60-degree rotation and the E-W mirror about a cell."""
    ax = lat.axial[: lat.n_cells] - lat.axial[center]
    where = {tuple(a): i for i, a in enumerate(ax.tolist())}
    rot = np.array([where[(-r, q + r)] for q, r in ax.tolist()])
    mirror = np.array([where[(q + r, -r)] for q, r in ax.tolist()])
    return rot, mirror


def ellipse_lattice(spacing=2.0):
    yy, xx = np.mgrid[0:40, 0:60]
    region = ((yy - 20) / 14) ** 2 + ((xx - 30) / 25) ** 2 <= 1
    return HexLattice.from_mask(region, spacing)


@pytest.mark.parametrize(("radius", "beta"), [(15, 0.35), (12, 0.3), (18, 0.45)])
def test_rth0_central_start_is_sixfold_symmetric_cell_for_cell(radius, beta):
    lat = HexLattice.hexagon(radius)
    c = lat.center_cell()
    res = grow(lat, [c], FrostParams(beta=beta), frames=300)
    rot, mirror = rotation_maps(lat, c)
    f = res.freeze_frame
    assert (f >= 0).sum() > 20, "the crystal must have grown for the check to mean something"
    assert (f < 0).any(), "and not have filled the hexagon (a trivial symmetry)"
    for _k in range(6):  # 60, 120, ... degrees
        assert np.array_equal(f, f[rot])
        f = f[rot]
    assert np.array_equal(f, f[mirror])


def test_rth0_dendrite_arms_point_along_the_six_lattice_directions():
    lat = HexLattice.hexagon(20)
    c = lat.center_cell()
    res = grow(lat, [c], FrostParams(beta=0.35), frames=120)
    ice = res.ice_at(120)
    ax = lat.axial[: lat.n_cells] - lat.axial[c]
    dist = (np.abs(ax[:, 0]) + np.abs(ax[:, 1]) + np.abs(ax.sum(axis=1))) // 2
    reach = dist[ice].max()
    tips = ice & (dist == reach)
    # The farthest ice lies on the six axes (one axial coordinate or their sum is 0).
    on_axis = (ax[:, 0] == 0) | (ax[:, 1] == 0) | (ax.sum(axis=1) == 0)
    assert tips.sum() >= 6
    assert on_axis[tips].all()


@pytest.mark.parametrize("rth", [0.4, 0.8])
def test_ice_never_melts_and_the_ice_set_only_grows(rth):
    lat = ellipse_lattice()
    res = grow(
        lat, [[20, 30]], FrostParams(rth=rth, beta=0.4), frames=150, seed=3, record_vapour=True
    )
    ice = res.vapour >= 1.0
    assert (ice[1:] >= ice[:-1]).all(), "ice at t is a subset of ice at t + 1"
    assert np.all(np.diff(res.coverage) >= 0)
    # Freeze frames agree with the vapour history.
    f = res.freeze_frame
    for t in (0, 40, 150):
        assert np.array_equal(ice[t], (f >= 0) & (f <= t))
        assert np.array_equal(ice[t], res.ice_at(t))


@pytest.mark.parametrize("rth", [0.0, 0.5])
def test_vectorised_kernel_matches_the_rule_written_cell_by_cell(rth):
    lat = ellipse_lattice(spacing=3.0)
    starts = lat.snap([[20, 30], [15, 12]])
    params = FrostParams(rth=rth, beta=0.4, alpha=1.3)
    res = grow(lat, starts, params, frames=50, seed=11, record_vapour=True)
    freeze, vapour = grow_reference(lat, starts, params, frames=50, seed=11)
    assert np.array_equal(freeze, res.freeze_frame)
    np.testing.assert_allclose(res.vapour, vapour, rtol=0, atol=1e-12)


@pytest.mark.parametrize("rth", [0.0, 0.4])
def test_the_compiled_step_is_the_numpy_step_bit_for_bit(rth):
    # _Kernel.advance (numba) against _Kernel.advance_numpy on a region with a ring
    # (a disc inside the lattice's storage): vapour, receptive set and gamma cells.
    from fluidnb.frost._reiter import _Kernel

    yy, xx = np.mgrid[:90, :110]
    lattice = HexLattice.from_mask((yy - 45) ** 2 + (xx - 50) ** 2 < 38**2, 3.0)
    params = FrostParams(beta=0.45, rth=rth, alpha=1.3)
    fast, slow = (_Kernel(lattice, params.alpha, params.gamma, params.rth) for _ in range(2))
    u = np.zeros(lattice.storage_size)
    u[lattice.cells] = np.random.default_rng(3).uniform(0.3, 0.6, lattice.n_cells)
    u[lattice.cells[lattice.snap([[45, 50]])]] = 1.0
    u_fast, u_slow = u.copy(), u.copy()
    gen = np.random.default_rng(4)
    for _ in range(150):
        fast.classify(u_fast)
        slow.classify(u_slow)
        r = gen.random(fast.random_shape, dtype=np.float32) if rth > 0 else None
        assert fast.advance(u_fast, r) == slow.advance_numpy(u_slow, r)
        np.testing.assert_array_equal(u_fast.view(np.uint64), u_slow.view(np.uint64))
        np.testing.assert_array_equal(fast.receptive, slow.receptive)
        if rth > 0:
            np.testing.assert_array_equal(fast.gets_gamma, slow.gets_gamma)
    assert 0 < np.count_nonzero(fast.ice) < lattice.n_cells  # it grew, and not all over


def test_seeded_runs_are_deterministic_and_the_seed_matters_for_rth_above_0():
    lat = ellipse_lattice()
    p = FrostParams(rth=0.6, beta=0.45)
    a = grow(lat, [[20, 30]], p, frames=80, seed=5)
    b = grow(lat, [[20, 30]], p, frames=80, seed=5)
    c = grow(lat, [[20, 30]], p, frames=80, seed=6)
    assert np.array_equal(a.freeze_frame, b.freeze_frame)
    assert not np.array_equal(a.freeze_frame, c.freeze_frame)
    # rth = 0 draws no random numbers at all: Reiter's deterministic model.
    d = grow(lat, [[20, 30]], p.replace(rth=0.0), frames=80, seed=5)
    e = grow(lat, [[20, 30]], p.replace(rth=0.0), frames=80, seed=99)
    assert np.array_equal(d.freeze_frame, e.freeze_frame)


def test_every_run_records_the_int_seed_it_used_so_it_can_be_remade():
    # Seed policy (fluidnb.resolve_seed): None or a Generator becomes a recorded int.
    lat = ellipse_lattice()
    p = FrostParams(rth=0.6, beta=0.45)
    fresh = grow(lat, [[20, 30]], p, frames=60)
    assert isinstance(fresh.seed, int)
    again = grow(lat, [[20, 30]], p, frames=60, seed=fresh.seed)
    assert np.array_equal(fresh.freeze_frame, again.freeze_frame)
    shared = grow(lat, [[20, 30]], p, frames=60, seed=np.random.default_rng(3))
    assert isinstance(shared.seed, int)
    remade = grow(lat, [[20, 30]], p, frames=60, seed=shared.seed)
    assert np.array_equal(shared.freeze_frame, remade.freeze_frame)
    with pytest.raises(ValueError, match="seed must be None, a non-negative integer"):
        grow(lat, [[20, 30]], p, frames=5, seed=-1)


def test_common_random_numbers_across_beta():
    # Runs with different beta see the same r_t(p) for every (step, cell): each matches
    # the per-cell reference, which draws its stream without looking at beta.
    lat = ellipse_lattice(spacing=3.0)
    for beta in (0.3, 0.45):
        p = FrostParams(rth=0.7, beta=beta)
        res = grow(lat, [[20, 30]], p, frames=40, seed=21)
        freeze, _ = grow_reference(lat, lat.snap([[20, 30]]), p, frames=40, seed=21)
        assert np.array_equal(res.freeze_frame, freeze)


@pytest.mark.parametrize(("gamma", "rth"), [(0.0, 0.0), (0.005, 0.0), (0.01, 0.6)])
def test_vapour_bookkeeping(gamma, rth):
    # Far from the boundary: the total changes by exactly gamma x (cells that got gamma).
    lat = HexLattice.hexagon(20)
    res = grow(
        lat,
        [lat.center_cell()],
        FrostParams(gamma=gamma, rth=rth, beta=0.4),
        frames=15,
        record_vapour=True,
        seed=2,
    )
    total = res.vapour.sum(axis=1)
    np.testing.assert_allclose(np.diff(total), gamma * res.gamma_cells, rtol=0, atol=1e-10)
    if rth == 0:  # then every receptive cell (ice or next to ice) gets gamma
        n = lat.n_cells
        nb = lat.neighbours[:n]
        for t in range(15):
            ice = res.vapour[t] >= 1
            near = (ice[np.where(nb < n, nb, 0)] & (nb < n)).any(axis=1)
            assert res.gamma_cells[t] == (ice | near).sum()
    if gamma == 0:
        np.testing.assert_allclose(total, total[0], rtol=1e-14)  # diffusion conserves


@pytest.mark.parametrize("rth", [0.0, 0.5])
def test_vapour_bookkeeping_holds_exactly_at_the_boundary_too(rth):
    # The ring's value is the mean of its region neighbours in the diffusion field
    # (receptive ones count 0): what it gives to receptive cells it takes from the
    # others, so even with the ice at the edge nothing but gamma changes the total.
    lat = ellipse_lattice(spacing=4.0)
    p = FrostParams(gamma=0.005, beta=0.4, alpha=1.5, rth=rth)
    res = grow(lat, [[20, 30], [20, 8]], p, frames=250, record_vapour=True, seed=4)
    edge = (lat.neighbours[: lat.n_cells] >= lat.n_cells).any(axis=1)
    assert res.ice_at(250)[edge].sum() >= 5, "ice must reach the boundary for this check"
    np.testing.assert_allclose(
        np.diff(res.vapour.sum(axis=1)), p.gamma * res.gamma_cells, rtol=0, atol=1e-10
    )
    # No vapour appears from nowhere near the boundary (a ring fed by the ice's own
    # vapour grows it exponentially, to ~5e4 in 50 steps): ice holds its own 1 + gamma t
    # plus what it soaked up from neighbours below 1.
    assert res.vapour.max() <= 2.0 + p.gamma * 250


def test_gamma_goes_to_ice_and_only_lucky_frontier_cells():
    lat = HexLattice.hexagon(3)
    c = lat.center_cell()
    u = np.full(lat.n_cells, 0.35)
    u[c] = 1.0
    nbrs = lat.neighbours[c]
    r = np.full(lat.n_cells, 0.9)
    r[nbrs[:3]] = 0.1  # three frontier cells draw below rth
    u1, got = step(lat, u, FrostParams(rth=0.5), r=r)
    assert got[c]
    assert got[nbrs[3:]].all()
    assert not got[nbrs[:3]].any()
    assert got.sum() == 4
    # Receptive cells keep their vapour and receive inflow; unlucky ones just miss gamma.
    assert np.all(u1[nbrs[3:]] - u1[nbrs[3]] == 0)
    np.testing.assert_allclose(u1[nbrs[3:]] - u1[nbrs[:3]], 0.005)
    assert (u1[nbrs] > 0.35).all()
    # And one step of `step` is one step of `grow`.
    res = grow(lat, [c], FrostParams(), frames=1, record_vapour=True)
    np.testing.assert_allclose(step(lat, res.vapour[0])[0], res.vapour[1], atol=1e-15)


def test_end_frame_is_the_first_frame_with_coverage_and_never_is_plain():
    lat = ellipse_lattice()
    res = grow(lat, [[20, 30]], FrostParams(beta=0.5))
    assert res.reached
    assert res.coverage[res.end_frame] >= 0.9 > res.coverage[res.end_frame - 1]
    assert res.n_frames == res.end_frame  # stops there by default
    assert f"ends at frame {res.end_frame}" in res.message
    short = grow(lat, [[20, 30]], FrostParams(beta=0.5, max_frames=10, target=10))
    assert short.end_frame is None
    assert not short.reached
    assert short.message.startswith("never within 10 frames")
    longer = grow(lat, [[20, 30]], FrostParams(beta=0.5), frames=res.end_frame + 20)
    assert longer.n_frames == res.end_frame + 20
    assert longer.end_frame == res.end_frame


def test_beta_per_cell_and_start_point_forms():
    lat = ellipse_lattice()
    p = FrostParams(beta=0.4)
    cells = lat.snap([[20, 30]])
    a = grow(lat, [[20, 30]], p, frames=60)
    b = grow(lat, cells, p, frames=60)
    c = grow(lat, cells, p, beta=np.full(lat.n_cells, 0.4), frames=60)
    d = grow(lat, cells, p.replace(beta=0.1), beta=0.4, frames=60)
    for other in (b, c, d):
        assert np.array_equal(a.freeze_frame, other.freeze_frame)
    faster = np.full(lat.n_cells, 0.4)
    faster[lat.points[:, 1] > 30] = 0.6  # more vapour on the right: frost goes there
    e = grow(lat, cells, p, beta=faster, frames=60)
    right = lat.points[:, 1] > 35
    left = lat.points[:, 1] < 25
    assert e.ice_at(60)[right].mean() > e.ice_at(60)[left].mean()


def test_bad_inputs_are_refused_with_the_parameter_named():
    lat = ellipse_lattice()
    for name, value, msg in [
        ("beta", 1.2, r"beta must be in \[0, 1\], got 1.2"),
        ("gamma", -0.1, r"gamma must be in \[0, 1\], got -0.1"),
        ("alpha", 2.5, r"alpha must be in \[0, 2\], got 2.5"),
        ("rth", 1.3, r"rth must be in \[0, 1\], got 1.3"),
        ("spacing", 0, r"spacing must be in \(0, 256\], got 0"),
    ]:
        with pytest.raises(ValueError, match=msg):
            FrostParams(**{name: value})
    with pytest.raises(ValueError, match=r"target must be <= max_frames \(100\)"):
        FrostParams(max_frames=100)
    with pytest.raises(ValueError, match="outside the region"):
        grow(lat, [[0, 0]])
    with pytest.raises(ValueError, match="starts is empty"):
        grow(lat, np.zeros((0, 2)))
    with pytest.raises(ValueError, match="start cells must be indices"):
        grow(lat, np.array([lat.n_cells]))
    with pytest.raises(ValueError, match=r"beta must be in \[0, 1\], got values"):
        grow(lat, [[20, 30]], beta=np.full(lat.n_cells, 1.5))
    with pytest.raises(ValueError, match="one value per cell"):
        grow(lat, [[20, 30]], beta=np.zeros(3))
    with pytest.raises(ValueError, match=r"beta must be in \[0, 1\], got 3"):
        grow(lat, [[20, 30]], beta=3.0)
    with pytest.raises(ValueError, match="lattice must be a HexLattice"):
        grow(np.ones((5, 5)), [[1, 1]])
    with pytest.raises(ValueError, match="params must be a FrostParams"):
        grow(lat, [[20, 30]], {"beta": 0.3})
    with pytest.raises(ValueError, match="r is required when rth > 0"):
        step(lat, np.zeros(lat.n_cells), FrostParams(rth=0.5))
    starts = np.array([[20.0, 30.0]])
    grow(lat, starts, frames=3)
    assert starts.tolist() == [[20.0, 30.0]]  # inputs are never modified
