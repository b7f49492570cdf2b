"""Animating one fluid image from a video database (Okabe et al., secs. 5-6): the entry point.

:func:`animate` = :func:`~fluidnb.videodb.assign` (which database fragment animates
each part of the image: retrieval, Eq. 1, and the MRF of Eq. 4-6) then
:func:`~fluidnb.videodb.render` (section 6).
"""

from __future__ import annotations

import dataclasses

from .._progress import Progress
from .._random import resolve_seed
from .assignment._assign import assign
from .rendering._render import render

__all__ = ["animate"]


def animate(
    image,
    matte=None,
    db="water",
    params=None,
    *,
    direction=None,
    speed=None,
    background=None,
    fps=24.0,
    seed=None,
    progress=None,
    stream=False,
    frames=None,
):
    r"""Animate a still image of fluid from a video database (Okabe et al. 2011).

    :func:`assign` (retrieval, Eq. 1; the MRF of Eq. 4-6 by alpha-expansion) then
    :func:`render` (section 6). The method is deterministic; ``seed`` is accepted for
    the library's convention and recorded.

    Parameters
    ----------
    image, matte, db, params, direction, speed
        As for :func:`assign`.
    background, fps, frames
        As for :func:`render` (``frames``: the flow rendering's clip length, whole
        repeats of the difference frames' loop).
    seed : None, int or numpy.random.Generator
        Nothing here is random; the int :func:`fluidnb.resolve_seed` makes of it is
        recorded in the clip's metadata, as every method does.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.
    stream : bool
        ``.clip`` a :class:`fluidnb.FrameStream` of the same frames, made as it is
        saved (:func:`render`): a file of a full-size photo's animation then needs
        memory for a few frames, not the clip. The assignment then keeps no
        smoothness tables (``assignment.tables`` is None; assign again to re-solve).

    Returns
    -------
    Animation
        ``.clip`` is the animation (a clip, or with ``stream`` a stream).

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Computer Graphics Forum 30(7) (Pacific Graphics 2011),
       sections 5-6.
    """
    seed = resolve_seed(seed)  # validated and recorded, as at every entry point
    first, second = Progress(progress).split(0.5)
    # A file needs no re-solve: the smoothness tables (3 x E x K x K float64, 0.9 GB
    # at 1920 px) are not kept, only W (the same values, a third of it, never all
    # four at once).
    assignment = assign(
        image,
        matte,
        db,
        params,
        direction=direction,
        speed=speed,
        progress=first,
        keep_tables=not stream,
    )
    result = render(
        assignment,
        background=background,
        fps=fps,
        progress=second,
        stream=stream,
        frames=frames,
    )
    return dataclasses.replace(result, clip=result.clip.with_metadata(seed=seed))
