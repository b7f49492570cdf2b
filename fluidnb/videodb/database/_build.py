"""Building a video database (Okabe et al., sec. 4): clips in, fragments and features out.

The build runs in four stages, each of which can be interrupted and resumed:

1. **ingest** (sequential): each source is read once (:func:`read_video`), scaled down
   if needed and stored as ``clips/<i>/frames``;
2. **fragments** (parallel across clips, on local threads or a dask cluster): per
   clip, optical flow once (:func:`optical_flow`), then for every temporal window and
   augmented version (:func:`sample_version`, :func:`transform_flow`) the fragments'
   features (:func:`window_features`) and dense SIFT descriptors of their mean images;
3. **codebook**: repeated cluster bisectioning on a seeded sample of the descriptors
   (:func:`fit_codebook`), then every descriptor's nearest visual word;
4. **manifest**: parameters, codebook, clips with their fingerprints and checksums,
   written last and atomically — a folder without it is an unfinished build.

Every stage's result depends only on the sources, the parameters and the seed, never
on which worker finished first, so a resumed build ends byte-identical to an
uninterrupted one, and a cluster build equals a local one.

Failures (our decision, so that ``info``, ``build``, ``build --resume`` and ``add``
agree on what a folder holds, see :func:`~fluidnb.videodb.database._folder.folder_state`):

- an interruption (a kill, a cancel, a worker that died, a full disk) leaves a
  resumable state: ``build/state.json`` records the settings and the clips stored so
  far; ``resume=True`` continues it, a plain build refuses the folder and says so;
- a ``ValueError`` -- the sources or settings are wrong (a missing file, a NaN clip,
  the same clip twice, no fragment at all) -- rolls the folder back to what it was:
  nothing (the folder this build made is removed) or, for :func:`add_clips`, the
  database as it was. Retrying cannot help until the input changes. Except on a
  resume, whose state is kept when a source does not match or cannot be read: the
  right sources can still continue it;
- a build or an addition holds the folder's lock (``_lock.py``): a second writer gets
  a :class:`~fluidnb.videodb.database._lock.DatabaseBusy` error naming the holder at once.
"""

from __future__ import annotations

import contextlib
import functools
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..._progress import Progress
from ..._threads import usable_cores
from ..._validation import check_int
from .._common._geometry import FRAGMENT
from .._common._params import DatabaseParams
from ._folder import folder_state, pending_addition, read_manifest
from ._format import (
    BUILD,
    FORMAT,
    FORMAT_VERSION,
    NO_ROOM,
    RAM_ARRAYS,
    STATE,
    checksum,
    chunk_table,
    clip_group,
    clip_layout,
    store_attributes,
    write_manifest,
    writing,
)
from ._lock import database_lock, lock_files
from ._pipeline import (
    _import_in_background,
    _Ingest,
    _ingest_and_run,
    _pause,
    _quantise_clips,
    _read_back,
    _SourceError,
    _train_codebook,
)
from ._store import built_database, open_database

__all__ = ["add_clips", "build_database", "discard_addition"]


