r"""Rebuilding fragments' frames from their source clips, and the cache that keeps them.

Rendering (Okabe et al., sec. 6) needs the :math:`N` frames :math:`F_i` of every
assigned fragment, from which it takes the difference frames :math:`D_i = F_i - A`.
The database keeps only the source clips' frames (and each fragment's ``source``:
clip, version, first frame, position), so every fragment is re-sampled from its
clip's frames with its version's flip, scale and rotation, exactly as the build cut it
(:func:`~fluidnb.videodb.database.sample_version`). At the paper's scale this was most of the
rendering: 364 fragments from 116 clip windows, each window's 32 frames decoded from
the store, made grey and re-sampled.

:func:`rebuild_fragments` does it once per fragment and keeps it:

- each fragment is rebuilt once, however many target fragments took it;
- the fragments of one clip are rebuilt together: the frames their windows need are
  read once (runs of frames, one read each), and only those;
- luminance (``grey=True``, what rendering needs) is computed only on the part of the
  frames the clip's fragments read, straight into the pixel-major layout the
  re-sampling kernel reads (:mod:`fluidnb.videodb.database._augment`), so every fragment samples
  the same array: no per-fragment copy or transposition;
- clips are processed on up to two threads (the decoder and the kernels release the
  GIL);
- decoded frames and rebuilt fragments are kept in the database's :class:`FrameCache`
  (bounded in bytes), so a second render of the same assignment, or a render after a
  re-solve that changed a few fragments, rebuilds only what changed.

The values are those of :func:`~fluidnb.videodb.database.sample_version` applied to the frames
made grey by :func:`luminance` (colour: divided by 255), bit for bit.
:func:`luminance` computes :math:`0.2125 R + 0.7154 G + 0.0721 B` element by element,
so a pixel's grey value never depends on which other pixels are converted with it
(numpy's ``frames @ LUMA`` differs from it and from itself across array shapes by a
float32 rounding, 1.2e-7). :func:`fluidnb.videodb.database.reference_fragment_frames` is the
plain version (one fragment at a time, scipy's filters), which the tests compare this
with.
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections import OrderedDict
from concurrent.futures import as_completed
from pathlib import Path

import numpy as np
from numba import njit

from ..._image import LUMA
from ..._progress import Progress
from ..._threads import spread_pool
from ..._validation import check_int
from .._common._geometry import FRAGMENT
from ._augment import _NO_MATRIX, _blur, _gather, _gaussian_kernel
from ._versions import _coordinates, _corners, prefilter_sigma

__all__ = ["CACHE_BYTES", "FrameCache", "luminance", "manifest_checksum", "rebuild_fragments"]

#: Default bound (bytes) of a database's :class:`FrameCache`: the rebuilt fragments of
#: a 640 x 360 target (364 fragments of 32 frames of 72 x 72 luminance, 241 MB) and
#: the frames of a few clips.
CACHE_BYTES = 512 * 2**20
#: Threads that rebuild clips at once.
_WORKERS = 2

_MANIFEST = "manifest.json"


def luminance(frames):
    """Rec. 709 luminance of uint8 RGB frames, float32 in [0, 1], element by element.

    ``(0.2125 R + 0.7154 G + 0.0721 B) / 255`` in float32, each pixel on its own (so
    its value does not depend on the array it is part of).

    Parameters
    ----------
    frames : ndarray, shape (..., 3), uint8

    Returns
    -------
    ndarray, shape (...), float32

    Examples
    --------
    >>> luminance(np.array([[255, 255, 255], [0, 0, 0]], np.uint8)).tolist()
    [1.0, 0.0]
    """
    arr = np.asarray(frames)
    if arr.dtype != np.uint8 or arr.ndim < 1 or arr.shape[-1] != 3:
        raise ValueError(f"frames must be uint8 RGB (..., 3), got {arr.dtype} {arr.shape}")
    f = arr.astype(np.float32)
    grey = f[..., 0] * LUMA[0]
    grey += f[..., 1] * LUMA[1]
    grey += f[..., 2] * LUMA[2]
    grey *= np.float32(1 / 255)
    return grey


# --------------------------------------------------------------------------------- cache


def _stamp(root):
    """What changes when the manifest is rewritten: inode, size, modification time."""
    try:
        st = os.stat(Path(root) / _MANIFEST)
    except OSError:
        return None
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def manifest_checksum(root):
    """SHA-256 of a database's manifest file (None if it cannot be read)."""
    try:
        return "sha256:" + hashlib.sha256((Path(root) / _MANIFEST).read_bytes()).hexdigest()
    except OSError:
        return None


