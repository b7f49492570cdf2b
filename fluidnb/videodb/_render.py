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
    colours_in_axes,
    frames_from_axes,
    frames_in_axes,
    match_histograms_cells,
    motion_blur,
)
from ._assign import Assignment, _check_params
from ._blend import BLEND_LEVELS, FEATHER, MARGIN, _blend, blend_values, play_loops
from ._composite import _restore_area, composite, dynamic_matte, inpaint_background
from ._desync import mirror_axes, temporal_offsets
from ._flow_render import (
    displacement_maps,
    eulerian_loop,
    extend_outside,
    flow_field,
    flow_timing,
    loop_phases,
)
from ._frames import rebuild_fragments
from ._geometry import FRAGMENT

__all__ = ["Animation", "render"]


@dataclass(frozen=True, eq=False)
class Animation:
    """An animated fluid image and how it was made (Okabe et al., secs. 5-6).

    Attributes
    ----------
    clip : Clip
        The animation (the target's size; the paper's rendering: ``N`` frames, or
        ``N - loop`` looping; the flow rendering: whole repeats of those).
    assignment : Assignment
        The fragments chosen, with the energy per sweep.
    stages : dict of ndarray
        The rendering's intermediate pictures, for the lesson. Both renderings:
        ``"differences"`` the blended difference frames :math:`D_i` (T, H, W),
        ``"unmatched"`` the frames before histogram matching, ``"matte"`` the
        (dynamic) matte :math:`B_i` (T, H, W), ``"background"`` the image behind the
        fluid, ``"offsets"`` each target fragment's temporal offset (P,)
        (:func:`temporal_offsets`) and ``"mirrors"`` its mirror axis (P,)
        (:func:`mirror_axes`). The paper's: ``"mean"`` the approximate mean
        image (H, W, 3). The flow rendering's: ``"velocity"`` the motion field
        (H, W, 2), ``"phase_a"`` and ``"phase_b"`` the two advected phases
        (T, H, W, 3), ``"ages"`` and ``"weights"`` their ages (frames) and weights
        (T, 2), ``"advected"`` their cross-fade (T, H, W, 3).
    timings : dict
        Seconds per stage (assignment and rendering).
    """

    clip: Clip
    assignment: Assignment
    stages: dict
    timings: dict


