r"""The rendering's steps as one would first write them, in numpy (Okabe et al., sec. 6; slow).

Each fast path of :mod:`fluidnb.videodb.rendering` (numba kernels, OpenCV pyramids over
phase layers, remaps) has its plain version here, in the paper's notation, one pixel,
one fragment or one frame at a time; the tests check the fast path against it, and a
reader finds the maths in its most readable form.

========================================  ==========================================
plain version                             fast path (tested against it)
========================================  ==========================================
:func:`reference_blend_differences`       :func:`~fluidnb.videodb.rendering.blend_differences`
:func:`reference_layer_blend`             the same, phase layer by phase layer
:func:`reference_match_histograms_cells`  :func:`~fluidnb.videodb.rendering.match_histograms_cells`
:func:`reference_motion_blur`             :func:`~fluidnb.videodb.rendering.motion_blur`
:func:`reference_eulerian_loop`           :func:`~fluidnb.videodb.rendering.eulerian_loop`
:func:`reference_fill`                    :func:`~fluidnb.videodb.rendering.exemplar_fill`
========================================  ==========================================

How closely each pair agrees, and why not bit for bit where it does not, is said in
each function's docstring.
"""

from __future__ import annotations

import math

import numpy as np

from ..._validation import check_vector_field
from ...fields import backward_warp, collapse, gaussian_pyramid, laplacian_pyramid
from ...fields._pyramid import _collapse32, _gaussian32, _laplacian32
from .._common._geometry import FRAGMENT
from .._common._weights import FEATHER, _check_feather, _check_positions, _raw_weights
from ._blend import _TINY, _check_diffs, _check_levels, _layers
from ._blend import MARGIN as _BLEND_MARGIN
from ._blend import _window as _blend_window
from ._flow_render import loop_phases
from ._histograms import _QUANTILES, _SLOPE_RANGE, HISTOGRAM_BINS, _Cells
from ._motion_blur import _check_image, _shutter_samples, _variable_blur

__all__ = [
    "reference_blend_differences",
    "reference_eulerian_loop",
    "reference_fill",
    "reference_layer_blend",
    "reference_match_histograms_cells",
    "reference_motion_blur",
]


# ----------------------------------------------------------------- augmentation (sec. 4)


# --------------------------------------------------------- fragment features (secs. 4-5)


# ------------------------------------------------------------ appearance (secs. 4-5, Eq. 1)


# ------------------------------------------------------------ smoothness tables (Eq. 2, 3, 6)


# ------------------------------------------------------------------- rendering (sec. 6)


