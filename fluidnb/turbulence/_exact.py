"""Two exact local searches, beyond the paper: the exhaustive answer, found faster.

Watanabe et al. (sec. 3, Table 1) make the local search of Eq. (2) faster by visiting
fewer window positions (uniform sampling, the adaptive coarse-to-fine search), at the
cost of sometimes missing the minimum. The searches here visit none fewer in effect:
they return exactly the exhaustive search's positions and energies, by doing less work
per position.

- ``exact-fft`` expands ``||X - Z||^2 = ||X||^2 - 2 X.Z + ||Z||^2``: box sums give
  ``||Z||^2`` everywhere and one FFT correlation per patch gives ``X.Z`` at all
  window positions at once; the few positions within round-off of the minimum are
  then measured directly, so ties resolve as the exhaustive search resolves them.
- ``exact-bounds`` rules positions out by lower bounds that cost a few operations
  (``||x - z||^2 >= (sum x - sum z)^2 / k`` over boxes of ``k`` cells: the patch's
  quarters at every window position, column sums over four bands of rows where
  that is not enough), measures the survivors row by row, and stops a measurement
  as soon as its partial sum plus the bound on the remaining rows exceeds the best so far
  (successive and partial distance elimination, as in block-matching motion
  search). No position that could be the minimum is skipped. Started from a hint
  (the previous frame's choice, in :func:`~fluidnb.turbulence.synthesize`), it
  needs to measure fewer positions.

Both are reached through :func:`fluidnb.turbulence.local_search` (``strategy=
"exact-fft"`` or ``"exact-bounds"``); the lesson's appendix
(``notebooks/06b_turbulence_appendix.ipynb``) derives them.
"""

from __future__ import annotations

import threading

import numpy as np
import scipy.fft
from numba import njit, uint64

from ._kernel import _row_ssd, _ssd

__all__ = ["bounds_search", "fft_search"]


def fft_search(S, X, starts, n):
    """The exhaustive search's answer by FFT correlation; returns (offsets, energies, counts)."""
    h, w, c = S.shape
    p, B = X.shape[:2]
    return _fft_search(S, X, S.reshape(h, w * c), X.reshape(p, B, B * c), starts, n)


def bounds_search(S, X, starts, n, hint=None):
    """The exhaustive search's answer by lower bounds; returns (offsets, energies, counts)."""
    h, w, c = S.shape
    p, B = X.shape[:2]
    S2, X2 = S.reshape(h, w * c), X.reshape(p, B, B * c)
    return _bounds_search(S2, X2, starts, n, c, _hint_offsets(hint, starts, n))


def _hint_offsets(hint, starts, n):
    """Window offsets ``a * n + b`` of the hinted positions, -1 where none or outside."""
    if hint is None:
        return np.full(len(starts), -1, np.int64)
    return _offsets_in_window(hint.astype(np.int64, copy=False), starts, n)


@njit(cache=True)
def _offsets_in_window(pos, starts, n):
    out = np.empty(len(starts), np.int64)
    for p in range(len(starts)):
        a, b = pos[p, 0] - starts[p, 0], pos[p, 1] - starts[p, 1]
        out[p] = a * n + b if 0 <= a < n and 0 <= b < n else -1
    return out


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


# -- exact search 2: lower bounds from box sums, then partial sums ---------------------
#
# Successive elimination (as in block-matching motion search): for any boxes covering
# part of a patch, ||X - Z||^2 >= sum over the boxes of (sum_box X - sum_box Z)^2 / size
# (Cauchy-Schwarz on each box). With s = B // 4, two levels of boxes are used:
#
# - level 1, the patch's 2 x 2 quarters (2s x 2s), at *every* window position, a
#   window row at a time (vectorised), over the channels whose quarter sums carry most
#   of their energy (velocity and mask; the detail channels are nearly zero-mean over
#   a quarter, cost the most and rule almost nothing out);
# - level 2, columns s cells tall: four bands of s rows, each cut into its B columns,
#   in every channel, only where level 1 could not rule the position out. A band's
#   column sums are one contiguous run of B * C values in the source's column sums
#   (like a patch row), so this level costs a quarter of a full measurement and is
#   much tighter than level 1. Each band also bounds the rows a partial sum has not
#   reached.
#
# The first position measured in full is a hint (last frame's choice) or level 1's
# minimum; the others follow in raster order, so ties resolve as in the exhaustive
# search. The sums are stored in float32 (half the memory traffic, twice the vector
# width); _threshold widens every comparison by a margin that covers their round-off,
# so no position that could win is skipped.

_WORKSPACE = threading.local()  # per-thread buffers, reused from frame to frame


