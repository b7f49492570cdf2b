"""The assignment MRF (Okabe et al., sec. 5, Eq. 4-5): the energy and its solvers."""

import numpy as np
import pytest

from fluidnb import Cancelled, CancelToken
from fluidnb.videodb._mrf import alpha_expansion, brute_force, energy, grid_edges, icm, solve

# ------------------------------------------------------------------------ helpers


def random_problem(gen, shape, k, *, metric=None):
    """A random MRF on a grid: uniform unary, per-edge tables (random or metric)."""
    _, edges, _ = grid_edges(np.ones(shape, bool))
    unary = gen.random((shape[0] * shape[1], k))
    a, b = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    weights = gen.random(len(edges))[:, None, None]
    if metric == "potts":
        pairwise = weights * (a != b)
    elif metric == "truncated":  # min(|a - b|, 2): a metric on the label indices
        pairwise = weights * np.minimum(np.abs(a - b), 2)
    else:
        pairwise = gen.random((len(edges), k, k))
    return unary, pairwise, edges


# -------------------------------------------------------------------------- grid


def test_grid_edges_known_answer_with_a_hole():
    active = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], bool)
    nodes, edges, horizontal = grid_edges(active)
    assert nodes.tolist() == [[0, 0], [0, 1], [0, 2], [1, 0], [1, 2], [2, 0], [2, 1], [2, 2]]
    assert edges.tolist() == [[0, 1], [0, 3], [1, 2], [2, 4], [3, 5], [4, 7], [5, 6], [6, 7]]
    assert horizontal.tolist() == [True, False, True, False, False, False, True, True]


def test_grid_edges_full_grid_geometry():
    nodes, edges, horizontal = grid_edges(np.ones((14, 26), bool))
    assert len(nodes) == 364
    assert len(edges) == 688  # 14 * 25 + 13 * 26
    step = nodes[edges[:, 1]] - nodes[edges[:, 0]]
    assert np.array_equal(step[horizontal], np.tile([0, 1], (horizontal.sum(), 1)))
    assert np.array_equal(step[~horizontal], np.tile([1, 0], ((~horizontal).sum(), 1)))
    assert np.array_equal(nodes, np.argwhere(np.ones((14, 26), bool)))


# ------------------------------------------------------------------------ energy


def test_energy_is_eq4_written_out():
    gen = np.random.default_rng(5)
    unary, pairwise, edges = random_problem(gen, (2, 3), 4)
    labels = gen.integers(0, 4, 6)
    expected = sum(unary[p, labels[p]] for p in range(6)) + 0.7 * sum(
        pairwise[e, labels[p], labels[q]] for e, (p, q) in enumerate(edges)
    )
    assert energy(labels, unary, pairwise, edges, 0.7) == pytest.approx(expected, rel=1e-14)


# ----------------------------------------------------------------------- solvers


@pytest.mark.parametrize("seed", range(4))
def test_expansion_never_raises_the_energy(seed):
    gen = np.random.default_rng(seed)
    unary, pairwise, edges = random_problem(gen, (5, 6), 8)
    init = gen.integers(0, 8, 30)
    run = alpha_expansion(unary, pairwise, edges, 1.5, init=init)
    assert np.all(np.diff(run.energies) <= 0)
    assert run.energies[0] == energy(init, unary, pairwise, edges, 1.5)
    assert run.energy == energy(run.labels, unary, pairwise, edges, 1.5)
    assert run.energy < run.energies[0]
    assert 0.1 < run.nonsubmodular < 0.7  # random tables: many truncated terms


def submodular_two_label(gen, shape):
    unary, pairwise, edges = random_problem(gen, shape, 2)
    deficit = pairwise[:, 0, 0] + pairwise[:, 1, 1] - pairwise[:, 0, 1] - pairwise[:, 1, 0]
    pairwise[:, 0, 1] += np.maximum(deficit, 0) + 0.1 * gen.random(len(edges))
    return unary, pairwise, edges


