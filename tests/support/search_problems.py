"""Random local-search problems for the turbulence search tests."""

import numpy as np


def problem(seed, shape=(40, 36), B=6, n=9, P=7, channels=5, smooth=False):
    """A source S, P target patches X near known windows, their windows' corners, n.

    Each target is a source patch inside its n x n window plus noise: a clear but not
    exact minimum, so the searches have something to find and ties are rare.
    """
    g = np.random.default_rng(seed)
    S = g.normal(size=(*shape, channels))
    if smooth:  # flow-like: low frequencies dominate, as in the sample flows
        S = np.cumsum(np.cumsum(S, 0), 1) / 30 + 0.1 * S
    starts = np.stack(
        [g.integers(0, shape[0] - B - n + 2, P), g.integers(0, shape[1] - B - n + 2, P)], -1
    )
    X = np.empty((P, B, B, channels))
    for p in range(P):
        y, x = starts[p] + g.integers(0, n, 2)
        X[p] = S[y : y + B, x : x + B] + 0.3 * g.normal(size=(B, B, channels))
    return S, X, starts, n
