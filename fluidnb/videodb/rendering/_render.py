r"""Rendering an assignment into an animation (Okabe et al., sec. 6): the pipeline.

:func:`render` rebuilds every assigned fragment's difference frames
:math:`D_i = F_i - A` from its source clip (the database's frame cache), plays and
blends them (:mod:`~fluidnb.videodb.rendering._loops`,
:mod:`~fluidnb.videodb.rendering._blend`), then makes the frames a run at a time: the
paper's rendering adds them to the approximate mean image, the flow rendering to the
photo carried along the motion (:mod:`~fluidnb.videodb.rendering._steps`); both match
the histograms and composite through the static or moving matte. What the renders of
one photo share is kept with it (:mod:`~fluidnb.videodb.rendering._shared`). The
:class:`Animation` it returns keeps each stage's picture for the lesson.
"""

from __future__ import annotations

import time
import weakref
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..._clip import Clip
from ..._image import as_image
from ..._progress import Progress
from ..._stream import FrameStream
from ..._threads import opencv_single_threaded
from ..._validation import check_fps, check_int, check_shape_match
from .._common._geometry import FRAGMENT
from ..assignment._assign import Assignment, _check_params
from ..database._frames import rebuild_fragments
from ._blend import MARGIN
from ._desync import mirror_axes, temporal_offsets
from ._flow_render import STAGGER, _Loop, _Maps, flow_field, flow_timing, phase_offsets
from ._shared import (
    _SHARED,
    _SHARED_LOCK,
    _advected_layer,
    _behind,
    _blend_plan,
    _colour_matching,
    _Later,
    _shared,
)
from ._steps import _BlendedFrames, _FlowFrames, _PaperFrames

__all__ = ["CHUNK", "FIRST_RUN", "RUN_PIXELS", "Animation", "prefetch", "render"]


@dataclass(frozen=True, eq=False)
class Animation:
    """An animated fluid image and how it was made (Okabe et al., secs. 5-6).

    Attributes
    ----------
    clip : Clip or FrameStream
        The animation (the target's size; the paper's rendering: ``N`` frames, or
        ``N - loop`` looping; the flow rendering: whole repeats of those); rendered
        with ``stream=True`` (:func:`render`), a :class:`fluidnb.FrameStream` of the
        same frames, made as it is saved.
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
        (T, 2), ``"advected"`` their cross-fade (T, H, W, 3). Rendered with
        ``stages=False`` (:func:`render`), only the pictures of one frame's size and
        the per-fragment and per-frame numbers are kept.
    timings : dict
        Seconds per stage (assignment and rendering).
    """

    clip: Clip
    assignment: Assignment
    stages: dict
    timings: dict

    def __repr__(self):
        # The dataclass's own repr printed every stage's array (thousands of lines).
        return (
            f"Animation({self.clip!r}, {self.assignment!r}, "
            f"stages=[{', '.join(self.stages)}], render {self.timings.get('render', 0):.1f} s)"
        )


