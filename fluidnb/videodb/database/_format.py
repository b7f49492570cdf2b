"""The video database's format on disk: a zarr v3 store and a JSON manifest (Okabe et al., sec. 4).

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

A chunk's own checksum says nothing of where it belongs: a chunk moved or swapped into
another clip's array decodes as well there. So each clip's record in the manifest
lists, for each of its arrays, the checksum every chunk file ends in, by chunk
(``"chunks": {"frames": "<8 hex digits a chunk>", ...}``, the chunk files' last four
bytes): a chunk that decodes but is not the one written in its place is refused too,
and the message names the place it came from when the database has one. The manifest
seals itself (``"digest"``: SHA-256 of the rest of it, canonical JSON), and the
store's root group records the version it was written as: editing the manifest --
its version down to 1 or 2 to switch these checks off, a clip's table -- makes a
database that does not open.

:func:`read_rows` reads rows so that any such chunk is a ``ValueError`` naming it.

Older versions still open, with the checks they had (their summary says so):
version 1 (before 2026-11-25) had no chunk checksums, version 2 (before 2026-11-28)
no tables. A store's arrays and root group must agree with the version its manifest
states (version 1 arrays carry no checksum codec, version 3's root group says 3), so
neither is a way round the checks. Clips are added to version 3 only.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import threading
from pathlib import Path

import numpy as np

from .._common._geometry import FRAGMENT, GRID, SPECTRA_SIDE, TEXTURE_LEVELS, TEXTURE_SIDE, VERSIONS

__all__ = [
    "BUILD",
    "CHUNK",
    "FORMAT",
    "FORMAT_VERSION",
    "FRAGMENT_ARRAYS",
    "MANIFEST",
    "NO_ROOM",
    "RAM_ARRAYS",
    "READABLE_VERSIONS",
    "STATE",
    "ChunkTables",
    "array_codecs",
    "checksum",
    "chunk_table",
    "clip_group",
    "clip_layout",
    "create_array",
    "fragment_layout",
    "manifest_digest",
    "read_rows",
    "store_attributes",
    "versions_used",
    "write_json_atomically",
    "write_manifest",
    "writing",
]

#: The manifest's ``format`` and the version of the layout this fluidnb writes.
FORMAT = "fluidnb.videodb"


#: 2: every chunk with a CRC-32C checksum, and written even when it is all zeros;
#: 3: each chunk's checksum recorded in the manifest by place, the manifest sealed by
#: its digest, the version in the root group's attributes.
FORMAT_VERSION = 3


#: The versions this fluidnb opens (1: no chunk checksums, 2: no tables of them; each
#: read with the checks it has).
READABLE_VERSIONS = (1, 2, 3)


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


def store_attributes():
    """The root group's attributes: whose store it is, and the version it was written as."""
    return {"fluidnb": FORMAT, "version": FORMAT_VERSION}


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
    with writing(group):
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


#: Why a write failed, for the errors that mean "no room" (see :func:`writing`).
NO_ROOM = {errno.ENOSPC: "the disk is full", errno.EFBIG: "a file size limit, ulimit -f"}
if hasattr(errno, "EDQUOT"):
    NO_ROOM[errno.EDQUOT] = "the disk quota is used up"


@contextlib.contextmanager
def writing(what):
    """Name what is written in an OSError raised meanwhile that names no file.

    zarr's store reports a full disk as ``[Errno 28] No space left on device`` and a
    file size limit (``ulimit -f``) as ``File too large``, naming nothing: the error
    says what was being written (``what``: a path, or a zarr array or group, named by
    its folder) and why.
    """
    try:
        yield
    except OSError as exc:
        if exc.filename is not None or exc.errno is None or "cannot write" in str(exc):
            raise
        if hasattr(what, "store_path"):  # a zarr array or group: its folder
            root = getattr(what.store, "root", None)
            what = Path(root) / what.path if root is not None else str(what.store_path)
        why = f" ({NO_ROOM[exc.errno]})" if exc.errno in NO_ROOM else ""
        raise OSError(exc.errno, f"cannot write {str(what)!r}: {exc.strerror}{why}") from None


