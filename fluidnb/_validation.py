"""One place for argument checks, so every error reads the same way.

Every message names the parameter, the value it got and what is allowed, e.g.
``ValueError: rth must be in [0, 1], got 1.3``.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import stat
import zipfile

import numpy as np

__all__ = [
    "check_array",
    "check_choice",
    "check_finite",
    "check_fps",
    "check_input_file",
    "check_int",
    "check_mask",
    "check_npz_file",
    "check_range",
    "check_shape_match",
    "check_vector_field",
    "parse_json",
]


def _fmt(value):
    if isinstance(value, float):
        return f"{value:g}"
    return repr(value)


def check_range(name, value, lo=None, hi=None, *, lo_open=False, hi_open=False):
    """Return ``value`` as a float if it lies in the interval, else raise ValueError.

    Parameters
    ----------
    name : str
        The parameter's name, as the user spells it (``"rth"``, ``"sigma"``).
    value : float
        The value to check. Booleans, NaN and infinities are refused.
    lo, hi : float or None
        Bounds; ``None`` means unbounded on that side.
    lo_open, hi_open : bool
        Exclude the bound itself.

    Examples
    --------
    >>> check_range("rth", 0.4, 0, 1)
    0.4
    >>> check_range("rth", 1.3, 0, 1)
    Traceback (most recent call last):
    ...
    ValueError: rth must be in [0, 1], got 1.3
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {_fmt(value)}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {_fmt(value)}")
    below = lo is not None and (v <= lo if lo_open else v < lo)
    above = hi is not None and (v >= hi if hi_open else v > hi)
    if below or above:
        raise ValueError(f"{name} must be {_interval(lo, hi, lo_open, hi_open)}, got {_fmt(v)}")
    return v


#: The frame rates a clip may have, frames per second. Below 0.01 a GIF cannot store
#: the delay (it keeps hundredths of a second in 16 bits: at most 655 s a frame); above
#: 1000 no player shows the frames and ffmpeg's rate arithmetic fails long before
#: absurd values such as 1e30.
FPS_RANGE = (0.01, 1000.0)


def check_fps(value, name="fps"):
    """Return a frame rate as a float if it lies in :data:`FPS_RANGE`, else raise ValueError.

    Examples
    --------
    >>> check_fps(24)
    24.0
    >>> check_fps(1e30)
    Traceback (most recent call last):
    ...
    ValueError: fps must be in [0.01, 1000] frames per second, got 1e+30
    """
    lo, hi = FPS_RANGE
    v = check_range(name, value)  # a finite real number, or ValueError
    if not lo <= v <= hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}] frames per second, got {_fmt(v)}")
    return v


def _interval(lo, hi, lo_open, hi_open):
    if lo is not None and hi is not None:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        return f"in {left}{_fmt(lo)}, {_fmt(hi)}{right}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {_fmt(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {_fmt(hi)}"
    return "a finite number"


def check_int(name, value, lo=None, hi=None):
    """Return ``value`` as an int if it is an integer within [lo, hi], else raise.

    Integral floats such as ``4.0`` are accepted (sliders and JSON produce them);
    ``4.5`` and booleans are not.

    Examples
    --------
    >>> check_int("T", 64, 2)
    64
    >>> check_int("T", 1, 2)
    Traceback (most recent call last):
    ...
    ValueError: T must be an integer >= 2, got 1
    """
    ok = isinstance(value, numbers.Integral) or (
        isinstance(value, numbers.Real) and float(value).is_integer()
    )
    if isinstance(value, bool) or not ok:
        raise ValueError(f"{name} must be an integer, got {_fmt(value)}")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} must be an integer {_interval(lo, hi, False, False)}, got {v}")
    return v


def check_choice(name, value, choices):
    """Return ``value`` if it is one of ``choices``, else raise ValueError.

    Examples
    --------
    >>> check_choice("mapping", "convex", ("plane", "convex", "concave"))
    'convex'
    """
    if value not in choices:
        allowed = ", ".join(repr(c) for c in choices)
        raise ValueError(f"{name} must be one of {allowed}, got {_fmt(value)}")
    return value