def render(
    assignment,
    params=None,
    *,
    background=None,
    fps=24.0,
    progress=None,
    on_frames=None,
    stages=True,
    stream=False,
    frames=None,
):
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
    on_frames : callable, optional
        ``on_frames(clip, done)``: after the work all frames share, the frames are
        made in runs (:data:`FIRST_RUN` frames, then :data:`CHUNK` at a time; each
        frame is made from its own inputs, so the clip is the same however it is
        cut), and after each run this hears the :class:`~fluidnb.Clip` being made,
        of which the first ``done`` frames are final (the rest are not made yet). A
        player can show and play those while the rest are made
        (:meth:`fluidnb.widgets.FramePlayer.stream`); the returned
        animation's clip has the same frames.

        The work all frames share is kept for the next render: with the target (the
        blend's weights, the colour axes, the advected layer, the background behind
        a moving matte) and, for the last assignment rendered or prefetched
        (:func:`prefetch`), the flow rendering's motion field and displacement maps
        (~150 MB at 480 px). The field and the maps are made on threads while the
        fragments are rebuilt and blended, and each run is blended while the frames
        of the one before are made.
    stages : bool
        Keep every frame's intermediate pictures in :attr:`Animation.stages` (the
        differences, the frames before matching, the flow rendering's phases...), for
        the lesson. An app that only plays the clip passes False: at 480 px a
        96-frame clip's stages take about a gigabyte. The clip is the same.
    stream : bool
        Make the frames as they are saved, a run at a time, instead of holding the
        clip: the animation's ``clip`` is then a :class:`fluidnb.FrameStream` of the
        same frames, bit for bit (one code path makes both), so writing a full-size
        photo's animation to a file needs memory for a few frames and the work they
        share, not for the clip (docs/conventions.md, "Streams"). The work all frames
        share is done here; each pass over the stream (``clip.save(path)``) makes
        the frames. No stages are kept (``stages`` must be False or left as is),
        and ``timings`` is complete once a pass has made every frame.
    frames : int, optional
        The flow rendering's clip length: a whole number of repeats of the
        difference frames' loop (``N - loop`` frames; ``N`` without a loop, then
        only that). Default: as many repeats (at most :data:`MAX_REPEATS`) as the
        ``travel`` needs (:func:`flow_timing`). The paper's rendering is one loop long
        and takes no other length.

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
    if background is not None:
        background = as_image(background, mode="rgb", name="background")
        check_shape_match("background", background, (h, w))
    if stream and on_frames is not None:
        raise ValueError(
            "on_frames is for a clip rendered in memory; a stream (stream=True) hands "
            "its frames to whatever it is saved to"
        )
    stages = stages and not stream
    if frames is not None and params.rendering != "flow":
        natural = n - params.loop if params.loop else n
        if check_int("frames", frames, 1) != natural:
            raise ValueError(
                f"frames must be {natural} (one loop) for the paper's rendering, got "
                f"{frames}; the flow rendering (rendering='flow') repeats the loop"
            )
    report = Progress(progress)
    rebuild, setup, making = report.split(0.3, 0.35)
    clock = dict.fromkeys(("rebuild", "blend"), 0.0)

    t = time.perf_counter()
    # The flow rendering's motion field and timing, and its displacement maps: they
    # do not need the fragments' frames, so they are made on threads of their own
    # while the frames are rebuilt and blended.
    flow = None
    if params.rendering == "flow":
        # Checked here (a wrong length raises before any work), made on a thread.
        length = n - params.loop if params.loop else n
        if frames is not None:
            flow_timing(np.zeros((1, 1, 2), np.float32), np.ones((1, 1)), length,
                        travel=params.travel, repeats=params.loop > 0, frames=frames)  # fmt: skip
        flow = _Later(_flow_work, assignment, params, n, frames)
    rebuild(0.0, f"rebuilding {len(target)} fragments from their source clips")
    ids = assignment.fragments
    # Each fragment's D_i = F_i - A, with ``loop`` made a loop of its own (its end
    # cross-faded into its start; difference_frames): made on the rebuild's threads,
    # each fragment once, and kept in the database's cache for the next render.
    looped = _rebuild(assignment, params, rebuild)
    flow = None if flow is None else flow.value
    offsets = np.zeros(len(ids), np.int64)
    mirrors = np.full(len(ids), -1, np.int8)
    rates = n_frames = None
    if params.loop:
        # Beyond the paper: neighbours that share a database fragment start its loop at
        # different times and mirrored (no tile pattern).
        offsets = temporal_offsets(ids, target.positions, n - params.loop)
        mirrors = mirror_axes(ids, target.positions, db.mean_motion[ids])
        if flow is not None and not np.all(flow["rates"] == 1):
            # Fragments play at different rates: play all the clip's frames. At rate 1
            # the blended loop is simply repeated (see _FlowFrames).
            rates, n_frames = flow["rates"], flow["n_frames"]
    clock["rebuild"] = time.perf_counter() - t

    setup(0.0, "preparing the frames")
    loops = [looped[f] for f in ids.tolist()]
    del looped
    length = n_frames or (n - params.loop if params.loop else n)  # one loop's frames
    blended = _BlendedFrames(loops, offsets, rates, mirrors, length, target, clock)
    if flow is None:
        frames = _PaperFrames(assignment, params, blended, mirrors, background, clock, stages)
    else:
        frames = _FlowFrames(assignment, params, blended, flow, background, clock, stages)
    # The frames a few at a time (_runs): each is made from its own inputs only
    # (blend, warp, matching, composite), so the clip is the same however it is cut
    # (to the round-off of the batched pyramids), the first frames can be shown while
    # the rest are made, and the blend's pyramids stay small.
    total = frames.n_frames
    desync = (offsets, mirrors)
    if stream:
        return _streamed(assignment, params, frames, making, clock, desync, fps)
    out = np.empty((total, h, w, 3), np.float32)
    live = None  # the clip being made, as on_frames sees it (a read-only view of out)
    for _, t1, _ in _made(frames, making, lambda t0, t1: out[t0:t1]):
        if on_frames is not None:
            if live is None:
                live = Clip._trusted(out.view(), fps, {})
            on_frames(live, t1)
    clip = Clip._trusted(out, fps, {})  # the render's own fresh frames, in [0, 1]
    meta, timings = _metadata(assignment, params, clock)
    return _animation(assignment, clip.with_metadata(**meta), frames.stages, timings, desync)


