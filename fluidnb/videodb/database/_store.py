"""The video database on disk (zarr v3 + a JSON manifest) and in memory.

Layout of a database folder::

    zarr.json                 the zarr root group
    manifest.json             format, parameters, codebook, clips, counts (written last)
    clips/00000/frames        (T, H, W, 3) uint8, the source clip as it went in
    clips/00000/mean          (F0, 48, 48, 3) uint8      mean image A
    clips/00000/words         (F0, 9, 9) uint8           visual-word map
    clips/00000/mean_motion   (F0, 2) float32            (dy, dx) px/frame
    clips/00000/motion        (F0, N - 1, 2) float32     the same, per frame pair
    clips/00000/spectra       (F0, NB, 2, 12, 12) float16  motion spectra M^ (Eq. 2)
    clips/00000/texture       (F0, 4, 24, 24) float16    textureness T (Fig. 7)
    clips/00000/source        (F0, 5) int32              clip, version, first frame, row, col
    clips/00001/...

A database is complete when ``manifest.json`` exists: it is written last, atomically,
so an interrupted build never leaves a folder that opens. Fragment ``i`` of the whole
database is fragment ``i - first`` of the clip whose range holds it (clips in order).

Every chunk of every array carries a CRC-32C checksum (zarr's ``crc32c`` codec, after
blosc-lz4), and every chunk is written, even an all-zero one: so a chunk that was
changed, truncated or deleted is found when it is read -- a clear error naming the
array, the chunk and its file, never zeros or garbage in its place.
:func:`verify_database` reads every chunk. Format version 1 (before 2026-11-25) had
neither; such a database still opens, without those checks (its summary says so).

A build, an addition of clips or a resume locks the folder (``.fluidnb-lock``, see
``_lock.py``); readers take no lock: a complete database only grows by new clip groups
and a new manifest, so a reader sees the database as it was or as it is.

:func:`open_database` reads the word maps, motions, spectra and textureness of every
clip sequentially into memory once (the paper's bottleneck was random disk access for
the smoothness terms); mean images and source frames are read on demand.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._progress import Progress
from ..._validation import check_array, check_int
from .._common._geometry import FRAGMENT, GRID, SPECTRA_SIDE, TEXTURE_LEVELS, TEXTURE_SIDE, VERSIONS
from .._common._params import DatabaseParams

__all__ = ["FORMAT", "FORMAT_VERSION", "VideoDatabase", "open_database", "verify_database"]

#: The manifest's ``format`` and the version of the layout this fluidnb writes.
FORMAT = "fluidnb.videodb"
#: 2: every chunk with a CRC-32C checksum, and written even when it is all zeros.
FORMAT_VERSION = 2
#: The versions this fluidnb opens (1: no chunk checksums, read without those checks).
READABLE_VERSIONS = (1, 2)

MANIFEST = "manifest.json"
#: The folder of an unfinished build's or addition's state (and its descriptors).
BUILD = "build"
STATE = "state.json"
#: Fragments per chunk along the first axis (the spec: 256-1024; blosc-lz4).
CHUNK = 512
#: Arrays loaded into memory when a database opens, in this order.
RAM_ARRAYS = ("words", "mean_motion", "motion", "spectra", "texture", "source")
#: Every per-fragment array, as written.
FRAGMENT_ARRAYS = ("mean", *RAM_ARRAYS)


def fragment_layout(params):
    """Shape (after the fragment axis) and dtype of every per-fragment array."""
    return {
        "mean": ((FRAGMENT, FRAGMENT, 3), "uint8"),
        "words": ((GRID, GRID), "uint8"),
        "mean_motion": ((2,), "float32"),
        "motion": ((params.N - 1, 2), "float32"),
        "spectra": ((params.n_bins, 2, SPECTRA_SIDE, SPECTRA_SIDE), "float16"),
        "texture": ((TEXTURE_LEVELS, TEXTURE_SIDE, TEXTURE_SIDE), "float16"),
        "source": ((5,), "int32"),
    }


def clip_group(index):
    """The zarr group path of source clip ``index``."""
    return f"clips/{index:05d}"


def checksum(arrays):
    """SHA-256 over the in-memory arrays of one clip (the order of RAM_ARRAYS)."""
    h = hashlib.sha256()
    for name in RAM_ARRAYS:
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}{a.shape}{a.dtype}".encode())
        h.update(a.data)
    return "sha256:" + h.hexdigest()


def array_codecs(shuffle="shuffle"):
    """The bytes-to-bytes codecs of every array: blosc-lz4, then a CRC-32C checksum."""
    from zarr.codecs import BloscCodec, Crc32cCodec

    return [BloscCodec(cname="lz4", clevel=5, shuffle=shuffle), Crc32cCodec()]


def create_array(group, name, shape, chunks, dtype, *, shuffle="shuffle"):
    """A new array of the store (replacing any of that name), every chunk to be written.

    zarr skips chunks equal to the fill value by default; here every chunk is written,
    so that a missing chunk file always means a damaged store.
    """
    return group.create_array(
        name,
        shape=shape,
        chunks=chunks,
        dtype=dtype,
        compressors=array_codecs(shuffle),
        fill_value=0,
        overwrite=True,
        config={"write_empty_chunks": True},
    )


def write_json_atomically(path, data):
    """Write ``data`` as JSON to ``path`` through a temporary file and a rename."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1, sort_keys=True)
            f.write("\n")
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def read_state(root):
    """The state file of an unfinished build or addition in ``root``, or None."""
    try:
        state = json.loads((Path(root) / BUILD / STATE).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return state if isinstance(state, dict) else None


def pending_addition(root, manifest):
    """The state of an unfinished addition of clips to the database, or None.

    A state left by a build or an addition that did finish (the process stopped
    between writing the manifest and removing ``build/``) is not pending.
    """
    state = read_state(root)
    if state and state.get("mode") == "add" and state.get("base") == len(manifest["clips"]):
        return state
    return None


def folder_state(root):
    """What a folder holds, as :func:`build_database`, :func:`add_clips` and ``info`` see it.

    Returns one of ``"missing"`` (no such folder), ``"file"``, ``"empty"`` (nothing, or
    only lock files), ``"database"`` (a manifest), ``"unfinished"`` (a build's state
    file: resume it), ``"debris"`` (only what a build makes, but no state: a build that
    stopped or was rolled back before it recorded its state; a new build clears it) and
    ``"foreign"`` (anything else: not ours to touch).
    """
    from ._lock import LOCK_FILE, lock_files

    root = Path(root)
    if not root.exists():
        return "missing"
    if not root.is_dir():
        return "file"
    if (root / MANIFEST).is_file():
        return "database"
    state = read_state(root)
    if state is not None and state.get("mode") == "build":
        return "unfinished"
    names = {p.name for p in root.iterdir()}
    names -= set(lock_files())
    names = {n for n in names if not n.startswith((f".{LOCK_FILE}", f".{MANIFEST}."))}
    if not names:
        return "empty"
    if names <= {"zarr.json", "clips", BUILD} and _our_zarr(root):
        return "debris"
    return "foreign"


def _our_zarr(root):
    try:
        meta = json.loads((Path(root) / "zarr.json").read_text(encoding="utf-8"))
        return meta["attributes"]["fluidnb"] == FORMAT
    except (OSError, ValueError, KeyError, TypeError):
        return False


def writer_at_work(root):
    """The lock holder's description if a live process is writing ``root``, else None."""
    from ._lock import LOCK_FILE, describe, holder

    info = holder(Path(root) / LOCK_FILE)
    return None if info is None else describe(info)


def read_manifest(path):
    """Read and check a database's manifest; ValueError naming the file if it is wrong.

    The message for a folder without a manifest says what it holds and what to do, in
    the same words :func:`~fluidnb.videodb.build_database` uses.
    """
    root = Path(path)
    file = root / MANIFEST
    if not root.is_dir():
        raise ValueError(f"db: no such database folder {str(root)!r}")
    if not file.is_file():
        raise ValueError(_not_a_database(root))
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"db: {str(file)!r} is corrupt: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ValueError(f"db: {str(file)!r} is not a fluidnb video database manifest")
    version = manifest.get("version")
    if version not in READABLE_VERSIONS:
        raise ValueError(
            f"db: {str(file)!r} has format version {version!r}; this fluidnb reads versions "
            f"{', '.join(map(str, READABLE_VERSIONS))}: rebuild the database with this version"
        )
    try:
        params = DatabaseParams.from_dict(manifest["params"])
        codebook = np.asarray(manifest["codebook"], dtype=np.float64)
        clips = list(manifest["clips"])
        total = int(manifest["fragments"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"db: {str(file)!r} is incomplete or damaged ({exc})") from None
    if codebook.shape != (params.words, 128) or not np.all(np.isfinite(codebook)):
        raise ValueError(
            f"db: {str(file)!r}: the codebook must be {params.words} x 128 finite numbers, "
            f"got shape {codebook.shape}"
        )
    first = 0
    for i, clip in enumerate(clips):
        if clip.get("index") != i or clip.get("first") != first:
            raise ValueError(f"db: {str(file)!r}: clip {i} is out of order or its range is wrong")
        first += int(clip["fragments"])
    if first != total:
        raise ValueError(
            f"db: {str(file)!r}: the clips hold {first} fragments but the manifest says {total}"
        )
    return manifest, params, codebook


def _not_a_database(root):
    where = repr(str(root))
    state = folder_state(root)
    writer = writer_at_work(root)
    if writer is not None and state in ("unfinished", "debris", "empty"):
        return f"db: {where} is being built right now by {writer}: wait for it to finish"
    if state == "unfinished":
        return (
            f"db: {where} holds an unfinished build (no {MANIFEST}): continue it with "
            "`fluidnb videodb build --resume` and the same clips (build_database(..., "
            "resume=True)), or delete the folder"
        )
    what = {
        "empty": "it is empty; build one into it",
        "debris": "it holds the remains of a build that stopped before recording its "
        "state; building into it again starts afresh",
    }.get(state)
    return f"db: {where} is not a fluidnb video database (no {MANIFEST})" + (
        f": {what}" if what else ""
    )


@dataclass(frozen=True, eq=False)
class VideoDatabase:
    """A video database, opened: its manifest, and its fragments' features in memory.

    Made by :func:`open_database` (or :func:`~fluidnb.videodb.build_database`); read
    only. ``F`` is the number of fragments, ``N`` the frames per fragment.

    Attributes
    ----------
    path : pathlib.Path
        The database folder.
    kind : str
        What the clips show (``"water"``, ``"smoke"``, ``"fire"`` or the user's label).
    params : DatabaseParams
        How it was built.
    codebook : ndarray, shape (k, 128), float64
        The visual words (centres of the SIFT descriptors).
    clips : list of dict
        One record per source clip: ``name``, ``origin``, ``sha256``, ``fps``,
        ``frames``, ``height``, ``width``, ``fragments`` and ``first`` (its first
        fragment's index), in order.
    words : ndarray, shape (F, 9, 9), uint8
    mean_motion : ndarray, shape (F, 2), float32
    motion : ndarray, shape (F, N - 1, 2), float32
    spectra : ndarray, shape (F, NB, 2, 12, 12), float16
    texture : ndarray, shape (F, 4, 24, 24), float16
    source : ndarray, shape (F, 5), int32
        Per fragment: clip index, version (index into :data:`VERSIONS`), first frame,
        row and column of its top-left corner in the version's pixels.
    manifest : dict
        The manifest as read.
    cache : FrameCache
        Decoded source frames and rebuilt fragments kept between renders and
        re-solves (bounded: ``cache.max_bytes``, by default 512 MiB; emptied when the
        store's manifest changes), and the opened store.
    """

    path: Path
    kind: str
    params: DatabaseParams
    codebook: np.ndarray
    clips: list
    words: np.ndarray
    mean_motion: np.ndarray
    motion: np.ndarray
    spectra: np.ndarray
    texture: np.ndarray
    source: np.ndarray
    manifest: dict
    cache: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        if self.cache is None:
            from ._frames import FrameCache, manifest_checksum

            object.__setattr__(self, "cache", FrameCache(self.path, manifest_checksum(self.path)))

    def __len__(self):
        return len(self.words)

    @property
    def checked(self):
        """Whether every chunk carries a checksum and must exist (format version 2 on)."""
        return self.manifest.get("version", FORMAT_VERSION) >= 2

    @functools.cached_property
    def index(self):
        """The :class:`HistogramIndex` of the word maps (built on first use, kept)."""
        from ..assignment._retrieval import HistogramIndex

        return HistogramIndex(self.words, self.params.words, mean_motion=self.mean_motion)

    @property
    def n_fragments(self):
        """``F``, the number of fragments."""
        return len(self.words)

    def __repr__(self):
        return (
            f"VideoDatabase({self.kind!r}, {len(self.clips)} clips, {self.n_fragments} "
            f"fragments, N={self.params.N}, k={self.params.words}, path={str(self.path)!r})"
        )

    # ------------------------------------------------------------------ summary
    def summary(self):
        """A few lines describing the database (what `fluidnb videodb info` prints)."""
        p = self.params
        lines = [
            f"video database {str(self.path)!r}",
            f"  kind {self.kind!r}: {len(self.clips)} clips, {self.n_fragments} fragments "
            f"of 48 x 48 px x {p.N} frames",
            f"  built with flow={p.flow!r}, augment={p.augment!r}, k={p.words} words, "
            f"motion threshold {p.motion_threshold:g} px/frame",
            f"  on disk {_folder_size(self.path) / 1e6:.1f} MB",
        ]
        if not self.checked:
            lines.append(
                f"  format version {self.manifest.get('version')}: its chunks carry no "
                "checksums and a missing chunk reads as zeros; rebuild the database to "
                "have both checked"
            )
        pending = pending_addition(self.path, self.manifest)
        if pending is not None:
            names = ", ".join(repr(c["name"]) for c in pending.get("clips", [])) or "clips"
            lines.append(
                f"  an addition of {names} was interrupted: continue it with `fluidnb "
                "videodb add DB CLIPS --resume` and the same clips (until then the "
                "database is as it was)"
            )
        for c in self.clips:
            lines.append(
                f"  [{c['index']:3d}] {c['name']!r}: {c['frames']} frames {c['height']}x"
                f"{c['width']}, {c['fragments']} fragments ({c['origin']})"
            )
        for s in self.manifest.get("skipped", []):
            lines.append(f"  skipped {s['name']!r}: {s['reason']}")
        return "\n".join(lines)

    # ------------------------------------------------------------------ lookups
    def clip_of(self, ids):
        """Index of the source clip of each fragment id."""
        return self.source[np.asarray(ids), 0].astype(np.int64)

    def _check_ids(self, ids):
        ids = check_array("ids", ids, ndim=(0, 1), dtype_kinds="iu", min_size=0)
        ids = np.atleast_1d(ids).astype(np.int64)
        if ids.size and (ids.min() < 0 or ids.max() >= self.n_fragments):
            raise ValueError(
                f"ids must be fragment indices in [0, {self.n_fragments - 1}], got values in "
                f"[{ids.min()}, {ids.max()}]"
            )
        return ids

    def _group(self):
        self.cache.check()
        return self.cache.group()

    def mean_images(self, ids):
        """The mean images :math:`A` of fragments, float32 (n, 48, 48, 3) in [0, 1]."""
        ids = self._check_ids(ids)
        out = np.empty((len(ids), FRAGMENT, FRAGMENT, 3), np.float32)
        group = self._group()
        for clip in np.unique(self.clip_of(ids)) if len(ids) else ():
            sel = np.flatnonzero(self.clip_of(ids) == clip)
            local = ids[sel] - self.clips[clip]["first"]
            arr = self._array(group, clip, "mean")
            rows = read_rows(arr, self.path, local, checked=self.checked)
            out[sel] = rows.astype(np.float32) / 255.0
        return out

    def clip_frames(self, clip, start=0, stop=None):
        """Frames ``start:stop`` of source clip ``clip`` as uint8 (T, H, W, 3).

        Raises
        ------
        ValueError
            If a chunk of them is missing or damaged (the message names it).
        """
        clip = check_int("clip", clip, 0, len(self.clips) - 1)
        arr = self._array(self._group(), clip, "frames")
        return read_rows(arr, self.path, slice(start, stop), checked=self.checked)

    def _array(self, group, clip, name):
        """Array ``name`` of clip ``clip``, checked against the manifest (opened once)."""
        shape, dtype = clip_layout(self.clips[clip], self.params)[name]
        where = f"{clip_group(clip)}/{name}"
        return self.cache.array(where, lambda: _open_array(group, self.path, where, shape, dtype))

    def fragment_frames(self, ids, *, margin=0, grey=False):
        """Rebuild the ``N`` frames of fragments from their source clips.

        Each fragment is re-sampled from its clip's frames with its version's flip,
        scale and rotation (:func:`~fluidnb.videodb.sample_version`), exactly as the
        build cut it, with ``margin`` extra pixels of context on every side (clamped
        at the clip's border). Each fragment is rebuilt once, reading only the frames
        its window needs, and kept in :attr:`cache` for the next call
        (:mod:`fluidnb.videodb._frames`).

        Parameters
        ----------
        ids : array_like of int
            Fragment indices.
        margin : int
            Context pixels around the 48 x 48 fragment.
        grey : bool
            Luminance only (what rendering needs): the frames are made grey
            (:func:`~fluidnb.videodb._frames.luminance`) before they are resampled
            (both are linear), a third of the work.

        Returns
        -------
        ndarray, shape (n, N, 48 + 2 margin, 48 + 2 margin[, 3]), float32 in [0, 1]
        """
        from ._frames import rebuild_fragments

        ids = self._check_ids(ids)
        margin = check_int("margin", margin, 0, 1024)
        n, side = self.params.N, FRAGMENT + 2 * margin
        out = np.empty((len(ids), n, side, side) + (() if grey else (3,)), np.float32)
        frames = rebuild_fragments(self, ids, margin=margin, grey=grey)
        for i, fid in enumerate(ids.tolist()):
            out[i] = frames[fid]
        return out

    def describe(self, images):
        """Visual-word maps of 48 x 48 images, by the same path as the database's.

        Parameters
        ----------
        images : array_like, shape (n, 48, 48, 3) or (n, 48, 48)
            Fragments (uint8, or floats in [0, 1]); rounded to 8 bits first, as the
            database's mean images were, so a stored mean image describes itself.

        Returns
        -------
        ndarray, shape (n, 9, 9), uint8
        """
        from ._sift import dense_sift
        from ._words import quantise

        return quantise(dense_sift(fragment_grey(images)), self.codebook)


def fragment_grey(images):
    """Grey float32 (n, 48, 48) of fragments rounded to 8 bits (one path for all)."""
    from ..._image import to_float01, to_uint8
    from ._features import grey

    arr = check_array("images", images, ndim=(3, 4))
    if arr.shape[1:3] != (FRAGMENT, FRAGMENT) or (arr.ndim == 4 and arr.shape[3] != 3):
        raise ValueError(f"images must have shape (n, 48, 48[, 3]), got {arr.shape}")
    u8 = arr if arr.dtype == np.uint8 else to_uint8(to_float01(arr, name="images"))
    if u8.ndim == 3:
        return u8.astype(np.float32) / np.float32(255)
    return grey(u8)


def open_database(path, *, progress=None):
    """Open a video database: check it, and load its features into memory.

    Parameters
    ----------
    path : str or os.PathLike
        The database folder (made by :func:`~fluidnb.videodb.build_database`).
    progress : callable, optional
        ``progress(fraction, message)`` while the arrays load.

    Returns
    -------
    VideoDatabase

    Raises
    ------
    ValueError
        If the folder is not a complete database, was made by an incompatible
        version, or a file is missing, truncated or damaged (the message names it).

    Examples
    --------
    >>> open_database("no-such-folder")
    Traceback (most recent call last):
    ...
    ValueError: db: no such database folder 'no-such-folder'
    """
    import zarr

    root = Path(path)
    manifest, params, codebook = read_manifest(root)
    report = Progress(progress)
    layout = fragment_layout(params)
    total = int(manifest["fragments"])
    data = {name: np.empty((total, *layout[name][0]), dtype=layout[name][1]) for name in RAM_ARRAYS}
    try:
        group = zarr.open_group(str(root), mode="r", zarr_format=3)
    except Exception as exc:
        raise ValueError(f"db: {str(root)!r}: cannot open the zarr store ({exc})") from None
    clips = manifest["clips"]
    checked = manifest["version"] >= 2
    for done, clip in enumerate(clips):
        first, count = int(clip["first"]), int(clip["fragments"])
        arrays = load_clip_arrays(group, root, int(clip["index"]), count, params, checked=checked)
        for name in RAM_ARRAYS:
            data[name][first : first + count] = arrays[name]
        report((done + 1) / max(1, len(clips)), f"loaded {clip['name']}")
        if checksum(arrays) != clip.get("checksum"):
            raise ValueError(
                f"db: {str(root / clip_group(int(clip['index'])))!r}: the arrays do not match "
                "the manifest's checksum (a file was changed or damaged); rebuild the database"
            )
    report(1.0, f"{total} fragments loaded")
    return _database(root, manifest, params, codebook, data)


def built_database(path, arrays):
    """A database just built in ``path``, from its clips' arrays already in memory.

    :func:`open_database` without reading every array again: ``arrays`` maps each
    clip's index to its :data:`RAM_ARRAYS` as the build read them back from the store
    (and made the manifest's checksums of).
    """
    root = Path(path)
    manifest, params, codebook = read_manifest(root)
    layout = fragment_layout(params)
    clips = [arrays[int(clip["index"])] for clip in manifest["clips"]]
    data = {
        name: np.concatenate([clip[name] for clip in clips]).astype(layout[name][1], copy=False)
        for name in RAM_ARRAYS
    }
    if len(data["words"]) != int(manifest["fragments"]):
        raise ValueError(f"db: {str(root)!r}: the built arrays do not match its manifest")
    return _database(root, manifest, params, codebook, data)


def load_clip_arrays(group, root, index, count, params, *, checked=True, names=RAM_ARRAYS):
    """Clip ``index``'s :data:`RAM_ARRAYS` (or ``names``) read from the store at ``root``.

    Each array's shape and dtype checked against ``count`` fragments and ``params``,
    each of its chunks accounted for (:func:`read_rows`); ValueError naming the file.
    """
    layout = fragment_layout(params)
    where = clip_group(index)
    arrays = {}
    for name in names:
        shape, dtype = layout[name]
        arr = _open_array(group, root, f"{where}/{name}", (count, *shape), dtype)
        arrays[name] = read_rows(arr, root, slice(None), checked=checked)
    return arrays


def _database(root, manifest, params, codebook, data):
    for arr in data.values():
        arr.setflags(write=False)
    return VideoDatabase(
        path=root,
        kind=str(manifest.get("kind", "")),
        params=params,
        codebook=codebook,
        clips=manifest["clips"],
        manifest=manifest,
        **data,
    )


def clip_layout(clip, params):
    """Shape and dtype of every array of one clip (its manifest record), frames included."""
    count = int(clip["fragments"])
    out = {"frames": ((int(clip["frames"]), int(clip["height"]), int(clip["width"]), 3), "uint8")}
    for name, (shape, dtype) in fragment_layout(params).items():
        out[name] = ((count, *shape), dtype)
    return out


#: Arrays read on demand, by row: more rows than the manifest's are harmless (the
#: benchmark's synthetic store cuts a clip's records but links its whole mean images).
_ON_DEMAND = ("frames", "mean")


def _open_array(group, root, name, shape, dtype):
    try:
        arr = group[name]
    except Exception:
        raise ValueError(f"db: {str(Path(root) / name)!r} is missing") from None
    fits = tuple(arr.shape) == tuple(shape)
    if name.rsplit("/", 1)[-1] in _ON_DEMAND:
        fits = arr.shape[1:] == tuple(shape[1:]) and arr.shape[0] >= shape[0]
    if not fits or str(arr.dtype) != dtype:
        raise ValueError(
            f"db: {str(Path(root) / name)!r} has shape {tuple(arr.shape)} and dtype {arr.dtype}; "
            f"the manifest expects {tuple(shape)} {dtype} (truncated or mismatched store)"
        )
    return arr


def read_rows(arr, root, rows, *, checked=True):
    """``arr[rows]`` along the first axis, every chunk it needs accounted for.

    zarr reads a missing chunk as its fill value and reports a damaged one as a codec
    error (a checksum mismatch, "error during blosc decompression"): here either is a
    ValueError naming the array, the chunk, its file and what to do.

    Parameters
    ----------
    arr : zarr.Array
        An array of the store, chunked along its first axis only.
    root : path-like
        The database folder (the store's root).
    rows : slice or array_like of int
        Rows to read.
    checked : bool
        Refuse missing chunks (format version 2 writes every chunk; version 1 did not
        write all-zero ones).
    """
    step = arr.chunks[0]
    if isinstance(rows, slice):
        start, stop, _ = rows.indices(arr.shape[0])
        chunks = range(start // step, -(-stop // step)) if stop > start else range(0)
    else:
        rows = np.asarray(rows, np.int64)
        chunks = np.unique(rows // step).tolist()
    if checked:
        for i in chunks:
            if not _chunk_file(arr, root, i).is_file():
                raise ValueError(_chunk_error(arr, root, i, "is missing"))
    try:
        return arr[rows] if isinstance(rows, slice) else arr.get_orthogonal_selection((rows,))
    except MemoryError:
        raise
    except Exception as exc:
        bad, reason = _first_bad_chunk(arr, chunks, exc)
        raise ValueError(_chunk_error(arr, root, bad, f"cannot be read: {reason}")) from None


def _chunk_file(arr, root, i):
    key = arr.metadata.encode_chunk_key((i,) + (0,) * (arr.ndim - 1))
    return Path(root) / arr.path / key


def _chunk_error(arr, root, i, what):
    return (
        f"db: {str(root)!r} is damaged: chunk {i} of {arr.path} {what} (file "
        f"{str(_chunk_file(arr, root, i))!r}); {_rebuild_advice(root)}"
    )


def _rebuild_advice(root):
    """What to do about a damaged database: a starter one is rebuilt by fluidnb itself."""
    from ..._cache import cache_dir

    root = Path(root)
    if root.parent == cache_dir() / "videodb":
        kind = root.name.split("-v")[0]
        quick = " --quick" if root.name.endswith("-quick") else ""
        return (
            f"rebuild this starter database: `fluidnb videodb build --starter {kind}{quick} "
            f"--rebuild` (starter_database({kind!r}, rebuild=True))"
        )
    return "rebuild the database from its source clips (`fluidnb videodb build`)"


def _first_bad_chunk(arr, chunks, exc):
    """The first of ``chunks`` that fails to decode, and why (else the first, and ``exc``)."""
    step = arr.chunks[0]
    for i in chunks:
        try:
            arr[i * step : (i + 1) * step]
        except Exception as err:
            return i, _reason(err)
    return next(iter(chunks), 0), _reason(exc)


def _reason(exc):
    if "checksum" in str(exc).lower():
        return "its checksum does not match, the file was changed or truncated"
    return f"{type(exc).__name__}: {exc}"


def verify_database(path, *, progress=None):
    """Read every chunk of a database and list what is wrong (``info --verify``).

    Checks the manifest, then for every clip every array (the frames, the mean images
    and the in-memory arrays): that it exists with the shape the manifest gives, that
    every chunk exists (format version 2 on) and decodes (its checksum matches), and
    that the in-memory arrays match the manifest's SHA-256 of them.

    Parameters
    ----------
    path : str or os.PathLike
        The database folder.
    progress : callable, optional
        ``progress(fraction, message)``.

    Returns
    -------
    list of str
        One line per problem found; empty if the database is intact.

    Raises
    ------
    ValueError
        If the folder is not a database or its manifest is damaged (nothing to verify
        against).
    """
    import zarr

    root = Path(path)
    manifest, params, _ = read_manifest(root)
    checked = manifest["version"] >= 2
    report = Progress(progress)
    try:
        group = zarr.open_group(str(root), mode="r", zarr_format=3)
    except Exception as exc:
        return [f"db: {str(root)!r}: cannot open the zarr store ({exc})"]
    problems = []
    clips = manifest["clips"]
    for k, clip in enumerate(clips):
        where = clip_group(int(clip["index"]))
        arrays, intact = {}, True
        for name, (shape, dtype) in clip_layout(clip, params).items():
            report(k / max(1, len(clips)), f"verifying {clip['name']} ({name})")
            try:
                arr = _open_array(group, root, f"{where}/{name}", shape, dtype)
            except ValueError as exc:
                problems.append(str(exc))
                intact = False
                continue
            found, rows = _verify_chunks(arr, root, checked)
            problems += found
            intact = intact and not found
            if name in RAM_ARRAYS:
                arrays[name] = rows
        # The manifest's SHA-256 of the in-memory arrays: for version 1 the only check
        # of a chunk that is missing (read as zeros), for version 2 one more.
        if intact and checksum(arrays) != clip.get("checksum"):
            problems.append(
                f"db: {str(root / where)!r}: the arrays do not match the manifest's "
                "checksum (a file was changed or damaged); rebuild the database"
            )
    report(1.0, f"verified {len(clips)} clips: {len(problems)} problems")
    return problems


def _verify_chunks(arr, root, checked):
    """Problems of every chunk of ``arr``, and its rows (None if one could not be read)."""
    step, problems, parts = arr.chunks[0], [], []
    for i in range(-(-arr.shape[0] // step)):
        if checked and not _chunk_file(arr, root, i).is_file():
            problems.append(_chunk_error(arr, root, i, "is missing"))
            continue
        try:
            parts.append(arr[i * step : (i + 1) * step])
        except Exception as exc:
            problems.append(_chunk_error(arr, root, i, f"cannot be read: {_reason(exc)}"))
    if problems:
        return problems, None
    return problems, np.concatenate(parts) if parts else arr[...]


def _folder_size(path):
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())


def versions_used(augment):
    """Indices into :data:`VERSIONS` that ``augment`` cuts fragments from."""
    identity = VERSIONS.index((False, 1.0, 0.0))
    if augment == "none":
        return [identity]
    if augment == "flip":
        return [identity, VERSIONS.index((True, 1.0, 0.0))]
    return list(range(len(VERSIONS)))