def reference_blend_differences(
    diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER
):
    r"""Multi-band blending of the fragments' differences written per fragment (slow).

    Burt & Adelson's multiresolution spline as one would first write it for many
    overlapping pieces. For every fragment :math:`p`:

    1. its difference frames on the whole canvas, :math:`D^p`: its own data on its
       :math:`(48 + 2m)`-pixel window, and beyond the window the *fill*, the
       tent-weighted average of all fragments' windows. A fragment's weight spreads
       past its data at the coarse levels, so its frames need some extension there;
       the fill is the one that gives identical inputs back exactly (it equals the
       data wherever the fragments agree);
    2. its weight :math:`W^p`: the flat-topped tent over its core of
       :func:`~fluidnb.videodb.rendering.fragment_weights` before the normalisation, 0 off the
       core;
    3. the Laplacian pyramid :math:`L_l(D^p)` and the Gaussian pyramid
       :math:`G_l(W^p)` (float64, :mod:`fluidnb.fields`; frames as channels);

    then per level :math:`L_l = \sum_p G_l(W^p) L_l(D^p) / \sum_p G_l(W^p)` (0 where
    no weight reaches), collapsed, and 0 off the cores.

    How :func:`~fluidnb.videodb.rendering.blend_differences` differs: it builds the same sums
    from 9 *phase layers* (fragments whose grid positions are equal modulo 3 share one
    canvas and one pyramid), so in a layer the neighbourhood of a fragment's 72 x 72
    tile holds its phase-mates' frames (72 px away) rather than the fill, and it keeps
    at most 12 px of a fragment's margin (the tile). Everything else is the same. So
    where no two fragments share a phase (grids of up to 3 x 3 fragments) and
    ``margin <= 12`` the two agree to float32 round-off (the fast path's arithmetic),
    and with up to 3 levels also on larger grids: a fragment's weights at levels 0-2
    hardly reach past its tile. At the fourth level (the default) they do, and the
    blends differ there: by at most 4.6e-3 of luminance at one pixel of the quick
    starter render of the stream (49 fragments of 32 frames; 1e-4 rms), by at most
    5e-4 on independent unit-variance textures. (Extending each fragment by its
    phase layer instead of the fill gives back the fast path to float32 round-off.)

    Arguments and result as :func:`~fluidnb.videodb.rendering.blend_differences`.
    """
    pos, shape = _check_positions(positions, canvas_shape)
    m = int(margin)
    d = _check_diffs(diffs, len(pos)).astype(np.float64)
    if d.shape[2] != FRAGMENT + 2 * m:
        raise ValueError(f"diffs must be {FRAGMENT + 2 * m} pixels wide, got shape {d.shape}")
    levels = _check_levels(levels)
    weight = _raw_weights(_check_feather(feather))  # W^p on the 48 x 48 core
    n = d.shape[1]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    size = FRAGMENT + 2 * m

    def window(r, c):
        """Canvas slices of a fragment's window, and the same pixels in its data."""
        r0, r1 = max(r - m, 0), min(r + FRAGMENT + m, shape[0])
        c0, c1 = max(c - m, 0), min(c + FRAGMENT + m, shape[1])
        data = (slice(r0 - (r - m), r1 - (r - m)), slice(c0 - (c - m), c1 - (c - m)))
        return (slice(r0, r1), slice(c0, c1)), data

    # The fill: every fragment's window weighted by a tent (its distance to the
    # window's nearer edge, on each axis), averaged.
    u = np.arange(size) + 0.5
    tent = np.outer(np.minimum(u, size - u), np.minimum(u, size - u))
    fill = np.zeros(shape + (n,))
    den = np.zeros(shape)
    for k, (r, c) in enumerate(pos):
        on_canvas, data = window(r, c)
        fill[on_canvas] += np.moveaxis(d[k][(slice(None), *data)], 0, -1) * tent[data][..., None]
        den[on_canvas] += tent[data]
    fill = np.divide(fill, den[..., None], out=np.zeros_like(fill), where=den[..., None] > 0)

    num = wsum = None
    for k, (r, c) in enumerate(pos):
        frames = fill.copy()  # D^p on the canvas
        on_canvas, data = window(r, c)
        frames[on_canvas] = np.moveaxis(d[k][(slice(None), *data)], 0, -1)
        w = np.zeros(shape)  # W^p on the canvas
        w[r : r + FRAGMENT, c : c + FRAGMENT] = weight
        bands = laplacian_pyramid(frames, levels)
        gw = gaussian_pyramid(w, levels)
        terms = [g[..., None] * b for g, b in zip(gw, bands)]
        num = terms if num is None else [a + t for a, t in zip(num, terms)]
        wsum = gw if wsum is None else [a + g for a, g in zip(wsum, gw)]
    blended = [
        np.where(s[..., None] > _TINY, a / np.where(s > _TINY, s, 1.0)[..., None], 0.0)
        for a, s in zip(num, wsum)
    ]
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = collapse(blended) * covered[..., None]
    return np.ascontiguousarray(np.moveaxis(out, -1, 0)).astype(np.float32)


