"""The whole frost method in one call: image + painted region + start points -> clip."""

from __future__ import annotations

import time

import numpy as np  # noqa: F401  (the doctest below uses np)

from .._image import as_image, as_mask
from .._progress import Progress
from .._random import resolve_seed
from ._lattice import HexLattice
from ._optimise import optimise_beta
from ._reiter import _check_params, grow
from ._render import check_image_size, render

__all__ = ["frost"]


def frost(
    image,
    region,
    starts,
    params=None,
    *,
    seed=None,
    solver=None,
    every=1,
    size=None,
    return_result=False,
    stream=False,
    progress=None,
):
    r"""Animate frost growing over a painted region of an image from start points.

    Builds the hexagonal lattice in the region (Sec. 3.1 of [1]_), optionally
    optimises :math:`\beta` so the run ends at ``params.target`` (Sec. 3.4), grows
    the frost with Reiter's automaton and the random threshold (Sec. 3.2-3.3) and
    draws it as ice lying on the image (:func:`render`).

    Parameters
    ----------
    image : array_like or path
        The picture (anything :func:`fluidnb.as_image` accepts).
    region : array_like of bool, shape (H, W)
        Where frost may grow (a painted mask of the image's size).
    starts : array_like, shape (n, 2)
        Start points, (row, col) in image pixels, inside the region.
    params : FrostParams, optional
        The paper's defaults if omitted.
    seed : None, int or numpy.random.Generator
        The random seed of :math:`r_t(p)`; the int actually used is stored in the metadata.
    solver : {None, "secant", "steepest"}
        Optimise :math:`\beta` for ``params.target`` first with this solver.
    every : int
        Draw every k-th step (the clip's fps is divided by k).
    size : int, optional
        Longest side of the output (default: the image's size).
    return_result : bool
        Also return the :class:`FrostResult` (per-cell freeze frames, for re-timing).
    stream : bool
        Return a :class:`fluidnb.FrameStream` of the same frames instead of the clip
        (``render(..., stream=True)``): drawn as it is saved, a few at a time, for a
        file at full size. Its ``timings`` are the growth's and the drawing's.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    clip : Clip
        Metadata: ``method="frost"``, ``params`` (with the optimised beta), ``seed``,
        ``timings``, ``end_frame`` (``None`` if 90 % was never reached), ``n_cells``,
        ``message`` and, with a solver, ``optimise`` (the iteration table).
    result : FrostResult
        Only with ``return_result=True``.

    Raises
    ------
    ValueError
        For an empty region, starts outside it, a spacing too large for it, invalid
        parameters, or (with a solver) a target no beta can reach.

    References
    ----------
    .. [1] M. Amano, S. Sato, T. Itoh, "スケッチ入力を用いた氷・霜アニメーション生成の
       ための初期値最適化による成長速度制御" (Growth speed control by initial value
       optimisation for sketch-based ice and frost animation).

    Examples
    --------
    >>> from fluidnb import data
    >>> from fluidnb.frost import FrostParams
    >>> img = data.sample("window", size=64)
    >>> region = np.zeros(img.shape[:2], bool)
    >>> region[16:40, 20:44] = True
    >>> clip = frost(img, region, [[28, 32]], FrostParams(beta=0.5, spacing=3), seed=0, every=10)
    >>> clip.metadata["method"], clip.metadata["end_frame"] is not None
    ('frost', True)
    """
    params = _check_params(params)
    started = time.perf_counter()
    img = as_image(image, mode="rgb")
    check_image_size(img.shape)
    mask = as_mask(region, shape=img.shape[:2], name="region")
    seed = resolve_seed(seed)  # recorded, so the clip can be remade
    report = Progress(progress)
    timings = {}
    t0 = time.perf_counter()
    lattice = HexLattice.from_mask(mask, params.spacing)
    cells = lattice.snap(starts)
    timings["lattice"] = time.perf_counter() - t0
    extra = {}
    if solver is not None:
        first, grow_report, draw_report = report.split(0.5, 0.75)
        t0 = time.perf_counter()
        opt = optimise_beta(
            lattice, cells, params.target, params, method=solver, seed=seed, progress=first
        )
        timings["optimise"] = time.perf_counter() - t0
        params = params.replace(beta=opt.beta)
        extra["optimise"] = opt.to_dict()
    else:
        grow_report, draw_report = report.split(0.5)
    result = grow(lattice, cells, params, seed=seed, progress=grow_report)
    timings["grow"] = result.seconds
    t0 = time.perf_counter()
    clip = render(img, lattice, result, every=every, size=size, stream=stream, progress=draw_report)
    if not stream:  # a stream times its drawing as it draws (render's metadata)
        timings["render"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - started
        extra["timings"] = timings
    clip = clip.with_metadata(
        params=params.to_dict(),
        seed=seed,
        n_cells=lattice.n_cells,
        start_cells=lattice.points[cells].tolist(),
        **extra,
    )
    return (clip, result) if return_result else clip
