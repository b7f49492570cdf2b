"""Flow strokes on disk: a small JSON file the app saves and the command line reads.

Format (``fluidnb.strokes``, version 1)::

    {
        "format": "fluidnb.strokes",
        "version": 1,
        "shape": [H, W],
        "strokes": [[[row, col], [row, col], ...], ...],
    }

Coordinates are (row, col) pixels of the image (docs/conventions.md), each stroke
drawn along the flow; ``shape`` is the image's size, so strokes drawn on one image
are not silently applied to another of a different size.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from .._media import write_atomically
from .._validation import check_input_file, check_int, parse_json
from ._direction import check_strokes

__all__ = ["load_strokes", "save_strokes"]

_FORMAT = "fluidnb.strokes"
_VERSION = 1


def save_strokes(path, strokes, shape):
    """Write strokes and the image size they belong to as JSON; returns the path.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.json`` file.
    strokes : sequence of array_like, each shape (n_i, 2)
        Polylines in (row, col) pixels.
    shape : tuple of int
        The image's (H, W).

    Raises
    ------
    ValueError
        For no stroke at all, a stroke that is not (n, 2), or a point far outside the
        image (:func:`check_strokes`): nothing is written then.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "s.json")
    >>> _ = save_strokes(p, [[[10, 2], [10, 30]]], (20, 32))
    >>> strokes, shape = load_strokes(p)
    >>> strokes[0].tolist(), shape
    ([[10.0, 2.0], [10.0, 30.0]], (20, 32))
    """
    h = check_int("shape[0]", shape[0], 1)
    w = check_int("shape[1]", shape[1], 1)
    out = [[[float(r), float(c)] for r, c in s] for s in check_strokes(strokes, (h, w))]
    data = {"format": _FORMAT, "version": _VERSION, "shape": [h, w], "strokes": out}
    path = Path(os.fspath(path))
    text = json.dumps(data, indent=1) + "\n"
    # Through a temporary file and a rename: a full disk keeps the strokes saved before.
    write_atomically(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return path


def load_strokes(path, shape=None):
    """Read strokes written by :func:`save_strokes` (or the app).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.json`` file.
    shape : tuple of int, optional
        The image's (H, W); if given, it must match the size the strokes were drawn on.

    Returns
    -------
    strokes : list of ndarray, each shape (n_i, 2), float64
    shape : tuple of int
        The (H, W) the strokes belong to.

    Raises
    ------
    ValueError
        For a missing or unreadable file, another format, a size mismatch, no stroke
        at all, or a point far outside the image (:func:`check_strokes`).
    """
    path = Path(os.fspath(path))
    check_input_file(path, "strokes", "a strokes file (.json)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"strokes: cannot read {str(path)!r} as JSON ({exc})") from None
    try:
        data = parse_json(text, repr(str(path)))
    except ValueError as exc:
        raise ValueError(f"strokes: {exc}") from None
    if not isinstance(data, dict) or data.get("format") != _FORMAT:
        raise ValueError(f"strokes: {str(path)!r} is not a fluidnb strokes file")
    if data.get("version") != _VERSION:
        raise ValueError(
            f"strokes: {str(path)!r} has version {data.get('version')!r}; this fluidnb reads "
            f"version {_VERSION}"
        )
    try:
        size = (int(data["shape"][0]), int(data["shape"][1]))
        strokes = data["strokes"]
        if not isinstance(strokes, list):
            raise TypeError(f"'strokes' is a {type(strokes).__name__}, not a list")
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        raise ValueError(f"strokes: {str(path)!r} is damaged ({exc})") from None
    if shape is not None and tuple(shape)[:2] != size:
        raise ValueError(
            f"strokes in {str(path)!r} were drawn on a {size[0]} x {size[1]} image; this "
            f"image is {shape[0]} x {shape[1]}"
        )
    try:
        strokes = check_strokes(strokes, size)
    except ValueError as exc:
        raise ValueError(f"strokes file {str(path)!r}: {exc}") from None
    return strokes, size