def build_database(
    sources,
    path,
    *,
    kind,
    params=None,
    seed=0,
    client=None,
    workers=None,
    resume=False,
    progress=None,
):
    """Build a video database from fluid clips (Okabe et al., sec. 4).

    Parameters
    ----------
    sources : sequence
        The clips: video files, folders of frames, :class:`fluidnb.Clip` objects,
        ``(T, H, W[, 3])`` arrays, or ``(name, source)`` pairs (see
        :func:`read_video`); or functions of no argument that return one, called
        when the clip's turn comes (e.g. ``future.result`` of a clip still being
        made: the clips before it are cut into fragments meanwhile).
    path : str or os.PathLike
        A new (or empty) folder for the database; with ``resume=True``, the folder of
        an interrupted build of the same sources.
    kind : str
        What the clips show: ``"water"``, ``"smoke"``, ``"fire"`` or your own label
        (the paper builds one database per kind of scene).
    params : DatabaseParams, optional
        Fragments, augmentation, flow backend, codebook size.
    seed : int
        Seeds the codebook's sample of descriptors and its clustering: same sources,
        params and seed, same database, byte for byte.
    client : dask.distributed.Client, optional
        Run the per-clip work on this cluster; default: local threads.
    workers : int, optional
        Local threads cutting clips into fragments (default: one per core the process
        may use).
    resume : bool
        Continue an interrupted build in ``path`` (same sources, params and seed).
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop
        (the folder can then be resumed).

    Returns
    -------
    VideoDatabase
        The database, opened.

    Raises
    ------
    ValueError
        For bad arguments, unreadable sources, a folder that is not empty (or holds an
        unfinished build, without ``resume``; or, with ``resume``, another build), the
        same clip given twice, or no fragment at all (every clip too short, too small
        or still): then the folder is left as it was (a resumed build's state is kept
        when a source does not match it). A
        :class:`~fluidnb.videodb.database._lock.DatabaseBusy` (a ValueError) if another process
        is building into or adding to the folder.
    """
    folder, arrays = _build(
        sources,
        path,
        kind=kind,
        params=params,
        seed=seed,
        client=client,
        workers=workers,
        resume=resume,
        progress=progress,
    )
    return built_database(folder, arrays)


def _build(sources, path, *, kind, params, seed, client, workers, resume, progress):
    """:func:`build_database` up to the open database: its folder and clips' arrays.

    ``arrays`` maps each clip's index to the arrays a database holds in memory, as
    stored: :func:`~fluidnb.videodb.database._store.built_database` makes the database of them
    -- after moving the folder, for a starter database built in ``<path>.partial``.
    """
    params = _check_params(params)
    kind = _check_kind(kind)
    seed = check_int("seed", seed, 0)
    workers = _check_workers(workers)
    sources = _check_sources(sources)
    root = Path(path)
    if root.exists() and not root.is_dir():
        raise ValueError(f"path {str(root)!r} exists and is not a folder")
    try:
        root.mkdir(parents=True)
        created = True
    except FileExistsError:
        created = False
    state = {"mode": "build", "kind": kind, "params": params.to_dict(), "seed": seed, "base": 0}
    with database_lock(root, "building it"):
        _pause("locked")
        resuming = _prepare_folder(root, resume)
        report = Progress(progress)
        stage = report.split(0.85, 0.95)
        undo = functools.partial(_roll_back_build, root, created)
        with (
            _no_room(root, "build"),
            _failing_input(undo, kept="build" if resuming else None, root=root),
        ):
            _import_in_background("sklearn.cluster")  # the codebook's, while clips are cut
            ingest = _Ingest(root, sources, state, resuming, params.max_side, base=0)
            records, counts = _ingest_and_run(ingest, params, None, client, workers, stage[0])
            if sum(counts.values()) == 0:
                raise ValueError(f"no fragment: {_why(records)}")
            with ThreadPoolExecutor(1, thread_name_prefix="fluidnb-read") as reader:
                # The arrays the database holds in memory, but for the words, read back
                # while the codebook is fitted (which leaves a core free).
                held = reader.submit(_read_back, root, counts, params)
                codebook = _train_codebook(root, counts, params, seed, stage[1])
                _pause("codebook")
                stage[2](0.0, "visual words")
                words = _quantise_clips(root, counts, codebook, params, workers)
                arrays = held.result()
            for index, clip_words in words.items():
                arrays[index]["words"] = clip_words
            manifest = _manifest(root, kind, params, seed, codebook, records, counts, (), arrays)
            _finish(root, manifest)
        stage[2](1.0, "database ready")
    return root, arrays


