r"""Bump mapping, Lambert shading, relighting (Yamamoto & Sakamoto, 2012, sec. 2.1, method [4]).

The height :math:`H` is a pseudo-relief (its slopes matter, not its values): each
frame's normals come from the height's gradient (bump mapping [6]), a parallel light
gives the Lambert shading :math:`S_t = \max(0, n \cdot l)`, and the photo's brightness
is changed by the shading's change since the rest height (our decision, multiplicative):

.. math:: O_t = \mathrm{clip}\big(I \, (1 + k \, w \, (S_t - S_0))\big)

with :math:`w` the feathered region weight (0 outside the region, so those pixels are
never touched). Colour is preserved: every channel is scaled by the same factor.
"""

from __future__ import annotations

import math

import numpy as np

from .._image import as_image
from .._validation import check_array, check_mask, check_range, check_shape_match

__all__ = ["apply_shading", "feather_weights", "light_vector", "shade"]


def light_vector(azimuth, elevation):
    """The unit vector towards a parallel light, in (x right, y up, z out of the image).

    Parameters
    ----------
    azimuth : float
        Degrees counter-clockwise from the image's +x axis (0 = light from the
        right, 90 = from the top, 135 = from the top left).
    elevation : float
        Degrees above the image plane, in (0, 90].

    Returns
    -------
    ndarray, shape (3,), float64

    Examples
    --------
    >>> np.round(light_vector(90, 45), 3).tolist()
    [0.0, 0.707, 0.707]
    """
    az = math.radians(check_range("azimuth", azimuth))
    el = math.radians(check_range("elevation", elevation, 0, 90, lo_open=True))
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def _lambert(height, light, bump, pixel_size):
    """Lambert shading of a stack (..., H, W); the kernel behind :func:`shade`."""
    h = np.asarray(height, dtype=np.float32)
    scale = np.float32(bump / (2.0 * pixel_size))
    out = np.empty(h.shape, np.float32)
    flat_h = (h * scale).reshape((-1,) + h.shape[-2:])
    flat_out = out.reshape(flat_h.shape)
    work = _Work(h.shape[-2:])
    for i in range(flat_h.shape[0]):
        _lambert_frame(flat_h[i], light, flat_out[i], work)
    return out


class _Work:
    """Scratch arrays for one frame, reused frame after frame (and one set per thread)."""

    def __init__(self, shape):
        self.gx = np.zeros(shape, np.float32)
        self.gy = np.zeros(shape, np.float32)
        self.tmp = np.empty(shape, np.float32)


def _lambert_frame(hs, light, out, work):
    """Shade one frame whose heights are pre-scaled by ``bump / (2 pixel_size)``.

    Processing one frame at a time keeps the dozen temporaries in cache, which makes
    this several times faster than the same operations on a whole stack.
    """
    lx, ly, lz = (np.float32(v) for v in light)
    gx, gy, tmp = work.gx, work.gy, work.tmp
    # Central differences inside, one-sided at the border, all as twice the slope (the
    # factor 1/2 is in the pre-scaling). Single rows/columns keep a zero slope.
    if hs.shape[1] > 1:
        np.subtract(hs[:, 2:], hs[:, :-2], out=gx[:, 1:-1])
        np.subtract(hs[:, 1], hs[:, 0], out=gx[:, 0])
        np.subtract(hs[:, -1], hs[:, -2], out=gx[:, -1])
        gx[:, 0] *= 2
        gx[:, -1] *= 2
    else:
        gx.fill(0)  # gx is overwritten below, so reset it for every frame
    if hs.shape[0] > 1:
        np.subtract(hs[2:], hs[:-2], out=gy[1:-1])
        np.subtract(hs[1], hs[0], out=gy[0])
        np.subtract(hs[-1], hs[-2], out=gy[-1])
        gy[0] *= 2
        gy[-1] *= 2
    # p = gx is the slope to the right, q = gy the slope down the rows, so the normal
    # is (-p, q, 1) / sqrt(1 + p^2 + q^2) in (x right, y up, z out of the image).
    np.multiply(gx, -lx, out=out)
    np.multiply(gy, ly, out=tmp)
    out += tmp
    out += lz
    np.square(gx, out=gx)
    np.square(gy, out=tmp)
    gx += tmp
    gx += np.float32(1)
    np.sqrt(gx, out=gx)
    out /= gx
    np.maximum(out, np.float32(0), out=out)
    return out


