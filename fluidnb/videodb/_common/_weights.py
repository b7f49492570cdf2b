r"""Partition-of-unity weights of the fragment grid (Burt & Adelson 1983; Okabe et al., sec. 6).

Each fragment gets a flat-topped tent over its 48 x 48 core; divided by their sum,
the weights make one everywhere the cores cover (:func:`fragment_weights`). The
rendering blends the fragments' difference frames with them
(:mod:`fluidnb.videodb.rendering._blend`), and the assignment spreads per-fragment
values -- the assigned mean motion, say -- over the image with them
(:func:`blend_values`), so both live below both.
"""

from __future__ import annotations

import numpy as np

from ..._validation import check_array, check_int, check_range
from ._geometry import FRAGMENT, STRIDE

__all__ = ["FEATHER", "blend_values", "fragment_weights"]

#: Default width in pixels of the level-0 transition between neighbouring fragments'
#: cells (:func:`fragment_weights`). 24 would be the plain tent: every pixel's finest
#: detail then mixes two or four fragments, and two unrelated textures mixed half and
#: half lose half their variance, a grid of washed-out bands 24 px apart. 0 is Burt &
#: Adelson's binary masks: full contrast, but a 4-level pyramid of sigma-1 blurs still
#: leaves a visible line between smooth textures. Measured on pairs of independent
#: textures (blur 0.7-3 px): 8 px keeps 73-79 % of the variance on average (the tent
#: 53-56 %, binary 80-96 %) with a gradient jump at the cell borders within 1.2 times
#: the tent's (binary: 1.6-3.7 times).
FEATHER = 8


# Floor of the raw 1-D weight profile: keeps every fragment's weight positive on its
# whole core, so the normalisation never divides by zero where neighbours are missing
# (at the canvas border, or fragments that do not take part) and stays continuous.
_FLOOR = 1e-3


def _profile(feather):
    """Raw 1-D weight over a fragment's 48 pixels (floored, not yet normalised).

    ``e`` is the distance of a pixel centre to the nearer core edge (0.5 .. 23.5 px);
    the boundary between two neighbours' cells lies at ``e = 12``. A linear ramp of
    width ``feather`` centred there sums to one with the neighbour's mirrored ramp.
    """
    u = np.arange(FRAGMENT, dtype=np.float64) + 0.5
    e = np.minimum(u, FRAGMENT - u)
    half = STRIDE / 2
    if feather == 0:
        ramp = (e > half).astype(np.float64)
    else:
        ramp = np.clip((e - half) / feather + 0.5, 0.0, 1.0)
    return np.maximum(ramp, _FLOOR)


def _raw_weights(feather):
    p = _profile(feather)
    return np.outer(p, p)


def _check_positions(positions, canvas_shape):
    shape = _check_canvas(canvas_shape)
    pos = check_array("positions", positions, ndim=2, dtype_kinds="iuf", min_size=0)
    if pos.shape[1:] != (2,):
        raise ValueError(f"positions must have shape (P, 2) as (row, col), got {pos.shape}")
    if pos.dtype.kind == "f" and not np.all(pos == np.round(pos)):
        raise ValueError("positions must hold whole pixels, got fractional values")
    pos = pos.astype(np.int64)
    if pos.size and np.any(pos % STRIDE):
        raise ValueError(
            f"positions must be multiples of the stride {STRIDE}, got "
            f"{pos[np.any(pos % STRIDE, axis=1)][0].tolist()}"
        )
    if pos.size and (
        pos.min() < 0
        or np.any(pos[:, 0] + FRAGMENT > shape[0])
        or np.any(pos[:, 1] + FRAGMENT > shape[1])
    ):
        raise ValueError(
            f"positions must place every {FRAGMENT} x {FRAGMENT} core inside the canvas "
            f"{shape}, got rows {pos[:, 0].min()}..{pos[:, 0].max()} and cols "
            f"{pos[:, 1].min()}..{pos[:, 1].max()}"
        )
    if len(np.unique(pos, axis=0)) != len(pos):
        raise ValueError("positions must not repeat: one fragment per grid position")
    return pos, shape


def _check_canvas(canvas_shape):
    try:
        shape = tuple(int(check_int("canvas_shape", s, FRAGMENT)) for s in canvas_shape)
    except TypeError:
        raise ValueError(f"canvas_shape must be (H, W), got {canvas_shape!r}") from None
    if len(shape) != 2:
        raise ValueError(f"canvas_shape must be (H, W), got {canvas_shape!r}")
    return shape


