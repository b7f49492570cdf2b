"""Sample images: licensed photographs shipped with the package, and procedural ones.

The photographs and their sources, authors, licences and modifications are listed in
``sources.json`` (read here) and ``SOURCES.md`` beside this file.
"""

from __future__ import annotations

import copy
import functools
import json
import numbers
from pathlib import Path

import numpy as np

from .._image import as_image
from .._validation import check_int
from ._procedural import PROCEDURAL

__all__ = ["catalogue", "data_dir", "names", "path", "region", "sample"]

_DIR = Path(__file__).resolve().parent
_SOURCES = "sources.json"
_MAX_SIDE = 4096  # a guard against typing an extra zero, not a limit of the code

#: The fluid in a sample photograph, drawn by hand: (x, y) polygon vertices on the
#: photograph at its own size, and the Gaussian sigma of the edge in its pixels. What a
#: user would paint with the app's matte brush.
_REGIONS = {
    # The stream's water: the cascades down the middle and the pool at the bottom.
    "stream": ([
        (250, 45), (345, 40), (355, 95), (300, 100), (270, 110), (255, 160), (250, 200),
        (240, 240), (245, 262), (300, 290), (330, 330), (300, 360), (285, 376), (15, 376),
        (20, 340), (60, 328), (120, 300), (60, 282), (45, 250), (70, 230), (110, 215),
        (100, 192), (140, 180), (170, 160), (185, 130), (180, 100), (200, 80), (230, 60),
    ], 2.0),
    # The cloud between the two peaks, wisps included (a smoke matte is soft).
    "clouds": ([
        (48, 108), (54, 78), (78, 54), (108, 42), (140, 40), (162, 56), (174, 84),
        (198, 92), (214, 118), (238, 134), (262, 126), (300, 138), (326, 114), (358, 114),
        (374, 134), (352, 158), (332, 172), (318, 196), (290, 215), (262, 232), (240, 237),
        (215, 229), (185, 213), (150, 199), (120, 190), (96, 170), (72, 146), (56, 128),
    ], 4.0),
}  # fmt: skip


def data_dir():
    """Return the folder holding the sample photographs and their licence records.

    Returns
    -------
    pathlib.Path
        An absolute path; ``SOURCES.md`` and ``sources.json`` are inside.

    Examples
    --------
    >>> (data_dir() / "sources.json").is_file()
    True
    """
    return _DIR


@functools.lru_cache(maxsize=1)
def _photos():
    with open(_DIR / _SOURCES, encoding="utf-8") as f:
        records = json.load(f)["photos"]
    return {r["name"]: r for r in records}


@functools.lru_cache(maxsize=1)
def _entries():
    entries = []
    for name, rec in _photos().items():
        shape = tuple(rec["shape"])
        entries.append(
            {
                "name": name,
                "kind": "photo",
                "description": rec["description"],
                "methods": list(rec["methods"]),
                "shape": shape if shape[-1] == 3 else shape[:2],
                "has_alpha": bool(rec["has_alpha"]),
                "file": rec["file"],
                "source": rec["source"],
                "author": rec["author"],
                "licence": rec["licence"],
                "licence_url": rec["licence_url"],
                "modifications": rec["modifications"],
            }
        )
    for name, spec in PROCEDURAL.items():
        shape = tuple(spec["shape"]) + ((3,) if spec["channels"] == 3 else ())
        entries.append(
            {
                "name": name,
                "kind": "procedural",
                "description": spec["description"],
                "methods": list(spec["methods"]),
                "shape": shape,
                "has_alpha": spec["has_alpha"],
                "file": None,
                "source": f"computed by fluidnb.data._procedural.{spec['generator'].__name__}",
                "author": "the fluidnb authors",
                "licence": "MIT (same as fluidnb)",
                "licence_url": None,
                "modifications": None,
            }
        )
    return tuple(entries)


def names():
    """Return the names of every sample: photographs first, then procedural ones.

    Returns
    -------
    list of str

    Examples
    --------
    >>> "checker" in names() and "fire" in names()
    True
    """
    return [e["name"] for e in _entries()]


def catalogue():
    """Describe every sample: what it is, what it suits, where it came from.

    Returns
    -------
    list of dict
        One dict per sample (a fresh copy each call), with keys ``name``; ``kind``
        (``"photo"`` or ``"procedural"``); ``description``; ``methods`` (the methods
        it suits: ``"flicker"``, ``"frost"``, ``"fire"``, ``"turbulence"``,
        ``"videodb"``, or ``"any"``); ``shape`` (of ``sample(name)`` at its default
        size); ``has_alpha``; ``file`` (photos only, else ``None``); ``source`` (Debian
        package and path, upstream URL); ``author``; ``licence`` (an SPDX-style
        identifier); ``licence_url``; ``modifications`` (what was done to a photo).

    Examples
    --------
    >>> entry = next(e for e in catalogue() if e["name"] == "stream")
    >>> entry["kind"], entry["licence"], entry["author"]
    ('photo', 'CC-BY-4.0', 'Aitzol Berasategi')
    """
    return copy.deepcopy(list(_entries()))


def _check_name(name):
    available = names()
    if not isinstance(name, str) or name not in available:
        raise ValueError(f"unknown sample {name!r}; available samples: {', '.join(available)}")
    return name


def path(name):
    """Return the file of a sample photograph.

    Parameters
    ----------
    name : str
        One of the photographs in :func:`names` (``kind == "photo"`` in
        :func:`catalogue`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ValueError
        For an unknown name, or a procedural sample (which has no file).

    Examples
    --------
    >>> path("stream").name
    'stream.jpg'
    """
    _check_name(name)
    photos = _photos()
    if name not in photos:
        raise ValueError(
            f"sample {name!r} is procedural and has no file; photographs: {', '.join(photos)}"
        )
    return _DIR / photos[name]["file"]


