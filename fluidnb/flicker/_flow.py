r"""The flow mapping's velocity, from a stroke drawn on the photo (beyond the paper).

The paper's mappings (Yamamoto & Sakamoto, sec. 3.2) are symmetric in
:math:`(f_x, f_y)`: ripples run both ways and nothing is carried along. The flow
mapping tilts the plane by a velocity :math:`v` (:func:`temporal_frequencies`), so
every spatial frequency travels along :math:`v`. A user gives :math:`v` by drawing
along the stream: the stroke's direction is the direction of flow, and its length is
the distance the surface travels in one loop of ``T`` frames.
"""

from __future__ import annotations

import numpy as np

from .._validation import check_array, check_int
from ._spectrum import check_velocity

__all__ = ["as_velocity", "flow_velocity"]


def flow_velocity(strokes, T):
    """The velocity ``(dy, dx)`` in pixels per frame that strokes drawn along a flow mean.

    Each stroke counts by its start-to-end displacement (the way it was drawn, not
    its wiggles); several strokes are averaged. The displacement is what the surface
    travels in one loop, so ``v = displacement / T``.

    Parameters
    ----------
    strokes : array_like, shape (n, 2), or sequence of them
        Polylines in (row, col) image pixels, each drawn in the direction of flow.
    T : int
        Frames per loop.

    Returns
    -------
    ndarray, shape (2,), float64
        :math:`v = (v_y, v_x)`, ``dy > 0`` down the image.

    Raises
    ------
    ValueError
        If there is no stroke of at least two points, or the result is faster than
        :data:`MAX_SPEED` pixels per frame.

    Examples
    --------
    >>> flow_velocity([[10, 0], [10, 32]], T=64).tolist()
    [0.0, 0.5]
    >>> flow_velocity([[[0, 40], [0, 8]], [[5, 40], [5, 8]]], T=64).tolist()
    [0.0, -0.5]
    """
    T = check_int("T", T, 2)
    if (isinstance(strokes, np.ndarray) and strokes.ndim == 2) or (
        len(strokes) and np.ndim(strokes[0]) == 1
    ):
        strokes = [strokes]
    moves = []
    for i, stroke in enumerate(strokes):
        pts = check_array(f"strokes[{i}]", stroke, ndim=2, dtype_kinds="iuf")
        if pts.shape[1] != 2:
            raise ValueError(f"strokes[{i}] must have shape (n, 2) as (row, col), got {pts.shape}")
        if len(pts) >= 2:
            moves.append(pts[-1].astype(np.float64) - pts[0])
    if not moves:
        raise ValueError("strokes must hold at least one stroke of two or more points")
    return check_velocity(np.mean(moves, axis=0) / T, "flow")


def as_velocity(flow, T):
    """``flow=`` as given to :func:`~fluidnb.flicker.flicker`: a velocity or strokes.

    A 1-D pair is a velocity ``(dy, dx)`` in pixels per frame; anything else is one
    stroke or a list of strokes (:func:`flow_velocity`).

    Examples
    --------
    >>> as_velocity((0.25, 0), T=64).tolist()
    [0.25, 0.0]
    """
    if flow is None:
        return None
    if isinstance(flow, np.ndarray):
        pair = flow.ndim == 1
    else:
        pair = len(flow) == 2 and all(np.ndim(x) == 0 for x in flow)
    if pair:
        return check_velocity(flow, "flow")
    return flow_velocity(flow, T)
