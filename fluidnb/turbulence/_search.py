"""The local patch search of Eq. (2) and its strategies (seed section 3, Table 1).

Every strategy solves the same problem: for each target patch ``X[p]`` (``B x B``
cells, ``C`` feature channels) find, among the ``n x n`` positions of its window
in the source feature image ``S``, the position minimising the energy

    E(q) = sum over the patch and channels of (X[p] - S[q + .])^2.

The weights of Eq. (2) are folded into the channels beforehand (a channel scaled by
``sqrt(alpha)`` contributes ``alpha`` times its squared difference), so one plain
sum of squared differences serves every term.

The paper's strategies (exhaustive, uniform interval, adaptive) share one compiled
energy kernel, so their timings compare the number of positions they visit, as the
paper's do. The two exact searches go beyond the paper and return exactly the
exhaustive answer:

- ``exact-fft`` expands ``||X - Z||^2 = ||X||^2 - 2 X.Z + ||Z||^2``: box sums give
  ``||Z||^2`` everywhere and one FFT correlation per patch gives ``X.Z`` at all
  window positions at once; the few positions within round-off of the minimum are
  then measured directly, so ties resolve as the exhaustive search resolves them.
- ``exact-bounds`` rules positions out by lower bounds that cost a few operations
  (the same expansion restricted to each channel's mean and spread over the patch
  and its quarters, from box sums), measures the survivors in full, and stops a
  measurement as soon as its partial sum exceeds the best so far (successive
  elimination and partial distance elimination, as in block-matching motion
  search). No position that could be the minimum is skipped.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.fft
from numba import njit

__all__ = ["SearchResult", "local_search", "window_positions"]


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
        How many full patch energies were computed (the exact searches count the
        positions they measured in full).
    seconds : float
        Wall time of the search (the whole frame).
    """

    positions: np.ndarray
    energies: np.ndarray
    evaluations: np.ndarray
    seconds: float


def window_positions(strategy, n, *, m0=8, interval=2, best=None):
    """The window offsets a strategy visits, in order (for pictures and teaching).

    Parameters
    ----------
    strategy : str
        ``"exhaustive"``, ``"interval"`` or ``"adaptive"``.
    n : int
        Positions per axis of the window.
    m0, interval : int
        As in :class:`TurbulenceParams`.
    best : callable, optional
        ``best(offsets) -> (row, col)``, the adaptive search's choice among the
        offsets measured so far in a round (default: the one nearest the window's
        centre, a stand-in for real energies).

    Returns
    -------
    list of ndarray, shape (k, 2)
        One array per round (one round for the non-adaptive strategies).

    Examples
    --------
    >>> [len(r) for r in window_positions("adaptive", 32, m0=8)]
    [16, 24, 24, 24]
    """
    if strategy in ("exhaustive", "interval"):
        m = 1 if strategy == "exhaustive" else interval
        g = np.arange(0, n, m)
        return [np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)]
    if strategy != "adaptive":
        raise ValueError(
            f"strategy must be 'exhaustive', 'interval' or 'adaptive', got {strategy!r}"
        )

    def nearest_centre(pts):
        return tuple(pts[np.argmin(((np.asarray(pts) - (n - 1) / 2) ** 2).sum(1))])

    pick = best or nearest_centre
    g = np.arange(0, n, m0)
    rounds = [np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)]
    cy, cx = pick(rounds[0])
    m = m0
    while m > 1:
        half = m // 2
        pts = [
            (a, b)
            for a in range(cy - m, cy + m + 1, half)
            for b in range(cx - m, cx + m + 1, half)
            if 0 <= a < n and 0 <= b < n and (a, b) != (cy, cx)
        ]
        rounds.append(np.array(pts, dtype=int).reshape(-1, 2))
        cy, cx = pick(rounds[-1] if not pts else np.vstack([[cy, cx], rounds[-1]]))
        m = half
    return rounds