class FrameCache:
    """Decoded source frames and rebuilt fragments of one database, bounded in bytes.

    Owned by a :class:`~fluidnb.videodb.VideoDatabase` (``db.cache``), so it lives as
    long as the opened database and serves every render and re-solve made with it.
    Least recently used entries go first, decoded frames before rebuilt fragments (a
    fragment costs a frame window's decoding and a re-sampling to remake). It also
    keeps the store's opened zarr group and arrays.

    It belongs to one state of the store: before every use it looks at the manifest
    (a file status, then its SHA-256 if the file was rewritten), and when the manifest
    is not the one the cache was filled from -- clips were added, or the database was
    rebuilt -- it empties itself and opens the store afresh.

    Thread-safe: a lock guards every change; two threads missing the same fragment may
    both rebuild it (with the same result).

    Parameters
    ----------
    root : path-like
        The database folder.
    checksum : str or None
        :func:`manifest_checksum` of the manifest the database was opened from.
    max_bytes : int
        The bound; 0 keeps nothing.

    Attributes
    ----------
    hits, misses : int
        Fragments served from the cache and rebuilt (since the last :meth:`clear`).
    """

    def __init__(self, root, checksum, max_bytes=CACHE_BYTES):
        self.root = Path(root)
        self._lock = threading.RLock()
        self._checksum = checksum
        self._stamp = _stamp(self.root)
        self._max = check_int("max_bytes", max_bytes, 0)
        self._frames = OrderedDict()  # (clip, frame) -> uint8 (H, W, 3)
        self._fragments = OrderedDict()  # (id, margin, grey) -> float32 frames
        self._bytes = 0
        self._group = None
        self._arrays = {}
        self.hits = 0
        self.misses = 0

    def __repr__(self):
        return (
            f"FrameCache({len(self._fragments)} fragments, {len(self._frames)} frames, "
            f"{self.nbytes / 2**20:.0f} of {self._max / 2**20:.0f} MiB)"
        )

    @property
    def max_bytes(self):
        """The bound in bytes (settable; lowering it evicts at once)."""
        return self._max

    @max_bytes.setter
    def max_bytes(self, value):
        value = check_int("max_bytes", value, 0)
        with self._lock:
            self._max = value
            self._evict()

    @property
    def nbytes(self):
        """Bytes held (frames and fragments)."""
        return self._bytes

    def clear(self):
        """Drop every frame and fragment (the opened store stays open)."""
        with self._lock:
            self._frames.clear()
            self._fragments.clear()
            self._bytes = 0
            self.hits = self.misses = 0

    def check(self):
        """Empty the cache and reopen the store if the manifest changed since it filled."""
        stamp = _stamp(self.root)
        if stamp == self._stamp and stamp is not None:
            return
        with self._lock:
            checksum = manifest_checksum(self.root)
            if checksum != self._checksum or checksum is None:
                self.clear()
                self._group = None
                self._arrays = {}
                self._checksum = checksum
            self._stamp = stamp

    # -- the store's handles
    def group(self):
        """The store's zarr group, opened once."""
        import zarr

        with self._lock:
            if self._group is None:
                self._group = zarr.open_group(str(self.root), mode="r", zarr_format=3)
            return self._group

    def array(self, key, opener):
        """A zarr array of the store, opened once by ``opener()``."""
        with self._lock:
            arr = self._arrays.get(key)
            if arr is None:
                arr = self._arrays[key] = opener()
            return arr

    # -- entries
    def _get(self, table, key):
        with self._lock:
            value = table.get(key)
            if value is not None:
                table.move_to_end(key)
            return value

    def _put(self, table, key, value):
        value.setflags(write=False)
        if value.nbytes > self._max:
            return
        with self._lock:
            old = table.pop(key, None)
            if old is not None:
                self._bytes -= old.nbytes
            table[key] = value
            self._bytes += value.nbytes
            self._evict()

    def _evict(self):
        # Frames first: cheaper to remake than fragments.
        for table in (self._frames, self._fragments):
            while self._bytes > self._max and table:
                _, value = table.popitem(last=False)
                self._bytes -= value.nbytes

    def frame(self, clip, index):
        return self._get(self._frames, (clip, index))

    def put_frame(self, clip, index, frame):
        self._put(self._frames, (clip, index), frame)

    def fragment(self, key):
        value = self._get(self._fragments, key)
        with self._lock:
            if value is None:
                self.misses += 1
            else:
                self.hits += 1
        return value

    def put_fragment(self, key, frames):
        self._put(self._fragments, key, frames)


