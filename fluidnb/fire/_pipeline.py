"""The fire entry point: keyframes, advection between them and cross-dissolve.

Furukawa et al. (2013), sec. 3.3-3.4, Fig. 5-6.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .._clip import DEFAULT_FPS, Clip
from .._progress import Progress
from .._random import resolve_seed, rng
from .._validation import check_array, check_int
from ..fields import advect, backward_warp, resize
from ._synthesis import _check_params, _check_photo, _photo_and_matte, _run

__all__ = ["FireResult", "colour_temperature", "dissolve_weights", "fire", "temperature_target"]


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
    t = np.asarray(temperature, dtype=np.float64)
    lo, hi = float(t.min()), float(t.max())
    if hi <= lo:
        return np.zeros(t.shape, np.float32)
    t = (t - lo) / (hi - lo)  # the paper's normalisation
    target = np.zeros(t.shape, np.float32)
    glowing = t > cutoff
    flame = np.sort(np.asarray(alpha, dtype=np.float64)[np.asarray(alpha) > 0.05])
    if not glowing.any() or flame.size == 0:
        return target
    hot = np.sort(t[glowing])
    # Rank of each glowing temperature in (0, 1], then the photo's alpha at that rank.
    rank = np.searchsorted(hot, t[glowing], side="right") / hot.size
    target[glowing] = np.interp(rank, np.arange(1, flame.size + 1) / flame.size, flame)
    return target


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
    clip : Clip
        The fire, (T, H, W, 3), with ``method="fire"``, params, the seed used,
        timings and the keyframe frame numbers in its metadata.
    temperature_clip : Clip
        The normalised temperature :math:`I_t`, colour-mapped, for comparison.
    keyframes : ndarray, shape (K, H, W, 3), float32
        The synthesised keyframes, before advection and blending.
    sources : ndarray, shape (K, H, W, 2), int64
        For each keyframe pixel its (row, col) in ``texture``.
    starts : ndarray, shape (K,), int
        The frame of each keyframe.
    weights : ndarray, shape (K, T)
        The cross-dissolve weights (:func:`dissolve_weights`).
    texture : ndarray, shape (Ha, Wa, 3), float32
        The photo as used: resized to ``params.input_size`` and composited onto
        black with its matte.
    texture_alpha : ndarray, shape (Ha, Wa), float32
        Its alpha :math:`a_a` (:func:`alpha_from_photo`).
    target : ndarray, shape (T, H, W), float32
        :math:`I_t`: the temperature normalised to [0, 1] over the whole sequence.
    simulation : object or None
        The fluid simulation the clip was made from (the one :func:`fire` ran, or
        the one it was given).
    seed : int
        The seed used (also ``clip.metadata["seed"]``): ``fire(..., seed=result.seed)``
        makes the same clip.
    """

    clip: Clip
    temperature_clip: Clip
    keyframes: np.ndarray
    sources: np.ndarray
    starts: np.ndarray
    weights: np.ndarray
    texture: np.ndarray
    texture_alpha: np.ndarray
    target: np.ndarray
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
        velocity is (dy, dx) in pixels per frame, at most ``max(H, W)`` in
        magnitude (frame ``t`` of a segment is frame ``t - 1`` advected with
        ``velocity[t]``).
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
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    FireResult
        ``result.clip`` is the fire, a :class:`fluidnb.Clip`.

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
    >>> result = fire(photo, (temp, vel), FireParams(interval=2), matte=matte, seed=0)
    >>> result.clip
    Clip(4 frames, 16x16 RGB, 8 fps, method='fire')
    >>> result.starts.tolist(), result.seed
    ([0, 1, 2, 3], 0)
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
    temperature, velocity, fps = _temperature_and_velocity(simulation, n_frames)
    n, h, w = temperature.shape
    texture, _ = _resize_photo(photo, matte, params.input_size)
    texture, alpha = _check_photo(texture, None)  # already composited with its matte
    target = temperature_target(temperature, alpha, params.cutoff)
    starts, weights = dissolve_weights(n, params.interval, params.m)

    frames = np.zeros((n, h, w, 3), np.float32)
    keyframes = np.empty((len(starts), h, w, 3), np.float32)
    sources = np.empty((len(starts), h, w, 2), np.int64)
    t_synth = t_advect = 0.0
    done, total = 0, sum(min(s + params.interval, n) - s for s in starts)
    for k, s in enumerate(starts):
        report(done / total, f"keyframe {k + 1}/{len(starts)} (frame {s})")
        clock = time.perf_counter()
        keyframe, src, _ = _run(texture, alpha, target[s], params, False, gen)
        t_synth += time.perf_counter() - clock
        keyframes[k], sources[k] = keyframe, src
        clock = time.perf_counter()
        displacement = np.zeros((h, w, 2), np.float32)  # d_s = 0: the keyframe itself
        image = keyframe
        for t in range(s, min(s + params.interval, n)):
            if t > s:
                # d_t(x) = -u_t(x) + d_{t-1}(x - u_t(x)): one more backtrace (Fig. 5).
                displacement = advect(displacement, velocity[t]) - velocity[t]
                image = backward_warp(keyframe, displacement)
            frames[t] += weights[k, t].astype(np.float32) * image
            done += 1
            if t > s and (t - s) % 8 == 0:
                report(done / total, f"advecting segment {k + 1}")
        t_advect += time.perf_counter() - clock
    np.clip(frames, 0.0, 1.0, out=frames)
    report(1.0, "done")
    meta.update(
        method="fire",
        params=params.to_dict(),
        seed=seed,
        timings={
            "synthesis": t_synth,
            "advection": t_advect,
            "total": time.perf_counter() - started,
        },
        keyframes=starts.tolist(),
    )
    clip = Clip(frames, fps=fps, metadata=meta)
    tclip = Clip(
        colour_temperature(target),
        fps=fps,
        metadata={"method": "fire", "what": "temperature (normalised, inferno)", "seed": seed},
    )
    return FireResult(
        clip=clip,
        temperature_clip=tclip,
        keyframes=keyframes,
        sources=sources,
        starts=starts,
        weights=weights,
        texture=texture,
        texture_alpha=alpha,
        target=target,
        simulation=None if isinstance(simulation, tuple) else simulation,
        seed=seed,
    )


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
    fps = DEFAULT_FPS
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
        fps = getattr(simulation, "fps", DEFAULT_FPS)
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