def test_two_label_submodular_expansion_equals_brute_force_from_any_start():
    # With two labels the alpha = 0 move is exact over the labellings below the start
    # and the alpha = 1 move exact over those above its result; by submodularity the
    # latter set holds a global minimiser, so one sweep reaches the optimum.
    gen = np.random.default_rng(7)
    for _ in range(40):
        unary, pairwise, edges = submodular_two_label(gen, (3, 3))
        init = gen.integers(0, 2, 9)
        run = alpha_expansion(unary, pairwise, edges, 2.0, init=init)
        labels, best = brute_force(unary, pairwise, edges, 2.0)
        assert run.nonsubmodular == 0.0
        assert np.array_equal(run.labels, labels)
        assert run.energy == best


def optimum_statistics(metric, lam, n=100, seed=11):
    """Fraction of tiny 3 x 2, 4-label problems solved optimally, and the gaps."""
    gen = np.random.default_rng(seed)
    hits = {"expansion": 0, "solve": 0, "icm": 0}
    gaps = {"expansion": [], "solve": []}
    ratios = []
    for _ in range(n):
        unary, pairwise, edges = random_problem(gen, (3, 2), 4, metric=metric)
        _, best = brute_force(unary, pairwise, edges, lam)
        runs = {
            "expansion": alpha_expansion(unary, pairwise, edges, lam).energy,
            "solve": solve(unary, pairwise, edges, lam).energy,
            "icm": icm(unary, pairwise, edges, lam).energy,
        }
        assert min(runs.values()) >= best - 1e-12
        for name, value in runs.items():
            hits[name] += value <= best + 1e-12 * best
        for name in gaps:
            gaps[name].append((runs[name] - best) / best)
        ratios.append(runs["expansion"] / best)
    fractions = {name: h / n for name, h in hits.items()}
    mean_gaps = {name: float(np.mean(g)) for name, g in gaps.items()}
    print(f"\n{metric or 'non-metric'} lam={lam}: optimal {fractions}, mean gap {mean_gaps}")
    return fractions, mean_gaps, max(ratios)


@pytest.mark.parametrize(("metric", "bound"), [("potts", 2.0), ("truncated", 4.0)])
def test_metric_problems_nearly_always_optimal_and_within_the_bound(metric, bound):
    # Expansion on a metric is exact per move (no truncation) and reaches a local
    # minimum within 2c of the optimum (Boykov et al. 2001; c = 1 for Potts, 2 for
    # min(|a - b|, 2)); it is not exact in general, but on these tiny problems it
    # misses the optimum rarely (measured: 98 % for both from the argmin, 100 % with
    # solve()'s two starts; ICM 27-30 %).
    fractions, gaps, worst = optimum_statistics(metric, 1.0)
    assert worst <= bound
    assert fractions["expansion"] >= 0.95
    assert fractions["solve"] >= fractions["expansion"]
    assert fractions["icm"] < 0.5  # the baseline is far weaker
    assert gaps["expansion"] < 0.005


def test_non_metric_problems_gap_to_brute_force_is_reported():
    # Per-node candidate labels make W non-metric; the truncated moves are a
    # heuristic. Measured on these 100 problems (3 x 2 nodes, 4 labels, uniform
    # tables, lam = 1): expansion from the argmin optimal in 56 %, solve() (two
    # starts) in 73 %, ICM in 50 %; mean relative gaps 4.6 % and 1.6 %. (The
    # research notes measured 31 % on their own random problems.) Deterministic:
    # the tolerances only absorb round-off deciding a near-tie.
    fractions, gaps, _ = optimum_statistics(None, 1.0)
    assert fractions["expansion"] == pytest.approx(0.56, abs=0.02)
    assert fractions["solve"] == pytest.approx(0.73, abs=0.02)
    assert fractions["icm"] == pytest.approx(0.50, abs=0.02)
    assert gaps["expansion"] == pytest.approx(0.046, abs=0.005)
    assert gaps["solve"] == pytest.approx(0.016, abs=0.005)


@pytest.mark.parametrize("seed", range(3))
def test_solve_never_worse_than_icm(seed):
    gen = np.random.default_rng(100 + seed)
    unary, pairwise, edges = random_problem(gen, (6, 7), 10)
    result = solve(unary, pairwise, edges, 1.0)
    baseline = icm(unary, pairwise, edges, 1.0)
    assert result.icm_energy == baseline.energy
    assert result.energy <= result.icm_energy
    assert result.energy == energy(result.labels, unary, pairwise, edges, 1.0)
    assert np.all(np.diff(result.energies) <= 0)
    assert np.all(np.diff(baseline.energies) <= 0)
    assert result.start in ("argmin", "icm")
    assert set(result.timings) == {"icm", "expansion_argmin", "expansion_icm"}


