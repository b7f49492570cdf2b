r"""The 18 augmented versions of a database clip (Okabe et al., sec. 4, Fig. 4-a).

To multiply its videos the paper [1]_ flips each one horizontally, scales it to 50, 75 and
100 % and rotates it by -22.5, 0 and +22.5 degrees, then cuts every version into
48 x 48 fragments. Here a version is an index into :data:`VERSIONS`
(``9 * flip + 3 * scale_index + angle_index``; 7 is the clip itself).

Geometry (shared by every part of :mod:`fluidnb.videodb`). For a source of
:math:`H \times W` pixels and version :math:`(F, s, \theta)` the canvas is

.. math::

    H_v = \max(1, [s (H |\cos\theta| + W |\sin\theta|)]), \quad
    W_v = \max(1, [s (W |\cos\theta| + H |\sin\theta|)])

(``[.]`` rounds half away from zero) and version pixel :math:`(r, c)` shows the
source at the pixel-centre coordinates

.. math::

    p = (r - \tfrac{H_v - 1}{2},\ c - \tfrac{W_v - 1}{2}), \quad
    q = F R(-\theta)\, p / s, \quad
    (y, x) = q + (\tfrac{H - 1}{2}, \tfrac{W - 1}{2}),

with :math:`R(\theta) = ((\cos\theta, -\sin\theta), (\sin\theta, \cos\theta))`
acting on (row, col) vectors -- counter-clockwise on screen for :math:`\theta > 0` --
and :math:`F = \mathrm{diag}(1, -1)` for a flipped version. A motion vector (dy, dx)
of the source becomes :math:`u_v = s R(\theta) F u_s` in the version.

Here: the versions' shapes, coordinates, matrices and prefilters, and where whole
fragments lie in them (:func:`valid_positions`); their pixels and motion are sampled
by :mod:`fluidnb.videodb.database._augment`.

References
----------
.. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Computer Graphics Forum 30(7) (Pacific Graphics 2011),
   section 4 and Fig. 4.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache

import numpy as np

from ..._validation import check_int
from .._common._geometry import FRAGMENT, STRIDE, VERSIONS

__all__ = [
    "IDENTITY",
    "mirror_order",
    "mirror_partner",
    "prefilter_sigma",
    "valid_positions",
    "version_coordinates",
    "version_matrix",
    "version_shape",
]

#: The version that is the clip itself (no flip, 100 %, 0 degrees).
IDENTITY = VERSIONS.index((False, 1.0, 0.0))


# scipy.ndimage.gaussian_filter's default: the kernel reaches int(4 sigma + 0.5) pixels.
_TRUNCATE = 4.0


def version_shape(shape, version):
    r"""Height and width of a version's canvas, :math:`(H_v, W_v)`.

    Parameters
    ----------
    shape : tuple of int
        The source's ``(H, W)`` (further entries, e.g. channels, are ignored).
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.

    Returns
    -------
    tuple of int
        ``(Hv, Wv)``: the bounding box of the scaled, rotated source (see the module
        docstring).

    Examples
    --------
    >>> version_shape((180, 320), 7), version_shape((180, 320), 1)
    ((180, 320), (90, 160))
    """
    h, w = _check_source_shape(shape)
    _, s, (cos, sin) = _parameters(version)
    ac, as_ = abs(cos), abs(sin)
    return (max(1, _round(s * (h * ac + w * as_))), max(1, _round(s * (w * ac + h * as_))))


def version_matrix(version):
    r"""The 2 x 2 matrix :math:`s R(\theta) F` taking source (dy, dx) to the version's.

    Examples
    --------
    >>> version_matrix(7).tolist(), version_matrix(16).tolist()
    ([[1.0, -0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, -1.0]])
    """
    flip, s, (cos, sin) = _parameters(version)
    f = -1.0 if flip else 1.0
    return np.array([[s * cos, -s * sin * f], [s * sin, s * cos * f]])


def prefilter_sigma(version):
    """Standard deviation (source pixels) of the antialiasing Gaussian; 0 if none.

    Examples
    --------
    >>> prefilter_sigma(1), prefilter_sigma(7)
    (0.5, 0.0)
    """
    _, s, _ = _parameters(version)
    return (1.0 / s - 1.0) / 2.0 if s < 1.0 else 0.0


def version_coordinates(shape, version, *, origin=(0, 0), size=None):
    r"""Source pixel-centre coordinates (y, x) of a window of a version's pixels.

    Parameters
    ----------
    shape : tuple of int
        The source's ``(H, W)``.
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.
    origin : tuple of int
        ``(row, col)`` of the window's top-left pixel in the version's canvas; may lie
        outside it (the mapping extends beyond the canvas).
    size : tuple of int, optional
        ``(h, w)`` of the window; default: from ``origin`` to the canvas's end.

    Returns
    -------
    ndarray, shape (h, w, 2), float64
        Source (y, x) of version pixels ``origin + (i, j)``, unclamped: values outside
        ``[0, H - 1] x [0, W - 1]`` fall outside the source.

    Examples
    --------
    >>> yx = version_coordinates((4, 6), 1)  # 50 %: every other source pixel
    >>> yx.shape, yx[0, 0].tolist(), yx[-1, -1].tolist()
    ((2, 3, 2), [0.5, 0.5], [2.5, 4.5])
    """
    h, w = _check_source_shape(shape)
    (r0, c0), (hh, ww) = _window(h, w, version, origin, size)
    y, x = _coordinates(h, w, version, r0, c0, hh, ww)
    return np.stack(np.broadcast_arrays(y, x), axis=-1)


def mirror_partner(version):
    r"""The version whose mirror image (left-right) is ``version``, bit for bit.

    A flipped version :math:`(F, s, \theta)` is the mirror image of the unflipped
    :math:`(s, -\theta)`, and the other way round (:math:`F R(-\theta) = R(\theta) F`).

    Examples
    --------
    >>> mirror_partner(7), mirror_partner(16), mirror_partner(0), mirror_partner(11)
    (16, 7, 11, 0)
    """
    flip, s, angle = VERSIONS[check_int("version", version, 0, len(VERSIONS) - 1)]
    return VERSIONS.index((not flip, s, -angle))


def mirror_order(versions):
    """``versions`` reordered so that each unflipped one comes just before its mirror.

    The order in which :class:`VersionSampler` samples each mirror pair once.

    Examples
    --------
    >>> mirror_order(range(18))[:6]
    [0, 11, 1, 10, 2, 9]
    """
    return sorted(versions, key=lambda v: (min(v, mirror_partner(v)), v))


def valid_positions(shape, version):
    """Top-left corners of the version's fragments that lie wholly inside the source.

    Fragments are ``FRAGMENT x FRAGMENT`` (48 x 48) pixels with corners on the
    ``STRIDE`` (24) grid from (0, 0); a fragment is kept when it lies inside the
    canvas and every one of its pixels maps to source coordinates within
    ``[0, H - 1] x [0, W - 1]`` (:func:`version_coordinates`), so no clamped pixel
    ever enters a fragment.

    Parameters
    ----------
    shape : tuple of int
        The source's ``(H, W)``.
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.

    Returns
    -------
    ndarray, shape (n, 2), int64
        ``(row, col)`` in the version's pixels, row-major order.

    Examples
    --------
    >>> valid_positions((72, 96), 7).tolist()
    [[0, 0], [0, 24], [0, 48], [24, 0], [24, 24], [24, 48]]
    """
    h, w = _check_source_shape(shape)
    hv, wv = version_shape((h, w), version)
    rows = np.arange(0, hv - FRAGMENT + 1, STRIDE)
    cols = np.arange(0, wv - FRAGMENT + 1, STRIDE)
    if not len(rows) or not len(cols):
        return np.empty((0, 2), np.int64)
    y, x = _coordinates(h, w, version, 0, 0, hv, wv)
    outside = (y < 0) | (y > h - 1) | (x < 0) | (x > w - 1)
    # A summed-area table counts outside pixels per fragment in one pass.
    sat = np.zeros((hv + 1, wv + 1), np.int64)
    sat[1:, 1:] = np.broadcast_to(outside, (hv, wv)).cumsum(0).cumsum(1)
    r, c = rows[:, None], cols[None, :]
    count = (
        sat[r + FRAGMENT, c + FRAGMENT] - sat[r, c + FRAGMENT] - sat[r + FRAGMENT, c] + sat[r, c]
    )
    keep = np.argwhere(count == 0)
    return np.stack([rows[keep[:, 0]], cols[keep[:, 1]]], axis=1).astype(np.int64)


def _round(v):
    return int(math.floor(v + 0.5))


@cache
def _trig(angle):
    # Exact 1 and 0 for 0 degrees, so the identity version maps pixels onto pixels.
    if angle == 0.0:
        return 1.0, 0.0
    rad = math.radians(angle)
    return math.cos(rad), math.sin(rad)


def _parameters(version):
    version = check_int("version", version, 0, len(VERSIONS) - 1)
    flip, s, angle = VERSIONS[version]
    return flip, s, _trig(angle)


def _check_source_shape(shape):
    if not isinstance(shape, Sequence | np.ndarray) or len(shape) < 2:
        raise ValueError(f"shape must be a (height, width) pair, got {shape!r}")
    return check_int("shape[0]", shape[0], 1), check_int("shape[1]", shape[1], 1)


def _check_pair(name, value, lo=None):
    if not isinstance(value, Sequence | np.ndarray) or len(value) != 2:
        raise ValueError(f"{name} must be a (row, col) pair of integers, got {value!r}")
    return check_int(f"{name}[0]", value[0], lo), check_int(f"{name}[1]", value[1], lo)


def _window(h, w, version, origin, size):
    r0, c0 = _check_pair("origin", origin)
    if size is None:
        hv, wv = version_shape((h, w), version)
        size = (hv - r0, wv - c0)
        if size[0] < 1 or size[1] < 1:
            raise ValueError(
                f"origin must lie inside the version's canvas {(hv, wv)} when size is "
                f"not given, got {(r0, c0)}"
            )
    return (r0, c0), _check_pair("size", size, 1)


def _coordinates(h, w, version, r0, c0, hh, ww):
    """Source (y, x) of version pixels [r0, r0 + hh) x [c0, c0 + ww), broadcastable.

    Every element is computed by the same sequence of float64 operations from its own
    (r, c) alone, so overlapping windows agree bit for bit.
    """
    flip, s, (cos, sin) = _parameters(version)
    hv, wv = version_shape((h, w), version)
    py = (np.arange(r0, r0 + hh, dtype=np.float64) - (hv - 1) / 2)[:, None]
    px = (np.arange(c0, c0 + ww, dtype=np.float64) - (wv - 1) / 2)[None, :]
    # q = F R(-theta) p / s, with R(-theta) = ((cos, sin), (-sin, cos)).
    y = (cos * py + sin * px) / s + (h - 1) / 2
    x = (cos * px - sin * py) / s
    if flip:
        x = -x
    return y, x + (w - 1) / 2


def _corners(coord, n):
    """Lower neighbour index, upper neighbour index and weight of clamped coordinates.

    A coordinate on a pixel centre gets weight 0 on that pixel (also the last one, whose
    upper neighbour is itself): ``a + 0 (b - a)`` is ``a`` exactly, while ``a + 1 (b -
    a)`` need not be ``b``.
    """
    c = np.clip(coord, 0.0, n - 1)
    lo = np.floor(c).astype(np.intp)
    hi = np.minimum(lo + 1, n - 1)
    return lo, hi, c - lo
