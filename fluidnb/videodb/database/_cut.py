"""One clip cut into fragments and their features (Okabe et al., sec. 4): a worker's task.

:func:`clip_fragments` cuts a clip's every temporal window and augmented version into
48 x 48 fragments with their features (:func:`~fluidnb.videodb.database.window_features`)
and dense-SIFT descriptors; :func:`_process_clip` -- what a build runs per clip, on a
local thread or a dask worker -- writes them into the clip's group of the store a whole
chunk at a time, and its count into ``build/done-<i>.json``, so that a resumed build
skips the clips already cut.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._threads import opencv_single_threaded
from ..._validation import parse_json
from .._common._params import DatabaseParams
from ._features import grey
from ._format import (
    BUILD,
    CHUNK,
    FRAGMENT_ARRAYS,
    clip_group,
    create_array,
    fragment_layout,
    versions_used,
    write_json_atomically,
    writing,
)

__all__ = ["clip_fragments"]


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
    from ._augment import VersionSampler
    from ._features import pixel_features
    from ._flow import optical_flow
    from ._sift import dense_sift
    from ._store import fragment_grey
    from ._versions import mirror_order, valid_positions

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
            with writing(arr):
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
        descs = _ChunkWriter(group[f"{BUILD}/{index:05d}"], {"d": ((9, 9, 128), "uint8")})
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
    write_json_atomically(Path(root) / BUILD / f"done-{index:05d}.json", {"fragments": count})


def _read_done(root, index):
    file = Path(root) / BUILD / f"done-{index:05d}.json"
    try:
        return int(parse_json(file.read_text(), file.name)["fragments"])
    except (OSError, ValueError, KeyError, TypeError):  # not done: cut it (again)
        return None
