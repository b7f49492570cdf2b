"""The local patch search of Eq. (2) and the paper's strategies (Watanabe et al., sec. 3, Table 1).

Every strategy solves the same problem: for each target patch ``X[p]`` (``B x B``
cells, ``C`` feature channels) find, among the ``n x n`` positions of its window
in the source feature image ``S``, the position minimising the energy

    E(q) = sum over the patch and channels of (X[p] - S[q + .])^2.

The weights of Eq. (2) are folded into the channels beforehand (a channel scaled by
``sqrt(alpha)`` contributes ``alpha`` times its squared difference), so one plain
sum of squared differences serves every term.

The paper's strategies (exhaustive, uniform interval, adaptive) are here, compiled,
and share one energy kernel (:mod:`._kernel`), so their timings compare the number of
positions they visit, as the paper's do. :mod:`._reference` writes the same three
strategies in a few lines of plain numpy (the tests check that both agree), and
:mod:`._exact` holds the two exact searches that go beyond the paper
(``exact-fft``, ``exact-bounds``): :func:`local_search` dispatches to all five.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

from ._exact import bounds_search, fft_search
from ._kernel import _ssd

__all__ = ["SearchResult", "local_search"]


@dataclass(frozen=True, eq=False)
class SearchResult:
    """What a local search found for every patch of one frame.

    Attributes
    ----------
    positions : ndarray of int, shape (P, 2)
        Top-left source cell (row, col) of the best patch found.
    energies : ndarray, shape (P,)
        Its energy :math:`E_h` (Eq. 2).
    evaluations : ndarray of int, shape (P,)
        How many positions' energies were measured directly (``exact-bounds``
        counts those it measured in full or until a partial sum ruled them out).
    seconds : float
        Wall time of the search (the whole frame).
    """

    positions: np.ndarray
    energies: np.ndarray
    evaluations: np.ndarray
    seconds: float


def local_search(S, X, starts, n, strategy, *, m0=8, interval=2, hint=None):
    """Find each patch's best window position with one strategy.

    Parameters
    ----------
    S : ndarray, shape (H, W, C)
        Source features (weights folded in), float64.
    X : ndarray, shape (P, B, B, C)
        Target patches, float64.
    starts : ndarray of int, shape (P, 2)
        Top-left source cell of each patch's window; the window's positions are
        ``starts + (0..n-1, 0..n-1)`` and must all fit in ``S``.
    n : int
        Positions per axis of the window.
    strategy : str
        One of :data:`fluidnb.turbulence.STRATEGIES`.
    m0, interval : int
        The adaptive search's first interval and the uniform search's interval.
    hint : ndarray of int, shape (P, 2), optional
        A likely position per patch (source cells), e.g. the previous frame's
        choice. ``exact-bounds`` measures it first, which lets its bounds rule
        more positions out sooner; the answer does not depend on it. The other
        strategies ignore it.

    Returns
    -------
    SearchResult
    """
    if hint is not None:
        hint = np.asarray(hint)
        if hint.shape != (len(X), 2) or not np.issubdtype(hint.dtype, np.integer):
            raise ValueError(
                f"hint must be integer positions of shape ({len(X)}, 2), "
                f"got {hint.dtype} of shape {hint.shape}"
            )
    S = np.ascontiguousarray(S, dtype=np.float64)
    X = np.ascontiguousarray(X, dtype=np.float64)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    h, w, c = S.shape
    p, B = X.shape[:2]
    S2 = S.reshape(h, w * c)  # a patch row is one contiguous run (see _kernel)
    X2 = X.reshape(p, B, B * c)
    t0 = time.perf_counter()
    if strategy == "exhaustive":
        off, e, k = _grid_search(S2, X2, starts, n, 1, c)
    elif strategy == "interval":
        off, e, k = _grid_search(S2, X2, starts, n, interval, c)
    elif strategy == "adaptive":
        off, e, k = _adaptive_search(S2, X2, starts, n, m0, c)
    elif strategy == "exact-fft":
        off, e, k = fft_search(S, X, starts, n)
    elif strategy == "exact-bounds":
        off, e, k = bounds_search(S, X, starts, n, hint)
    else:
        from ._params import STRATEGIES

        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    seconds = time.perf_counter() - t0
    return SearchResult(starts + off, e, k, seconds)


# -- the paper's strategies, on the shared energy kernel ------------------------------


@njit(cache=True)
def _scan(S2, X2, p, y0, x0, n, m, c):
    # Every m-th position of patch p's window in raster order: (best, row, col, count).
    best, by, bx, count = np.inf, 0, 0, 0
    for a in range(0, n, m):
        for b in range(0, n, m):
            e = _ssd(S2, X2, p, y0 + a, x0 + b, c)
            count += 1
            if e < best:
                best, by, bx = e, a, b
    return best, by, bx, count


@njit(cache=True)
def _grid_search(S2, X2, starts, n, m, c):
    P = X2.shape[0]
    off = np.zeros((P, 2), np.int64)
    en = np.empty(P)
    ev = np.zeros(P, np.int64)
    for p in range(P):
        en[p], off[p, 0], off[p, 1], ev[p] = _scan(S2, X2, p, starts[p, 0], starts[p, 1], n, m, c)
    return off, en, ev


@njit(cache=True)
def _adaptive_search(S2, X2, starts, n, m0, c):
    # Watanabe et al., sec. 3: sample the window every m0 positions, then around the best so
    # far every m/2 positions over -m..+m (a 5 x 5 grid less its centre, already
    # measured), until the interval is 1.
    P = X2.shape[0]
    off = np.zeros((P, 2), np.int64)
    en = np.empty(P)
    ev = np.zeros(P, np.int64)
    for p in range(P):
        y0, x0 = starts[p, 0], starts[p, 1]
        best, by, bx, count = _scan(S2, X2, p, y0, x0, n, m0, c)
        m = m0
        while m > 1:
            half = m // 2
            cy, cx = by, bx
            for a in range(cy - m, cy + m + 1, half):
                if a < 0 or a >= n:
                    continue
                for b in range(cx - m, cx + m + 1, half):
                    if b < 0 or b >= n or (a == cy and b == cx):
                        continue
                    e = _ssd(S2, X2, p, y0 + a, x0 + b, c)
                    count += 1
                    if e < best or (e == best and (a < by or (a == by and b < bx))):
                        best, by, bx = e, a, b
            m = half
        off[p, 0], off[p, 1], en[p], ev[p] = by, bx, best, count
    return off, en, ev
