r"""Appearance matching (Okabe et al., sec. 6): each frame's histograms matched to the target's.

The blended difference frames added to the approximate mean image
(:mod:`fluidnb.videodb.rendering._motion_blur`) need not have the photo's tones, so each
frame's histograms are matched to the target's, cell by cell of a uniform grid (Heeger
& Bergen 1995), the cells' mappings blended bilinearly so no grid seam shows
(:func:`match_histograms_cells`, as CLAHE blends its tiles).

The matching runs in numba kernels;
:func:`~fluidnb.videodb.rendering.reference_match_histograms_cells` is the same in plain
numpy.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._validation import check_array, check_int
from ._threads import _each_frame

__all__ = ["HISTOGRAM_BINS", "match_histograms_cells"]


# --------------------------------------------------------------------------------------
# Appearance matching: per-cell histogram matching, cells blended as in CLAHE
# --------------------------------------------------------------------------------------

#: Histogram bins per channel (over each image's own value range).
HISTOGRAM_BINS = 256
# Quantiles that describe each cell's distribution (p = 0, 1/K, ..., 1).
_QUANTILES = 128
# Slope of a cell's map beyond the frame's range in that cell (see
# fluidnb.videodb.rendering._reference._maps_np).
_SLOPE_RANGE = (0.25, 4.0)


def _check_histogram_args(frames, reference, weight, cell):
    f = check_array("frames", frames, ndim=(3, 4), dtype_kinds="biuf")
    ref = check_array("reference", reference, ndim=(2, 3), dtype_kinds="biuf")
    if ref.shape != f.shape[1:]:
        raise ValueError(
            f"reference must have the shape of one frame {f.shape[1:]}, got {ref.shape}"
        )
    w = check_array("weight", weight, ndim=2, dtype_kinds="biuf")
    if w.shape != f.shape[1:3]:
        raise ValueError(
            f"weight must have the frames' height and width {f.shape[1:3]}, got {w.shape}"
        )
    if w.min() < 0:
        raise ValueError(f"weight must be >= 0, got values down to {float(w.min()):g}")
    cell = check_int("cell", cell, 2)
    return f, ref, w.astype(np.float64), cell


def _cell_geometry(n, cell):
    """Cell index of every pixel and the cells' centres along one axis."""
    starts = np.arange(0, n, cell)
    ends = np.minimum(starts + cell, n)
    centres = (starts + ends - 1) / 2.0
    return np.arange(n) // cell, centres


def _bilinear_roles(n, centres):
    """Per pixel along one axis: the two bracketing cells and the second one's weight.

    The cells are those whose centres bracket the pixel; beyond the outer centres
    both are the first (last) cell.
    """
    x = np.arange(n, dtype=np.float64)
    i0 = np.clip(np.searchsorted(centres, x, side="right") - 1, 0, len(centres) - 1)
    i1 = np.minimum(i0 + 1, len(centres) - 1)
    span = centres[i1] - centres[i0]
    f = np.divide(x - centres[i0], span, out=np.zeros(n), where=span > 0)
    return i0, i1, np.clip(f, 0.0, 1.0)


class _Cells:
    """The checked inputs of a matching, the reference's side and every frame's bins.

    For the reference matching (:func:`fluidnb.videodb.rendering.reference_match_histograms_cells`):
    the cell grid, its bilinear roles, the cells' mass and the reference's bins of
    :class:`_Matching`, and each frame's bins (:attr:`lo`, :attr:`step`, one row per
    frame). Every image is binned over its own range, per channel, so a frame's
    result does not depend on the other frames matched with it, and a clip matched a
    few frames at a time is the clip matched at once, bit for bit.
    """

    def __init__(self, frames, reference, weight, cell):
        f, ref, w, cell = _check_histogram_args(frames, reference, weight, cell)
        self.grey = f.ndim == 3
        f = np.ascontiguousarray(f, dtype=np.float32)  # read only: no copy needed
        ref = np.ascontiguousarray(ref, dtype=np.float32)
        if self.grey:
            f, ref = f[..., None], ref[..., None]
        self.frames, self.reference, self.weight = f, ref, w
        shared = _Matching(ref, w, cell)
        self.nx, self.n_cells, self.cid, self.mass = (
            shared.nx, shared.n_cells, shared.cid, shared.mass
        )  # fmt: skip
        self.rows, self.cols = shared.rows, shared.cols
        self.lo_ref, self.step_ref = shared.lo_ref, shared.step_ref
        bins = [_bins(frame) for frame in f]
        #: (T, C): each frame's lowest bin edge and bin width per channel.
        self.lo = np.array([b[0] for b in bins]).reshape(len(f), -1)
        self.step = np.array([b[1] for b in bins]).reshape(len(f), -1)

    def result(self, out):
        return out[..., 0] if self.grey else out


