r"""The fluid clips the starter databases are built from, made by fluidnb itself (beyond the paper).

The paper builds its databases from real footage (151 water, 96 fire and 89 smoke
videos, 640 x 360). No such footage ships with any package registry, so fluidnb makes
stand-ins, one set per kind of scene, from its own methods and bundled pictures:

- water: water-only crops of the bundled photos moved along flows that change in time
  (:mod:`fluidnb.videodb.starter._water`);
- smoke: :mod:`fluidnb.fluid` (Stable Fluids) plumes, and fire:
  :func:`fluidnb.fire.fire` flames (:mod:`fluidnb.videodb.starter._solver_clips`).

:func:`starter_clips` makes one kind's clips (on threads); :func:`submit_clips` hands
them to a build as they are made. Nothing here is cached:
:func:`~fluidnb.videodb.starter_database` caches the databases.
"""

from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..._clip import Clip
from ..._progress import Progress
from ..._random import resolve_seed, rng
from ..._validation import check_choice, check_int
from ._solver_clips import _FIRE, _SMOKE, _make_fire, _make_smoke
from ._water import _WATER, _make_water, _water

__all__ = ["STARTER_KINDS", "starter_clips", "submit_clips"]

#: The kinds of scene :func:`starter_clips` makes (one starter database each).
STARTER_KINDS = ("water", "smoke", "fire")


#: Frames per second of every starter clip.
_FPS = 24.0


@dataclass(frozen=True)
class _Size:
    """A mode: clips of (H, W) pixels and n_frames, the first n_clips recipes a kind."""

    shape: tuple
    n_frames: int
    n_clips: int | None  # None: every recipe


# Full mode: two 32-frame windows per clip at a size near half the paper's 640 x 360.
# Quick mode (tests, CI, notebooks): one window and a little spare, small frames.
_FULL = _Size((180, 320), 64, None)


_QUICK = _Size((96, 160), 36, 2)


def starter_clips(kind, *, quick=False, seed=0, workers=None, progress=None):
    """The fluid clips a starter database of ``kind`` is built from.

    Real fluid footage is not available to fluidnb, so these are made by the project
    itself (see :mod:`fluidnb.videodb.starter._water`): smoke from the fluid solver,
    fire from the fire method on the bundled fire photo, water by advecting water-only
    textures along known flows (:func:`flow_map_texture`). Each kind holds different
    motions (directions, speeds, turbulence), so that retrieval and the MRF have
    choices.

    Parameters
    ----------
    kind : {"water", "smoke", "fire"}
        The kind of scene (the paper builds one database per kind).
    quick : bool
        The first two clips of the kind, small (96 x 160, 36 frames: one window of
        N = 32 frames; about a second a kind), instead of all of them (eight of water,
        eight of smoke, six of fire; 180 x 320, 64 frames: two windows; 3-9 s a kind
        on one core).
    seed : None, int or numpy.random.Generator
        Seeds every clip; the same seed gives the same clips, bit for bit.
    workers : int, optional
        Clips made at once, on threads (default: the number of cores).
    progress : callable, optional
        ``progress(fraction, message)``, at every frame or solver step of every clip;
        raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    list of (str, Clip)
        ``(name, clip)`` pairs, names unique (``"water-cascade"``, ...); each clip
        float32 RGB (T, H, W, 3) in [0, 1] at 24 fps, with ``metadata``: ``method``
        (``"starter-water"``, ...), ``kind``, ``recipe``, ``params`` (what the recipe
        sets, plus the solver's or fire method's parameters), ``seed`` (the int used:
        :func:`fluidnb.resolve_seed` of the one given), ``clip_seed`` (the clip's own
        seed drawn from it), ``quick`` and ``timings``.

    Raises
    ------
    ValueError
        For an unknown ``kind``, a ``quick`` that is not a bool, a bad ``seed`` or a
        ``progress`` that is not callable.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Computer Graphics Forum 30(7) (Pacific Graphics 2011),
       section 4 (the video database).

    Examples
    --------
    >>> clips = starter_clips("water", quick=True, seed=0)
    >>> [name for name, _ in clips]
    ['water-river', 'water-cascade']
    >>> clips[0][1]
    Clip(36 frames, 160x96 RGB, 24 fps, method='starter-water')
    >>> clips[0][1].metadata["params"]["flow"]["type"]
    'shear'
    """
    workers = (os.cpu_count() or 1) if workers is None else check_int("workers", workers, 1, 64)
    with ThreadPoolExecutor(workers) as pool:
        futures = submit_clips(pool, kind, quick=quick, seed=seed, progress=progress)
        try:
            return [f.result() for f in futures]
        except BaseException:
            for f in futures:
                f.cancel()
            raise


