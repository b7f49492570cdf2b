"""A unit direction field interpolated from sketched flow strokes.

Strokes are polylines in image pixels, (row, col). Their tangents, sampled evenly
along each stroke, are interpolated over the whole image with radial basis functions
(:class:`scipy.interpolate.RBFInterpolator`), then normalised. The video-database
method reads the user's intended flow from this field.
"""

from __future__ import annotations

import numbers

import numpy as np
from scipy.interpolate import RBFInterpolator

from .._validation import check_array, check_choice, check_finite, check_int, check_range

__all__ = ["check_strokes", "direction_field", "resample_stroke", "stroke_tangents"]

_KERNELS = ("thin_plate_spline", "linear", "cubic", "quintic", "gaussian", "multiquadric")


def _as_stroke(stroke, name):
    if isinstance(stroke, (list, tuple)) and stroke:
        # Checked point by point, a list needs only numpy's conversion and a finite
        # check: check_array's general path cost 200,000 strokes ten seconds.
        _check_points(stroke, name)
        arr = np.array(stroke, dtype=np.float64)
        if not np.isfinite(arr).all():
            check_finite(name, arr)  # raises, counting them
        return arr
    arr = check_array(name, stroke, ndim=2, dtype_kinds="iuf")
    if arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2) as (row, col), got {arr.shape}")
    return arr.astype(np.float64)


def _check_points(points, name):
    """Refuse, naming the stroke and the point, what numpy would turn into other numbers.

    A list is checked point by point before it becomes an array: numpy reads ``True``
    as 1, and a stroke of three-coordinate points is an (n, 3) array that a reshape
    would have made into different (row, col) points.
    """
    plain = (int, float)  # what JSON gives: checked by type alone, fast
    for j, point in enumerate(points):
        if (
            type(point) is list
            and len(point) == 2
            and type(point[0]) in plain
            and type(point[1]) in plain
        ):
            continue
        if isinstance(point, np.ndarray):
            point = point.tolist()
        if not isinstance(point, (list, tuple)):
            raise ValueError(
                f"{name} point {j} is {point!r}: each point must be a pair [row, col] of numbers"
            )
        if len(point) != 2:
            raise ValueError(
                f"{name} point {j} is {list(point)!r}: it has {len(point)} coordinates; a "
                "point has two, [row, col] in pixels"
            )
        for v in point:
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
                raise ValueError(
                    f"{name} point {j} is {list(point)!r}: coordinates must be numbers "
                    f"(pixels), not {type(v).__name__} {v!r}"
                )


def check_strokes(strokes, shape=None, name="strokes"):
    """Return strokes as a list of (n, 2) float64 arrays, refusing what cannot be meant.

    Refused, with a ValueError naming ``name``: no stroke at all, a stroke that is not
    an (n, 2) array of finite numbers, and (given the image's ``shape``) a point *far*
    outside the image, i.e. more than the image's own height (width) beyond its top or
    bottom (left or right) border. Such a point is a mistake -- (x, y) for (row, col),
    display coordinates, another image's strokes -- not a stroke drawn past the edge;
    points just outside are kept, as a hand drawing to the border makes them.

    Parameters
    ----------
    strokes : sequence of array_like, each shape (n_i, 2), or one (n, 2) array
        Polylines in (row, col) pixels.
    shape : tuple of int, optional
        The image's (H, W) (extra trailing entries are ignored).
    name : str
        How messages name the strokes.

    Examples
    --------
    >>> check_strokes([[[0, 0], [3, 4]]], (10, 10))[0].shape
    (2, 2)
    >>> check_strokes([[[0, 0], [3, 40]]], (10, 10))
    Traceback (most recent call last):
    ...
    ValueError: strokes[0] has a point at (row, col) = (3, 40), far outside the 10 x 10 image: ...
    """
    if isinstance(strokes, np.ndarray) and strokes.ndim == 2:
        strokes = [strokes]
    try:
        strokes = list(strokes)
    except TypeError:
        raise ValueError(
            f"{name} must be a list of (n, 2) arrays, got {type(strokes).__name__}"
        ) from None
    if not strokes:
        raise ValueError(f"{name} is empty: draw at least one stroke along the flow")
    out = [_as_stroke(s, f"{name}[{i}]") for i, s in enumerate(strokes)]
    if shape is not None:
        h, w = int(shape[0]), int(shape[1])
        pts = np.concatenate(out)
        rows, cols = pts[:, 0], pts[:, 1]
        far = (rows < -h) | (rows > 2 * h - 1) | (cols < -w) | (cols > 2 * w - 1)
        if far.any():
            k = int(np.argmax(far))
            i = int(np.searchsorted(np.cumsum([len(p) for p in out]), k, side="right"))
            r, c = pts[k]
            raise ValueError(
                f"{name}[{i}] has a point at (row, col) = ({r:g}, {c:g}), far outside "
                f"the {h} x {w} image: points may lie at most the image's size beyond "
                "its border (strokes are (row, col) pixels of the image)"
            )
    return out