def _check_feather(feather):
    return check_range("feather", feather, 0, STRIDE)


def _weight_sum(pos, shape, raw):
    total = np.zeros(shape, dtype=np.float64)
    for r, c in pos:
        total[r : r + FRAGMENT, c : c + FRAGMENT] += raw
    return total


def fragment_weights(positions, canvas_shape, *, feather=FEATHER):
    """Partition-of-unity weights of the fragments on the stride-24 grid.

    Each fragment gets a weight over its 48 x 48 core: the product of two 1-D profiles
    that ramp linearly across the boundary between its cell and its neighbours' (the
    line halfway between their centres, 12 px inside the core), over ``feather``
    pixels (a flat-topped tent), then every weight is divided by the sum of all
    fragments' weights at each pixel. With ``feather = 24`` the profile is the plain
    tent of a fragment (0.5/24 at the core's edge, 1 at its centre) and neighbours'
    tents already sum to one; with ``feather = 0`` each pixel belongs to the fragment
    whose centre is nearest (Burt & Adelson's binary masks); the default,
    :data:`FEATHER` = 8, keeps most of the fine detail's contrast and no seam (see
    there). Raw profiles are floored at 1e-3, so the division makes the weights sum to
    exactly one (to rounding) everywhere in the union of the cores, also at the canvas
    border and next to fragments that do not take part, where fewer fragments cover a
    pixel, and the weights stay continuous there.

    Parameters
    ----------
    positions : ndarray, shape (P, 2), int
        Top-left (row, col) of each taking-part fragment's core on the canvas,
        multiples of 24.
    canvas_shape : tuple of int, (Hc, Wc)
        The canvas the fragments tile.
    feather : float
        Width in pixels of the linear transition between neighbouring cells, in
        [0, 24].

    Returns
    -------
    ndarray, shape (P, 48, 48), float64
        Pasted at their positions and summed, 1 on every pixel a core covers, 0
        elsewhere.

    References
    ----------
    .. [1] P. J. Burt and E. H. Adelson, "A multiresolution spline with application to
       image mosaics", ACM Transactions on Graphics 2(4), pp. 217-236, 1983.

    Examples
    --------
    >>> w = fragment_weights([[0, 0], [0, 24]], (48, 72))
    >>> w.shape
    (2, 48, 48)
    >>> total = np.zeros((48, 72))
    >>> total[:, :48] += w[0]
    >>> total[:, 24:] += w[1]
    >>> bool(np.allclose(total, 1.0, rtol=0, atol=1e-12))
    True
    """
    pos, shape = _check_positions(positions, canvas_shape)
    raw = _raw_weights(_check_feather(feather))
    total = _weight_sum(pos, shape, raw)
    out = np.empty((len(pos), FRAGMENT, FRAGMENT), dtype=np.float64)
    for k, (r, c) in enumerate(pos):
        out[k] = raw / total[r : r + FRAGMENT, c : c + FRAGMENT]
    return out


def blend_values(values, positions, canvas_shape):
    r"""Per-fragment values spread over the canvas by the blend's weights.

    Parameters
    ----------
    values : ndarray, shape (P, ...)
        One value (a vector, a sequence...) per fragment, e.g. its mean motion (P, 2).
    positions : ndarray, shape (P, 2), int
        Top-left (row, col) of each fragment's core on the canvas, multiples of 24.
    canvas_shape : tuple of int, (Hc, Wc)
        The canvas the fragments tile.

    Returns
    -------
    ndarray, shape (Hc, Wc, ...), float32
        :math:`\sum_p w_p(x)\, v_p` with the weights of :func:`fragment_weights`
        (default feather): the fragments' values where they own the pixel, blended
        across their overlaps, 0 outside every core.
    """
    weights = fragment_weights(positions, canvas_shape)
    out = np.zeros(tuple(canvas_shape) + values.shape[1:], np.float64)
    for (r, c), wgt, v in zip(positions, weights, values):
        out[r : r + FRAGMENT, c : c + FRAGMENT] += wgt.reshape(wgt.shape + (1,) * v.ndim) * v
    return out.astype(np.float32)
