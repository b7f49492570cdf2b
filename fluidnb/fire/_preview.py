"""A cheap look at the fire while its settings move: one keyframe at low resolution."""

from __future__ import annotations

import time

import numpy as np

from .._clip import Clip
from .._kept import LastKept
from .._random import resolve_seed
from .._validation import check_int
from ._params import FireParams
from ._pipeline import _resize_photo, fire
from ._synthesis import MIN_PHOTO_SIDE, _photo_and_matte

__all__ = ["keyframe_preview"]

# What the last preview made that a slider of the synthesis does not change, kept: the
# flame's warm-up simulation (half a preview's time; it depends on the fluid's
# parameters, the grid and the seed alone) and the photo composited with its matte and
# shrunk to the grid.
_FLAME = LastKept()
_PHOTO = LastKept()


def _flame(fluid, shape, seed, warmup):
    """The temperature at the end of the flame's warm-up, (1, *shape): simulated or kept."""
    from ..fluid import simulate

    found, temperature = _FLAME.get(fluid, shape, seed, warmup)
    if not found:
        sim = simulate(fluid, 1, shape=shape, seed=seed, warmup=warmup)
        temperature = sim.temperature[-1:].copy()
        temperature.flags.writeable = False
        _FLAME.keep((fluid, shape, seed, warmup), temperature)
    return temperature


def _small_photo(photo, matte, size):
    """The photo composited with its matte and shrunk to ``size``: made, or the last kept.

    As :func:`fire` makes its texture; passed to it with no matte, it is left as it is.
    """
    found, small = _PHOTO.get(photo, matte, size)
    if not found:
        small = _resize_photo(*_photo_and_matte(photo, matte), size)[0]
        if isinstance(photo, np.ndarray) and (matte is None or isinstance(matte, np.ndarray)):
            _PHOTO.keep((photo, matte, size), small)  # (a path may change on disk)
    return small


def keyframe_preview(photo, params=None, *, fluid_params=None, size=48, matte=None, seed=None):
    r"""One keyframe of the fire, synthesised on a small simulated flame.

    What an app shows while a slider moves (the whole clip follows when it rests):
    the flame preset (Furukawa et al. (2013), sec. 3.1) simulated on a ``size`` x
    ``size`` grid up to the end of its warm-up, and the photo synthesised onto that
    one temperature field (sec. 3.2, :func:`synthesize`) -- the texture, the flame's
    shape and the synthesis's weight, coherence and cutoff, without the
    advection and cross-dissolve of the other frames (sec. 3.3-3.4). About 30 ms at
    48 x 48 on one core, where the whole clip takes seconds.

    Parameters
    ----------
    photo : array_like or path
        :math:`I_a`, as for :func:`fire`.
    params : FireParams, optional
        The synthesis's settings (``input_size`` is set to ``size``).
    fluid_params : fluidnb.fluid.FluidParams, optional
        The flame's (default: the preset's).
    size : int
        The grid's side, at least 16.
    matte : array_like, optional
        The photo's alpha matte, as for :func:`fire`.
    seed : None, int or numpy.random.Generator
        Seeds the simulation and the synthesis (the int used is in the metadata).

    Returns
    -------
    Clip
        One frame, ``size`` x ``size`` RGB; metadata ``method="fire"``,
        ``preview=True``, ``seed``, ``timings``.

    Examples
    --------
    >>> from fluidnb.data import sample
    >>> photo, matte = sample("flame", size=32, return_alpha=True)
    >>> keyframe_preview(photo, matte=matte, size=24, seed=0)
    Clip(1 frame, 24x24 RGB, 24 fps, method='fire')
    """
    from ..fluid import flame_preset

    size = check_int("size", size, 16)
    params = FireParams() if params is None else params
    if not isinstance(params, FireParams):
        raise ValueError(f"params must be a FireParams, got {type(params).__name__}")
    seed = resolve_seed(seed)
    started = time.perf_counter()
    preset = flame_preset()
    fluid = preset.params if fluid_params is None else fluid_params
    shape = (size, size)
    temperature = _flame(fluid, shape, seed, preset.warmup_for(shape))
    simulated = time.perf_counter() - started
    # One frame: a (temperature, velocity) pair with no motion to advect.
    velocity = np.zeros((1, size, size, 2), np.float32)
    one = params.replace(input_size=size, output_size=size, interval=max(params.overlap + 1, 2))
    texture = _small_photo(photo, matte, size)
    if min(texture.shape[:2]) >= MIN_PHOTO_SIDE:
        result = fire(texture, (temperature, velocity), one, seed=seed)
    else:  # a sliver fire itself accepts (it checks the photo before shrinking it)
        result = fire(photo, (temperature, velocity), one, matte=matte, seed=seed)
    return Clip(
        result.keyframes[:1],
        fps=24.0,
        metadata={
            "method": "fire",
            "preview": True,
            "seed": seed,
            "params": params.to_dict(),
            "fluid_params": fluid.to_dict(),
            "timings": {"simulation": simulated, "total": time.perf_counter() - started},
        },
    )