def resample_stroke(stroke, spacing):
    """Points evenly spaced by arc length along a polyline.

    Parameters
    ----------
    stroke : array_like, shape (n, 2)
        Polyline vertices (row, col) in pixels.
    spacing : float
        Distance between samples in pixels (> 0).

    Returns
    -------
    ndarray, shape (m, 2)
        Samples from the first vertex to the last, at most ``spacing`` apart; a
        stroke of zero length gives its single point.

    Examples
    --------
    >>> resample_stroke([[0, 0], [0, 4]], 1.0)[:, 1].tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0]
    """
    pts = _as_stroke(stroke, "stroke")
    spacing = check_range("spacing", spacing, 0, None, lo_open=True)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] == 0:
        return pts[:1].copy()
    n = max(int(np.ceil(s[-1] / spacing)), 1) + 1
    t = np.linspace(0.0, s[-1], n)
    keep = np.concatenate([[True], seg > 0])  # repeated vertices break np.interp
    return np.stack([np.interp(t, s[keep], pts[keep, k]) for k in range(2)], axis=1)


def stroke_tangents(strokes, spacing=8.0):
    """Sample positions and unit tangents along every stroke.

    Parameters
    ----------
    strokes : sequence of array_like, each shape (n_i, 2)
        Polylines (row, col) in pixels, each drawn in its direction of flow.
    spacing : float
        Distance between samples along a stroke, in pixels.

    Returns
    -------
    points : ndarray, shape (m, 2)
        Sample positions (row, col): each stroke :func:`resample_stroke`-d.
    tangents : ndarray, shape (m, 2)
        Unit tangents (dy, dx) at those positions (central differences, one-sided at
        a stroke's ends). Strokes shorter than a pixel contribute nothing.

    Notes
    -----
    All strokes are sampled at once (one interpolation along their arc lengths laid
    end to end); :func:`fluidnb.sketch._reference.stroke_tangents` is the literal
    loop over strokes it replaces.
    """
    spacing = check_range("spacing", spacing, 0, None, lo_open=True)
    checked = [_as_stroke(s, f"strokes[{i}]") for i, s in enumerate(strokes)]
    return _tangents(checked, spacing)


