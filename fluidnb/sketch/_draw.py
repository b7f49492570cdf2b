"""Geometry and colours for drawing user input and fields over an image."""

from __future__ import annotations

import numpy as np

from .._validation import check_array, check_int, check_range, check_vector_field

__all__ = ["arrow_heads", "quiver_segments", "scalar_to_rgba", "segment_heads"]


def arrow_heads(points, size=6.0, angle=25.0):
    """The two barbs of an arrow head at the end of a polyline.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        The polyline (row, col); the head points along its last segment that has
        length.
    size : float
        Barb length in the same units as ``points``.
    angle : float
        Half-angle of the head, in degrees.

    Returns
    -------
    ndarray, shape (2, 2, 2)
        Two segments ``[[tip, barb_end], ...]`` in (row, col); empty (0, 2, 2) if the
        polyline has no length.

    Examples
    --------
    >>> arrow_heads([[0, 0], [0, 10]], size=2, angle=90).round(6).tolist()
    [[[0.0, 10.0], [-2.0, 10.0]], [[0.0, 10.0], [2.0, 10.0]]]
    """
    pts = check_array("points", points, ndim=2, dtype_kinds="iuf").astype(float)
    tip = pts[-1]
    back = pts[:-1][np.linalg.norm(pts[:-1] - tip, axis=1) > 1e-9]
    if len(back) == 0:
        return np.empty((0, 2, 2))
    d = tip - back[-1]
    d /= np.linalg.norm(d)
    out = []
    for sign in (1.0, -1.0):
        a = np.deg2rad(180.0 - sign * angle)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        out.append([tip, tip + size * (rot @ d)])
    return np.array(out)


def segment_heads(segments, size=6.0, angle=25.0):
    """The arrow heads of many straight segments at once (what :func:`arrow_heads` draws).

    A quiver or the video-database app's motion map draws a few hundred arrows each
    time a slider moves; one array expression for all of them instead of a call each
    (about 25 us per arrow).

    Parameters
    ----------
    segments : array_like, shape (k, 2, 2)
        Segments ``[start, tip]`` in (row, col).
    size, angle : float
        As :func:`arrow_heads`.

    Returns
    -------
    ndarray, shape (2 m, 2, 2)
        The two barbs ``[tip, barb_end]`` of each of the m segments that have length,
        in segment order (both barbs of the first, then of the second, ...).

    Examples
    --------
    >>> segment_heads([[[0, 0], [0, 10]]], size=2, angle=90).round(6).tolist()
    [[[0.0, 10.0], [-2.0, 10.0]], [[0.0, 10.0], [2.0, 10.0]]]
    """
    seg = np.asarray(segments, dtype=float)
    if seg.ndim != 3 or seg.shape[1:] != (2, 2):
        raise ValueError(f"segments must have shape (k, 2, 2), got {seg.shape}")
    check_array("segments", seg.reshape(-1, 2), ndim=2, dtype_kinds="f", min_size=0)
    tip = seg[:, 1]
    d = tip - seg[:, 0]
    length = np.linalg.norm(d, axis=1)
    keep = length > 1e-9
    tip, d = tip[keep], d[keep] / length[keep, None]
    out = np.empty((len(tip), 2, 2, 2))
    for j, sign in enumerate((1.0, -1.0)):
        a = np.deg2rad(180.0 - sign * angle)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        out[:, j, 0] = tip
        out[:, j, 1] = tip + size * (d @ rot.T)
    return out.reshape(-1, 2, 2)


def quiver_segments(field, step=16, length=None):
    """Line segments that draw a vector field as a quiver plot.

    Parameters
    ----------
    field : ndarray, shape (H, W, 2)
        (dy, dx) vectors.
    step : int
        Spacing of the arrows in pixels.
    length : float, optional
        Draw every arrow with this length (for direction fields); by default the
        vectors are drawn as they are, scaled so the longest spans ``0.9 * step``.

    Returns
    -------
    ndarray, shape (k, 2, 2)
        Segments ``[start, end]`` in (row, col), centred on the grid points; vectors of
        zero length are left out.
    """
    v = check_vector_field("field", field)
    step = check_int("step", step, 1)
    h, w = v.shape[:2]
    rr, cc = np.mgrid[step // 2 : h : step, step // 2 : w : step]
    vec = v[rr, cc].reshape(-1, 2).astype(float)
    centres = np.column_stack([rr.ravel(), cc.ravel()]).astype(float)
    norm = np.linalg.norm(vec, axis=1)
    keep = norm > 1e-9
    vec, centres, norm = vec[keep], centres[keep], norm[keep]
    if length is None:
        scale = 0.9 * step / norm.max() if len(norm) else 1.0
        vec = vec * scale
    else:
        length = check_range("length", length, 0, None, lo_open=True)
        vec = vec / norm[:, None] * length
    return np.stack([centres - vec / 2, centres + vec / 2], axis=1)


def scalar_to_rgba(values, color=(1.0, 0.3, 0.1), *, opacity=0.5, vmin=0.0, vmax=1.0):
    """An RGBA uint8 overlay showing a scalar map (zero is fully transparent).

    Parameters
    ----------
    values : ndarray, shape (H, W)
        The map (e.g. a painted speed map or a mask).
    color : tuple of 3 float
        RGB in [0, 1] at full value.
    opacity : float
        Alpha at full value; alpha grows linearly with the value.
    vmin, vmax : float
        The value range mapped to [0, 1].

    Returns
    -------
    ndarray, shape (H, W, 4), uint8
    """
    v = check_array("values", values, ndim=2).astype(np.float32)
    opacity = check_range("opacity", opacity, 0, 1)
    if vmax <= vmin:
        raise ValueError(f"vmax must be > vmin, got vmin={vmin}, vmax={vmax}")
    t = np.clip((v - vmin) / (vmax - vmin), 0.0, 1.0)
    out = np.empty(v.shape + (4,), np.uint8)
    out[..., :3] = (np.asarray(color, np.float32) * 255 + 0.5).astype(np.uint8)
    out[..., 3] = (t * opacity * 255 + 0.5).astype(np.uint8)
    return out