def render(assignment, params=None, *, background=None, fps=24.0, progress=None):
    r"""Render the animation of an assignment (Okabe et al., sec. 6, or beyond it).

    ``params.rendering`` chooses between the paper's rendering and the flow
    rendering (the default, beyond the paper). The paper's:

    1. Rebuild every assigned fragment's frames from its source clip (with 12 px of
       context) and its difference frames :math:`D_i = F_i - A` (luminance); with
       ``loop``, cross-fade each fragment's end into its start
       (:func:`loop_crossfade`) and start neighbours that share a database fragment
       at different times (:func:`temporal_offsets`, :func:`stagger`; beyond the
       paper);
    2. blend them with Laplacian pyramids over the overlaps
       (:func:`blend_differences`);
    3. add them to the approximate mean image: the target blurred along the assigned
       motion (:func:`motion_blur`);
    4. match each frame's histograms to the target's cell by cell
       (:func:`match_histograms_cells`), in the principal axes of the target's
       colours (Heeger & Bergen's decorrelation), so no foreign hue appears;
    5. composite through the matte over the untouched image — for ``tau > 0`` through
       the dynamic matte :math:`B_i` (:func:`dynamic_matte`) over the background
       (given, or filled behind the fluid with the photo's texture,
       :func:`inpaint_background`).

    The flow rendering keeps steps 1, 2, 4 and 5 and replaces 3: the photo itself is
    moved along the motion field of the chosen fragments (:func:`flow_field`) in a
    seamless Eulerian loop (:func:`eulerian_loop`, :func:`flow_timing`), and the
    :math:`D_i`, played at the painted speed, are added on top (``detail``); a
    moving matte is carried by the same loop.

    Parameters
    ----------
    assignment : Assignment
    params : AnimateParams, optional
        Rendering settings (rendering, shutter, denoise, cell, tau, loop, travel,
        detail); default the assignment's.
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
    # Each fragment's D_i = F_i - A, with ``loop`` made a loop of its own (its end
    # cross-faded into its start; difference_frames): made on the rebuild's threads,
    # each fragment once, and kept in the database's cache for the next render.
    looped = rebuild_fragments(
        db, ids, margin=MARGIN, grey=True, differences=params.loop, progress=rebuild
    )
    offsets = np.zeros(len(ids), np.int64)
    mirrors = np.full(len(ids), -1, np.int8)
    rates = n_frames = None
    flow = _flow_plan(assignment, params, n) if params.rendering == "flow" else None
    if params.loop:
        # Beyond the paper: neighbours that share a database fragment start its loop at
        # different times and mirrored (no tile pattern).
        offsets = temporal_offsets(ids, target.positions, n - params.loop)
        mirrors = mirror_axes(ids, target.positions, db.mean_motion[ids])
        if flow is not None and not np.all(flow["rates"] == 1):
            # Fragments play at different rates: make all the clip's frames before the
            # blend. At rate 1 the blended loop is simply repeated (see _render_flow).
            rates, n_frames = flow["rates"], flow["n_frames"]
    # Every fragment's loop played from its offset, mirrored, at its rate (what
    # stagger does), pixel-major as the blend reads it.
    diffs = play_loops(
        [looped[f] for f in ids.tolist()], offsets, rates=rates, n_frames=n_frames, mirrors=mirrors
    )
    del looped
    clock["rebuild"] = time.perf_counter() - t

    t = time.perf_counter()
    blend(0.0, "blending the difference frames (Laplacian pyramids)")
    # The private entry: these differences were made just above (finite, checked shape).
    d = _blend(diffs, target.positions, (hc, wc), MARGIN, BLEND_LEVELS, FEATHER)
    del diffs
    clock["blend"] = time.perf_counter() - t
    if flow is not None:
        out, stages, flow_clock = _render_flow(
            assignment, params, d, flow, background, report.sub(0.6, 1.0)
        )
        clock.update(flow_clock)
        return _animation(assignment, params, out, stages, clock, (offsets, mirrors), fps)

    t = time.perf_counter()
    mean(0.0, "approximate mean image (pseudo motion blur)")
    velocity = blend_values(db.mean_motion[ids], target.positions, (hc, wc))
    approx = motion_blur(target.canvas, velocity, shutter=params.shutter, denoise=params.denoise)
    clock["mean"] = time.perf_counter() - t

    t = time.perf_counter()
    match(0.0, "matching histograms cell by cell")
    # The frames approx + D_i made straight in the colour axes, with the picture of
    # them before matching, in one pass.
    centre, axes = colour_axes(target.canvas, target.canvas_matte)
    rotated, unmatched = frames_in_axes(approx, d, centre, axes, unmatched=(h, w))
    matched = _match_in_axes(rotated, target, centre, axes, params.cell)
    del rotated
    clock["match"] = time.perf_counter() - t

    t = time.perf_counter()
    comp(0.0, "compositing")
    if params.tau > 0:
        per_fragment = db.motion[ids].astype(np.float32)  # (P, N - 1, 2)
        for axis in (0, 1):  # a mirrored fragment moves mirrored
            per_fragment[mirrors == axis, :, axis] *= -1
        motion = blend_values(per_fragment, target.positions, (hc, wc))  # (Hc, Wc, N - 1, 2)
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
    stages = {
        "differences": d[:, :h, :w],
        "mean": np.clip(approx[:h, :w], 0, 1),
        "unmatched": unmatched,
        "matte": (matte if matte.ndim == 3 else np.broadcast_to(matte, (len(out), hc, wc)))[
            :, :h, :w
        ],
        "background": back[:h, :w],
    }
    return _animation(assignment, params, out, stages, clock, (offsets, mirrors), fps)


def _animation(assignment, params, out, stages, clock, desync, fps):
    """The Animation: the clip with its metadata, the stages and the timings."""
    db = assignment.db
    stages["offsets"], stages["mirrors"] = desync
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
    # Trusted: the render's own fresh float32 frames, clipped to [0, 1] (Clip() would
    # copy and check them again).
    clip = Clip._trusted(np.ascontiguousarray(out, np.float32), fps, {}).with_metadata(**meta)
    return Animation(clip=clip, assignment=assignment, stages=stages, timings=timings)


def _flow_plan(assignment, params, n):
    """The flow rendering's field, clip length, cycle and per-fragment playback rates.

    The difference frames of a fragment play faster (or slower) by the factor its
    motion was rescaled to the painted speed (:func:`flow_field`), so the detail
    moves with the warp; rates are multiples of 1/k for a clip of k repeats of the
    loop, so each fragment's loop fits a whole number of times.
    """
    velocity = flow_field(assignment)
    target = assignment.target
    length = n - params.loop if params.loop else n
    n_frames, cycle = flow_timing(
        velocity, target.canvas_matte, length, travel=params.travel, repeats=params.loop > 0
    )
    repeats = n_frames // length
    own = np.linalg.norm(assignment.db.mean_motion[assignment.fragments], axis=1)
    centre = target.positions + FRAGMENT // 2
    wanted = np.linalg.norm(velocity[centre[:, 0], centre[:, 1]], axis=1)
    gain = np.divide(wanted, own, out=np.ones_like(wanted), where=own > 1e-3)
    rates = np.maximum(1, np.round(gain * repeats)) / repeats
    return {"velocity": velocity, "n_frames": n_frames, "cycle": cycle, "rates": rates}


def _render_flow(assignment, params, d, plan, background, progress):
    r"""The flow rendering's steps after the blend (beyond the paper; see :func:`render`).

    Returns the frames (T, H, W, 3), the stages and the seconds per step.
    """
    target = assignment.target
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    field, advect, match, comp = Progress(progress).split(0.15, 0.6, 0.85)
    clock = {}

    t = time.perf_counter()
    field(0.0, "the motion field's displacement maps")
    velocity, n_frames, cycle = plan["velocity"], plan["n_frames"], plan["cycle"]
    age_a, age_b, weight_a = loop_phases(n_frames, cycle)
    steps = int(np.ceil(max(np.abs(age_a).max(), np.abs(age_b).max())))
    maps = displacement_maps(velocity, steps)
    clock["field"] = time.perf_counter() - t

    t = time.perf_counter()
    advect(0.0, "advecting the photo in two phases (Eulerian loop)")
    # What flows in across the matte's edge is the fluid's own texture, mirrored.
    layer = extend_outside(target.canvas, target.canvas_matte)
    moved, phase_a, phase_b = eulerian_loop(
        layer, velocity, n_frames, cycle=cycle, maps=maps, return_phases=True
    )
    # The differences' loop, repeated to the clip's length (or already that long).
    d = d[np.arange(n_frames) % len(d)]
    frames = moved + np.float32(params.detail) * d[..., None]
    clock["advect"] = time.perf_counter() - t

    t = time.perf_counter()
    match(0.0, "matching histograms cell by cell")
    matched = _match_to_target(frames, target, params.cell)
    clock["match"] = time.perf_counter() - t

    t = time.perf_counter()
    comp(0.0, "compositing")
    alpha = target.canvas_matte
    if params.tau > 0:
        # The outline moves with the fluid by the same loop (frame 0 is alpha, the
        # loop closes), pulled towards alpha by 1 - tau as the paper's B_i are.
        carried = eulerian_loop(alpha, velocity, n_frames, cycle=cycle, maps=maps)
        matte = np.float32(params.tau) * carried + np.float32(1 - params.tau) * alpha
        np.clip(matte, 0.0, 1.0, out=matte)
        area = float(alpha.sum(dtype=np.float64))
        for b in matte[1:]:
            _restore_area(b, area)
        if background is None:
            back = inpaint_background(target.canvas, alpha)
        else:
            back = target.canvas.copy()
            back[:h, :w] = background
    else:
        matte = alpha
        back = target.canvas
    out = composite(matched, back, matte)[:, :h, :w]
    np.clip(out, 0.0, 1.0, out=out)
    clock["composite"] = time.perf_counter() - t
    comp(1.0, "done")
    stages = {
        "velocity": velocity[:h, :w],
        "phase_a": phase_a[:, :h, :w],
        "phase_b": phase_b[:, :h, :w],
        "weights": np.stack([weight_a, 1.0 - weight_a], axis=1),
        "ages": np.stack([age_a, age_b], axis=1),
        "advected": moved[:, :h, :w],
        "differences": d[:, :h, :w],
        "unmatched": np.clip(frames[:, :h, :w], 0, 1),
        "matte": (matte if matte.ndim == 3 else np.broadcast_to(matte, (len(out), hc, wc)))[
            :, :h, :w
        ],
        "background": back[:h, :w],
    }
    return out, stages, clock


def _match_to_target(frames, target, cell):
    """Each frame's histograms matched to the target's, cell by cell (Okabe et al., sec. 6).

    In the target's principal colour axes (Heeger & Bergen 1995 decorrelate colour by
    PCA): matching R, G and B independently can mix hues the photo does not have (a
    white-hot flame turned lilac); matching decorrelated axes keeps its colours.
    """
    centre, axes = colour_axes(target.canvas, target.canvas_matte)
    return _match_in_axes(colours_in_axes(frames, centre, axes), target, centre, axes, cell)


def _match_in_axes(rotated, target, centre, axes, cell):
    """:func:`_match_to_target` for frames already in the colour axes; back in RGB."""
    matched = match_histograms_cells(
        rotated, (target.canvas - centre) @ axes, target.canvas_matte, cell=cell
    )
    return frames_from_axes(matched, centre, axes)
