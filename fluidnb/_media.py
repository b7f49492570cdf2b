"""Clip files and inline display: the media I/O behind :meth:`fluidnb.Clip.save`.

This module knows file formats and nothing about the :class:`~fluidnb.Clip` type:
it writes and reads plain arrays, an fps and a metadata dict, and :mod:`fluidnb._clip`
turns them into a clip (and validates them there).

Formats, chosen by extension:

- ``.npz``: exact ``float32`` frames, fps and metadata (numpy's own archive).
- ``.gif``: 8-bit frames through Pillow; the fps and metadata travel in the GIF's
  comment, which Pillow writes and reads (``im.info["comment"]``).
- ``.mp4``: H.264 through the ffmpeg binary that imageio-ffmpeg ships. Size and fps
  are read with :func:`imageio_ffmpeg.read_frames` (its first item is a metadata
  dict); fps and metadata travel in a JSON file beside the video, ``NAME.mp4.json``
  (a *sidecar*), because imageio-ffmpeg can write container tags but not read them
  back. Without the sidecar a video still loads, with the stream's fps and no
  metadata.
- a folder: ``frame_00000.png``, ``frame_00001.png``, ... plus ``clip.json``. A folder
  is written only if it is new, empty, or was written by fluidnb (its ``clip.json``
  says which frames are ours): a file fluidnb did not write is never replaced.

``clip.json``, the MP4 sidecar and the GIF comment hold the same JSON object (see
:func:`file_info`), tagged ``"format": "fluidnb.Clip"`` so that a foreign file's
comment or JSON is never mistaken for ours.
"""

from __future__ import annotations

import base64
import contextlib
import errno
import io
import json
import logging
import math
import os
import re
import subprocess
import tempfile
import threading
import warnings
import zipfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from ._image import _open, _read, to_uint8
from ._validation import check_fps, check_input_file, parse_json

__all__ = [
    "EXTENSIONS",
    "blocks_of",
    "check_folder",
    "html_player",
    "read",
    "read_video",
    "targets",
    "write",
    "write_atomically",
    "write_frames",
]

#: File extensions :func:`write` and :func:`read` know (a folder needs none).
EXTENSIONS = (".gif", ".mp4", ".npz")
_ALLOWED = "'.gif', '.mp4', '.npz', or a folder (no extension) for a PNG sequence"

# The key that marks our JSON (GIF comment, MP4 sidecar, clip.json).
_TAG = "fluidnb.Clip"

# MP4 quality on imageio's 1-10 scale (10 best); 7 maps to x264 CRF 15, visually
# lossless for smooth fluid frames at a modest size.
DEFAULT_QUALITY = 7

# x264's speed preset. "veryfast" rather than its default "medium": on a 64-frame
# 1920 x 1080 flicker loop at CRF 15 it took 4.1 s of CPU against 10.6 s (the
# encoder had become the largest part of `fluidnb flicker` at HD), for a file of the
# same size (2.4 MB against 2.5 MB) at 43.6 dB PSNR against 44.4 dB: both visually
# lossless (issue 39).
PRESET = "veryfast"

# Inline display: the longest side is brought into [_DISPLAY_MIN, _DISPLAY_MAX] px. Larger
# clips are averaged down (a notebook cell cannot show more and the base64 payload grows
# with the area); tiny simulation grids are enlarged (nearest) so they are visible.
_DISPLAY_MAX = 480
_DISPLAY_MIN = 128

_PNG_NAME = re.compile(r"^frame_(\d+)\.png$")


# ---------------------------------------------------------------------- paths


def as_path(path):
    """Return ``path`` as a :class:`~pathlib.Path`, or raise ValueError."""
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or os.PathLike, got {type(path).__name__}")
    return Path(path)


def sidecar(path):
    """Return the JSON file beside an MP4 that holds its fps and metadata."""
    return path.with_name(path.name + ".json")