def _made(frames, making, into):
    """The frames, a run at a time: ``(t0, t1, block)`` once each run is final, in order.

    ``into(t0, t1)`` is the (t1 - t0, H, W, 3) float32 array a run's frames are made
    in. Each run is blended here while the frames of the one before are made on the
    other threads (both cores busy); the first is handed out as soon as it is made.
    The one loop of the clip held in memory and of the stream (:func:`render`), so
    both hold the same frames.

    A run's frames are queued on the maker before the run before it is handed out,
    so what the consumer does with a block (a stream's ``.npz`` writes 70 MB a run
    at 1920 px, ~8 s of system time over 96 frames) overlaps the next frames instead
    of leaving both cores idle. It costs one more run's block in memory.
    """
    total = frames.n_frames
    pending = None
    # The frames (two at a time) and the blend's layers (two at a time) already keep
    # both cores busy: OpenCV's own threads inside each (remap, the pyramids) would
    # only contend, and its pool spins while it waits. OpenCV's results do not depend
    # on its threads.
    with opencv_single_threaded(), ThreadPoolExecutor(1) as maker:
        try:
            for t0, t1 in _runs(total, frames.blended.canvas):
                making(t0 / total, f"rendering frames {t0 + 1}-{t1} of {total}")
                d = frames.blend(t0, t1)
                block = into(t0, t1)
                run = (maker.submit(frames.frames, t0, d, block), t0, t1, block)
                del d
                if pending is not None:
                    yield _handed(pending)  # these frames are made meanwhile
                pending = run
                if t0 == 0:
                    yield _handed(pending)
                    pending = None
            if pending is not None:
                yield _handed(pending)
                pending = None
        finally:
            if pending is not None:
                pending[0].cancel()  # a cancelled render: what is under way ends
    making(1.0, "done")


def _handed(run):
    """A run's ``(t0, t1, block)`` once its frames are made."""
    future, t0, t1, block = run
    future.result()
    return t0, t1, block


def _streamed(assignment, params, frames, making, clock, desync, fps):
    """:func:`render`'s animation whose clip is a stream: each pass runs :func:`_made`."""
    h, w = assignment.target.shape
    timings = {}

    def blocks():
        for _, _, block in _made(
            frames, making, lambda t0, t1: np.empty((t1 - t0, h, w, 3), np.float32)
        ):
            yield block
        timings.update(_metadata(assignment, params, clock)[1])

    def metadata():
        return _metadata(assignment, params, clock)[0]

    clip = FrameStream(
        blocks, n_frames=frames.n_frames, shape=(h, w), color=True, fps=fps, metadata=metadata
    )
    timings.update(_metadata(assignment, params, clock)[1])
    return _animation(assignment, clip, frames.stages, timings, desync)


def prefetch(assignment, params=None, *, progress=None):
    """Rebuild the fragments :func:`render` will need, and make what it shares, ahead.

    The first step of :func:`render` alone (each chosen fragment's difference frames
    from its source clip, into the database's frame cache), then the work its frames
    share (the flow rendering's motion field and displacement maps, the blend's
    weights, the colour axes, the background behind a moving matte), kept for it: an
    app calls it while a slider rests, so the render that follows starts with its
    first frames. What is already made costs nothing.

    Parameters
    ----------
    assignment : Assignment
    params : AnimateParams, optional
        The rendering settings (their ``loop``); default the assignment's.
    progress : callable, optional
        ``progress(fraction, message)`` after each source clip and before the shared
        work; raise :class:`fluidnb.Cancelled` to stop (what is made so far stays
        kept).

    Returns
    -------
    int
        How many of the assignment's distinct fragments are now cached.
    """
    if not isinstance(assignment, Assignment):
        raise ValueError(f"assignment must be an Assignment, got {type(assignment).__name__}")
    params = assignment.params if params is None else _check_params(params, assignment.db)
    report = Progress(progress)
    rebuild, shared = report.split(0.9)
    done = len(_rebuild(assignment, params, rebuild))
    # What else render makes before its first frames and keeps: the flow rendering's
    # motion field and maps for this assignment, the target's blend weights, colour
    # axes, advected layer and (a moving matte) the background behind the fluid. Asked
    # first whether to go on: an app dragging a slider has moved on by now.
    shared(0.0, "making what the render's frames share")
    target = assignment.target
    if params.rendering == "flow":
        _flow_work(assignment, params, assignment.db.params.N)
        _advected_layer(target)
    _blend_plan(target)
    _colour_matching(target, params.cell)
    if params.tau > 0:
        _behind(target, None)
    shared(1.0, "ready to render")
    return done


