"""Brush painting on scalar maps, at image resolution (what the brush tool calls)."""

from __future__ import annotations

import numpy as np
from skimage.segmentation import flood_fill as _sk_flood_fill

from .._validation import check_array, check_range

__all__ = ["flood_fill", "paint_disk", "paint_segment"]


def _check_target(array):
    if not isinstance(array, np.ndarray) or array.ndim != 2:
        raise ValueError("array must be a 2-D numpy array to paint into")
    return array


def paint_disk(array, center, radius, value):
    """Set every pixel within ``radius`` of ``center`` to ``value``, in place.

    Parameters
    ----------
    array : ndarray, shape (H, W)
        The map to paint (modified in place; a brush works on its own copy).
    center : (float, float)
        (row, col) in pixels.
    radius : float
        Brush radius in pixels (>= 0; 0 paints the nearest pixel).
    value : float or bool
        The value to paint.

    Returns
    -------
    tuple of slice
        The bounding box that changed (for partial redraws).

    Examples
    --------
    >>> a = np.zeros((5, 5))
    >>> _ = paint_disk(a, (2, 2), 1, 1.0)
    >>> int(a.sum())
    5
    """
    return paint_segment(array, center, center, radius, value)


def paint_segment(array, start, end, radius, value):
    """Paint a round-capped thick segment (a brush dragged from ``start`` to ``end``).

    Every pixel whose centre lies within ``radius`` of the segment is set to
    ``value``, so a drag paints a continuous band however fast the mouse moved.

    Parameters
    ----------
    array : ndarray, shape (H, W)
        The map to paint, modified in place.
    start, end : (float, float)
        (row, col) in pixels.
    radius : float
        Brush radius in pixels (>= 0).
    value : float or bool
        The value to paint.

    Returns
    -------
    tuple of slice
        The bounding box that changed (empty slices if the brush is off the map).
    """
    _check_target(array)
    radius = check_range("radius", radius, 0, None)
    p0 = check_array("start", start, ndim=1, dtype_kinds="iuf").astype(float)
    p1 = check_array("end", end, ndim=1, dtype_kinds="iuf").astype(float)
    h, w = array.shape
    r = max(radius, 0.5)  # radius 0 still paints the pixel under the cursor
    lo = np.floor(np.minimum(p0, p1) - r).astype(int)
    hi = np.ceil(np.maximum(p0, p1) + r).astype(int) + 1
    r0, c0 = max(lo[0], 0), max(lo[1], 0)
    r1, c1 = min(hi[0], h), min(hi[1], w)
    box = (slice(r0, max(r1, r0)), slice(c0, max(c1, c0)))
    if r1 <= r0 or c1 <= c0:
        return box
    rr, cc = np.mgrid[r0:r1, c0:c1]
    d = p1 - p0
    length2 = float(d @ d)
    if length2 == 0:
        t = 0.0
    else:
        t = np.clip(((rr - p0[0]) * d[0] + (cc - p0[1]) * d[1]) / length2, 0.0, 1.0)
    dist2 = (rr - (p0[0] + t * d[0])) ** 2 + (cc - (p0[1] + t * d[1])) ** 2
    array[box][dist2 <= r * r] = value
    return box


def flood_fill(array, start, value, *, tolerance=None):
    """Fill the connected region of equal values around ``start``; a new array.

    Parameters
    ----------
    array : ndarray, shape (H, W)
        The map (not modified).
    start : (int, int)
        (row, col) where the fill starts; rounded to the nearest pixel.
    value : float or bool
        The fill value.
    tolerance : float, optional
        Also fill neighbours whose value differs from the start pixel's by at most this.

    Returns
    -------
    ndarray
        The filled copy (4-connected fill, as in paint programs).
    """
    _check_target(array)
    r, c = (int(round(float(v))) for v in start)
    h, w = array.shape
    if not (0 <= r < h and 0 <= c < w):
        raise ValueError(f"start must lie inside the map (0..{h - 1}, 0..{w - 1}), got {(r, c)}")
    return _sk_flood_fill(array, (r, c), value, connectivity=1, tolerance=tolerance)
