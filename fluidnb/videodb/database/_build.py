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
agree on what a folder holds, see :func:`~fluidnb.videodb._store.folder_state`):

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
  a :class:`~fluidnb.videodb._lock.DatabaseBusy` error naming the holder at once.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import shutil
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..._progress import Progress
from ..._threads import opencv_single_threaded, spread_pool, usable_cores
from ..._validation import check_int
from .._common._geometry import FRAGMENT
from .._common._params import DatabaseParams
from ._features import grey
from ._lock import database_lock, lock_files
from ._store import (
    BUILD,
    CHUNK,
    FORMAT,
    FORMAT_VERSION,
    FRAGMENT_ARRAYS,
    MANIFEST,
    RAM_ARRAYS,
    STATE,
    built_database,
    checksum,
    clip_group,
    create_array,
    folder_state,
    fragment_layout,
    load_clip_arrays,
    open_database,
    pending_addition,
    read_manifest,
    versions_used,
    write_json_atomically,
)
from ._video import read_video

__all__ = ["add_clips", "build_database", "clip_fragments"]

_BUILD = BUILD  # the folder of an unfinished build's state and descriptors
_STATE = STATE

#: Fault injection for the tests (tests/faults/): when this environment variable names
#: a point of a build or an addition ("locked", "ingested", "fragments", "codebook",
#: "manifest"), the process stops there the first time -- prints a line to stderr and
#: waits -- so that a test can kill it at exactly that point, or race another process
#: against it. It waits until the file named by ``FLUIDNB_TEST_PAUSE_UNTIL`` exists
#: (if that is set), at most an hour.
PAUSE_ENV = "FLUIDNB_TEST_PAUSE_AT"


def _pause(point):
    if os.environ.get(PAUSE_ENV) != point:
        return
    os.environ.pop(PAUSE_ENV)  # the first time only
    print(f"fluidnb: paused at {point} (pid {os.getpid()})", file=sys.stderr, flush=True)
    until = os.environ.get("FLUIDNB_TEST_PAUSE_UNTIL")
    deadline = time.monotonic() + 3600
    while time.monotonic() < deadline and not (until and os.path.exists(until)):
        time.sleep(0.05)


def clip_fragments(frames, params=None, *, clip=0, versions=None):
    """Cut one clip into fragments and compute their features (Okabe et al., sec. 4).

    Windows of ``N`` frames follow each other every ``N - window_overlap`` frames;
    within each window the optical flow is computed once on the clip and carried to
    every augmented version (:func:`transform_flow`), whose fragments (48 x 48 on the
    stride-24 grid, wholly inside the version) keep their features
    (:func:`window_features`) when at least one pixel moves.

    Parameters
    ----------
    frames : ndarray, shape (T, H, W, 3), uint8
        The clip.
    params : DatabaseParams, optional
    clip : int
        The clip's index, recorded in each fragment's ``source``.
    versions : sequence of int, optional
        Indices into :data:`VERSIONS`; default as ``params.augment`` says.

    Yields
    ------
    dict of ndarray
        One batch per window and version, in that order: the arrays of
        :func:`window_features` plus ``source`` (k, 5) int32 and ``descriptors``
        (k, 9, 9, 128) uint8 (dense SIFT of the rounded mean images).
    """
    from ._augment import VersionSampler, mirror_order, valid_positions
    from ._features import pixel_features
    from ._flow import optical_flow
    from ._sift import dense_sift
    from ._store import fragment_grey

    params = DatabaseParams() if params is None else params
    versions = versions_used(params.augment) if versions is None else list(versions)
    t, h, w = frames.shape[:3]
    n = params.N
    positions = {v: valid_positions((h, w), v) for v in versions}
    positions = {v: p for v, p in positions.items() if len(p)}
    if t < n or not positions:
        return
    for start in range(0, t - n + 1, params.window_step):
        window = frames[start : start + n]
        g = grey(window)
        flow = optical_flow(g, backend=params.flow)
        mean = window.astype(np.float32).mean(axis=0) / np.float32(255)
        # Every version sampled from one prepared copy of the window, each mirror pair
        # once (VersionSampler): the same pixels as sample_version / transform_flow.
        samplers = VersionSampler(g), VersionSampler(mean[None]), VersionSampler(flow, vectors=True)
        batches = {}
        for v in mirror_order(positions):
            stack, colour, motion = (sample(v) for sample in samplers)
            keep, feats = pixel_features(
                stack,
                colour,
                motion,
                positions[v],
                threshold=params.motion_threshold,
                n_bins=params.n_bins,
            )
            if feats is None:
                continue
            kept = positions[v][keep]
            source = np.empty((len(kept), 5), np.int32)
            source[:, 0], source[:, 1], source[:, 2] = clip, v, start
            source[:, 3:] = kept
            feats["source"] = source
            feats["descriptors"] = dense_sift(fragment_grey(feats["mean"]))
            batches[v] = feats
        for v in sorted(batches):  # in the order of the versions
            yield batches[v]