def local_search(S, X, starts, n, strategy, *, m0=8, interval=2):
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

    Returns
    -------
    SearchResult
    """
    S = np.ascontiguousarray(S, dtype=np.float64)
    X = np.ascontiguousarray(X, dtype=np.float64)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    h, w, c = S.shape
    p, B = X.shape[:2]
    S2 = S.reshape(h, w * c)
    X2 = X.reshape(p, B, B * c)
    t0 = time.perf_counter()
    if strategy == "exhaustive":
        off, e, k = _grid_search(S2, X2, starts, n, 1, c)
    elif strategy == "interval":
        off, e, k = _grid_search(S2, X2, starts, n, interval, c)
    elif strategy == "adaptive":
        off, e, k = _adaptive_search(S2, X2, starts, n, m0, c)
    elif strategy == "exact-fft":
        off, e, k = _fft_search(S, X, S2, X2, starts, n)
    elif strategy == "exact-bounds":
        off, e, k = _bounds_search(S, X, S2, X2, starts, n)
    else:
        from ._params import STRATEGIES

        raise ValueError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    seconds = time.perf_counter() - t0
    return SearchResult(starts + off, e, k, seconds)


# -- the paper's strategies: one energy kernel ---------------------------------------


@njit(cache=True, fastmath=True)
def _row_ssd(S2, X2, p, y, o, i):
    # A patch row is a contiguous run of B * C values in both arrays, so this loop
    # vectorises (fastmath lets it reorder this row's sum; rows add up in order).
    # Both runs are taken as slices: indexing ``row[o + k]`` instead would make
    # numba guard every access against negative (wrap-around) indices, which
    # blocks vectorisation and made every search 2.5-4x slower.
    xr = X2[p, i]
    row = S2[y, o : o + xr.shape[0]]
    e = 0.0
    for k in range(xr.shape[0]):
        d = xr[k] - row[k]
        e += d * d
    return e


@njit(cache=True)
def _ssd(S2, X2, p, y, x, c):
    e = 0.0
    for i in range(X2.shape[1]):
        e += _row_ssd(S2, X2, p, y + i, x * c, i)
    return e


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
    # Seed section 3: sample the window every m0 positions, then around the best so
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


# -- exact search 1: correlation through FFTs ---------------------------------------


def _box_sums(a, size):
    """Sums of ``a`` (H, W, ...) over every ``size x size`` box, by an integral image."""
    h, w = a.shape[:2]
    ii = np.zeros((h + 1, w + 1, *a.shape[2:]))
    np.cumsum(a, axis=0, out=ii[1:, 1:])
    np.cumsum(ii[1:, 1:], axis=1, out=ii[1:, 1:])
    return ii[size:, size:] - ii[:-size, size:] - ii[size:, :-size] + ii[:-size, :-size]


def _fft_search(S, X, S2, X2, starts, n):
    P, B = X.shape[:2]
    L = n + B - 1  # a window's source region
    F = scipy.fft.next_fast_len(L, real=True)  # circular wrap never reaches the valid part
    z2 = _box_sums((S * S).sum(-1), B)  # ||Z(q)||^2 at every position
    rows = starts[:, :1] + np.arange(L)
    cols = starts[:, 1:] + np.arange(L)
    region = S[rows[:, :, None], cols[:, None, :]]  # (P, L, L, C)
    spec_r = scipy.fft.rfft2(region, s=(F, F), axes=(1, 2))
    spec_x = scipy.fft.rfft2(X, s=(F, F), axes=(1, 2))
    xz = scipy.fft.irfft2((spec_r * spec_x.conj()).sum(-1), s=(F, F), axes=(1, 2))[:, :n, :n]
    wy = starts[:, :1, None] + np.arange(n)[None, :, None]
    wx = starts[:, 1:, None] + np.arange(n)[None, None, :]
    energy = (X * X).sum((1, 2, 3))[:, None, None] - 2 * xz + z2[wy, wx]
    # Round-off of the expansion is ~1e-13 of the magnitudes; everything within a
    # generous margin of the minimum is measured directly, in raster order.
    flat = energy.reshape(P, -1)
    scale = (X * X).sum((1, 2, 3)) + flat.max(1)
    cand = flat <= flat.min(1, keepdims=True) + 1e-9 * scale[:, None]
    return _measure_candidates(S2, X2, starts, n, cand, S.shape[2])


@njit(cache=True)
def _measure_candidates(S2, X2, starts, n, cand, c):
    P = X2.shape[0]
    off = np.zeros((P, 2), np.int64)
    en = np.empty(P)
    ev = np.zeros(P, np.int64)
    for p in range(P):
        best, by, bx, count = np.inf, 0, 0, 0
        for k in range(n * n):
            if cand[p, k]:
                a, b = k // n, k % n
                e = _ssd(S2, X2, p, starts[p, 0] + a, starts[p, 1] + b, c)
                count += 1
                if e < best:
                    best, by, bx = e, a, b
        off[p, 0], off[p, 1], en[p], ev[p] = by, bx, best, count
    return off, en, ev


# -- exact search 2: lower bounds, then partial sums -----------------------------------


def _bounds_search(S, X, S2, X2, starts, n):
    P, B, _, c = X.shape
    # Three levels of boxes: the whole patch, its quarters, its sixteenths (as far
    # as B halves exactly). Finer levels bound tighter but cost more, so each level
    # only sees the positions the coarser ones could not rule out.
    sizes = [B]
    while sizes[-1] % 2 == 0 and len(sizes) < 3:
        sizes.append(sizes[-1] // 2)
    sizes += [sizes[-1]] * (3 - len(sizes))  # repeat the last level if B is odd
    channels_first = np.ascontiguousarray(S.transpose(2, 0, 1))  # (C, H, W)
    h, w = S.shape[:2]
    stats = []
    norm2 = np.zeros((h, w))  # ||Z||^2 of every whole patch
    for lv, size in enumerate(sizes):
        k = B // size
        tgt = (np.empty((P, k * k, c)), np.empty((P, k * k, c)))
        _patch_stats(X, size, *tgt)
        # Only the boxes that fit are written (and read).
        if lv == 0:  # read along window rows: channels first
            src = (np.empty((c, h, w)), np.empty((c, h, w)))
            _box_stats(channels_first, size, *src, norm2, np.empty((1, 1, 1, 2)), 0)
            stats += [*src, *tgt]
        else:  # read a position at a time: all its channels' numbers side by side
            side = np.empty((h, w, c, 2))
            none = np.empty((1, 1, 1))
            _box_stats(channels_first, size, none, none, norm2, side, 1)
            stats += [side, *tgt]
    return _bounds_kernel(S2, X2, starts, n, c, *sizes, norm2, *stats)


@njit(cache=True, fastmath=True)
def _box_stats(S, size, mean, spread, norm2, side, layout):
    # Mean and spread ||v - mean|| of every size x size box (by its top-left cell)
    # per channel, from running sums of the values and their squares: down the
    # columns, then along the rows (channels-first input, so the inner loops run
    # over contiguous rows and vectorise). layout 0: into mean[ch, y, x] and
    # spread[ch, y, x], plus the boxes' squared norms summed over channels into
    # norm2[y, x]; layout 1: into side[y, x, ch] = (mean, spread).
    c, h, w = S.shape
    hh, ww = h - size + 1, w - size + 1
    count = float(size * size)
    col1 = np.zeros(w)
    col2 = np.zeros(w)
    pre1 = np.zeros(w + 1)
    pre2 = np.zeros(w + 1)
    for ch in range(c):
        col1[:] = 0.0
        col2[:] = 0.0
        for i in range(size):
            for x in range(w):
                v = S[ch, i, x]
                col1[x] += v
                col2[x] += v * v
        for y in range(hh):
            if y > 0:
                for x in range(w):
                    a, b = S[ch, y + size - 1, x], S[ch, y - 1, x]
                    col1[x] += a - b
                    col2[x] += a * a - b * b
            for x in range(w):
                pre1[x + 1] = pre1[x] + col1[x]
                pre2[x + 1] = pre2[x] + col2[x]
            for x in range(ww):
                s1 = pre1[x + size] - pre1[x]
                s2 = pre2[x + size] - pre2[x]
                m = s1 / count
                v = np.sqrt(max(s2 - s1 * m, 0.0))
                if layout == 0:
                    mean[ch, y, x] = m
                    spread[ch, y, x] = v
                    norm2[y, x] += s2
                else:
                    side[y, x, ch, 0] = m
                    side[y, x, ch, 1] = v


@njit(cache=True)
def _patch_stats(X, size, mean, spread):
    # The same statistics for the (B / size)^2 boxes of every target patch.
    P, B, _, c = X.shape
    k = B // size
    count = float(size * size)
    for p in range(P):
        for j in range(k * k):
            y0, x0 = (j // k) * size, (j % k) * size
            for ch in range(c):
                s1 = 0.0
                s2 = 0.0
                for i in range(size):
                    for jj in range(size):
                        v = X[p, y0 + i, x0 + jj, ch]
                        s1 += v
                        s2 += v * v
                m = s1 / count
                mean[p, j, ch] = m
                spread[p, j, ch] = np.sqrt(max(s2 - s1 * m, 0.0))


@njit(cache=True, fastmath=True)
def _bound(stats, m_x, v_x, p, size, k, y, x):
    # ||x - z||^2 = count (mean_x - mean_z)^2 + ||x~ - z~||^2 over each box, where
    # x~, z~ are the values less their means, and ||x~ - z~|| >= | ||x~|| - ||z~|| |
    # (triangle inequality): a lower bound from two numbers per box and channel.
    # stats[y, x, channel] holds (mean, spread) of the box at (y, x).
    c = m_x.shape[2]
    count = float(size * size)
    lb = 0.0
    for j in range(k * k):
        yy, xx = y + (j // k) * size, x + (j % k) * size
        for ch in range(c):
            d = m_x[p, j, ch] - stats[yy, xx, ch, 0]
            r = v_x[p, j, ch] - stats[yy, xx, ch, 1]
            lb += count * d * d + r * r
    return lb


@njit(cache=True, fastmath=True)
def _level0_row(m0, v0, mx0, vx0, norm2, p, y, x0, count, qx, lb, slack):
    # Level 0 along one window row: vectorised over the row's positions.
    n = lb.shape[0]
    for b in range(n):
        lb[b] = 0.0
        # The stats carry round-off (a spread is the square root of a difference,
        # ~1e-8 of the norms): a bound rules a position out only when it clears
        # the best by far more than that.
        slack[b] = 1e-6 * (qx + norm2[y, x0 + b])
    for ch in range(m0.shape[0]):
        mx, vx = mx0[p, 0, ch], vx0[p, 0, ch]
        for b in range(n):
            d = mx - m0[ch, y, x0 + b]
            r = vx - v0[ch, y, x0 + b]
            lb[b] += count * d * d + r * r


@njit(cache=True)
def _bounds_kernel(
    S2, X2, starts, n, c, s0, s1, s2, norm2,
    m0, v0, mx0, vx0, st1, mx1, vx1, st2, mx2, vx2,
):  # fmt: skip
    P, B = X2.shape[0], X2.shape[1]
    off = np.zeros((P, 2), np.int64)
    en = np.empty(P)
    ev = np.zeros(P, np.int64)
    lb0 = np.empty(n * n)
    slack = np.empty(n * n)
    lb_row = np.empty(n)
    slack_row = np.empty(n)
    count0 = float(s0 * s0)
    for p in range(P):
        y0, x0 = starts[p, 0], starts[p, 1]
        qx = 0.0
        for ch in range(c):
            qx += count0 * mx0[p, 0, ch] ** 2 + vx0[p, 0, ch] ** 2
        # Level 0 (whole patch) at every position; start from the most promising.
        first = 0
        for a in range(n):
            _level0_row(m0, v0, mx0, vx0, norm2, p, y0 + a, x0, count0, qx, lb_row, slack_row)
            for b in range(n):
                k = a * n + b
                slack[k] = slack_row[b]
                lb0[k] = lb_row[b] - slack_row[b]
                if lb0[k] < lb0[first]:
                    first = k
        best = _ssd(S2, X2, p, y0 + first // n, x0 + first % n, c)
        by, bx, count = first // n, first % n, 1
        for k in range(n * n):
            if k == first:
                continue
            # Ties go to the first position in raster order, as in the exhaustive
            # search: after the best so far only a strictly lower energy wins.
            later = k > by * n + bx
            if lb0[k] > best or (later and lb0[k] >= best):
                continue
            a, b = k // n, k % n
            y, x = y0 + a, x0 + b
            lb = _bound(st1, mx1, vx1, p, s1, B // s1, y, x) - slack[k]
            if lb > best or (later and lb >= best):
                continue
            lb = _bound(st2, mx2, vx2, p, s2, B // s2, y, x) - slack[k]
            if lb > best or (later and lb >= best):
                continue
            # Partial distance elimination: stop once the sum of whole rows cannot
            # win (the row sums are the ones _ssd adds, in the same order).
            e = 0.0
            for i in range(B):
                e += _row_ssd(S2, X2, p, y + i, x * c, i)
                if e > best or (later and e >= best):
                    break
            count += 1
            if e < best or (e == best and not later):
                best, by, bx = e, a, b
        off[p, 0], off[p, 1], en[p], ev[p] = by, bx, best, count
    return off, en, ev
