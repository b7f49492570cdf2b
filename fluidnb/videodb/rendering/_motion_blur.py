r"""The approximate mean image (Okabe et al., sec. 6): the target blurred along its motion.

The blended difference frames :math:`D_i` carry no colour, so each frame of the
paper's rendering is an image standing for the fragments' mean images :math:`A` plus
:math:`D_i`: the target blurred along the assigned motion with a pseudo shutter, then
by a Gaussian whose size grows with the motion's magnitude, against noise
(:func:`motion_blur`). :func:`~fluidnb.videodb.rendering.reference_motion_blur` is the
same as whole-image warps.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy import ndimage as ndi

from ..._validation import check_array, check_range, check_vector_field
from ._threads import _THREADS, _each_frame

__all__ = ["motion_blur"]

# Motion-blur samples are at most this far apart along the blur line (pixels).
_BLUR_STEP = 0.5


def _check_image(name, image):
    """A float32 copy of a (H, W) or (H, W, C) image."""
    arr = check_array(name, image, ndim=(2, 3), dtype_kinds="biuf")
    return arr.astype(np.float32)  # always a copy


def _sigma_levels(top):
    """Blur levels 0, 0.5, 1, then a factor sqrt(2) apart, up to at least ``top``.

    Linear interpolation between two Gaussian blurs approximates the blur in between
    closely when their sigmas are this close.
    """
    levels = [0.0]
    s = 0.5
    while levels[-1] < top:
        levels.append(s)
        s = s + 0.5 if s < 1.0 else s * math.sqrt(2.0)
    return np.array(levels)


def _variable_blur(image, sigma):
    """Gaussian blur of standard deviation ``sigma(x)`` per pixel (pre-blurred copies)."""
    top = float(sigma.max())
    if top == 0.0:
        return image
    levels = _sigma_levels(top)
    k = np.clip(np.searchsorted(levels, sigma, side="right") - 1, 0, len(levels) - 2)
    frac = (sigma - levels[k]) / (levels[k + 1] - levels[k])
    frac = frac.astype(np.float32)
    if image.ndim == 3:
        frac = frac[..., None]
    out = image.copy()
    prev = image
    for i in range(1, len(levels)):
        sig = (levels[i],) * 2 + (0,) * (image.ndim - 2)
        cur = ndi.gaussian_filter(image, sig, mode="reflect")
        sel = k == i - 1
        if np.any(sel):
            # prev + frac (cur - prev): a fraction of exactly 0 returns prev bit for bit.
            out[sel] = (prev + frac * (cur - prev))[sel]
        prev = cur
    return out


def motion_blur(image, velocity, *, shutter, denoise):
    r"""The approximate mean image :math:`A`: the target blurred along its motion.

    Okabe et al., sec. 6: the blended differences carry no colour, so they are added to an
    image standing for the fragments' mean images :math:`A`, made from the target by a
    pseudo motion blur along the assigned motion (with a pseudo shutter time), plus a
    Gaussian blur whose size is proportional to the motion's magnitude, against noise.

    The motion blur averages the image along the line :math:`x + t\,v(x)` for
    :math:`t \in [-s/2, s/2]` frames (``s = shutter``), with samples at most half a
    pixel apart (bilinear, clamped at the border). The Gaussian blur has standard
    deviation ``denoise * |v(x)|`` pixels at each pixel, interpolated between a few
    pre-blurred copies.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        The target image, float in [0, 1] (any real values work).
    velocity : ndarray, shape (H, W, 2)
        The assigned motion (dy, dx) in pixels per frame.
    shutter : float
        Pseudo shutter time in frames (>= 0): the blur spans ``shutter * |v|`` pixels.
    denoise : float
        Gaussian standard deviation per unit of speed (>= 0), pixels per (px/frame).

    Returns
    -------
    ndarray, shape of ``image``, float32
        ``shutter = 0`` and ``denoise = 0`` (or a zero velocity) return the image
        exactly.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Pacific Graphics 2011, section 6.

    Examples
    --------
    Vertical stripes keep their contrast under a vertical motion and lose it under a
    horizontal one:

    >>> img = np.tile(np.array([0.0, 1.0], dtype=np.float32), (8, 8))
    >>> v = np.zeros((8, 16, 2))
    >>> v[..., 0] = 2.0
    >>> bool(np.array_equal(motion_blur(img, v, shutter=2, denoise=0), img))
    True
    >>> v = v[..., ::-1]
    >>> round(float(motion_blur(img, v, shutter=2, denoise=0)[4, 4:12].std()), 3)
    0.0
    """
    img = _check_image("image", image)
    v = check_vector_field("velocity", velocity, shape=img.shape[:2]).astype(np.float32)
    shutter = check_range("shutter", shutter, 0)
    denoise = check_range("denoise", denoise, 0)
    speed = np.hypot(v[..., 0], v[..., 1])
    out = img
    times, weights = _shutter_samples(shutter, float(speed.max()))
    if len(times):
        flat = img.reshape(*img.shape[:2], -1)
        blurred = np.empty_like(flat)
        # Bands of rows, several per core, to whichever thread is free.
        bands = min(flat.shape[0], 8 * _THREADS)
        bounds = np.linspace(0, flat.shape[0], bands + 1).astype(int)
        _each_frame(
            lambda k: _line_average(flat, v, times, weights, bounds[k], bounds[k + 1], blurred),
            bands,
        )
        out = blurred.reshape(img.shape)
    if denoise > 0:
        out = _variable_blur(out, denoise * speed)
    return out  # _check_image made img a copy


def _shutter_samples(shutter, top_speed):
    """Times (frames, float32) and trapezoid weights of the motion blur's samples.

    ``n = ceil(shutter * top_speed / 0.5) + 1`` samples from ``-shutter / 2`` to
    ``shutter / 2`` (at most half a pixel apart where the motion is fastest), the two
    end ones weighing half: they stand for a continuous box average over the shutter.
    None (empty arrays) when nothing moves.
    """
    length = shutter * top_speed
    if not length > 0:
        return np.zeros(0, np.float32), np.zeros(0, np.float32)
    n = math.ceil(length / _BLUR_STEP) + 1
    times = np.linspace(-shutter / 2, shutter / 2, n).astype(np.float32)
    weights = np.ones(n, np.float32)
    weights[[0, -1]] = 0.5
    return times, weights


@njit(cache=True, nogil=True)
def _line_average(img, v, times, weights, row0, row1, out):
    """The pseudo motion blur, one pixel at a time: all samples along its line at once.

    ``out(x) = sum_j w_j img(x + t_j v(x)) / (n - 1)`` for the rows ``row0:row1``
    (the samples may read any row): each sample is
    :func:`fluidnb.fields.backward_warp`'s bilinear value (the displacement
    ``t_j v`` in float32, positions in float64 clamped at the border, the weights in
    float32, ``top + fy (bottom - top)``), summed in float64 in the order of ``j``,
    so the result is :func:`~fluidnb.videodb.rendering.reference_motion_blur`'s (whole-image
    warps in float64) to float32 round-off, without its n warps and temporaries.
    """
    h, w, n_ch = img.shape
    acc = np.empty(n_ch)
    last_r = np.float64(h - 1)
    last_c = np.float64(w - 1)
    count = np.float64(times.shape[0] - 1)
    for r in range(row0, row1):
        for c in range(w):
            acc[:] = 0.0
            for j in range(times.shape[0]):
                y = np.float64(times[j] * v[r, c, 0]) + r
                x = np.float64(times[j] * v[r, c, 1]) + c
                y = min(max(y, 0.0), last_r)
                x = min(max(x, 0.0), last_c)
                y0 = int(y)
                x0 = int(x)
                fy = np.float32(y - y0)
                fx = np.float32(x - x0)
                y1 = min(y0 + 1, h - 1)
                x1 = min(x0 + 1, w - 1)
                for ch in range(n_ch):
                    v00 = img[y0, x0, ch]
                    v10 = img[y1, x0, ch]
                    top = (img[y0, x1, ch] - v00) * fx + v00
                    bottom = (img[y1, x1, ch] - v10) * fx + v10
                    acc[ch] += np.float64(weights[j] * ((bottom - top) * fy + top))
            for ch in range(n_ch):
                out[r, c, ch] = np.float32(acc[ch] / count)
