r"""The rendering's steps as one would first write them, in numpy (Okabe et al., sec. 6; slow).

Each fast path of :mod:`fluidnb.videodb.rendering` (numba kernels, OpenCV pyramids over
phase layers, remaps) has its plain version here, in the paper's notation, one pixel,
one fragment or one frame at a time. They are written from the method, not from the
fast path's code: this module imports none of the rendering's kernels or helpers, only
the grid's sizes, the blend's and the matching's published constants, and
:mod:`fluidnb.fields` (warps and pyramids, tested against their own plain versions).
So a test comparing a fast path with its plain version fails when the fast path is
broken (each test says which deliberate breakage it catches); the benchmarks show what
the optimisation buys, and a reader finds the maths in its most readable form.

========================================  ==========================================
plain version                             fast path (tested against it)
========================================  ==========================================
:func:`reference_blend_differences`       :func:`~fluidnb.videodb.rendering.blend_differences`
:func:`reference_layer_blend`             the same, phase layer by phase layer
:func:`reference_match_histograms_cells`  :func:`~fluidnb.videodb.rendering.match_histograms_cells`
:func:`reference_motion_blur`             :func:`~fluidnb.videodb.rendering.motion_blur`
:func:`reference_eulerian_loop`           :func:`~fluidnb.videodb.rendering.eulerian_loop`
:func:`reference_supersample`             :func:`~fluidnb.videodb.rendering.supersample`
:func:`reference_variance_blend`          :func:`~fluidnb.videodb.rendering.variance_blend`
:func:`reference_fill`                    :func:`~fluidnb.videodb.rendering.exemplar_fill`
========================================  ==========================================

How closely each pair agrees, and why not bit for bit where it does not, is said in
each function's docstring.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage as ndi

from ...fields import backward_warp, collapse, gaussian_pyramid, laplacian_pyramid
from .._common._geometry import FRAGMENT, STRIDE
from .._common._weights import FEATHER
from ._blend import BLEND_LEVELS
from ._fill import PATCH_RADIUS
from ._flow_render import LANCZOS_A, SUPERSAMPLE
from ._histograms import _QUANTILES, _SLOPE_RANGE, HISTOGRAM_BINS

__all__ = [
    "reference_blend_differences",
    "reference_eulerian_loop",
    "reference_fill",
    "reference_layer_blend",
    "reference_match_histograms_cells",
    "reference_motion_blur",
    "reference_supersample",
    "reference_variance_blend",
]

# Per-level weight sums at or below this count as "no fragment here" (as the blend).
_NO_WEIGHT = 1e-30


# -------------------------------------------------------------- the blend (Burt & Adelson)


def _core_weight(feather):
    r"""A fragment's weight :math:`W^p` on its 48 x 48 core, before the normalisation.

    The product of two 1-D profiles: pixel :math:`i`'s distance to the core's nearer
    edge, :math:`e = \min(i + 1/2, 48 - i - 1/2)`, ramps linearly from 0 to 1 over
    ``feather`` pixels centred on the boundary between two neighbours' cells,
    :math:`e = 12` (a step for ``feather = 0``), floored at 1e-3 so that no pixel of a
    core has weight 0.
    """
    profile = np.empty(FRAGMENT)
    for i in range(FRAGMENT):
        e = min(i + 0.5, FRAGMENT - i - 0.5)
        if feather == 0:
            ramp = 1.0 if e > STRIDE / 2 else 0.0
        else:
            ramp = min(max((e - STRIDE / 2) / feather + 0.5, 0.0), 1.0)
        profile[i] = max(ramp, 1e-3)
    return np.outer(profile, profile)


def _blend_inputs(diffs, positions, canvas_shape, margin, levels, feather):
    """The blend's arguments, checked as plainly as they are used."""
    pos = np.asarray(positions, np.int64).reshape(-1, 2)
    shape = tuple(int(s) for s in canvas_shape)
    d = np.asarray(diffs)
    m = int(margin)
    if d.ndim != 4 or len(d) != len(pos) or d.shape[2:] != (FRAGMENT + 2 * m,) * 2:
        raise ValueError(
            f"diffs must be (P, N, {FRAGMENT + 2 * m}, {FRAGMENT + 2 * m}) for {len(pos)} "
            f"positions, got shape {d.shape}"
        )
    if np.any(pos % STRIDE) or len(np.unique(pos, axis=0)) != len(pos):
        raise ValueError("positions must be distinct multiples of the stride 24")
    if not 0 <= feather <= STRIDE:
        raise ValueError(f"feather must be in [0, {STRIDE}], got {feather}")
    return d, pos, shape, m, BLEND_LEVELS if levels is None else int(levels)