def reference_layer_blend(diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER):
    r"""The phase-layer blend of :func:`blend_differences` in numpy (float32).

    The fast path's own design (9 phase layers, the fill, OpenCV's float32 pyramids)
    with every step of its own arithmetic written as numpy array operations, one
    layer after the other: the fill summed fragment by fragment, each layer's bands
    weighted by :math:`G_l(W)` and summed in layer order, divided by the summed
    weights (0 where none reaches), collapsed, 0 off the cores. The fast path (its
    compiled fill, weighting and normalisation, its weights made once, its layers on
    threads) gives the same frames bit for bit (tested).

    Arguments and result as :func:`~fluidnb.videodb.rendering.blend_differences`.
    """
    pos, shape = _check_positions(positions, canvas_shape)
    m = int(margin)
    d = np.moveaxis(_check_diffs(diffs, len(pos)), 1, 3).astype(np.float32)  # (P, s, s, N)
    levels = _check_levels(levels)
    raw = _raw_weights(_check_feather(feather)).astype(np.float32)
    n = d.shape[3]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    size = FRAGMENT + 2 * m
    u = np.arange(size, dtype=np.float64) + 0.5
    tent = np.outer(np.minimum(u, size - u), np.minimum(u, size - u)).astype(np.float32)
    fill = np.zeros(shape + (n,), np.float32)
    den = np.zeros(shape, np.float32)
    for k, (r, c) in enumerate(pos):
        (rs, cs), (wr, wc) = _blend_window(r, c, m, size, shape)
        fill[rs, cs] += d[k, wr, wc] * tent[wr, wc][..., None]
        den[rs, cs] += tent[wr, wc]
    np.divide(fill, den[..., None], out=fill, where=den[..., None] > 0)
    tile = FRAGMENT + 2 * min(m, _BLEND_MARGIN)
    num = wsum = None
    for members in _layers(pos):
        layer = fill.copy()
        weight = np.zeros(shape + (1,), np.float32)
        for k in members:
            r, c = pos[k]
            (rs, cs), (wr, wc) = _blend_window(r, c, m, tile, shape)
            layer[rs, cs] = d[k, wr, wc]
            weight[r : r + FRAGMENT, c : c + FRAGMENT, 0] = raw
        gw = _gaussian32(weight, levels)
        terms = [b * g for b, g in zip(_laplacian32(layer, levels), gw)]
        num = terms if num is None else [a + t for a, t in zip(num, terms)]
        wsum = gw if wsum is None else [a + g for a, g in zip(wsum, gw)]
    for a, s in zip(num, wsum):
        np.divide(a, s, out=a, where=s > _TINY)
        a[np.broadcast_to(s <= _TINY, a.shape)] = 0.0
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = _collapse32(num) * covered[..., None]
    return np.ascontiguousarray(out.transpose(2, 0, 1))


def reference_motion_blur(image, velocity, *, shutter, denoise):
    r""":func:`~fluidnb.videodb.rendering.motion_blur` as whole-image warps (Okabe et al., sec. 6).

    The approximate mean image: the target averaged along its motion, sample by
    sample, each sample a whole image warped by
    :func:`fluidnb.fields.backward_warp` to ``x + t v(x)``, accumulated with the
    trapezoid weights; then the speed-dependent Gaussian blur. The fast path gives the
    same result bit for bit. Arguments and result as
    :func:`~fluidnb.videodb.rendering.motion_blur`.
    """
    img = _check_image("image", image)
    v = check_vector_field("velocity", velocity, shape=img.shape[:2]).astype(np.float32)
    speed = np.hypot(v[..., 0], v[..., 1])
    out = img
    times, weights = _shutter_samples(shutter, float(speed.max()))
    if len(times):
        acc = np.zeros_like(img, dtype=np.float64)
        for t, w in zip(times, weights):
            acc += w * backward_warp(img, t * v)  # img(x + t v(x))
        out = (acc / (len(times) - 1)).astype(np.float32)
    if denoise > 0:
        out = _variable_blur(out, denoise * speed)
    return out