# ------------------------------------------------------------------------------- rebuild


def rebuild_fragments(db, ids, *, margin, grey, differences=None, progress=None):
    """Every fragment's frames, rebuilt from its source clip or taken from the cache.

    Parameters
    ----------
    db : VideoDatabase
    ids : ndarray of int64
        Fragment ids (checked by the caller; repeats are rebuilt once).
    margin : int
        Context pixels around the 48 x 48 fragment.
    grey : bool
        Luminance (:func:`luminance`) instead of RGB.
    differences : int, optional
        Instead of the frames, the rendering's difference frames :math:`D_i = F_i -
        A` cross-faded over this many frames, frame-major (grey only): made on the
        rebuild's threads and kept in the cache as they are (a render of the same
        fragments then only plays and blends them, a frame's plane at a time).
    progress : callable, optional
        ``progress(fraction, message)`` after each clip, from the calling thread;
        raising (:class:`fluidnb.Cancelled`) stops the rebuild.

    Returns
    -------
    dict
        Fragment id -> read-only float32 (N, 48 + 2 margin, 48 + 2 margin[, 3]) in
        [0, 1], as :meth:`~fluidnb.videodb.VideoDatabase.fragment_frames` documents;
        with ``differences``, (N - differences, 48 + 2 margin, 48 + 2 margin)
        (:func:`fluidnb.videodb.database._differences.difference_frames`).
    """
    if differences is not None and not grey:
        raise ValueError("differences are made of grey frames: pass grey=True")
    kind = (margin, grey) if differences is None else (margin, grey, "differences", differences)
    report = Progress(progress)
    cache = db.cache
    cache.check()
    out, todo = {}, []
    for fid in np.unique(ids).tolist():
        got = cache.fragment((fid, *kind))
        if got is None:
            todo.append(fid)
        else:
            out[fid] = got
    total = len(out) + len(todo)
    report(len(out) / max(total, 1), f"{len(out)} of {total} fragments from the cache")
    if not todo:
        return out
    todo = np.asarray(todo, np.int64)
    # One job per clip and start (the frames of one fragment time, read once), the
    # largest first: one clip often holds most of the fragments, and a job per clip
    # left the other core idle.
    src = db.source[todo]
    groups = np.unique(src[:, [0, 2]], axis=0)
    jobs = [todo[(src[:, 0] == c) & (src[:, 2] == t)] for c, t in groups]
    jobs.sort(key=len, reverse=True)
    with spread_pool(min(_WORKERS, len(jobs)), "fluidnb-rebuild") as pool:
        futures = [pool.submit(_rebuild_clip, db, job, kind) for job in jobs]
        try:
            for future in as_completed(futures):
                out.update(future.result())
                report(len(out) / total, f"rebuilt {len(out)} of {total} fragments")
        finally:
            for future in futures:
                future.cancel()
    return out