def _tent(size):
    """The fill's weights over a (size x size) window: the distance to its nearer edge."""
    u = np.arange(size) + 0.5
    return np.outer(np.minimum(u, size - u), np.minimum(u, size - u))


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
    2. its weight :math:`W^p`: the flat-topped tent over its core (:func:`_core_weight`),
       0 off the core;
    3. the Laplacian pyramid :math:`L_l(D^p)` and the Gaussian pyramid
       :math:`G_l(W^p)` (float64, :mod:`fluidnb.fields`; frames as channels);

    then per level :math:`L_l = \sum_p G_l(W^p) L_l(D^p) / \sum_p G_l(W^p)` (0 where
    no weight reaches), collapsed, and 0 off the cores.

    How :func:`~fluidnb.videodb.rendering.blend_differences` differs: it builds the
    same sums from 9 *phase layers* (fragments whose grid positions are equal modulo 3
    share one canvas and one pyramid), so in a layer the neighbourhood of a fragment's
    72 x 72 tile holds its phase-mates' frames (72 px away) rather than the fill, and
    it keeps at most 12 px of a fragment's margin (the tile). Everything else is the
    same. So where no two fragments share a phase (grids of up to 3 x 3 fragments) and
    ``margin <= 12`` the two agree to float32 round-off (the fast path's arithmetic),
    and with up to 3 levels also on larger grids: a fragment's weights at levels 0-2
    hardly reach past its tile. At the fourth level (the default) they do, and the
    blends differ there: by at most 4.6e-3 of luminance at one pixel of the quick
    starter render of the stream (49 fragments of 32 frames; 1e-4 rms), by at most
    5e-4 on independent unit-variance textures. (Extending each fragment by its
    phase layer instead of the fill gives back the fast path to float32 round-off.)

    Arguments and result as :func:`~fluidnb.videodb.rendering.blend_differences`.
    """
    d, pos, shape, m, levels = _blend_inputs(
        diffs, positions, canvas_shape, margin, levels, feather
    )
    d = d.astype(np.float64)
    weight = _core_weight(feather)
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
    tent = _tent(size)
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
        np.where(s[..., None] > _NO_WEIGHT, a / np.where(s > _NO_WEIGHT, s, 1.0)[..., None], 0.0)
        for a, s in zip(num, wsum)
    ]
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = collapse(blended) * covered[..., None]
    return np.ascontiguousarray(np.moveaxis(out, -1, 0)).astype(np.float32)


def reference_layer_blend(diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER):
    r"""The phase-layer blend of :func:`blend_differences` in numpy (float32).

    The fast path's own design with every step written as numpy array operations, one
    layer after the other: the fill (every fragment's window weighted by its tent,
    summed fragment by fragment and divided), the 9 phase layers (fragments whose grid
    positions are equal modulo 3, in the order of their phase :math:`3 (r / 24 \bmod
    3) + (c / 24 \bmod 3)`), each a canvas holding the fill and, on each member's
    72 x 72 tile, its own frames, with the members' weights :math:`W^p` on their
    cores; each layer's bands weighted by :math:`G_l(W)` and summed in layer order,
    divided by the summed weights (0 where none reaches), collapsed, 0 off the cores.
    The pyramids are :mod:`fluidnb.fields`'s float32 ones. The fast path (its compiled
    fill, weighting and normalisation, its weights made once, its layers on threads)
    gives the same frames bit for bit (tested).

    Arguments and result as :func:`~fluidnb.videodb.rendering.blend_differences`.
    """
    d, pos, shape, m, levels = _blend_inputs(
        diffs, positions, canvas_shape, margin, levels, feather
    )
    d = np.moveaxis(d, 1, 3).astype(np.float32)  # (P, s, s, N)
    raw = _core_weight(feather).astype(np.float32)
    n = d.shape[3]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)

    def window(r, c, size):
        """A fragment's window of ``size`` pixels: its canvas slices and its data's."""
        h = (size - FRAGMENT) // 2
        r0, r1 = max(r - h, 0), min(r + FRAGMENT + h, shape[0])
        c0, c1 = max(c - h, 0), min(c + FRAGMENT + h, shape[1])
        canvas = (slice(r0, r1), slice(c0, c1))
        return canvas, (slice(r0 - r + m, r1 - r + m), slice(c0 - c + m, c1 - c + m))

    tent = _tent(FRAGMENT + 2 * m).astype(np.float32)
    fill = np.zeros(shape + (n,), np.float32)
    den = np.zeros(shape, np.float32)
    for k, (r, c) in enumerate(pos):
        (rs, cs), (wr, wc) = window(r, c, FRAGMENT + 2 * m)
        fill[rs, cs] += d[k, wr, wc] * tent[wr, wc][..., None]
        den[rs, cs] += tent[wr, wc]
    np.divide(fill, den[..., None], out=fill, where=den[..., None] > 0)
    # Same-phase fragments are 3 strides apart: each fills a tile of 72 x 72 pixels.
    tile = FRAGMENT + 2 * min(m, (3 * STRIDE - FRAGMENT) // 2)
    phase = (pos // STRIDE) % 3
    phase = 3 * phase[:, 0] + phase[:, 1]
    num = wsum = None
    for p in range(9):
        members = np.flatnonzero(phase == p)
        if not len(members):
            continue
        layer = fill.copy()
        weight = np.zeros(shape + (1,), np.float32)
        for k in members:
            r, c = pos[k]
            (rs, cs), (wr, wc) = window(r, c, tile)
            layer[rs, cs] = d[k, wr, wc]
            weight[r : r + FRAGMENT, c : c + FRAGMENT, 0] = raw
        gw = gaussian_pyramid(weight, levels, precision="float32")
        bands = laplacian_pyramid(layer, levels, precision="float32")
        terms = [b * g for b, g in zip(bands, gw)]
        num = terms if num is None else [a + t for a, t in zip(num, terms)]
        wsum = gw if wsum is None else [a + g for a, g in zip(wsum, gw)]
    for a, s in zip(num, wsum):
        np.divide(a, s, out=a, where=s > _NO_WEIGHT)
        a[np.broadcast_to(s <= _NO_WEIGHT, a.shape)] = 0.0
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = collapse(num, precision="float32") * covered[..., None]
    return np.ascontiguousarray(out.transpose(2, 0, 1))


# ------------------------------------------------------ the approximate mean image (sec. 6)


def reference_motion_blur(image, velocity, *, shutter, denoise):
    r"""The approximate mean image (Okabe et al., sec. 6) as whole-image warps, in float64.

    The target averaged along its motion: with :math:`s` the shutter and
    :math:`n = \lceil s \max|v| / 0.5 \rceil + 1` samples at times
    :math:`t_k = -s/2 + k s / (n - 1)` (at most half a pixel apart where the motion is
    fastest), the trapezoid rule for a box average over the shutter,

    .. math::

        A(x) = \frac{1}{n - 1} \Big(\tfrac12 I(x + t_0 v(x)) + \sum_{k=1}^{n-2}
            I(x + t_k v(x)) + \tfrac12 I(x + t_{n-1} v(x))\Big),

    each sample a whole image warped by :func:`fluidnb.fields.backward_warp`
    (bilinear, clamped at the border); then a Gaussian blur of standard deviation
    :math:`\sigma(x) = \text{denoise}\,|v(x)|` at each pixel, interpolated linearly
    between whole images blurred at :math:`\sigma = 0, 0.5, 1` and then a factor
    :math:`\sqrt 2` apart (:func:`scipy.ndimage.gaussian_filter`, reflected border).

    The fast path averages each pixel's line in compiled code in float32 and blurs in
    float32: the two agree to float32 round-off (checked to 2e-6 in the tests).
    Arguments as :func:`~fluidnb.videodb.rendering.motion_blur`; the result in float32.
    """
    img = np.array(image, np.float64)
    # The velocity as the fast path takes it, float32: the same top speed, so the
    # same number of samples.
    v32 = np.asarray(velocity, np.float32)
    if img.ndim not in (2, 3) or v32.shape != img.shape[:2] + (2,):
        raise ValueError(f"velocity must be (H, W, 2) for an image {img.shape}, got {v32.shape}")
    v = v32.astype(np.float64)
    speed = np.hypot(v[..., 0], v[..., 1])
    length = shutter * float(np.hypot(v32[..., 0], v32[..., 1]).max())
    out = img
    if length > 0:
        n = math.ceil(length / 0.5) + 1
        acc = np.zeros_like(img)
        for k in range(n):
            t = -shutter / 2 + k * shutter / (n - 1)
            w = 0.5 if k in (0, n - 1) else 1.0  # the trapezoid rule
            acc += w * backward_warp(img, t * v)  # I(x + t v(x))
        out = acc / (n - 1)
    sigma = denoise * speed
    if denoise > 0 and sigma.max() > 0:
        levels = [0.0]
        s = 0.5
        while levels[-1] < sigma.max():
            levels.append(s)
            s = s + 0.5 if s < 1.0 else s * math.sqrt(2.0)
        axes = (1.0, 1.0) + (0.0,) * (img.ndim - 2)
        blurred = [out] + [
            ndi.gaussian_filter(out, tuple(a * lv for a in axes), mode="reflect")
            for lv in levels[1:]
        ]
        result = np.empty_like(out)
        for y, x in np.ndindex(sigma.shape):
            k = 0
            while k + 2 < len(levels) and levels[k + 1] <= sigma[y, x]:
                k += 1
            f = (sigma[y, x] - levels[k]) / (levels[k + 1] - levels[k])
            result[y, x] = (1 - f) * blurred[k][y, x] + f * blurred[k + 1][y, x]
        out = result
    return out.astype(np.float32)


# ---------------------------------------------------------- the appearance matching (sec. 6)


def reference_match_histograms_cells(frames, reference, weight, *, cell):
    r""":func:`match_histograms_cells` in plain numpy, for tests and teaching.

    The cell grid (pixel :math:`(y, x)` in cell :math:`(\lfloor y / c \rfloor,
    \lfloor x / c \rfloor)`, the last row and column of cells maybe narrower), each
    cell's share of the matte, every image's bins over its own range per channel
    (256 bins), ``np.bincount`` histograms, quantiles by (vectorised) binary search,
    each cell's map between the quantiles, and, for every pixel, the four cells whose
    centres bracket it, their maps blended bilinearly and by their share of the matte.
    The compiled kernels of :func:`match_histograms_cells` are checked against it (to
    1e-6).
    """
    f = np.asarray(frames, np.float32)
    ref = np.asarray(reference, np.float32)
    weight = np.asarray(weight, np.float64)
    grey = f.ndim == 3
    if grey:
        f, ref = f[..., None], ref[..., None]
    if ref.shape != f.shape[1:] or weight.shape != f.shape[1:3] or weight.min() < 0:
        raise ValueError("reference must be one frame's shape, weight (H, W) and >= 0")
    if int(cell) != cell or cell < 2:
        raise ValueError(f"cell must be an integer >= 2, got {cell}")
    cell = int(cell)
    n_frames, h, w, n_ch = f.shape
    bins = HISTOGRAM_BINS
    ny, nx = -(-h // cell), -(-w // cell)
    n_cells = ny * nx
    cid = (np.arange(h) // cell)[:, None] * nx + (np.arange(w) // cell)[None, :]
    mass = np.bincount(cid.ravel(), weights=weight.ravel(), minlength=n_cells)

    def bracket(n):
        """Per pixel along an axis: the two cells whose centres bracket it, the 2nd's weight."""
        centres = np.array([(a + min(a + cell, n) - 1) / 2 for a in range(0, n, cell)])
        x = np.arange(n, dtype=np.float64)
        i0 = np.clip(np.searchsorted(centres, x, side="right") - 1, 0, len(centres) - 1)
        i1 = np.minimum(i0 + 1, len(centres) - 1)
        span = centres[i1] - centres[i0]
        frac = np.divide(x - centres[i0], span, out=np.zeros(n), where=span > 0)
        return i0, i1, np.clip(frac, 0.0, 1.0)

    def value_bins(img):
        """Each channel's lowest bin edge and bin width: 256 bins over its own range."""
        values = img.reshape(-1, n_ch)
        lo, hi = values.min(axis=0).astype(np.float64), values.max(axis=0).astype(np.float64)
        return lo, np.where(hi > lo, (hi - lo) / bins, 1.0 / bins)

    def bins_of(lo, step):  # one image's bins -> per (channel, cell) row
        return np.repeat(lo, n_cells)[:, None], np.repeat(step, n_cells)[:, None]

    def bin_of(img, lo, step):
        z = (img.astype(np.float64) - lo) * (1.0 / step)
        return z, np.minimum(np.where(z > 0, z, 0).astype(np.intp), bins - 1)

    def histograms(img, lo, step):  # (H, W, C) -> (C * cells, bins)
        idx = (np.arange(n_ch) * n_cells + cid[..., None]) * bins + bin_of(img, lo, step)[1]
        wt = np.broadcast_to(weight[..., None], idx.shape)
        counts = np.bincount(idx.ravel(), weights=wt.ravel(), minlength=n_ch * n_cells * bins)
        return counts.reshape(n_ch * n_cells, bins)

    # Every image over its own range: the reference's bins, then each frame's.
    lo_r, step_r = value_bins(ref)
    q_ref = _quantiles_np(histograms(ref, lo_r, step_r), *bins_of(lo_r, step_r))
    (y0, y1, fy), (x0, x1, fx) = bracket(h), bracket(w)
    roles = []
    for ys, wy in ((y0, 1 - fy), (y1, fy)):
        for xs, wx in ((x0, 1 - fx), (x1, fx)):
            c = ys[:, None] * nx + xs[None, :]
            roles.append((c, wy[:, None] * wx[None, :] * mass[c]))
    total = sum(wt for _, wt in roles)[..., None]
    inv_total = np.divide(1.0, total, out=np.zeros(total.shape), where=total > 0)
    ch = np.arange(n_ch)
    out = np.empty_like(f)
    for t in range(n_frames):
        lo, step = value_bins(f[t])
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
    return out[..., 0] if grey else out


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