def reference_match_histograms_cells(frames, reference, weight, *, cell):
    """:func:`match_histograms_cells` in plain numpy, for tests and teaching.

    ``np.bincount`` histograms, quantiles by (vectorised) binary search, and, for every
    pixel, the four neighbouring cells' maps gathered and blended. The compiled
    kernels of :func:`match_histograms_cells` are checked against it.
    """
    cells = _Cells(frames, reference, weight, cell)
    f = cells.frames
    n_ch, n_cells, bins = f.shape[3], cells.n_cells, HISTOGRAM_BINS

    def bins_of(lo, step):  # one image's bins -> per (channel, cell) row
        return np.repeat(lo, n_cells)[:, None], np.repeat(step, n_cells)[:, None]

    def bin_of(img, lo, step):
        z = (img.astype(np.float64) - lo) * (1.0 / step)
        return z, np.minimum(np.where(z > 0, z, 0).astype(np.intp), bins - 1)

    def histograms(img, lo, step):  # (H, W, C) -> (C * cells, bins)
        idx = (np.arange(n_ch) * n_cells + cells.cid[..., None]) * bins + bin_of(img, lo, step)[1]
        wt = np.broadcast_to(cells.weight[..., None], idx.shape)
        counts = np.bincount(idx.ravel(), weights=wt.ravel(), minlength=n_ch * n_cells * bins)
        return counts.reshape(n_ch * n_cells, bins)

    # Every image over its own range: the reference's bins, then each frame's.
    lo_r, step_r = cells.lo_ref, cells.step_ref
    q_ref = _quantiles_np(histograms(cells.reference, lo_r, step_r), *bins_of(lo_r, step_r))
    (y0, y1, fy), (x0, x1, fx) = cells.rows, cells.cols
    roles = []
    for ys, wy in ((y0, 1 - fy), (y1, fy)):
        for xs, wx in ((x0, 1 - fx), (x1, fx)):
            c = ys[:, None] * cells.nx + xs[None, :]
            roles.append((c, wy[:, None] * wx[None, :] * cells.mass[c]))
    total = sum(wt for _, wt in roles)[..., None]
    inv_total = np.divide(1.0, total, out=np.zeros(total.shape), where=total > 0)
    ch = np.arange(n_ch)
    out = np.empty_like(f)
    for t in range(f.shape[0]):
        lo, step = cells.lo[t], cells.step[t]
        row_lo, row_step = bins_of(lo, step)
        q_f = _quantiles_np(histograms(f[t], lo, step), row_lo, row_step)
        edges = row_lo + row_step * np.arange(bins + 1)
        lut = _maps_np(edges, q_f, q_ref).reshape(n_ch, n_cells, bins + 1)
        z, j = bin_of(f[t], lo, step)
        frac = z - j
        acc = np.zeros(z.shape)
        for c, w_c in roles:
            v0 = lut[ch, c[..., None], j]
            v1 = lut[ch, c[..., None], j + 1]
            acc += w_c[..., None] * (v0 + frac * (v1 - v0))
        out[t] = np.where(total > 0, acc * inv_total, f[t])
    return cells.result(out)


def _searchsorted_rows(a, v, side):
    """Row-wise ``np.searchsorted``: ``a`` (R, K) non-decreasing rows, ``v`` (R, M).

    A vectorised binary search (exact, ``log2 K`` gathers) instead of one call per row.
    """
    k = a.shape[1]
    lo = np.zeros(v.shape, dtype=np.intp)
    hi = np.full(v.shape, k, dtype=np.intp)
    for _ in range(max(1, math.ceil(math.log2(k + 1)))):
        mid = (lo + hi) >> 1
        am = np.take_along_axis(a, np.minimum(mid, k - 1), axis=1)
        go = (am < v) if side == "left" else (am <= v)
        go &= lo < hi
        lo = np.where(go, mid + 1, lo)
        hi = np.where(go | (lo >= hi), hi, mid)
    return lo


