r"""Blending the assigned fragments' difference frames into one video (Okabe et al., sec. 6).

Every target fragment :math:`p` has been assigned a database fragment whose :math:`N`
frames :math:`F_i` split into the mean image :math:`A = \frac{1}{N}\sum_i F_i` and the
difference frames :math:`D_i = F_i - A`. Overlapping fragments' :math:`D_i` are
blended into one difference video with Laplacian pyramids (multi-band blending, Burt &
Adelson 1983; Okabe et al., Fig. 9): every band of every fragment's Laplacian pyramid
is weighted by the Gaussian pyramid of the fragment's weight, the weighted bands are
summed and divided, level by level, by the sum of the weights' pyramids (as OpenCV's
``MultiBandBlender``), and the result is collapsed. Low frequencies are blended over
wide transitions and high ones over narrow ones, so no seam shows.

- :func:`fragment_weights`: the weights, flat-topped tents over each fragment's cell
  that sum to one over the canvas;
- :func:`blend_differences`: the blend (the fast path: phase layers, float32 pyramids);
- :func:`blend_values`: per-fragment values (a mean motion, say) spread over the canvas
  with the same weights.

The blend's pyramids run in float32 (``precision="float32"`` of
:func:`fluidnb.fields.laplacian_pyramid` and its kin, compiled or through OpenCV: the
same Gaussian of ``sigma = 1`` truncated at 4 sigma, the same half-sample-symmetric
border and the same pixel-centre-aligned bilinear resampling as the float64 pyramids,
to float32 round-off). :func:`fluidnb.videodb.reference_blend_differences` is the blend written
per fragment, as one would first write it, with the float64 pyramids.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numba import njit

from ..._threads import spread_pool
from ..._validation import check_array, check_int, check_range
from ...fields._pyramid import _collapse32, _gaussian32, _laplacian32
from .._common._geometry import FRAGMENT, STRIDE

__all__ = [
    "BLEND_LEVELS",
    "FEATHER",
    "MARGIN",
    "blend_differences",
    "blend_values",
    "fragment_weights",
]

#: Default width in pixels of the level-0 transition between neighbouring fragments'
#: cells (:func:`fragment_weights`). 24 would be the plain tent: every pixel's finest
#: detail then mixes two or four fragments, and two unrelated textures mixed half and
#: half lose half their variance, a grid of washed-out bands 24 px apart. 0 is Burt &
#: Adelson's binary masks: full contrast, but a 4-level pyramid of sigma-1 blurs still
#: leaves a visible line between smooth textures. Measured on pairs of independent
#: textures (blur 0.7-3 px): 8 px keeps 73-79 % of the variance on average (the tent
#: 53-56 %, binary 80-96 %) with a gradient jump at the cell borders within 1.2 times
#: the tent's (binary: 1.6-3.7 times).
FEATHER = 8

#: Pyramid levels of :func:`blend_differences` by default: 48 -> 24 -> 12 -> 6 pixels a
#: fragment. The residual (level 3, one pixel per 8) is then blended over about a
#: fragment's width, while deeper levels would spread the weights beyond the context the
#: fragments bring (their margin) and lean on the fill.
BLEND_LEVELS = 4

# Threads building the phase layers' pyramids.
_THREADS = 2
# Same-phase fragments of the stride-24 grid are _PHASES * STRIDE = 72 pixels apart.
_PHASES = 3
#: The context (pixels) around a fragment's 48 x 48 core that the blend uses: with it,
#: each fragment fills a 72 x 72 tile of its phase layer without touching its
#: phase-mates' tiles (12 px). What the render rebuilds of each assigned fragment.
MARGIN = (_PHASES * STRIDE - FRAGMENT) // 2
# Floor of the raw 1-D weight profile: keeps every fragment's weight positive on its
# whole core, so the normalisation never divides by zero where neighbours are missing
# (at the canvas border, or fragments that do not take part) and stays continuous.
_FLOOR = 1e-3
# Per-level weight sums at or below this count as "no fragment here" (far outside the
# cores). The normalised bands are weighted averages, so any positive sum is safe to
# divide by; only exact zeros (and float32 denormals) are left out. Not larger: a
# corner pixel of the canvas has a raw weight of _FLOOR ** 2 = 1e-6.
_TINY = 1e-30


# --------------------------------------------------------------------------------------
# Partition-of-unity weights
# --------------------------------------------------------------------------------------


def _profile(feather):
    """Raw 1-D weight over a fragment's 48 pixels (floored, not yet normalised).

    ``e`` is the distance of a pixel centre to the nearer core edge (0.5 .. 23.5 px);
    the boundary between two neighbours' cells lies at ``e = 12``. A linear ramp of
    width ``feather`` centred there sums to one with the neighbour's mirrored ramp.
    """
    u = np.arange(FRAGMENT, dtype=np.float64) + 0.5
    e = np.minimum(u, FRAGMENT - u)
    half = STRIDE / 2
    if feather == 0:
        ramp = (e > half).astype(np.float64)
    else:
        ramp = np.clip((e - half) / feather + 0.5, 0.0, 1.0)
    return np.maximum(ramp, _FLOOR)


def _raw_weights(feather):
    p = _profile(feather)
    return np.outer(p, p)


def _check_positions(positions, canvas_shape):
    shape = _check_canvas(canvas_shape)
    pos = check_array("positions", positions, ndim=2, dtype_kinds="iuf", min_size=0)
    if pos.shape[1:] != (2,):
        raise ValueError(f"positions must have shape (P, 2) as (row, col), got {pos.shape}")
    if pos.dtype.kind == "f" and not np.all(pos == np.round(pos)):
        raise ValueError("positions must hold whole pixels, got fractional values")
    pos = pos.astype(np.int64)
    if pos.size and np.any(pos % STRIDE):
        raise ValueError(
            f"positions must be multiples of the stride {STRIDE}, got "
            f"{pos[np.any(pos % STRIDE, axis=1)][0].tolist()}"
        )
    if pos.size and (
        pos.min() < 0
        or np.any(pos[:, 0] + FRAGMENT > shape[0])
        or np.any(pos[:, 1] + FRAGMENT > shape[1])
    ):
        raise ValueError(
            f"positions must place every {FRAGMENT} x {FRAGMENT} core inside the canvas "
            f"{shape}, got rows {pos[:, 0].min()}..{pos[:, 0].max()} and cols "
            f"{pos[:, 1].min()}..{pos[:, 1].max()}"
        )
    if len(np.unique(pos, axis=0)) != len(pos):
        raise ValueError("positions must not repeat: one fragment per grid position")
    return pos, shape


def _check_canvas(canvas_shape):
    try:
        shape = tuple(int(check_int("canvas_shape", s, FRAGMENT)) for s in canvas_shape)
    except TypeError:
        raise ValueError(f"canvas_shape must be (H, W), got {canvas_shape!r}") from None
    if len(shape) != 2:
        raise ValueError(f"canvas_shape must be (H, W), got {canvas_shape!r}")
    return shape


def _check_feather(feather):
    return check_range("feather", feather, 0, STRIDE)


def _weight_sum(pos, shape, raw):
    total = np.zeros(shape, dtype=np.float64)
    for r, c in pos:
        total[r : r + FRAGMENT, c : c + FRAGMENT] += raw
    return total


def fragment_weights(positions, canvas_shape, *, feather=FEATHER):
    """Partition-of-unity weights of the fragments on the stride-24 grid.

    Each fragment gets a weight over its 48 x 48 core: the product of two 1-D profiles
    that ramp linearly across the boundary between its cell and its neighbours' (the
    line halfway between their centres, 12 px inside the core), over ``feather``
    pixels (a flat-topped tent), then every weight is divided by the sum of all
    fragments' weights at each pixel. With ``feather = 24`` the profile is the plain
    tent of a fragment (0.5/24 at the core's edge, 1 at its centre) and neighbours'
    tents already sum to one; with ``feather = 0`` each pixel belongs to the fragment
    whose centre is nearest (Burt & Adelson's binary masks); the default,
    :data:`FEATHER` = 8, keeps most of the fine detail's contrast and no seam (see
    there). Raw profiles are floored at 1e-3, so the division makes the weights sum to
    exactly one (to rounding) everywhere in the union of the cores, also at the canvas
    border and next to fragments that do not take part, where fewer fragments cover a
    pixel, and the weights stay continuous there.

    Parameters
    ----------
    positions : ndarray, shape (P, 2), int
        Top-left (row, col) of each taking-part fragment's core on the canvas,
        multiples of 24.
    canvas_shape : tuple of int, (Hc, Wc)
        The canvas the fragments tile.
    feather : float
        Width in pixels of the linear transition between neighbouring cells, in
        [0, 24].

    Returns
    -------
    ndarray, shape (P, 48, 48), float64
        Pasted at their positions and summed, 1 on every pixel a core covers, 0
        elsewhere.

    References
    ----------
    .. [1] P. J. Burt and E. H. Adelson, "A multiresolution spline with application to
       image mosaics", ACM Transactions on Graphics 2(4), pp. 217-236, 1983.

    Examples
    --------
    >>> w = fragment_weights([[0, 0], [0, 24]], (48, 72))
    >>> w.shape
    (2, 48, 48)
    >>> total = np.zeros((48, 72))
    >>> total[:, :48] += w[0]
    >>> total[:, 24:] += w[1]
    >>> bool(np.allclose(total, 1.0, rtol=0, atol=1e-12))
    True
    """
    pos, shape = _check_positions(positions, canvas_shape)
    raw = _raw_weights(_check_feather(feather))
    total = _weight_sum(pos, shape, raw)
    out = np.empty((len(pos), FRAGMENT, FRAGMENT), dtype=np.float64)
    for k, (r, c) in enumerate(pos):
        out[k] = raw / total[r : r + FRAGMENT, c : c + FRAGMENT]
    return out


# --------------------------------------------------------------------------------------
# Blending the difference frames
# --------------------------------------------------------------------------------------


def _check_diffs(diffs, n_pos):
    d = check_array("diffs", diffs, ndim=4, dtype_kinds="iuf", min_size=0)
    if d.shape[0] != n_pos:
        raise ValueError(
            f"diffs must hold one fragment per position ({n_pos}), got shape {d.shape}"
        )
    if d.shape[2] != d.shape[3] or (d.shape[2] - FRAGMENT) % 2 or d.shape[2] < FRAGMENT:
        raise ValueError(
            f"diffs must have square frames of {FRAGMENT} + 2 * margin pixels, got shape {d.shape}"
        )
    return d


def _check_levels(levels):
    return BLEND_LEVELS if levels is None else check_int("levels", levels, 1, 8)


def _window(r, c, m, size, shape):
    """Slices of a fragment's window of ``size`` pixels, on the canvas and in its data.

    The window is the core grown by ``(size - 48) / 2`` on each side, cut to the
    canvas; the data is the fragment's own (48 + 2m)-window.
    """
    h = (size - FRAGMENT) // 2
    r0, r1 = max(r - h, 0), min(r + FRAGMENT + h, shape[0])
    c0, c1 = max(c - h, 0), min(c + FRAGMENT + h, shape[1])
    rows = slice(r0 - r + m, r1 - r + m)
    cols = slice(c0 - c + m, c1 - c + m)
    return (slice(r0, r1), slice(c0, c1)), (rows, cols)


def _fill(d, pos, m, shape, den=None):
    """Feathered average of all fragments' data windows, (Hc, Wc, N) float32.

    ``d`` is pixel-major, (P, 48 + 2m, 48 + 2m, N). It stands in wherever a phase
    layer has no fragment of its own; it is the data itself where the fragments agree,
    so identical inputs blend back exactly. ``den``, the windows' summed tents
    (:func:`_fill_weights`), if already made.
    """
    tau = _fill_tent(m)
    if den is None:
        den = _fill_weights(pos, m, shape)
    acc = np.zeros(shape + (d.shape[3],), dtype=np.float32)
    pos = np.ascontiguousarray(pos, np.int64)
    # Bands of rows on the cores: each pixel still sums the fragments in their order.
    rows = np.linspace(0, shape[0], _THREADS + 1).astype(int)

    def band(k):
        _accumulate_windows(d, pos, m, tau, acc, rows[k], rows[k + 1])
        _divide_rows(acc[rows[k] : rows[k + 1]], den[rows[k] : rows[k + 1]])

    list(_in_order(band, range(_THREADS)))
    return acc


def _fill_tent(m):
    """The fill's weight over a fragment's (48 + 2m)-window: its distance to the edges."""
    s = FRAGMENT + 2 * m
    u = np.arange(s, dtype=np.float64) + 0.5
    tau = np.minimum(u, s - u)
    return np.outer(tau, tau).astype(np.float32)


def _fill_weights(pos, m, shape):
    """The fill's denominator: every window's tent summed in the fragments' order (float32)."""
    tau = _fill_tent(m)
    den = np.zeros(shape, dtype=np.float32)
    for r, c in pos:
        (rs, cs), (wr, wc) = _window(r, c, m, tau.shape[0], shape)
        den[rs, cs] += tau[wr, wc]
    return den


@njit(cache=True, nogil=True)
def _accumulate_windows(d, pos, m, tau, acc, row0, row1):
    """``acc += tau * D_k`` over every fragment's window (in order), on rows ``row0:row1``.

    The window of :func:`_window` (the core and ``m`` pixels of context, cut to the
    canvas): float32 products and sums in the order of the fragments, as the numpy
    loop ``acc[rs, cs] += D_k[wr, wc] * tau`` gives them.
    """
    n = d.shape[3]
    s = d.shape[1]
    w = acc.shape[1]
    for k in range(pos.shape[0]):
        r0 = pos[k, 0] - m
        c0 = pos[k, 1] - m
        for i in range(max(0, row0 - r0), min(s, row1 - r0)):
            for j in range(max(0, -c0), min(s, w - c0)):
                t = tau[i, j]
                cell = acc[r0 + i, c0 + j]
                src = d[k, i, j]
                for f in range(n):
                    cell[f] += src[f] * t


@njit(cache=True, nogil=True)
def _divide_rows(acc, den):
    """``acc /= den`` where ``den > 0`` (per pixel, every channel), as numpy's masked divide."""
    h, w, n = acc.shape
    for i in range(h):
        for j in range(w):
            q = den[i, j]
            if q > 0:
                for f in range(n):
                    acc[i, j, f] = acc[i, j, f] / q


def _layers(pos):
    phase = (pos // STRIDE) % _PHASES
    keys = phase[:, 0] * _PHASES + phase[:, 1]
    return [np.flatnonzero(keys == k) for k in range(_PHASES * _PHASES) if np.any(keys == k)]


def blend_differences(diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER):
    r"""Blend the fragments' difference frames :math:`D_i` into one difference video.

    Multi-band alpha blending (Burt & Adelson 1983) of all fragments (Okabe et al., sec. 6,
    Fig. 9): every band of every fragment's Laplacian pyramid is weighted by the
    Gaussian pyramid of its weight (the flat-topped tent of :func:`fragment_weights`
    before that function's normalisation), the weighted bands are summed and divided,
    level by level, by the sum of the weights' pyramids (as OpenCV's
    ``MultiBandBlender``), and the result is collapsed. Low frequencies are blended
    over wide transitions and high ones over narrow ones, so no seam shows.

    Design: fragments on the stride-24 grid fall into 9 phase layers,
    ``(row / 24 mod 3, col / 24 mod 3)``. Same-phase fragments are 72 px apart, so
    each one, with 12 px of its own context (``margin``), fills a 72 x 72 tile of its
    layer without overlapping its phase-mates. Each layer is one canvas image (frames
    batched as channels) whose pyramid serves all its fragments at once: 9 pyramids of
    the canvas instead of one per fragment (each pixel lies in 4 cores, so the work is
    that of per-fragment pyramids with margins, in 9 large calls), and the bands under
    a fragment's weights come from its own pixels and context, up to the coarsest
    levels, whose weights reach past the tile. Where a layer has no fragment (the
    canvas border, absent neighbours, beyond a short margin) it holds the feathered
    average of all fragments' data (the fill), which equals the data where the
    fragments agree, so identical inputs come back exactly. Dividing every level by
    its weight sum keeps the weights a partition of unity at every level, also where
    fewer fragments cover a pixel. The output is zero outside the union of the cores.

    :func:`fluidnb.videodb.reference_blend_differences` is the same blend written one
    fragment at a time, each fragment extended beyond its data by the fill. It
    differs from this one only where a fragment's coarsest weights reach past its
    tile, which here holds its phase-mates' frames rather than the fill: with up to 3
    levels, or up to 3 x 3 fragments, the two agree to float32 round-off; with the
    default 4 levels, on the quick starter render of the stream (49 fragments), by at
    most 4.6e-3 of luminance at one pixel (1.2 grey levels of 255; 1e-4 rms).

    Measured (2 shared cores, 32 frames, margin 12): 91 fragments on 336 x 192 in
    0.4 s, 364 on 648 x 360 in 1.4-2.6 s.

    Parameters
    ----------
    diffs : ndarray, shape (P, N, 48 + 2m, 48 + 2m)
        Each taking-part fragment's difference frames :math:`D_i = F_i - A` (grey),
        with ``m = margin`` pixels of context from its source clip on each side.
    positions : ndarray, shape (P, 2), int
        Top-left (row, col) of each fragment's 48 x 48 core on the canvas, multiples
        of 24.
    canvas_shape : tuple of int, (Hc, Wc)
        The padded target's size.
    margin : int
        The context ``m`` around each core in ``diffs`` (>= 0). 12 fills the phase
        tiles; more is used by the fill only; less leaves more of each tile to the fill.
    levels : int, optional
        Pyramid levels (1 is a plain alpha blend); by default :data:`BLEND_LEVELS`.
    feather : float
        Width of the level-0 transition between neighbouring fragments, in [0, 24]
        (24: the tent; 0: binary masks); see :func:`fragment_weights` and
        :data:`FEATHER`.

    Returns
    -------
    ndarray, shape (N, Hc, Wc), float32
        The blended difference video; exactly 0 on pixels no core covers.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Pacific Graphics 2011, section 6.
    .. [2] P. J. Burt and E. H. Adelson, "A multiresolution spline with application to
       image mosaics", ACM Transactions on Graphics 2(4), pp. 217-236, 1983.

    Examples
    --------
    Fragments cut from one sequence blend back into it:

    >>> rng = np.random.default_rng(0)
    >>> video = rng.standard_normal((2, 96, 96)).astype(np.float32)
    >>> padded = np.pad(video, ((0, 0), (12, 12), (12, 12)), mode="reflect")
    >>> pos = np.array([(r, c) for r in (0, 24, 48) for c in (0, 24, 48)])
    >>> diffs = np.stack([padded[:, r : r + 72, c : c + 72] for r, c in pos])
    >>> out = blend_differences(diffs, pos, (96, 96), margin=12)
    >>> bool(np.abs(out - video).max() < 1e-5)
    True
    """
    pos, shape = _check_positions(positions, canvas_shape)
    m = check_int("margin", margin, 0)
    d = _check_diffs(diffs, len(pos))
    if d.shape[2] != FRAGMENT + 2 * m:
        raise ValueError(
            f"diffs must be {FRAGMENT} + 2 * margin = {FRAGMENT + 2 * m} pixels wide, "
            f"got shape {d.shape}"
        )
    pixel_major = np.ascontiguousarray(np.moveaxis(d, 1, 3), dtype=np.float32)
    return _blend(pixel_major, pos, shape, m, _check_levels(levels), _check_feather(feather))


def _blend(d, pos, shape, m, levels, feather, plan=None):
    """:func:`blend_differences` on checked, pixel-major differences (P, s, s, N) float32.

    The renderer's own differences come this way (:func:`difference_frames` writes
    them so): each fragment's window is then pasted into its layer and the fill as
    contiguous blocks. ``plan``: the :class:`_BlendPlan` of these positions, canvas,
    margin, levels and feather, if already made (a renderer blends its frames a few
    at a time).
    """
    n = d.shape[3]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    if plan is None:
        plan = _BlendPlan(pos, shape, m, levels, feather)
    fill = _fill(d, pos, m, shape, plan.fill_den)

    def bands(index):
        """One phase layer's Laplacian bands L_l(X), each weighted by G_l(W)."""
        layer = fill.copy()
        for k in plan.layers[index]:
            r, c = pos[k]
            (rs, cs), (wr, wc) = _window(r, c, m, plan.tile, shape)
            layer[rs, cs] = d[k, wr, wc]
        # The pyramids' float32 kernels themselves: the inputs are this function's.
        weighted = _laplacian32(layer, levels)
        for band, g in zip(weighted, plan.weights[index]):
            _weigh(band, g)
        return weighted

    # The layers' pyramids on threads (the compiled kernels release the GIL; a few
    # layers in flight), weighted there, and summed here in layer order: the same sums
    # as one thread's (each product rounded, then added).
    acc = None
    for bs in _in_order(bands, range(len(plan.layers))):
        if acc is None:
            acc = bs
            continue
        for a, b in zip(acc, bs):
            np.add(a, b, out=a)
    for a, s in zip(acc, plan.weight_sums):
        _normalise(a, s, np.float32(_TINY))
    out = _collapse32(acc)
    frames = np.empty((n,) + shape, dtype=np.float32)
    _covered_frames(out, plan.covered, frames)
    return frames


class _BlendPlan:
    """What the blend of one set of positions shares across batches of frames.

    The phase layers, each layer's weight pyramid :math:`G_l(W)` and their sums per
    level (summed in layer order, as the blend sums the bands), the fill's
    denominator and the union of the cores: none depends on the frames.
    """

    def __init__(self, pos, shape, m, levels, feather):
        raw = _raw_weights(feather).astype(np.float32)
        self.layers = _layers(pos)
        self.tile = FRAGMENT + 2 * min(m, MARGIN)
        self.fill_den = _fill_weights(pos, m, shape)
        self.weights = []
        for members in self.layers:
            weight = np.zeros(shape + (1,), dtype=np.float32)
            for r, c in pos[members]:
                weight[r : r + FRAGMENT, c : c + FRAGMENT, 0] = raw
            self.weights.append(_gaussian32(weight, levels))
        sums = [g.copy() for g in self.weights[0]]
        for gw in self.weights[1:]:
            for s, g in zip(sums, gw):
                s += g
        self.weight_sums = sums
        self.covered = _weight_sum(pos, shape, np.ones((FRAGMENT, FRAGMENT))) > 0


@njit(cache=True, nogil=True)
def _weigh(band, weight):
    """``band *= weight`` in place: ``weight`` (h, w, 1) over every frame of ``band`` (h, w, N).

    numpy's broadcast multiply, a pixel's frames as one contiguous run (twice as fast).
    """
    h, w, n = band.shape
    rows = band.reshape(h * w, n)
    g = weight.reshape(h * w)
    for p in range(h * w):
        s = g[p]
        row = rows[p]
        for f in range(n):
            row[f] *= s


@njit(cache=True, nogil=True)
def _normalise(acc, total, tiny):
    """``acc / total`` where ``total > tiny``, else 0 (each level of the blend), in place."""
    h, w, n = acc.shape
    for i in range(h):
        for j in range(w):
            s = total[i, j, 0]
            if s > tiny:
                for f in range(n):
                    acc[i, j, f] = acc[i, j, f] / s
            else:
                for f in range(n):
                    acc[i, j, f] = 0.0


@njit(cache=True, nogil=True)
def _covered_frames(blended, covered, out):
    """The collapsed blend (Hc, Wc, N) times the cores' union, frame-major (N, Hc, Wc).

    A canvas row at a time, each frame's row written in one run (the row read
    from cache): five times as fast as pixel by pixel with strided writes.
    """
    h, w, n = blended.shape
    for i in range(h):
        row = blended[i]
        cover = covered[i]
        for f in range(n):
            o = out[f, i]
            for j in range(w):
                c = np.float32(1.0) if cover[j] else np.float32(0.0)
                o[j] = row[j, f] * c


def difference_frames(frames, loop=0, *, out=None):
    r"""A fragment's difference frames :math:`D_i = F_i - A`, cross-faded to loop, pixel-major.

    :math:`A = \frac{1}{N} \sum_i F_i` in float32 (summed in frame order, as
    ``frames.mean(axis=0)``), then, with ``loop`` > 0, :func:`loop_crossfade`'s
    equal-power fade of the last ``loop`` frames into the first, in one pass (in
    float64, as it does). Written pixel-major, as the blend reads them.

    Parameters
    ----------
    frames : ndarray, shape (N, h, w), float32
        A fragment's frames :math:`F_i`.
    loop : int
        Frames to cross-fade, in [0, N // 2].
    out : ndarray, shape (h, w, N - loop), float32, optional

    Returns
    -------
    ndarray, shape (h, w, N - loop), float32
    """
    f = np.ascontiguousarray(frames, dtype=np.float32)
    loop = check_int("loop", loop, 0, f.shape[0] // 2)
    if out is None:
        out = np.empty((*f.shape[1:], f.shape[0] - loop), np.float32)
    theta = 0.5 * np.pi * np.arange(1, loop + 1) / (loop + 1)
    _difference_frames(f, np.sin(theta), np.cos(theta), out)
    return out


@njit(cache=True, nogil=True)
def _difference_frames(f, sin, cos, out):
    n = f.shape[0]
    loop = sin.shape[0]
    length = n - loop
    h, w = f.shape[1:]
    # A: the frames summed in order, whole frames at a time (numpy's float32 mean).
    a = f[0].copy()
    for i in range(1, n):
        a += f[i]
    a /= np.float32(n)
    # A row at a time, frame by frame along the row (each pixel's sums still in frame
    # order): the pixels of a row are independent, so their sums go side by side.
    d = np.empty((n, w), np.float32)
    m = np.empty(w)
    for r in range(h):
        for i in range(n):
            for c in range(w):
                d[i, c] = f[i, r, c] - a[r, c]
        for c in range(w):
            o = out[r, c]
            for i in range(loop, length):
                o[i] = d[i, c]
        if loop == 0:
            continue
        # The fade's mean of D (zero but for rounding), in float64 as loop_crossfade.
        m[:] = 0.0
        for i in range(n):
            for c in range(w):
                m[c] += np.float64(d[i, c])
        for c in range(w):
            mc = m[c] / n
            o = out[r, c]
            for j in range(loop):
                head = np.float64(d[j, c]) - mc
                tail = np.float64(d[length + j, c]) - mc
                o[j] = np.float32(mc + sin[j] * head + cos[j] * tail)


def play_loops(loops, offsets, *, rates=None, n_frames=None, mirrors=None, frames=None):
    r"""Every fragment's loop played from its offset, mirrored, at its rate, pixel-major.

    What :func:`fluidnb.videodb.stagger` does after making the loops, for loops
    already made (:func:`difference_frames`, kept in the frame cache) and laid out as
    the blend reads them: fragment ``p`` shows frame :math:`(o_p + r_p t) \bmod L` of
    its loop at time :math:`t` (linear between frames at fractional times), flipped
    across ``mirrors[p]`` (0: upside down, 1: left to right, -1: not). The times are
    computed as ``stagger`` computes them and the interpolation is the same float32
    ``a + f (b - a)``, so the frames are ``stagger``'s bit for bit (tested).

    Parameters
    ----------
    loops : sequence of ndarray, shape (s, s, L), float32
        Each fragment's loop, pixel-major.
    offsets : ndarray, shape (P,)
        :math:`o_p`, in frames.
    rates : ndarray, shape (P,), optional
        :math:`r_p`, frames of the loop played per frame (default 1).
    n_frames : int, optional
        Frames to make (default :math:`L`).
    mirrors : ndarray, shape (P,), optional
        Per fragment -1, 0 or 1 (default -1).
    frames : array_like of int, optional
        Which frames :math:`t` to make (default ``range(n_frames)``): a renderer
        makes a clip a few frames at a time; each frame is the same however the clip
        is cut.

    Returns
    -------
    ndarray, shape (P, s, s, len(frames)), float32
    """
    p = len(loops)
    offs = np.asarray(offsets, np.float64)
    if offs.shape != (p,):
        raise ValueError(f"offsets must have shape ({p},), got {offs.shape}")
    if frames is not None:
        t = np.asarray(frames)
        if t.ndim != 1 or t.dtype.kind not in "iu" or (len(t) and t.min() < 0):
            raise ValueError("frames must be a 1-D array of frame numbers >= 0")
    if p == 0:
        n = len(t) if frames is not None else (0 if n_frames is None else n_frames)
        return np.zeros((0, FRAGMENT, FRAGMENT, n), np.float32)
    side, length = loops[0].shape[0], loops[0].shape[2]
    if frames is None:
        n_frames = length if n_frames is None else check_int("n_frames", n_frames, 1)
        t = np.arange(n_frames)
    n_frames = len(t)
    r = np.ones(p) if rates is None else np.asarray(rates, np.float64)
    flips = np.full(p, -1, np.int64) if mirrors is None else np.asarray(mirrors, np.int64)
    if r.shape != (p,) or flips.shape != (p,):
        raise ValueError(f"rates and mirrors must have shape ({p},)")
    # As stagger: times mod L in float64, the frame below and the fraction in float32.
    times = np.mod(offs[:, None] + r[:, None] * t[None, :], length)
    i0 = np.floor(times).astype(np.int64)
    frac = (times - i0).astype(np.float32)
    below, above = i0 % length, (i0 + 1) % length
    out = np.empty((p, side, side, n_frames), np.float32)
    loops = [np.ascontiguousarray(x, np.float32) for x in loops]

    def play(k0, k1):
        for k in range(k0, k1):
            _play_loop(loops[k], below[k], above[k], frac[k], flips[k], out[k])

    # Each fragment on its own (the kernel releases the GIL): half of them on each core.
    bounds = np.linspace(0, p, _THREADS + 1).astype(int)
    list(_in_order(lambda k: play(bounds[k], bounds[k + 1]), range(_THREADS)))
    return out


@njit(cache=True, nogil=True)
def _play_loop(loop, below, above, frac, mirror, out):
    side = loop.shape[0]
    for r in range(side):
        rr = side - 1 - r if mirror == 0 else r
        for c in range(side):
            cc = side - 1 - c if mirror == 1 else c
            src = loop[rr, cc]
            dst = out[r, c]
            for t in range(frac.shape[0]):
                v = src[below[t]]
                if frac[t] != 0:
                    v = v + frac[t] * (src[above[t]] - v)
                dst[t] = v


def _in_order(fn, items):
    """``fn(item)`` for every item, computed on threads, yielded in the items' order.

    At most one more call than there are threads is in flight (each holds a layer's
    pyramids).
    """
    items = list(items)
    workers = min(_THREADS, len(items))
    if workers <= 1:
        yield from map(fn, items)
        return
    with spread_pool(workers, "fluidnb-blend") as pool:
        pending = deque()
        try:
            for item in items:
                pending.append(pool.submit(fn, item))
                if len(pending) > workers:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for future in pending:
                future.cancel()


def blend_values(values, positions, canvas_shape):
    r"""Per-fragment values spread over the canvas by the blend's weights.

    Parameters
    ----------
    values : ndarray, shape (P, ...)
        One value (a vector, a sequence...) per fragment, e.g. its mean motion (P, 2).
    positions : ndarray, shape (P, 2), int
        Top-left (row, col) of each fragment's core on the canvas, multiples of 24.
    canvas_shape : tuple of int, (Hc, Wc)
        The canvas the fragments tile.

    Returns
    -------
    ndarray, shape (Hc, Wc, ...), float32
        :math:`\sum_p w_p(x)\, v_p` with the weights of :func:`fragment_weights`
        (default feather): the fragments' values where they own the pixel, blended
        across their overlaps, 0 outside every core.
    """
    weights = fragment_weights(positions, canvas_shape)
    out = np.zeros(tuple(canvas_shape) + values.shape[1:], np.float64)
    for (r, c), wgt, v in zip(positions, weights, values):
        out[r : r + FRAGMENT, c : c + FRAGMENT] += wgt.reshape(wgt.shape + (1,) * v.ndim) * v
    return out.astype(np.float32)