def _target_shape(size, default):
    """(H, W) from ``size``: None (default), an int (longest side) or (H, W)."""
    if size is None:
        return tuple(default)
    if isinstance(size, (numbers.Integral, float)):
        side = check_int("size", size, 1, _MAX_SIDE)
        h, w = default
        scale = side / max(h, w)
        return max(1, round(h * scale)), max(1, round(w * scale))
    if isinstance(size, (tuple, list, np.ndarray)) and len(size) == 2:
        return (
            check_int("size[0] (height)", size[0], 1, _MAX_SIDE),
            check_int("size[1] (width)", size[1], 1, _MAX_SIDE),
        )
    raise ValueError(
        f"size must be None, an int (the longest side) or a (height, width) pair, got {size!r}"
    )


def _resize(arr, shape):
    if arr.shape[:2] == tuple(shape):
        return arr
    from skimage.transform import resize  # slow to import: only when resizing

    shrinking = shape[0] < arr.shape[0] or shape[1] < arr.shape[1]
    out = resize(
        arr,
        tuple(shape) + arr.shape[2:],
        order=1,
        mode="edge",
        anti_aliasing=shrinking,
        preserve_range=True,
    )
    return np.clip(out, 0.0, 1.0)


def sample(name, *, size=None, mode=None, return_alpha=False):
    """Load a sample image as float32 in [0, 1].

    Parameters
    ----------
    name : str
        A name from :func:`names`: a photograph (``"fire"``, ``"stream"``, ...) or a
        procedural image (``"checker"``, ``"ripples"``, ``"flame"``, ...); see
        :func:`catalogue` for what each is and suits.
    size : int or (int, int), optional
        ``None`` for the sample's own size (see ``catalogue()[i]["shape"]``); an int
        for the longest side, keeping the aspect ratio; or ``(H, W)``. Photographs
        are resized (bilinear, anti-aliased when shrinking); procedural samples are
        computed at that size, the picture scaling with the longest side.
    mode : {None, "grey", "rgb"}
        As in :func:`fluidnb.as_image`: ``None`` keeps the sample's channels.
    return_alpha : bool
        Also return the alpha matte, float32 (H, W), or ``None`` for samples without
        one (``catalogue()[i]["has_alpha"]``: ``"fire"``, ``"flame"``, ``"smoke"``).

    Returns
    -------
    image : ndarray, shape (H, W) or (H, W, 3), float32
        A new array each call.
    alpha : ndarray, shape (H, W), float32, or None
        Only with ``return_alpha=True``.

    Raises
    ------
    ValueError
        For an unknown name (the message lists the available ones), or a bad
        ``size`` or ``mode``.

    Examples
    --------
    >>> sample("checker", size=(8, 8)).shape
    (8, 8)
    >>> sample("gradient").dtype
    dtype('float32')
    >>> image, alpha = sample("flame", size=64, return_alpha=True)
    >>> image.shape, alpha.shape
    ((64, 48, 3), (64, 48))
    """
    _check_name(name)
    if name in _photos():
        image, alpha = as_image(path(name), name=name, return_alpha=True)
        shape = _target_shape(size, image.shape[:2])
        image = _resize(image, shape)
        alpha = None if alpha is None else _resize(alpha, shape)
    else:
        spec = PROCEDURAL[name]
        shape = _target_shape(size, spec["shape"])
        image, alpha = spec["generator"](shape)
    image = as_image(image, mode=mode, name=name)
    if not return_alpha:
        return image
    return image, None if alpha is None else as_image(alpha, name=f"{name} alpha")


def region(name, *, size=None):
    """The fluid's region in a sample photograph, drawn by hand, as a soft matte.

    A ready-made matte for the methods that animate part of a photo (the video
    database's alpha, flicker's region): what a user would paint over the water.

    Parameters
    ----------
    name : str
        A photograph with a drawn region: ``"stream"`` (the water) or ``"clouds"`` (the
        cloud). (The ``"fire"`` photograph has its own alpha: ``sample(...,
        return_alpha=True)``.)
    size : int or (int, int), optional
        As in :func:`sample`; the region matches ``sample(name, size=size)``.

    Returns
    -------
    ndarray, shape (H, W), float32
        1 inside the fluid, 0 outside, with a Gaussian edge (2 pixels for the water, 4
        for the cloud, at the photograph's own size, scaled with it).

    Raises
    ------
    ValueError
        For a name without a drawn region (the message lists those with one), or a bad
        ``size``.

    Examples
    --------
    >>> matte = region("stream", size=240)
    >>> matte.shape == sample("stream", size=240).shape[:2], matte.dtype
    (True, dtype('float32'))
    """
    from scipy import ndimage as ndi
    from skimage.draw import polygon2mask

    _check_name(name)
    if name not in _REGIONS:
        raise ValueError(
            f"sample {name!r} has no drawn region; samples with one: {', '.join(_REGIONS)}"
        )
    own = tuple(_photos()[name]["shape"][:2])
    h, w = _target_shape(size, own)
    scale = np.array([h / own[0], w / own[1]])
    polygon, softness = _REGIONS[name]
    rows_cols = np.array(polygon, float)[:, ::-1] * scale  # (x, y) -> (row, col)
    inside = polygon2mask((h, w), rows_cols).astype(np.float32)
    matte = ndi.gaussian_filter(inside, softness * scale)
    return np.clip(matte, 0.0, 1.0).astype(np.float32)