def reference_eulerian_loop(image, velocity, n_frames, *, cycle, offsets=None):
    r"""The flow rendering's Eulerian loop, one frame and one phase at a time (slow).

    The loop's period :math:`P` is ``n_frames`` divided by the whole number of cycles
    nearest to ``n_frames / cycle`` (at least one). Pixel :math:`x` of frame :math:`t`
    blends two phases of ages :math:`s_a = ((u + P/2) \bmod P) - P/2` and
    :math:`s_b = (u \bmod P) - P/2`, :math:`u = t + o(x) P` (``offsets`` :math:`o`, 0
    if not given), with weight :math:`w_a = 1 - 2 |s_a| / P` for phase a. Each whole age
    is walked from 0, one frame at a time, with the semi-Lagrangian recurrence of the
    displacement map, :math:`D_{s+1}(x) = D_s(x - v(x)) - v(x)` forwards and
    :math:`D_{s-1}(x) = D_s(x + v(x)) + v(x)` backwards
    (:func:`fluidnb.fields.backward_warp`); a fractional age interpolates linearly
    between the two whole ones around it. Each phase samples the image
    :math:`I(x + D_s(x))` from its :func:`reference_supersample` with Keys' cubic
    kernel (:math:`a = -0.75`), and the frame is their
    :func:`reference_variance_blend`.

    :func:`~fluidnb.videodb.rendering.eulerian_loop` makes every map once and samples
    with OpenCV's ``remap``, whose interpolation weights are tabulated every 1/32 of a
    pixel: the two agree to about ``|grad I| / 64`` (checked in the tests to 1e-2 on
    smooth images).
    """
    img = np.asarray(image, np.float64)
    v = np.asarray(velocity, np.float64)
    h, w = img.shape[:2]
    period = n_frames / max(1, round(n_frames / cycle))
    o = np.zeros((h, w)) if offsets is None else np.asarray(offsets, np.float64)

    def walk(steps):
        sign = 1.0 if steps >= 0 else -1.0
        d = np.zeros_like(v)
        for _ in range(abs(steps)):
            d = backward_warp(d, -sign * v) - sign * v
        return d

    top = math.ceil(period / 2)
    whole = {s: walk(s) for s in range(-top, top + 1)}
    rows, cols = np.mgrid[:h, :w]

    def displacement(age):  # (H, W) ages -> (H, W, 2)
        lo = np.floor(age)
        frac = (age - lo)[..., None]
        lo = np.clip(lo.astype(int), -top, top)
        hi = np.clip(lo + 1, -top, top)
        return (1 - frac) * _pick(whole, lo, rows, cols) + frac * _pick(whole, hi, rows, cols)

    fine = reference_supersample(img, SUPERSAMPLE)
    frames = []
    for t in range(n_frames):
        u = t + o * period
        age_a = np.mod(u + period / 2, period) - period / 2
        age_b = np.mod(u, period) - period / 2
        w_a = np.clip(1.0 - 2.0 * np.abs(age_a) / period, 0.0, 1.0)
        a, b = (
            _cubic_sample(fine, SUPERSAMPLE * (rows + d[..., 0]), SUPERSAMPLE * (cols + d[..., 1]))
            for d in (displacement(age_a), displacement(age_b))
        )
        frames.append(reference_variance_blend(a, b, w_a))
    return np.array(frames, np.float32)


