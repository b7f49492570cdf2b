"""The compiled searches equal the plain-numpy searches written in the paper's notation."""

import numpy as np
import pytest

from fluidnb.fields import advect
from fluidnb.turbulence import (
    TurbulenceParams,
    global_search,
    local_features,
    local_search,
    sample_flows,
    synthesize,
)
from fluidnb.turbulence._reference import (
    E_h,
    E_l,
    energy,
    global_search_reference,
    local_search_reference,
)
from tests.support.search_problems import problem as search_problem


def problem(seed, **kw):
    """A smaller problem than the search tests' (the numpy searches are slow)."""
    return search_problem(seed, **{"shape": (30, 28), "B": 5, "n": 9, "P": 6, "channels": 4, **kw})


CASES = [
    ("exhaustive", {}),
    ("interval", {"interval": 2}),
    ("interval", {"interval": 4}),
    ("adaptive", {"m0": 4}),
    ("adaptive", {"m0": 8}),
    ("adaptive", {"m0": 2}),
]


@pytest.mark.parametrize(("strategy", "extra"), CASES)
@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("smooth", [False, True])
def test_the_compiled_search_equals_the_reference(strategy, extra, seed, smooth):
    S, X, starts, n = problem(seed, smooth=smooth, n=16 if "m0" in extra else 9)
    ref = local_search_reference(S, X, starts, n, strategy, **extra)
    out = local_search(S, X, starts, n, strategy, **extra)
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_allclose(out.energies, ref.energies, rtol=1e-12)
    np.testing.assert_array_equal(out.evaluations, ref.evaluations)


@pytest.mark.parametrize("strategy", ["exact-fft", "exact-bounds"])
@pytest.mark.parametrize("seed", range(3))
def test_the_exact_searches_equal_the_reference_exhaustive_search(strategy, seed):
    S, X, starts, n = problem(seed, smooth=True, B=8, n=10)
    ref = local_search_reference(S, X, starts, n, "exhaustive")
    out = local_search(S, X, starts, n, strategy)
    np.testing.assert_array_equal(out.positions, ref.positions)
    np.testing.assert_allclose(out.energies, ref.energies, rtol=1e-12)


def test_the_reference_exhaustive_search_is_the_brute_force_minimum():
    S, X, starts, n = problem(4)
    B = X.shape[1]
    ref = local_search_reference(S, X, starts, n, "exhaustive")
    for p, (y0, x0) in enumerate(starts):
        E = np.empty((n, n))
        for a in range(n):
            for b in range(n):
                E[a, b] = ((X[p] - S[y0 + a : y0 + a + B, x0 + b : x0 + b + B]) ** 2).sum()
        assert tuple(ref.positions[p] - starts[p]) == np.unravel_index(E.argmin(), E.shape)
    assert (ref.evaluations == n * n).all()


def test_ties_go_to_the_first_position_in_both():
    # Every position of a constant source ties: the first in raster order must win.
    S = np.ones((20, 20, 2))
    X = np.zeros((2, 4, 4, 2))
    starts = np.array([[0, 0], [3, 5]])
    for strategy in ("exhaustive", "interval", "adaptive"):
        ref = local_search_reference(S, X, starts, 8, strategy, m0=4)
        out = local_search(S, X, starts, 8, strategy, m0=4)
        np.testing.assert_array_equal(ref.positions, starts)
        np.testing.assert_array_equal(out.positions, starts)


@pytest.fixture(scope="module")
def run():
    target, source = sample_flows(6, scale=2)
    params = TurbulenceParams(strategy="exhaustive", alpha=2.0, beta=0.5)
    return synthesize(target, source, params)


def test_eq_2_term_by_term_is_the_folded_energy_the_searches_minimise(run):
    # local_features folds sqrt(alpha), sqrt(beta) into channels; E_h writes Eq. (2)
    # with its three terms. Both must agree at the positions the synthesis chose.
    prep, params, B = run.prepared, run.params, run.params.B
    _ty, tx = prep.tiles
    i = 4
    previous = advect(run.detail[i - 1], prep.U_t[i - 1])
    S, X = local_features(prep, i, previous, params)
    for p, (y, x) in enumerate(run.local_positions[i]):
        r, c = divmod(p, tx)
        tile = np.s_[r * B : (r + 1) * B, c * B : (c + 1) * B]
        here = np.s_[y : y + B, x : x + B]
        e = E_h(
            prep.U_t[i][tile],
            prep.D_t[i][tile],
            prep.U_sl[i][here],
            prep.D_s[i][here],
            params.alpha,
            params.beta,
            X_star=previous[tile],
            Z_star=prep.U_sh[i][here],
        )
        # float32 fields: the two forms round differently, in the 7th digit
        assert e == pytest.approx(energy(X[p], S[here]), rel=1e-5)
        assert e == pytest.approx(run.energies[i, p], rel=1e-5)


def test_the_compiled_global_search_equals_eq_1_written_out(run):
    prep = run.prepared
    for i in (0, 3, 5):
        q_ref, e_ref = global_search_reference(prep, i)
        q_l, e = global_search(prep, i)
        np.testing.assert_array_equal(q_l, q_ref)
        np.testing.assert_allclose(e, e_ref, rtol=1e-9, atol=1e-12)
    assert E_l(np.ones((2, 2, 2)), np.ones((2, 2)), 0, 0, alpha=3.0) == 8 + 3 * 4


def test_the_synthesis_search_equals_the_reference_on_real_features(run):
    prep, params = run.prepared, run.params
    i = 5
    previous = advect(run.detail[i - 1], prep.U_t[i - 1])
    S, X = local_features(prep, i, previous, params)
    starts = prep.window_starts(run.global_positions[i])
    for strategy in ("exhaustive", "adaptive"):
        ref = local_search_reference(S, X, starts, prep.window, strategy)
        out = local_search(S, X, starts, prep.window, strategy)
        np.testing.assert_allclose(out.energies, ref.energies, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(out.positions, ref.positions)