@contextlib.contextmanager
def _no_room(root, mode):
    """An OSError for want of room says what it was writing, what is kept and what to do.

    The build or addition stops where the disk filled; its state stays (see the
    module's docstring), so the message says how to continue it -- or, when nothing
    was kept, that a new build starts afresh.
    """
    try:
        yield
    except OSError as exc:
        if exc.errno not in NO_ROOM:
            raise
        text = exc.strerror or ""
        if not text.startswith("cannot write"):  # named by writing(), else the folder
            text = f"cannot write {str(root)!r}: {text or exc} ({NO_ROOM[exc.errno]})"
        if mode == "add":
            then = (
                "the database is as it was; make room, then continue the addition with "
                "`fluidnb videodb add DB CLIPS --resume` (add_clips(..., resume=True)) or "
                "discard it with `fluidnb videodb add DB --discard` (discard_addition)"
            )
        elif folder_state(root) == "unfinished":
            then = (
                "the unfinished build is kept: make room, then continue it with `fluidnb "
                "videodb build OUT CLIPS --resume` (build_database(..., resume=True))"
            )
        else:
            then = "nothing was kept that a build could continue: make room and build again"
        raise OSError(exc.errno, f"{text}; {then}") from None


@contextlib.contextmanager
def _failing_input(undo, *, kept=None, root=None):
    """On a ValueError (the input's fault: retrying cannot help) call ``undo``.

    With ``kept`` (a resume checking its sources against the state), a source that
    is wrong (a :class:`_SourceError`) keeps the state and the message says so: the
    right sources can still continue it.
    """
    try:
        yield
    except ValueError as exc:
        if kept and isinstance(exc, _SourceError):
            raise ValueError(
                f"{exc} (the unfinished {kept} in {str(root)!r} is kept: continue it with "
                "--resume (resume=True) and the right clips)"
            ) from None
        undo()
        raise


def add_clips(db, sources, *, client=None, workers=None, resume=False, progress=None):
    """Add clips to an existing database, with its codebook (Okabe et al., sec. 4).

    Parameters
    ----------
    db : VideoDatabase, str or os.PathLike
        The database (or its folder).
    sources : sequence
        As for :func:`build_database`.
    client, workers, progress
        As for :func:`build_database`.
    resume : bool
        Continue an interrupted addition of the same sources.

    Returns
    -------
    VideoDatabase
        The grown database, opened. Until the addition finishes, the folder keeps
        opening as the database it was; if it fails for its input, it stays so.

    Raises
    ------
    ValueError
        For unreadable sources, a clip already in the database, an unfinished
        addition (without ``resume``), clips that give no fragment at all, or a
        database of format version 1 (rebuild it first). A
        :class:`~fluidnb.videodb.database._lock.DatabaseBusy` if another process is writing it.
    """
    root = Path(getattr(db, "path", db))
    workers = _check_workers(workers)
    sources = _check_sources(sources)
    read_manifest(root)  # a clear error before a lock file is made in a folder that is no database
    with database_lock(root, "adding clips to it"):
        _pause("locked")
        manifest, params, codebook = read_manifest(root)  # as it is now that we hold the lock
        if manifest["version"] != FORMAT_VERSION:
            lacks = "chunk checksums" if manifest["version"] < 2 else "tables of its chunks"
            raise ValueError(
                f"db: {str(root)!r} has format version {manifest['version']} (no {lacks}); "
                f"clips can be added to version {FORMAT_VERSION} only: rebuild it"
            )
        base = len(manifest["clips"])
        pending = pending_addition(root, manifest) is not None
        if pending and not resume:
            raise ValueError(
                f"db: {str(root)!r} has an unfinished addition of clips: continue it with "
                "--resume (resume=True) and the same clips, or discard it with --discard "
                "(discard_addition)"
            )
        if not pending:
            _roll_back_addition(root, base)  # what a finished or failed one left behind
        report = Progress(progress)
        stage = report.split(0.95)
        known = {c["sha256"]: c["name"] for c in manifest["clips"]}
        state = {
            "mode": "add",
            "kind": manifest["kind"],
            "params": params.to_dict(),
            "seed": manifest["seed"],
            "base": base,
        }
        undo = functools.partial(_roll_back_addition, root, base)
        with (
            _no_room(root, "add"),
            _failing_input(undo, kept="addition" if pending else None, root=root),
        ):
            ingest = _Ingest(root, sources, state, pending, params.max_side, base, known)
            records, counts = _ingest_and_run(ingest, params, codebook, client, workers, stage[0])
            if sum(counts.values()) == 0:
                names = ", ".join(repr(r["name"]) for r in records)
                raise ValueError(
                    f"no fragment: none of the clips {names} gives a fragment ({_why(records)})"
                )
            new = _manifest(
                root,
                manifest["kind"],
                params,
                manifest["seed"],
                codebook,
                records,
                counts,
                old_clips=manifest["clips"],
            )
            _finish(root, new)
        stage[1](1.0, "database ready")
        return open_database(root)