def shade(height, *, azimuth=135.0, elevation=45.0, bump=2.0, pixel_size=1.0):
    r"""Lambert shading of a bump-mapped height field (Sec. 2.1 of the paper, [6]).

    The normal at each pixel is :math:`n \propto (-b \, \partial H/\partial x,
    -b \, \partial H/\partial y, 1)` (:math:`y` pointing up the image, :math:`b` the
    ``bump`` relief), and :math:`S = \max(0, n \cdot l)` for the parallel light
    :math:`l` (:func:`light_vector`).

    Parameters
    ----------
    height : array_like, shape (H, W) or (n, H, W)
        Height in [0, 1] units (a stack is shaded frame by frame).
    azimuth, elevation : float
        Light direction in degrees (see :func:`light_vector`).
    bump : float
        Pixels of relief per unit of height, >= 0.
    pixel_size : float
        Size of one pixel in full-resolution pixels (slopes are per full-resolution
        pixel, so a reduced-size preview shades like the full image).

    Returns
    -------
    ndarray, same shape as ``height``, float32 in [0, 1]

    Examples
    --------
    >>> flat = shade(np.zeros((3, 3)), elevation=30)
    >>> float(flat[1, 1])
    0.5
    >>> ramp = np.tile(np.linspace(0, 1, 5), (3, 1))  # rising to the right: faces left
    >>> bool(shade(ramp, azimuth=180)[1, 2] > shade(ramp, azimuth=0)[1, 2])
    True
    """
    h = check_array("height", height, ndim=(2, 3), dtype_kinds="biuf")
    light = light_vector(azimuth, elevation)
    bump = check_range("bump", bump, 0)
    pixel_size = check_range("pixel_size", pixel_size, 0, lo_open=True)
    return _lambert(np.asarray(h, dtype=np.float32), light, bump, pixel_size)


def feather_weights(mask, feather, *, pixel_size=1.0):
    """Weights that fade the effect in over ``feather`` pixels inside the region's edge.

    Parameters
    ----------
    mask : array_like of bool, shape (H, W)
        The region (True inside).
    feather : float
        Width of the fade, in full-resolution pixels; 0 gives a hard edge.
    pixel_size : float
        Size of one pixel of ``mask`` in full-resolution pixels.

    Returns
    -------
    ndarray, shape (H, W), float32
        0 outside the region (exactly), rising smoothly (smoothstep of the distance
        to the nearest outside pixel) to 1 at ``feather`` pixels inside. The image
        border is not an edge: a region covering the whole image has weight 1.

    Examples
    --------
    >>> m = np.zeros((1, 7), bool)
    >>> m[0, 1:] = True
    >>> np.round(feather_weights(m, 4).astype(float), 2).tolist()
    [[0.0, 0.04, 0.32, 0.68, 0.96, 1.0, 1.0]]
    """
    m = check_mask("mask", mask, allow_empty=True)
    feather = check_range("feather", feather, 0)
    pixel_size = check_range("pixel_size", pixel_size, 0, lo_open=True)
    width = feather / pixel_size
    if m.all() or width == 0:
        return m.astype(np.float32)
    # Distance (in pixels) from each inside pixel to the nearest outside pixel: 1 for
    # pixels on the edge, so the fade starts half a pixel outside the region. Only
    # distances up to width + 1/2 change the weight (beyond, it is 1).
    reach = math.ceil(width + 0.5)
    if reach <= _NEAR_REACH:
        d = np.sqrt(_near_squared_distance(m, reach))
    else:
        from scipy import ndimage

        d = ndimage.distance_transform_edt(m)
    x = np.clip((d - 0.5) / width, 0.0, 1.0)
    return (x * x * (3 - 2 * x)).astype(np.float32)


# The feathers (in pixels of the array) the exact short-range distance below serves;
# wider ones use scipy's transform, whose cost does not grow with the width.
_NEAR_REACH = 12


def _near_squared_distance(inside, reach):
    r"""Squared distance from each pixel to the nearest outside one, exact up to ``reach``.

    float64 (H, W): 0 outside, the exact :math:`d^2` where :math:`d \le` ``reach``,
    and some value above ``reach**2`` elsewhere (a pixel farther in, or one with no
    outside pixel at all); beyond the image is not outside. As
    ``scipy.ndimage.distance_transform_edt(inside) ** 2`` up to ``reach`` (the tests
    compare them), without importing ``scipy.ndimage``, whose import alone took
    longer than this at 1920 px (0.35 s of parsing docstrings against 0.05 s;
    issue 39), and in a few passes for the feather's few pixels.

    Separable: first, per column, the distance ``g`` to the nearest outside pixel
    above or below, up to ``reach`` (``reach + 1`` meaning none that near); then
    :math:`d^2(y, x) = \min_{|k| \le reach} k^2 + g(y, x + k)^2`. The nearest
    outside pixel at a distance <= ``reach`` lies within ``reach`` in both
    directions, so it is among the candidates, and every candidate is a true
    distance or larger than ``reach``.
    """
    h, w = inside.shape
    far = reach + 1
    outside = ~inside
    g = np.where(inside, far, 0).astype(np.int32)
    hit = np.empty((h, w), bool)
    for k in range(1, min(reach, h - 1) + 1):
        # An outside pixel k rows above or below, and none nearer found yet.
        hit[:k] = False
        hit[k:] = outside[:-k]
        hit[:-k] |= outside[k:]
        hit &= g == far
        g[hit] = k
    g *= g
    d2 = g.copy()
    for k in range(1, min(reach, w - 1) + 1):
        np.minimum(d2[:, k:], g[:, :-k] + k * k, out=d2[:, k:])
        np.minimum(d2[:, :-k], g[:, k:] + k * k, out=d2[:, :-k])
    return d2.astype(np.float64)