class _ChunkWriter:
    """Append rows to zarr arrays one whole chunk at a time (each chunk written once)."""

    def __init__(self, group, layout):
        self.arrays = {}
        for name, (shape, dtype) in layout.items():
            self.arrays[name] = create_array(group, name, (0, *shape), (CHUNK, *shape), dtype)
        self.pending = {name: [] for name in layout}
        self.n_pending = 0
        self.written = 0

    def add(self, batch):
        for name in self.pending:
            self.pending[name].append(batch[name])
        self.n_pending += len(next(iter(batch.values())))
        while self.n_pending >= CHUNK:
            self._flush(CHUNK)

    def close(self):
        if self.n_pending:
            self._flush(self.n_pending)
        return self.written

    def _flush(self, count):
        for name, parts in self.pending.items():
            rows = np.concatenate(parts) if len(parts) > 1 else parts[0]
            arr = self.arrays[name]
            arr.resize((self.written + count, *arr.shape[1:]))
            arr[self.written : self.written + count] = rows[:count]
            self.pending[name] = [rows[count:]] if len(rows) > count else []
        self.n_pending -= count
        self.written += count


def _process_clip(root, index, params_dict, codebook, frames=None):
    """One clip's fragments: the dask task (runs in a worker thread or process).

    ``frames``: the clip's stored frames, if the caller has them in memory (else read).
    """
    import zarr

    params = DatabaseParams.from_dict(params_dict)
    root = Path(root)
    group = zarr.open_group(str(root), mode="a", zarr_format=3)
    clip = group[clip_group(index)]
    if frames is None:
        frames = clip["frames"][...]
    layout = fragment_layout(params)
    names = [n for n in FRAGMENT_ARRAYS if n != "words"]
    writer = _ChunkWriter(clip, {n: layout[n] for n in names})
    descs = None
    if codebook is None:
        descs = _ChunkWriter(group[f"{_BUILD}/{index:05d}"], {"d": ((9, 9, 128), "uint8")})
        words_writer = None
    else:
        words_writer = _ChunkWriter(clip, {"words": layout["words"]})
    from ._words import quantise

    with opencv_single_threaded():  # the clips run side by side: one thread each
        for batch in clip_fragments(frames, params, clip=index):
            writer.add({n: batch[n] for n in names})
            if descs is not None:
                descs.add({"d": batch["descriptors"]})
            else:
                words_writer.add({"words": quantise(batch["descriptors"], codebook)})
    count = writer.close()
    if descs is not None:
        descs.close()
    else:
        words_writer.close()
    _write_done(root, index, count)
    return count


def _write_done(root, index, count):
    write_json_atomically(Path(root) / _BUILD / f"done-{index:05d}.json", {"fragments": count})


