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
The ``*_spans`` kernels are the same passes on runs of each row only (a multiband
blend's bands where their weights are not 0, and the Gaussian levels those read),
with the same sums in the same order: their values are those of the whole passes.
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


# --------------------------------------------------------------------------------------
# Weighted bands on spans: the blend's bands where their weight is not 0
# --------------------------------------------------------------------------------------

# A multiband blend multiplies each band L_l of a layer by the layer's weights G_l(W),
# which are 0 on much of the image (outside a layer's fragments and their reach). The
# kernels below compute the band only on the runs of each row where the weight is not
# 0 (spans: ``ptr`` (h + 1,) and ``spans`` (k, 2), row i's runs [c0, c1) being
# ``spans[ptr[i]:ptr[i + 1]]``), with the arithmetic of :func:`_expand_fused` and the
# blend's weighting, value for value.


@njit(cache=True, nogil=True)
def mask_spans(mask, gap=0):
    """The runs of True of each row of ``mask`` (h, w) bool: ``(ptr, spans)``.

    Runs fewer than ``gap`` pixels apart are one run (the pixels between included):
    a kernel's work per run costs as much as a few dozen pixels.
    """
    h, w = mask.shape
    ptr = np.zeros(h + 1, np.int64)
    found = np.empty((mask.size // 2 + h, 2), np.int64)
    k = 0
    for i in range(h):
        j = 0
        while j < w:
            if mask[i, j]:
                start = j
                while j < w and mask[i, j]:
                    j += 1
                if k > ptr[i] and start - found[k - 1, 1] < gap:
                    found[k - 1, 1] = j
                else:
                    found[k, 0] = start
                    found[k, 1] = j
                    k += 1
            else:
                j += 1
        ptr[i + 1] = k
    return ptr, found[:k].copy()


@njit(cache=True, nogil=True)
def expand_rows_needed(mask, h, kernels, d0):
    """Which pixels of the width-doubled coarse rows (h, 2w) an expansion needs.

    The second pass of :func:`_expand_fused` makes fine row ``2m + p`` from the
    width-doubled coarse rows ``reflect(m + d + d0)`` of its phase's non-zero taps:
    those rows are needed on the columns ``mask`` (2h, 2w) marks on the fine row.
    """
    out = np.zeros((h, mask.shape[1]), np.bool_)
    taps = kernels.shape[1]
    for i in range(mask.shape[0]):
        m, p = divmod(i, 2)
        for d in range(taps):
            if kernels[p, d] != 0.0:
                r = _reflect(m + d + d0, h)
                out[r] |= mask[i]
    return out


@njit(cache=True, nogil=True)
def _weighted_band_spans(x, kernels, d0, base, weight, a_ptr, a_spans, ptr, spans, out):
    """``out = weight * (base - expand(x))`` on the spans (``ptr``, ``spans``) only.

    ``x`` (h, w, C), ``base`` and ``out`` (2h, 2w, C), ``weight`` (2h, 2w, 1); ``out``
    is not written off the spans. ``a_ptr``, ``a_spans``: the spans of the
    width-doubled coarse rows that those need (:func:`expand_rows_needed`). The
    same sums in the same order as :func:`_expand_fused` with ``sign`` -1, then the
    product by the weight: each value is that of the full band weighted.
    """
    h, w, nc = x.shape
    taps = kernels.shape[1]
    pad = max(-d0, d0 + taps - 1)
    wide = 2 * w * nc
    sign = np.float32(-1.0)
    across = np.empty((h, wide), np.float32)  # written on a_spans only
    ext = np.empty((w + 2 * pad) * nc, np.float32)
    phase = np.empty(w * nc, np.float32)
    rows = x.reshape(h, w * nc)
    for i in range(h):
        row = across[i]
        for s in range(a_ptr[i], a_ptr[i + 1]):
            j0 = a_spans[s, 0]
            j1 = a_spans[s, 1]
            # The coarse columns whose doubled pixels hold j0..j1 - 1, reflected
            # around them as _expand_fused's whole row is.
            c0 = j0 // 2
            c1 = (j1 + 1) // 2
            if c0 >= pad and c1 + pad <= w:  # inside the row: no reflection
                src_row = rows[i]
                shift = c0 - pad
            else:
                for a in range(c1 - c0 + 2 * pad):
                    src = _reflect(c0 + a - pad, w)
                    for ch in range(nc):
                        ext[a * nc + ch] = x[i, src, ch]
                src_row = ext
                shift = 0
            n = (c1 - c0) * nc
            for p in range(2):
                phase[:n] = 0.0
                for d in range(taps):
                    if kernels[p, d] != 0.0:
                        _axpy(phase, kernels[p, d], src_row, (shift + d + d0 + pad) * nc, n)
                # The doubled columns 2m + p within j0..j1 - 1.
                m0 = max(c0, (j0 - p + 1) // 2)
                m1 = min(c1, (j1 - p + 1) // 2)
                if nc == 1:
                    row[2 * m0 + p : 2 * m1 + p : 2] = phase[m0 - c0 : m1 - c0]
                else:
                    for m in range(m0, m1):
                        j = (2 * m + p) * nc
                        q = (m - c0) * nc
                        for ch in range(nc):
                            row[j + ch] = phase[q + ch]
    flat = out.reshape(2 * h, wide)
    fine = base.reshape(2 * h, wide)
    gains = weight.reshape(2 * h, 2 * w)
    acc = np.empty(wide, np.float32)
    for i in range(2 * h):
        m, p = divmod(i, 2)
        for s in range(ptr[i], ptr[i + 1]):
            q0 = spans[s, 0] * nc
            n = (spans[s, 1] - spans[s, 0]) * nc
            acc[:n] = 0.0
            for d in range(taps):
                if kernels[p, d] != 0.0:
                    _axpy(acc, kernels[p, d], across[_reflect(m + d + d0, h)], q0, n)
            # Slices of the runs: contiguous views the compiler vectorises.
            dst = flat[i, q0 : q0 + n]
            src = fine[i, q0 : q0 + n]
            if nc == 1:
                g = gains[i, q0 : q0 + n]
                for q in range(n):
                    dst[q] = (src[q] + sign * acc[q]) * g[q]
            else:  # a pixel's frames, contiguous, times its weight
                g = gains[i, spans[s, 0] : spans[s, 1]]
                for j in range(g.size):
                    c = g[j]
                    for q in range(j * nc, (j + 1) * nc):
                        dst[q] = (src[q] + sign * acc[q]) * c


@njit(cache=True, nogil=True)
def weigh_spans(band, weight, ptr, spans):
    """``band *= weight`` (h, w, C) by (h, w, 1), in place, on the spans only."""
    h, w, nc = band.shape
    rows = band.reshape(h, w * nc)
    gains = weight.reshape(h, w)
    for i in range(h):
        row = rows[i]
        g = gains[i]
        for s in range(ptr[i], ptr[i + 1]):
            r = row[spans[s, 0] * nc : spans[s, 1] * nc]
            c = g[spans[s, 0] : spans[s, 1]]
            if nc == 1:
                for q in range(r.size):
                    r[q] *= c[q]
            else:
                for j in range(c.size):
                    for q in range(j * nc, (j + 1) * nc):
                        r[q] *= c[j]


@njit(cache=True, nogil=True)
def add_spans(acc, band, ptr, spans):
    """``acc += band`` (h, w, C), in place, on the spans only."""
    h, w, nc = band.shape
    a = acc.reshape(h, w * nc)
    b = band.reshape(h, w * nc)
    for i in range(h):
        ai = a[i]
        bi = b[i]
        for s in range(ptr[i], ptr[i + 1]):
            # Slices of the runs: contiguous views the compiler vectorises.
            sa = ai[spans[s, 0] * nc : spans[s, 1] * nc]
            sb = bi[spans[s, 0] * nc : spans[s, 1] * nc]
            for q in range(sa.size):
                sa[q] += sb[q]


@njit(cache=True, nogil=True)
def spans_mask(ptr, spans, w):
    """The mask (h, w) bool of the runs ``(ptr, spans)``: the inverse of :func:`mask_spans`."""
    h = ptr.size - 1
    mask = np.zeros((h, w), np.bool_)
    for i in range(h):
        for s in range(ptr[i], ptr[i + 1]):
            mask[i, spans[s, 0] : spans[s, 1]] = True
    return mask


@njit(cache=True, nogil=True)
def expand_reads(a_ptr, a_spans, h, w, kernels, d0):
    """The pixels of ``x`` (h, w) that :func:`_weighted_band_spans` reads, as a mask."""
    taps = kernels.shape[1]
    pad = max(-d0, d0 + taps - 1)
    mask = np.zeros((h, w), np.bool_)
    for i in range(h):
        for s in range(a_ptr[i], a_ptr[i + 1]):
            for a in range(a_spans[s, 0] // 2 - pad, (a_spans[s, 1] + 1) // 2 + pad):
                mask[i, _reflect(a, w)] = True
    return mask


@njit(cache=True, nogil=True)
def reduce_reads(ptr, spans, h, w, k2):
    """The pixels of ``x`` (h, w) that :func:`_reduce_spans` reads for these runs, a mask."""
    r = (k2.size - 2) // 2
    mask = np.zeros((h, w), np.bool_)
    for i in range(ptr.size - 1):
        for s in range(ptr[i], ptr[i + 1]):
            q0 = max(0, 2 * spans[s, 0] - r)
            q1 = min(w, 2 * (spans[s, 1] + (k2.size - 1) // 2) - r)
            for t in range(k2.size):
                mask[_reflect(2 * i + t - r, h), q0:q1] = True
    return mask


@njit(cache=True, nogil=True)
def _reduce_spans(x, k2, ptr, spans, out):
    """:func:`_reduce_fused` on the runs (``ptr``, ``spans``) of ``out`` only.

    ``out`` is not written off the runs; ``x`` is read only where
    :func:`reduce_reads` says. The same sums in the same order as
    :func:`_reduce_fused`: each value is that of the whole reduce.
    """
    h, w, nc = x.shape
    r = (k2.size - 2) // 2
    reach = (k2.size - 1) // 2  # the row filter reads even/odd[b .. b + reach]
    wide = w * nc
    rows = x.reshape(h, wide)
    col = np.empty(wide, np.float32)  # the column filter's row, on q0..q1 - 1
    half = (w + 2 * r + 2) // 2
    even = np.empty(half * nc, np.float32)
    odd = np.empty(half * nc, np.float32)
    flat = out.reshape(h // 2, (w // 2) * nc)
    for i in range(h // 2):
        for s in range(ptr[i], ptr[i + 1]):
            b0 = spans[s, 0]
            b1 = spans[s, 1]
            # The columns the row filter reads (reflected ones included: near an
            # edge the range reaches it).
            q0 = max(0, 2 * b0 - r)
            q1 = min(w, 2 * (b1 + reach) - r)
            n = (q1 - q0) * nc
            c = col[q0 * nc : q1 * nc]
            c[:] = 0.0
            for t in range(k2.size):
                _axpy(c, k2[t], rows[_reflect(2 * i + t - r, h)], q0 * nc, n)
            # even[a - b0] is column 2a - r, odd[a - b0] column 2a + 1 - r.
            inside = 2 * b0 - r >= 0 and 2 * (b1 + reach) - r <= w
            if inside and nc == 1:  # strided copies (no reflection)
                k = b1 + reach - b0
                even[:k] = col[2 * b0 - r : 2 * (b1 + reach) - r : 2]
                odd[:k] = col[2 * b0 + 1 - r : 2 * (b1 + reach) + 1 - r : 2]
            elif inside:
                for a in range(b1 + reach - b0):
                    e = (2 * (a + b0) - r) * nc
                    for ch in range(nc):
                        even[a * nc + ch] = col[e + ch]
                        odd[a * nc + ch] = col[e + nc + ch]
            else:
                for a in range(b0, b1 + reach):
                    e = _reflect(2 * a - r, w) * nc
                    o = _reflect(2 * a + 1 - r, w) * nc
                    for ch in range(nc):
                        even[(a - b0) * nc + ch] = col[e + ch]
                        odd[(a - b0) * nc + ch] = col[o + ch]
            m = (b1 - b0) * nc
            dst = flat[i, b0 * nc : b1 * nc]
            dst[:] = 0.0
            for t in range(k2.size):
                _axpy(dst, k2[t], even if t % 2 == 0 else odd, (t // 2) * nc, m)