def _pick(whole, ages, rows, cols):
    """Each pixel's own displacement ``whole[age][row, col]``."""
    out = np.empty(ages.shape + (2,))
    for s, d in whole.items():
        at = ages == s
        out[at] = d[rows[at], cols[at]]
    return out


def reference_supersample(image, factor):
    r"""The image ``factor`` times finer: Lanczos interpolation, one axis then the other.

    Fine pixel :math:`j` lies at :math:`j / f` in the image's pixels; with
    :math:`i = \lfloor j / f \rfloor` and :math:`\phi = j / f - i` it is
    :math:`\sum_{k=-a+1}^{a} L(k - \phi) I_{i + k} / \sum_k L(k - \phi)`,
    :math:`L(x) = \operatorname{sinc}(x) \operatorname{sinc}(x / a)`, ``a`` =
    :data:`~fluidnb.videodb.rendering._flow_render.LANCZOS_A`, indices clamped to the
    image. At :math:`\phi = 0` the sum is the pixel itself.
    """
    out = np.asarray(image, np.float64)
    a = LANCZOS_A
    for axis in (0, 1):
        n = out.shape[axis]
        fine = []
        for j in range((n - 1) * factor + 1):
            i, phi = divmod(j, factor)
            phi = phi / factor
            x = np.arange(-a + 1, a + 1) - phi
            taps = np.sinc(x) * np.sinc(x / a)
            taps /= taps.sum()
            idx = np.clip(np.arange(i - a + 1, i + a + 1), 0, n - 1)
            fine.append(np.tensordot(taps, np.take(out, idx, axis=axis), axes=([0], [axis])))
        out = np.stack(fine, axis=axis)
    return out


