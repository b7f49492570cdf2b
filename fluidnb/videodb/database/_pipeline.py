"""The build's stages after the folder is locked: ingest, fragments, codebook, words.

1. **ingest**: each source read once (:func:`~fluidnb.videodb.read_video`) and stored as
   ``clips/<i>/frames``, its record in ``build/state.json`` (:class:`_Ingest`);
2. **fragments**: each clip cut (:mod:`fluidnb.videodb.database._cut`) as soon as it is
   stored, on local threads beside the ingest (:func:`_pipeline`), or on a dask cluster
   after it (:func:`_run_clips`);
3. **codebook**: bisecting k-means on a seeded sample of the descriptors
   (:func:`_train_codebook`);
4. **words**: every fragment's descriptors quantised to its word map
   (:func:`_quantise_clips`), the arrays read back for the manifest's checksums.

What :func:`~fluidnb.videodb.build_database` and :func:`~fluidnb.videodb.add_clips`
share; their transactions (locks, roll-backs, the manifest) are
:mod:`fluidnb.videodb.database._build`'s.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path

import numpy as np

from ..._threads import spread_pool
from ..._validation import parse_json
from ._cut import _ChunkWriter, _process_clip, _read_done
from ._format import (
    BUILD,
    CHUNK,
    RAM_ARRAYS,
    STATE,
    clip_group,
    create_array,
    write_json_atomically,
    writing,
)
from ._store import load_clip_arrays
from ._video import read_video

__all__ = ["PAUSE_ENV"]

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
        self.state_file = self.root / BUILD / STATE
        self.old = None
        if resume and self.state_file.is_file():
            try:
                self.old = parse_json(self.state_file.read_text(), STATE)
            except (OSError, ValueError) as exc:
                raise _SourceError(f"db: {str(self.state_file)!r}: {exc}") from None
            if not isinstance(self.old, dict):
                raise _SourceError(f"db: {str(self.state_file)!r} is not a build's state")
            same = {k: self.old.get(k) for k in ("mode", "kind", "params", "seed", "base")}
            if same != {k: state[k] for k in same}:
                raise _SourceError(
                    f"db: {str(root)!r} holds an unfinished build with other settings "
                    f"({same}); resume it with those, or start in a new folder"
                )
        (self.root / BUILD).mkdir(parents=True, exist_ok=True)
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
            with writing(arr):
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

        zarr.open_group(str(root), mode="a", zarr_format=3).require_group(BUILD)
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

        zarr.open_group(root, mode="a", zarr_format=3)[BUILD].require_group(f"{index:05d}")
    return _process_clip(root, index, params_dict, codebook, frames)


def _mark_ingested(root, index):
    write_json_atomically(Path(root) / BUILD / f"ingested-{index:05d}.json", {"index": index})


def _frames_complete(root, group, index, shape):
    if not (Path(root) / BUILD / f"ingested-{index:05d}.json").is_file():
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

        build = zarr.open_group(str(root), mode="a", zarr_format=3).require_group(BUILD)
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

    The thread is not a daemon: a build stopped with Ctrl-C while the import runs
    lets it finish (~0.5 s) before the interpreter shuts down, instead of tearing
    down a half-loaded compiled extension under it (a daemon thread in the middle of
    an import at shutdown can crash the process, as numba's loader did).
    """
    import importlib
    import threading

    def run():
        for name in modules:
            with contextlib.suppress(Exception):
                importlib.import_module(name)

    thread = threading.Thread(target=run, name="fluidnb-import", daemon=False)
    thread.start()
    return thread


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
        d = group[f"{BUILD}/{i:05d}/d"][...].reshape(-1, 128)
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
    descs = group[f"{BUILD}/{index:05d}/d"]
    for lo in range(0, count, CHUNK):
        writer.add({"words": quantise(descs[lo : lo + CHUNK], codebook)})
    writer.close()
    return load_clip_arrays(group, root, index, count, params, names=("words",))["words"]


def _read_back(root, counts, params):
    """Each clip's arrays a database holds in memory (but for its words), from the store.

    The manifest's checksums and the database :func:`build_database` returns are made
    of them (:func:`~fluidnb.videodb.database._store.built_database`), with the words: read
    here while the codebook is fitted, not again, one clip after the other, at the end.
    """
    import zarr

    group = zarr.open_group(str(root), mode="r", zarr_format=3)
    names = [name for name in RAM_ARRAYS if name != "words"]
    return {i: load_clip_arrays(group, root, i, n, params, names=names) for i, n in counts.items()}
