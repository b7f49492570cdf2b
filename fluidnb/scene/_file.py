"""A scene on disk: one folder, ``scene.json`` beside the photo and each layer's masks.

Format (``fluidnb.scene``, version 1)::

    folder/
        scene.json      {"format": "fluidnb.scene", "version": 1, "fps": 24.0,
                         "duration": null, "size": [H, W], "photo": "photo.png",
                         "layers": [{"name", "kind", "region": "water.region.png",
                                     "params": {...} or null, "strokes": [...],
                                     "speed": "water.speed.png" or null,
                                     "speed_max": 5.0, "starts": [...] or null,
                                     "exemplar": "fire", "visible": true,
                                     "seed": 0}, ...]}
        photo.png       the photo at the scene's size (8-bit RGB)
        <layer>.region.png   its region, 8-bit grey (a soft matte keeps its edge)
        <layer>.speed.png    its painted speed, 16-bit grey scaled by speed_max

A newer fluidnb reads every older version; a file from a newer one, or a bad field,
is refused with one line naming the layer and the field.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
from PIL import Image

from .._media import write_atomically
from .._validation import parse_json
from ._layer import KINDS, Layer
from ._methods import default_params

__all__ = ["SCENE_VERSION", "load_scene", "save_scene"]

_FORMAT = "fluidnb.scene"
#: The version :func:`save_scene` writes (and the newest :func:`load_scene` reads).
SCENE_VERSION = 1


def _file_name(name):
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "layer"


def _write_png(path, array):
    write_atomically(path, lambda tmp: Image.fromarray(array).save(tmp, format="PNG"))


def save_scene(scene, folder):
    """Write ``scene`` to ``folder`` (made if missing); returns the folder's path.

    Examples
    --------
    >>> import tempfile
    >>> from fluidnb.data import sample
    >>> from fluidnb.scene import Layer, Scene, load_scene
    >>> photo = sample("lake", size=48)
    >>> region = np.zeros(photo.shape[:2], bool)
    >>> region[20:, :] = True
    >>> folder = save_scene(Scene(photo, [Layer("flicker", region)], size=None), tempfile.mkdtemp())
    >>> load_scene(folder)
    Scene(48x27, 24 fps: flicker (flicker))
    """
    folder = Path(os.fspath(folder))
    folder.mkdir(parents=True, exist_ok=True)
    _write_png(folder / "photo.png", np.round(np.clip(scene.photo, 0, 1) * 255).astype(np.uint8))
    layers, used = [], set()
    for layer in scene.layers:
        stem = _file_name(layer.name)
        while stem in used:
            stem += "_"
        used.add(stem)
        entry = {
            "name": layer.name,
            "kind": layer.kind,
            "region": f"{stem}.region.png",
            "params": None if layer.params is None else layer.params.to_dict(),
            "strokes": [s.tolist() for s in layer.strokes],
            "speed": None,
            "starts": None if layer.starts is None else layer.starts.tolist(),
            "exemplar": layer.exemplar,
            "visible": layer.visible,
            "seed": layer.seed,
        }
        region = np.round(np.clip(layer.region, 0, 1) * 255).astype(np.uint8)
        _write_png(folder / entry["region"], region)
        if layer.speed is not None:
            top = float(layer.speed.max()) or 1.0
            entry["speed"], entry["speed_max"] = f"{stem}.speed.png", top
            speed = np.round(layer.speed / top * 65535).astype(np.uint16)
            _write_png(folder / entry["speed"], speed)
        layers.append(entry)
    data = {
        "format": _FORMAT,
        "version": SCENE_VERSION,
        "fps": scene.fps,
        "duration": scene.duration,
        "size": list(scene.shape),
        "photo": "photo.png",
        "layers": layers,
    }
    text = json.dumps(data, indent=1) + "\n"
    write_atomically(folder / "scene.json", lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return folder


def load_scene(folder):
    """Read a scene :func:`save_scene` wrote; ValueError naming the layer and field."""
    from ._scene import Scene

    folder = Path(os.fspath(folder))
    path = folder / "scene.json"
    if not path.is_file():
        raise ValueError(f"scene folder {str(folder)!r} has no scene.json")
    data = parse_json(path.read_text(encoding="utf-8"), f"scene file {str(path)!r}")
    if not isinstance(data, dict) or data.get("format") != _FORMAT:
        raise ValueError(f"{str(path)!r} is not a fluidnb scene (format {_FORMAT!r})")
    version = data.get("version")
    if not isinstance(version, int) or not 1 <= version <= SCENE_VERSION:
        raise ValueError(
            f"{str(path)!r} has scene version {version!r}; this fluidnb reads 1 to "
            f"{SCENE_VERSION} (a newer fluidnb wrote it?)"
        )
    photo = _read_png(folder, data.get("photo"), "photo", "the scene")
    if photo.ndim != 3:
        raise ValueError(f"{str(path)!r}: the photo must be an RGB image")
    try:
        scene = Scene(
            photo / 255.0, size=None, fps=data.get("fps", 24.0), duration=data.get("duration")
        )
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: {exc}") from None
    entries = data.get("layers")
    if not isinstance(entries, list):
        raise ValueError(f"{str(path)!r}: layers must be a list")
    for i, entry in enumerate(entries):
        scene.add(_layer(folder, path, i, entry, scene.shape))
    return scene


def _layer(folder, path, i, entry, shape):
    if not isinstance(entry, dict):
        raise ValueError(f"{str(path)!r}: layer {i} must be an object")
    name = entry.get("name", f"layer {i}")
    where = f"{str(path)!r}, layer {name!r}"
    kind = entry.get("kind")
    if kind not in KINDS:
        raise ValueError(f"{where}: kind must be one of {sorted(KINDS)}, got {kind!r}")
    region = _read_png(folder, entry.get("region"), "region", where)
    if region.ndim != 2 or region.shape != shape:
        raise ValueError(f"{where}: region must be a grey image of the photo's size {shape}")
    fields = {"kind": kind, "name": str(name), "region": region / 255.0}
    params = entry.get("params")
    try:
        if params is not None:
            fields["params"] = type(default_params(kind)).from_dict(params)
        if entry.get("speed") is not None:
            speed = _read_png(folder, entry["speed"], "speed", where).astype(np.float32)
            fields["speed"] = speed / 65535 * float(entry.get("speed_max", 1.0))
        fields["strokes"] = tuple(np.asarray(s, np.float64) for s in entry.get("strokes") or ())
        if entry.get("starts") is not None:
            fields["starts"] = np.asarray(entry["starts"], np.float64)
        for key in ("exemplar", "visible", "seed"):
            if key in entry:
                fields[key] = entry[key]
        return Layer(**fields)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def _read_png(folder, name, field, where):
    if not isinstance(name, str) or Path(name).name != name:
        raise ValueError(f"{where}: {field} must be a file name in the scene folder, got {name!r}")
    try:
        with Image.open(folder / name) as im:
            return np.asarray(im)
    except FileNotFoundError:
        raise ValueError(f"{where}: {field} file {name!r} is missing from the folder") from None
    except OSError as exc:
        raise ValueError(f"{where}: {field} file {name!r} cannot be read: {exc}") from None
