r"""Dense SIFT on a fragment's 9 x 9 grid: the appearance descriptor (Okabe et al., sec. 4).

Every 48 x 48 fragment (its grey mean image :math:`A`) is described by 9 x 9 upright
SIFT descriptors (Lowe 2004) on a regular grid, as VLFeat's dense SIFT computes them
(Vedaldi & Fulkerson 2008): descriptor :math:`(k_y, k_x)`, :math:`k = 0 .. 8`, covers
the pixels :math:`[4k, 4k + 16)` on each axis, cut into 4 x 4 spatial bins of 4 pixels,
each a histogram of 8 gradient orientations: :math:`4 \cdot 4 \cdot 8 = 128` values.

The recipe, in pixel coordinates (pixel :math:`(y, x)` is row :math:`y`, column
:math:`x`; descriptor :math:`k` has its centre at :math:`4k + 7.5` and its bin
:math:`b` at :math:`4k + 4b + 1.5` on each axis):

1. Gradients :math:`(g_y, g_x)` by central differences, one-sided at the image border
   (``numpy.gradient``; VLFeat's ``vl_imgradient``). Magnitude
   :math:`m = \sqrt{g_x^2 + g_y^2}`, orientation
   :math:`\theta = \operatorname{atan2}(g_y, g_x) \in [0, 2\pi)` with rows pointing down,
   so :math:`\theta = 0` is a gradient to the right and :math:`\pi/2` one downwards.
2. Orientation binning with linear interpolation in angle: with
   :math:`u = 8\theta / 2\pi`, bin :math:`\lfloor u \rfloor` gets
   :math:`(1 - (u - \lfloor u \rfloor))\, m` and the next bin (modulo 8) the rest.
3. Spatial binning with bilinear (triangular) weights between bin centres:
   :math:`\max(0, 1 - |y - c_{b_y}| / 4)\, \max(0, 1 - |x - c_{b_x}| / 4)`
   (Lowe's trilinear interpolation), times a Gaussian window centred on the descriptor
   with :math:`\sigma` = half the descriptor width = 8 px (Lowe's choice; VLFeat's
   default ``windowSize`` of 2 bins).
4. Normalise to unit L2 norm, clip at 0.2, renormalise (Lowe 2004, section 6.1), and
   store as VLFeat does: ``uint8(min(255, 512 v))`` (truncated).

Decision: only the descriptor's own 16 x 16 pixels contribute. Lowe's, VLFeat's and
OpenCV's descriptors also take the half bin around the window (up to 2 pixels
outside it); restricted to its window, every descriptor of a fragment is computed the
same way, border ones included, and nothing outside the 48 x 48 fragment is needed.
No rotation normalisation (fragments keep the orientation they have in the video, as
the paper's dense descriptors). A region without gradient (a constant image) gives an
all-zero descriptor; VLFeat's dense SIFT has no contrast threshold either.

:func:`dense_sift` is a compiled kernel over a batch (each descriptor is computed by
the same operations in the same order wherever its fragment sits in the batch, so a
fragment's descriptors do not depend on the batch it came in: database and target
agree bit for bit; no fastmath, so the compiler may not reorder sums). It computes
``atan2`` by octants and a polynomial (to a few ulp), pools
separably, and normalises with reciprocals. :func:`fluidnb.videodb.database.reference_dense_sift`
is the recipe above written out literally, one descriptor and one pixel at a time; the two
agree to within one count of the uint8 values (a value differs only where
:math:`512 v` lands within round-off of an integer), and on the tests' images
exactly.

References
----------
.. [1] D. G. Lowe, "Distinctive image features from scale-invariant keypoints",
   International Journal of Computer Vision 60(2), 91-110, 2004.
.. [2] A. Vedaldi, B. Fulkerson, "VLFeat: an open and portable library of computer
   vision algorithms", 2008 (``vl_dsift``), https://www.vlfeat.org.
.. [3] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Pacific Graphics 2011.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..._validation import check_array
from .._common._geometry import FRAGMENT, GRID

__all__ = ["BINS", "ORIENTATIONS", "SIGMA", "dense_sift"]

#: Spatial bins per axis of a descriptor, and their width in pixels.
BINS = 4
_BIN_WIDTH = 4
#: Orientation bins of a descriptor.
ORIENTATIONS = 8
#: Standard deviation of the Gaussian window in pixels: half the descriptor's width.
SIGMA = 0.5 * BINS * _BIN_WIDTH
_SIDE = BINS * _BIN_WIDTH  # 16 pixels: the descriptor's window
_STEP = 4  # pixels between neighbouring descriptors
_CLIP = 0.2
# VLFeat adds the float32 machine epsilon to the norm before dividing.
_EPS = float(np.finfo(np.float32).eps)


def _axis_table():
    """Per pixel of an axis: the (descriptor, bin) slots it feeds and their weights.

    Returns ``slot`` (48, 8) int64 (``4 k + b``), ``weight`` (48, 8) float64
    (triangular weight times the 1-D Gaussian window) and ``count`` (48,) int64.
    """
    slot = np.zeros((FRAGMENT, 2 * BINS), np.int64)
    weight = np.zeros((FRAGMENT, 2 * BINS), np.float64)
    count = np.zeros(FRAGMENT, np.int64)
    for p in range(FRAGMENT):
        for k in range(GRID):
            d = p - _STEP * k
            if not 0 <= d < _SIDE:
                continue
            gauss = math.exp(-((d - (_SIDE - 1) / 2) ** 2) / (2 * SIGMA**2))
            for b in range(BINS):
                tri = 1.0 - abs(d - (_BIN_WIDTH * b + (_BIN_WIDTH - 1) / 2)) / _BIN_WIDTH
                if tri > 0:
                    slot[p, count[p]] = BINS * k + b
                    weight[p, count[p]] = tri * gauss
                    count[p] += 1
    return slot, weight, count


_SLOT, _WEIGHT, _COUNT = _axis_table()


def dense_sift(images):
    r"""Dense upright SIFT descriptors of 48 x 48 grey fragments on the 9 x 9 grid.

    Parameters
    ----------
    images : array_like, shape (B, 48, 48) or (48, 48)
        Grey fragments, floats in [0, 1] (computed as float32, like the images of
        the rest of the package). In the database these are the mean images
        :math:`A = \frac{1}{N}\sum_i F_i` (Okabe et al., sec. 4).

    Returns
    -------
    ndarray, shape (B, 9, 9, 128) or (9, 9, 128), uint8
        Descriptor ``[..., ky, kx, :]`` describes the pixels
        ``[4 ky, 4 ky + 16) x [4 kx, 4 kx + 16)``; its value ``(by * 4 + bx) * 8 + t``
        is spatial bin ``(by, bx)`` (row, column) and orientation bin ``t`` (angle
        :math:`2\pi t / 8`, measured from the +x axis towards +y, i.e. clockwise on
        screen). Each descriptor is :math:`\min(255, \lfloor 512 v \rfloor)` of its
        normalised, clipped, renormalised histogram :math:`v` (see the module notes).

    Notes
    -----
    Deterministic; a fragment's descriptors do not depend on the other fragments of
    the batch. About 7000 fragments a second on one core (2017 AMD EPYC).

    References
    ----------
    .. [1] D. G. Lowe, "Distinctive image features from scale-invariant keypoints",
       IJCV 60(2), 2004.
    .. [2] A. Vedaldi, B. Fulkerson, VLFeat (``vl_dsift``), 2008.

    Examples
    --------
    >>> ramp = np.tile(np.linspace(0, 1, 48, dtype=np.float32), (48, 1))
    >>> d = dense_sift(ramp)
    >>> d.shape, d.dtype
    ((9, 9, 128), dtype('uint8'))
    >>> # The gradient points along +x: only orientation bin 0 holds energy.
    >>> bool(d.reshape(9, 9, 16, 8)[..., 1:].any()), bool(d[..., ::8].all())
    (False, True)
    """
    arr = _check_images(images)
    single = arr.ndim == 2
    batch = arr[None] if single else arr
    out = np.empty((batch.shape[0], GRID, GRID, BINS * BINS * ORIENTATIONS), np.uint8)
    if batch.shape[0]:
        _dsift(np.ascontiguousarray(batch, dtype=np.float32), _SLOT, _WEIGHT, _COUNT, out)
    return out[0] if single else out


def _check_images(images):
    arr = check_array("images", images, ndim=(2, 3), dtype_kinds="f", min_size=0)
    if arr.shape[-2:] != (FRAGMENT, FRAGMENT):
        raise ValueError(f"images must have shape (B, 48, 48) or (48, 48), got {arr.shape}")
    if arr.size and (arr.min() < 0 or arr.max() > 1):
        raise ValueError(
            f"images must be grey values in [0, 1], got values in "
            f"[{float(arr.min()):g}, {float(arr.max()):g}]"
        )
    return arr


# atan(t) = sum_n (-1)^n t^(2n+1) / (2n+1): for |t| <= tan(pi/16) twelve terms reach
# the float64 round-off (the tests check <= 4 ulp against numpy.arctan2).
_ATAN_TERMS = tuple((-1) ** n / (2 * n + 1) for n in range(12))
_TAN_PI_16 = math.tan(math.pi / 16)
_TAN_PI_8 = math.tan(math.pi / 8)
_TAN_3PI_16 = math.tan(3 * math.pi / 16)


@njit(cache=True, nogil=True, error_model="numpy")
def _orientation_units(gy, gx, u):
    """``u = 8 atan2(gy, gx) / 2 pi`` in [0, 8] for a row of gradients.

    A libm ``atan2`` costs ~60 ns here, more than the rest of a pixel's work, so this
    computes it by octants, branch-free so that the loop vectorises
    (``error_model="numpy"`` drops Python's zero-division check, which would stop
    that). With ``lo <= hi`` the smaller and larger of ``|gx|, |gy|``,
    ``atan(lo / hi) = atan(c) + atan(t)``, ``t = (lo - c hi) / (hi + c lo)``, for
    ``c`` = 0, tan(pi/8) or 1 (whichever is nearest, so ``|t| <= tan(pi/16)``), and a
    Taylor polynomial gives ``atan(t)``. ``lo = hi`` gives ``t = 0``: 45-degree
    gradients fall exactly on a bin, as with ``atan2``. A zero gradient gives 0 (its
    magnitude is 0 anyway).
    """
    c = _ATAN_TERMS
    for x in range(gx.shape[0]):
        a, b = gx[x], gy[x]
        ax = a if a >= 0.0 else -a
        ay = b if b >= 0.0 else -b
        steep = ay > ax
        lo = ax if steep else ay
        hi = ay if steep else ax
        near = lo <= _TAN_3PI_16 * hi
        tc = (_TAN_PI_8 if lo > _TAN_PI_16 * hi else 0.0) if near else 1.0
        base = (0.5 if lo > _TAN_PI_16 * hi else 0.0) if near else 1.0
        den = hi + tc * lo
        t = (lo - tc * hi) / (den if den > 0.0 else 1.0)
        z = t * t
        p = c[11]
        p = p * z + c[10]
        p = p * z + c[9]
        p = p * z + c[8]
        p = p * z + c[7]
        p = p * z + c[6]
        p = p * z + c[5]
        p = p * z + c[4]
        p = p * z + c[3]
        p = p * z + c[2]
        p = p * z + c[1]
        p = p * z + c[0]
        at = base + t * p * (4.0 / math.pi)
        alpha = 2.0 - at if steep else at  # the angle in [0, pi/2], units of pi/4
        below = 4.0 + alpha if a < 0.0 else 8.0 - alpha
        above = 4.0 - alpha if a < 0.0 else alpha
        u[x] = below if b < 0.0 else above


@njit(cache=True, nogil=True, error_model="numpy")
def _dsift(images, slot, weight, count, out):
    """Descriptors of every fragment; see the module notes for the recipe.

    Separable pooling: each pixel's two oriented magnitudes are spread along y into
    the (descriptor, bin) slots ``4 ky + by`` of its row (``py[sy, t, x]``); then,
    transposed, whole rows are spread along x (``acc[sx, sy, t]``, contiguous
    multiply-adds). The Gaussian window is a product of two 1-D windows, so each
    pass carries one factor of it with the triangular weights.
    """
    n, side = images.shape[0], images.shape[1]
    slots = GRID * BINS
    no = ORIENTATIONS
    gx = np.empty(side)
    gy = np.empty(side)
    mag = np.empty(side)
    u = np.empty(side)
    o0 = np.empty(side, np.int64)
    o1 = np.empty(side, np.int64)
    m0 = np.empty(side)
    m1 = np.empty(side)
    py = np.empty((slots, no * side))
    pyt = np.empty((side, slots * no))
    acc = np.empty((slots, slots * no))
    v = np.empty(BINS * BINS * no)
    for f in range(n):
        img = images[f]
        py[:] = 0.0
        for y in range(side):
            up, down = max(y - 1, 0), min(y + 1, side - 1)
            scale = 2.0 if 0 < y < side - 1 else 1.0
            for x in range(side):
                gy[x] = (float(img[down, x]) - float(img[up, x])) / scale
            gx[0] = float(img[y, 1]) - float(img[y, 0])
            gx[side - 1] = float(img[y, side - 1]) - float(img[y, side - 2])
            for x in range(1, side - 1):
                gx[x] = (float(img[y, x + 1]) - float(img[y, x - 1])) / 2.0
            for x in range(side):
                mag[x] = math.sqrt(gx[x] * gx[x] + gy[x] * gy[x])
            _orientation_units(gy, gx, u)
            for x in range(side):
                t0 = int(math.floor(u[x]))
                frac = u[x] - t0
                o0[x] = (t0 % no) * side + x
                o1[x] = ((t0 + 1) % no) * side + x
                m0[x] = (1.0 - frac) * mag[x]
                m1[x] = frac * mag[x]
            # Row y feeds the slots of the descriptors whose window holds it; within a
            # slot's row every pixel x writes its own two cells (no chain of updates).
            for e in range(count[y]):
                w = weight[y, e]
                dst = py[slot[y, e]]
                for x in range(side):
                    dst[o0[x]] += w * m0[x]
                    dst[o1[x]] += w * m1[x]
        for s in range(slots):
            for t in range(no):
                for x in range(side):
                    pyt[x, s * no + t] = py[s, t * side + x]
        acc[:] = 0.0
        for x in range(side):
            src = pyt[x]
            for e in range(count[x]):
                w = weight[x, e]
                dst = acc[slot[x, e]]
                for j in range(slots * no):
                    dst[j] += w * src[j]
        for ky in range(GRID):
            for kx in range(GRID):
                i = 0
                for by in range(BINS):
                    for bx in range(BINS):
                        a_row = acc[BINS * kx + bx]
                        for t in range(no):
                            v[i] = a_row[(BINS * ky + by) * no + t]
                            i += 1
                _normalise_quantise(v, out[f, ky, kx])


@njit(cache=True, nogil=True, error_model="numpy")
def _sum_squares(v):
    # Four running sums: one would chain every addition on the last (4x slower).
    a = b = c = d = 0.0
    for i in range(0, v.shape[0], 4):
        a += v[i] * v[i]
        b += v[i + 1] * v[i + 1]
        c += v[i + 2] * v[i + 2]
        d += v[i + 3] * v[i + 3]
    return (a + b) + (c + d)


@njit(cache=True, nogil=True, error_model="numpy")
def _normalise_quantise(v, out):
    """L2-normalise, clip at 0.2, renormalise, then ``min(255, floor(512 v))``.

    Multiplies by reciprocals (a division per value cost a third of the descriptor's
    time): that changes a value by at most an ulp, as the summation order does.
    """
    inv = 1.0 / (math.sqrt(_sum_squares(v)) + _EPS)
    for i in range(v.shape[0]):
        x = v[i] * inv
        v[i] = x if x < _CLIP else _CLIP
    scale = 512.0 / (math.sqrt(_sum_squares(v)) + _EPS)
    for i in range(v.shape[0]):
        q = v[i] * scale
        out[i] = np.uint8(q if q < 255.0 else 255.0)
