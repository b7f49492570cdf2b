"""The float32 pyramids' reduce and expand for exact halvings, filter and resampling fused.

``reduce`` is the blur followed by the halving. When a level halves exactly (even
sides), the halving is the mean of each 2 x 2 block, so most of the blurred pixels
are never used: filtering and decimating in one step (a stride-2 filter with the
10-tap kernel ``k2[t] = (k[t] + k[t - 1]) / 2``) computes only the pixels kept.
``expand`` to exactly twice the size is the bilinear doubling (weights 1/4, 3/4)
followed by the blur: per output parity (polyphase) one 7-tap kernel on the coarse
level. The library's border (half-sample symmetric, "reflect") carries over
exactly: the bilinear doubling of the coarse level reflected is the doubled level
reflected. So both equal the blur-then-resample (and resample-then-blur) pyramids of
:mod:`fluidnb.fields._pyramid` up to float32 round-off, which its tests check against
the float64 pyramids (the literal definition, scipy.ndimage).

Every function takes and returns C-contiguous float32 (h, w, C) arrays; the passes
run row by row over whole rows (``w * C`` values), which the compiler vectorises.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# Private kernels of the float32 pyramids (fluidnb.fields._pyramid): nothing public.
__all__: list[str] = []


def reduce_kernel(k):
    """The stride-2 kernel of blur ``k`` (2r + 1 taps) then the 2-tap mean: 2r + 2 taps."""
    k = np.asarray(k, dtype=np.float64)
    k2 = 0.5 * (np.concatenate([k, [0.0]]) + np.concatenate([[0.0], k]))
    return k2.astype(np.float32)


def expand_kernels(k):
    """The two polyphase kernels of the bilinear doubling then blur ``k``, and their offset.

    Output ``2m + p`` is ``sum_d kernels[p, d] * x[m + d + d0]``: the blurred pixel
    ``2m + p`` gathers the doubled pixels ``2m + p + t`` (|t| <= r), and doubled pixel
    ``2a`` is ``x[a - 1] / 4 + 3 x[a] / 4``, ``2a + 1`` is ``3 x[a] / 4 + x[a + 1] / 4``.
    """
    k = np.asarray(k, dtype=np.float64)
    r = len(k) // 2
    taps = {}
    for p in (0, 1):
        for t in range(-r, r + 1):
            a, odd = divmod(p + t, 2)
            pairs = ((a, 0.75), (a + 1, 0.25)) if odd else ((a - 1, 0.25), (a, 0.75))
            for d, w in pairs:
                taps[p, d] = taps.get((p, d), 0.0) + k[t + r] * w
    d0 = min(d for _, d in taps)
    d1 = max(d for _, d in taps)
    kernels = np.zeros((2, d1 - d0 + 1))
    for (p, d), w in taps.items():
        kernels[p, d - d0] = w
    return kernels.astype(np.float32), d0


@njit(cache=True, nogil=True)
def _reflect(i, n):
    """Index ``i`` into ``0..n-1`` reflected half-sample ("fedcba|abcdef")."""
    while i < 0 or i >= n:
        i = -i - 1 if i < 0 else 2 * n - i - 1
    return i


@njit(cache=True, nogil=True)
def _axpy(acc, c, src, start, n):
    """``acc[:n] += c * src[start:start + n]``."""
    s = src[start : start + n]
    for q in range(n):
        acc[q] += c * s[q]


@njit(cache=True, nogil=True)
def _reduce_fused(x, k2, out):
    """``out`` (h/2, w/2, C) = blur then 2 x 2 mean of ``x`` (h, w, C), h and w even."""
    h, w, nc = x.shape
    r = (k2.size - 2) // 2
    wide = w * nc
    rows = x.reshape(h, wide)
    col = np.empty(wide, np.float32)  # the column filter's row of output
    # The row's columns reflected and split by parity: even[a] is column 2a - r.
    half = (w + 2 * r + 2) // 2
    even = np.empty(half * nc, np.float32)
    odd = np.empty(half * nc, np.float32)
    n_out = (w // 2) * nc
    flat = out.reshape(h // 2, n_out)  # whole rows (a contiguous view: vectorised)
    for i in range(h // 2):
        col[:] = 0.0
        for t in range(k2.size):
            _axpy(col, k2[t], rows[_reflect(2 * i + t - r, h)], 0, wide)
        for a in range(half):
            e = _reflect(2 * a - r, w) * nc
            o = _reflect(2 * a + 1 - r, w) * nc
            for ch in range(nc):
                even[a * nc + ch] = col[e + ch]
                odd[a * nc + ch] = col[o + ch]
        dst = flat[i]
        dst[:] = 0.0
        for t in range(k2.size):
            _axpy(dst, k2[t], even if t % 2 == 0 else odd, (t // 2) * nc, n_out)


@njit(cache=True, nogil=True)
def _expand_fused(x, kernels, d0, base, sign, out):
    """``out`` (2h, 2w, C) = ``base + sign * expand(x)`` for ``x`` (h, w, C).

    ``expand`` is the bilinear doubling then the blur; ``base`` (2h, 2w, C) or None
    (then ``sign`` must be 1: the expansion alone).
    """
    h, w, nc = x.shape
    taps = kernels.shape[1]
    pad = max(-d0, d0 + taps - 1)
    n_row = w * nc
    wide = 2 * n_row
    # The rows doubled along the width first (h rows), then along the height.
    across = np.empty((h, wide), np.float32)
    ext = np.empty((w + 2 * pad) * nc, np.float32)
    phase = np.empty(n_row, np.float32)
    for i in range(h):
        for a in range(w + 2 * pad):
            s = _reflect(a - pad, w)
            for ch in range(nc):
                ext[a * nc + ch] = x[i, s, ch]
        for p in range(2):
            phase[:] = 0.0
            for d in range(taps):
                if kernels[p, d] != 0.0:  # each phase has one tap fewer
                    _axpy(phase, kernels[p, d], ext, (d + d0 + pad) * nc, n_row)
            for m in range(w):
                for ch in range(nc):
                    across[i, (2 * m + p) * nc + ch] = phase[m * nc + ch]
    flat = out.reshape(2 * h, wide)
    acc = np.empty(wide, np.float32)
    for i in range(2 * h):
        m, p = divmod(i, 2)
        acc[:] = 0.0
        for d in range(taps):
            if kernels[p, d] != 0.0:
                _axpy(acc, kernels[p, d], across[_reflect(m + d + d0, h)], 0, wide)
        dst = flat[i]
        if base is None:
            dst[:] = acc
        else:
            src = base.reshape(2 * h, wide)[i]
            for q in range(wide):
                dst[q] = src[q] + sign * acc[q]
