"""Image input at the public boundary: anything reasonable in, float32 [0, 1] out.

Converted once, here, so the rest of the library can assume
``float32`` arrays of shape (H, W) or (H, W, 3) with values in [0, 1]
(see docs/conventions.md).
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np

from ._validation import check_choice, check_input_file, check_int

__all__ = [
    "LUMA",
    "MAX_PIXELS",
    "as_image",
    "as_mask",
    "image_size",
    "max_pixels",
    "shrunk_shape",
    "to_float01",
    "to_uint8",
]

_MODES = (None, "grey", "rgb")

#: Rec. 709 luminance weights of R, G, B (as scikit-image's ``rgb2gray``): grey = RGB @ LUMA.
LUMA = np.array([0.2125, 0.7154, 0.0721], dtype=np.float32)

#: The most pixels an image file may declare (``FLUIDNB_MAX_PIXELS`` overrides it). Our
#: decision: 50 million takes every camera and phone photo up to 50 MP (8160 x 6120),
#: whose 8-bit decoding costs at most 200 MB, and refuses at once, from the file's
#: header, what only a mistake or a decompression bomb declares (8000 x 8000 black
#: pixels in 182 KiB; 30000 x 30000 in 200 bytes) -- before it fills the memory.
MAX_PIXELS = 50_000_000


def as_image(image, *, mode=None, name="image", return_alpha=False, background=None, max_side=None):
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
    max_side : int, optional
        Scale an image whose longer side is larger down to this many pixels
        (:func:`shrunk_shape`), by area averaging (alpha-weighted where there is an
        alpha channel). A file is scaled as it is decoded, before any float copy, so
        a large photo never fills memory at full size (the command line's
        ``--max-side``). ``None`` (the default) keeps the size.

    Returns
    -------
    image : ndarray, shape (H, W) or (H, W, 3), float32
        A new array (never a view of the caller's data) with values in [0, 1].
    alpha : ndarray, shape (H, W), float32 or None
        Only with ``return_alpha=True``.

    Raises
    ------
    ValueError
        For a missing or unreadable file (or a folder, a FIFO, ... named as such), a
        file that declares more than :func:`max_pixels` pixels, an empty image, a
        wrong number of dimensions or channels, a non-numeric dtype, NaN/infinite
        values, or floats outside [0, 1].

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
    if max_side is not None:
        max_side = check_int("max_side", max_side, 1)
    arr = _to_array(image, name, max_side)
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
    if max_side is not None and max(out.shape[:2]) > max_side:  # an array or PIL image
        out, alpha = _shrink_float(out, alpha, shrunk_shape(out.shape, max_side))
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


def _to_array(image, name, max_side=None):
    if isinstance(image, (str, os.PathLike)):
        return _read(Path(image), name, max_side)
    if type(image).__module__.startswith("PIL."):
        # A PIL image opened from a phone's file (an upload) carries its EXIF block;
        # one made from pixels says nothing and stays as it is.
        return _from_pil(_upright(image, _orientation(image)))
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


def max_pixels():
    """The most pixels an image file may declare: ``$FLUIDNB_MAX_PIXELS``, else MAX_PIXELS.

    Examples
    --------
    >>> max_pixels() >= 25_000_000
    True
    """
    text = os.environ.get("FLUIDNB_MAX_PIXELS", "").strip()
    if not text:
        return MAX_PIXELS
    try:
        value = int(float(text))
    except ValueError:
        value = 0
    if value < 1:
        raise ValueError(
            f"FLUIDNB_MAX_PIXELS must be a positive number of pixels (e.g. 100e6), got {text!r}"
        )
    return value


def shrunk_shape(shape, max_side):
    """The (H, W) an image of ``shape`` has once its longer side is at most ``max_side``.

    Both sides scale by ``max_side / max(H, W)`` (rounded, at least 1 pixel); an image
    that fits keeps its shape.

    Examples
    --------
    >>> shrunk_shape((3000, 4000), 1920), shrunk_shape((1080, 1920), 1920)
    ((1440, 1920), (1080, 1920))
    """
    h, w = int(shape[0]), int(shape[1])
    if max(h, w) <= max_side:
        return (h, w)
    scale = max_side / max(h, w)
    return (max(1, round(h * scale)), max(1, round(w * scale)))


def image_size(path, name="image"):
    """The (H, W) an image file declares, read from its header without decoding it.

    Raises the same ValueError as :func:`as_image` for a file that is missing, not a
    regular file, not an image, or larger than :func:`max_pixels`.

    Examples
    --------
    >>> from fluidnb import data
    >>> image_size(data.path("lake"))
    (270, 480)
    """
    with _open(Path(path), name) as im:
        if _orientation(im) in _QUARTER_TURNS:
            return (im.width, im.height)
        return (im.height, im.width)


def _open(path, name):
    """Open an image file lazily (header only), refusing what must not be decoded."""
    from PIL import Image, UnidentifiedImageError

    check_input_file(path, name, "an image file")
    limit = max_pixels()
    try:
        # We apply our own limit below; Pillow's warning for 89-179 MP would only repeat it.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            im = Image.open(path)
    except Image.DecompressionBombError as exc:  # Pillow's own limit, 179 MP
        found = re.search(r"\((\d+) pixels\)", str(exc))
        declared = f"{int(found.group(1)) / 1e6:.0f} MP" if found else "too many pixels"
        raise ValueError(_too_large(name, path, declared, limit)) from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise ValueError(f"{name}: cannot read {str(path)!r} as an image ({exc})") from None
    if im.width * im.height > limit:
        w, h = im.size
        im.close()
        raise ValueError(_too_large(name, path, f"{w} x {h} pixels ({w * h / 1e6:.0f} MP)", limit))
    return im


def _too_large(name, path, declared, limit):
    return (
        f"{name}: {str(path)!r} declares {declared}, more than the {limit / 1e6:g} MP fluidnb "
        "reads; scale it down first, or set FLUIDNB_MAX_PIXELS to allow more"
    )


#: EXIF orientations (tag 0x0112) whose upright picture is turned by a quarter: its
#: height is the stored width.
_QUARTER_TURNS = (5, 6, 7, 8)


def _orientation(im):
    """The EXIF orientation a photo declares (1 = stored upright; 1 when it says nothing)."""
    try:
        value = im.getexif().get(0x0112, 1)
    except Exception:  # a damaged EXIF block: show the pixels as they are stored
        return 1
    return value if value in range(1, 9) else 1


def _upright(im, orientation):
    """``im`` turned the way its EXIF orientation says a viewer shows it.

    Phones store the sensor's pixels and write which way is up into the EXIF block;
    every photo viewer applies it, so a user expects the photo the way it looked on
    their phone, not on its side. Pillow's ``ImageOps.exif_transpose`` does this for
    a full-size image; we read the orientation before a shrink (which drops the EXIF
    block) and apply the same transposition afterwards.
    """
    from PIL import Image

    method = {
        2: Image.Transpose.FLIP_LEFT_RIGHT,
        3: Image.Transpose.ROTATE_180,
        4: Image.Transpose.FLIP_TOP_BOTTOM,
        5: Image.Transpose.TRANSPOSE,
        6: Image.Transpose.ROTATE_270,
        7: Image.Transpose.TRANSVERSE,
        8: Image.Transpose.ROTATE_90,
    }.get(orientation)
    return im if method is None else im.transpose(method)


def _read(path, name, max_side=None):
    from PIL import UnidentifiedImageError

    with _open(path, name) as im:
        try:
            orientation = _orientation(im)
            if max_side is not None and max(im.size) > max_side:
                return _from_pil(_upright(_shrink_pil(im, max_side), orientation))
            im.load()
            return _from_pil(_upright(im, orientation))
        except (UnidentifiedImageError, OSError, SyntaxError, ValueError, EOFError) as exc:
            raise ValueError(f"{name}: cannot read {str(path)!r} as an image ({exc})") from None


def _shrink_pil(im, max_side):
    """``im`` scaled to :func:`shrunk_shape` by area averaging, decoded at a reduced size.

    A JPEG is decoded straight at 1/2, 1/4 or 1/8 of its size where that is still
    larger than the target (``draft``), so a 12 MP photo never exists in memory at
    full size. Pillow averages RGBA and LA premultiplied by alpha, so the colour of
    clear pixels does not bleed into their neighbours.
    """
    from PIL import Image

    h, w = shrunk_shape((im.height, im.width), max_side)
    if im.format == "JPEG":
        im.draft(im.mode, (w, h))
    im.load()
    if im.mode == "1":
        im = im.convert("L")
    elif im.mode not in ("L", "LA", "RGB", "RGBA", "I;16", "I", "F"):
        im = im.convert("RGBA" if "A" in im.getbands() or "transparency" in im.info else "RGB")
    return im.resize((w, h), Image.Resampling.BOX)


def _shrink_float(image, alpha, shape):
    """Area-average float32 pixels (and alpha, colour weighted by it) down to ``shape``."""
    from PIL import Image

    h, w = shape

    def box(channel):
        return np.asarray(
            Image.fromarray(np.ascontiguousarray(channel, np.float32)).resize(
                (w, h), Image.Resampling.BOX
            )
        )

    planes = image[:, :, None] if image.ndim == 2 else image
    if alpha is None:
        out = np.stack([box(planes[:, :, k]) for k in range(planes.shape[2])], axis=2)
        return (out[:, :, 0] if image.ndim == 2 else out), None
    a = box(alpha)
    safe = np.where(a > 0, a, 1.0)
    out = np.stack([box(planes[:, :, k] * alpha) / safe for k in range(planes.shape[2])], axis=2)
    return (out[:, :, 0] if image.ndim == 2 else out), a


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


#: Values :func:`to_uint8` converts per pass (1 MB of float32 scratch, in cache).
_SLAB = 1 << 18


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
    if arr.ndim == 0:
        return (np.clip(arr, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    # A slab at a time through one scratch array: converting a whole clip at once made
    # three float32 copies of it (4x the clip: at 1920 px 5 GB and half a minute).
    # clip(x, 0, 1) * 255 equals clip(x * 255, 0, 255) bit for bit.
    flat = arr.reshape(-1)  # a view of a contiguous array (a copy of a strided one)
    out = np.empty(flat.shape, np.uint8)
    scratch = np.empty(min(_SLAB, flat.size), np.float32)
    for i in range(0, flat.size, _SLAB):
        work = scratch[: min(_SLAB, flat.size - i)]
        np.multiply(flat[i : i + _SLAB], np.float32(255), out=work)
        np.clip(work, np.float32(0), np.float32(255), out=work)
        work += np.float32(0.5)
        out[i : i + _SLAB] = work  # truncating after + 0.5 rounds
    return out.reshape(arr.shape)