@njit(cache=True, nogil=True)
def _channel_range(values):
    """Smallest and largest value of each channel (column) of (n, C) float32.

    A channel at a time, its running extremes in registers (twice as fast as all
    channels per pixel through memory); each channel's values are taken in the same
    order, so the result is the same, NaN included.
    """
    n_ch = values.shape[1]
    lo = np.full(n_ch, np.inf, np.float32)
    hi = np.full(n_ch, -np.inf, np.float32)
    for c in range(n_ch):
        low, high = lo[c], hi[c]
        for i in range(values.shape[0]):
            v = values[i, c]
            low = min(low, v)
            high = max(high, v)
        lo[c], hi[c] = low, high
    return lo, hi


def match_histograms_cells(frames, reference, weight, *, cell):
    r"""Match each frame's appearance to the target's, cell by cell (Okabe et al., sec. 6).

    The last step of the paper's rendering: on a uniform grid of ``cell x cell``
    pixels, each frame's histogram is matched to the target's in every cell,
    independently per channel (Heeger & Bergen 1995), so the animation keeps the
    target's local colours. Only the fluid counts: every pixel enters the histograms
    with its ``weight`` (the matte; pixels of weight 0 do not count). Each cell's
    mapping is the monotone map between the two distributions' quantiles (histograms
    of :data:`HISTOGRAM_BINS` bins, uniform within a bin, 129 quantiles). Mappings
    are blended bilinearly between the cells' centres, as CLAHE interpolates its
    mappings (Zuiderveld 1994), each cell also weighted by its share of the matte, so
    the result is continuous: no grid seam, and a cell with hardly any fluid does not
    drag its neighbourhood. Where no cell nearby holds any fluid, values are kept.

    The histograms, quantiles, maps and the blend run in numba kernels (compiled on
    first use, a few seconds, then cached): 32 RGB frames of 648 x 360 in about 1 s
    on 2 shared cores. :func:`fluidnb.videodb.rendering.reference_match_histograms_cells` is the
    same in numpy.

    Parameters
    ----------
    frames : ndarray, shape (T, H, W, C) or (T, H, W)
        The rendered frames (float, usually in [0, 1]).
    reference : ndarray, shape (H, W, C) or (H, W)
        The target image.
    weight : ndarray, shape (H, W)
        Non-negative weight of each pixel in the histograms, e.g. the alpha matte.
    cell : int
        Side of the grid's cells in pixels (>= 2); the last row and column of cells
        may be narrower.

    Returns
    -------
    ndarray, shape of ``frames``, float32
        The matched frames. A frame matched to itself comes back unchanged (to float32
        rounding).

    References
    ----------
    .. [1] D. J. Heeger and J. R. Bergen, "Pyramid-based texture analysis/synthesis",
       Proceedings of SIGGRAPH 95, pp. 229-238, 1995.
    .. [2] K. Zuiderveld, "Contrast limited adaptive histogram equalization",
       Graphics Gems IV, pp. 474-485, 1994.
    .. [3] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Pacific Graphics 2011, section 6.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ref = rng.random((32, 32, 3)).astype(np.float32)
    >>> dim = 0.5 * ref + 0.2  # a darker, flatter rendering
    >>> out = match_histograms_cells(dim[None], ref, np.ones((32, 32)), cell=16)
    >>> bool(np.abs(out[0] - ref).max() < 0.02)
    True
    """
    f, ref, w, cell = _check_histogram_args(frames, reference, weight, cell)
    grey = f.ndim == 3
    f = np.ascontiguousarray(f, dtype=np.float32)  # read only: no copy needed
    if grey:
        f, ref = f[..., None], ref[..., None]
    matching = _Matching(ref, w, cell)
    out = np.empty_like(f)
    # Frames are independent: matched on the cores (the kernels release the GIL).
    _each_frame(lambda t: matching.match(f[t], out[t]), f.shape[0])
    return out[..., 0] if grey else out