def _read_done(root, index):
    try:
        return int(
            json.loads((Path(root) / _BUILD / f"done-{index:05d}.json").read_text())["fragments"]
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None


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
        :class:`~fluidnb.videodb._lock.DatabaseBusy` (a ValueError) if another process
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
    stored: :func:`~fluidnb.videodb._store.built_database` makes the database of them
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
        with _failing_input(undo, kept="build" if resuming else None, root=root):
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
        :class:`~fluidnb.videodb._lock.DatabaseBusy` if another process is writing it.
    """
    root = Path(getattr(db, "path", db))
    workers = _check_workers(workers)
    sources = _check_sources(sources)
    read_manifest(root)  # a clear error before a lock file is made in a folder that is no database
    with database_lock(root, "adding clips to it"):
        _pause("locked")
        manifest, params, codebook = read_manifest(root)  # as it is now that we hold the lock
        if manifest["version"] != FORMAT_VERSION:
            raise ValueError(
                f"db: {str(root)!r} has format version {manifest['version']} (no chunk "
                f"checksums); clips can be added to version {FORMAT_VERSION} only: rebuild it"
            )
        base = len(manifest["clips"])
        pending = pending_addition(root, manifest) is not None
        if pending and not resume:
            raise ValueError(
                f"db: {str(root)!r} has an unfinished addition of clips: continue it with "
                "--resume (resume=True) and the same clips"
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
        with _failing_input(undo, kept="addition" if pending else None, root=root):
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


# ---------------------------------------------------------------------- stages


class _SourceError(ValueError):
    """A source that cannot go in (unreadable, doubled, not the one a resume expects)."""


class _Ingest:
    """Stores each source's frames as clips/<i>/frames, in order, and its record in the state.

    :meth:`step` stores source ``k``; steps must run in order (each writes the state
    with the records so far). Its errors are :class:`_SourceError`.
    """

    def __init__(self, root, sources, state, resume, max_side, base, known=None):
        import zarr

        self.root, self.sources, self.state = Path(root), sources, state
        self.max_side, self.base = max_side, base
        self.state_file = self.root / _BUILD / _STATE
        self.old = None
        if resume and self.state_file.is_file():
            self.old = json.loads(self.state_file.read_text())
            same = {k: self.old.get(k) for k in ("mode", "kind", "params", "seed", "base")}
            if same != {k: state[k] for k in same}:
                raise _SourceError(
                    f"db: {str(root)!r} holds an unfinished build with other settings "
                    f"({same}); resume it with those, or start in a new folder"
                )
        (self.root / _BUILD).mkdir(parents=True, exist_ok=True)
        self.group = zarr.open_group(str(root), mode="a", zarr_format=3)
        self.records, self.seen = [], dict(known or {})
        # The clips the interrupted run had stored, in order; the ones after may be new.
        self.done_before = (self.old or {}).get("clips", [])

    def __len__(self):
        return len(self.sources)

    def step(self, k):
        """Store source ``k`` (after sources 0 .. k - 1); returns its record."""
        return self.store(k)[0]

    def store(self, k):
        """:meth:`step`, returning the record and the clip's frames as stored (uint8)."""
        root, index = self.root, self.base + k
        src = self.sources[k]
        try:
            if callable(src):  # a clip still in the making: wait for it
                src = src()
            video = read_video(src, max_side=self.max_side)
        except ValueError as exc:
            raise _SourceError(f"sources[{k}]: {exc}") from None
        if video.sha256 in self.seen:
            raise _SourceError(
                f"sources[{k}] ({video.name!r}) is the same clip as "
                f"{self.seen[video.sha256]!r}: each clip goes in once"
            )
        self.seen[video.sha256] = video.name
        rec = {
            "index": index,
            "name": video.name,
            "origin": video.origin,
            "sha256": video.sha256,
            "fps": video.fps,
            "frames": int(video.frames.shape[0]),
            "height": int(video.frames.shape[1]),
            "width": int(video.frames.shape[2]),
            "scaled": video.scaled,
        }
        prev = self.done_before[k] if k < len(self.done_before) else None
        if prev is not None and (prev["sha256"] != video.sha256 or prev["index"] != index):
            raise _SourceError(
                f"db: {str(root)!r}: sources[{k}] ({video.name!r}) is not the clip the "
                "interrupted build had in that place; resume with the same sources in the "
                "same order"
            )
        if prev is None or not _frames_complete(root, self.group, index, video.frames.shape):
            g = self.group.require_group(clip_group(index))
            shape = video.frames.shape
            arr = create_array(g, "frames", shape, (1, *shape[1:]), "uint8", shuffle="bitshuffle")
            arr[...] = video.frames
            # The record goes into the state after the frames are on disk.
            _mark_ingested(root, index)
        self.records.append(rec)
        self.state["clips"] = self.records
        write_json_atomically(self.state_file, self.state)
        _pause("ingested")
        return rec, video.frames

    def finish(self):
        """Check that a resume was given every clip the interrupted run had."""
        if self.old is not None and len(self.old.get("clips", [])) > len(self.records):
            raise _SourceError(
                f"db: {str(self.root)!r}: the interrupted build had {len(self.old['clips'])} "
                f"clips, resume was given {len(self.records)}; resume with the same sources"
            )
        return self.records


def _ingest_and_run(ingest, params, codebook, client, workers, report):
    """Every source stored (in order) and cut into fragments: ``(records, counts)``.

    Locally both run at once (:func:`_pipeline`): the clips are stored one after the
    other (as the state lists them, in order), and each clip is cut into fragments as
    soon as it is stored, on another thread, while the next one is read (or, for a
    starter database, still made). On a cluster the clips are stored here first, then
    sent out.
    """
    n = len(ingest)
    if client is not None:
        read, run = report.split(0.15)
        for k in range(n):
            read(k / n, f"reading clip {k + 1}/{n}")
            ingest.step(k)
        read(1.0, "clips read")
        records = ingest.finish()
        return records, _run_clips(ingest.root, records, params, codebook, client, run)
    return _pipeline(ingest, params, codebook, workers, report)


def _pipeline(ingest, params, codebook, workers, report):
    """:func:`_ingest_and_run` on local threads.

    The clips are stored one after the other on this thread -- each waits here for its
    source to be read or, for a starter database, made -- and each is cut into
    fragments on one of ``workers`` threads as soon as it is stored. A clip still in
    the making holds up only this thread, never a cutting one: every worker cuts
    from the first clips on (when the storing had a worker of its own, the second
    worker waited for all the clips to be made, and ended cutting ~1 s after the
    first). The workers are handed the frames as stored, not read back; a clip is
    stored when one is free or about to be (at most ``workers + 1`` clips' frames in
    memory, whatever the number of sources).
    """
    from concurrent.futures import FIRST_COMPLETED, wait

    root, n = ingest.root, len(ingest)
    if codebook is None:  # the descriptors' groups are made here, once
        import zarr

        zarr.open_group(str(root), mode="a", zarr_format=3).require_group(_BUILD)
    params_dict = params.to_dict()
    cutting = {}  # future -> clip
    read = cut_done = 0

    def tick(message):
        # Reading a clip counts for 1, cutting it for 5: one bar, always forward.
        report(min((read + 5 * cut_done) / (6 * n), 0.999), message)

    def collect(block):
        nonlocal cut_done
        done, _ = wait(list(cutting), timeout=None if block else 0, return_when=FIRST_COMPLETED)
        for job in sorted(done, key=cutting.get):
            k = cutting.pop(job)
            job.result()  # a clip that failed stops the build here
            cut_done += 1
            tick(f"fragments: {cut_done}/{n} clips done ({ingest.records[k]['name']})")
            _pause("fragments")

    report(0.0, f"reading clip 1/{n}")
    # Leaf work (no threads of its own: OpenCV and BLAS are held at one), a clip at a
    # time to whichever worker is free.
    pool = spread_pool(workers, "fluidnb-videodb")
    try:
        for k in range(n):
            while len(cutting) > workers:  # every worker busy and one clip waiting
                collect(block=True)
            record, frames = ingest.store(k)
            read += 1
            tick("clips read" if read == n else f"read clip {read}/{n}")
            job = pool.submit(_cut_clip, str(root), params_dict, codebook, record, frames)
            cutting[job] = k
            del frames  # the worker's, until it has cut the clip
            collect(block=False)
        while cutting:
            collect(block=True)
    finally:
        # On an error or a cancel, let the clips in flight finish writing before
        # returning, so a resume never races a worker still writing.
        pool.shutdown(wait=True, cancel_futures=True)
    records = ingest.finish()
    counts = {r["index"]: _read_done(root, r["index"]) for r in records}
    report(1.0, "fragments done")
    return records, counts


def _cut_clip(root, params_dict, codebook, record, frames):
    """One stored clip's fragments, unless a run before finished them; returns the count."""
    index = record["index"]
    done = _read_done(root, index)
    if done is not None:
        return done
    if codebook is None:
        import zarr

        zarr.open_group(root, mode="a", zarr_format=3)[_BUILD].require_group(f"{index:05d}")
    return _process_clip(root, index, params_dict, codebook, frames)


def _mark_ingested(root, index):
    write_json_atomically(Path(root) / _BUILD / f"ingested-{index:05d}.json", {"index": index})


def _frames_complete(root, group, index, shape):
    if not (Path(root) / _BUILD / f"ingested-{index:05d}.json").is_file():
        return False
    try:
        return tuple(group[f"{clip_group(index)}/frames"].shape) == tuple(shape)
    except Exception:
        return False


def _run_clips(root, records, params, codebook, client, report):
    """Fragments of every clip not done yet, on a dask cluster; returns {index: count}.

    Locally the clips are cut by :func:`_pipeline` (threads, while the next clip is
    stored); this is the cluster's path (``client``: a ``distributed.Client``).
    """
    import dask

    counts = {r["index"]: _read_done(root, r["index"]) for r in records}
    todo = [i for i, c in counts.items() if c is None]
    names = {r["index"]: r["name"] for r in records}
    total = len(records)
    finished = total - len(todo)
    report(finished / total, f"fragments: {finished}/{total} clips done")
    if codebook is None:
        # Groups are made here, once: workers only add arrays to their own group.
        import zarr

        build = zarr.open_group(str(root), mode="a", zarr_format=3).require_group(_BUILD)
        for i in todo:
            build.require_group(f"{i:05d}")
    tasks = {
        i: dask.delayed(_process_clip, pure=False)(str(root), i, params.to_dict(), codebook)
        for i in todo
    }
    by_key = {t.key: i for i, t in tasks.items()}

    def tick(index):
        nonlocal finished
        finished += 1
        report(finished / total, f"fragments: {finished}/{total} clips done ({names[index]})")
        _pause("fragments")

    if tasks:
        from distributed import as_completed

        futures = client.compute(list(tasks.values()))
        try:
            for fut in as_completed(futures):
                fut.result()
                tick(by_key[fut.key])
        except BaseException:
            client.cancel(futures)
            raise
    counts = {i: _read_done(root, i) for i in counts}
    report(1.0, "fragments done")
    return counts


def _import_in_background(*modules):
    """Import ``modules`` on a thread of their own, now, rather than when first used.

    A fresh process building a database imports scikit-learn (~0.5 s of CPU) only
    for the codebook, when every clip has been cut and the other core waits: done
    meanwhile, on cores that are busy anyway, it leaves the end of the build. An
    import that fails here fails again, with its message, where it is used.
    """
    import importlib
    import threading

    def run():
        for name in modules:
            with contextlib.suppress(Exception):
                importlib.import_module(name)

    threading.Thread(target=run, name="fluidnb-import", daemon=True).start()


def _train_codebook(root, counts, params, seed, report):
    """Fit the codebook on a seeded sample of every clip's descriptors."""
    import zarr

    from ._words import fit_codebook

    rows = sum(counts.values()) * 81
    keep = min(1.0, params.codebook_samples / rows)
    group = zarr.open_group(str(root), mode="r", zarr_format=3)
    parts = []
    for i, count in counts.items():
        if not count:
            continue
        d = group[f"{_BUILD}/{i:05d}/d"][...].reshape(-1, 128)
        # Per clip, a generator seeded by (seed, clip): the sample does not depend on
        # the order clips finished in.
        pick = np.random.default_rng([seed, i]).random(len(d)) < keep
        parts.append(d[pick])
        report(len(parts) / len(counts) * 0.3, "sampling descriptors")
    sample = np.concatenate(parts)
    if len(sample) < params.words:
        raise ValueError(
            f"too few fragments: {len(sample)} descriptors cannot train a codebook of "
            f"k = {params.words} words; add clips or lower DatabaseParams.words"
        )
    report(0.3, f"codebook: {params.words} words from {len(sample)} descriptors")
    codebook = fit_codebook(sample, params.words, max_samples=params.codebook_samples, seed=seed)
    report(1.0, "codebook ready")
    return codebook


def _quantise_clips(root, counts, codebook, params, workers):
    """Every clip's visual words, clips side by side on ``workers`` threads.

    :func:`quantise` runs its products on one BLAS thread: OpenBLAS's own threads
    beside ours only slowed it down (measured: 1.5-2x the wall time with two of them
    on two busy cores). The words are the same whatever the threads (it is exact).

    Returns each clip's words as stored (read back), for :func:`_read_back`'s arrays.
    """
    with spread_pool(max(1, min(workers, len(counts))), "fluidnb-words") as pool:
        jobs = {
            i: pool.submit(_quantise_clip, root, i, n, codebook, params) for i, n in counts.items()
        }
        return {i: job.result() for i, job in jobs.items()}


def _quantise_clip(root, index, count, codebook, params):
    import zarr

    from ._words import quantise

    group = zarr.open_group(str(root), mode="a", zarr_format=3)
    writer = _ChunkWriter(group[clip_group(index)], {"words": ((9, 9), "uint8")})
    descs = group[f"{_BUILD}/{index:05d}/d"]
    for lo in range(0, count, CHUNK):
        writer.add({"words": quantise(descs[lo : lo + CHUNK], codebook)})
    writer.close()
    return load_clip_arrays(group, root, index, count, params, names=("words",))["words"]


def _read_back(root, counts, params):
    """Each clip's arrays a database holds in memory (but for its words), from the store.

    The manifest's checksums and the database :func:`build_database` returns are made
    of them (:func:`~fluidnb.videodb._store.built_database`), with the words: read
    here while the codebook is fitted, not again, one clip after the other, at the end.
    """
    import zarr

    group = zarr.open_group(str(root), mode="r", zarr_format=3)
    names = [name for name in RAM_ARRAYS if name != "words"]
    return {i: load_clip_arrays(group, root, i, n, params, names=names) for i, n in counts.items()}


def _manifest(root, kind, params, seed, codebook, records, counts, old_clips=(), arrays=None):
    """The manifest; ``arrays``, each clip's in-memory arrays if the caller has them."""
    import zarr

    from ._store import RAM_ARRAYS

    group = zarr.open_group(str(root), mode="r", zarr_format=3)
    clips = [dict(c) for c in old_clips]
    first = sum(c["fragments"] for c in clips)
    for rec in records:
        count = counts[rec["index"]]
        if arrays is not None:
            held = arrays[rec["index"]]
        else:
            held = {n: group[f"{clip_group(rec['index'])}/{n}"][...] for n in RAM_ARRAYS}
        clip = {**rec, "first": first, "fragments": count, "checksum": checksum(held)}
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
    write_json_atomically(Path(root) / MANIFEST, manifest)
    _pause("manifest")
    shutil.rmtree(Path(root) / _BUILD, ignore_errors=True)


def _roll_back_build(root, created):
    """Undo a build that failed for its input: the folder as it was (gone, or empty).

    The state file goes first, so that a process killed half-way leaves "debris" (see
    :func:`folder_state`) that the next build clears, never a state without its data.
    """
    root = Path(root)
    (root / _BUILD / _STATE).unlink(missing_ok=True)
    for name in ("clips", _BUILD):
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
    (root / _BUILD / _STATE).unlink(missing_ok=True)
    clips = root / "clips"
    for folder in clips.iterdir() if clips.is_dir() else ():
        if folder.name.isdigit() and int(folder.name) >= base:
            shutil.rmtree(folder, ignore_errors=True)
    shutil.rmtree(root / _BUILD, ignore_errors=True)


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
    zarr.open_group(str(root), mode="a", zarr_format=3, attributes={"fluidnb": FORMAT})
    return state == "unfinished"