def check_finite(name, array):
    """Raise ValueError if ``array`` holds NaN or infinity; return it unchanged."""
    array = np.asarray(array)
    if array.dtype.kind in "fc" and not np.all(np.isfinite(array)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        raise ValueError(f"{name} contains {bad} NaN or infinite value(s); all must be finite")
    return array


def check_array(name, array, *, ndim=None, dtype_kinds="biuf", finite=True, min_size=1):
    """Check a numeric array's dimensionality, kind and values.

    Parameters
    ----------
    name : str
        The parameter's name for messages.
    array : array_like
        The value to check.
    ndim : int or tuple of int, optional
        Allowed numbers of dimensions.
    dtype_kinds : str
        Allowed ``dtype.kind`` letters (default: bool, integers, floats).
    finite : bool
        Refuse NaN and infinities.
    min_size : int
        Smallest number of elements (refuses empty arrays by default).

    Returns
    -------
    ndarray
        ``np.asarray(array)``.
    """
    try:
        arr = np.asarray(array)
    except Exception as exc:  # ragged lists and the like
        raise ValueError(f"{name} must be an array, got {type(array).__name__}: {exc}") from None
    if arr.dtype == object or arr.dtype.kind not in dtype_kinds:
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(str(a) for a in allowed)
            raise ValueError(f"{name} must have {want} dimensions, got shape {arr.shape}")
    if arr.size < min_size:
        raise ValueError(f"{name} must not be empty, got shape {arr.shape}")
    if finite:
        check_finite(name, arr)
    return arr


def check_shape_match(name, array, shape, other="the image"):
    """Raise ValueError unless ``array.shape[:len(shape)] == shape``."""
    shape = tuple(shape)
    if tuple(array.shape[: len(shape)]) != shape:
        raise ValueError(
            f"{name} must have the same height and width as {other} {shape}, "
            f"got shape {tuple(array.shape)}"
        )
    return array


def check_mask(name, mask, shape=None, *, allow_empty=False):
    """Return a boolean mask, checking shape and that it is not empty.

    Accepts booleans, or numbers where nonzero means "inside" (a painted float map
    is thresholded at 0.5).

    Parameters
    ----------
    name : str
        The parameter's name for messages.
    mask : array_like, shape (H, W)
        The mask.
    shape : tuple of int, optional
        The required (H, W).
    allow_empty : bool
        Whether an all-False mask is acceptable.

    Examples
    --------
    >>> check_mask("region", np.zeros((2, 2)))
    Traceback (most recent call last):
    ...
    ValueError: region is empty: paint at least one pixel
    """
    arr = check_array(name, mask, ndim=2)
    out = arr > 0.5 if arr.dtype.kind == "f" else arr.astype(bool)
    if shape is not None:
        check_shape_match(name, out, tuple(shape)[:2])
    if not allow_empty and not out.any():
        raise ValueError(f"{name} is empty: paint at least one pixel")
    return out


def check_vector_field(name, field, shape=None):
    """Check a vector field of shape (H, W, 2) in (dy, dx) order; return it as float.

    Parameters
    ----------
    name : str
        The parameter's name for messages.
    field : array_like, shape (H, W, 2)
        Components (dy, dx) in pixels per frame (see docs/conventions.md).
    shape : tuple of int, optional
        The required (H, W).
    """
    arr = check_array(name, field, ndim=3, dtype_kinds="iuf")
    if arr.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (H, W, 2) as (dy, dx), got {arr.shape}")
    if shape is not None:
        check_shape_match(name, arr, tuple(shape)[:2], "the field")
    return arr.astype(np.result_type(arr.dtype, np.float32), copy=False)


def check_npz_file(path, what):
    """Raise ValueError unless ``path`` is an existing ``.npz`` archive.

    numpy's own message for a file that is no archive speaks of pickled data, which
    sends the user the wrong way; this says what is wrong, after ``what`` (e.g.
    ``"--sim 'x.npz' is not a simulation"``).
    """
    kind = _file_kind(path)
    if kind == "missing":
        raise ValueError(f"{what}: no such file")
    if kind != "file":
        raise ValueError(f"{what}: it is {kind}, not a file")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"{what}: it is not an .npz archive")
    return path


# What stat says a path is, in words, for the files that are not regular files.
_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def _file_kind(path):
    """``"file"``, ``"missing"``, or what else ``path`` is ("a folder", "a named pipe (FIFO)")."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "missing"
    except OSError as exc:  # a loop of symlinks, a path through a file, no permission
        return f"unreachable ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return "file"
    return next((word for test, word in _KINDS if test(mode)), "not a regular file")


def check_input_file(path, name, what="file"):
    """Raise ValueError unless ``path`` is an existing regular file; return it.

    A folder, a named pipe, a socket or a device is named as what it is: "no such
    file" would send the user looking for a file that is there, and reading a FIFO
    would wait for a writer forever.

    Parameters
    ----------
    path : str or os.PathLike
    name : str
        How messages name the parameter (``"IMAGE"``, ``"strokes"``).
    what : str
        What the file should be, for messages (``"an image file"``).

    Examples
    --------
    >>> check_input_file("/", "IMAGE", "an image file")
    Traceback (most recent call last):
    ...
    ValueError: IMAGE: '/' is a folder, not an image file
    """
    kind = _file_kind(path)
    if kind == "missing":
        raise ValueError(f"{name}: no such file {os.fspath(path)!r}")
    if kind != "file":
        raise ValueError(f"{name}: {os.fspath(path)!r} is {kind}, not {what}")
    return path


def parse_json(text, what):
    """``json.loads(text)``, with every way of failing a ValueError that names ``what``.

    Beside invalid JSON this covers text nested so deeply that Python's parser runs out
    of recursion (``[[[[...]]]]`` 200,000 deep): a RecursionError otherwise, which no
    caller expects from a file.

    Examples
    --------
    >>> parse_json("[" * 100_000 + "]" * 100_000, "'s.json'")
    Traceback (most recent call last):
    ...
    ValueError: cannot read 's.json' as JSON (it is nested too deeply)
    """
    try:
        return json.loads(text)
    except RecursionError:
        detail = "it is nested too deeply"
    except (TypeError, ValueError) as exc:  # JSONDecodeError and UnicodeDecodeError too
        detail = str(exc)
    raise ValueError(f"cannot read {what} as JSON ({detail})")