def _quantiles_np(counts, lo, step):
    """Quantiles at p = 0, 1/K, ..., 1 of piecewise-uniform histograms (R, B) -> (R, K+1).

    The distribution is uniform within each bin (the CDF piecewise linear through the
    bin edges), so the quantile function is continuous and strictly increasing, from
    the lower edge of the first non-empty bin to the upper edge of the last, and a
    histogram matched to itself maps every value to itself.
    """
    n_rows, bins = counts.shape
    mass = counts.sum(axis=1, keepdims=True)
    cdf = np.zeros((n_rows, bins + 1))
    np.cumsum(counts, axis=1, out=cdf[:, 1:])
    cdf /= np.where(mass > 0, mass, 1.0)
    p = np.broadcast_to(np.arange(_QUANTILES + 1) / _QUANTILES, (n_rows, _QUANTILES + 1))
    i = np.clip(_searchsorted_rows(cdf, p, "left"), 1, bins)
    c0 = np.take_along_axis(cdf, i - 1, axis=1)
    c1 = np.take_along_axis(cdf, i, axis=1)
    frac = np.divide(p - c0, c1 - c0, out=np.ones(c0.shape), where=c1 > c0)
    q = lo + step * (i - 1 + np.clip(frac, 0.0, 1.0))
    filled = counts > 0
    first = np.argmax(filled, axis=1)
    last = bins - np.argmax(filled[:, ::-1], axis=1)
    q[:, :1] = lo + step * first[:, None]
    q[:, -1:] = lo + step * last[:, None]
    return np.where(mass > 0, q, lo + step * bins)


def _interp_rows(x, xp, fp):
    """Row-wise ``np.interp(x, xp, fp)``, clamped; a zero-width segment gives its start.

    ``x``, ``xp``, ``fp``: (R, M), (R, K), (R, K).
    """
    i = np.clip(_searchsorted_rows(xp, x, "right"), 1, xp.shape[1] - 1)
    x0 = np.take_along_axis(xp, i - 1, axis=1)
    x1 = np.take_along_axis(xp, i, axis=1)
    f0 = np.take_along_axis(fp, i - 1, axis=1)
    f1 = np.take_along_axis(fp, i, axis=1)
    width = x1 - x0
    frac = np.divide(x - x0, width, out=np.zeros(x.shape), where=width > 0)
    return f0 + np.clip(frac, 0.0, 1.0) * (f1 - f0)


def _maps_np(edges, q_f, q_r):
    """Each cell's map from frame values to reference values, sampled at the bin edges.

    Between the quantiles it interpolates them; beyond the frame's range in the cell
    (values met only through the blending with neighbouring cells) it continues
    linearly with the slope of the whole range (clipped to [1/4, 4]) rather than
    clamping, so a frame matched to itself maps every value to itself.
    """
    lut = _interp_rows(edges, q_f, q_r)
    span_f = q_f[:, -1:] - q_f[:, :1]
    span_r = q_r[:, -1:] - q_r[:, :1]
    slope = np.divide(span_r, span_f, out=np.ones(span_f.shape), where=span_f > 0)
    np.clip(slope, *_SLOPE_RANGE, out=slope)
    lut = np.where(edges < q_f[:, :1], q_r[:, :1] + slope * (edges - q_f[:, :1]), lut)
    return np.where(edges > q_f[:, -1:], q_r[:, -1:] + slope * (edges - q_f[:, -1:]), lut)


# ------------------------------------------------------ the flow rendering (beyond the paper)