def write_json_atomically(path, data):
    """Write ``data`` as JSON to ``path`` through a temporary file and a rename.

    The file is created as every other file of the store (mode 0666 less the umask):
    ``tempfile.mkstemp``'s 0600 kept a database from the other users of a shared
    folder (issue 37). The temporary name starts with ``.<name>.`` (what
    :func:`~fluidnb.videodb.database._folder.folder_state` takes for a writer's) and is
    this thread's own. An OSError names ``path``.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{threading.get_ident()}.tmp")
    text = json.dumps(data, indent=1, sort_keys=True) + "\n"
    try:
        with writing(path):
            with open(tmp, "x", encoding="utf-8") as f:
                f.write(text)
            os.replace(tmp, path)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def manifest_digest(manifest):
    """``"sha256:<hex>"`` of a manifest without its ``"digest"``, as canonical JSON.

    What a manifest of format version 3 seals itself with (:func:`write_manifest`):
    canonical JSON (sorted keys, no spaces, ASCII) of the values as read back, which
    a JSON round trip keeps exactly (Python writes floats in their shortest exact form).
    """
    body = {k: v for k, v in manifest.items() if k != "digest"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return "sha256:" + hashlib.sha256(text.encode("ascii")).hexdigest()


def write_manifest(root, manifest):
    """Seal ``manifest`` with its digest and write it as the database's, atomically."""
    sealed = {k: v for k, v in manifest.items() if k != "digest"}
    sealed["digest"] = manifest_digest(sealed)
    write_json_atomically(Path(root) / MANIFEST, sealed)
    return sealed


# ------------------------------------------------------------------- chunk tables

#: Bytes of the checksum every chunk file of format 2 on ends in (zarr's crc32c codec).
_TAIL = 4


def _tail(file):
    """The checksum a chunk file ends in (its last 4 bytes), or None if it has none."""
    try:
        with open(file, "rb") as f:
            f.seek(-_TAIL, os.SEEK_END)
            return f.read(_TAIL)
    except OSError:  # missing, shorter than 4 bytes, unreadable: the reader says which
        return None


def chunk_table(arr, root):
    """The checksum each chunk file of ``arr`` ends in, in order, as hex (8 digits each).

    What a clip's record keeps of each array (format version 3): read when the build
    has written every chunk, and compared with the chunk files whenever they are read
    (:func:`read_rows`, :func:`~fluidnb.videodb.database._verify.verify_database`).
    """
    tails = []
    for i in range(_n_chunks(arr)):
        tail = _tail(_chunk_file(arr, root, i))
        if tail is None:
            raise ValueError(_chunk_error(arr, root, i, "is missing"))
        tails.append(tail)
    return b"".join(tails).hex()


