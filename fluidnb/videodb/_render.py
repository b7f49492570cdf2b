r"""Rendering an assignment into an animation (Okabe et al., sec. 6).

:func:`render` rebuilds every assigned fragment's frames from its source clip, blends
their difference frames :math:`D_i = F_i - A` (:mod:`fluidnb.videodb._blend`), adds them
to the approximate mean image and matches the histograms
(:mod:`fluidnb.videodb._appearance`), and composites the frames through the static or
moving matte (:mod:`fluidnb.videodb._composite`). The :class:`Animation` it returns keeps
each stage's picture for the lesson.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .._clip import Clip
from .._image import as_image
from .._progress import Progress
from .._validation import check_fps, check_shape_match
from ._appearance import (
    colour_axes,
    frames_from_axes,
    frames_in_axes,
    match_histograms_cells,
    motion_blur,
)
from ._assign import Assignment, _check_params
from ._blend import BLEND_LEVELS, FEATHER, MARGIN, _blend, blend_values
from ._composite import composite, dynamic_matte, inpaint_background
from ._frames import rebuild_fragments
from ._geometry import FRAGMENT

__all__ = ["Animation", "render"]


@dataclass(frozen=True, eq=False)
class Animation:
    """An animated fluid image and how it was made (Okabe et al., secs. 5-6).

    Attributes
    ----------
    clip : Clip
        The animation (the target's size, ``N`` frames, or ``N - loop`` looping).
    assignment : Assignment
        The fragments chosen, with the energy per sweep.
    stages : dict of ndarray
        The rendering's intermediate pictures, for the lesson: ``"differences"`` the
        blended difference frames :math:`D_i` (T, H, W), ``"mean"`` the approximate
        mean image (H, W, 3), ``"unmatched"`` the frames before histogram matching,
        ``"matte"`` the (dynamic) matte :math:`B_i` (T, H, W), ``"background"`` the
        image behind the fluid.
    timings : dict
        Seconds per stage (assignment and rendering).
    """

    clip: Clip
    assignment: Assignment
    stages: dict
    timings: dict


def render(assignment, params=None, *, background=None, fps=24.0, progress=None):
    r"""Render the animation of an assignment (Okabe et al., sec. 6).

    1. Rebuild every assigned fragment's frames from its source clip (with 12 px of
       context) and its difference frames :math:`D_i = F_i - A` (luminance);
    2. with ``loop``, cross-fade their ends into their starts
       (:func:`loop_crossfade`), and blend them with Laplacian pyramids over the
       overlaps (:func:`blend_differences`);
    3. add them to the approximate mean image: the target blurred along the assigned
       motion (:func:`motion_blur`);
    4. match each frame's histograms to the target's cell by cell
       (:func:`match_histograms_cells`), in the principal axes of the target's
       colours (Heeger & Bergen's decorrelation), so no foreign hue appears;
    5. composite through the matte over the untouched image — for ``tau > 0`` through
       the dynamic matte :math:`B_i` (:func:`dynamic_matte`) over the background
       (given, or inpainted behind the fluid, :func:`inpaint_background`).

    Parameters
    ----------
    assignment : Assignment
    params : AnimateParams, optional
        Rendering settings (shutter, denoise, cell, tau, loop); default the
        assignment's.
    background : array_like, shape (H, W, 3), optional
        What shows where a moving outline uncovers the scene (``tau > 0``); default
        the target inpainted under its matte.
    fps : float
        Frame rate of the clip.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    Animation
    """
    if not isinstance(assignment, Assignment):
        raise ValueError(f"assignment must be an Assignment, got {type(assignment).__name__}")
    params = assignment.params if params is None else _check_params(params, assignment.db)
    fps = check_fps(fps)
    db, target = assignment.db, assignment.target
    n = db.params.N
    if params.loop > n // 2:
        raise ValueError(
            f"loop must be <= N/2 = {n // 2} frames for this database, got {params.loop}"
        )
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    if background is not None:
        background = as_image(background, mode="rgb", name="background")
        check_shape_match("background", background, (h, w))
    report = Progress(progress)
    rebuild, blend, mean, match, comp = report.split(0.35, 0.6, 0.7, 0.9)
    clock = {}

    t = time.perf_counter()
    rebuild(0.0, f"rebuilding {len(target)} fragments from their source clips")
    ids = assignment.fragments
    # Each fragment rebuilt once, kept in the database's cache for the next render.
    # D_i = F_i - A (difference_frames), and with ``loop`` already cross-faded: the
    # cross-fade and the blend are both linear maps, one over time, the other over
    # space for each frame alike, so they commute, and fading every fragment's
    # differences first blends T - loop frames instead of T (a quarter less work for
    # the default 8 of 32; the same clip to float32 rounding). Made on the rebuild's
    # threads and kept in the database's cache for the next render.
    rebuilt = rebuild_fragments(
        db, ids, margin=MARGIN, grey=True, differences=params.loop, progress=rebuild
    )
    side = FRAGMENT + 2 * MARGIN
    diffs = np.empty((len(ids), side, side, n - params.loop), np.float32)  # pixel-major
    for i, fid in enumerate(ids.tolist()):
        diffs[i] = rebuilt[fid]
    del rebuilt
    clock["rebuild"] = time.perf_counter() - t

    t = time.perf_counter()
    blend(0.0, "blending the difference frames (Laplacian pyramids)")
    # The private entry: these differences were made just above (finite, checked shape).
    d = _blend(diffs, target.positions, (hc, wc), MARGIN, BLEND_LEVELS, FEATHER)
    del diffs
    clock["blend"] = time.perf_counter() - t

    t = time.perf_counter()
    mean(0.0, "approximate mean image (pseudo motion blur)")
    velocity = blend_values(db.mean_motion[ids], target.positions, (hc, wc))
    approx = motion_blur(target.canvas, velocity, shutter=params.shutter, denoise=params.denoise)
    clock["mean"] = time.perf_counter() - t

    t = time.perf_counter()
    match(0.0, "matching histograms cell by cell")
    # In the target's principal colour axes (Heeger & Bergen 1995 decorrelate colour by
    # PCA): matching R, G and B independently can mix hues the photo does not have (a
    # white-hot flame turned lilac); matching decorrelated axes keeps its colours.
    # The frames are approx + D_i, made in the axes in one pass.
    centre, axes = colour_axes(target.canvas, target.canvas_matte)
    rotated, unmatched = frames_in_axes(approx, d, centre, axes, unmatched=(h, w))
    matched = match_histograms_cells(
        rotated, (target.canvas - centre) @ axes, target.canvas_matte, cell=params.cell
    )
    del rotated
    matched = frames_from_axes(matched, centre, axes)
    clock["match"] = time.perf_counter() - t

    t = time.perf_counter()
    comp(0.0, "compositing")
    if params.tau > 0:
        motion = blend_values(db.motion[ids], target.positions, (hc, wc))  # (Hc, Wc, N - 1, 2)
        motion = np.moveaxis(motion, 2, 0)[: len(matched) - 1]
        matte = dynamic_matte(target.canvas_matte, motion, tau=params.tau)
        if background is None:
            back = inpaint_background(target.canvas, target.canvas_matte)
        else:
            back = target.canvas.copy()
            back[:h, :w] = background
    else:
        matte = target.canvas_matte
        back = target.canvas
    out = composite(matched[:, :h, :w], back[:h, :w], matte[..., :h, :w])
    np.clip(out, 0.0, 1.0, out=out)
    clock["composite"] = time.perf_counter() - t
    comp(1.0, "done")

    timings = {**{f"assign_{k}": v for k, v in assignment.timings.items()}, **clock}
    timings["render"] = sum(clock.values())
    meta = {
        "method": "videodb",
        "params": params.to_dict(),
        "seed": None,
        "timings": timings,
        "database": {
            "path": str(db.path),
            "kind": db.kind,
            "fragments": db.n_fragments,
        },
        "energy": float(assignment.solution.energy),
    }
    # Trusted: a fresh contiguous float32 array in [0, 1] (Clip() would copy and check it).
    clip = Clip._trusted(out, fps, {}).with_metadata(**meta)
    stages = {
        "differences": d[:, :h, :w],
        "mean": np.clip(approx[:h, :w], 0, 1),
        "unmatched": unmatched,
        "matte": (matte if matte.ndim == 3 else np.broadcast_to(matte, (len(out), hc, wc)))[
            :, :h, :w
        ],
        "background": back[:h, :w],
    }
    return Animation(clip=clip, assignment=assignment, stages=stages, timings=timings)