def reference_eulerian_loop(image, velocity, n_frames, *, cycle):
    r"""The flow rendering's Eulerian loop, one frame and one phase at a time (slow).

    For every frame :math:`t`, each phase's age :math:`s` (:func:`loop_phases`) is
    walked from 0, one frame at a time, with the semi-Lagrangian recurrence of the
    displacement map, :math:`D_{s+1}(x) = D_s(x - v(x)) - v(x)` forwards and
    :math:`D_{s-1}(x) = D_s(x + v(x)) + v(x)` backwards
    (:func:`fluidnb.fields.backward_warp`); a fractional age interpolates linearly
    between the two whole ones around it. The frame is

    .. math::

        I_t(x) = w_a(t)\, I\big(x + D_{s_a(t)}(x)\big)
            + (1 - w_a(t))\, I\big(x + D_{s_b(t)}(x)\big).

    :func:`~fluidnb.videodb.rendering.eulerian_loop` makes every map once and warps with
    OpenCV's ``remap``, whose bilinear weights are rounded to 1/32 of a pixel: the
    two agree to about ``|grad I| / 32`` (checked in the tests to 1e-2 on smooth
    images).
    """
    img = np.asarray(image, np.float64)
    v = np.asarray(velocity, np.float64)
    age_a, age_b, weight_a = loop_phases(n_frames, cycle)

    def displacement(age):
        def walk(steps):
            sign = 1.0 if steps >= 0 else -1.0
            d = np.zeros_like(v)
            for _ in range(abs(steps)):
                d = backward_warp(d, -sign * v) - sign * v
            return d

        lo = math.floor(age)
        frac = age - lo
        d = walk(lo)
        return d if frac == 0 else (1 - frac) * d + frac * walk(lo + 1)

    frames = []
    for sa, sb, wa in zip(age_a, age_b, weight_a):
        a = backward_warp(img, displacement(sa))
        b = backward_warp(img, displacement(sb))
        frames.append(wa * a + (1 - wa) * b)
    return np.array(frames, np.float32)


def reference_fill(image, hole, *, seed=0):
    r"""Exemplar-based fill with an exhaustive search for every patch's match (slow).

    The completion of :func:`~fluidnb.videodb.rendering.exemplar_fill` (Wexler et al. 2007:
    coarse to fine, match every patch that touches the hole, each hole pixel the mean
    of what the matches say), but each 7 x 7 patch is compared with *every* patch
    wholly outside the hole, in numpy, where the fast path's PatchMatch samples a
    few. Its matches are the best there are, so the fast path's patch distances can
    only be as low or higher (the tests check they stay close), and the fills look
    alike. Only for small images.
    """
    from ._fill import PATCH_RADIUS, _check, _complete, _pyramid, _sources

    img, h, grey = _check(image, hole)
    r = PATCH_RADIUS
    offsets = np.stack(np.mgrid[-r : r + 1, -r : r + 1], axis=-1).reshape(-1, 2)

    def patches(im, centres):
        # out-of-image pixels are clamped here and excluded by the mask below
        yy = centres[:, None, 0] + offsets[None, :, 0]
        xx = centres[:, None, 1] + offsets[None, :, 1]
        inside = (yy >= 0) & (yy < im.shape[0]) & (xx >= 0) & (xx < im.shape[1])
        yy = np.clip(yy, 0, im.shape[0] - 1)
        xx = np.clip(xx, 0, im.shape[1] - 1)
        return im[yy, xx].astype(np.float64), inside

    def exhaustive(im, hole_, targets, sources, nnf, gen):
        src, _ = patches(im, sources)
        tgt, inside = patches(im, targets)
        best = np.empty((len(targets), 2), np.int64)
        for i in range(len(targets)):
            diff = (src - tgt[i][None]) ** 2 * inside[i][None, :, None]
            best[i] = sources[np.argmin(diff.sum(axis=(1, 2)))]
        return best

    if not h.any():
        out = img
    else:
        if len(_sources(h, r)) == 0:
            raise ValueError("hole leaves no 7 x 7 patch of the image to fill it from")
        out = _complete(_pyramid(img, h), exhaustive, seed)
        out = np.where(h[..., None], out, img)
    return out[..., 0] if grey else out


# --------------------------------------------------------------- the MRF solvers (Eq. 4)


# ------------------------------------------------------------- the starter water clips
