"""Keyframes, advection between them and cross-dissolve (seed 3.3, 3.4, Fig. 5-6)."""

from __future__ import annotations

import dataclasses
import numbers
import time
from dataclasses import dataclass

import numpy as np

from .._clip import DEFAULT_FPS, Clip
from .._progress import Progress
from .._random import rng
from .._validation import check_array, check_int
from ..fields import advect, resize
from ._params import FireParams
from ._synthesis import _check_photo, _photo_and_matte, _run

__all__ = [
    "FireResult",
    "colour_temperature",
    "dissolve_weights",
    "fire",
    "fire_flame",
    "fire_from_simulation",
]


def dissolve_weights(n_frames, interval, overlap):
    """Where the segments start and how much each contributes to every frame.

    Segment ``k`` starts at frame ``k (N - m)`` with a keyframe and lasts ``N``
    frames, so consecutive segments share ``m`` frames (seed Fig. 6). Over the
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
    """What :func:`fire` makes.

    Attributes
    ----------
    clip : Clip
        The fire, (T, H, W, 3), with ``method="fire"``, params, seed, timings and
        the keyframe frame numbers in its metadata.
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
        The photo as used (resized to ``params.input_size``).
    texture_alpha : ndarray, shape (Ha, Wa), float32
        Its alpha :math:`a_a` (the matte, or the normalised luminance).
    target : ndarray, shape (T, H, W), float32
        :math:`I_t`: the temperature normalised to [0, 1] over the whole sequence.
    simulation : object or None
        The fluid simulation the clip was made from, when :func:`fire_flame` ran it.
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


def fire(
    photo,
    temperature,
    velocity,
    params=None,
    *,
    matte=None,
    seed=None,
    progress=None,
    fps=DEFAULT_FPS,
):
    r"""Animate fire that looks like ``photo`` and moves like a simulation.

    The seed's pipeline (Sec. 3.2-3.4): the temperature of frame ``s`` is the
    target of a texture synthesis from the photo (:func:`synthesize`, a keyframe);
    the keyframe is then advected by backtracing with the simulation's velocity,
    one step per frame (Fig. 5, :func:`fluidnb.fields.advect`), for the rest of its
    segment of ``N`` frames; consecutive segments overlap by ``m`` frames and are
    cross-dissolved linearly (Fig. 6, :func:`dissolve_weights`).

    Parameters
    ----------
    photo : array_like, shape (Ha, Wa, 3)
        :math:`I_a`, a photograph of fire on a dark background.
    temperature : array_like, shape (T, H, W)
        The simulation's temperature per frame; normalised to [0, 1] by the
        sequence's minimum and maximum to make :math:`I_t`.
    velocity : array_like, shape (T, H, W, 2)
        The simulation's velocity per frame, (dy, dx) in pixels per frame. Frame
        ``t`` of a segment is frame ``t - 1`` advected with ``velocity[t]``.
    params : FireParams, optional
    matte : array_like, shape (Ha, Wa), optional
        The photo's alpha matte; default its normalised luminance.
    seed : None, int or numpy.random.Generator
        Same seed, same clip.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.
    fps : float
        Frame rate of the clips.

    Returns
    -------
    FireResult

    Raises
    ------
    ValueError
        For a photo that is not RGB, a matte of another size, temperature and
        velocity sequences of different lengths or sizes, NaN, or bad params.

    References
    ----------
    .. [1] A. Kogawa (古川 歩), Y. Dobashi (土橋 宜典), T. Yamamoto (山本 強),
       "実写画像に類似した流体アニメーションの生成" (Creating realistic animation
       of fluids using photographs), Sec. 3.2-3.4, Fig. 4-6.
    .. [2] M. Ashikhmin, "Synthesizing natural textures", Proc. I3D, 2001.

    Examples
    --------
    A warm blob rising one pixel per frame:

    >>> from fluidnb.data import sample
    >>> photo, matte = sample("flame", size=24, return_alpha=True)
    >>> yy, xx = np.mgrid[:16, :16]
    >>> temp = np.stack([np.exp(-((xx - 8) ** 2 + (yy - 10 + t) ** 2) / 12) for t in range(4)])
    >>> vel = np.zeros((4, 16, 16, 2))
    >>> vel[..., 0] = -1.0
    >>> result = fire(photo, temp, vel, FireParams(interval=2), matte=matte, seed=0)
    >>> result.clip
    Clip(4 frames, 16x16 RGB, 8 fps, method='fire')
    >>> result.starts.tolist()
    [0, 1, 2, 3]
    """
    started = time.perf_counter()
    params = FireParams() if params is None else params
    if not isinstance(params, FireParams):
        raise ValueError(f"params must be a FireParams, got {type(params).__name__}")
    report = Progress(progress)
    photo, matte = _photo_and_matte(photo, matte)
    temperature = check_array("temperature", temperature, ndim=3, dtype_kinds="iuf")
    n, h, w = temperature.shape
    velocity = check_array("velocity", velocity, ndim=4, dtype_kinds="iuf")
    if velocity.shape != (n, h, w, 2):
        raise ValueError(
            f"velocity must have shape (T, H, W, 2) = {(n, h, w, 2)} to match the "
            f"temperature, got {velocity.shape}"
        )
    texture, texture_matte = _resize_photo(photo, matte, params.input_size)
    texture, alpha = _check_photo(texture, texture_matte)
    target = _normalise(temperature)
    gen = rng(seed)
    starts, weights = dissolve_weights(n, params.interval, params.m)

    frames = np.zeros((n, h, w, 3), np.float32)
    keyframes = np.empty((len(starts), h, w, 3), np.float32)
    sources = np.empty((len(starts), h, w, 2), np.int64)
    t_synth = t_advect = 0.0
    done, total = 0, sum(min(s + params.interval, n) - s for s in starts)
    for k, s in enumerate(starts):
        report(done / total, f"keyframe {k + 1}/{len(starts)} (frame {s})")
        clock = time.perf_counter()
        image, src, _ = _run(texture, alpha, target[s], params, False, gen)
        t_synth += time.perf_counter() - clock
        keyframes[k], sources[k] = image, src
        clock = time.perf_counter()
        for t in range(s, min(s + params.interval, n)):
            if t > s:
                image = advect(image, velocity[t])
            frames[t] += weights[k, t].astype(np.float32) * image
            done += 1
            if t > s and (t - s) % 8 == 0:
                report(done / total, f"advecting segment {k + 1}")
        t_advect += time.perf_counter() - clock
    np.clip(frames, 0.0, 1.0, out=frames)
    report(1.0, "done")
    timings = {
        "synthesis": t_synth,
        "advection": t_advect,
        "total": time.perf_counter() - started,
    }
    meta = {
        "method": "fire",
        "params": params.to_dict(),
        "seed": seed if isinstance(seed, numbers.Integral) else None,
        "timings": timings,
        "keyframes": starts.tolist(),
    }
    clip = Clip(frames, fps=fps, metadata=meta)
    tclip = Clip(
        colour_temperature(target),
        fps=fps,
        metadata={"method": "fire", "what": "temperature (normalised, inferno)"},
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
    )


