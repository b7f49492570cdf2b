"""Resampling of images, scalar maps and vector fields between grids.

All resampling is pixel-centre aligned: the centre of pixel ``(0, 0)`` and the outer
edges of the image stay where they are, so an (H, W) grid and its (2H, 2W) version
cover the same area. Vector fields are in pixels, so changing the grid rescales
their components (docs/conventions.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from skimage.transform import resize as _sk_resize

from .._validation import check_array, check_choice, check_int, check_vector_field

__all__ = ["downsample", "resize", "resize_vector_field", "upsample"]


def resize(field, shape, *, order=1, anti_aliasing=None):
    """Resample an image, scalar map or multichannel field to a new height and width.

    Parameters
    ----------
    field : ndarray, shape (H, W) or (H, W, C)
        Channels are resampled independently and never mixed.
    shape : tuple of int, (H2, W2)
        The new height and width (a trailing channel count equal to C is accepted,
        so ``other.shape`` can be passed).
    order : {0, 1, 3}
        0 nearest, 1 bilinear (default), 3 bicubic (can overshoot the input's range).
    anti_aliasing : bool, optional
        Blur before downsampling so that fine detail does not alias (a Gaussian of
        standard deviation ``(scale - 1) / 2`` pixels per axis, as scikit-image).
        Defaults to True when either side shrinks, False otherwise.

    Returns
    -------
    ndarray, shape (H2, W2) or (H2, W2, C)
        Float32 for float32 (and integer or bool) input, float64 for float64 input.
        Values are not rescaled (use :func:`resize_vector_field` for velocities).

    Raises
    ------
    ValueError
        For a field that is not 2-D or 3-D, holds NaN or infinity, or a shape with
        a side below 1, or a bad ``order`` or ``anti_aliasing``.

    Notes
    -----
    Uses :func:`skimage.transform.resize` with ``mode="edge"`` (the border pixels
    extend outwards) and ``preserve_range=True``.

    Examples
    --------
    >>> img = np.full((4, 6), 0.5, dtype=np.float32)
    >>> out = resize(img, (8, 3))
    >>> out.shape, out.dtype, bool(np.allclose(out, 0.5))
    ((8, 3), dtype('float32'), True)
    """
    arr = _check_field(field)
    shape = _check_shape(shape, arr)
    order = _check_order(order)
    check_choice("anti_aliasing", anti_aliasing, (None, True, False))
    if shape == arr.shape[:2]:
        return arr.copy()
    if anti_aliasing is None:
        anti_aliasing = shape[0] < arr.shape[0] or shape[1] < arr.shape[1]
    out = _sk_resize(
        arr, shape, order=order, mode="edge", anti_aliasing=anti_aliasing, preserve_range=True
    )
    return out.astype(arr.dtype, copy=False)


def resize_vector_field(velocity, shape, *, order=1):
    """Resample a (dy, dx) vector field to a new grid, rescaling its components.

    The unit is the pixel, so a field that moves content a quarter of the way across
    an (H, W) image must do the same on the (H2, W2) grid: ``dy`` is multiplied by
    ``H2 / H`` and ``dx`` by ``W2 / W``.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        (dy, dx) in pixels (per frame).
    shape : tuple of int, (H2, W2)
        The new height and width.
    order : {0, 1, 3}
        Interpolation order, see :func:`resize`.

    Returns
    -------
    ndarray, shape (H2, W2, 2)
        Float32 for float32 input, float64 for float64 input.

    Examples
    --------
    >>> v = np.zeros((16, 24, 2), dtype=np.float32)
    >>> v[..., 1] = 1.0  # one pixel per frame to the right
    >>> big = resize_vector_field(v, (128, 192))
    >>> big.shape, float(big[0, 0, 1])
    ((128, 192, 2), 8.0)
    """
    v = check_vector_field("velocity", velocity)
    shape = _check_shape(shape, v)
    out = resize(v, shape, order=order)
    out[..., 0] *= shape[0] / v.shape[0]
    out[..., 1] *= shape[1] / v.shape[1]
    return out


def downsample(field, factor, *, vector=False, precision="float64"):
    """Shrink a field by an integer factor.

    When ``factor`` divides both sides, each output pixel is the mean of a
    ``factor x factor`` block: the natural low-resolution version of the field (the
    source grid of the turbulence method), exact for constants, and the inverse of
    a nearest-neighbour :func:`upsample`. Otherwise the field is resized to
    ``(ceil(H / factor), ceil(W / factor))`` with :func:`resize` (anti-aliased
    bilinear), which covers the same area.

    Parameters
    ----------
    field : ndarray, shape (H, W) or (H, W, C)
        An image, scalar map or, with ``vector=True``, a (dy, dx) field.
    factor : int
        The shrink factor, at least 1.
    vector : bool
        The field is a vector field (H, W, 2) in pixels: divide its components by
        the scale change, as :func:`resize_vector_field` does.
    precision : {"float64", "float32"}
        The arithmetic of the block means: float64 (numpy), or float32 through
        OpenCV's area resize (about 25 times as fast on many channels, equal to
        float64 to float32 round-off), for which ``factor`` must divide both sides.

    Returns
    -------
    ndarray, shape (ceil(H / factor), ceil(W / factor)[, C])
        Float32 for float32 (and integer or bool) input or ``precision="float32"``,
        float64 for float64 input.

    Examples
    --------
    >>> x = np.arange(16, dtype=np.float32).reshape(4, 4)
    >>> downsample(x, 2)
    array([[ 2.5,  4.5],
           [10.5, 12.5]], dtype=float32)
    """
    arr, factor = _check_factor_args(field, factor, vector)
    h, w = arr.shape[:2]
    if check_choice("precision", precision, ("float64", "float32")) == "float32":
        if h % factor or w % factor:
            raise ValueError(
                f"factor must divide the field's height and width {(h, w)} with "
                f'precision="float32", got {factor}: crop the field to whole blocks first'
            )
        out = _block_means32(arr, factor)
        if vector:
            out /= np.float32(factor)
        return out
    if h % factor or w % factor:
        shape = (math.ceil(h / factor), math.ceil(w / factor))
        return resize_vector_field(arr, shape) if vector else resize(arr, shape)
    blocks = arr.reshape(h // factor, factor, w // factor, factor, *arr.shape[2:])
    # Summing in float64 keeps a constant float32 field exactly constant.
    out = blocks.mean(axis=(1, 3), dtype=np.float64)
    if vector:
        out /= factor
    return out.astype(arr.dtype, copy=False)


def upsample(field, factor, *, order=1, vector=False):
    """Enlarge a field by an integer factor to ``(factor * H, factor * W)``.

    Parameters
    ----------
    field : ndarray, shape (H, W) or (H, W, C)
        An image, scalar map or, with ``vector=True``, a (dy, dx) field.
    factor : int
        The enlargement factor, at least 1.
    order : {0, 1, 3}
        0 repeats each pixel into a ``factor x factor`` block (exactly; the inverse
        of :func:`downsample` is then exact), 1 bilinear (default), 3 bicubic.
    vector : bool
        The field is a vector field (H, W, 2) in pixels: multiply its components by
        ``factor``.

    Returns
    -------
    ndarray, shape (factor * H, factor * W[, C])
        Float32 for float32 (and integer or bool) input, float64 for float64 input.

    Examples
    --------
    >>> upsample(np.array([[0.0, 1.0]]), 2, order=0)
    array([[0., 0., 1., 1.],
           [0., 0., 1., 1.]])
    """
    arr, factor = _check_factor_args(field, factor, vector)
    order = _check_order(order)
    if order == 0:
        out = np.repeat(np.repeat(arr, factor, axis=0), factor, axis=1)
    else:
        out = resize(arr, (arr.shape[0] * factor, arr.shape[1] * factor), order=order)
    if vector:
        out *= factor
    return out


# OpenCV's filters and resizes take at most a few hundred channels: channels go
# through in chunks of this many.
_CV_CHANNELS = 128


def _per_chunk(x, fn, shape_out):
    """Apply an OpenCV call to (h, w, C) float32 in chunks of channels."""
    c = x.shape[2]
    if c <= _CV_CHANNELS:
        return fn(x).reshape(shape_out + (c,))
    out = np.empty(shape_out + (c,), dtype=np.float32)
    for c0 in range(0, c, _CV_CHANNELS):
        c1 = min(c, c0 + _CV_CHANNELS)
        out[..., c0:c1] = fn(np.ascontiguousarray(x[..., c0:c1])).reshape(shape_out + (c1 - c0,))
    return out


def _block_means32(arr, factor):
    """Means of ``factor x factor`` blocks in float32 (OpenCV's area resize by a whole factor).

    OpenCV's area resampling by a whole factor is exactly the block mean, 25 times
    as fast as a numpy reduction over strided axes.
    """
    import cv2

    x = np.ascontiguousarray(arr if arr.ndim == 3 else arr[..., None], dtype=np.float32)
    shape = (arr.shape[0] // factor, arr.shape[1] // factor)
    size = (shape[1], shape[0])
    out = _per_chunk(x, lambda a: cv2.resize(a, size, interpolation=cv2.INTER_AREA), shape)
    return out if arr.ndim == 3 else out[..., 0]


def _check_field(field, name="field"):
    arr = check_array(name, field, ndim=(2, 3))
    return arr.astype(np.result_type(arr.dtype, np.float32), copy=False)


def _check_order(order):
    order = check_int("order", order, 0, 3)
    return check_choice("order", order, (0, 1, 3))


def _check_shape(shape, arr, name="shape"):
    ok = isinstance(shape, Sequence | np.ndarray) and len(shape) in (2, 3)
    if ok and len(shape) == 3:
        ok = arr.ndim == 3 and shape[2] == arr.shape[2]
    if not ok:
        raise ValueError(f"{name} must be a (height, width) pair, got {shape!r}")
    return (check_int(f"{name}[0]", shape[0], 1), check_int(f"{name}[1]", shape[1], 1))


def _check_factor_args(field, factor, vector):
    check_choice("vector", vector, (True, False))
    arr = check_vector_field("field", field) if vector else _check_field(field)
    return arr, check_int("factor", factor, 1)
