r"""A quick, low-resolution frame of an assignment's animation, for live previews.

:func:`render` makes all ``N`` frames at full size from every assigned fragment's
frames with context (Okabe et al., sec. 6). While a person drags :math:`\sigma`,
:math:`\lambda` or :math:`\rho`, an app wants a picture of each new assignment within
a few tens of milliseconds, so :func:`preview_frame` makes **one** frame the same way,
from the same public building blocks, with three shortcuts (beyond the paper):

* each fragment's difference frame is :math:`D_t = F_t - A` with :math:`A` its stored
  mean image (8 bits) and :math:`F_t` one frame rebuilt from its clip, without the
  12 px of context the full render blends with (a fragment's weights fade out inside
  its core anyway);
* the approximate mean image, the histogram matching and the composite run at
  ``scale`` of the target's size (the motion in pixels per frame scaled with it);
* the matte stays still (no :math:`B_i`, whatever :math:`\tau`), the loop's
  cross-fade is left out, and with the flow rendering (``params.rendering ==
  "flow"``, where the library has it) the photo stands still under the difference
  frames instead of moving along the motion (in one frame it has moved a few pixels).

A ``cache`` (a dict the caller keeps) holds the fragments' :math:`D_t` between calls:
the assignments of one retrieval choose among the same candidates, so a drag of a
slider rebuilds only the fragments it brings in.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._progress import Progress
from ..._validation import check_int
from ...fields import downsample
from .._common._geometry import FRAGMENT, STRIDE
from .._common._weights import blend_values, fragment_weights
from ..assignment._assign import Assignment, _check_params
from ..database._augment import sample_version
from ..database._features import grey
from ._blend import blend_differences
from ._colour_axes import colour_axes
from ._composite import composite
from ._histograms import _Matching
from ._motion_blur import motion_blur

__all__ = ["prefetch_preview", "preview_frame"]

#: The key of ``cache`` under which :func:`prefetch_preview` keeps the candidates' grey
#: mean images (fragment id -> (48, 48) float32).
_MEANS = ("mean images",)


def preview_frame(assignment, params=None, *, frame=None, factor=2, levels=None, cache=None):
    r"""One frame of an assignment's animation at low resolution, fast (live previews).

    The rendering of :func:`fluidnb.videodb.render` (Okabe et al., sec. 6) for one
    frame ``t``: the assigned fragments' difference frames :math:`D_t = F_t - A`
    blended with Laplacian pyramids, added to the approximate mean image (the target
    blurred along the assigned motion), histograms matched cell by cell, composited
    through the matte. Beyond the paper, for speed: no context around the fragments,
    :math:`A` from the database's 8-bit mean images, everything after the blend at
    ``scale`` of the size, a still matte and no loop (see the module's notes).

    Parameters
    ----------
    assignment : Assignment
    params : AnimateParams, optional
        The rendering settings (shutter, denoise, cell); default the assignment's.
    frame : int, optional
        Which frame ``t`` of the fragments' ``N`` (default the middle one, ``N // 2``).
    factor : int
        The preview is ``factor`` times smaller than the target on each side (1 to
        8; block means of the target's pixels).
    levels : int, optional
        Pyramid levels of the blend (default the render's; 1, a plain weighted sum,
        is faster).
    cache : dict, optional
        Kept by the caller between calls on assignments of one database and frame:
        fragment id -> its :math:`D_t` (48 x 48), fragments already in it are not
        rebuilt; and the target's photo and matte at the preview's size with their
        colour axes, the blend's weights and the histogram matchings to it (for the latest
        target), made once.

    Returns
    -------
    ndarray, shape (ceil(H / factor), ceil(W / factor), 3), float32 in [0, 1]

    Examples
    --------
    >>> from fluidnb import data
    >>> from fluidnb.videodb import AnimateParams, assign, starter_database
    >>> db = starter_database("water", quick=True)
    >>> photo = data.sample("stream", size=96)
    >>> a = assign(photo, None, db, AnimateParams(candidates=5))
    >>> preview_frame(a, factor=2).shape
    (38, 48, 3)
    """
    if not isinstance(assignment, Assignment):
        raise ValueError(f"assignment must be an Assignment, got {type(assignment).__name__}")
    a = assignment
    params = a.params if params is None else _check_params(params, a.db)
    n = a.db.params.N
    t = n // 2 if frame is None else check_int("frame", frame, 0, n - 1)
    factor = check_int("factor", factor, 1, 8)
    if levels is not None:
        levels = check_int("levels", levels, 1, 8)
    cache = {} if cache is None else cache
    target = a.target
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    ids = a.fragments
    still = _target_constants(target, factor, cache)

    diffs = _difference_frames(a.db, ids, t, cache)
    if levels == 1 and factor > 1 and STRIDE % factor == 0:
        # The one-level blend made small at once (the same block means, see there).
        small = _weighted_sum_shrunk(diffs, target.positions, still.weights, (hc, wc), factor)
    elif levels == 1:
        # A one-level blend is the weighted sum of the fragments with the blend's
        # weights (what blend_differences computes with 9 layer images): one add per
        # fragment.
        small = _shrink(_weighted_sum(diffs, target.positions, still.weights, (hc, wc)), factor)
    else:
        layers = blend_differences(
            diffs[:, None], target.positions, (hc, wc), margin=0, levels=levels
        )
        small = _shrink(layers[0], factor)

    image, matte = still.image, still.matte
    if getattr(params, "rendering", "paper") == "flow":
        # The flow rendering moves the sharp photo and adds the differences, weighted.
        shown = image + np.float32(params.detail) * small[..., None]
    else:
        # The paper's: the differences over the approximate mean image. Pixels per
        # frame shrink with the picture; shutter (frames) and denoise (pixels of blur
        # per px/frame) keep their meaning at any size.
        velocity = blend_values(a.db.mean_motion[ids], target.positions, (hc, wc))
        approx = motion_blur(
            image,
            _shrink(velocity, factor, vector=True),
            shutter=params.shutter,
            denoise=params.denoise,
        )
        shown = approx + small[..., None]
    centre, axes = still.centre, still.axes
    # match_histograms_cells for one frame, the target's side of it made once (kept).
    in_axes = np.ascontiguousarray((shown - centre) @ axes, dtype=np.float32)
    matched = still.matching(max(2, round(params.cell / factor))).match(
        in_axes, np.empty_like(in_axes)
    )
    out = composite((matched @ axes.T + centre)[None], image, matte)[0]
    out = out[: -(-h // factor), : -(-w // factor)]
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def _weighted_sum(diffs, positions, weights, shape):
    r""":math:`\sum_i w_i D_i` over the canvas: one-level blend of (P, 48, 48) frames."""
    d = np.zeros(shape, np.float32)
    for (r, c), wgt, d_t in zip(positions, weights, diffs):
        d[r : r + FRAGMENT, c : c + FRAGMENT] += wgt * d_t
    return d


def _weighted_sum_shrunk(diffs, positions, weights, shape, factor):
    r""":func:`_weighted_sum` shrunk ``factor`` times by block means, made small at once.

    Block means are linear, and each fragment's 48 x 48 core lies on whole blocks (its
    position a multiple of 24, which ``factor`` divides): the block means of the sum
    are the sum of each weighted fragment's block means, added on the small grid a
    quarter of the core (one 24 x 24 cell of the canvas) at a time -- four vector adds
    (the fragments' positions differ) instead of one add of 48 x 48 pixels per
    fragment and a shrink of the whole canvas.
    """
    p, s = len(diffs), STRIDE // factor  # a canvas cell's side, small
    weighted = diffs * weights
    # Block sums as factor^2 strided adds (a mean over axes of a 7-d view: 4x slower).
    sums = np.zeros((p, 2 * s, 2 * s), np.float32)
    for dy in range(factor):
        for dx in range(factor):
            sums += weighted[:, dy::factor, dx::factor]
    blocks = (sums * np.float32(1.0 / factor**2)).reshape(p, 2, s, 2, s)
    gy, gx = (np.asarray(positions) // STRIDE).T
    grid = np.zeros((shape[0] // STRIDE, shape[1] // STRIDE, s, s), np.float32)
    for qy in (0, 1):
        for qx in (0, 1):
            grid[gy + qy, gx + qx] += blocks[:, qy, :, qx, :]
    return grid.transpose(0, 2, 1, 3).reshape(shape[0] // factor, shape[1] // factor)


def _shrink(x, factor, vector=False):
    """``x`` (canvas-sized) ``factor`` times smaller on each side, float32."""
    if factor == 1:
        return x.astype(np.float32, copy=False)
    # The canvas is whole fragments (multiples of 24 px): block means of any factor up
    # to 8 that divides 24 fit (in float32, OpenCV's area resize: a third of the
    # preview's time in float64); others are resized.
    precision = "float32" if FRAGMENT % factor == 0 else "float64"
    return downsample(x.astype(np.float32), factor, vector=vector, precision=precision)


@dataclass(frozen=True)
class _Still:
    """What a target's previews share (kept in the caller's cache).

    Its photo and matte shrunk, their colour axes, the photo in them, the blend's
    weights, and the histogram matchings to the photo (:meth:`matching`).
    """

    target: object
    image: np.ndarray
    matte: np.ndarray
    centre: np.ndarray
    axes: np.ndarray
    in_axes: np.ndarray
    weights: np.ndarray
    matchings: dict = field(default_factory=dict)

    def matching(self, cell):
        """The matching to the photo in its colour axes (:class:`_Matching`), per ``cell``.

        What :func:`match_histograms_cells` makes of the reference for every call (its
        bins, histograms and quantiles per cell: half a preview's matching), kept.
        """
        made = self.matchings.get(cell)
        if made is None:
            made = self.matchings[cell] = _Matching(
                self.in_axes, self.matte.astype(np.float64), cell
            )
        return made


def _target_constants(target, factor, cache):
    """The target's :class:`_Still` at ``factor``, from ``cache`` if made for this target."""
    key = ("target", factor)
    still = cache.get(key)
    if still is None or still.target is not target:
        image, matte = _shrink(target.canvas, factor), _shrink(target.canvas_matte, factor)
        centre, axes = colour_axes(image, matte)
        weights = fragment_weights(target.positions, target.canvas.shape[:2]).astype(np.float32)
        still = cache[key] = _Still(
            target, image, matte, centre, axes, (image - centre) @ axes, weights
        )
    return still


def prefetch_preview(assignment, cache, *, progress=None):
    r"""Read the mean images :math:`A` of all of an assignment's candidates into ``cache``.

    Any re-solve of the assignment (a new :math:`\sigma`, :math:`\lambda` or
    :math:`\rho`) chooses among the same candidates, so once their :math:`A` are in
    the cache a preview of a re-solve reads only one frame per new fragment
    (:math:`D_t = F_t - A`). Reading the mean images a few at a time was about half a
    preview's time while a slider was dragged (9 ms of 16 a step, alone; more beside
    the browser); an app calls this while the values rest after a run.

    Parameters
    ----------
    assignment : Assignment
    cache : dict
        The cache :func:`preview_frame` is given (the grey :math:`A` go under one key
        of it).
    progress : callable, optional
        ``progress(fraction, message)`` after each source clip's candidates; raise
        :class:`fluidnb.Cancelled` to stop (what was read stays in the cache).

    Returns
    -------
    int
        The mean images read (those already in the cache are not read again).
    """
    if not isinstance(assignment, Assignment):
        raise ValueError(f"assignment must be an Assignment, got {type(assignment).__name__}")
    if not isinstance(cache, dict):
        raise ValueError(f"cache must be a dict, got {type(cache).__name__}")
    db = assignment.db
    means = cache.setdefault(_MEANS, {})
    todo = np.array(
        [i for i in np.unique(assignment.candidates).tolist() if i not in means], np.int64
    )
    report = Progress(progress)
    clips = db.clip_of(todo)
    by_clip = np.unique(clips)
    for k, clip in enumerate(by_clip):
        ids = todo[clips == clip]  # one read of each clip's mean images
        for i, mean in zip(ids.tolist(), grey(db.mean_images(ids))):
            means[i] = mean
        report((k + 1) / len(by_clip), f"mean images of the candidates: clip {k + 1}")
    return len(todo)


def _difference_frames(db, ids, t, cache):
    """:math:`D_t = F_t - A` (grey, 48 x 48) of every fragment in ``ids``, (P, 48, 48)."""
    missing = np.unique([i for i in ids.tolist() if i not in cache]).astype(np.int64)
    if len(missing):
        # The mean images prefetch_preview read, the others from the store.
        known = cache.get(_MEANS, {})
        unknown = [i for i in missing.tolist() if i not in known]
        read = {}
        if unknown:  # (no store access at all when prefetch_preview read them all)
            read = dict(zip(unknown, grey(db.mean_images(np.array(unknown, np.int64)))))
        means = [known[i] if i in known else read[i] for i in missing.tolist()]
        source = db.source[missing]
        # One read of frame t of each (clip, window) serves all its fragments.
        keys = source[:, [0, 2]]
        for key in np.unique(keys, axis=0):
            sel = np.flatnonzero((keys == key).all(axis=1))
            clip, start = int(key[0]), int(key[1])
            frames = grey(db.clip_frames(clip, start + t, start + t + 1))
            for s in sel:
                _, version, _, row, col = (int(v) for v in source[s])
                f_t = sample_version(frames, version, origin=(row, col), size=(FRAGMENT, FRAGMENT))
                cache[int(missing[s])] = np.clip(f_t[0], 0.0, 1.0) - means[s]
    return np.stack([cache[i] for i in ids.tolist()]).astype(np.float32)