class _Matching:
    """The matching of frames to one reference: the reference's side made once.

    The reference's bins (over its own range, per channel), its histograms and
    quantiles per cell, the cell grid, its bilinear roles and the cells' matte mass:
    what every frame's matching shares. :meth:`match` then matches one frame (its
    own bins, histograms, quantiles, maps, and the blended mapping), so a clip can be
    matched a frame at a time, on any thread, with the numbers of
    :class:`_Cells` (the same operations, row by row).

    Parameters
    ----------
    reference : ndarray, shape (H, W, C), float
    weight : ndarray, shape (H, W), float64, >= 0
    cell : int
    """

    def __init__(self, reference, weight, cell):
        ref = np.ascontiguousarray(reference, dtype=np.float32)
        self.n_ch = n_ch = ref.shape[2]
        h, w_px = ref.shape[:2]
        self.lo_ref, self.step_ref = _bins(ref)
        cy, centres_y = _cell_geometry(h, cell)
        cx, centres_x = _cell_geometry(w_px, cell)
        self.nx = len(centres_x)
        self.n_cells = len(centres_y) * self.nx
        self.cid = (cy[:, None] * self.nx + cx[None, :]).astype(np.intp)
        self.weight = np.ascontiguousarray(weight, dtype=np.float64)
        self.mass = np.bincount(
            self.cid.ravel(), weights=self.weight.ravel(), minlength=self.n_cells
        )
        self.rows = _bilinear_roles(h, centres_y)
        self.cols = _bilinear_roles(w_px, centres_x)
        counts = np.zeros((1, n_ch, self.n_cells, HISTOGRAM_BINS))
        _histogram_kernel(ref, self.cid, self.weight, self.lo_ref, 1.0 / self.step_ref, counts[0])
        self.q_ref = np.empty(counts.shape[:3] + (_QUANTILES + 1,))
        _quantiles_kernel(counts, self.lo_ref[None], self.step_ref[None], self.q_ref)
        self.slopes = np.array(_SLOPE_RANGE)

    def cropped(self, box):
        """The same matching for the part ``[r0:r1, c0:c1]`` of the reference's canvas.

        ``box`` (r0, r1, c0, c1) must hold every pixel of weight > 0: the cells, their
        mass, the reference's quantiles and each pixel's bilinear roles are this
        matching's, so a frame cut to the box is matched as the same pixels of the
        whole frame would be (the histograms add the same weights in the same order;
        the frame's bins are those of the part :meth:`match` is given as ``span``).
        """
        r0, r1, c0, c1 = box
        if self.weight[:r0].any() or self.weight[r1:].any():
            raise ValueError(f"box {box} must hold every pixel of weight > 0")
        if self.weight[:, :c0].any() or self.weight[:, c1:].any():
            raise ValueError(f"box {box} must hold every pixel of weight > 0")
        cut = object.__new__(_Matching)
        cut.__dict__.update(self.__dict__)
        cut.cid = np.ascontiguousarray(self.cid[r0:r1, c0:c1])
        cut.weight = np.ascontiguousarray(self.weight[r0:r1, c0:c1])
        cut.rows = tuple(np.ascontiguousarray(x[r0:r1]) for x in self.rows)
        cut.cols = tuple(np.ascontiguousarray(x[c0:c1]) for x in self.cols)
        return cut

    def match(self, frame, out, span=None, where=None, counted=None):
        """Match one frame (H, W, C) float32 into ``out`` (H, W, C) float32.

        ``span`` (r0, r1, c0, c1), or a sequence of them: the frame's bins span its
        values there only (in their union; the whole frame if None). ``where``: a
        sequence of them, the only parts of ``out`` written (each pixel is mapped on
        its own: the same values there as matching the whole frame); None: all.
        ``out`` may be ``frame`` (each value is read, then its own is written).
        ``counted``: a sequence of them that holds every pixel of weight > 0, on
        bands of rows in order (each row in one of them at most): only they are read
        for the histograms, which add the same weights in the same order as over
        the whole frame; None: the whole frame.
        """
        if span is None:
            lo, step = _bins(frame)
        elif np.ndim(span[0]) == 0:
            lo, step = _bins(frame[span[0] : span[1], span[2] : span[3]])
        else:
            lo, step = _bins_over(frame, span)
        inv_step = 1.0 / step
        counts = np.zeros((1, self.n_ch, self.n_cells, HISTOGRAM_BINS))
        if counted is None:
            _histogram_kernel(frame, self.cid, self.weight, lo, inv_step, counts[0])
        else:
            for r0, r1, c0, c1 in counted:
                _histogram_kernel(
                    frame[r0:r1, c0:c1], self.cid[r0:r1, c0:c1], self.weight[r0:r1, c0:c1],
                    lo, inv_step, counts[0],
                )  # fmt: skip
        q = np.empty(counts.shape[:3] + (_QUANTILES + 1,))
        _quantiles_kernel(counts, lo[None], step[None], q)
        luts = np.empty(counts.shape[:3] + (HISTOGRAM_BINS + 1,))
        _maps_kernel(q, self.q_ref[0], lo[None], step[None], self.slopes, luts)
        if where is None:
            _apply_kernel(
                frame, luts[0], lo, inv_step, *self.rows, *self.cols, self.mass, self.nx, out
            )
            return out
        for r0, r1, c0, c1 in where:
            rows = tuple(x[r0:r1] for x in self.rows)
            cols = tuple(x[c0:c1] for x in self.cols)
            part = out[r0:r1, c0:c1]
            _apply_kernel(
                frame[r0:r1, c0:c1], luts[0], lo, inv_step, *rows, *cols, self.mass, self.nx, part
            )
        return out