def _tangents(strokes, spacing):
    """:func:`stroke_tangents` of checked (n_i, 2) float64 strokes, all at once."""
    empty = (np.empty((0, 2)), np.empty((0, 2)))
    counts = np.array([len(s) for s in strokes])
    strokes = [s for s, n in zip(strokes, counts) if n >= 2]
    counts = counts[counts >= 2]
    if not strokes:
        return empty
    pts = np.concatenate(strokes)
    ids = np.repeat(np.arange(len(counts)), counts)
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    last = first + counts - 1
    same = ids[1:] == ids[:-1]  # segment i joins points i and i + 1 of one stroke
    seg = np.where(same, np.linalg.norm(np.diff(pts, axis=0), axis=1), 0.0)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    arc -= arc[first][ids]  # arc length from each stroke's start
    length = arc[last]
    chord = np.linalg.norm(pts[last] - pts[first], axis=1)
    drawn = ~((chord < 1.0) & (length < 1.0))  # shorter than a pixel: no direction
    if not drawn.any():
        return empty
    # resample_stroke for every stroke: n samples evenly spaced over its length ...
    n = np.maximum(np.ceil(length / spacing).astype(np.int64), 1) + 1
    n = np.where(drawn, n, 0)
    sid = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(sid)) - np.repeat(np.cumsum(n) - n, n)
    t = k * (length / np.maximum(n - 1, 1))[sid]
    # ... by one interpolation along the strokes laid end to end, a pixel apart, without
    # repeated vertices (they break np.interp).
    offset = np.concatenate([[0.0], np.cumsum(length + 1.0)[:-1]])
    keep = np.concatenate([[True], ~same | (seg > 0)])
    xp = (arc + offset[ids])[keep]
    tg = t + offset[sid]
    samples = np.stack([np.interp(tg, xp, pts[keep, c]) for c in range(2)], axis=1)
    # np.gradient along each stroke: central inside, one-sided at its two ends.
    prev_same = np.concatenate([[False], sid[1:] == sid[:-1]])
    next_same = np.concatenate([sid[1:] == sid[:-1], [False]])
    ahead = np.where(next_same[:, None], np.roll(samples, -1, axis=0), samples)
    behind = np.where(prev_same[:, None], np.roll(samples, 1, axis=0), samples)
    d = (ahead - behind) / np.where(prev_same & next_same, 2.0, 1.0)[:, None]
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    ok = norm[:, 0] > 0
    return samples[ok], d[ok] / norm[ok]


def _merge_samples(points, tangents, max_samples):
    """At most ``max_samples`` samples: those in one grid cell become their mean.

    Every stroke gives at least two samples however far the spacing grows, so 200,000
    short strokes gave 400,000 samples, and the RBF fit (O(m^2) memory, O(m^3) time)
    ran out of memory. The cell grows until few enough cells hold samples; a cell's
    sample is at its samples' mean position, with their mean direction (unit, or zero
    where opposing strokes cancel, as in the field).
    """
    extent = np.ptp(points, axis=0)
    # Cells of the size that tiles the samples' bounding box max_samples times (a line
    # of samples: its length in max_samples cells), grown until few enough hold any.
    cell = max(np.sqrt(extent.prod() / max_samples), extent.max() / max_samples, 1e-6)
    while True:
        keys = np.floor(points / cell).astype(np.int64)
        _, group, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        group = group.reshape(-1)
        if len(counts) <= max_samples:
            break
        cell *= max(1.1, np.sqrt(len(counts) / max_samples))
    merged = np.zeros((len(counts), 2, 2))
    np.add.at(merged, group, np.stack([points, tangents], axis=1))
    centres = merged[:, 0] / counts[:, None]
    norm = np.linalg.norm(merged[:, 1], axis=1, keepdims=True)
    directions = np.where(norm > 1e-9 * counts[:, None], merged[:, 1] / np.maximum(norm, 1e-300), 0)
    return centres, directions


