"""The fire entry point: keyframes, advection between them and cross-dissolve.

Furukawa et al. (2013), sec. 3.3-3.4, Fig. 5-6.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass

import numpy as np

from .._clip import Clip
from .._progress import Progress
from .._random import resolve_seed, rng
from .._stream import FrameStream, timed
from .._validation import check_array, check_int
from ..fields import resize, resize_vector_field
from . import _advance
from ._params import SIMULATION_FPS
from ._synthesis import _check_params, _check_photo, _photo_and_matte, _Prepared, _run

__all__ = [
    "FireResult",
    "clip_times",
    "colour_temperature",
    "dissolve_weights",
    "fire",
    "output_shape",
    "temperature_target",
]


def dissolve_weights(n_frames, interval, overlap):
    """Where the segments start and how much each contributes to every frame.

    Segment ``k`` starts at frame ``k (N - m)`` with a keyframe and lasts ``N``
    frames, so consecutive segments share ``m`` frames (Furukawa et al. (2013), Fig. 6). Over the
    shared frames the older segment fades out and the newer one in linearly: on the
    ``j``-th shared frame (``j = 0 .. m - 1``) the new one weighs ``(j + 1) / (m +
    1)``, the old one the rest. The weights are normalised so they sum to 1 on every
    frame (which they already do when ``m <= N / 2``; larger overlaps blend more
    than two segments).

    Parameters
    ----------
    n_frames : int
        :math:`T`, the clip's length (>= 1).
    interval : int
        :math:`N`, frames per segment (>= 1).
    overlap : int
        :math:`m`, shared frames, ``0 <= m < N``.

    Returns
    -------
    starts : ndarray, shape (K,), int
        The keyframes: the first frame of each segment.
    weights : ndarray, shape (K, T), float64
        ``weights[k, t]``, zero outside segment ``k``; ``weights.sum(0) == 1``.

    Examples
    --------
    >>> starts, w = dissolve_weights(8, 4, 2)
    >>> starts.tolist()
    [0, 2, 4, 6]
    >>> np.round(w, 2).tolist()[1]
    [0.0, 0.0, 0.33, 0.67, 0.67, 0.33, 0.0, 0.0]
    >>> bool(np.allclose(w.sum(0), 1))
    True
    """
    n_frames = check_int("n_frames", n_frames, 1)
    interval = check_int("interval", interval, 1)
    overlap = check_int("overlap", overlap, 0)
    if overlap >= interval:
        raise ValueError(f"overlap must be < interval ({interval}), got {overlap}")
    step = interval - overlap
    starts = np.arange(0, n_frames, step)
    j = np.arange(interval)
    # Trapezoid: rises over the first m frames, falls over the last m.
    ramp = np.minimum(np.minimum(j + 1, interval - j), overlap + 1) / (overlap + 1)
    weights = np.zeros((len(starts), n_frames))
    for k, s in enumerate(starts):
        stop = min(s + interval, n_frames)
        weights[k, s:stop] = ramp[: stop - s]
    weights /= weights.sum(axis=0, keepdims=True)
    return starts, weights


def temperature_target(temperature, alpha, cutoff=0.2):
    r"""The target :math:`I_t` of every frame: the temperature as the photo's alpha.

    The paper normalises the temperature to [0, 1] (sec. 3.2). Two steps beyond that
    make the fire look like the photo (decisions, see ``docs/contact/``):

    1. **Cut-off.** Gas cooler than ``cutoff`` of the sequence's temperature range
       does not glow (soot emits visibly only when hot): its target is 0, matched by
       the black around the photo's flame, so the cooled plume fades to black
       instead of being painted as dim fire.
    2. **Histogram match.** Above the cut-off, each temperature is replaced by the
       photo's alpha :math:`a_a` at the same rank among the photo's flame pixels
       (:math:`a_a > 0.05`): the hottest decile of the simulated flame is matched
       with the photo's brightest decile, the coolest visible gas with the photo's
       dimmest flame. Without it a photo's bright core (a_a near 1) was matched only
       by the rare hottest pixels, and hot regions came out in the darker orange of
       the flame's edge.

    The map is monotone, so brighter output still means hotter gas.

    Parameters
    ----------
    temperature : ndarray, shape (T, H, W)
        The simulation's temperature (any units).
    alpha : ndarray, shape (Ha, Wa)
        The photo's alpha :math:`a_a` (:func:`alpha_from_photo`).
    cutoff : float
        The fraction of the temperature range below which gas is black, in [0, 1).

    Returns
    -------
    ndarray, shape (T, H, W), float32 in [0, 1]

    Examples
    --------
    >>> alpha = np.array([[0.0, 0.5], [0.9, 1.0]])
    >>> temp = np.array([[[0.0, 0.1, 0.3, 0.6, 1.0]]])
    >>> temperature_target(temp, alpha, cutoff=0.2).astype(float).round(2).tolist()
    [[[0.0, 0.0, 0.5, 0.9, 1.0]]]
    """
    return _target_map(temperature, alpha, cutoff)(temperature)


def _target_map(temperature, alpha, cutoff):
    """:func:`temperature_target`'s map, fitted on a sequence, for any temperatures.

    The cut-off and the ranks come from the whole ``temperature`` sequence; the map
    then applies to other temperatures too (the sequence resampled to the keyframes'
    grid, or at an in-between time).
    """
    t = np.asarray(temperature, dtype=np.float64)
    lo, hi = float(t.min()), float(t.max())
    flame = np.sort(np.asarray(alpha, dtype=np.float64)[np.asarray(alpha) > 0.05])
    norm = (t - lo) / (hi - lo) if hi > lo else None
    hot = np.sort(norm[norm > cutoff]) if norm is not None else np.empty(0)

    def apply(temperature):
        t = np.asarray(temperature, dtype=np.float64)
        target = np.zeros(t.shape, np.float32)
        if hi <= lo or hot.size == 0 or flame.size == 0:
            return target
        t = (t - lo) / (hi - lo)  # the paper's normalisation
        glowing = t > cutoff
        # Rank of each glowing temperature in (0, 1], then the photo's alpha at that rank.
        rank = np.searchsorted(hot, t[glowing], side="right") / hot.size
        target[glowing] = np.interp(rank, np.arange(1, flame.size + 1) / flame.size, flame)
        return target

    return apply


def colour_temperature(temperature, cmap="inferno"):
    """Colour-map a temperature sequence in [0, 1] for display (plain comparison clip).

    Parameters
    ----------
    temperature : ndarray, shape (T, H, W) or (H, W), in [0, 1]
    cmap : str
        A matplotlib colour map name.

    Returns
    -------
    ndarray, shape (..., 3), float32
    """
    from matplotlib import colormaps

    lut = colormaps[cmap](np.linspace(0.0, 1.0, 256))[:, :3].astype(np.float32)
    idx = np.clip(np.rint(np.asarray(temperature) * 255), 0, 255).astype(np.intp)
    return lut[idx]


@dataclass(frozen=True)
class FireResult:
    """What :func:`fire` makes: the clip, and the steps a lesson shows.

    Attributes
    ----------
    clip : Clip or FrameStream
        The fire, (T, H, W, 3) at ``params.fps``, H and W from
        ``params.output_size``, with ``method="fire"``, params, the seed used,
        timings, the keyframe frame numbers and the simulation's grid and frame rate
        in its metadata.
    temperature_clip : Clip
        The normalised temperature :math:`I_t`, colour-mapped, for comparison: one
        frame per simulation frame, on the simulation's grid, at its frame rate.
    keyframes : ndarray, shape (K, H, W, 3), float32, or None
        The synthesised keyframes, before advection and blending (``None`` for a
        stream, ``fire(..., stream=True)``).
    sources : ndarray, shape (K, H, W, 2), int64, or None
        For each keyframe pixel its (row, col) in ``texture`` (``None`` for a stream).
    starts : ndarray, shape (K,), int
        The frame of each keyframe.
    weights : ndarray, shape (K, T)
        The cross-dissolve weights (:func:`dissolve_weights`).
    texture : ndarray, shape (Ha, Wa, 3), float32
        The photo as used: resized to ``params.input_size`` and composited onto
        black with its matte.
    texture_alpha : ndarray, shape (Ha, Wa), float32
        Its alpha :math:`a_a` (:func:`alpha_from_photo`).
    target : ndarray, shape (N, h, w), float32
        :math:`I_t` of every simulation frame on the simulation's grid (the
        keyframes' targets are the same map of the temperature resampled to
        their grid and time, see :func:`temperature_target`).
    times : ndarray, shape (T,), float64
        The simulation time (in simulation frames) of each clip frame
        (:func:`clip_times`).
    simulation : object or None
        The fluid simulation the clip was made from (the one :func:`fire` ran, or
        the one it was given).
    seed : int
        The seed used (also ``clip.metadata["seed"]``): ``fire(..., seed=result.seed)``
        makes the same clip.
    """

    clip: Clip | FrameStream
    temperature_clip: Clip
    keyframes: np.ndarray | None
    sources: np.ndarray | None
    starts: np.ndarray
    weights: np.ndarray
    texture: np.ndarray
    texture_alpha: np.ndarray
    target: np.ndarray
    times: np.ndarray = None
    simulation: object = None
    seed: int | None = None


def fire(
    photo,
    simulation=None,
    params=None,
    *,
    matte=None,
    n_frames=None,
    fluid_params=None,
    seed=None,
    stream=False,
    progress=None,
):
    r"""Animate fire that looks like ``photo`` and moves like a fluid simulation.

    The one entry point of the method (Furukawa et al. (2013), sec. 3): without a
    ``simulation`` the flame preset of :mod:`fluidnb.fluid` is simulated first
    (sec. 3.1). The temperature of frame ``s`` is then the target of a texture
    synthesis from the photo (:func:`synthesize`, a keyframe; sec. 3.2); the
    keyframe is advected with the simulation's velocity, one backtrace per frame,
    for the rest of its segment of ``N`` frames (sec. 3.3, Fig. 5); consecutive
    segments overlap by ``m`` frames and are cross-dissolved linearly (sec. 3.4,
    Fig. 6, :func:`dissolve_weights`).

    Beyond the paper, by default (``FireParams.paper()`` turns both off): the
    keyframes are synthesised on a finer grid than the simulation's,
    ``params.output_size`` pixels on the longer side (the temperature resampled
    cubically, the velocity bilinearly and rescaled), and the clip has
    ``params.fps`` frames a second, the frames between two simulation frames advected
    by the matching fraction of its velocity (:func:`clip_times`).

    Advection detail (ours): rather than re-interpolating the image every frame,
    which blurs it a little more each time, the backtraces are composed into one
    displacement :math:`d_t(x) = -u_t(x) + d_{t-1}(x - u_t(x))` and the keyframe is
    sampled once, :math:`I(x) = K(x + d_t(x))`. The motion is the same (Fig. 5's
    backtrace, frame after frame); the texture stays as sharp as the keyframe.

    Parameters
    ----------
    photo : array_like or path, shape (Ha, Wa, 3) or (Ha, Wa, 4)
        :math:`I_a`, a photograph of fire, at least 8 x 8 pixels: on a dark
        background, or a cut-out (RGBA; its alpha is the matte). The colour is
        composited onto black with the matte, so transparent pixels' colour never
        enters the fire.
    simulation : None, Simulation, object or (temperature, velocity)
        Where the fire moves: ``None`` simulates the flame preset; a
        :class:`fluidnb.fluid.Simulation` (its ``centred_velocity()`` is used) or
        anything with ``temperature`` (T, H, W) and ``velocity`` (T, H, W, 2); or a
        pair of arrays ``(temperature, velocity)``. The temperature is normalised to
        [0, 1] by the sequence's minimum and maximum to make :math:`I_t`; the
        velocity is (dy, dx) in grid cells per simulation frame, at most ``max(H, W)``
        in magnitude (simulation frame ``t`` is frame ``t - 1`` advected with
        ``velocity[t]``). Its frames are :data:`SIMULATION_FPS` a second unless it has
        an ``fps`` attribute.
    params : FireParams, optional
    matte : array_like, shape (Ha, Wa), optional
        The photo's alpha matte (overrides an alpha channel). Without either, the
        photo is taken to be on black as it is.
    n_frames : int, optional
        Frames to use: the first ``n_frames`` of the simulation, or the number to
        simulate (default: all, or the preset's length).
    fluid_params : fluidnb.fluid.FluidParams, optional
        Only when the preset is simulated: replaces its parameters.
    seed : None, int or numpy.random.Generator
        Seeds the simulation (when run here) and the synthesis; the int used is
        recorded in ``result.seed`` and ``clip.metadata["seed"]``.
    stream : bool
        Make ``result.clip`` a :class:`fluidnb.FrameStream` of the same frames
        instead of a clip: the simulation and the photo's features are made now, the
        keyframes and frames as it is saved, a few frames at a time (each pass the
        same, from the generator as it was here), so a 1920-px fire needs memory for
        the two keyframes of a cross-dissolve and a few frames, not the clip
        (docs/conventions.md, "Streams"). ``result.keyframes`` and
        ``result.sources`` are then ``None``: they are as large as the clip.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.
        With ``stream=True``, for the simulation and the photo; the frames report to
        the same callable as they are made.

    Returns
    -------
    FireResult
        ``result.clip`` is the fire, a :class:`fluidnb.Clip` (a
        :class:`fluidnb.FrameStream` with ``stream=True``).

    Raises
    ------
    ValueError
        For a photo that is not RGB(A) or smaller than 8 x 8, a matte of another
        size, temperature and velocity sequences of different lengths or sizes, a
        velocity faster than the image is large, NaN, or bad params.

    References
    ----------
    .. [1] A. Furukawa (古川 歩), Y. Dobashi (土橋 宜典), T. Yamamoto (山本 強),
       "実写画像に類似した流体アニメーションの生成" (Creating realistic animation
       of fluids using photographs), IPSJ SIG Technical Report CG-152, 2013,
       sec. 3.2-3.4, Fig. 4-6.
    .. [2] M. Ashikhmin, "Synthesizing natural textures", Proc. I3D, 2001.

    Examples
    --------
    A warm blob rising one pixel per frame:

    >>> from fluidnb.data import sample
    >>> from fluidnb.fire import FireParams
    >>> photo, matte = sample("flame", size=24, return_alpha=True)
    >>> yy, xx = np.mgrid[:16, :16]
    >>> temp = np.stack([np.exp(-((xx - 8) ** 2 + (yy - 10 + t) ** 2) / 12) for t in range(4)])
    >>> vel = np.zeros((4, 16, 16, 2))
    >>> vel[..., 0] = -1.0
    >>> params = FireParams.paper(interval=2)  # keyframes on the grid, 8 fps
    >>> result = fire(photo, (temp, vel), params, matte=matte, seed=0)
    >>> result.clip
    Clip(4 frames, 16x16 RGB, 8 fps, method='fire')
    >>> result.starts.tolist(), result.seed
    ([0, 1, 2, 3], 0)
    >>> fire(photo, (temp, vel), FireParams(output_size=32, interval=2), seed=0).clip
    Clip(10 frames, 32x32 RGB, 24 fps, method='fire')
    """
    started = time.perf_counter()
    params = _check_params(params)
    seed = resolve_seed(seed)
    gen = rng(seed)
    photo, matte = _photo_and_matte(photo, matte)
    if n_frames is not None:
        n_frames = check_int("n_frames", n_frames, 1)
    report = Progress(progress)
    meta = {}
    if simulation is None:
        simulate_part, report = report.split(0.3)
        simulation, fluid_params = _simulate_preset(fluid_params, n_frames, gen, simulate_part)
        meta["fluid_params"] = fluid_params.to_dict()
    elif fluid_params is not None:
        raise ValueError(
            "fluid_params is only used when fire simulates the preset (simulation=None)"
        )
    temperature, velocity, sim_fps = _temperature_and_velocity(simulation, n_frames)
    n, h, w = temperature.shape
    shape = output_shape((h, w), params.output_size)
    photo_size = max(shape) if params.input_size < 0 else params.input_size
    texture, _ = _resize_photo(photo, matte, photo_size)
    texture, alpha = _check_photo(texture, None)  # already composited with its matte
    target_of = _target_map(temperature, alpha, params.cutoff)
    target = target_of(temperature)
    times, interval, overlap = clip_times(n, sim_fps, params)
    starts, weights = dissolve_weights(len(times), interval, overlap)
    fields = _Fields(temperature, velocity, shape)

    prepared = _Prepared(texture, alpha, params)  # the photo's features, once
    meta.update(
        method="fire",
        params=params.to_dict(),
        seed=seed,
        simulation_shape=[h, w],
        simulation_fps=sim_fps,
    )
    maker = _Frames(
        texture, alpha, target_of, fields, times, starts, weights, interval, params, prepared
    )
    tclip = Clip(
        colour_temperature(target),
        fps=sim_fps,
        metadata={"method": "fire", "what": "temperature (normalised, inferno)", "seed": seed},
    )
    result = dict(
        temperature_clip=tclip,
        starts=starts,
        weights=weights,
        texture=texture,
        texture_alpha=alpha,
        target=target,
        times=times,
        simulation=None if isinstance(simulation, tuple) else simulation,
        seed=seed,
    )
    if stream:
        # Every pass starts from the generator as it is now (after the simulation),
        # so every pass makes the same keyframes.
        state = copy.deepcopy(gen)
        frames = maker.stream(lambda: copy.deepcopy(state), meta, started, report)
        return FireResult(clip=frames, keyframes=None, sources=None, **result)
    keyframes = np.empty((len(starts), *shape, 3), np.float32)
    sources = np.empty((len(starts), *shape, 2), np.int64)

    def keep(k, keyframe, src):
        keyframes[k], sources[k] = keyframe, src

    # The in-memory clip is the stream collected (one code path), with the generator
    # itself: a Generator given as the seed advances as it always did.
    clip = maker.stream(lambda: gen, meta, started, report, keep=keep).clip()
    return FireResult(clip=clip, keyframes=keyframes, sources=sources, **result)


class _Frames:
    """The frames of :func:`fire` made in order, a block at a time (sec. 3.3-3.4).

    Frame ``t`` is the sum over the segments that cover it (at most two, with the
    paper's overlap) of ``weight * K_k(x + d_t(x))``, added in the order of the
    keyframes; a segment's keyframe is synthesised when the clip reaches its start
    and let go of at its end. So a pass holds the keyframes of the segments under way
    and a block of frames, and makes the frames of the in-memory clip bit for bit
    (the same operations in the same order, the generator drawn in keyframe order).
    """

    def __init__(
        self, texture, alpha, target_of, fields, times, starts, weights, interval, params, prepared
    ):
        self.texture, self.alpha, self.target_of = texture, alpha, target_of
        self.fields, self.times, self.starts, self.weights = fields, times, starts, weights
        self.interval, self.params, self.prepared = interval, params, prepared
        self.shape = fields.shape

    def _per_block(self):
        """Frames a block holds: about 32 MB (one at 1920 px, all of a short clip at 256)."""
        size = self.shape[0] * self.shape[1] * 3 * 4
        return int(max(1, min(len(self.times), (32 << 20) // size)))

    def blocks(self, gen, report, timings, keep=None):
        """The frames in blocks (n, H, W, 3) float32 in [0, 1], in order (one pass)."""
        times, starts, weights, interval = self.times, self.starts, self.weights, self.interval
        n = len(times)
        per = self._per_block()
        segments = []  # [k, start, keyframe, displacement, spare] of the segments under way
        following = 0  # the next keyframe to synthesise
        total = sum(min(s + interval, n) - s for s in starts)
        done = 0
        block = None
        for t in range(n):
            while following < len(starts) and starts[following] == t:
                k, s = following, int(starts[following])
                report(done / total, f"keyframe {k + 1}/{len(starts)} (frame {s})")
                clock = time.perf_counter()
                target = self.target_of(self.fields.temperature(times[s]))
                keyframe, src, _ = _run(
                    self.texture, self.alpha, target, self.params, False, gen, self.prepared
                )
                timings["synthesis"] += time.perf_counter() - clock
                if keep is not None:
                    keep(k, keyframe, src)
                # d_s = 0: the keyframe itself.
                displacement = np.zeros((*self.shape, 2), np.float32)
                segments.append([k, s, keyframe, displacement, np.empty_like(displacement)])
                following += 1
            if block is None:
                block = np.zeros((min(per, n - t), *self.shape, 3), np.float32)
                i = 0
            frame = block[i]
            clock = time.perf_counter()
            for segment in segments:
                k, s, keyframe, displacement, spare = segment
                weight = weights[k, t].astype(np.float32)
                if t == s:
                    frame += weight * keyframe
                else:
                    # d_t(x) = -u(x) + d_{t-1}(x - u(x)): one more backtrace (Fig. 5),
                    # with u the velocity over [times[t - 1], times[t]] on the
                    # keyframes' grid; then frame += weight * K(x + d_t(x)). Compiled
                    # (_advance); the same in numpy is _reference.advance_reference.
                    for u in self.fields.steps(times[t - 1], times[t]):
                        _advance.compose(displacement, u, spare)
                        displacement, spare = spare, displacement
                    segment[3], segment[4] = displacement, spare
                    _advance.warp_add(keyframe, displacement, weight, frame)
                done += 1
            # A segment ends after its interval's last frame: its keyframe is let go of.
            segments = [g for g in segments if g[1] + interval > t + 1]
            np.clip(frame, 0.0, 1.0, out=frame)
            timings["advection"] += time.perf_counter() - clock
            if t % 8 == 0:
                report(done / total, f"frame {t + 1}/{n}")
            i += 1
            if i == len(block):
                yield block
                block = None
        report(1.0, "done")

    def stream(self, generator, meta, started, progress, keep=None):
        """The frames as a :class:`~fluidnb.FrameStream`; ``generator()`` gives a pass its own."""
        setup = time.perf_counter() - started
        timings = {}

        def blocks():
            timings.update(synthesis=0.0, advection=0.0, total=setup)
            report = Progress(progress)
            yield from timed(self.blocks(generator(), report, timings, keep), timings, "total")

        def metadata():
            return {
                **{
                    k: v for k, v in meta.items() if k not in ("simulation_shape", "simulation_fps")
                },
                "timings": dict(timings),
                "keyframes": self.starts.tolist(),
                "simulation_shape": meta["simulation_shape"],
                "simulation_fps": meta["simulation_fps"],
            }

        return FrameStream(
            blocks,
            n_frames=len(self.times),
            shape=self.shape,
            color=True,
            fps=self.params.fps,
            metadata=metadata,
        )


def output_shape(shape, size):
    """The keyframes' (H, W): ``shape`` scaled so its longest side is ``size`` (0: as is).

    Examples
    --------
    >>> output_shape((128, 128), 256), output_shape((128, 192), 256), output_shape((128, 96), 0)
    ((256, 256), (171, 256), (128, 96))
    """
    h, w = shape
    if size == 0:
        return int(h), int(w)
    scale = size / max(h, w)
    return max(1, round(h * scale)), max(1, round(w * scale))


def clip_times(n_frames, sim_fps, params):
    r"""When each clip frame is, in simulation frames, and the segments in clip frames.

    The clip covers the simulation's ``n_frames`` frames (``(n_frames - 1) / sim_fps``
    seconds) at ``params.fps`` frames a second: frame ``j`` is at simulation time
    :math:`\tau_j = j \, f_{sim} / f`. A segment of :math:`N` simulation frames lasts
    ``round(N f / f_sim)`` clip frames and segments overlap by ``round(m f / f_sim)``
    (at least one frame less than a segment), so keyframes stay :math:`N - m`
    simulation frames apart (Furukawa et al. (2013), Fig. 6) whatever the frame rate.

    Parameters
    ----------
    n_frames : int
        The simulation's frames.
    sim_fps : float
        Its frames a second (:data:`fluidnb.fire.SIMULATION_FPS` for fluidnb's).
    params : FireParams
        ``fps``, ``interval`` (N) and ``overlap`` (m).

    Returns
    -------
    times : ndarray, shape (T,), float64
        :math:`\tau_j` of each clip frame, from 0 to at most ``n_frames - 1``.
    interval, overlap : int
        :math:`N` and :math:`m` in clip frames.

    Examples
    --------
    >>> from fluidnb.fire import FireParams
    >>> times, interval, overlap = clip_times(4, 8.0, FireParams(fps=24, interval=4))
    >>> times.round(3).tolist(), interval, overlap
    ([0.0, 0.333, 0.667, 1.0, 1.333, 1.667, 2.0, 2.333, 2.667, 3.0], 12, 6)
    """
    ratio = params.fps / sim_fps
    count = int(np.floor((n_frames - 1) * ratio + 1e-9)) + 1
    times = np.arange(count) / ratio
    interval = max(1, round(params.interval * ratio))
    overlap = min(round(params.m * ratio), interval - 1)
    return times, interval, overlap


class _Fields:
    """The simulation's temperature and velocity on the keyframes' grid, at any time.

    Temperature: cubic interpolation in space (clipped to the sequence's range, a
    cubic overshoots), linear in time; only at keyframes. Velocity: each simulation
    frame resampled bilinearly once and rescaled to pixels of the keyframes' grid
    (:func:`fluidnb.fields.resize_vector_field`, compiled in
    ``_advance.upsample_velocity``), kept for the few frames a segment uses.
    """

    def __init__(self, temperature, velocity, shape):
        self._temperature = temperature
        self._velocity = velocity
        self._shape = tuple(shape)
        #: (H, W) of the keyframes' grid.
        self.shape = self._shape
        self._range = float(temperature.min()), float(temperature.max())
        self._same = self._shape == tuple(temperature.shape[1:])
        self._cache = {}

    def temperature(self, tau):
        """The temperature at simulation time ``tau`` on the keyframes' grid."""
        i = int(np.floor(tau))
        f = tau - i
        t = self._temperature[i].astype(np.float32)
        if f > 1e-9:
            t = (1 - f) * t + f * self._temperature[i + 1]
        if self._same:
            return t
        return np.clip(resize(t, self._shape, order=3), *self._range)

    def velocity(self, i):
        """Frame ``i``'s velocity (dy, dx) on the keyframes' grid, px per simulation frame."""
        if i not in self._cache:
            if len(self._cache) > 64:
                self._cache.pop(next(iter(self._cache)))
            v = self._velocity[i]
            if self._shape[0] >= v.shape[0] and self._shape[1] >= v.shape[1]:
                # = resize_vector_field(v, shape), compiled (30x faster).
                fine = np.empty((*self._shape, 2), np.float32)
                _advance.upsample_velocity(np.ascontiguousarray(v, np.float32), fine)
                v = fine
            elif not self._same:  # a coarser grid: anti-aliased
                v = resize_vector_field(v, self._shape).astype(np.float32)
            self._cache[i] = v
        return self._cache[i]

    def steps(self, t0, t1):
        """The displacements that carry a picture from time ``t0`` to ``t1``.

        Simulation frame ``i`` moves it by ``velocity[i]`` over ``(i - 1, i]``; a
        clip frame that spans part of a frame moves by that fraction of it, one that
        spans a frame's end takes two steps.
        """
        out = []
        while t1 - t0 > 1e-9:
            i = int(np.floor(t0 + 1e-9)) + 1
            end = min(t1, float(i))
            out.append(self.velocity(i) * np.float32(end - t0))
            t0 = end
        return out


def _simulate_preset(fluid_params, n_frames, gen, progress):
    """Run the flame preset (sec. 3.1) with ``fluid_params`` replacing its own."""
    from ..fluid import flame_preset, simulate

    preset = flame_preset()
    fluid_params = preset.params if fluid_params is None else fluid_params
    sim = simulate(
        fluid_params,
        preset.n_frames if n_frames is None else n_frames,
        shape=preset.shape,
        seed=gen,
        progress=progress,
        substeps=preset.substeps,
        warmup=preset.warmup,
    )
    return sim, fluid_params


def _temperature_and_velocity(simulation, n_frames):
    """Checked (temperature, velocity at the pixels, fps) of a simulation or a pair."""
    fps = SIMULATION_FPS
    if isinstance(simulation, tuple):
        if len(simulation) != 2:
            raise ValueError(
                "simulation must be a Simulation, an object with temperature and velocity, "
                f"or a pair (temperature, velocity), got a tuple of {len(simulation)}"
            )
        temperature, velocity = simulation
    else:
        for name in ("temperature", "velocity"):
            if not hasattr(simulation, name):
                raise ValueError(
                    f"simulation must have a {name!r} array (a fluidnb.fluid Simulation), "
                    f"or be a pair (temperature, velocity); got {type(simulation).__name__}"
                )
        temperature = simulation.temperature
        if callable(getattr(simulation, "centred_velocity", None)):
            # A fluidnb.fluid.Simulation stores its velocity staggered (MAC grid).
            velocity = simulation.centred_velocity()
        else:
            velocity = simulation.velocity
        fps = float(getattr(simulation, "fps", SIMULATION_FPS))
    temperature = check_array("temperature", temperature, ndim=3, dtype_kinds="iuf")
    velocity = check_array("velocity", velocity, ndim=4, dtype_kinds="iuf")
    n, h, w = temperature.shape
    if velocity.shape != (n, h, w, 2):
        raise ValueError(
            f"velocity must have shape (T, H, W, 2) = {(n, h, w, 2)} to match the "
            f"temperature, got {velocity.shape}"
        )
    # A backtrace longer than the image reads only its border: no simulation of
    # this picture moves that fast, so such a velocity is a unit mistake.
    limit = max(h, w)
    speed = float(np.sqrt((velocity.astype(np.float64) ** 2).sum(-1)).max())
    if speed > limit:
        raise ValueError(
            f"velocity must be at most max(H, W) = {limit} pixels per frame in magnitude "
            f"(a backtrace longer than the image leaves it), got {speed:g}"
        )
    if n_frames is not None:
        if n_frames > n:
            raise ValueError(f"n_frames must be <= the simulation's {n} frames, got {n_frames}")
        temperature, velocity = temperature[:n_frames], velocity[:n_frames]
    return temperature, velocity.astype(np.float32), fps


def _resize_photo(photo, matte, size):
    ha, wa = photo.shape[:2]
    if size == 0 or max(ha, wa) == size:
        return photo, matte
    scale = size / max(ha, wa)
    shape = (max(1, round(ha * scale)), max(1, round(wa * scale)))
    photo = np.clip(resize(photo, shape), 0.0, 1.0)
    if matte is not None:
        matte = np.clip(resize(matte, shape), 0.0, 1.0)
    return photo, matte