def _bins(image):
    """An image's bins per channel: the lowest edge and the width (its own range / bins)."""
    lo, hi = _channel_range(image.reshape(-1, image.shape[-1]))
    lo, hi = lo.astype(np.float64), hi.astype(np.float64)
    return lo, np.where(hi > lo, (hi - lo) / HISTOGRAM_BINS, 1.0 / HISTOGRAM_BINS)


def _bins_over(image, rects):
    """:func:`_bins` of the union of the parts ``[r0:r1, c0:c1]`` of ``image`` (disjoint or not).

    Each part's extremes, then theirs: the same lowest and highest values as over the
    union's pixels in any order (min and max are exact), without gathering them.
    """
    n_ch = image.shape[-1]
    lo = np.full(n_ch, np.inf, np.float32)
    hi = np.full(n_ch, -np.inf, np.float32)
    for r0, r1, c0, c1 in rects:
        part = image[r0:r1, c0:c1]
        if part.size:
            low, high = _channel_range(part.reshape(-1, n_ch))
            lo, hi = np.minimum(lo, low), np.maximum(hi, high)
    lo, hi = lo.astype(np.float64), hi.astype(np.float64)
    return lo, np.where(hi > lo, (hi - lo) / HISTOGRAM_BINS, 1.0 / HISTOGRAM_BINS)


# The compiled kernels below follow the numpy functions of
# fluidnb.videodb.rendering._reference (_quantiles_np, _maps_np) operation for operation (same
# sums in the same order), so both paths agree to the last bit or nearly.


@njit(cache=True, nogil=True)
def _bin(v, lo, inv_step, bins):
    z = (np.float64(v) - lo) * inv_step
    j = int(z) if z > 0.0 else 0
    return z, min(j, bins - 1)


@njit(cache=True, nogil=True)
def _histogram_kernel(img, cid, weight, lo, inv_step, out):
    """Add each pixel's weight to its (channel, cell, bin) of ``out``."""
    h, w, n_ch = img.shape
    bins = out.shape[2]
    for r in range(h):
        for c in range(w):
            wt = weight[r, c]
            if wt <= 0.0:
                continue
            cell = cid[r, c]
            for ch in range(n_ch):
                j = _bin(img[r, c, ch], lo[ch], inv_step[ch], bins)[1]
                out[ch, cell, j] += wt