def _rebuild(assignment, params, progress):
    """Each chosen fragment's loop of :math:`D_i` (render's step 1; cached by the database)."""
    return rebuild_fragments(
        assignment.db,
        assignment.fragments,
        margin=MARGIN,
        grey=True,
        differences=params.loop,
        progress=progress,
    )


#: Frames :func:`render` makes at a time, after the work all frames share (the clip
#: is the same whatever it is; :func:`render`'s ``on_frames`` hears of each run). The
#: first run is :data:`FIRST_RUN` frames: what an app shows first comes sooner.
CHUNK = 12
FIRST_RUN = 4

#: At most this many canvas pixels (frames times pixels) in a run: the run's played
#: differences, the blend's pyramids and its frames grow with it, so a large photo
#: is made in shorter runs (two frames at 1920 x 1280, seven at 960 x 640; the app's
#: sizes in runs of :data:`CHUNK`). Issue 39: memory bounded by a few frames.
RUN_PIXELS = 2 * 1968 * 1320


def _runs(total, canvas=(0, 0)):
    """The runs of frames (t0, t1) :func:`render` makes one after the other."""
    most = max(1, min(CHUNK, RUN_PIXELS // max(1, canvas[0] * canvas[1])))
    t0 = 0
    while t0 < total:
        t1 = min(t0 + (min(FIRST_RUN, most) if t0 == 0 else most), total)
        yield t0, t1
        t0 = t1


def _metadata(assignment, params, clock):
    """The clip's metadata and the timings, as the clock stands."""
    db = assignment.db
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
    return meta, timings


def _animation(assignment, clip, stages, timings, desync):
    """The Animation: the clip (or stream) with its metadata, the stages and the timings."""
    stages["offsets"], stages["mirrors"] = desync
    return Animation(clip=clip, assignment=assignment, stages=stages, timings=timings)


def _flow_plan(assignment, params, n, frames=None):
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
        velocity,
        target.canvas_matte,
        length,
        travel=params.travel,
        repeats=params.loop > 0,
        frames=frames,
    )
    repeats = n_frames // length
    own = np.linalg.norm(assignment.db.mean_motion[assignment.fragments], axis=1)
    centre = target.positions + FRAGMENT // 2
    wanted = np.linalg.norm(velocity[centre[:, 0], centre[:, 1]], axis=1)
    gain = np.divide(wanted, own, out=np.ones_like(wanted), where=own > 1e-3)
    rates = np.maximum(1, np.round(gain * repeats)) / repeats
    return {"velocity": velocity, "n_frames": n_frames, "cycle": cycle, "rates": rates}


def _flow_work(assignment, params, n, frames=None):
    """:func:`_flow_plan` with its displacement maps (made on a thread: ``plan["maps"]``).

    Kept for the next render of the same assignment with the same loop and travel
    (the last such only: the maps take ~150 MB at the app's size).
    """
    key = (params.loop, params.travel, STAGGER, frames)
    with _SHARED_LOCK:
        last = _SHARED.setdefault(assignment.target, {}).get("flow")
    if last is not None and last[0]() is assignment and last[1] == key:
        return last[2]
    plan = _flow_plan(assignment, params, n, frames)
    shape = assignment.target.canvas.shape[:2]
    # Each pixel's cycle offset (phase_offsets), on a grid that grows with the travel:
    # the offsets' gradient shears the phases by the travel over the grid's spacing.
    scale = STAGGER * params.travel
    offsets = (
        _shared(assignment.target, ("offsets", scale), lambda: phase_offsets(shape, scale))
        if STAGGER > 0
        else None
    )
    loop = _Loop(plan["n_frames"], plan["cycle"], offsets, shape)
    # The first run's maps first: its frames wait for no others (with offsets, every
    # frame needs them all).
    first = np.concatenate([loop.ages(t) for t in range(min(FIRST_RUN, plan["n_frames"]))])
    plan.update(loop=loop, maps=_Maps(plan["velocity"], loop.steps, first, compact=True))
    plan["velocity"].flags.writeable = False
    with _SHARED_LOCK:
        _SHARED.setdefault(assignment.target, {})["flow"] = (weakref.ref(assignment), key, plan)
    return plan