def fire_from_simulation(photo, simulation, params=None, *, matte=None, seed=None, progress=None):
    """:func:`fire` on a fluid simulation's temperature and velocity.

    Parameters
    ----------
    photo : array_like, shape (Ha, Wa, 3)
    simulation : fluidnb.fluid.Simulation or object
        Anything with ``temperature`` (T, H, W) and ``velocity`` (T, H, W, 2). A
        :class:`fluidnb.fluid.Simulation` stores a staggered velocity; its
        ``centred_velocity()`` (the velocity at the pixels) is used when present.
    params, matte, seed, progress
        As for :func:`fire`.

    Returns
    -------
    FireResult
        With ``simulation`` set.
    """
    for name in ("temperature", "velocity"):
        if not hasattr(simulation, name):
            raise ValueError(
                f"simulation must have a {name!r} array (a fluidnb.fluid Simulation), "
                f"got {type(simulation).__name__}"
            )
    if callable(getattr(simulation, "centred_velocity", None)):
        velocity = simulation.centred_velocity()
    else:
        velocity = simulation.velocity
    result = fire(
        photo,
        simulation.temperature,
        velocity,
        params,
        matte=matte,
        seed=seed,
        progress=progress,
        fps=getattr(simulation, "fps", DEFAULT_FPS),
    )
    return dataclasses.replace(result, simulation=simulation)


def fire_flame(
    photo,
    params=None,
    *,
    n_frames=None,
    fluid_params=None,
    matte=None,
    seed=None,
    progress=None,
):
    """Simulate the flame preset (seed 3.1) and make fire from ``photo`` on it.

    Parameters
    ----------
    photo : array_like, shape (Ha, Wa, 3)
    params : FireParams, optional
    n_frames : int, optional
        Frames to simulate (default: the preset's).
    fluid_params : fluidnb.fluid.FluidParams, optional
        Replaces the preset's parameters (buoyancy, vorticity confinement, ...).
    matte, seed, progress
        As for :func:`fire`; ``seed`` seeds both the simulation and the synthesis.

    Returns
    -------
    FireResult
        With ``simulation`` set.
    """
    from ..fluid import flame_preset, simulate

    preset = flame_preset()
    fluid_params = preset.params if fluid_params is None else fluid_params
    n_frames = preset.n_frames if n_frames is None else check_int("n_frames", n_frames, 1)
    gen = rng(seed)
    first, second = Progress(progress).split(0.3)
    sim = simulate(
        fluid_params,
        n_frames,
        shape=preset.shape,
        seed=gen,
        progress=first,
        substeps=preset.substeps,
        warmup=preset.warmup,
    )
    result = fire_from_simulation(photo, sim, params, matte=matte, seed=gen, progress=second)
    meta = result.clip.metadata
    meta["seed"] = seed if isinstance(seed, numbers.Integral) else None
    meta["fluid_params"] = fluid_params.to_dict()
    clip = result.clip.with_metadata(**meta)
    return dataclasses.replace(result, clip=clip)


def _normalise(temperature):
    t = temperature.astype(np.float32)
    lo, hi = float(t.min()), float(t.max())
    if hi <= lo:
        return np.zeros_like(t)
    return np.clip((t - lo) / (hi - lo), 0.0, 1.0)


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