def test_icm_ends_in_a_single_node_local_minimum():
    gen = np.random.default_rng(9)
    unary, pairwise, edges = random_problem(gen, (4, 4), 5)
    run = icm(unary, pairwise, edges, 1.0)
    for p in range(16):
        for label in range(5):
            changed = run.labels.copy()
            changed[p] = label
            assert energy(changed, unary, pairwise, edges, 1.0) >= run.energy - 1e-12


def test_lam_zero_gives_the_unary_argmin():
    gen = np.random.default_rng(4)
    unary, pairwise, edges = random_problem(gen, (4, 5), 6)
    argmin = np.argmin(unary, axis=1)
    assert np.array_equal(alpha_expansion(unary, pairwise, edges, 0.0).labels, argmin)
    start = gen.integers(0, 6, 20)
    assert np.array_equal(alpha_expansion(unary, pairwise, edges, 0, init=start).labels, argmin)
    assert np.array_equal(icm(unary, pairwise, edges, 0.0, init=start).labels, argmin)
    assert np.array_equal(solve(unary, pairwise, edges, 0.0).labels, argmin)


def test_single_node_without_edges():
    unary = np.array([[0.3, 0.1, 0.2]])
    pairwise = np.zeros((0, 3, 3))
    edges = np.zeros((0, 2), int)
    result = solve(unary, pairwise, edges, 1.0)
    assert result.labels.tolist() == [1]
    assert result.energy == 0.1


def test_solvers_leave_their_inputs_untouched():
    gen = np.random.default_rng(2)
    unary, pairwise, edges = random_problem(gen, (3, 3), 4)
    init = gen.integers(0, 4, 9)
    copies = [a.copy() for a in (unary, pairwise, edges, init)]
    alpha_expansion(unary, pairwise, edges, 1.0, init=init)
    icm(unary, pairwise, edges, 1.0, init=init)
    for before, after in zip(copies, (unary, pairwise, edges, init)):
        assert np.array_equal(before, after)


def test_solve_reports_progress_and_can_be_cancelled():
    gen = np.random.default_rng(6)
    unary, pairwise, edges = random_problem(gen, (3, 4), 5)
    seen = []
    solve(unary, pairwise, edges, 1.0, progress=lambda f, m: seen.append((f, m)))
    assert any("ICM" in m for _, m in seen)
    assert any("expansion" in m for _, m in seen)
    assert all(0.0 <= f <= 1.0 for f, _ in seen)
    token = CancelToken()
    token.cancel()
    with pytest.raises(Cancelled):
        alpha_expansion(unary, pairwise, edges, 1.0, progress=token)


def test_brute_force_refuses_big_problems():
    gen = np.random.default_rng(0)
    unary, pairwise, edges = random_problem(gen, (4, 4), 10)
    with pytest.raises(ValueError, match=r"K\*\*P = 10\*\*16"):
        brute_force(unary, pairwise, edges, 1.0)