def _keys(x, a=-0.75):
    """Keys' cubic convolution kernel (OpenCV's INTER_CUBIC uses a = -0.75)."""
    x = np.abs(x)
    near = ((a + 2) * x - (a + 3)) * x * x + 1
    far = ((a * x - 5 * a) * x + 8 * a) * x - 4 * a
    return np.where(x <= 1, near, np.where(x < 2, far, 0.0))


def _cubic_sample(img, y, x):
    """``img`` at fractional (y, x), Keys' cubic over 4 x 4 pixels, indices clamped."""
    h, w = img.shape[:2]
    y0, x0 = np.floor(y), np.floor(x)
    out = 0.0
    for dy in range(-1, 3):
        wy = _keys(y - (y0 + dy))
        r = np.clip(y0 + dy, 0, h - 1).astype(int)
        for dx in range(-1, 3):
            wx = _keys(x - (x0 + dx))
            c = np.clip(x0 + dx, 0, w - 1).astype(int)
            k = wy * wx
            out = out + (k[..., None] if img.ndim == 3 else k) * img[r, c]
    return out


def reference_variance_blend(a, b, weight):
    r"""The phases' blend that keeps the contrast of its parts, pixel by pixel (numpy).

    With :math:`m = w a + (1 - w) b`, :math:`L` one level of a Burt & Adelson pyramid
    down and up, :math:`H_x = x - L(x)`, :math:`H_m = w H_a + (1 - w) H_b`, :math:`E_x`
    the local mean (two pyramid levels down and up) of :math:`\sum_c H_{x,c}^2`, the
    result is :math:`m + (g - 1) H_m` with
    :math:`g = \sqrt{(w E_a + (1 - w) E_b) / E_m}` clipped to
    :math:`[1, 1 / \sqrt{w^2 + (1 - w)^2}]` (:math:`g = 1` where :math:`E_m = 0`).
    The pyramid levels are OpenCV's ``pyrDown``/``pyrUp`` (5-tap, reflect-101), as in
    :func:`~fluidnb.videodb.rendering._phase_blend.variance_blend`, which computes
    the same in float32 (they agree to float32 rounding).
    """
    import cv2

    a = np.asarray(a, np.float32)
    b = np.asarray(b, np.float32)
    w = np.broadcast_to(np.asarray(weight, np.float64), a.shape[:2])

    def low(x):
        return cv2.pyrUp(cv2.pyrDown(x), dstsize=(x.shape[1], x.shape[0])).reshape(x.shape)

    def local(e):
        half = cv2.pyrDown(e)
        quarter = cv2.pyrDown(half)
        half = cv2.pyrUp(quarter, dstsize=(half.shape[1], half.shape[0]))
        return cv2.pyrUp(half, dstsize=(e.shape[1], e.shape[0])).astype(np.float64)

    wc = w[..., None] if a.ndim == 3 else w
    ha = a - low(a).astype(np.float64)
    hb = b - low(b).astype(np.float64)
    hm = wc * ha + (1 - wc) * hb
    per_pixel = (lambda x: (x * x).sum(axis=-1)) if a.ndim == 3 else (lambda x: x * x)
    e_a, e_b, e_m = (local(per_pixel(x).astype(np.float32)) for x in (ha, hb, hm))
    want = w * e_a + (1 - w) * e_b
    cap = 1 / np.sqrt(w * w + (1 - w) ** 2)
    g = np.where(e_m > 1e-20, np.sqrt(np.maximum(want, 0) / np.where(e_m > 1e-20, e_m, 1)), 1.0)
    g = np.clip(g, 1.0, cap)
    g = g[..., None] if a.ndim == 3 else g
    return wc * a + (1 - wc) * b + (g - 1) * hm


