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
:func:`read_rows` reads rows so that any such chunk is a ``ValueError`` naming it.
Format version 1 (before 2026-11-25) had neither; such a database still opens, without
those checks (its summary says so).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
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
    "RAM_ARRAYS",
    "READABLE_VERSIONS",
    "STATE",
    "array_codecs",
    "checksum",
    "clip_group",
    "clip_layout",
    "create_array",
    "fragment_layout",
    "read_rows",
    "versions_used",
    "write_json_atomically",
]

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


def versions_used(augment):
    """Indices into :data:`VERSIONS` that ``augment`` cuts fragments from."""
    identity = VERSIONS.index((False, 1.0, 0.0))
    if augment == "none":
        return [identity]
    if augment == "flip":
        return [identity, VERSIONS.index((True, 1.0, 0.0))]
    return list(range(len(VERSIONS)))
