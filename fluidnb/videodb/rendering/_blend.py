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

The weights are :func:`~fluidnb.videodb.rendering.fragment_weights`, flat-topped tents
over each fragment's cell that sum to one over the canvas
(:mod:`fluidnb.videodb._common._weights`); :func:`blend_differences` is the blend (the
fast path: phase layers, float32 pyramids).

The blend's pyramids run in float32 (``precision="float32"`` of
:func:`fluidnb.fields.laplacian_pyramid` and its kin, compiled or through OpenCV: the
same Gaussian of ``sigma = 1`` truncated at 4 sigma, the same half-sample-symmetric
border and the same pixel-centre-aligned bilinear resampling as the float64 pyramids,
to float32 round-off). :func:`~fluidnb.videodb.rendering.reference_blend_differences` is
the blend written per fragment, as one would first write it, with the float64 pyramids.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._validation import check_array, check_int
from ...fields._pyramid import (
    _collapse32,
    _gaussian32,
    _weight_spans32,
    _weighted_laplacian32,
)
from ...fields._pyramid_fused import add_spans
from .._common._geometry import FRAGMENT, STRIDE
from .._common._weights import FEATHER, _check_feather, _check_positions, _raw_weights, _weight_sum
from ._threads import _THREADS, _in_order

__all__ = ["BLEND_LEVELS", "MARGIN", "blend_differences"]


#: Pyramid levels of :func:`blend_differences` by default: 48 -> 24 -> 12 -> 6 pixels a
#: fragment. The residual (level 3, one pixel per 8) is then blended over about a
#: fragment's width, while deeper levels would spread the weights beyond the context the
#: fragments bring (their margin) and lean on the fill.
BLEND_LEVELS = 4

# Same-phase fragments of the stride-24 grid are _PHASES * STRIDE = 72 pixels apart.
_PHASES = 3
#: The context (pixels) around a fragment's 48 x 48 core that the blend uses: with it,
#: each fragment fills a 72 x 72 tile of its phase layer without touching its
#: phase-mates' tiles (12 px). What the render rebuilds of each assigned fragment.
MARGIN = (_PHASES * STRIDE - FRAGMENT) // 2
# Per-level weight sums at or below this count as "no fragment here" (far outside the
# cores). The normalised bands are weighted averages, so any positive sum is safe to
# divide by; only exact zeros (and float32 denormals) are left out. Not larger: a
# corner pixel of the canvas has a raw weight of _FLOOR ** 2 = 1e-6.
_TINY = 1e-30


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
    # A window's row at a time, as flat runs of pixels' frames: contiguous views the
    # compiler vectorises (3.4 times as fast at 1920 px, one frame, as pixel by pixel).
    rows = acc.reshape(acc.shape[0], w * n)
    data = d.reshape(d.shape[0], s, s * n)
    for k in range(pos.shape[0]):
        r0 = pos[k, 0] - m
        c0 = pos[k, 1] - m
        j0, j1 = max(0, -c0), min(s, w - c0)
        for i in range(max(0, row0 - r0), min(s, row1 - r0)):
            cell = rows[r0 + i, (c0 + j0) * n : (c0 + j1) * n]
            src = data[k, i, j0 * n : j1 * n]
            t = tau[i, j0:j1]
            if n == 1:
                for q in range(cell.size):
                    cell[q] += src[q] * t[q]
            else:
                for j in range(t.size):
                    for q in range(j * n, (j + 1) * n):
                        cell[q] += src[q] * t[j]


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
    All of it runs on the box around the fragments' windows and the pyramids' reach
    (:func:`_fragments_box`: the blend of a matte's fragments need not cover the
    photo), the same values as on the whole canvas.

    :func:`fluidnb.videodb.rendering.reference_blend_differences` is the same blend written one
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

    The renderer's own differences come this way (:func:`play_loops` writes them so
    from the frame-major loops): each fragment's window is then pasted into its layer
    and the fill as contiguous blocks. ``plan``: the :class:`_BlendPlan` of these positions, canvas,
    margin, levels and feather, if already made (a renderer blends its frames a few
    at a time).
    """
    n = d.shape[3]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    if plan is None:
        plan = _BlendPlan(pos, shape, m, levels, feather)
    # On the plan's box (the fragments' windows and the pyramids' reach): the same
    # pixels as on the whole canvas, which is 0 outside it.
    d = np.ascontiguousarray(d)  # (the compiled paste reads its rows flat)
    fill = _fill(d, plan.positions, m, plan.shape, plan.fill_den)

    def bands(index):
        """One phase layer's Laplacian bands L_l(X), each weighted by G_l(W), on its spans."""
        layer = fill.copy()
        # Each fragment's window pasted in (_window's slices, compiled: at 1920 px a
        # run of two frames pasted 5,000 windows through Python, 60 ms a frame).
        _paste_windows(layer, d, plan.positions, plan.layers[index], m, plan.tile)
        # The pyramids' float32 kernels themselves: the inputs are this function's.
        # Only where the layer's weight is not 0 (at 1920 px a fifth of a layer's
        # finest level): elsewhere its weighted band is 0 and left out of the sum.
        return _weighted_laplacian32(layer, plan.weights[index], plan.spans[index])

    # The layers' pyramids on threads (the compiled kernels release the GIL; a few
    # layers in flight), and summed here in layer order, each on its spans: the same
    # sums as one thread's (each product rounded, then added). The sums start at -0
    # (x + -0 is x for every x, -0 included), so a pixel's sum is that of the layers
    # weighted there, in order. A layer left out (weight 0) would add its band times
    # 0, +-0: that changes no sum that is not 0, and one of 0 only in its sign where
    # every weighted product is -0 (never in the tests' blends nor at 1920 px: the
    # frames are those of the whole products bit for bit).
    acc = [np.full(g.shape[:2] + (n,), -0.0, np.float32) for g in plan.weight_sums]
    for index, bs in enumerate(_in_order(bands, range(len(plan.layers)))):
        for a, b, (ptr, runs, _, _) in zip(acc, bs, plan.spans[index], strict=True):
            add_spans(a, b, ptr, runs)
    for a, s in zip(acc, plan.weight_sums):
        _normalise(a, s, np.float32(_TINY))
    out = _collapse32(acc)
    r0, r1, c0, c1 = plan.box
    frames = (np.empty if plan.shape == shape else np.zeros)((n,) + shape, dtype=np.float32)
    _covered_frames(out, plan.covered, frames[:, r0:r1, c0:c1])
    return frames