def discard_addition(db):
    """Discard an interrupted addition of clips: the database stays as it was.

    An addition that was killed, cancelled or ran out of room leaves its clips' groups
    and its state in the folder (the database opens as it was meanwhile):
    :func:`add_clips` with ``resume=True`` continues it; this removes them instead.

    Parameters
    ----------
    db : VideoDatabase, str or os.PathLike
        The database (or its folder).

    Returns
    -------
    list of str
        The names of the clips whose addition was discarded.

    Raises
    ------
    ValueError
        If the folder is not a database, or has no interrupted addition. A
        :class:`~fluidnb.videodb.database._lock.DatabaseBusy` if another process is
        writing it (an addition under way is not interrupted).
    """
    root = Path(getattr(db, "path", db))
    read_manifest(root)  # a clear error before a lock file is made in a folder that is no database
    with database_lock(root, "discarding an interrupted addition"):
        manifest, _, _ = read_manifest(root)
        pending = pending_addition(root, manifest)
        if pending is None:
            raise ValueError(f"db: {str(root)!r} has no interrupted addition of clips to discard")
        names = [str(c.get("name")) for c in pending.get("clips", [])]
        _roll_back_addition(root, len(manifest["clips"]))
    return names


# ---------------------------------------------------------------------- stages


def _manifest(root, kind, params, seed, codebook, records, counts, old_clips=(), arrays=None):
    """The manifest; ``arrays``, each clip's in-memory arrays if the caller has them."""
    import zarr

    group = zarr.open_group(str(root), mode="r", zarr_format=3)
    clips = [dict(c) for c in old_clips]
    first = sum(c["fragments"] for c in clips)
    for rec in records:
        count = counts[rec["index"]]
        where = clip_group(rec["index"])
        if arrays is not None:
            held = arrays[rec["index"]]
        else:
            held = {n: group[f"{where}/{n}"][...] for n in RAM_ARRAYS}
        clip = {**rec, "first": first, "fragments": count, "checksum": checksum(held)}
        # Where each chunk belongs: the checksum each chunk file ends in, by place.
        clip["chunks"] = {
            name: chunk_table(group[f"{where}/{name}"], root) for name in clip_layout(clip, params)
        }
        if count == 0:
            # Kept (the record says what went in) but it adds nothing: say why.
            clip["note"] = f"no fragment: {_why([rec])}"
        clips.append(clip)
        first += count
    return {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "kind": kind,
        "params": params.to_dict(),
        "seed": seed,
        "fragment": {"size": FRAGMENT, "stride": 24, "grid": 9},
        "codebook": codebook.tolist(),
        "clips": clips,
        "fragments": first,
    }


def _finish(root, manifest):
    import zarr

    group = zarr.open_group(str(root), mode="r+", zarr_format=3)
    if dict(group.attrs) != store_attributes():  # the version the store is written as
        with writing(Path(root) / "zarr.json"):
            group.update_attributes(store_attributes())
    write_manifest(root, manifest)
    _pause("manifest")
    shutil.rmtree(Path(root) / BUILD, ignore_errors=True)