def _rebuild_clip(db, ids, kind):
    """The fragments ``ids`` of one clip: its frames read once, each window sampled.

    ``kind`` is the cache key's tail: ``(margin, grey)``, or ``(margin, True,
    "differences", loop)`` for the rendering's difference frames.
    """
    from ._differences import difference_frames

    margin, grey = kind[:2]
    n, side = db.params.N, FRAGMENT + 2 * margin
    src = db.source[ids]
    clip = int(src[0, 0])
    starts = np.unique(src[:, 2])
    frames = _clip_frames(db, clip, np.unique(starts[:, None] + np.arange(n)))
    shape = next(iter(frames.values())).shape[:2]
    out = {}
    for start in starts.tolist():
        sel = np.flatnonzero(src[:, 2] == start)
        plans = [
            _plan(shape, int(src[s, 1]), int(src[s, 3]) - margin, int(src[s, 4]) - margin, side)
            for s in sel
        ]
        box = (
            min(p["top"] for p in plans),
            max(p["bottom"] for p in plans),
            min(p["left"] for p in plans),
            max(p["right"] for p in plans),
        )
        top, bottom, left, right = box
        part = np.stack([frames[start + t][top:bottom, left:right] for t in range(n)])
        planes = _pixel_major(part, grey)  # (rows, cols, P) float32 on the box
        blurred = _prefiltered(planes, box, plans)
        for s, plan, pre in zip(sel, plans, blurred):
            frag = _sample_planned(planes, box, plan, n, side, grey, pre)
            if len(kind) > 2:
                frag = difference_frames(frag, kind[3])
            key = (int(ids[s]), *kind)
            db.cache.put_fragment(key, frag)
            out[key[0]] = frag
    return out


def _clip_frames(db, clip, wanted):
    """Frames ``wanted`` (sorted indices) of one clip, uint8, from the cache or the store.

    The missing ones are read in runs of consecutive frames, one read each; every frame
    read is put into the cache.
    """
    cache = db.cache
    got = {}
    missing = []
    for f in wanted.tolist():
        frame = cache.frame(clip, f)
        if frame is None:
            missing.append(f)
        else:
            got[f] = frame
    if missing:
        runs = np.split(np.asarray(missing), np.flatnonzero(np.diff(missing) != 1) + 1)
        for run in runs:
            a, b = int(run[0]), int(run[-1]) + 1
            block = _read_frames(db, clip, a, b)
            for i in range(b - a):
                frame = block[i].copy()  # the cache owns its own (a view would pin the block)
                cache.put_frame(clip, a + i, frame)
                got[a + i] = frame
    return got


def _read_frames(db, clip, a, b):
    """Frames ``a:b`` of a clip, uint8: decoded here, or by zarr at the least doubt.

    The frames arrays are chunked one frame per chunk, blosc then (format 2) CRC-32C.
    Each chunk is decoded as zarr would -- the checksum checked by the same
    ``google_crc32c``, blosc by the same ``numcodecs`` -- without zarr's asynchronous
    machinery, which cost as much again per frame (0.54-0.75 ms a frame against
    0.32-0.52 ms, measured on the starter water clips under load 5.7). A chunk that is
    missing, fails its checksum or does not decode to one frame, or an array with any
    other codecs, or (format version 3) one that does not end in the checksum the
    manifest records for its place, is read by
    :meth:`~fluidnb.videodb.VideoDatabase.clip_frames` instead, which fills or refuses
    it and names it as the store does.
    """
    from ._format import _chunk_file

    arr = db._array(db._group(), clip, "frames")
    crc = _direct_codecs(arr)
    if crc is not None:
        out = np.empty((b - a, *arr.shape[1:]), np.uint8)
        table = db.tables.expected(arr.path) if db.tables is not None else None
        if all(
            _decode(_chunk_file(arr, db.path, i), out[i - a], crc, _at(table, i))
            for i in range(a, b)
        ):
            return out
    return db.clip_frames(clip, a, b)


