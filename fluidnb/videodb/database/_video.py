"""Fluid clips on their way into a database: read, scale down, fingerprint.

A database is built from *sources*: video files (MP4, WebM, MOV, AVI, MKV, GIF), folders
of frames, :class:`fluidnb.Clip` objects or ``(T, H, W[, 3])`` arrays, each optionally
paired with a name as ``(name, source)``. Each is read once into 8-bit RGB frames,
scaled down when its longer side exceeds ``max_side`` (the paper's videos are 640 x 360
or 480 x 360), and fingerprinted with SHA-256 so that a database records exactly what
went in and refuses the same clip twice.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from ..._clip import Clip
from ..._image import as_image, to_float01, to_uint8
from ..._validation import check_input_file, check_int, parse_json

__all__ = ["VIDEO_EXTENSIONS", "Video", "read_video"]

#: Files read through ffmpeg (imageio-ffmpeg ships its own binary); GIFs go through Pillow.
VIDEO_EXTENSIONS = (".mp4", ".webm", ".mov", ".avi", ".mkv", ".m4v")
_IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
_DEFAULT_FPS = 24.0


@dataclass(frozen=True, eq=False)
class Video:
    """A source clip as a database stores it.

    Attributes
    ----------
    frames : ndarray, shape (T, H, W, 3), uint8
        RGB frames (grey sources are repeated into three channels).
    fps : float
        Frames per second (informational: the method works frame by frame).
    name : str
        A short label (the file name, or the name given with the source).
    origin : str
        Where it came from: a path, or ``"array"`` / ``"clip"``.
    sha256 : str
        ``"sha256:<hex>"`` of the file's bytes, or of the frames for in-memory sources.
    scaled : float
        The factor the frames were scaled by on the way in (1.0: unchanged).
    """

    frames: np.ndarray
    fps: float
    name: str
    origin: str
    sha256: str
    scaled: float = 1.0

    @property
    def shape(self):
        """(T, H, W) of the frames."""
        return self.frames.shape[:3]

    def __repr__(self):
        t, h, w = self.shape
        return f"Video({self.name!r}, {t} frames, {h}x{w}, {self.fps:g} fps)"


def read_video(source, *, max_side=640, name=None):
    """Read a fluid clip from a file, a folder of frames, a Clip or an array.

    Parameters
    ----------
    source : str, os.PathLike, fluidnb.Clip, ndarray or (name, source)
        A video file (one of :data:`VIDEO_EXTENSIONS`, or ``.gif``), a folder of
        image frames (read in natural order of their names), a :class:`fluidnb.Clip`,
        or frames ``(T, H, W)`` / ``(T, H, W, 3)`` (uint8, uint16 or floats in [0, 1]).
        A ``(name, source)`` pair names the clip.
    max_side : int
        Frames whose longer side exceeds this are scaled down (area averaging).
    name : str, optional
        The clip's label; default the file or folder name, or ``"clip"``.

    Returns
    -------
    Video

    Raises
    ------
    ValueError
        For a missing or unreadable file, an unknown extension, an empty folder,
        frames of differing sizes, or an array of the wrong shape or values.

    Examples
    --------
    >>> v = read_video(np.zeros((3, 20, 30), np.uint8), name="still")
    >>> v.frames.shape, v.name, v.sha256[:7]
    ((3, 20, 30, 3), 'still', 'sha256:')
    """
    max_side = check_int("max_side", max_side, 1)
    if isinstance(source, tuple) and len(source) == 2 and isinstance(source[0], str):
        name, source = source if name is None else (name, source[1])
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        frames, fps, scaled, digest = _read_path(path, max_side)
        origin, default_name = str(path), path.stem or path.name
    elif isinstance(source, Clip):
        frames, fps, scaled = _clip_uint8(source.frames), source.fps, 1.0
        digest, origin, default_name = None, "clip", "clip"
    elif isinstance(source, (np.ndarray, list)):
        frames, fps, scaled = _array_frames(source), _DEFAULT_FPS, 1.0
        digest, origin, default_name = None, "array", "clip"
    else:
        raise ValueError(
            "source must be a video file, a folder of frames, a fluidnb.Clip, a (T, H, W[, 3]) "
            f"array or a (name, source) pair, got {type(source).__name__}"
        )
    if frames.ndim == 3:
        frames = np.repeat(frames[..., None], 3, axis=3)
    if digest is None:
        digest = _digest_frames(frames)
    frames, scale = _limit_size(frames, max_side)
    scale *= scaled
    return Video(
        frames=np.ascontiguousarray(frames),
        fps=float(fps),
        name=str(name if name is not None else default_name),
        origin=origin,
        sha256=digest,
        scaled=scale,
    )


def _clip_uint8(frames):
    """:func:`fluidnb.to_uint8` of a clip's float32 frames, bit for bit, in one pass.

    A starter build converts every clip it makes on the thread that stores them
    (11 million values a water clip): numpy's clip, scale, offset and cast are four
    passes with their temporaries (~27 ms a clip), the kernel one (~2 ms).
    """
    arr = np.ascontiguousarray(frames, dtype=np.float32)
    out = np.empty(arr.shape, np.uint8)
    _to_uint8(arr.reshape(-1), out.reshape(-1))
    return out


@njit(cache=True, nogil=True)
def _to_uint8(x, out):
    """``out = (np.clip(x, 0, 1) * 255 + 0.5).astype(np.uint8)``, the same float32 steps."""
    zero, one = np.float32(0.0), np.float32(1.0)
    for i in range(x.shape[0]):
        v = min(max(x[i], zero), one)  # np.clip for every value but NaN (never in a clip)
        out[i] = np.uint8(v * np.float32(255.0) + np.float32(0.5))  # truncates, as astype


def _array_frames(source):
    try:
        arr = np.asarray(source)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"source is not a rectangular array: {exc}") from None
    if arr.ndim == 4 and arr.shape[3] == 4:
        arr = arr[..., :3]
    if arr.ndim not in (3, 4) or (arr.ndim == 4 and arr.shape[3] != 3):
        raise ValueError(
            f"source frames must have shape (T, H, W) or (T, H, W, 3), got {arr.shape}"
        )
    if 0 in arr.shape:
        raise ValueError(f"source frames are empty: got shape {arr.shape}")
    if arr.dtype == np.uint8:
        return arr
    return to_uint8(to_float01(arr, name="source"))


def _digest_frames(frames):
    h = hashlib.sha256()
    h.update(repr(frames.shape).encode())
    h.update(np.ascontiguousarray(frames).data)
    return "sha256:" + h.hexdigest()


def _digest_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()


def _read_path(path, max_side):
    if path.is_dir():
        frames, fps, digest = _read_folder(path)
        return frames, fps, 1.0, digest
    if not path.exists() and not path.is_symlink():
        raise ValueError(f"source: no such file or folder {str(path)!r}")
    # A named pipe, a socket, a device: said as what it is (reading a FIFO would wait).
    check_input_file(path, "source", "a video file or a folder of frames")
    suffix = path.suffix.lower()
    if suffix == ".gif":
        clip = Clip.load(path)
        return to_uint8(clip.frames), clip.fps, 1.0, _digest_file(path)
    if suffix in VIDEO_EXTENSIONS:
        return (*_read_ffmpeg(path, max_side), _digest_file(path))
    allowed = ", ".join((*VIDEO_EXTENSIONS, ".gif"))
    raise ValueError(
        f"source {str(path)!r}: unknown video extension {suffix!r}; use {allowed}, "
        "or a folder of image frames"
    )


def _read_ffmpeg(path, max_side):
    """Decode a video with ffmpeg into uint8 RGB, scaled down on the way if it is big.

    Through :func:`fluidnb._media.read_video` (imageio-ffmpeg's reader, as
    :meth:`fluidnb.Clip.load` reads MP4): a large video is scaled by ffmpeg (area
    averaging) before it ever fills memory at full size.
    """
    from ... import _media

    frames, fps, scale = _media.read_video(
        path, max_side=max_side, what=f"source {str(path)!r}: cannot read it as a video"
    )
    return frames.copy(), fps if fps > 0 else _DEFAULT_FPS, scale


def _natural_key(name):
    import re

    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def _read_folder(folder):
    files = sorted(
        (p for p in folder.iterdir() if p.suffix.lower() in _IMAGE_EXTENSIONS),
        key=lambda p: _natural_key(p.name),
    )
    if not files:
        raise ValueError(f"source {str(folder)!r}: the folder holds no image frames")
    frames = []
    h = hashlib.sha256()
    for p in files:
        frames.append(to_uint8(as_image(p, name="source")))  # grey or RGB; alpha dropped
        h.update(p.name.encode())
        h.update(p.read_bytes())
    shapes = {f.shape for f in frames}
    if len(shapes) > 1:
        raise ValueError(f"source {str(folder)!r}: the frames do not all have the same size")
    if any(f.ndim == 3 for f in frames):
        frames = [np.repeat(f[..., None], 3, axis=2) if f.ndim == 2 else f for f in frames]
    fps = _DEFAULT_FPS
    clip_json = folder / "clip.json"
    if clip_json.is_file():
        # Informational (the method works frame by frame): a damaged one is ignored.
        with contextlib.suppress(OSError, ValueError, TypeError, AttributeError):
            fps = float(parse_json(clip_json.read_text(), "clip.json").get("fps", fps))
    return np.stack(frames), fps, "sha256:" + h.hexdigest()


def _limit_size(frames, max_side):
    h, w = frames.shape[1:3]
    if max(h, w) <= max_side:
        return frames, 1.0
    import cv2

    scale = max_side / max(h, w)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    # Area averaging: the anti-aliased reduction for uint8 frames, one call a frame.
    out = np.stack([cv2.resize(f, size, interpolation=cv2.INTER_AREA) for f in frames])
    return out, scale