#: The blend runs on the box around the fragments (:func:`_fragments_box`); False: on
#: the whole canvas (the tests compare the two bit for bit).
_BOX = True

#: The box's margin beyond the fragments' windows, in pixels at level 0 per pyramid
#: level (times ``2**levels - 1``). The layers and weights are 0 beyond the windows
#: and cores; each level's Gaussian (sigma 1, cut at 4 sigma) and the bilinear
#: resampling spread what is not 0 by 5 of that level's pixels on the way down and
#: again on the way up: 70 px at 4 levels (measured: the box is the canvas bit for
#: bit from 60 px). Beyond that both hold 0 at every level, so the box's own border
#: (a mirror of 0s) changes nothing. 6: 90 px at 4 levels.
_BOX_REACH = 6


def _fragments_box(pos, shape, m, levels):
    """The box (r0, r1, c0, c1) on the canvas ``shape`` the blend of ``pos`` runs on.

    The fragments' (48 + 2m)-windows grown by the pyramids' reach (:data:`_BOX_REACH`),
    its edges on the coarsest level's grid, within the canvas: each level then halves
    the box exactly, as it halves the canvas, and samples the same points (the
    bilinear resampling maps pixel centres by the ratio of the sizes), so the box's
    pyramid is the canvas's cut out. Along a side of the canvas that is not on that
    grid (a level of odd size), the whole side; with no fragments, the whole canvas.
    """
    whole = (0, shape[0], 0, shape[1])
    if not len(pos):
        return whole
    grid = 2 ** (levels - 1)
    reach = m + _BOX_REACH * (2**levels - 1)
    lo = np.asarray(pos).min(axis=0) - reach
    hi = np.asarray(pos).max(axis=0) + FRAGMENT + reach
    box = []
    for a, b, n in zip(lo, hi, shape):
        if n % grid:
            box += [0, n]
        else:
            box += [max(0, int(a) // grid * grid), min(n, -(-int(b) // grid) * grid)]
    return tuple(box)


class _BlendPlan:
    """What the blend of one set of positions shares across batches of frames.

    The phase layers, each layer's weight pyramid :math:`G_l(W)` and their sums per
    level (summed in layer order, as the blend sums the bands), the fill's
    denominator and the union of the cores: none depends on the frames.
    """

    def __init__(self, pos, shape, m, levels, feather):
        raw = _raw_weights(feather).astype(np.float32)
        # The layers by the fragments' places on the canvas (their phases), then
        # everything on the box, the positions relative to its corner.
        self.layers = _layers(pos)
        self.box = _fragments_box(pos, shape, m, levels) if _BOX else (0, shape[0], 0, shape[1])
        r0, r1, c0, c1 = self.box
        pos = np.asarray(pos, np.int64) - np.array([r0, c0], np.int64)
        self.shape = shape = (r1 - r0, c1 - c0)
        self.positions = np.ascontiguousarray(pos, np.int64)
        self.tile = FRAGMENT + 2 * min(m, MARGIN)
        self.fill_den = _fill_weights(pos, m, shape)
        self.weights = []
        for members in self.layers:
            weight = np.zeros(shape + (1,), dtype=np.float32)
            for r, c in pos[members]:
                weight[r : r + FRAGMENT, c : c + FRAGMENT, 0] = raw
            self.weights.append(_gaussian32(weight, levels))
        # Where each layer's weights are not 0, level by level: its bands are made
        # and summed there only.
        self.spans = [_weight_spans32(g) for g in self.weights]
        sums = [g.copy() for g in self.weights[0]]
        for gw in self.weights[1:]:
            for s, g in zip(sums, gw):
                s += g
        self.weight_sums = sums
        self.covered = _weight_sum(pos, shape, np.ones((FRAGMENT, FRAGMENT))) > 0


@njit(cache=True, nogil=True)
def _paste_windows(layer, d, pos, members, m, tile):
    """``layer[rs, cs] = d[k, wr, wc]`` for each fragment ``k`` of ``members`` (in order).

    The slices of :func:`_window` (the core grown to ``tile`` pixels, cut to the
    canvas; the data's own window): a plain copy, as the numpy loop makes it.
    """
    grow = (tile - FRAGMENT) // 2
    height, width, n = layer.shape
    # Rows as flat runs of pixels' frames: a plain loop over contiguous values (2.6
    # times as fast as numba's 2-D slice assignment at 1920 px).
    rows = layer.reshape(height, width * n)
    data = d.reshape(d.shape[0], d.shape[1], d.shape[2] * n)
    for k in members:
        r = pos[k, 0]
        c = pos[k, 1]
        r0, r1 = max(r - grow, 0), min(r + FRAGMENT + grow, height)
        c0, c1 = max(c - grow, 0), min(c + FRAGMENT + grow, width)
        for i in range(r0, r1):
            dst = rows[i, c0 * n : c1 * n]
            src = data[k, i - r + m, (c0 - c + m) * n : (c1 - c + m) * n]
            for q in range(dst.size):
                dst[q] = src[q]


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