def _n_chunks(arr):
    return -(-arr.shape[0] // arr.chunks[0])


class ChunkTables:
    """The manifest's tables of a database's chunks: what each place must hold.

    Parameters
    ----------
    clips : list of dict
        The manifest's clip records (format version 3: each with ``"chunks"``).
    """

    def __init__(self, clips):
        self._hex = {clip_group(int(c["index"])): c.get("chunks") or {} for c in clips}
        self._tables = {}
        self._places = None
        self._lock = threading.Lock()

    def expected(self, where):
        """The checksums the chunks of array ``where`` (``"clips/00000/frames"``) end in."""
        table = self._tables.get(where)
        if table is None:
            group, _, name = where.rpartition("/")
            data = bytes.fromhex(self._hex.get(group, {}).get(name, ""))
            table = [data[i : i + _TAIL] for i in range(0, len(data), _TAIL)]
            self._tables[where] = table
        return table

    def check(self, arr, root, i, tail):
        """None if chunk ``i`` of ``arr`` ends in the checksum written there, else why not."""
        table = self.expected(arr.path)
        if tail is not None and i < len(table) and tail == table[i]:
            return None
        return self._misplaced(arr, root, i, tail)

    def _misplaced(self, arr, root, i, tail):
        step = arr.chunks[0]
        try:  # a chunk that does not decode is damaged, not moved: say so
            arr[i * step : (i + 1) * step]
        except Exception as exc:
            return f"cannot be read: {_reason(exc)}"
        here = f"chunk {i} of {arr.path}"
        owners = [place for place in self._owners().get(tail, ()) if place != here]
        if owners:
            return (
                f"is not the chunk written there: it holds {' or '.join(owners[:3])} "
                "(chunks moved, copied or swapped)"
            )
        return (
            "is not the chunk written there: it decodes, but its checksum is that of no "
            "chunk of this database (replaced by other data)"
        )

    def _owners(self):
        """Checksum -> the places whose chunk ends in it (made once, when first needed)."""
        with self._lock:
            if self._places is None:
                places = {}
                for group, arrays in self._hex.items():
                    for name in arrays:
                        for i, tail in enumerate(self.expected(f"{group}/{name}")):
                            places.setdefault(tail, []).append(f"chunk {i} of {group}/{name}")
                self._places = places
            return self._places


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


def _open_array(group, root, name, shape, dtype, version=FORMAT_VERSION):
    """Array ``name`` of the store, checked against the manifest's shape, dtype and version.

    An array of a version-1 manifest carries no checksum codec and one of a later
    version does: a manifest whose version disagrees with its arrays was edited.
    """
    try:
        arr = group[name]
    except Exception:
        if not (Path(root) / name / "zarr.json").is_file():
            raise ValueError(f"db: {str(Path(root) / name)!r} is missing") from None
        raise ValueError(
            f"db: {str(Path(root) / name / 'zarr.json')!r} is damaged; {_rebuild_advice(root)}"
        ) from None
    fits = tuple(arr.shape) == tuple(shape)
    if name.rsplit("/", 1)[-1] in _ON_DEMAND:
        fits = arr.shape[1:] == tuple(shape[1:]) and arr.shape[0] >= shape[0]
    if not fits or str(arr.dtype) != dtype:
        raise ValueError(
            f"db: {str(Path(root) / name)!r} has shape {tuple(arr.shape)} and dtype {arr.dtype}; "
            f"the manifest expects {tuple(shape)} {dtype} (truncated or mismatched store)"
        )
    if has_checksums(arr) != (version >= 2):
        raise ValueError(
            f"db: {str(Path(root) / MANIFEST)!r} says format version {version}, but "
            f"{str(Path(root) / name)!r} was written {'with' if version < 2 else 'without'} "
            "chunk checksums: the manifest was edited or belongs to another store; "
            f"{_rebuild_advice(root)}"
        )
    return arr


def has_checksums(arr):
    """Whether the chunks of ``arr`` end in a CRC-32C (format version 2 on)."""
    from zarr.codecs import Crc32cCodec

    codecs = getattr(getattr(arr, "metadata", None), "codecs", ())
    return any(isinstance(c, Crc32cCodec) for c in codecs)


def read_rows(arr, root, rows, *, checked=True, tables=None):
    """``arr[rows]`` along the first axis, every chunk it needs accounted for.

    zarr reads a missing chunk as its fill value and reports a damaged one as a codec
    error (a checksum mismatch, "error during blosc decompression"): here either is a
    ValueError naming the array, the chunk, its file and what to do -- and so is, with
    ``tables``, a chunk that decodes but is not the one written in its place.

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
    tables : ChunkTables, optional
        The manifest's checksums of every chunk by place (format version 3).
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
    if tables is not None:
        for i in chunks:
            wrong = tables.check(arr, root, i, _tail(_chunk_file(arr, root, i)))
            if wrong is not None:
                raise ValueError(_chunk_error(arr, root, i, wrong))
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


def versions_used(augment):
    """Indices into :data:`VERSIONS` that ``augment`` cuts fragments from."""
    identity = VERSIONS.index((False, 1.0, 0.0))
    if augment == "none":
        return [identity]
    if augment == "flip":
        return [identity, VERSIONS.index((True, 1.0, 0.0))]
    return list(range(len(VERSIONS)))