def _at(table, i):
    """The checksum chunk ``i`` must end in, or None: no table (or no such entry: refused)."""
    if table is None:
        return None
    return table[i] if i < len(table) else b""


def _direct_codecs(arr):
    """Whether ``arr``'s chunks end in a CRC-32C (True), do not (False), or None: use zarr.

    Decoded here: uint8 arrays of one frame per chunk whose codecs are bytes, blosc and
    optionally crc32c, nothing else.
    """
    from zarr.codecs import BloscCodec, BytesCodec, Crc32cCodec

    meta = getattr(arr, "metadata", None)
    codecs = tuple(getattr(meta, "codecs", ()))
    if (
        arr.dtype != np.uint8
        or tuple(arr.chunks) != (1, *arr.shape[1:])
        or len(codecs) not in (2, 3)
        or not isinstance(codecs[0], BytesCodec)
        or not isinstance(codecs[1], BloscCodec)
        or (len(codecs) == 3 and not isinstance(codecs[2], Crc32cCodec))
    ):
        return None
    return len(codecs) == 3


def _decode(path, out, crc, expected=None):
    """Decode one chunk file into ``out``; False if it is missing or anything is wrong.

    ``expected``: the checksum the file must end in (the manifest's, for its place).
    """
    import google_crc32c
    from numcodecs import blosc

    try:
        data = np.frombuffer(path.read_bytes(), np.uint8)
    except OSError:
        return False
    if expected is not None and data[-4:].tobytes() != expected:
        return False
    if crc:
        if len(data) < 4:
            return False
        body = data[:-4]
        if google_crc32c.value(body) != int.from_bytes(data[-4:].tobytes(), "little"):
            return False
    else:
        body = data
    # Blosc's header: bytes 4-7 hold the decompressed size.
    if len(body) < 16 or int.from_bytes(body[4:8].tobytes(), "little") != out.nbytes:
        return False
    try:
        blosc.decompress(body, out)
    except Exception:
        return False
    return True


def _plan(shape, version, r0, c0, side):
    """Where a (side x side) window of a version reads the source, as ``_augment._sample``.

    Returns the bilinear corners and weights of every output pixel and the source
    rectangle they read, widened by the prefilter's reach and cut at the source's
    border (see :func:`fluidnb.videodb.database.sample_version`).
    """
    h, w = shape
    y, x = _coordinates(h, w, version, r0, c0, side, side)
    y, x = np.broadcast_arrays(y, x)
    y0, y1, wy = _corners(y, h)
    x0, x1, wx = _corners(x, w)
    kernel = _gaussian_kernel(prefilter_sigma(version))
    reach = len(kernel) - 1
    return {
        "y0": y0, "y1": y1, "wy": wy, "x0": x0, "x1": x1, "wx": wx,
        "kernel": kernel, "reach": reach,
        "top": max(int(y0.min()) - reach, 0), "bottom": min(int(y1.max()) + 1 + reach, h),
        "left": max(int(x0.min()) - reach, 0), "right": min(int(x1.max()) + 1 + reach, w),
    }  # fmt: skip


def _pixel_major(part, grey):
    """uint8 frames (N, rows, cols, 3) as (rows, cols, planes) float32, planes contiguous.

    Planes: the N frames' :func:`luminance` (``grey``), or channel-major colour (plane
    ``c N + t`` is channel ``c`` of frame ``t``, divided by 255), the order
    ``_augment._sample`` gives colour.
    """
    n, rows, cols = part.shape[:3]
    out = np.empty((rows, cols, n if grey else 3 * n), np.float32)
    _to_planes(part, LUMA, grey, out)
    return out


