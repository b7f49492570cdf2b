"""The local search strategies of Watanabe et al., sec. 3 (Table 1), and the two exact ones."""

import numpy as np
import pytest

from fluidnb.turbulence import STRATEGIES, local_search, window_positions
from tests.support.search_problems import problem

EXACT = ("exhaustive", "exact-fft", "exact-bounds")


def brute_force(S, X, starts, n):
    """Every window position's energy, by plain numpy, shape (P, n, n)."""
    P, B = X.shape[:2]
    E = np.empty((P, n, n))
    for p in range(P):
        for a in range(n):
            for b in range(n):
                y, x = starts[p] + (a, b)
                E[p, a, b] = ((X[p] - S[y : y + B, x : x + B]) ** 2).sum()
    return E


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("smooth", [False, True])
def test_exhaustive_returns_the_brute_force_minimum(seed, smooth):
    S, X, starts, n = problem(seed, smooth=smooth)
    E = brute_force(S, X, starts, n).reshape(len(X), -1)
    out = local_search(S, X, starts, n, "exhaustive")
    k = E.argmin(1)  # the first minimum in raster order
    np.testing.assert_array_equal(out.positions, starts + np.stack([k // n, k % n], -1))
    np.testing.assert_allclose(out.energies, E.min(1), rtol=1e-12)
    assert (out.evaluations == n * n).all()


@pytest.mark.parametrize("strategy", ["exact-fft", "exact-bounds"])
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("smooth", [False, True])
def test_the_exact_searches_return_the_exhaustive_answer(strategy, seed, smooth):
    S, X, starts, n = problem(seed, smooth=smooth, B=8, n=12)
    ref = local_search(S, X, starts, n, "exhaustive")
    out = local_search(S, X, starts, n, strategy)
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_array_equal(out.energies, ref.energies)  # the same kernel: bit for bit


@pytest.mark.parametrize("strategy", ["exact-fft", "exact-bounds", "adaptive"])
def test_ties_resolve_like_the_exhaustive_search(strategy):
    # A periodic source: the same patch at many positions, all with energy 0.
    y, x = np.mgrid[:30, :30]
    S = np.stack([np.sin(y * np.pi / 2), np.cos(x * np.pi / 2), (y + x) % 2], -1).astype(float)
    X = np.stack([S[4:10, 4:10], S[8:14, 6:12]])
    starts = np.array([[1, 1], [3, 2]])
    ref = local_search(S, X, starts, 16, "exhaustive")
    out = local_search(S, X, starts, 16, strategy, m0=1)
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_array_equal(out.energies, 0)


def test_odd_patch_sizes_work_for_every_strategy():
    S, X, starts, n = problem(3, B=5, n=8)
    ref = local_search(S, X, starts, n, "exhaustive")
    for strategy in STRATEGIES:
        out = local_search(S, X, starts, n, strategy, m0=4, interval=2)
        assert (out.energies >= ref.energies).all()
        if strategy.startswith("exact"):
            np.testing.assert_array_equal(out.positions, ref.positions)


@pytest.mark.parametrize("seed", range(3))
def test_adaptive_from_interval_1_and_interval_1_are_the_exhaustive_search(seed):
    S, X, starts, n = problem(seed, smooth=True, n=10)
    ref = local_search(S, X, starts, n, "exhaustive")
    for out in (
        local_search(S, X, starts, n, "adaptive", m0=1),
        local_search(S, X, starts, n, "interval", interval=1),
    ):
        np.testing.assert_array_equal(out.positions, ref.positions)
        np.testing.assert_array_equal(out.energies, ref.energies)
        assert (out.evaluations == n * n).all()


def test_sampling_strategies_visit_what_the_paper_says_and_never_beat_exhaustive():
    S, X, starts, n = problem(1, shape=(60, 60), B=8, n=32, smooth=True)
    ref = local_search(S, X, starts, n, "exhaustive")
    for m in (2, 4, 8):
        out = local_search(S, X, starts, n, "interval", interval=m)
        assert (out.evaluations == (n // m) ** 2).all()
        assert (out.energies >= ref.energies).all()
        assert ((out.positions - starts) % m == 0).all()
    ada = local_search(S, X, starts, n, "adaptive", m0=8)
    # 4 x 4 samples, then at most 24 new ones in each of the rounds m = 4, 2, 1.
    assert (ada.evaluations >= 16).all()
    assert (ada.evaluations <= 16 + 3 * 24).all()
    assert (ada.energies >= ref.energies).all()
    # On smooth data the coarse-to-fine search finds (nearly) the exhaustive minimum.
    assert np.mean((ada.energies - ref.energies) / ref.energies) < 0.05


def test_window_positions_draws_the_adaptive_rounds():
    rounds = window_positions("adaptive", 32, m0=8, best=lambda pts: tuple(pts[-1]))
    assert next(len(r) for r in rounds) == 16
    assert all(len(r) <= 24 for r in rounds[1:])
    assert len(rounds) == 4
    steps = [np.diff(np.unique(r[:, 0])).min() for r in rounds[1:]]
    assert steps == [4, 2, 1]
    (grid,) = window_positions("interval", 32, interval=4)
    assert len(grid) == 64
    assert grid.max() == 28
    with pytest.raises(ValueError, match="strategy"):
        window_positions("exact-fft", 32)


def test_an_unknown_strategy_is_refused():
    S, X, starts, n = problem(0)
    with pytest.raises(ValueError, match="strategy must be one of"):
        local_search(S, X, starts, n, "random")


def test_still_air_ties_cost_the_bounded_search_almost_nothing():
    # Early frames are mostly still air: many windows are all zeros, every position
    # ties at energy 0, and the first in raster order must win without measuring all.
    S = np.zeros((40, 40, 5))
    S[30:, 30:] = np.random.default_rng(0).normal(size=(10, 10, 5))
    X = np.zeros((3, 8, 8, 5))
    starts = np.array([[0, 0], [5, 3], [10, 10]])
    ref = local_search(S, X, starts, 16, "exhaustive")
    out = local_search(S, X, starts, 16, "exact-bounds")
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_array_equal(out.positions, starts)
    assert (out.evaluations == 1).all()


@pytest.mark.parametrize("seed", range(4))
def test_a_hint_speeds_the_bounded_search_but_never_changes_its_answer(seed):
    S, X, starts, n = problem(seed, smooth=True, B=8, n=12, P=9)
    ref = local_search(S, X, starts, n, "exhaustive")
    g = np.random.default_rng(seed)
    hints = {
        "the answer": ref.positions,
        "random, inside": starts + g.integers(0, n, starts.shape),
        "outside the window": starts - 1 - g.integers(0, 5, starts.shape),
        "mixed": np.where(g.random((len(X), 1)) < 0.5, ref.positions, starts + n),
    }
    plain = local_search(S, X, starts, n, "exact-bounds")
    for name, hint in hints.items():
        out = local_search(S, X, starts, n, "exact-bounds", hint=hint)
        np.testing.assert_array_equal(out.positions, ref.positions, err_msg=name)
        np.testing.assert_array_equal(out.energies, ref.energies, err_msg=name)
    # Starting from the answer, fewer positions need measuring than from level 1's guess.
    best = local_search(S, X, starts, n, "exact-bounds", hint=ref.positions)
    assert best.evaluations.sum() <= plain.evaluations.sum()
    # The paper's strategies ignore it.
    ada = local_search(S, X, starts, n, "adaptive", hint=hints["random, inside"])
    np.testing.assert_array_equal(
        ada.positions, local_search(S, X, starts, n, "adaptive").positions
    )


def test_a_malformed_hint_is_refused():
    S, X, starts, n = problem(0)
    with pytest.raises(ValueError, match="hint must be integer positions of shape"):
        local_search(S, X, starts, n, "exact-bounds", hint=np.zeros((len(X), 3), int))
    with pytest.raises(ValueError, match="hint must be integer positions"):
        local_search(S, X, starts, n, "exact-bounds", hint=np.zeros((len(X), 2)))


@pytest.mark.parametrize("B", [4, 7, 12, 16])
def test_the_bounded_search_is_exact_for_any_patch_size(B):
    # B = 4 s + r: the level-2 boxes (s x s) cover the patch's top-left 4s x 4s only;
    # a bound over part of the patch is still a lower bound.
    S, X, starts, n = problem(B, shape=(50, 50), B=B, n=10, P=5, smooth=True)
    ref = local_search(S, X, starts, n, "exhaustive")
    out = local_search(S, X, starts, n, "exact-bounds")
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_array_equal(out.energies, ref.energies)


def test_the_bounded_search_is_exact_on_a_mix_of_smooth_and_rough_channels():
    # As in Eq. (2): smooth velocity and mask channels (used at level 1) next to
    # zero-mean detail channels (left to level 2 and the partial sums).
    g = np.random.default_rng(5)
    B, n, P = 16, 20, 6
    smooth = np.cumsum(np.cumsum(g.normal(size=(60, 60, 3)), 0), 1) / 30
    S = np.concatenate([smooth, 0.5 * g.normal(size=(60, 60, 2))], -1)
    starts = g.integers(0, 60 - B - n + 2, (P, 2))
    X = np.empty((P, B, B, 5))
    for p in range(P):
        y, x = starts[p] + g.integers(0, n, 2)
        X[p] = S[y : y + B, x : x + B] + 0.2 * g.normal(size=(B, B, 5))
    ref = local_search(S, X, starts, n, "exhaustive")
    out = local_search(S, X, starts, n, "exact-bounds")
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_array_equal(out.energies, ref.energies)
    assert out.evaluations.mean() < n * n / 4  # the bounds do rule most positions out