def _roll_back_build(root, created):
    """Undo a build that failed for its input: the folder as it was (gone, or empty).

    The state file goes first, so that a process killed half-way leaves "debris" (see
    :func:`folder_state`) that the next build clears, never a state without its data.
    """
    root = Path(root)
    (root / BUILD / STATE).unlink(missing_ok=True)
    for name in ("clips", BUILD):
        shutil.rmtree(root / name, ignore_errors=True)
    (root / "zarr.json").unlink(missing_ok=True)
    if created:
        # Lock files too (we hold the lock: a process that opened the old lock file
        # finds it unlinked and takes a new one, see _lock.locked), then the folder.
        for name in lock_files():
            (root / name).unlink(missing_ok=True)
        with contextlib.suppress(OSError):  # something else appeared in it: leave it
            root.rmdir()


def _roll_back_addition(root, base):
    """Undo an addition that failed (or clear what an old one left): clips ``>= base`` go."""
    root = Path(root)
    (root / BUILD / STATE).unlink(missing_ok=True)
    clips = root / "clips"
    for folder in clips.iterdir() if clips.is_dir() else ():
        if folder.name.isdigit() and int(folder.name) >= base:
            shutil.rmtree(folder, ignore_errors=True)
    shutil.rmtree(root / BUILD, ignore_errors=True)


def _why(records):
    reasons = []
    for r in records:
        if min(r["height"], r["width"]) < FRAGMENT:
            reasons.append(f"{r['name']!r} is {r['height']}x{r['width']}, smaller than a fragment")
        else:
            reasons.append(
                f"{r['name']!r} ({r['frames']} frames) has no moving 48 x 48 window of N frames"
            )
    return "; ".join(reasons)


# ---------------------------------------------------------------------- checks


def _check_params(params):
    if params is None:
        return DatabaseParams()
    if not isinstance(params, DatabaseParams):
        raise ValueError(f"params must be a DatabaseParams, got {type(params).__name__}")
    return params


def _check_kind(kind):
    if not isinstance(kind, str) or not kind.strip() or len(kind) > 64:
        raise ValueError(
            f"kind must be a short label such as 'water', 'smoke' or 'fire', got {kind!r}"
        )
    return kind.strip()


def _check_workers(workers):
    if workers is None:  # one per core this process may use (a container's share)
        return len(usable_cores())
    return check_int("workers", workers, 1, 1024)


def _check_sources(sources):
    if isinstance(sources, (str, os.PathLike, np.ndarray)) or hasattr(sources, "frames"):
        sources = [sources]
    try:
        sources = list(sources)
    except TypeError:
        raise ValueError(
            f"sources must be a list of clips (paths, Clips, arrays), got {type(sources).__name__}"
        ) from None
    if not sources:
        raise ValueError("sources is empty: give at least one clip")
    return sources


def _prepare_folder(root, resume):
    """Check the destination (locked by us); returns True if an unfinished build resumes."""
    import zarr

    state = folder_state(root)
    if state == "database":
        raise ValueError(
            f"path {str(root)!r} already holds a video database; add clips to it with "
            "add_clips() (`fluidnb videodb add`), or choose a new folder"
        )
    if state == "foreign":
        raise ValueError(
            f"path {str(root)!r} is not empty and holds no unfinished build: choose an "
            "empty or new folder"
        )
    if state == "unfinished" and not resume:
        raise ValueError(
            f"path {str(root)!r} holds an unfinished build: continue it with --resume "
            "(resume=True) and the same clips, or delete the folder"
        )
    if state == "debris":
        _roll_back_build(root, created=False)
    with writing(root / "zarr.json"):
        zarr.open_group(str(root), mode="a", zarr_format=3, attributes={"fluidnb": FORMAT})
    return state == "unfinished"
