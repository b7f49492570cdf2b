"""The :class:`Clip`: frames, their fps and metadata -- what every method makes.

A clip is ``(T, H, W)`` or ``(T, H, W, 3)`` ``float32`` in [0, 1] (see
docs/conventions.md). It is an immutable value: the frames are a read-only array, so a
clip can be shared, sliced and displayed without copies, and its inline rendering in
Jupyter can be computed once and cached.

Files are :mod:`fluidnb._media`'s business: :meth:`Clip.save` and :meth:`Clip.load`
hand it plain arrays, the fps and the metadata.
"""

from __future__ import annotations

import html
import json
import math
import numbers
import os

import numpy as np

from . import _media
from ._image import to_float01, to_uint8
from ._validation import check_fps, check_int, check_range

__all__ = ["Clip", "load_clip"]

#: Frames per second when nothing says otherwise (the papers' preview rate).
DEFAULT_FPS = 8.0


class Clip:
    """An animation: frames in [0, 1], a frame rate and JSON metadata.

    Every method in fluidnb returns a ``Clip``, or a result object whose ``.clip`` is
    one (see docs/conventions.md). It is immutable: the frames are stored
    as a read-only ``float32`` copy, and :meth:`with_metadata` or slicing return new
    clips. In Jupyter a clip displays itself as a looping video.

    Parameters
    ----------
    frames : array_like, shape (T, H, W), (T, H, W, 1), (T, H, W, 3) or (T, H, W, 4)
        The frames: ``uint8`` (0-255), ``uint16`` (0-65535), ``bool``, or floats in
        [0, 1]. A channel axis of length 1 is squeezed to grey; an alpha channel is
        dropped. The array is copied, never modified or kept.
    fps : float
        Frames per second, in [0.01, 1000] (``fluidnb._validation.FPS_RANGE``: a GIF
        cannot store a slower rate, and no player shows a faster one).
    metadata : dict, optional
        JSON-serialisable information about how the clip was made. By convention
        ``method`` (str), ``params`` (dict), ``seed`` (the int random seed actually
        used, see :func:`fluidnb.resolve_seed`) and ``timings`` (dict of stage to
        seconds). NumPy scalars and arrays, tuples and paths are converted to plain
        Python values.

    Raises
    ------
    ValueError
        For frames of the wrong shape, dtype or range (or containing NaN), an
        ``fps`` outside [0.01, 1000], or metadata that is not JSON-serialisable.

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
        self._fps = check_fps(fps)
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
          row/column; :meth:`load` crops the padding away again. The fps, metadata
          and size go to a JSON file beside the video, ``NAME.mp4.json``: copy it
          along with the video to keep them.
        - a path without extension, or an existing folder: a PNG sequence
          ``frame_00000.png``, ``frame_00001.png``, ... (8-bit) plus ``clip.json``
          with the fps and metadata. The folder must be new, empty, or one a clip
          was saved into before: a file fluidnb did not write there is never
          replaced (such a folder is refused with a ValueError; choose another).

        Parent folders are created. Files are written under a temporary name and then
        renamed, so a failed save never leaves a truncated file behind, and an
        OSError names ``path``.

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
            For an unknown extension, an ``fps`` outside [0.01, 1000], an invalid
            ``quality``, or a folder holding files fluidnb did not write.
        OSError
            If the file cannot be written (a file where a folder should be, no
            permission, a full disk); the message names ``path``.

        Examples
        --------
        >>> import tempfile
        >>> clip = Clip(np.zeros((4, 8, 8)), fps=10, metadata={"method": "demo"})
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     path = clip.save(os.path.join(folder, "demo.npz"))
        ...     Clip.load(path)
        Clip(4 frames, 8x8 grey, 10 fps, method='demo')
        """
        path = _media.as_path(path)
        fps = self._fps if fps is None else check_fps(fps)
        if quality is not None:
            quality = check_range("quality", quality, 1, 10)
        return _media.write(path, self._frames, fps, self._metadata, quality=quality)

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
        - ``.mp4``: lossy frames; fps, metadata and the unpadded size from the
          ``NAME.mp4.json`` that :meth:`save` writes beside the video; without it,
          fps from the video stream (two decimals) and no metadata.

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
        path = _media.as_path(path)
        frames, fps, metadata = _media.read(path)
        try:
            return cls(frames, DEFAULT_FPS if fps is None else fps, metadata)
        except ValueError as exc:
            raise ValueError(f"cannot read {str(path)!r}: {exc}") from None

    # ------------------------------------------------------------------ display

    def _repr_html_(self):
        """Return HTML showing the clip as a looping video (Jupyter's rich display)."""
        # Encoded once: the frames are read-only and the metadata is never handed out,
        # so the rendering cannot go stale.
        if self._html is None:
            self._html = self._render_html()
        return self._html

    def _render_html(self):
        try:
            player = _media.html_player(self._frames, self._fps)
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
    out = to_float01(arr, name="frames")  # always a new array, so clipping in place is safe
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