def test_solvers_refuse_bad_inputs():
    gen = np.random.default_rng(1)
    unary, pairwise, edges = random_problem(gen, (2, 3), 4)
    with pytest.raises(ValueError, match="pairwise must have shape"):
        solve(unary, pairwise[:, :3, :3], edges, 1.0)
    with pytest.raises(ValueError, match="pairwise must have shape"):
        alpha_expansion(unary, pairwise[:-1], edges, 1.0)
    nan_unary = unary.copy()
    nan_unary[0, 0] = np.nan
    with pytest.raises(ValueError, match="unary contains 1 NaN"):
        alpha_expansion(nan_unary, pairwise, edges, 1.0)
    with pytest.raises(ValueError, match="lam must be >= 0"):
        icm(unary, pairwise, edges, -0.1)
    with pytest.raises(ValueError, match="edges must hold node indices"):
        energy(np.zeros(6, int), unary, pairwise, edges + 6, 1.0)
    with pytest.raises(ValueError, match="edges must join two different nodes"):
        energy(np.zeros(6, int), unary, pairwise, np.zeros_like(edges), 1.0)
    with pytest.raises(ValueError, match=r"init must be label indices in \[0, 3\]"):
        alpha_expansion(unary, pairwise, edges, 1.0, init=np.full(6, 4))
    with pytest.raises(ValueError, match="labels must have shape"):
        energy(np.zeros(5, int), unary, pairwise, edges, 1.0)
    with pytest.raises(ValueError, match="max_sweeps must be an integer >= 1"):
        solve(unary, pairwise, edges, 1.0, max_sweeps=0)


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_solvers_equal_the_plain_ones_bit_for_bit(seed):
    """alpha_expansion and icm (compiled move terms, compiled sweeps) against the plain
    numpy versions in _reference: same labels, same energies, same truncated share."""
    from fluidnb.videodb import reference_alpha_expansion, reference_icm

    gen = np.random.default_rng(seed)
    shape = [(3, 4), (5, 6), (2, 9), (6, 6), (1, 7), (4, 4)][seed]
    k = [2, 5, 9, 7, 3, 12][seed]
    unary, pairwise, edges = random_problem(gen, shape, k)
    lam = [0.5, 1.0, 2.0, 0.1, 3.0, 1.5][seed]
    init = gen.integers(0, k, len(unary)) if seed % 2 else None
    for fast, plain in ((alpha_expansion, reference_alpha_expansion), (icm, reference_icm)):
        got = fast(unary, pairwise, edges, lam, init=init, max_sweeps=6)
        want = plain(unary, pairwise, edges, lam, init=init, max_sweeps=6)
        assert np.array_equal(got.labels, want.labels), fast.__name__
        assert np.array_equal(got.energies, want.energies), fast.__name__
        assert got.sweeps == want.sweeps
        assert got.nonsubmodular == want.nonsubmodular
    # Random per-node candidates make non-submodular moves: the truncation is exercised.
    if seed == 3:
        assert reference_alpha_expansion(unary, pairwise, edges, lam).nonsubmodular > 0


def test_the_compiled_solvers_handle_a_problem_without_edges():
    from fluidnb.videodb import reference_alpha_expansion, reference_icm

    unary = np.array([[0.3, 0.1, 0.2], [0.0, 0.5, 0.4]])
    pairwise, edges = np.zeros((0, 3, 3)), np.zeros((0, 2), int)
    for fast, plain in ((alpha_expansion, reference_alpha_expansion), (icm, reference_icm)):
        got = fast(unary, pairwise, edges, 1.0)
        assert got.labels.tolist() == [1, 0]
        assert np.array_equal(got.energies, plain(unary, pairwise, edges, 1.0).energies)


@pytest.mark.parametrize("seed", range(4))
def test_moves_that_failed_on_the_same_labels_are_skipped_without_changing_the_result(seed):
    # _expand does not try a move again that failed while the labels have not changed
    # since: here against the same sweeps trying every move every time.
    from fluidnb.videodb._mrf import _compiled_move_terms, _cut_and_move, _problem

    gen = np.random.default_rng(40 + seed)
    k = [4, 7, 10, 6][seed]
    unary, pairwise, edges = random_problem(gen, (5, 6), k)
    lam = [0.5, 1.0, 2.0, 4.0][seed]
    got = alpha_expansion(unary, pairwise, edges, lam, max_sweeps=8)
    prob = _problem(unary, pairwise, edges, lam)
    terms = _compiled_move_terms(prob)
    labels = np.argmin(prob.unary, axis=1)
    current = prob.energy(labels)
    energies, truncated, free, tried = [current], 0, 0, 0
    for _ in range(8):
        improved = False
        for alpha in range(k):
            cap, cost1, n_trunc, n_free = terms(labels, alpha)
            truncated, free, tried = truncated + n_trunc, free + n_free, tried + 1
            labels, current, moved = _cut_and_move(prob, labels, current, alpha, cap, cost1)
            improved |= moved
        energies.append(current)
        if not improved:
            break
    assert np.array_equal(got.labels, labels)
    assert np.array_equal(got.energies, energies)
    assert got.nonsubmodular == (truncated / free if free else 0.0)
    assert got.sweeps == len(energies) - 1 >= 2  # a last sweep of skips, at least