def _bounds_search(S2, X2, starts, n, c, hint):
    P, B = X2.shape[:2]
    if B < 4:  # too small for 4 bands: measure everything
        return _measure_candidates(S2, X2, starts, n, np.ones((P, n * n), np.bool_), c)
    s = B // 4
    h, w = S2.shape[0], S2.shape[1] // c
    key = (h, w, c, P, B)
    if getattr(_WORKSPACE, "key", None) != key:
        hh, ww = h - s + 1, w - s + 1
        _WORKSPACE.key = key
        _WORKSPACE.arrays = (
            np.empty((P, 4, B * c), np.float32),  # the patches' column sums per band
            np.empty((P, c, 2, 2), np.float32),  # their quarter sums
            np.empty(P),  # their squared norms
            np.empty(c, np.int64),  # the level-1 channels
            np.empty((hh, w * c), np.float32),  # the source's column sums
            np.empty((c, hh, ww), np.float32),  # s x s box sums, level-1 channels
            np.empty((c, hh - s, ww - s), np.float32),  # quarter sums
            np.empty(2 * w * c),  # row buffers
        )
    xcol, x8, qx, chans, col, box, quarter, row = _WORKSPACE.arrays
    m = _patch_sums(X2, c, s, xcol, x8, qx, chans)
    _source_sums(S2, c, s, chans[:m], col, box[:m], quarter[:m], row)
    return _bounds_kernel(S2, X2, starts, n, c, s, quarter, col, chans[:m], x8, xcol, qx, hint)


@njit(cache=True, fastmath=True)
def _source_sums(S2, c, s, chans, col, box, quarter, row):
    # The source's sums, accumulated in float64 and stored in float32:
    # - col[y, x * c + ch]: column sums over rows y .. y + s - 1 (S2's layout);
    # - box[m, y, x]: s x s box sums of channel chans[m], channels first;
    # - quarter[m, y, x]: 2s x 2s box sums, from four of box's.
    # Direct sums (no running differences), so each sum's round-off is relative to
    # its own cells.
    L = S2.shape[1]
    m_count, hh, ww = box.shape
    for y in range(hh):
        r = S2[y]
        for k in range(L):
            row[k] = r[k]
        for i in range(1, s):
            r = S2[y + i]
            for k in range(L):
                row[k] += r[k]
        o = col[y]
        for k in range(L):
            o[k] = row[k]
        # along the row: s consecutive columns (channels interleaved, so offsets of c)
        LL = ww * c
        hsum = row[L : L + LL]
        for k in range(LL):
            hsum[k] = row[k]
        for j in range(1, s):
            rj = row[j * c : j * c + LL]
            for k in range(LL):
                hsum[k] += rj[k]
        for m in range(m_count):
            ch = chans[m]
            b = box[m, y]
            for x in range(ww):
                b[x] = hsum[x * c + ch]
    for m in range(m_count):
        for y in range(hh - s):
            a, b, q = box[m, y], box[m, y + s], quarter[m, y]
            a1, b1 = a[s : s + ww - s], b[s : s + ww - s]
            for x in range(ww - s):
                q[x] = a[x] + a1[x] + b[x] + b1[x]


@njit(cache=True, fastmath=True)
def _patch_sums(X2, c, s, xcol, x8, qx, chans):
    # For every target patch: xcol[p, i, j * c + ch], the column sums of band i (rows
    # i*s .. i*s + s - 1), column j, channel ch; x8[p, ch, i, j], its 2 x 2 quarters
    # (2s x 2s); qx[p], its squared norm. chans[:m] (m returned): the channels whose
    # quarter sums carry at least half of their energy over all patches (level 1
    # uses those; all of them if none does, e.g. a zero target).
    P, B, L = X2.shape
    acc = np.empty(L)
    sq = np.empty(L)
    sq_all = np.zeros(L)
    captured = np.zeros(c)
    for p in range(P):
        sq[:] = 0.0
        for i in range(B):
            r = X2[p, i]
            for t in range(L):
                sq[t] += r[t] * r[t]
        q = 0.0
        for t in range(L):
            q += sq[t]
            sq_all[t] += sq[t]
        qx[p] = q
        for band in range(4):
            acc[:] = 0.0
            for i in range(s):
                r = X2[p, band * s + i]
                for t in range(L):
                    acc[t] += r[t]
            xb = xcol[p, band]
            for t in range(L):
                xb[t] = acc[t]
        xq = x8[p]
        xq[:] = 0.0
        for band in range(4):
            xb = xcol[p, band]
            for j in range(2):  # the quarter's columns: 2s of them from j * 2s
                for k in range(j * 2 * s * c, (j + 1) * 2 * s * c, c):
                    for ch in range(c):
                        xq[ch, band >> 1, j] += xb[k + ch]
        for ch in range(c):
            for i in range(2):
                for j in range(2):
                    captured[ch] += float(xq[ch, i, j]) ** 2 / (4 * s * s)
    m = 0
    for ch in range(c):
        energy = 0.0
        for j in range(B):
            energy += sq_all[j * c + ch]
        if 2.0 * captured[ch] >= energy:
            chans[m] = ch
            m += 1
    if m == 0:
        for ch in range(c):
            chans[ch] = ch
        m = c
    return m


