"""Image input at the public boundary: anything reasonable in, float32 [0, 1] out.

Converted once, here, so the rest of the library can assume
``float32`` arrays of shape (H, W) or (H, W, 3) with values in [0, 1]
(see docs/conventions.md).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ._validation import check_choice

__all__ = ["LUMA", "as_image", "as_mask", "to_float01", "to_uint8"]

_MODES = (None, "grey", "rgb")

#: Rec. 709 luminance weights of R, G, B (as scikit-image's ``rgb2gray``): grey = RGB @ LUMA.
LUMA = np.array([0.2125, 0.7154, 0.0721], dtype=np.float32)


def as_image(image, *, mode=None, name="image", return_alpha=False, background=None):
    """Convert an image from a path, array or PIL image to float32 in [0, 1].

    Parameters
    ----------
    image : str, os.PathLike, ndarray or PIL.Image.Image
        A file path (any format Pillow reads), or pixels: ``uint8`` (0-255),
        ``uint16`` (0-65535), ``bool``, or floats already in [0, 1]; grey (H, W),
        grey with a channel axis (H, W, 1), grey + alpha (H, W, 2), RGB (H, W, 3)
        or RGBA (H, W, 4).
    mode : {None, "grey", "rgb"}
        ``None`` keeps grey as (H, W) and colour as (H, W, 3); ``"grey"`` converts
        colour to luminance (Rec. 709 weights, as scikit-image's ``rgb2gray``);
        ``"rgb"`` repeats grey into three channels.
    name : str
        The parameter's name in error messages.
    return_alpha : bool
        Also return the alpha channel (H, W) float32, or ``None`` if there is none.
        Otherwise an alpha channel is dropped (or used by ``background``).
    background : None, float or sequence of 3 floats
        Composite an image that has an alpha channel onto this grey level or RGB
        colour in [0, 1]: ``colour * alpha + background * (1 - alpha)``. The alpha
        is taken as straight (not premultiplied), as PNG stores it, so whatever
        colour a cut-out's fully transparent pixels hold disappears. ``None`` (the
        default) returns the colour channels as stored. No effect without alpha.

    Returns
    -------
    image : ndarray, shape (H, W) or (H, W, 3), float32
        A new array (never a view of the caller's data) with values in [0, 1].
    alpha : ndarray, shape (H, W), float32 or None
        Only with ``return_alpha=True``.

    Raises
    ------
    ValueError
        For a missing or unreadable file, an empty image, a wrong number of
        dimensions or channels, a non-numeric dtype, NaN/infinite values, or floats
        outside [0, 1].

    Examples
    --------
    >>> img = as_image(np.array([[0, 255]], dtype=np.uint8))
    >>> img.dtype, img.tolist()
    (dtype('float32'), [[0.0, 1.0]])

    A cut-out pixel half covered by white, over black:

    >>> as_image(np.array([[[255, 255, 255, 128]]], dtype=np.uint8), background=0).round(2).tolist()
    [[[0.5, 0.5, 0.5]]]
    """
    check_choice("mode", mode, _MODES)
    arr = _to_array(image, name)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (2, 3, 4)):
        raise ValueError(
            f"{name} must have shape (H, W), (H, W, 2), (H, W, 3) or (H, W, 4), got {arr.shape}"
        )
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"{name} is empty: got shape {arr.shape}")
    out = to_float01(arr, name=name)
    alpha = None
    if out.ndim == 3 and out.shape[2] in (2, 4):
        alpha = out[:, :, -1].copy()
        out = out[:, :, :-1]
        if out.shape[2] == 1:
            out = out[:, :, 0]
    if background is not None and alpha is not None:
        out = _composite(out, alpha, background, name)
    if mode == "grey" and out.ndim == 3:
        out = out @ LUMA
    elif mode == "rgb" and out.ndim == 2:
        out = np.repeat(out[:, :, None], 3, axis=2)
    out = np.ascontiguousarray(np.clip(out, 0.0, 1.0), dtype=np.float32)
    return (out, alpha) if return_alpha else out


def _composite(colour, alpha, background, name):
    bg = np.asarray(background, dtype=np.float32)
    if bg.ndim > 1 or bg.size not in (1, 3) or not np.all((bg >= 0) & (bg <= 1)):
        raise ValueError(
            f"background must be a grey level or an RGB colour in [0, 1], got {background!r}"
        )
    if bg.size == 3 and colour.ndim == 2:
        colour = np.repeat(colour[:, :, None], 3, axis=2)
    a = alpha[:, :, None] if colour.ndim == 3 else alpha
    return colour * a + bg.reshape(-1)[: 3 if colour.ndim == 3 else 1] * (1 - a)


def _to_array(image, name):
    if isinstance(image, (str, os.PathLike)):
        return _read(Path(image), name)
    if type(image).__module__.startswith("PIL."):
        return _from_pil(image)
    if isinstance(image, np.ndarray):
        return image
    if isinstance(image, (list, tuple)):
        try:
            return np.asarray(image)
        except ValueError as exc:
            raise ValueError(f"{name} is not a rectangular array: {exc}") from None
    raise ValueError(
        f"{name} must be a file path, a numpy array or a PIL image, got {type(image).__name__}"
    )


def _read(path, name):
    from PIL import Image, UnidentifiedImageError

    if path.is_dir():
        raise ValueError(f"{name}: {str(path)!r} is a folder, not an image file")
    if not path.is_file():
        raise ValueError(f"{name}: no such file {str(path)!r}")
    try:
        with Image.open(path) as im:
            im.load()
            return _from_pil(im)
    except (UnidentifiedImageError, OSError, SyntaxError) as exc:
        raise ValueError(f"{name}: cannot read {str(path)!r} as an image ({exc})") from None


def _from_pil(im):
    if im.mode in ("I;16", "I;16B", "I;16L"):
        return np.asarray(im, dtype=np.uint16)
    if im.mode not in ("L", "RGB", "RGBA", "1"):
        im = im.convert("RGBA" if "A" in im.getbands() or "transparency" in im.info else "RGB")
    return np.asarray(im)


def to_float01(pixels, *, name="pixels"):
    """Pixels of any shape as float32 in [0, 1]: what :func:`as_image` does once read.

    For stacks of frames and other arrays :func:`as_image` does not take (it wants
    one image): ``uint8`` (0-255) and ``uint16`` (0-65535) are divided by their
    maximum, ``bool`` is 0 or 1, floats must already lie in [0, 1] (to 1e-6).

    Parameters
    ----------
    pixels : ndarray
        Any shape.
    name : str
        The parameter's name in error messages.

    Returns
    -------
    ndarray, float32
        A new array of the same shape (values are not clipped: floats within 1e-6
        outside [0, 1] stay as they are; :func:`to_uint8` clips).

    Raises
    ------
    ValueError
        For another dtype, NaN or infinite values, or floats outside [0, 1].

    Examples
    --------
    >>> to_float01(np.array([[0, 65535]], dtype=np.uint16)).tolist()
    [[0.0, 1.0]]
    """
    arr = np.asarray(pixels)
    kind = arr.dtype.kind
    if kind == "b":
        return arr.astype(np.float32)
    if arr.dtype == np.uint8:
        return arr.astype(np.float32) / np.float32(255)
    if arr.dtype == np.uint16:
        return arr.astype(np.float32) / np.float32(65535)
    if kind == "f":
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or infinite values")
        lo, hi = float(arr.min()), float(arr.max())
        if lo < -1e-6 or hi > 1 + 1e-6:
            raise ValueError(
                f"{name} has float values in [{lo:g}, {hi:g}]; floats must lie in [0, 1] "
                "(divide 8-bit values by 255, or pass a uint8 array)"
            )
        return arr.astype(np.float32)
    raise ValueError(
        f"{name} has dtype {arr.dtype}; pass uint8 (0-255), uint16 (0-65535), bool, "
        "or floats in [0, 1]"
    )


def as_mask(mask, shape=None, *, name="mask", allow_empty=False):
    """Convert a mask from a path, array or PIL image to a boolean (H, W) array.

    A pixel is inside where the (grey) value exceeds 0.5, so white-on-black masks
    painted in any image editor work.

    Parameters
    ----------
    mask : str, os.PathLike, ndarray or PIL.Image.Image
        The mask, in any form :func:`as_image` accepts.
    shape : tuple of int, optional
        The required (H, W), usually the image's.
    name : str
        The parameter's name in error messages.
    allow_empty : bool
        Whether an all-False mask is acceptable.

    Returns
    -------
    ndarray, shape (H, W), bool

    Examples
    --------
    >>> as_mask(np.array([[0.0, 0.9]])).tolist()
    [[False, True]]
    """
    grey = as_image(mask, mode="grey", name=name)
    if shape is not None and grey.shape != tuple(shape)[:2]:
        raise ValueError(
            f"{name} must have the same height and width as the image {tuple(shape)[:2]}, "
            f"got {grey.shape}"
        )
    out = grey > 0.5
    if not allow_empty and not out.any():
        raise ValueError(f"{name} is empty: paint at least one pixel")
    return out


def to_uint8(image):
    """Convert float [0, 1] pixels to uint8 with rounding (not truncation).

    ipycanvas and most encoders want 8-bit pixels; casting floats straight to uint8
    would truncate 0.999 to 0, so convert here, once, tested.

    Examples
    --------
    >>> to_uint8(np.array([0.0, 0.5, 1.0])).tolist()
    [0, 128, 255]
    """
    arr = np.asarray(image, dtype=np.float32)
    return (np.clip(arr, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