@njit(cache=True, nogil=True)
def _to_planes(part, luma, grey, out):
    """uint8 (N, h, w, 3) -> float32 (h, w, P): :func:`luminance`, or colour / 255."""
    n, h, w = part.shape[:3]
    inv = np.float32(1 / 255)
    scale = np.float32(255.0)
    for t in range(n):
        for r in range(h):
            for c in range(w):
                px = part[t, r, c]
                if grey:
                    v = np.float32(px[0]) * luma[0]
                    v += np.float32(px[1]) * luma[1]
                    v += np.float32(px[2]) * luma[2]
                    out[r, c, t] = v * inv
                else:
                    for ch in range(3):
                        out[r, c, ch * n + t] = np.float32(px[ch]) / scale


def _prefiltered(planes, box, plans):
    """The prefiltered source of each plan (None: not prefiltered), shared where it pays.

    Each fragment's scaled-down version is sampled from the frames blurred by its
    prefilter on its own rectangle (``_sample``). Fragments of one start with the same
    kernel are blurred together on the rectangle around theirs when it is no larger
    than theirs summed: every value read is then the same, bit for bit (the blur
    clamps at the rectangle's edge, and each fragment's rectangle reaches the kernel's
    width beyond what it reads, or ends where the frame does, as the union then does).
    Returns ``(src, (top, left))`` per plan.
    """
    top, _, left, _ = box
    out = [None] * len(plans)
    groups = {}
    for i, plan in enumerate(plans):
        if plan["reach"]:
            groups.setdefault(plan["kernel"].tobytes(), []).append(i)
    for members in groups.values():
        kernel = plans[members[0]]["kernel"]
        rects = np.array(
            [[plans[i][k] for k in ("top", "bottom", "left", "right")] for i in members]
        )
        areas = (rects[:, 1] - rects[:, 0]) * (rects[:, 3] - rects[:, 2])
        t, b = rects[:, 0].min(), rects[:, 1].max()
        lft, rgt = rects[:, 2].min(), rects[:, 3].max()
        if len(members) > 1 and (b - t) * (rgt - lft) <= areas.sum():
            rects = [(t, b, lft, rgt)] * len(members)
        made = {}
        for i, rect in zip(members, map(tuple, rects)):
            if rect not in made:
                t, b, lft, rgt = rect
                made[rect] = (
                    _blur(planes[t - top : b - top, lft - left : rgt - left], kernel),
                    (t, lft),
                )
            out[i] = made[rect]
    return out


def _sample_planned(planes, box, plan, n, side, grey, prefiltered):
    """One fragment sampled from the pixel-major ``planes`` (the ``_augment`` kernels).

    ``prefiltered``: its source blurred by its prefilter and that source's top-left on
    the frame (:func:`_prefiltered`), or None (a version that is not prefiltered).
    """
    top, _, left, _ = box
    n_planes = planes.shape[2]
    if prefiltered is not None:
        src, origin = prefiltered
        width = src.shape[1]
    else:
        src, origin, width = planes, (top, left), planes.shape[1]
    flat = src.reshape(-1, n_planes)
    y0, y1, x0, x1 = plan["y0"], plan["y1"], plan["x0"], plan["x1"]
    k = ((y0 - origin[0]) * width + (x0 - origin[1])).ravel().astype(np.uint32)
    ox = (x1 - x0).ravel().astype(np.uint32)
    oy = ((y1 - y0) * width).ravel().astype(np.uint32)
    fx = plan["wx"].ravel().astype(np.float32)
    fy = plan["wy"].ravel().astype(np.float32)
    out = np.empty((n_planes, side * side), np.float32)
    _gather(flat, k, ox, oy, fx, fy, _NO_MATRIX, out)
    if grey:
        frames = out.reshape(n, side, side)
    else:
        frames = np.ascontiguousarray(np.moveaxis(out.reshape(3, n, side, side), 0, 3))
    np.clip(frames, 0.0, 1.0, out=frames)
    return frames