def submit_clips(pool, kind, *, quick=False, seed=0, progress=None):
    """:func:`starter_clips`' clips, each made by a task of ``pool``: their futures, in order.

    Clips are independent (each has its own seed) and the solver's and synthesis'
    compiled kernels release the GIL: made side by side on threads, whose results
    are the same whatever their number. A starter build hands these futures to
    :func:`~fluidnb.videodb.build_database` as they are, and starts cutting each
    clip into fragments as soon as it is made (``future.result`` as a source).
    """
    check_choice("kind", kind, STARTER_KINDS)
    if not isinstance(quick, (bool, np.bool_)):
        raise ValueError(f"quick must be True or False, got {quick!r}")
    size = _QUICK if quick else _FULL
    report = Progress(progress)
    seed = resolve_seed(seed)
    gen = rng(seed)
    recipes = _RECIPES[kind]
    # One seed per recipe of the full set, drawn up front: a clip's randomness does
    # not depend on which other clips are made.
    clip_seeds = [int(s) for s in gen.integers(0, 2**31 - 1, size=len(recipes))]
    make = _MAKERS[kind]
    chosen = recipes if size.n_clips is None else recipes[: size.n_clips]
    parts = [0.0] * len(chosen)
    lock = threading.Lock()

    def part(i, name):
        def report_part(fraction, message=""):
            # Clips are made side by side: the whole is the mean of their fractions.
            with lock:
                parts[i] = max(parts[i], min(max(float(fraction), 0.0), 1.0))
                report(sum(parts) / len(parts), f"{name}: {message}")

        return report_part

    def make_one(i, recipe, clip_seed):
        name = f"{kind}-{recipe['name']}"
        started = time.perf_counter()
        stage = Progress(part(i, name))
        frames, params = make(recipe, size, clip_seed, stage)
        metadata = {
            "method": f"starter-{kind}",
            "kind": kind,
            "recipe": recipe["name"],
            "params": params,
            "seed": seed,
            "clip_seed": clip_seed,
            "quick": bool(quick),
            "timings": {"total": time.perf_counter() - started},
        }
        stage(1.0, "made")
        return name, Clip(frames, fps=_FPS, metadata=metadata)

    report(0.0, f"making {len(chosen)} {kind} clips")
    return [pool.submit(make_one, i, r, s) for i, (r, s) in enumerate(zip(chosen, clip_seeds))]


_RECIPES = {"water": _WATER, "smoke": _SMOKE, "fire": _FIRE}


_MAKERS = {"water": _make_water, "smoke": _make_smoke, "fire": _make_fire}


def _water_clip(recipe, *, quick=True, seed=0):
    """The frames, velocity and texture of the water clip ``recipe``.

    For tests and notebooks: the same frames as ``starter_clips("water", ...)`` gives
    for that recipe and seed, with the flow that moves them (the "ground truth") and
    the periodic texture they are made of.
    """
    names = [r["name"] for r in _WATER]
    check_choice("recipe", recipe, tuple(names))
    index = names.index(recipe)
    clip_seed = int(rng(seed).integers(0, 2**31 - 1, size=len(_WATER))[index])
    return _water(_WATER[index], _QUICK if quick else _FULL, clip_seed)
