"""The :class:`FrameStream`: a clip made in order, a block of frames at a time.

A method's clip held whole costs its frames' float32 bytes: at 1920 x 1080, 64 RGB
frames are 1.6 GB, and converting, padding or encoding them made more copies. Where
the frames go to a file they need never be held together: a stream makes them in
order, a few at a time, and :meth:`FrameStream.save` writes each block as it comes
(``.npz`` into its archive, MP4 through the encoder's pipe, PNG frames one by one;
:func:`fluidnb._media.write_frames`). So memory is bounded by a block and the
method's own tables, not by the length of the clip (docs/conventions.md, "Streams").

Every method that streams makes its in-memory clip by collecting its stream
(:meth:`FrameStream.clip`): one code path, so the streamed file and the clip hold the
same frames by construction, and tests check it.
"""

from __future__ import annotations

import json
import time

import numpy as np

from . import _media
from ._clip import Clip, _as_metadata
from ._validation import check_fps, check_int, check_range

__all__ = ["FrameStream"]


class FrameStream:
    """A clip made in order, a block of frames at a time (see the module).

    A recipe, not a buffer: each pass (:meth:`save`, :meth:`clip`, iterating) runs
    the method's frame loop again from its start, with its recorded seed, so every
    pass gives the same frames.

    Parameters
    ----------
    blocks : callable
        ``blocks()`` returns an iterator over the frames in order, as arrays
        ``(n, H, W)`` or ``(n, H, W, 3)`` of float32 in [0, 1] (any ``n >= 1``),
        ``n_frames`` frames in all.
    n_frames : int
        ``T``, known before the first frame is made.
    shape : (int, int)
        ``(H, W)`` of every frame.
    color : bool
        RGB frames rather than grey.
    fps : float
        Frames per second, in [0.01, 1000].
    metadata : dict or callable, optional
        The clip's metadata, or ``metadata()`` returning it; read once a pass has
        made every frame, so a method can record what it learns while making them
        (its timings).

    Examples
    --------
    >>> def blocks():
    ...     for t in range(0, 6, 4):
    ...         n = min(4, 6 - t)
    ...         yield np.full((n, 2, 3), 0.5, np.float32)
    >>> stream = FrameStream(blocks, n_frames=6, shape=(2, 3), fps=12, metadata={"method": "demo"})
    >>> stream
    FrameStream(6 frames, 3x2 grey, 12 fps, method='demo')
    >>> stream.clip()
    Clip(6 frames, 3x2 grey, 12 fps, method='demo')
    """

    __slots__ = ("_blocks", "_color", "_extra", "_fps", "_metadata", "_n", "_shape")

    def __init__(self, blocks, *, n_frames, shape, color=False, fps, metadata=None):
        if not callable(blocks):
            raise ValueError(
                f"blocks must be a callable returning an iterator of frames, got "
                f"{type(blocks).__name__}"
            )
        self._blocks = blocks
        self._n = check_int("n_frames", n_frames, 1)
        if len(shape) != 2:
            raise ValueError(f"shape must be (H, W), got {shape!r}")
        self._shape = (check_int("shape[0]", shape[0], 1), check_int("shape[1]", shape[1], 1))
        self._color = bool(color)
        self._fps = check_fps(fps)
        self._metadata = metadata if callable(metadata) else _as_metadata(metadata)
        self._extra = {}

    @classmethod
    def of_clip(cls, clip):
        """A clip's frames as a stream (blocks of its own array, no copies)."""
        if not isinstance(clip, Clip):
            raise ValueError(f"clip must be a fluidnb.Clip, got {type(clip).__name__}")
        frames = clip.frames
        return cls(
            lambda: _media.blocks_of(frames),
            n_frames=len(clip),
            shape=clip.shape,
            color=clip.is_color,
            fps=clip.fps,
            metadata=lambda: clip.metadata,
        )

    # ------------------------------------------------------------------ properties

    @property
    def n_frames(self):
        """The number of frames ``T``."""
        return self._n

    @property
    def shape(self):
        """The frame size ``(H, W)`` in pixels."""
        return self._shape

    @property
    def is_color(self):
        """Whether the frames are RGB."""
        return self._color

    @property
    def fps(self):
        """Frames per second, a float."""
        return self._fps

    @property
    def metadata(self):
        """The metadata as it stands (a copy); complete once a pass has made every frame."""
        base = self._metadata() if callable(self._metadata) else self._metadata
        return json.loads(json.dumps({**_as_metadata(base), **self._extra}))

    @property
    def nbytes(self):
        """What the whole clip would hold as float32 frames, in bytes."""
        return self._n * self._shape[0] * self._shape[1] * (3 if self._color else 1) * 4

    def __len__(self):
        return self._n

    def __repr__(self):
        h, w = self._shape
        parts = [
            f"{self._n} frame{'s' if self._n != 1 else ''}",
            f"{w}x{h} {'RGB' if self._color else 'grey'}",
            f"{self._fps:g} fps",
        ]
        base = self._metadata if isinstance(self._metadata, dict) else {}
        method = self._extra.get("method", base.get("method"))
        if method is not None:
            parts.append(f"method={method!r}")
        return f"FrameStream({', '.join(parts)})"

    # ------------------------------------------------------------------ passes

    def __iter__(self):
        """The frames in blocks ``(n, H, W[, 3])`` float32, in order (one pass)."""
        layout = (self._n, *self._shape) + ((3,) if self._color else ())
        return iter(_media._Checked(self._blocks(), layout))

    def frames(self):
        """The frames one at a time, ``(H, W[, 3])`` float32, in order (one pass)."""
        for block in self:
            yield from block

    def with_metadata(self, **changes):
        """A stream of the same frames with some metadata keys set or replaced.

        The changes are laid over the method's metadata when it is read, after a
        pass (see :attr:`metadata`).
        """
        out = FrameStream.__new__(FrameStream)
        out._blocks, out._n, out._shape = self._blocks, self._n, self._shape
        out._color, out._fps, out._metadata = self._color, self._fps, self._metadata
        out._extra = {**self._extra, **_as_metadata(changes)}
        return out

    def clip(self):
        """Make every frame and hold them: the :class:`~fluidnb.Clip` (one pass).

        Returns
        -------
        Clip
            The frames, the fps and the metadata complete.
        """
        out = np.empty((self._n, *self._shape) + ((3,) if self._color else ()), np.float32)
        t = 0
        for block in self:
            out[t : t + len(block)] = block
            t += len(block)
        return Clip._trusted(out, self._fps, {}).with_metadata(**self.metadata)

    def save(self, path, *, fps=None, quality=None):
        """Make the frames and write them as they come; memory is a block, not the clip.

        The format follows the extension, as for :meth:`fluidnb.Clip.save` (which
        writes the same files): ``.npz`` (exact float32), ``.mp4``, ``.gif`` (which
        alone keeps the clip, as 8-bit frames, for its palette), or a folder of PNG
        frames. A failed or cancelled pass leaves no partial file.

        Parameters
        ----------
        path : str or os.PathLike
        fps : float, optional
            Frame rate for the file; by default the stream's.
        quality : float, optional
            MP4 quality, 1 (smallest) to 10 (best); default 7.

        Returns
        -------
        pathlib.Path
        """
        path = _media.as_path(path)
        fps = self._fps if fps is None else check_fps(fps)
        if quality is not None:
            quality = check_range("quality", quality, 1, 10)
        return _media.write_frames(
            path,
            self,
            n_frames=self._n,
            shape=self._shape,
            color=self._color,
            fps=fps,
            metadata=lambda: self.metadata,
            quality=quality,
        )


def timed(blocks, timings, key):
    """``blocks`` (an iterator), adding the seconds spent making them to ``timings[key]``.

    Only the time inside the method counts, not what the consumer does between blocks
    (encoding, writing), so a streamed render reports the same kind of time as an
    in-memory one.
    """
    timings[key] = timings.get(key, 0.0)
    iterator = iter(blocks)
    while True:
        started = time.perf_counter()
        try:
            block = next(iterator)
        except StopIteration:
            timings[key] += time.perf_counter() - started
            return
        timings[key] += time.perf_counter() - started
        yield block