def write_atomically(path, write):
    """Call ``write(tmp)`` for a temporary name next to ``path``, then rename it.

    ``path`` is a :class:`~pathlib.Path`; ``tmp`` keeps its suffix (encoders choose
    the container from it).

    A failure never leaves the temporary file behind, and its OSError names ``path``
    (what the caller asked for), not the temporary name.
    """
    # Keep the suffix: encoders choose the container from it.
    tmp = path.with_name(f".{path.stem}.partial-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise _write_error(exc, path, tmp) from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def _write_error(exc, path, tmp=None):
    """An OSError of the same kind as ``exc`` whose message names ``path``."""
    if exc.errno is not None and exc.strerror:
        # OSError(errno, text) builds the matching subclass (FileNotFoundError, ...).
        if exc.strerror.startswith("cannot write "):  # names its file already (a sidecar)
            return OSError(exc.errno, exc.strerror)
        return OSError(exc.errno, f"cannot write {str(path)!r}: {exc.strerror}")
    text = str(exc)
    if tmp is not None:
        text = text.replace(str(tmp), str(path))
    return OSError(text if str(path) in text else f"cannot write {str(path)!r}: {text}")


def _make_parent(path):
    """Create the folders above ``path``; a file in the way is a clear NotADirectoryError."""
    for folder in reversed(path.parents):
        if folder.exists() and not folder.is_dir():
            raise NotADirectoryError(
                errno.ENOTDIR,
                f"cannot write {str(path)!r}: {str(folder)!r} is a file, not a folder",
            )
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _write_error(exc, path) from None


def targets(path):
    """What :func:`write` would create or replace for ``path``: a list of (Path, is_folder).

    A PNG sequence is its whole folder; an MP4 is the video and its JSON sidecar;
    other formats are the file itself. The command line uses this to check, before
    any work, that no output lands on an input.
    """
    path = as_path(path)
    if path.is_dir() or path.suffix == "":
        return [(path, True)]
    if path.suffix.lower() == ".mp4":
        return [(path, False), (sidecar(path), False)]
    return [(path, False)]


def file_info(frames, fps, metadata):
    """The JSON object that GIF comments, MP4 sidecars and clip.json hold.

    It lets :func:`read` restore exactly the fps, metadata, colour mode and (for
    padded MP4s) the original size.
    """
    return {
        "format": _TAG,
        "fps": fps,
        "n_frames": int(frames.shape[0]),
        "shape": [int(frames.shape[1]), int(frames.shape[2])],
        "color": frames.ndim == 4,
        "metadata": metadata,
    }


# ---------------------------------------------------------------------- writing


def write(path, frames, fps, metadata, *, quality=None):
    """Write frames to ``path``; the format follows the extension (see the module).

    Parameters
    ----------
    path : pathlib.Path
        A file ending in ``.gif``, ``.mp4`` or ``.npz``; an existing folder, or a path
        without extension, for a PNG sequence.
    frames : ndarray, shape (T, H, W) or (T, H, W, 3), float32 in [0, 1]
    fps : float
        Already validated (> 0).
    metadata : dict
        Plain JSON values (already validated).
    quality : float, optional
        MP4 quality, 1-10 (validated by the caller); default 7.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    return write_frames(
        path,
        blocks_of(frames),
        n_frames=len(frames),
        shape=frames.shape[1:3],
        color=frames.ndim == 4,
        fps=fps,
        metadata=lambda: metadata,
        quality=quality,
    )


#: Bytes of float32 frames one block of an in-memory clip holds while it is written.
BLOCK_BYTES = 64 << 20


def blocks_of(frames):
    """The frames of an array as blocks of at most :data:`BLOCK_BYTES` (views, in order)."""
    per = max(1, BLOCK_BYTES // max(frames[0].nbytes, 1)) if len(frames) else 1
    for t in range(0, len(frames), per):
        yield frames[t : t + per]


def write_frames(path, blocks, *, n_frames, shape, color, fps, metadata, quality=None):
    """Write frames that come a block at a time; memory is a block, not the clip.

    The one writer of every format (:func:`write` hands it an in-memory clip's
    blocks; :class:`fluidnb.FrameStream` a method's): ``.npz`` is written into its
    archive as the blocks come, an MP4 is piped to the encoder, a PNG sequence saved
    a frame at a time. A GIF alone keeps the clip, as 8-bit frames (a quarter of
    the floats): its palette is chosen from frames across the whole loop.

    Parameters
    ----------
    path : pathlib.Path
        As for :func:`write`.
    blocks : iterable of ndarray, shape (n, H, W) or (n, H, W, 3), float32 in [0, 1]
        The frames in order, ``n_frames`` in all.
    n_frames : int
    shape : (int, int)
        (H, W) of every frame.
    color : bool
        RGB frames rather than grey.
    fps : float
        Already validated.
    metadata : callable
        ``metadata()`` -> the JSON metadata, asked for once every frame is made (a
        method records its timings while it makes them).
    quality : float, optional
        MP4 quality, 1-10; default 7.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    RuntimeError
        If the blocks do not hold ``n_frames`` frames of that size (a producer's bug).
    """
    suffix = path.suffix.lower()
    layout = (int(n_frames), int(shape[0]), int(shape[1])) + ((3,) if color else ())
    frames = _Checked(blocks, layout)

    def info():
        return file_info(_Layout(layout), fps, metadata())

    if path.is_dir() or suffix == "":
        _write_png_folder(path, frames, fps, info)
        return path
    if suffix not in EXTENSIONS:
        raise ValueError(f"path must end in {_ALLOWED}; got {str(path)!r}")
    _make_parent(path)
    if suffix == ".npz":
        write_atomically(path, lambda tmp: _write_npz(tmp, frames, fps, metadata))
    elif suffix == ".gif":

        def gif(tmp):
            with open(tmp, "wb") as f:
                whole = np.empty(layout, np.uint8)
                for t, block in frames.enumerate():
                    whole[t : t + len(block)] = to_uint8(block)
                _write_gif(f, whole, fps, comment=lambda: json.dumps(info()))

        write_atomically(path, gif)
    else:
        q = DEFAULT_QUALITY if quality is None else quality

        def mp4(tmp):
            even = _pad_even(np.empty((1,) + layout[1:], np.uint8)).shape[1:]
            _encode_mp4(tmp, frames.uint8_even(), fps, q, name=path, layout=even)
            # The sidecar is written (and renamed) before the video is renamed: a disk
            # that fills up on either keeps the video and sidecar that were there, never
            # a new video beside an old sidecar or none.
            _write_json(sidecar(path), info())

        write_atomically(path, mp4)
    return path


class _Layout:
    """What :func:`file_info` reads of a clip: its shape and number of dimensions."""

    def __init__(self, shape):
        self.shape = shape
        self.ndim = len(shape)


class _Checked:
    """The blocks of :func:`write_frames`, checked: their size, and the count in all."""

    def __init__(self, blocks, layout):
        self.blocks = blocks
        self.layout = layout

    def enumerate(self):
        """(first frame, block) pairs, each block float32 of the clip's frame size."""
        t = 0
        for block in self.blocks:
            block = np.asarray(block, dtype=np.float32)
            if block.shape[1:] != self.layout[1:] or t + len(block) > self.layout[0]:
                raise RuntimeError(
                    f"a block of frames {block.shape} after {t} frames does not fit the "
                    f"clip announced, {self.layout}"
                )
            yield t, block
            t += len(block)
        if t != self.layout[0]:
            raise RuntimeError(f"the frames ended after {t} of the {self.layout[0]} announced")

    def __iter__(self):
        for _, block in self.enumerate():
            yield block

    def uint8_even(self):
        """One 8-bit frame at a time, padded to even sides (H.264, yuv420p)."""
        for _, block in self.enumerate():
            yield from _pad_even(to_uint8(block))


def _write_json(path, info):
    text = json.dumps(info, indent=2) + "\n"
    write_atomically(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _write_npz(tmp, frames, fps, metadata):
    """An archive :func:`numpy.load` reads, its frames written as the blocks come.

    What :func:`numpy.savez` writes (the same stored ``.npy`` members), without the
    whole clip in memory first. Not deflated: the float32 frames of a photo deflate
    only to ~0.7 of their size, at 1.0-1.9 s of CPU per 1920-px frame (zlib levels
    1-6) against 0.07 s stored -- 85 s of a 48-frame HD ``fluidnb animate`` under
    load (issue 39). An ``.npz`` is the exact clip; MP4 is the small one.
    """
    from numpy.lib import format as npy

    with open(tmp, "wb") as f, zipfile.ZipFile(f, "w", zipfile.ZIP_STORED) as archive:
        with archive.open("frames.npy", "w", force_zip64=True) as member:
            header = {
                "descr": npy.dtype_to_descr(np.dtype(np.float32)),
                "fortran_order": False,
                "shape": frames.layout,
            }
            npy.write_array_header_1_0(member, header)
            for _, block in frames.enumerate():
                member.write(np.ascontiguousarray(block).data)
        arrays = {
            "fps": np.float64(fps),
            "metadata": np.array(json.dumps(metadata())),
            "format": np.array(_TAG),
        }
        for name, value in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                npy.write_array(member, np.asanyarray(value), allow_pickle=False)


def _write_png_folder(folder, frames, fps, info):
    """Write a PNG sequence and its clip.json, never replacing a file fluidnb did not write.

    fluidnb knows what it wrote in a folder by the folder's clip.json: that file and
    the frames ``frame_00000.png`` ... up to the count it records. A folder that does
    not exist yet or is empty is filled; a folder with our clip.json may have those
    frames replaced (and the surplus ones of a longer clip removed); any other folder
    with files in it is refused, and so is a file our new frames would replace that
    clip.json does not claim (docs/conventions.md, "Clips and results").
    """
    from PIL import Image

    n = frames.layout[0]
    names = [f"frame_{t:05d}.png" for t in range(n)]
    owned = check_folder(folder, names)
    _make_parent(folder)
    try:
        folder.mkdir(exist_ok=True)
    except OSError as exc:
        raise _write_error(exc, folder) from None
    claim = file_info(_Layout(frames.layout), fps, {})
    # Claim every frame before writing the first, so a save cut short leaves a
    # clip.json that names all our files (and the folder can be saved into again).
    _write_json(folder / "clip.json", {**claim, "unfinished": True, "owned": max(n, owned)})
    try:
        for t, block in frames.enumerate():
            for i, frame in enumerate(to_uint8(block)):
                Image.fromarray(frame).save(folder / names[t + i])
        for t in range(n, owned):  # the surplus frames of a longer clip
            (folder / f"frame_{t:05d}.png").unlink(missing_ok=True)
    except OSError as exc:
        raise _write_error(exc, folder) from None
    _write_json(folder / "clip.json", info())


def check_folder(folder, names=(), *, name="path"):
    """Refuse (ValueError) a folder a PNG sequence must not be written into.

    Returns how many frames fluidnb wrote there before (0 for a new or empty folder).

    Parameters
    ----------
    folder : pathlib.Path
    names : sequence of str
        The frame files about to be written; each must be new or one of ours.
    name : str
        How messages name the folder (``"path"``, ``"--output"``).
    """
    if folder.exists() and not folder.is_dir():
        raise ValueError(
            f"{name} {str(folder)!r} is a file: a PNG sequence needs a folder (or end the "
            "path in .gif, .mp4 or .npz)"
        )
    owned = _frames_written(folder)
    present = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    if owned is None and present:
        shown = ", ".join(repr(n) for n in present[:3]) + (", ..." if len(present) > 3 else "")
        raise ValueError(
            f"{name} {str(folder)!r} is a folder of files fluidnb did not write ({shown}; "
            "no clip.json of ours): frames saved there could replace them. Nothing was "
            "written; choose a new or empty folder"
        )
    ours = {f"frame_{t:05d}.png" for t in range(owned or 0)}
    foreign = sorted(set(names).intersection(present) - ours)
    if foreign:
        raise ValueError(
            f"{name} {str(folder)!r}: {foreign[0]!r} there was not written by fluidnb (its "
            f"clip.json lists {owned} frames) and would be replaced. Nothing was written; "
            "move that file or choose a new or empty folder"
        )
    return owned or 0


def _frames_written(folder):
    """How many ``frame_NNNNN.png`` fluidnb wrote in ``folder`` by its clip.json.

    0 for a folder that does not exist, None for one without a clip.json of ours.
    """
    if not folder.exists():
        return 0
    path = folder / "clip.json"
    try:
        info = _parse_json(path.read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return None
    if not isinstance(info, dict) or info.get("format") != _TAG:
        return None
    count = info.get("owned", info.get("n_frames"))
    ok = isinstance(count, int) and not isinstance(count, bool) and count >= 0
    return count if ok else None


def _gif_delay_ms(fps):
    # GIF stores delays in hundredths of a second, and browsers play delays under
    # 20 ms at 100 ms, so round to 10 ms and never go below 20 ms.
    return max(20, round(100.0 / fps) * 10)


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
    if callable(comment):  # known once every frame is made
        comment = comment()
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


def _pad_even(frames):
    """Pad uint8 frames to an even height and width by repeating the edge.

    H.264 in yuv420p (the pixel format every player takes) needs even sides.
    """
    h, w = frames.shape[1:3]
    if h % 2 == 0 and w % 2 == 0:
        return frames
    pad = [(0, 0), (0, h % 2), (0, w % 2)] + [(0, 0)] * (frames.ndim - 3)
    return np.pad(frames, pad, mode="edge")


def _last_lines(log, n=3):
    lines = [ln.strip() for ln in log.strip().splitlines() if ln.strip()]
    return " / ".join(lines[-n:]) or "no message"


def _encode_mp4(path, frames, fps, quality, *, preset=PRESET, name=None, layout=None):
    """Encode even-sized uint8 frames to H.264/yuv420p MP4 by piping them to ffmpeg.

    ``frames`` is an array, or any iterable of frames whose ``layout`` (H, W) or
    (H, W, 3) is given: they are piped as they come.

    Our own pipe to imageio-ffmpeg's binary rather than
    :func:`imageio_ffmpeg.write_frames`, which neither checks ffmpeg's exit status
    nor captures its messages: here a failed encode raises OSError with ffmpeg's
    words (naming ``name``, the file the caller asked for, if given), and nothing
    (pipes, warnings) leaks.
    """
    import imageio_ffmpeg

    layout = frames.shape[1:] if layout is None else tuple(layout)
    h, w = layout[:2]
    rate = Fraction(fps).limit_denominator(100_000)
    # imageio's 1-10 quality scale, mapped to x264's CRF the way imageio does.
    crf = int((1.0 - quality / 10.0) * 51)
    # -nostdin: ffmpeg otherwise listens to the terminal for keystrokes.
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-y"]
    cmd += ["-loglevel", "error"]
    cmd += ["-f", "rawvideo", "-pix_fmt", "rgb24" if len(layout) == 3 else "gray"]
    cmd += ["-s", f"{w}x{h}", "-r", f"{rate.numerator}/{rate.denominator}", "-i", "pipe:0"]
    cmd += ["-an", "-c:v", "libx264", "-preset", preset, "-crf", str(crf)]
    cmd += ["-pix_fmt", "yuv420p", "-movflags", "+faststart", "-f", "mp4", str(path)]
    # stderr read by a thread, not into a temporary file: on a full disk that file
    # (in $TMPDIR) stayed empty and the error said "no message". Read, the pipe never
    # fills up and blocks ffmpeg.
    proc = subprocess.Popen(
        cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    log = []
    reader = threading.Thread(target=lambda: log.append(proc.stderr.read()), daemon=True)
    reader.start()
    try:
        for frame in frames:  # frames may be made as they are piped (a stream)
            proc.stdin.write(np.ascontiguousarray(frame).data)
    except BrokenPipeError:
        pass  # ffmpeg stopped early; its message is reported below
    except BaseException:
        proc.kill()  # the frames failed (or were cancelled): no use encoding the rest
        raise
    finally:
        with contextlib.suppress(BrokenPipeError):
            proc.stdin.close()
        code = proc.wait()
        reader.join()
        proc.stderr.close()
    if code != 0:
        text = b"".join(log).decode("utf-8", errors="replace")
        if "No space left on device" in text or _disk_full(Path(path).parent):
            raise OSError(errno.ENOSPC, "No space left on device (the disk is full)")
        message = _last_lines(text)
        raise OSError(f"ffmpeg could not encode {str(name or path)!r}: {message}")


def _disk_full(folder):
    """Whether the disk holding ``folder`` has (next to) no room left for a file."""
    try:
        st = os.statvfs(folder)
    except (OSError, AttributeError):  # no statvfs on Windows
        return False
    # root may write into the blocks a disk reserves for it; others may not.
    blocks = st.f_bfree if getattr(os, "geteuid", lambda: -1)() == 0 else st.f_bavail
    return blocks * st.f_frsize < 1 << 20


# ---------------------------------------------------------------------- reading


def read(path):
    """Read frames, fps and metadata from a file or folder written by :func:`write`.

    Parameters
    ----------
    path : pathlib.Path

    Returns
    -------
    frames : ndarray, shape (T, H, W) or (T, H, W, 3)
        ``uint8`` from GIF, MP4 and PNG files, as stored in ``.npz`` files.
    fps : float or None
        None when the file does not say (a foreign PNG folder).
    metadata : dict
        Empty for foreign files.

    Raises
    ------
    ValueError
        If the path does not exist, has an unknown extension, or cannot be read as
        the expected content; the message names the path and what was expected.
    """
    if path.is_dir():
        return _read_png_folder(path)
    suffix = path.suffix.lower()
    if suffix not in EXTENSIONS:
        what = "no such folder" if suffix == "" else "unknown extension"
        raise ValueError(f"path must end in {_ALLOWED} ({what}): got {str(path)!r}")
    check_input_file(path, "path", "a clip file")
    return {".npz": _read_npz, ".gif": _read_gif, ".mp4": _read_mp4}[suffix](path)


def _parse_json(text):
    try:
        return parse_json(text, "clip information")
    except ValueError:
        return None


def _read_json(path):
    """Return the JSON object in a clip.json or MP4 sidecar, or None if there is none."""
    if not path.is_file():
        return None
    info = _parse_json(path.read_text(encoding="utf-8", errors="replace"))
    if not isinstance(info, dict) or info.get("format") != _TAG:
        raise ValueError(f"cannot read {str(path)!r}: expected JSON written by Clip.save")
    return info


def _from_file_info(info, path):
    """Return (fps, metadata) from our JSON object, or (None, {}) if it is foreign."""
    if not isinstance(info, dict) or info.get("format") != _TAG:
        return None, {}
    try:
        fps = check_fps(info.get("fps"))
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: damaged clip information ({exc})") from None
    metadata = info.get("metadata")
    return fps, {} if metadata is None else metadata


def _read_npz(path):
    expected = "an .npz written by Clip.save, with arrays 'frames' and 'fps'"
    try:
        # Our own file object: np.load leaves a file it opened itself unclosed when the
        # archive turns out to be damaged.
        with open(path, "rb") as f:
            data = np.load(f, allow_pickle=False)
            if not isinstance(data, np.lib.npyio.NpzFile):  # a lone .npy array
                raise ValueError("it is not an .npz archive")
            with data:
                missing = [k for k in ("frames", "fps") if k not in data.files]
                if missing:
                    raise ValueError(f"it has no {', '.join(repr(m) for m in missing)}")
                frames = data["frames"]
                fps = data["fps"]
                meta_text = str(data["metadata"]) if "metadata" in data.files else "{}"
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise ValueError(f"cannot read {str(path)!r}: expected {expected} ({exc})") from None
    if fps.shape != () or fps.dtype.kind not in "iuf":
        raise ValueError(f"cannot read {str(path)!r}: fps must be a single number")
    metadata = _parse_json(meta_text)
    if metadata is None:
        raise ValueError(f"cannot read {str(path)!r}: metadata is not valid JSON")
    return frames, float(fps), metadata


def _read_png_folder(folder):
    files = {}
    for p in folder.iterdir():
        m = _PNG_NAME.match(p.name)
        if m:
            files[int(m.group(1))] = p
    info = _read_json(folder / "clip.json")
    if info is not None and info.get("unfinished"):
        raise ValueError(
            f"{str(folder)!r} holds an unfinished clip: saving it was interrupted; save it again"
        )
    fps, metadata = _from_file_info(info, folder / "clip.json")
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
    return np.stack(frames), fps, metadata


def _read_gif(path):
    from PIL import ImageSequence, UnidentifiedImageError

    # A folder, a FIFO, a bomb or a file that is no image at all: _open's own words.
    im = _open(path, "path")
    try:
        with im:
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
        fps = 1000.0 / float(np.median(positive)) if positive else None
    color = info.get("color") if ours else None
    if color is False or (color is None and _channels_equal(frames)):
        frames = frames[..., 0]
    return frames, fps, metadata


def read_video(path, *, max_side=None, what=None):
    """Decode a video's first video stream with imageio-ffmpeg into uint8 RGB frames.

    Parameters
    ----------
    path : pathlib.Path
        Any video ffmpeg reads (MP4, WebM, MOV, ...).
    max_side : int, optional
        If the longer side is larger, ffmpeg scales the frames down (area averaging)
        while decoding, so a large video never fills memory at full size.
    what : str, optional
        How error messages name the file; by default ``repr(str(path))``.

    Returns
    -------
    frames : ndarray, shape (T, H, W, 3), uint8
    fps : float
        The stream's frame rate as ffmpeg reports it (two decimals), 0 if unknown.
    scale : float
        Output size over source size (1.0 unless ``max_side`` shrank it).

    Raises
    ------
    ValueError
        If ffmpeg cannot open the file, it holds no frames, or it is truncated or
        damaged: fewer frames decode than the container declares (its duration times
        its frame rate) and ffmpeg's demuxer reports an error reading the stream.
    """
    what = what or f"cannot read {str(path)!r}"
    check_input_file(path, what, "a video file")
    # When ffmpeg has already exited as a reader ends, imageio-ffmpeg drops its pipes
    # without closing them (imageio-ffmpeg issue #61): Python closes them as they are
    # freed, with a ResourceWarning that is not ours to fix. Errors are raised after
    # the ``except`` blocks, so that no traceback keeps a reader alive past this point.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        # One pass reads the size and fps and then the frames; a video larger than
        # max_side is read again, scaled down by ffmpeg.
        meta, data, error = _ffmpeg_read(path, frames=max_side is None)
        scale = 1.0
        if error is None and max_side is not None:
            w, h = meta["size"]
            params = None
            if max(h, w) > max_side:
                scale = max_side / max(h, w)
                w, h = max(1, round(w * scale)), max(1, round(h * scale))
                params = ["-vf", f"scale={w}:{h}:flags=area"]
            meta, data, error = _ffmpeg_read(path, params)
    if error is not None:
        raise ValueError(f"{what}: expected a video ({error})")
    w, h = meta["size"]
    n = len(data) // (w * h * 3)
    if n == 0:
        raise ValueError(f"{what}: the video has no frames")
    _check_complete(path, meta, n, what)
    frames = np.frombuffer(data, np.uint8, count=n * w * h * 3).reshape(n, h, w, 3)
    return frames, float(meta.get("fps") or 0.0), scale


def _check_complete(path, meta, n, what):
    """Refuse a video cut short: fewer frames than its container declares, and errors.

    ffmpeg decodes what there is of a truncated MP4 (its index, at the front with
    ``+faststart``, still declares every frame) and stops without failing: 2 of 24
    frames were converted without a word. Our decision: a user converting or building
    from a video expects all of it, so a short read is an error naming the file, as
    a truncated GIF or .npz is, not a warning beside a clip that silently lacks most
    of its frames. The container's duration can exceed the video's (a longer audio
    track), so a short count alone is not proof: ffmpeg's demuxer is asked to read
    the video stream again without decoding it (cheap), and its error -- "partial
    file" -- is what decides, and what the message quotes.
    """
    duration, fps = meta.get("duration") or 0, meta.get("fps") or 0
    declared = round(float(duration) * float(fps))
    if n >= declared - 1:  # the duration is printed to 1/100 s: allow a frame
        return
    problem = _demux_error(path)
    if problem is not None:
        raise ValueError(
            f"{what}: the video is truncated or damaged: {n} of the {declared} frames its "
            f"container declares could be decoded (ffmpeg: {problem})"
        )


def _demux_error(path):
    """The first error ffmpeg reports reading the video stream of ``path``, or None."""
    import imageio_ffmpeg

    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-v", "error"]
    cmd += ["-i", str(path), "-map", "0:v:0", "-c", "copy", "-f", "null", "-"]
    try:
        run = subprocess.run(cmd, capture_output=True, check=False, timeout=600)
    except (OSError, subprocess.TimeoutExpired):
        return None
    lines = [
        re.sub(r"^\[[^\]]*\]\s*", "", line).strip()  # "[in#0/mov,... @ 0x55...] " prefixes
        for line in run.stderr.decode("utf-8", errors="replace").splitlines()
    ]
    lines = [line for line in lines if line]
    if not lines and run.returncode == 0:
        return None
    partial = [line for line in lines if "partial file" in line]
    return (partial or lines or [f"exit status {run.returncode}"])[0]


def _scaling_is_intended(record):
    return not record.getMessage().startswith("The frame size for reading")


def _ffmpeg_read(path, output_params=None, *, frames=True):
    """Return (metadata dict, RGB24 bytes of all frames or None, None) or an error text.

    :func:`imageio_ffmpeg.read_frames` yields its metadata (``size`` as (W, H),
    ``fps``, ...) before the frames.
    """
    import imageio_ffmpeg

    if output_params:
        # We asked ffmpeg to scale: imageio-ffmpeg's warning that the frames differ in
        # size from the source's is expected, not news for the user.
        logging.getLogger("imageio_ffmpeg").addFilter(_scaling_is_intended)
    reader = imageio_ffmpeg.read_frames(str(path), output_params=output_params)
    try:
        meta = next(reader)
        return meta, b"".join(reader) if frames else None, None
    except (OSError, RuntimeError, IndexError, ValueError, StopIteration) as exc:
        error = _last_lines(str(exc))
    finally:
        reader.close()
    return None, None, error


def _read_mp4(path):
    frames, fps, _ = read_video(path)
    info_path = sidecar(path)
    info = _read_json(info_path)
    if info is None:  # a foreign video: the stream's fps, no metadata
        color = None
        fps = fps if fps > 0 else None
        metadata = {}
    else:
        fps, metadata = _from_file_info(info, info_path)
        shape = info.get("shape")
        if not (
            isinstance(shape, list) and len(shape) == 2 and all(isinstance(s, int) for s in shape)
        ):
            raise ValueError(f"{str(info_path)!r}: damaged clip information (no 'shape')")
        h, w = shape
        padded = (h + h % 2, w + w % 2)
        if info.get("n_frames") != len(frames) or frames.shape[1:3] != padded:
            raise ValueError(
                f"{str(path)!r} holds {len(frames)} frames of "
                f"{frames.shape[2]}x{frames.shape[1]} but {info_path.name} describes "
                f"{info.get('n_frames')} of {w}x{h}: the video is truncated, or was "
                "replaced without its .json"
            )
        frames = frames[:, :h, :w]  # crop the even-size padding
        color = info.get("color")
    if color is False:
        # Chroma is neutral for grey input, but rounding can differ by a level
        # between channels: average them.
        frames = frames.mean(axis=3, dtype=np.float32) / np.float32(255)
    elif color is None and _channels_equal(frames):
        frames = frames[..., 0]
    return frames, fps, metadata


def _channels_equal(frames):
    return bool(
        np.all(frames[..., 0] == frames[..., 1]) and np.all(frames[..., 1] == frames[..., 2])
    )


# ---------------------------------------------------------------------- display


def html_player(frames, fps):
    """Return HTML that plays float frames in a notebook: a looping video or an image.

    One frame becomes a PNG; several an H.264 ``<video>`` (autoplay, loop, muted),
    or an animated GIF if ffmpeg fails. Frames are sized for a notebook cell.
    """
    shown, scale = _display_frames(frames)
    h, w = shown.shape[1:3]
    style = "max-width:100%;height:auto;" + ("image-rendering:pixelated;" if scale > 1 else "")
    size = f'width="{w}" height="{h}" style="{style}"'
    if len(shown) == 1:
        data = _base64_image(shown[0], ".png")
        return f'<img {size} alt="clip frame" src="data:image/png;base64,{data}">'
    try:
        with tempfile.TemporaryDirectory(prefix="fluidnb-") as folder:
            tmp = Path(folder) / "clip.mp4"
            _encode_mp4(tmp, shown, fps, DEFAULT_QUALITY, preset="veryfast")
            data = base64.b64encode(tmp.read_bytes()).decode("ascii")
        return (
            f"<video {size} controls loop autoplay muted playsinline "
            f'src="data:video/mp4;base64,{data}"></video>'
        )
    except Exception:
        # No working ffmpeg (or an encoder failure): an animated GIF plays
        # everywhere, just larger and with a reduced palette.
        data = _base64_image(shown, ".gif", fps=fps)
        return f'<img {size} alt="clip animation" src="data:image/gif;base64,{data}">'


def _base64_image(frames, extension, fps=None):
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