@njit(cache=True, nogil=True)
def _quantiles_kernel(counts, lo, step, out):
    """:func:`_quantiles_np` for counts (S, C, cells, bins) -> out (S, C, cells, K + 1).

    ``lo``, ``step``: (S, C), the bins of each image.
    """
    n_s, n_ch, n_cells, bins = counts.shape
    n_q = out.shape[3] - 1
    cdf = np.empty(bins + 1)
    for s in range(n_s):
        for ch in range(n_ch):
            for k in range(n_cells):
                row = counts[s, ch, k]
                total = 0.0
                first = -1
                last = 0
                for j in range(bins):
                    total += row[j]
                    if row[j] > 0.0:
                        last = j + 1
                        if first < 0:
                            first = j
                if not total > 0.0:
                    out[s, ch, k, :] = lo[s, ch] + step[s, ch] * bins
                    continue
                cdf[0] = 0.0
                run = 0.0
                for j in range(bins):
                    run += row[j]
                    cdf[j + 1] = run / total
                i = 0
                for m in range(n_q + 1):
                    p = m / n_q
                    while i < bins + 1 and cdf[i] < p:
                        i += 1
                    ic = min(max(i, 1), bins)
                    c0 = cdf[ic - 1]
                    c1 = cdf[ic]
                    frac = (p - c0) / (c1 - c0) if c1 > c0 else 1.0
                    frac = min(max(frac, 0.0), 1.0)
                    out[s, ch, k, m] = lo[s, ch] + step[s, ch] * (ic - 1 + frac)
                out[s, ch, k, 0] = lo[s, ch] + step[s, ch] * first
                out[s, ch, k, n_q] = lo[s, ch] + step[s, ch] * last


@njit(cache=True, nogil=True)
def _maps_kernel(q_f, q_r, lo, step, slope_range, out):
    """:func:`_maps_np` compiled.

    q_f (T, C, cells, K + 1), q_r (C, cells, K + 1) -> out (T, C, cells, bins + 1),
    sampled at each frame's bin edges (``lo``, ``step``: (T, C)).
    """
    n_t, n_ch, n_cells, n_k = q_f.shape
    n_e = out.shape[3]
    for t in range(n_t):
        for ch in range(n_ch):
            for k in range(n_cells):
                xp = q_f[t, ch, k]
                fp = q_r[ch, k]
                span_f = xp[n_k - 1] - xp[0]
                slope = (fp[n_k - 1] - fp[0]) / span_f if span_f > 0.0 else 1.0
                slope = min(max(slope, slope_range[0]), slope_range[1])
                i = 0
                for j in range(n_e):
                    e = lo[t, ch] + step[t, ch] * j
                    while i < n_k and xp[i] <= e:
                        i += 1
                    ic = min(max(i, 1), n_k - 1)
                    x0 = xp[ic - 1]
                    width = xp[ic] - x0
                    frac = (e - x0) / width if width > 0.0 else 0.0
                    frac = min(max(frac, 0.0), 1.0)
                    v = fp[ic - 1] + frac * (fp[ic] - fp[ic - 1])
                    if e < xp[0]:
                        v = fp[0] + slope * (e - xp[0])
                    elif e > xp[n_k - 1]:
                        v = fp[n_k - 1] + slope * (e - xp[n_k - 1])
                    out[t, ch, k, j] = v


@njit(cache=True, nogil=True)
def _apply_kernel(img, lut, lo, inv_step, y0, y1, fy, x0, x1, fx, mass, nx, out):
    """Map every value through its four neighbouring cells' maps.

    Blended bilinearly and by the cells' matte mass (the identity where none has any).
    """
    h, w, n_ch = img.shape
    bins = lut.shape[2] - 1
    for r in range(h):
        a0 = y0[r] * nx
        a1 = y1[r] * nx
        gy = fy[r]
        for c in range(w):
            gx = fx[c]
            k00 = a0 + x0[c]
            k01 = a0 + x1[c]
            k10 = a1 + x0[c]
            k11 = a1 + x1[c]
            w00 = (1.0 - gy) * (1.0 - gx) * mass[k00]
            w01 = (1.0 - gy) * gx * mass[k01]
            w10 = gy * (1.0 - gx) * mass[k10]
            w11 = gy * gx * mass[k11]
            total = w00 + w01 + w10 + w11
            inv_total = 1.0 / total if total > 0.0 else 0.0
            for ch in range(n_ch):
                v = img[r, c, ch]
                if not total > 0.0:
                    out[r, c, ch] = v
                    continue
                z, j = _bin(v, lo[ch], inv_step[ch], bins)
                f = z - j
                acc = w00 * (lut[ch, k00, j] + f * (lut[ch, k00, j + 1] - lut[ch, k00, j]))
                acc += w01 * (lut[ch, k01, j] + f * (lut[ch, k01, j + 1] - lut[ch, k01, j]))
                acc += w10 * (lut[ch, k10, j] + f * (lut[ch, k10, j + 1] - lut[ch, k10, j]))
                acc += w11 * (lut[ch, k11, j] + f * (lut[ch, k11, j + 1] - lut[ch, k11, j]))
                out[r, c, ch] = acc * inv_total
