"""A video database opened: its manifest, its fragments' features in memory (Okabe et al., sec. 4).

:func:`open_database` checks a database folder (its format:
:mod:`fluidnb.videodb.database._format`) and reads the word maps, motions, spectra and
textureness of every clip sequentially into memory once (the paper's bottleneck was
random disk access for the smoothness terms); the :class:`VideoDatabase` it returns
reads mean images and source frames on demand, and rebuilds fragments' frames through
its frame cache (:mod:`fluidnb.videodb.database._frames`).

A build, an addition of clips or a resume locks the folder (``.fluidnb-lock``, see
``_lock.py``); readers take no lock: a complete database only grows by new clip groups
and a new manifest, so a reader sees the database as it was or as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from ..._progress import Progress
from ..._validation import check_array, check_int
from .._common._geometry import FRAGMENT
from .._common._params import DatabaseParams
from ._folder import pending_addition, read_manifest
from ._format import (
    FORMAT_VERSION,
    RAM_ARRAYS,
    ChunkTables,
    _open_array,
    checksum,
    clip_group,
    clip_layout,
    fragment_layout,
    read_rows,
)

__all__ = ["VideoDatabase", "built_database", "fragment_grey", "load_clip_arrays", "open_database"]


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
    def version(self):
        """The format version of the store (:data:`~._format.FORMAT_VERSION` when built)."""
        return self.manifest.get("version", FORMAT_VERSION)

    @property
    def checked(self):
        """Whether every chunk carries a checksum and must exist (format version 2 on)."""
        return self.version >= 2

    @cached_property
    def tables(self):
        """Each chunk's checksum by place (:class:`~._format.ChunkTables`; version 3 on)."""
        return ChunkTables(self.clips) if self.version >= 3 else None

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
                f"  format version {self.version}: its chunks carry no checksums and a "
                "missing chunk reads as zeros; rebuild the database to have both checked"
            )
        elif self.tables is None:
            lines.append(
                f"  format version {self.version}: a chunk moved or swapped into another "
                "place of the store reads as if it belonged there; rebuild the database to "
                "have every chunk checked against its place"
            )
        pending = pending_addition(self.path, self.manifest)
        if pending is not None:
            names = ", ".join(repr(c["name"]) for c in pending.get("clips", [])) or "clips"
            lines.append(
                f"  an addition of {names} was interrupted: continue it with `fluidnb "
                "videodb add DB CLIPS --resume` and the same clips, or discard it with "
                "`fluidnb videodb add DB --discard` (until then the database is as it was)"
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
            rows = read_rows(arr, self.path, local, checked=self.checked, tables=self.tables)
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
        rows = slice(start, stop)
        return read_rows(arr, self.path, rows, checked=self.checked, tables=self.tables)

    def _array(self, group, clip, name):
        """Array ``name`` of clip ``clip``, checked against the manifest (opened once)."""
        shape, dtype = clip_layout(self.clips[clip], self.params)[name]
        where = f"{clip_group(clip)}/{name}"

        def opener():
            return _open_array(group, self.path, where, shape, dtype, self.version)

        return self.cache.array(where, opener)

    def fragment_frames(self, ids, *, margin=0, grey=False):
        """Rebuild the ``N`` frames of fragments from their source clips.

        Each fragment is re-sampled from its clip's frames with its version's flip,
        scale and rotation (:func:`~fluidnb.videodb.database.sample_version`), exactly as the
        build cut it, with ``margin`` extra pixels of context on every side (clamped
        at the clip's border). Each fragment is rebuilt once, reading only the frames
        its window needs, and kept in :attr:`cache` for the next call
        (:mod:`fluidnb.videodb.database._frames`).

        Parameters
        ----------
        ids : array_like of int
            Fragment indices.
        margin : int
            Context pixels around the 48 x 48 fragment.
        grey : bool
            Luminance only (what rendering needs): the frames are made grey
            (:func:`~fluidnb.videodb.database._frames.luminance`) before they are resampled
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
    version = manifest["version"]
    tables = ChunkTables(clips) if version >= 3 else None
    for done, clip in enumerate(clips):
        first, count = int(clip["first"]), int(clip["fragments"])
        index = int(clip["index"])
        arrays = load_clip_arrays(group, root, index, count, params, version=version, tables=tables)
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


def load_clip_arrays(
    group, root, index, count, params, *, version=FORMAT_VERSION, tables=None, names=RAM_ARRAYS
):
    """Clip ``index``'s :data:`RAM_ARRAYS` (or ``names``) read from the store at ``root``.

    Each array's shape, dtype and codecs checked against ``count`` fragments,
    ``params`` and the format ``version``, each of its chunks accounted for (and with
    ``tables`` checked against its place, :func:`read_rows`); ValueError naming the file.
    """
    layout = fragment_layout(params)
    where = clip_group(index)
    arrays = {}
    for name in names:
        shape, dtype = layout[name]
        arr = _open_array(group, root, f"{where}/{name}", (count, *shape), dtype, version)
        rows = slice(None)
        arrays[name] = read_rows(arr, root, rows, checked=version >= 2, tables=tables)
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


def _folder_size(path):
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())