def apply_shading(image, shading, reference, k, weight=None):
    r"""Change the photo's brightness by the change of shading: Sec. 2.1, our decision.

    .. math:: O_t = I \, \min\big(\max(0, 1 + k \, w \, (S_t - S_0)), 1 / \max_c I\big)

    i.e. :math:`\mathrm{clip}(I (1 + k w (S_t - S_0)))` with the clipping done on the
    factor, the same for every channel, so that a brightened colour keeps its hue
    instead of drifting to white where one channel saturates.

    Parameters
    ----------
    image : array_like, shape (H, W) or (H, W, 3)
        The photo :math:`I`.
    shading : array_like, shape (H, W) or (n, H, W)
        :math:`S_t` from :func:`shade`.
    reference : array_like, shape (H, W)
        :math:`S_0`, the shading of the rest height (Eq. (2)); where
        :math:`S_t = S_0` the photo is returned unchanged.
    k : float
        Shading strength >= 0.
    weight : array_like, shape (H, W), optional
        :math:`w` (:func:`feather_weights`); pixels with weight 0 keep the photo's
        values exactly.

    Returns
    -------
    ndarray, shape of ``shading`` (+ the channel axis of ``image``), float32

    Examples
    --------
    >>> I = np.full((2, 2, 3), 0.5, np.float32)
    >>> S0 = np.full((2, 2), 0.5, np.float32)
    >>> out = apply_shading(I, S0 + 0.2, S0, k=1.0)
    >>> out.dtype, np.round(out[0, 0].astype(float), 3).tolist()
    (dtype('float32'), [0.6, 0.6, 0.6])
    """
    img = as_image(image)
    S = check_array("shading", shading, ndim=(2, 3), dtype_kinds="f").astype(np.float32)
    S0 = check_array("reference", reference, ndim=2, dtype_kinds="f").astype(np.float32)
    check_shape_match("shading", S if S.ndim == 2 else S[0], img.shape[:2])
    check_shape_match("reference", S0, img.shape[:2])
    k = check_range("k", k, 0)
    w = np.ones(img.shape[:2], np.float32)
    if weight is not None:
        w = check_array("weight", weight, ndim=2, dtype_kinds="f").astype(np.float32)
        check_shape_match("weight", w, img.shape[:2])
    relight = _Relight(img, S0, k * w)
    stack = S.reshape((-1,) + S.shape[-2:])
    out = np.empty(stack.shape + img.shape[2:], np.float32)
    factor = np.empty(img.shape[:2], np.float32)
    for i in range(stack.shape[0]):
        relight.frame(stack[i], out[i], factor)
    return out.reshape(S.shape + img.shape[2:])


class _Relight:
    r""":math:`O = I f`, :math:`f = \min(\max(0, 1 + k w (S - S_0)), 1 / \max_c I)`, per frame."""

    def __init__(self, image, reference, kw):
        self.image = image
        self.reference = reference
        self.kw = kw.astype(np.float32)
        # f = kw S + (1 - kw S_0): two passes per frame instead of three. Where w == 0
        # this is 0 S + 1 = 1 exactly, so the photo's value comes back bit for bit.
        self.offset = (1 - self.kw * reference).astype(np.float32)
        # f >= 1 - kw >= 0 already when k w <= 1: then no clipping at black is needed.
        self.can_go_negative = bool(self.kw.size) and float(self.kw.max()) > 1
        if image.ndim == 3:
            # One channel at a time: a long inner loop over pixels is several times
            # faster than broadcasting the factor along a length-3 last axis.
            #: The photo channel-first, (C, h, w) float32 (C = 1 for grey).
            self.planes = np.ascontiguousarray(np.moveaxis(image, -1, 0), np.float32)
            self.channels = list(self.planes)
            top = self.channels[0]
            for channel in self.channels[1:]:
                top = np.maximum(top, channel)
        else:
            self.planes = np.ascontiguousarray(image[None], np.float32)
            top = image.astype(np.float32)
        # The largest factor that keeps every channel <= 1 (inf for black pixels).
        with np.errstate(divide="ignore"):
            self.cap = np.float32(1) / top

    def frame(self, shading, out, factor):
        """Write frame ``out`` (h, w[, 3]) for one shading (h, w), using ``factor`` as scratch."""
        np.multiply(shading, self.kw, out=factor)
        factor += self.offset
        # Dark shading would flip the photo's sign: stop at black. Bright shading stops
        # where the brightest channel reaches 1.
        if self.can_go_negative:
            np.maximum(factor, np.float32(0), out=factor)
        np.minimum(factor, self.cap, out=factor)
        if self.image.ndim == 3:
            for c, channel in enumerate(self.channels):
                np.multiply(channel, factor, out=out[..., c])
        else:
            np.multiply(self.image, factor, out=out)
        return out