def direction_field(
    strokes,
    shape,
    *,
    spacing=None,
    kernel="thin_plate_spline",
    smoothing=1.0,
    grid_step=None,
    max_samples=400,
):
    """Interpolate a unit direction field over an image from flow strokes.

    Parameters
    ----------
    strokes : sequence of array_like, each shape (n_i, 2)
        Polylines (row, col) in image pixels, each drawn along the flow.
    shape : tuple of int
        The image's (H, W) (extra trailing entries are ignored).
    spacing : float, optional
        Distance between tangent samples along a stroke (default: 1/40 of the
        larger image side, at least 2 px).
    kernel : str
        RBF kernel of :class:`scipy.interpolate.RBFInterpolator`. The default thin-plate
        spline bends smoothly between strokes and needs no length scale.
    smoothing : float
        RBF smoothing (>= 0): 0 interpolates the samples exactly; a little smoothing
        keeps nearby, slightly disagreeing strokes from making whorls.
    grid_step : int, optional
        The RBF is evaluated on a grid this many pixels apart and bilinearly upsampled
        (the field is smooth, and this keeps large images fast). Default: 1/64 of the
        larger side, at least 1.
    max_samples : int
        At most this many tangent samples: the spacing grows to fit, and where many
        short strokes still give more, the samples in one cell of a grid become their
        mean (the RBF fit costs O(m^2) memory and O(m^3) time).

    Returns
    -------
    ndarray, shape (H, W, 2), float32
        Unit vectors (dy, dx); zero where opposing strokes cancel exactly.

    Raises
    ------
    ValueError
        If there is no stroke, no stroke is at least a pixel long, a stroke is not an
        (n, 2) array, or a point lies far outside the image (:func:`check_strokes`).

    Examples
    --------
    >>> field = direction_field([[[10, 2], [10, 30]]], (20, 32))
    >>> field.shape, bool(np.allclose(field[..., 1], 1.0, atol=1e-3))
    ((20, 32, 2), True)
    """
    h, w = (check_int("shape[0]", shape[0], 1), check_int("shape[1]", shape[1], 1))
    check_choice("kernel", kernel, _KERNELS)
    smoothing = check_range("smoothing", smoothing, 0, None)
    max_samples = check_int("max_samples", max_samples, 3)
    if spacing is None:
        spacing = max(2.0, max(h, w) / 40.0)
    spacing = check_range("spacing", spacing, 0, None, lo_open=True)
    strokes = check_strokes(strokes, (h, w))
    pts = np.concatenate(strokes)
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    ends = np.cumsum([len(s) for s in strokes])[:-1] - 1  # steps from one stroke to the next
    total = float(steps.sum() - steps[ends].sum())
    if total < 1.0:
        raise ValueError("strokes: draw at least one stroke longer than one pixel")
    spacing = max(spacing, total / max_samples)
    points, tangents = _tangents(strokes, spacing)
    if len(points) > max_samples:  # many short strokes: two samples each at least
        points, tangents = _merge_samples(points, tangents, max_samples)
    if len(points) < 3:
        # Too few samples for an RBF fit: the field is the mean direction.
        mean = tangents.mean(axis=0)
        out = np.empty((h, w, 2), np.float32)
        out[:] = mean / max(np.linalg.norm(mean), 1e-12)
        return out
    if grid_step is None:
        grid_step = max(1, max(h, w) // 64)
    grid_step = check_int("grid_step", grid_step, 1)
    rows = np.arange(0, h + grid_step - 1, grid_step, dtype=np.float64).clip(max=h - 1)
    cols = np.arange(0, w + grid_step - 1, grid_step, dtype=np.float64).clip(max=w - 1)
    rr, cc = np.meshgrid(np.unique(rows), np.unique(cols), indexing="ij")
    # A degree-1 polynomial term lets a straight stroke reproduce a uniform field, but
    # it is singular when every sample lies on one line; then a linear kernel with a
    # constant term (which it allows) does the same job.
    centred = points - points.mean(axis=0)
    collinear = np.linalg.matrix_rank(centred, tol=1e-6 * max(h, w)) < 2
    if collinear:
        rbf = RBFInterpolator(points, tangents, kernel="linear", smoothing=smoothing, degree=0)
    else:
        rbf = RBFInterpolator(points, tangents, kernel=kernel, smoothing=smoothing, degree=1)
    coarse = rbf(np.column_stack([rr.ravel(), cc.ravel()])).reshape(rr.shape + (2,))
    if coarse.shape[:2] != (h, w):
        from ..fields import resize

        coarse = resize(coarse, (h, w))
    norm = np.linalg.norm(coarse, axis=-1, keepdims=True)
    field = np.where(norm > 1e-9, coarse / np.maximum(norm, 1e-12), 0.0)
    return field.astype(np.float32)