@njit(cache=True, fastmath=True)
def _level1_window(quarter, chans, x8, y0, x0, n, s2, lb):
    # Level 1 at every window position, a window row at a time (contiguous runs of
    # n positions, vectorised): lb[a * n + b] = sum over channels and quarters of
    # (x_sum - z_sum)^2 (divided by the quarter's size later).
    for a in range(n):
        o = lb[a * n : (a + 1) * n]
        for b in range(n):
            o[b] = 0.0
        for m in range(chans.shape[0]):
            for i in range(2):
                zrow = quarter[m, y0 + a + i * s2]
                for j in range(2):
                    sx = x8[chans[m], i, j]
                    zr = zrow[x0 + j * s2 : x0 + j * s2 + n]
                    for b in range(n):
                        d = sx - zr[b]
                        o[b] += d * d


@njit(cache=True, fastmath=True)
def _level2_bands(colf, zo, step, xcolf, xo, L, out):
    # Level 2 at one position, per band: out[i] = sum over band i's columns and
    # channels of (x_sum - z_sum)^2; returns their total. zo: the position's first
    # column sum in the flat colf, step: one band further down; xo: the patch's in
    # xcolf; L: B * c values per band. Unsigned flat indices (no wrap-around
    # guards) and float32 sums (no conversions), so each run vectorises. (Not
    # inlined: numba would compile it with the caller's strict float semantics.)
    total = 0.0
    for i in range(4):
        z, x = uint64(zo + i * step), uint64(xo + i * L)
        e = np.float32(0.0)
        for t in range(uint64(L)):
            d = xcolf[x + t] - colf[z + t]
            e += d * d
        out[i] = e
        total += e
    return total


@njit(cache=True)
def _threshold(best, qx):
    # A bound from the float32 sums differs from its exact value by at most
    # 2 sqrt(lb t) + t, t = 1e-12 (||X|| + sqrt(best))^2 for any position that could
    # still reach best (the sums' round-off is below 1e-7 of their cells' norms, and
    # such a position's ||Z|| <= ||X|| + sqrt(best)), and by 1e-4 relative for the
    # float32 arithmetic. It rules a position out only above this.
    t = 1e-12 * (np.sqrt(qx) + np.sqrt(best)) ** 2
    r = np.sqrt(t) + np.sqrt(best + 2.0 * t)
    return r * r * (1.0 + 1e-4)


@njit(cache=True)
def _bounds_kernel(S2, X2, starts, n, c, s, quarter, col, chans, x8, xcol, qx, hint):
    P, B = X2.shape[0], X2.shape[1]
    W = col.shape[1]
    colf, xcolf = col.ravel(), xcol.ravel()
    off = np.zeros((P, 2), np.int64)
    en = np.empty(P)
    ev = np.zeros(P, np.int64)
    lb = np.empty(n * n, np.float32)
    part = np.empty(4)
    size1, size2 = float(4 * s * s), float(s)
    L = B * c
    for p in range(P):
        y0, x0 = starts[p, 0], starts[p, 1]
        _level1_window(quarter, chans, x8[p], y0, x0, n, 2 * s, lb)
        # The first position measured in full: the hint, else level 1's minimum.
        kb = hint[p] if hint[p] >= 0 else np.argmin(lb)
        best = _ssd(S2, X2, p, y0 + kb // n, x0 + kb % n, c)
        first = kb
        thr = _threshold(best, qx[p])
        t1, t2 = thr * size1, thr * size2  # in the units of the raw sums
        count = 1
        for a in range(n):
            y = y0 + a
            for b in range(n):
                k = a * n + b
                # Ties go to the first position in raster order: a later one must
                # beat best strictly, so its bound may not even reach it.
                later = k > kb
                lv = lb[k]
                if lv > t1 or (later and lv >= t1) or k == first:
                    continue
                x = x0 + b
                lv = _level2_bands(colf, y * W + x * c, s * W, xcolf, p * 4 * L, L, part)
                if lv > t2 or (later and lv >= t2):
                    continue
                # Partial distance elimination: stop once the rows summed so far,
                # plus level 2's bound on the bands not reached, cannot win.
                after = part[1] + part[2] + part[3]
                e = 0.0
                in_band = 0
                for i in range(B):
                    e += _row_ssd(S2, X2, p, y + i, x * c, i)
                    if e > best or (later and e >= best):
                        break
                    in_band += 1
                    if in_band == s and i < 3 * s:  # the end of band i // s
                        in_band = 0
                        lv = e * size2 + after
                        if lv > t2 or (later and lv >= t2):
                            e = np.inf
                            break
                        after -= part[i // s + 1]
                count += 1
                if e < best or (e == best and not later):
                    best, kb = e, k
                    thr = _threshold(best, qx[p])
                    t1, t2 = thr * size1, thr * size2
        off[p, 0], off[p, 1], en[p], ev[p] = kb // n, kb % n, best, count
    return off, en, ev