# ------------------------------------------------ the background's fill (beyond the paper)


def reference_fill(image, hole, *, seed=0):
    r"""Exemplar-based fill, Wexler et al.'s completion with an exhaustive search (slow).

    What :func:`~fluidnb.videodb.rendering.exemplar_fill` computes, written plainly:
    coarse to fine over a pyramid of 2 x 2 means (a coarse pixel is in the hole if any
    of its four is) down to about 24 pixels on the shorter side; the coarsest hole
    first filled by a diffusion of its border (Telea's, ``cv2.inpaint``), each finer
    one by the coarser result; then, 8 rounds at the coarsest scale and 3 at the
    others: every 7 x 7 patch that touches the hole is matched to the patch wholly
    outside the hole (and the image's border) of least sum of squared differences --
    here by comparing it with *every* such patch, where the fast path's PatchMatch
    samples a few -- and every hole pixel becomes the mean of what the matches of the
    patches over it say. At full size each hole pixel finally takes the centre of its
    own patch's match. Its matches are the best there are, so the fast path's fills
    explain the hole at most a little worse (the tests check how much), and the fills
    look alike. Only for small images; ``seed`` is unused (nothing is random).
    """
    img = np.array(image, np.float32)
    grey = img.ndim == 2
    if grey:
        img = img[..., None]
    h = np.asarray(hole) > 0
    if h.shape != img.shape[:2]:
        raise ValueError(f"hole must have the image's height and width {img.shape[:2]}")
    if not h.any():
        return img[..., 0] if grey else img
    r = PATCH_RADIUS
    offsets = [(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1)]

    def shrink(im, ho):
        hh, ww = ho.shape
        pad = ((0, hh % 2), (0, ww % 2))
        im = np.pad(im, pad + ((0, 0),), mode="edge")
        ho = np.pad(ho, pad, mode="edge")
        small = (im[0::2, 0::2] + im[1::2, 0::2] + im[0::2, 1::2] + im[1::2, 1::2]) / 4
        return small.astype(np.float32), ho[0::2, 0::2] | ho[1::2, 0::2] | ho[0::2, 1::2] | ho[
            1::2, 1::2
        ]

    def near(ho):  # pixels within r of the hole (a patch centred there touches it)
        return ndi.binary_dilation(ho, np.ones((2 * r + 1, 2 * r + 1), bool))

    def telea(im, ho):
        import cv2

        out = im.copy()
        lo, hi = float(im.min()), float(im.max())
        scale = 65535.0 / (hi - lo) if hi > lo else 1.0
        for k in range(im.shape[2]):
            u16 = np.round((im[..., k] - lo) * scale).astype(np.uint16)
            filled = cv2.inpaint(u16, ho.astype(np.uint8), 3.0, cv2.INPAINT_TELEA)
            out[..., k][ho] = filled[ho] / np.float32(scale) + np.float32(lo)
        return out

    def best_matches(im, targets, sources):
        """For each target centre, the source centre of least SSD (over in-image pixels).

        Every target patch against every source patch: ``sum (t - s)^2`` over the
        target's pixels inside the image, as ``|t|^2 + |s|^2 - 2 t.s`` in float64.
        """
        hh, ww = im.shape[:2]
        im = im.astype(np.float64)
        src = np.stack([im[sources[:, 0] + dy, sources[:, 1] + dx] for dy, dx in offsets], 1)
        ty = targets[:, None, 0] + np.array([dy for dy, _ in offsets])[None]
        tx = targets[:, None, 1] + np.array([dx for _, dx in offsets])[None]
        inside = (ty >= 0) & (ty < hh) & (tx >= 0) & (tx < ww)
        tgt = im[np.clip(ty, 0, hh - 1), np.clip(tx, 0, ww - 1)] * inside[..., None]
        ssd = (
            (tgt**2).sum(axis=(1, 2))[:, None]
            + inside.astype(np.float64) @ (src**2).sum(axis=2).T
            - 2.0 * tgt.reshape(len(targets), -1) @ src.reshape(len(sources), -1).T
        )
        return sources[np.argmin(ssd, axis=1)]

    levels = [(img, h)]
    while min(levels[-1][1].shape) >= 48 and levels[-1][1].any():
        levels.append(shrink(*levels[-1]))
    est = None
    for depth, (im, ho) in enumerate(reversed(levels)):
        im = im.copy()
        bad = near(ho)
        bad[:r], bad[-r:], bad[:, :r], bad[:, -r:] = True, True, True, True
        sources = np.argwhere(~bad)
        if len(sources) == 0:
            if depth == len(levels) - 1:
                raise ValueError("hole leaves no 7 x 7 patch of the image to fill it from")
            est = None
            continue
        targets = np.argwhere(near(ho))
        if est is None:
            im = telea(im, ho)
        else:
            up = np.repeat(np.repeat(est, 2, axis=0), 2, axis=1)[: ho.shape[0], : ho.shape[1]]
            im[ho] = up[ho]
        for _ in range(8 if depth == 0 else 3):
            matches = best_matches(im, targets, sources)
            # Each hole pixel: the mean of what the matches of the patches over it say.
            acc = np.zeros(im.shape)
            count = np.zeros(ho.shape)
            for dy, dx in offsets:
                y, x = targets[:, 0] + dy, targets[:, 1] + dx
                ok = (y >= 0) & (y < ho.shape[0]) & (x >= 0) & (x < ho.shape[1])
                ok[ok] = ho[y[ok], x[ok]]
                np.add.at(acc, (y[ok], x[ok]), im[matches[ok, 0] + dy, matches[ok, 1] + dx])
                np.add.at(count, (y[ok], x[ok]), 1.0)
            voted = ho & (count > 0)
            im[voted] = acc[voted] / count[voted][:, None]
        if depth == len(levels) - 1:
            matches = best_matches(im, targets, sources)
            centre = ho[targets[:, 0], targets[:, 1]]
            im[targets[centre, 0], targets[centre, 1]] = im[matches[centre, 0], matches[centre, 1]]
        est = im
    out = np.where(h[..., None], est, img)
    return out[..., 0] if grey else out
