"""The :class:`Clip`: the frames every method returns, with their fps and metadata.

A clip is ``(T, H, W)`` or ``(T, H, W, 3)`` ``float32`` in [0, 1] (see
docs/conventions.md). It is an immutable value: the frames are a read-only array, so a
clip can be shared, sliced and displayed without copies, and its inline rendering in
Jupyter can be computed once and cached.

Files: ``.npz`` (exact, keeps metadata), ``.gif``, ``.mp4`` and a folder of PNG frames
plus ``clip.json``. GIF and MP4 files also carry the fps and metadata in a comment, so
:meth:`Clip.load` gets them back exactly from files this module wrote.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import json
import math
import numbers
import os
import re
import subprocess
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from ._image import _read, _to_float01, to_uint8
from ._validation import check_int, check_range

__all__ = ["Clip", "load_clip"]

#: Frames per second when nothing says otherwise (the papers' preview rate).
DEFAULT_FPS = 8.0

_FILE_EXTENSIONS = (".gif", ".mp4", ".npz")
_ALLOWED = "'.gif', '.mp4', '.npz', or a folder (no extension) for a PNG sequence"

# The key that marks the JSON we embed in GIF/MP4 comments and clip.json, so that a
# foreign file's unrelated comment is never mistaken for ours.
_TAG = "fluidnb.Clip"

# Inline display: the longest side is brought into [_DISPLAY_MIN, _DISPLAY_MAX] px. Larger
# clips are averaged down (a notebook cell cannot show more and the base64 payload grows
# with the area); tiny simulation grids are enlarged (nearest) so they are visible.
_DISPLAY_MAX = 480
_DISPLAY_MIN = 128

# MP4 quality on imageio's 1-10 scale (10 best); 7 maps to x264 CRF 15, visually
# lossless for smooth fluid frames at a modest size.
_DEFAULT_QUALITY = 7

_PNG_NAME = re.compile(r"^frame_(\d+)\.png$")


class Clip:
    """An animation: frames in [0, 1], a frame rate and JSON metadata.

    Every method in fluidnb returns a ``Clip``. It is immutable: the frames are stored
    as a read-only ``float32`` copy, and :meth:`with_metadata` or slicing return new
    clips. In Jupyter a clip displays itself as a looping video.

    Parameters
    ----------
    frames : array_like, shape (T, H, W), (T, H, W, 1), (T, H, W, 3) or (T, H, W, 4)
        The frames: ``uint8`` (0-255), ``uint16`` (0-65535), ``bool``, or floats in
        [0, 1]. A channel axis of length 1 is squeezed to grey; an alpha channel is
        dropped. The array is copied, never modified or kept.
    fps : float
        Frames per second, > 0.
    metadata : dict, optional
        JSON-serialisable information about how the clip was made. By convention
        ``method`` (str), ``params`` (dict), ``seed`` and ``timings`` (dict of stage to
        seconds). NumPy scalars and arrays, tuples and paths are converted to plain
        Python values.

    Raises
    ------
    ValueError
        For frames of the wrong shape, dtype or range (or containing NaN), a
        non-positive or non-finite ``fps``, or metadata that is not JSON-serialisable.

    See Also
    --------
    Clip.load : Read a clip saved with :meth:`Clip.save`.

    Examples
    --------
    >>> frames = np.zeros((16, 32, 48, 3), dtype=np.uint8)
    >>> clip = Clip(frames, fps=12, metadata={"method": "flicker", "seed": 0})
    >>> clip
    Clip(16 frames, 48x32 RGB, 12 fps, method='flicker')
    >>> clip.n_frames, clip.shape, clip.duration
    (16, (32, 48), 1.3333333333333333)
    """

    __slots__ = ("_fps", "_frames", "_html", "_metadata")

    def __init__(self, frames, fps=DEFAULT_FPS, metadata=None):
        self._fps = check_range("fps", fps, 0, lo_open=True)
        self._metadata = _as_metadata(metadata)
        self._frames = _as_frames(frames)
        self._html = None

    @classmethod
    def _trusted(cls, frames, fps, metadata):
        """Build a clip from already-validated parts without copying (internal)."""
        clip = cls.__new__(cls)
        if frames.flags.writeable:  # only ever a fresh array owned by this module
            frames.setflags(write=False)
            frames = frames.view()  # see _as_frames: a view cannot be unfrozen
        clip._frames = frames
        clip._fps = fps
        clip._metadata = metadata
        clip._html = None
        return clip

    def __reduce__(self):
        # Through the constructor, so an unpickled clip (e.g. from a worker process) is
        # read-only again; the cached HTML is not worth shipping.
        return (Clip, (self._frames, self._fps, self._metadata))

    # ------------------------------------------------------------------ properties

    @property
    def frames(self):
        """The frames, a read-only float32 array of shape (T, H, W) or (T, H, W, 3).

        Copy it (``clip.frames.copy()``) to get an array you can modify.
        """
        return self._frames

    @property
    def fps(self):
        """Frames per second, a float."""
        return self._fps

    @property
    def metadata(self):
        """A copy of the metadata dict (changing it does not change the clip).

        Use :meth:`with_metadata` for a clip with different metadata.
        """
        return json.loads(json.dumps(self._metadata))

    @property
    def n_frames(self):
        """The number of frames ``T``."""
        return int(self._frames.shape[0])

    @property
    def shape(self):
        """The frame size ``(H, W)`` in pixels, a tuple of int."""
        return (int(self._frames.shape[1]), int(self._frames.shape[2]))

    @property
    def is_color(self):
        """Whether the frames are RGB ``(T, H, W, 3)`` rather than grey ``(T, H, W)``."""
        return self._frames.ndim == 4

    @property
    def duration(self):
        """The playing time in seconds, ``n_frames / fps``."""
        return self.n_frames / self._fps

    # ------------------------------------------------------------------ sequence

    def __len__(self):
        return self.n_frames

    def __getitem__(self, index):
        """Return frame ``index`` (an int) or a sub-clip (a slice or index array).

        Sub-clips keep the fps and metadata.
        """
        if isinstance(index, (numbers.Integral, np.integer)) and not isinstance(index, bool):
            return self._frames[int(index)]
        if isinstance(index, slice):
            sub = self._frames[index]
        else:
            idx = np.asarray(index)
            if idx.ndim != 1 or idx.dtype.kind not in "biu":
                raise TypeError(
                    "Clip indices must be an int, a slice or a 1-D array of ints or "
                    f"bools, got {index!r}"
                )
            sub = self._frames[idx]
        if sub.shape[0] == 0:
            raise IndexError(f"index {index!r} selects no frames from a {len(self)}-frame clip")
        # A step slice or fancy index is not contiguous; a plain slice is a read-only
        # view of this clip's frames, which is safe to share.
        return Clip._trusted(np.ascontiguousarray(sub), self._fps, self._metadata)

    def __iter__(self):
        return iter(self._frames)

    def __repr__(self):
        t = self.n_frames
        h, w = self.shape
        parts = [
            f"{t} frame{'s' if t != 1 else ''}",
            f"{w}x{h} {'RGB' if self.is_color else 'grey'}",
            f"{self._fps:g} fps",
        ]
        if "method" in self._metadata:
            parts.append(f"method={self._metadata['method']!r}")
        return f"Clip({', '.join(parts)})"

    # ------------------------------------------------------------------ conversions

    def to_uint8(self):
        """Return the frames as a new ``uint8`` array (rounded, not truncated).

        Returns
        -------
        ndarray, shape (T, H, W) or (T, H, W, 3), uint8

        Examples
        --------
        >>> Clip(np.full((2, 1, 1), 0.5)).to_uint8().ravel().tolist()
        [128, 128]
        """
        return to_uint8(self._frames)

    def with_metadata(self, **changes):
        """Return a clip with the same frames and some metadata keys set or replaced.

        The frames are shared, not copied (they are read-only).

        Parameters
        ----------
        **changes
            Metadata keys and their new JSON-serialisable values, e.g.
            ``method="flicker"``, ``params={...}``, ``seed=0``, ``timings={...}``.

        Returns
        -------
        Clip

        Examples
        --------
        >>> clip = Clip(np.zeros((2, 4, 4)), metadata={"seed": 1})
        >>> clip.with_metadata(method="reiter").metadata
        {'seed': 1, 'method': 'reiter'}
        """
        metadata = {**self._metadata, **_as_metadata(changes)}
        return Clip._trusted(self._frames, self._fps, metadata)

    def montage(self, n=6, cols=None):
        """Tile ``n`` evenly spaced frames into one image, for static figures.

        Parameters
        ----------
        n : int
            How many frames, >= 1, always including the first and (for ``n > 1``) the
            last. Capped at the number of frames.
        cols : int, optional
            Frames per row; by default ``min(n, 6)``.

        Returns
        -------
        ndarray, shape (H', W') or (H', W', 3), float32
            A new array; frames are separated by 2-pixel white lines.

        Examples
        --------
        >>> Clip(np.zeros((10, 20, 30))).montage(n=4, cols=2).shape
        (42, 62)
        """
        n = min(check_int("n", n, 1), self.n_frames)
        cols = min(n, 6) if cols is None else min(check_int("cols", cols, 1), n)
        rows = math.ceil(n / cols)
        gap = 2
        h, w = self.shape
        # Evenly spaced and distinct: with n <= T the spacing is >= 1 frame.
        picks = np.linspace(0, self.n_frames - 1, n).round().astype(int)
        out_shape = (rows * h + (rows - 1) * gap, cols * w + (cols - 1) * gap)
        out = np.ones(out_shape + self._frames.shape[3:], dtype=np.float32)
        for k, t in enumerate(picks):
            r, c = divmod(k, cols)
            out[r * (h + gap) : r * (h + gap) + h, c * (w + gap) : c * (w + gap) + w] = (
                self._frames[t]
            )
        return out

    # ------------------------------------------------------------------ files

    def save(self, path, *, fps=None, quality=None):
        """Write the clip to a file or folder; the format follows the extension.

        - ``.npz``: exact frames, fps and metadata (the command line's format).
        - ``.gif``: 8-bit, looping. Grey is exact; RGB frames share one 256-colour
          palette (exact if the whole clip has at most 256 colours). GIF frame delays
          are whole hundredths of a second (at least 0.02 s), so players show
          approximately ``fps``; the exact value is kept in a comment.
        - ``.mp4``: H.264, yuv420p (plays everywhere), lossy. That pixel format needs
          an even width and height, so an odd size is padded by repeating the last
          row/column; :meth:`load` crops the padding away again.
        - a path without extension, or an existing folder: a PNG sequence
          ``frame_00000.png``, ``frame_00001.png``, ... (8-bit) plus ``clip.json``
          with the fps and metadata.

        Parent folders are created. Files are written under a temporary name and then
        renamed, so a failed save never leaves a truncated file behind.

        Parameters
        ----------
        path : str or os.PathLike
            Where to write.
        fps : float, optional
            Frame rate for the file; by default the clip's.
        quality : float, optional
            MP4 quality on imageio's scale, 1 (smallest) to 10 (best); default 7.
            Ignored by the other formats.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ValueError
            For an unknown extension or an invalid ``fps`` or ``quality``.
        OSError
            If the file cannot be written.

        Examples
        --------
        >>> import tempfile
        >>> clip = Clip(np.zeros((4, 8, 8)), fps=10, metadata={"method": "demo"})
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     path = clip.save(Path(folder) / "demo.npz")
        ...     Clip.load(path)
        Clip(4 frames, 8x8 grey, 10 fps, method='demo')
        """
        path = _as_path(path)
        fps = self._fps if fps is None else check_range("fps", fps, 0, lo_open=True)
        if quality is not None:
            quality = check_range("quality", quality, 1, 10)
        suffix = path.suffix.lower()
        if path.is_dir() or suffix == "":
            self._save_png_folder(path, fps)
            return path
        if suffix not in _FILE_EXTENSIONS:
            raise ValueError(f"path must end in {_ALLOWED}; got {str(path)!r}")
        path.parent.mkdir(parents=True, exist_ok=True)
        if suffix == ".npz":
            _write_atomically(path, lambda tmp: self._save_npz(tmp, fps))
        elif suffix == ".gif":
            _write_atomically(path, lambda tmp: self._save_gif(tmp, fps))
        else:
            q = _DEFAULT_QUALITY if quality is None else quality
            _write_atomically(path, lambda tmp: self._save_mp4(tmp, fps, q))
        return path

    def _file_info(self, fps):
        # What GIF/MP4 comments and clip.json record, so load() restores exactly the
        # fps, metadata, colour mode and (for padded MP4s) the original size.
        return {
            "format": _TAG,
            "fps": fps,
            "n_frames": self.n_frames,
            "shape": list(self.shape),
            "color": self.is_color,
            "metadata": self._metadata,
        }

    def _save_npz(self, tmp, fps):
        with open(tmp, "wb") as f:  # a file object: numpy would append ".npz" to a name
            np.savez_compressed(
                f,
                frames=self._frames,
                fps=np.float64(fps),
                metadata=np.array(json.dumps(self._metadata)),
                format=np.array(_TAG),
            )

    def _save_gif(self, tmp, fps):
        with open(tmp, "wb") as f:
            _write_gif(f, self.to_uint8(), fps, comment=json.dumps(self._file_info(fps)))

    def _save_mp4(self, tmp, fps, quality):
        frames = _pad_even(self.to_uint8())
        _encode_mp4(
            tmp,
            frames,
            fps,
            quality,
            comment=json.dumps(self._file_info(fps)),
            preset="medium",
        )

    def _save_png_folder(self, folder, fps):
        from PIL import Image

        had_clip = (folder / "clip.json").is_file()
        folder.mkdir(parents=True, exist_ok=True)
        frames = self.to_uint8()
        for t, frame in enumerate(frames):
            Image.fromarray(frame).save(folder / f"frame_{t:05d}.png")
        if had_clip:
            # Overwriting a longer clip: drop its extra frames so the folder holds one
            # clip. Only our own frame_NNNNN.png names in a folder we wrote are touched.
            for p in folder.iterdir():
                m = _PNG_NAME.match(p.name)
                if m and int(m.group(1)) >= len(frames):
                    p.unlink()
        info = self._file_info(fps)
        _write_atomically(
            folder / "clip.json",
            lambda tmp: tmp.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8"),
        )

    @classmethod
    def load(cls, path):
        """Read a clip written by :meth:`save` (``.npz``, ``.gif``, ``.mp4`` or folder).

        - ``.npz``: exact frames, fps and metadata.
        - folder: ``frame_*.png`` in numeric order; fps and metadata from ``clip.json``
          (fps 8 if there is none). Frames are 8-bit, i.e. equal to
          ``clip.to_uint8() / 255`` of the clip saved.
        - ``.gif``: 8-bit frames; frames whose channels are all equal come back grey.
          fps and metadata come from the comment :meth:`save` writes, otherwise fps is
          estimated from the frame delays (multiples of 10 ms).
        - ``.mp4``: lossy frames; fps and metadata from the comment :meth:`save`
          writes, otherwise fps from the video stream and no metadata.

        Parameters
        ----------
        path : str or os.PathLike
            The file or folder.

        Returns
        -------
        Clip

        Raises
        ------
        ValueError
            If the path does not exist, has an unknown extension, or cannot be read as
            the expected content; the message names the path and what was expected.

        Examples
        --------
        >>> Clip.load("missing.npz")
        Traceback (most recent call last):
        ...
        ValueError: path: no such file 'missing.npz'
        """
        path = _as_path(path)
        if path.is_dir():
            return _load_png_folder(path)
        suffix = path.suffix.lower()
        if suffix not in _FILE_EXTENSIONS:
            what = "no such folder" if suffix == "" else "unknown extension"
            raise ValueError(f"path must end in {_ALLOWED} ({what}): got {str(path)!r}")
        if not path.is_file():
            raise ValueError(f"path: no such file {str(path)!r}")
        return {".npz": _load_npz, ".gif": _load_gif, ".mp4": _load_mp4}[suffix](path)

    # ------------------------------------------------------------------ display

    def _repr_html_(self):
        """Return HTML showing the clip as a looping video (Jupyter's rich display)."""
        # Encoded once: the frames are read-only and the metadata is never handed out,
        # so the rendering cannot go stale.
        if self._html is None:
            self._html = self._render_html()
        return self._html

    def _render_html(self):
        frames, scale = _display_frames(self._frames)
        h, w = frames.shape[1:3]
        style = "max-width:100%;height:auto;" + ("image-rendering:pixelated;" if scale > 1 else "")
        size = f'width="{w}" height="{h}" style="{style}"'
        try:
            if len(frames) == 1:
                data = _encode_image_bytes(frames[0], ".png")
                player = f'<img {size} alt="clip frame" src="data:image/png;base64,{data}">'
            else:
                try:
                    with tempfile.TemporaryDirectory(prefix="fluidnb-") as folder:
                        tmp = Path(folder) / "clip.mp4"
                        _encode_mp4(tmp, frames, self._fps, _DEFAULT_QUALITY, preset="veryfast")
                        data = base64.b64encode(tmp.read_bytes()).decode("ascii")
                    player = (
                        f"<video {size} controls loop autoplay muted playsinline "
                        f'src="data:video/mp4;base64,{data}"></video>'
                    )
                except Exception:
                    # No working ffmpeg (or an encoder failure): an animated GIF
                    # plays everywhere, just larger and with a reduced palette.
                    data = _encode_image_bytes(frames, ".gif", fps=self._fps)
                    player = f'<img {size} alt="clip animation" src="data:image/gif;base64,{data}">'
        except Exception as exc:  # pragma: no cover - Pillow itself failing
            player = f"<pre>(preview unavailable: {html.escape(str(exc))})</pre>"
        return (
            '<div class="fluidnb-clip">'
            f"{player}"
            '<div style="font:12px monospace;color:#777;margin-top:2px">'
            f"{html.escape(self._caption())}</div></div>"
        )

    def _caption(self):
        h, w = self.shape
        t = self.n_frames
        text = (
            f"{t} frame{'s' if t != 1 else ''} · {w}×{h} {'RGB' if self.is_color else 'grey'}"
            f" · {self._fps:g} fps · {self.duration:.3g} s"
        )
        if "method" in self._metadata:
            text += f" · {self._metadata['method']}"
        return text


def load_clip(path):
    """Read a clip from a file or folder; the same as :meth:`Clip.load`.

    Parameters
    ----------
    path : str or os.PathLike
        An ``.npz``, ``.gif`` or ``.mp4`` file, or a folder of PNG frames.

    Returns
    -------
    Clip

    Examples
    --------
    >>> load_clip("missing.gif")
    Traceback (most recent call last):
    ...
    ValueError: path: no such file 'missing.gif'
    """
    return Clip.load(path)


# ---------------------------------------------------------------------- validation


def _as_frames(frames):
    if isinstance(frames, np.ndarray):
        arr = frames
    else:
        try:
            arr = np.asarray(frames)
        except (ValueError, TypeError) as exc:  # ragged lists and the like
            raise ValueError(f"frames is not a rectangular array: {exc}") from None
    if arr.ndim == 4 and arr.shape[3] == 1:
        arr = arr[..., 0]
    if arr.ndim not in (3, 4) or (arr.ndim == 4 and arr.shape[3] not in (3, 4)):
        raise ValueError(
            "frames must have shape (T, H, W), (T, H, W, 1), (T, H, W, 3) or (T, H, W, 4), "
            f"got {arr.shape}"
        )
    if 0 in arr.shape[:3]:
        raise ValueError(
            f"frames is empty: need at least one frame of at least 1x1 pixels, got {arr.shape}"
        )
    if arr.ndim == 4 and arr.shape[3] == 4:
        arr = arr[..., :3]  # drop alpha before converting: less to convert
    out = _to_float01(arr, "frames")  # always a new array, so clipping in place is safe
    np.clip(out, 0.0, 1.0, out=out)
    out = np.ascontiguousarray(out, dtype=np.float32)
    out.setflags(write=False)
    # Hand out a view: a view of a read-only array cannot be made writable again, so
    # ``clip.frames.setflags(write=True)`` fails instead of silently unfreezing the clip.
    return out.view()


def _as_metadata(metadata):
    if metadata is None:
        return {}
    if not isinstance(metadata, dict):
        raise ValueError(f"metadata must be a dict, got {type(metadata).__name__}")
    try:
        return _jsonable(metadata, "metadata")
    except RecursionError:
        raise ValueError("metadata is not JSON-serialisable: it contains itself") from None


def _jsonable(value, where):
    """Return ``value`` as plain JSON types (dict, list, str, int, float, bool, None)."""
    if value is None or isinstance(value, (bool, str)):
        return str(value) if isinstance(value, str) else value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (numbers.Integral, np.integer)):
        return int(value)
    if isinstance(value, (numbers.Real, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            # JSON has no NaN/Infinity; browsers and other tools would refuse the file.
            raise ValueError(f"{where} must be finite to be stored as JSON, got {v}")
        return v
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biufU":
            raise ValueError(
                f"{where} is an array of dtype {value.dtype}, which is not JSON-serialisable"
            )
        return _jsonable(value.tolist(), where)
    if isinstance(value, np.generic):  # np.str_ and friends
        return _jsonable(value.item(), where)
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                # JSON would turn 1 into "1" and the loaded clip would differ.
                raise ValueError(f"{where} keys must be strings, got {k!r}")
            out[str(k)] = _jsonable(v, f"{where}[{k!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [_jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise ValueError(
        f"{where} is not JSON-serialisable: got {type(value).__name__} {value!r:.60}"
        " (use str, int, float, bool, None, lists and dicts)"
    )


def _as_path(path):
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    return Path(path)


def _write_atomically(path, write):
    """Call ``write(tmp)`` for a temporary name next to ``path``, then rename it."""
    # Keep the suffix: encoders choose the container from it.
    tmp = path.with_name(f".{path.stem}.partial-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


# ---------------------------------------------------------------------- loading


def _from_file_info(info, path):
    """Return (fps, metadata) from a comment/clip.json dict, or (None, {}) if foreign."""
    if not isinstance(info, dict) or info.get("format") != _TAG:
        return None, {}
    try:
        fps = check_range("fps", info.get("fps"), 0, lo_open=True)
        metadata = _as_metadata(info.get("metadata"))
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: damaged clip information ({exc})") from None
    return fps, metadata


def _parse_json(text):
    try:
        return json.loads(text)
    except (TypeError, ValueError, UnicodeDecodeError):
        return None


def _load_npz(path):
    import zipfile

    expected = "an .npz written by Clip.save, with arrays 'frames' and 'fps'"
    try:
        with np.load(path, allow_pickle=False) as data:
            if not isinstance(data, np.lib.npyio.NpzFile):  # pragma: no cover
                raise ValueError("not an .npz archive")
            missing = [k for k in ("frames", "fps") if k not in data.files]
            if missing:
                raise ValueError(f"it has no {', '.join(repr(m) for m in missing)}")
            frames = data["frames"]
            fps = data["fps"]
            meta_text = str(data["metadata"]) if "metadata" in data.files else "{}"
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(f"cannot read {str(path)!r}: expected {expected} ({exc})") from None
    metadata = _parse_json(meta_text)
    try:
        if fps.shape != ():
            raise ValueError(f"fps must be a single number, got shape {fps.shape}")
        if metadata is None:
            raise ValueError("metadata is not valid JSON")
        return Clip(frames, float(fps), metadata)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"cannot read {str(path)!r}: {exc}") from None


def _load_png_folder(folder):
    files = {}
    for p in folder.iterdir():
        m = _PNG_NAME.match(p.name)
        if m:
            files[int(m.group(1))] = p
    info_path = folder / "clip.json"
    info = None
    if info_path.is_file():
        info = _parse_json(info_path.read_text(encoding="utf-8", errors="replace"))
        if not isinstance(info, dict):
            raise ValueError(f"cannot read {str(info_path)!r}: expected JSON written by Clip.save")
    fps, metadata = _from_file_info(info, info_path)
    if info is not None and isinstance(info.get("n_frames"), int) and info["n_frames"] > 0:
        wanted = range(info["n_frames"])
        missing = [t for t in wanted if t not in files]
        if missing:
            raise ValueError(
                f"{str(folder)!r}: clip.json lists {info['n_frames']} frames but "
                f"frame_{missing[0]:05d}.png is missing"
            )
        order = list(wanted)
    else:
        order = sorted(files)
    if not order:
        raise ValueError(
            f"{str(folder)!r} holds no clip: expected frame_00000.png, frame_00001.png, ... "
            "and clip.json as written by Clip.save"
        )
    frames = [_read(files[t], "path") for t in order]
    if len({f.dtype for f in frames}) > 1:
        frames = [(f >> 8).astype(np.uint8) if f.dtype == np.uint16 else f for f in frames]
    if any(f.ndim == 3 for f in frames):  # mixed grey and colour: promote grey
        frames = [np.repeat(f[:, :, None], 3, axis=2) if f.ndim == 2 else f for f in frames]
    if len({f.shape for f in frames}) > 1:
        raise ValueError(f"{str(folder)!r}: the PNG frames do not all have the same size")
    return Clip(np.stack(frames), DEFAULT_FPS if fps is None else fps, metadata)


def _load_gif(path):
    from PIL import Image, ImageSequence, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            if im.format != "GIF":
                raise ValueError(f"it is a {im.format} image")
            # Read the comment before iterating: seeking to frame 0 forgets it.
            info = _parse_json(im.info.get("comment", b""))
            frames, delays = [], []
            for frame in ImageSequence.Iterator(im):
                frames.append(np.asarray(frame.convert("RGB")))
                delays.append(int(frame.info.get("duration", 0) or 0))
    except (UnidentifiedImageError, OSError, SyntaxError, EOFError, ValueError) as exc:
        raise ValueError(f"cannot read {str(path)!r}: expected a GIF animation ({exc})") from None
    fps, metadata = _from_file_info(info, path)
    ours = fps is not None
    frames = np.stack(frames)
    if ours:
        # Pillow merges identical consecutive frames into one with a longer delay;
        # knowing the delay we wrote, repeat them to restore the frame count.
        base = _gif_delay_ms(fps)
        repeats = [max(1, round(d / base)) for d in delays]
        if sum(repeats) != len(frames):
            frames = np.repeat(frames, repeats, axis=0)
    else:
        positive = [d for d in delays if d > 0]
        fps = 1000.0 / float(np.median(positive)) if positive else DEFAULT_FPS
    color = info.get("color") if ours else None
    if color is False or (color is None and _channels_equal(frames)):
        frames = frames[..., 0]
    return Clip(frames, fps, metadata)


def _load_mp4(path):
    cmd = [
        *_ffmpeg_base(),
        "-i",
        str(path),
        "-map",
        "0:v:0",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        "pipe:1",
    ]
    try:
        proc = subprocess.run(cmd, capture_output=True, stdin=subprocess.DEVNULL, check=False)
    except OSError as exc:  # pragma: no cover - no ffmpeg binary
        raise ValueError(f"cannot read {str(path)!r}: ffmpeg failed to start ({exc})") from None
    log = proc.stderr.decode("utf-8", errors="replace")
    expected = f"cannot read {str(path)!r}: expected an MP4 video"
    if proc.returncode != 0:
        raise ValueError(f"{expected} ({_last_lines(log)})")
    head, _, out = log.partition("\nOutput #0")
    size = re.search(r"Video:.*?, (\d+)x(\d+)", out)
    if size is None or not proc.stdout:
        raise ValueError(f"{expected} (no video frames found)")
    w, h = int(size.group(1)), int(size.group(2))
    frame_bytes = w * h * 3
    n = len(proc.stdout) // frame_bytes
    if n == 0 or n * frame_bytes != len(proc.stdout):
        raise ValueError(f"{expected} (decoded data does not match the size {w}x{h})")
    frames = np.frombuffer(proc.stdout, dtype=np.uint8).reshape(n, h, w, 3)

    info = _parse_json(_mp4_comment(path))
    fps, metadata = _from_file_info(info, path)
    if fps is None:
        rate = re.search(r"Video:.*?, ([\d.]+) (?:fps|tbr)", head)
        fps = float(rate.group(1)) if rate and float(rate.group(1)) > 0 else DEFAULT_FPS
        color = None
    else:
        color = info.get("color")
        shape = info.get("shape")
        if isinstance(shape, list) and len(shape) == 2 and all(isinstance(s, int) for s in shape):
            frames = frames[:, : shape[0], : shape[1]]  # crop the even-size padding
    if color is False:
        # Chroma is neutral for grey input, but rounding can differ by a level
        # between channels: average them.
        frames = frames.mean(axis=3, dtype=np.float32) / np.float32(255)
    elif color is None and _channels_equal(frames):
        frames = frames[..., 0]
    return Clip(frames, fps, metadata)


def _mp4_comment(path):
    """Return the container's ``comment`` tag, or None.

    Read through ffmpeg's metadata muxer rather than its log, which cuts long values.
    """
    cmd = [*_ffmpeg_base(), "-v", "error", "-i", str(path), "-f", "ffmetadata", "pipe:1"]
    proc = subprocess.run(cmd, capture_output=True, stdin=subprocess.DEVNULL, check=False)
    if proc.returncode != 0:
        return None
    text = proc.stdout.decode("utf-8", errors="replace")
    # Global tags come before the first [STREAM]/[CHAPTER] section; values escape
    # '=', ';', '#', backslash and newline with a backslash.
    m = re.search(r"^comment=((?:[^\\\n]|\\.)*)$", text.split("\n[", 1)[0], re.M | re.S)
    return re.sub(r"\\(.)", r"\1", m.group(1), flags=re.S) if m else None


def _channels_equal(frames):
    return bool(
        np.all(frames[..., 0] == frames[..., 1]) and np.all(frames[..., 1] == frames[..., 2])
    )


# ---------------------------------------------------------------------- encoding


def _gif_delay_ms(fps):
    # GIF stores delays in hundredths of a second, and browsers play delays under
    # 20 ms at 100 ms, so round to 10 ms and never go below 20 ms.
    return max(20, round(100.0 / fps) * 10)


def _pad_even(frames):
    """Pad uint8 frames to an even height and width by repeating the edge."""
    h, w = frames.shape[1:3]
    if h % 2 == 0 and w % 2 == 0:
        return frames
    pad = [(0, 0), (0, h % 2), (0, w % 2)] + [(0, 0)] * (frames.ndim - 3)
    return np.pad(frames, pad, mode="edge")


def _ffmpeg_base():
    import imageio_ffmpeg

    # -nostdin: ffmpeg otherwise listens to the terminal for keystrokes.
    return [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin"]


def _last_lines(log, n=3):
    lines = [ln.strip() for ln in log.strip().splitlines() if ln.strip()]
    return " / ".join(lines[-n:]) or "no message"


def _encode_mp4(path, frames, fps, quality, *, comment=None, preset="medium"):
    """Encode even-sized uint8 frames to H.264/yuv420p MP4 by piping them to ffmpeg.

    Our own pipe rather than imageio's writer: ffmpeg's errors are captured for the
    exception message, and nothing (pipes, warnings) leaks when it fails.
    """
    h, w = frames.shape[1:3]
    rate = Fraction(fps).limit_denominator(100_000)
    # imageio's 1-10 quality scale, mapped to x264's CRF the way imageio does.
    crf = int((1.0 - quality / 10.0) * 51)
    cmd = [
        *_ffmpeg_base(),
        "-y",
        "-loglevel",
        "error",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24" if frames.ndim == 4 else "gray",
        "-s",
        f"{w}x{h}",
        "-r",
        f"{rate.numerator}/{rate.denominator}",
        "-i",
        "pipe:0",
        "-an",
        "-c:v",
        "libx264",
        "-preset",
        preset,
        "-crf",
        str(crf),
        "-pix_fmt",
        "yuv420p",
        "-movflags",
        "+faststart",
    ]
    if comment is not None:
        cmd += ["-metadata", f"comment={comment}"]
    cmd += ["-f", "mp4", str(path)]
    # stderr to a file, not a pipe: a pipe nobody reads could fill up and deadlock.
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log)
        try:
            for frame in frames:
                proc.stdin.write(np.ascontiguousarray(frame).data)
        except BrokenPipeError:
            pass  # ffmpeg stopped early; its message is reported below
        finally:
            with contextlib.suppress(BrokenPipeError):
                proc.stdin.close()
            code = proc.wait()
        if code != 0:
            log.seek(0)
            message = _last_lines(log.read().decode("utf-8", errors="replace"))
            raise OSError(f"ffmpeg could not encode {str(path)!r}: {message}")


def _write_gif(file, frames, fps, comment=None):
    """Write uint8 frames as a looping GIF to a binary file object.

    Grey frames are stored exactly (256 grey levels). Colour frames share one palette:
    exact when the whole clip has at most 256 colours, otherwise 256 colours chosen
    (octree) from up to 16 evenly spaced frames, without dithering. One palette keeps
    colours from flickering between frames, and is several times faster than Pillow's
    per-frame median cut; no dithering avoids crawling noise in the animation.
    """
    from PIL import Image

    h, w = frames.shape[1:3]
    if frames.ndim == 3:
        images = [Image.fromarray(f) for f in frames]
    else:
        palette, indices = _exact_palette(frames)
        if palette is not None:
            images = []
            for idx in indices:
                im = Image.frombytes("P", (w, h), idx.tobytes())
                im.putpalette(palette.tobytes())
                images.append(im)
        else:
            picks = np.unique(np.linspace(0, len(frames) - 1, min(16, len(frames))).astype(int))
            sample = Image.fromarray(np.concatenate(frames[picks], axis=0))
            reference = sample.quantize(256, method=Image.Quantize.FASTOCTREE)
            images = [
                Image.fromarray(f).quantize(palette=reference, dither=Image.Dither.NONE)
                for f in frames
            ]
    extra = {"comment": comment} if comment else {}
    images[0].save(
        file,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=_gif_delay_ms(fps),
        loop=0,
        **extra,
    )


def _exact_palette(frames):
    """Return (palette (n, 3) uint8, indices (T, H, W) uint8) if <= 256 colours, else None."""
    packed = (
        (frames[..., 0].astype(np.uint32) << 16)
        | (frames[..., 1].astype(np.uint32) << 8)
        | frames[..., 2].astype(np.uint32)
    )
    # Most fluid clips have thousands of colours: the first frame usually says so
    # cheaply, before sorting the whole clip.
    if len(np.unique(packed[0])) > 256:
        return None, None
    colours, inverse = np.unique(packed, return_inverse=True)
    if len(colours) > 256:
        return None, None
    palette = np.stack([colours >> 16, (colours >> 8) & 255, colours & 255], axis=-1)
    return palette.astype(np.uint8), inverse.reshape(packed.shape).astype(np.uint8)


def _encode_image_bytes(frames, extension, fps=None):
    """Return base64 text of a PNG (one frame) or an animated GIF (frames)."""
    buffer = io.BytesIO()
    if extension == ".gif":
        _write_gif(buffer, frames, fps)
    else:
        from PIL import Image

        Image.fromarray(frames).save(buffer, format="PNG")
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _display_frames(frames):
    """Return (uint8 frames sized for display with even sides, integer upscale)."""
    h, w = frames.shape[1:3]
    longest = max(h, w)
    scale = 1
    if longest > _DISPLAY_MAX:
        k = math.ceil(longest / _DISPLAY_MAX)
        kh, kw = min(k, h), min(k, w)  # a clip thinner than k pixels keeps 1 pixel
        # Area averaging over kh x kw blocks, so fine fluid detail does not alias.
        # Summing strided views is several times faster than reshape(...).mean() over
        # two axes. The last h % kh rows (w % kw columns), under 1% of the image, are
        # dropped: this is only the preview.
        hc, wc = h // kh * kh, w // kw * kw
        acc = None
        for i in range(kh):
            for j in range(kw):
                part = frames[:, i:hc:kh, j:wc:kw]
                acc = part.copy() if acc is None else np.add(acc, part, out=acc)
        acc *= np.float32(1.0 / (kh * kw))
        out = to_uint8(acc)
    else:
        out = to_uint8(frames)
        if longest < _DISPLAY_MIN:
            # Tiny simulation grids: enlarge (nearest, so cells stay crisp).
            scale = math.ceil(_DISPLAY_MIN / longest)
            out = out.repeat(scale, axis=1).repeat(scale, axis=2)
    return _pad_even(out), scale
