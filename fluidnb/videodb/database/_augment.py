r"""The augmented versions' pixels and motion, sampled from the source clip (Okabe et al., sec. 4).

A version's geometry (:mod:`fluidnb.videodb.database._versions`): version pixel
:math:`(r, c)` shows the source at :math:`q = F R(-\theta)\, p / s` about the centres,
and a motion vector becomes :math:`u_v = s R(\theta) F u_s`.

Frames are sampled bilinearly after a Gaussian antialiasing prefilter of standard
deviation :math:`(1/s - 1)/2` source pixels when :math:`s < 1` (scikit-image's rule),
clamped at the source's border. A window of a version sampled on its own (``origin``,
``size``) is bit-for-bit the same window cut out of the whole version, so a renderer
can rebuild one fragment from the source clip exactly as the build cut it.

The sampling runs in two small numba kernels (a separable Gaussian and a bilinear
gather that serves all frames from one set of indices and weights) on a pixel-major
copy of the source window; :class:`VersionSampler` prepares a clip once for all 18
versions. :func:`fluidnb.videodb.database.reference_sample_version` and
:func:`fluidnb.videodb.database.reference_transform_vectors` write the same computation
out literally with scipy and explicit matrices, and the tests compare the two. All 18
versions of a 64-frame 320 x 180 grey clip take about 0.5 s on one core, its flow's
about 1 s.
"""

from __future__ import annotations

from functools import cache, lru_cache

import numpy as np
from numba import njit

from ..._validation import check_array
from ._versions import (
    _TRUNCATE,
    IDENTITY,
    _coordinates,
    _corners,
    _window,
    mirror_partner,
    prefilter_sigma,
    version_matrix,
    version_shape,
)

__all__ = ["VersionSampler", "sample_version", "transform_flow", "transform_vectors"]


# Passed to the gather kernel when no vectors are to be transformed.
_NO_MATRIX = np.zeros((0, 0), np.float32)


def sample_version(frames, version, *, origin=(0, 0), size=None):
    r"""A version's pixels of a clip: flipped, scaled, rotated (Okabe et al., Fig. 4-a).

    Parameters
    ----------
    frames : ndarray, shape (T, H, W) or (T, H, W, C), float
        The source clip (grey or colour, or any channels, e.g. a flow).
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.
    origin : tuple of int
        ``(row, col)`` of the window's top-left pixel in the version's canvas.
    size : tuple of int, optional
        ``(h, w)`` of the window; default: from ``origin`` to the canvas's end (the
        whole canvas for the default origin).

    Returns
    -------
    ndarray, shape (T, h, w) or (T, h, w, C), float32
        Bilinear samples of the (prefiltered, when :math:`s < 1`) source at
        :func:`version_coordinates`, clamped at the source's border. A window sampled
        on its own equals, bit for bit, the same window of the whole version; the
        identity version returns the frames unchanged.

    Raises
    ------
    ValueError
        For frames that are not a 3-D or 4-D float array or hold NaN, a bad version
        or a window with a side below 1.

    See Also
    --------
    transform_flow : The same resampling for a flow, with its vectors carried along.

    Notes
    -----
    Each output pixel reads the four source pixels around its coordinates with
    weights computed once for all frames; only the source rectangle those pixels
    (and the prefilter's reach around them) need is filtered, with the source's own
    border rule, so a window's values cannot depend on what else is sampled.

    Examples
    --------
    >>> clip = np.arange(24, dtype=np.float32).reshape(1, 4, 6)
    >>> sample_version(clip, 16)[0]  # the mirror image
    array([[ 5.,  4.,  3.,  2.,  1.,  0.],
           [11., 10.,  9.,  8.,  7.,  6.],
           [17., 16., 15., 14., 13., 12.],
           [23., 22., 21., 20., 19., 18.]], dtype=float32)
    >>> whole = sample_version(clip, 2)
    >>> bool(
    ...     np.array_equal(sample_version(clip, 2, origin=(1, 2), size=(2, 2)), whole[:, 1:3, 2:4])
    ... )
    True
    """
    arr = _check_frames("frames", frames)
    return _sample(arr, version, origin, size)


def transform_vectors(vectors, version):
    r"""Carry source motion vectors into a version: :math:`u_v = s R(\theta) F u_s`.

    Parameters
    ----------
    vectors : ndarray, shape (..., 2)
        (dy, dx) in source pixels.
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.

    Returns
    -------
    ndarray, shape (..., 2)
        (dy, dx) in the version's pixels; float32 for float32 input, else float64.

    Examples
    --------
    Flipping negates dx; +22.5 degrees turns "right" a little upwards (dy < 0):

    >>> transform_vectors(np.array([0.0, 1.0]), 16).tolist()
    [0.0, -1.0]
    >>> np.round(transform_vectors(np.array([0.0, 1.0]), 8), 3).tolist()
    [-0.383, 0.924]
    """
    arr = check_array("vectors", vectors, dtype_kinds="iuf")
    if arr.ndim < 1 or arr.shape[-1] != 2:
        raise ValueError(f"vectors must have shape (..., 2) as (dy, dx), got {arr.shape}")
    dtype = np.float32 if arr.dtype == np.float32 else np.float64
    return _transform(arr.astype(dtype, copy=False), version)


def transform_flow(flow, version, *, origin=(0, 0), size=None):
    r"""A clip's optical flow as seen in one of its versions.

    The flow is resampled exactly like the frames (:func:`sample_version`: same
    coordinates, same prefilter), then each vector is carried by
    :func:`transform_vectors`. This stands in for estimating the flow of every version
    again (the spec: compute once per clip).

    Parameters
    ----------
    flow : ndarray, shape (T - 1, H, W, 2), float
        (dy, dx) of the source clip (:func:`~fluidnb.videodb.database._flow.optical_flow`).
    version : int
        Index into :data:`~fluidnb.videodb.VERSIONS`.
    origin, size : tuple of int
        The window of the version's canvas, as in :func:`sample_version`.

    Returns
    -------
    ndarray, shape (T - 1, h, w, 2), float32
        (dy, dx) in the version's pixels per frame.

    Examples
    --------
    >>> flow = np.zeros((1, 8, 8, 2), np.float32)
    >>> flow[..., 1] = 1.0  # one pixel per frame to the right
    >>> transform_flow(flow, 1)[0, 2, 2].tolist()  # at 50 %: half a pixel
    [0.0, 0.5]
    """
    arr = _check_frames("flow", flow)
    if arr.ndim != 4 or arr.shape[-1] != 2:
        raise ValueError(f"flow must have shape (T, H, W, 2) as (dy, dx), got {arr.shape}")
    return _sample(arr, version, origin, size, version_matrix(version))


# --- internals ---


def _check_frames(name, frames):
    arr = check_array(name, frames, ndim=(3, 4), dtype_kinds="f")
    return np.ascontiguousarray(arr, dtype=np.float32)


def _sample(arr, version, origin, size, matrix=None):
    """Sample a window of a version; with ``matrix``, also carry (dy, dx) pairs by it."""
    h, w = arr.shape[1:3]
    (r0, c0), (hh, ww) = _window(h, w, version, origin, size)
    if version == IDENTITY and (r0, c0, hh, ww) == (0, 0, h, w):
        return arr.copy() if matrix is None else _transform(arr, version)
    plan = _Plan(h, w, version, r0, c0, hh, ww)
    layout = _Layout(arr.shape)
    src = layout.pixel_major(arr[:, plan.top : plan.bottom, plan.left : plan.right])
    if len(plan.kernel) > 1:
        src = _blur(src, plan.kernel)
    out = np.empty((layout.n_planes, hh * ww), layout.item)
    _gather(plan.source_rows(src), *plan.indices, _matrix(matrix), out)
    return layout.frame_major(out.view(np.float32), hh, ww)


def _matrix(matrix):
    return _NO_MATRIX if matrix is None else matrix.astype(np.float32)


class _Plan:
    """Where a window of a version reads the source: its rectangle and bilinear indices."""

    def __init__(self, h, w, version, r0, c0, hh, ww):
        y, x = _coordinates(h, w, version, r0, c0, hh, ww)
        y, x = np.broadcast_arrays(y, x)
        y0, y1, wy = _corners(y, h)
        x0, x1, wx = _corners(x, w)
        # The source rectangle the window reads, widened by the prefilter's reach and
        # cut at the source's border (where the filter clamps, as it does on the whole
        # frame): inside it every filtered value equals the whole frame's, bit for bit.
        self.sigma = prefilter_sigma(version)
        self.kernel = _gaussian_kernel(self.sigma)
        reach = len(self.kernel) - 1
        self.top, self.bottom = max(int(y0.min()) - reach, 0), min(int(y1.max()) + 1 + reach, h)
        self.left, self.right = max(int(x0.min()) - reach, 0), min(int(x1.max()) + 1 + reach, w)
        self.whole = (self.top, self.bottom, self.left, self.right) == (0, h, 0, w)
        sw = self.right - self.left
        # Each pixel reads rows k, k + ox, k + oy and k + oy + ox of the source window.
        k = ((y0 - self.top) * sw + (x0 - self.left)).ravel().astype(np.uint32)
        ox = (x1 - x0).ravel().astype(np.uint32)
        oy = ((y1 - y0) * sw).ravel().astype(np.uint32)
        self.indices = (k, ox, oy, wx.ravel().astype(np.float32), wy.ravel().astype(np.float32))

    def source_rows(self, src):
        """The (pixels, values) view of a pixel-major source window the indices read."""
        return src.reshape((self.bottom - self.top) * (self.right - self.left), src.shape[2])


@lru_cache(maxsize=16)
def _whole_plan(h, w, version):
    """The :class:`_Plan` of a whole version of an (h, w) source, made once (read-only).

    A build samples each window's grey frames, mean image and flow at the same
    points, and its clips are often all one size: the plan (coordinates, corners,
    indices; ~0.3 s a water build when made for every call) depends on nothing else.
    The 8 unflipped, resampled versions of a 180 x 320 clip hold 8.6 MB of indices.
    """
    hv, wv = version_shape((h, w), version)
    plan = _Plan(h, w, version, 0, 0, hv, wv)
    for arr in plan.indices:
        arr.flags.writeable = False
    return plan


class _Layout:
    """Frames (T, H, W[, C]) moved to and from the pixel-major layout the kernels use.

    Pixel-major: each source pixel's values over all frames (and channels) are
    contiguous, so the kernels run vectorised along them. A (dy, dx) pair moves as one
    uint64 item (3-4x faster than moving floats); colour and the like go through as
    extra frames, channel-major.
    """

    def __init__(self, shape):
        self.shape = tuple(shape)
        self.t = shape[0]
        self.channels = int(np.prod(shape[3:], dtype=np.int64))
        self.per_item = 2 if self.channels == 2 else 1
        self.item = np.uint64 if self.per_item == 2 else np.float32
        self.n_planes = self.t * (self.channels if self.channels > 2 else 1)

    def pixel_major(self, window):
        """(T, h, w[, C]) -> (h, w, values) float32, contiguous."""
        t, hh, ww = window.shape[:3]
        window = window.reshape(t, hh, ww, self.channels)
        if self.channels > 2:
            # (a small crop of a long clip moves only what it reads)
            window = np.moveaxis(window, 3, 0).reshape(self.channels * t, hh, ww, 1)
        window = np.ascontiguousarray(window).view(self.item)[..., 0]
        src = np.ascontiguousarray(np.moveaxis(window, 0, 2)).view(np.float32)
        return src.reshape(hh, ww, self.n_planes * self.per_item)

    def frame_major(self, out, hh, ww):
        """(planes, points) float32 -> (T, hh, ww[, C])."""
        if self.channels > 2:
            out = np.moveaxis(out.reshape(self.channels, self.t, hh, ww), 0, 3)
            return np.ascontiguousarray(out).reshape(self.t, hh, ww, *self.shape[3:])
        return out.reshape(self.t, hh, ww, *self.shape[3:])


class VersionSampler:
    r"""Every whole version of one clip (or window of frames), prepared once.

    A build samples all 18 versions of each window of each clip: its grey frames, its
    mean image and its flow. :func:`sample_version` and :func:`transform_flow` prepare
    the source for every call (the pixel-major copy, the prefilter); this prepares it
    once -- one pixel-major copy, blurred once per scale -- and makes each flipped
    version as the mirror image of the unflipped one at the opposite angle:
    :math:`F R(-\theta) = R(\theta) F`, so version :math:`(F, s, \theta)`'s pixel
    :math:`(r, c)` reads the source at the very numbers version
    :math:`(s, -\theta)`'s pixel :math:`(r, W_v - 1 - c)` does, and a vector's dx
    comes out negated (the matrices' rows agree up to sign). The results are, bit for
    bit, :func:`sample_version`'s and :func:`transform_flow`'s, pixel-major.

    Parameters
    ----------
    frames : ndarray, shape (T, H, W) or (T, H, W, C), float
        As for :func:`sample_version`; a flow (C = 2) with ``vectors=True``.
    vectors : bool
        The frames are (dy, dx) vectors, carried into each version as
        :func:`transform_flow` does.
    """

    def __init__(self, frames, *, vectors=False):
        arr = _check_frames("frames", frames)
        if vectors and (arr.ndim != 4 or arr.shape[-1] != 2):
            raise ValueError(f"frames must have shape (T, H, W, 2) as (dy, dx), got {arr.shape}")
        self.vectors = bool(vectors)
        self.layout = _Layout(arr.shape)
        self.shape = arr.shape[1:3]
        self._arr = arr
        self._src = {0.0: self.layout.pixel_major(arr)}
        self._last = None

    def __call__(self, version):
        """Version ``version``, pixel-major: ``(Hv, Wv, values)`` float32, contiguous.

        ``values`` are the frames (grey: ``T``), the (dy, dx) pairs of each frame
        (``2 T``) or the channels of each frame, channel-major (``C T``).
        """
        partner = mirror_partner(version)
        if partner < version:
            # The mirror image of its unflipped partner, kept from the call before when
            # that was the partner (ask for versions in mirror_order() to get it free).
            cached = self._last is not None and self._last[0] == partner
            out = self._last[1] if cached else self._unflipped(partner)
            out = np.ascontiguousarray(out[:, ::-1])
            if self.vectors:
                out[..., 1::2] *= np.float32(-1)
            return out
        out = self._unflipped(version)
        self._last = (version, out)
        return out

    def _unflipped(self, version):
        h, w = self.shape
        hv, wv = version_shape((h, w), version)
        src = self._src[0.0]
        if version == IDENTITY:
            out = src.copy()
            if self.vectors:
                matrix = version_matrix(version).astype(np.float32)
                _apply_matrix(out.reshape(-1, 2), matrix, out.reshape(-1, 2))
            return out
        plan = _whole_plan(h, w, version)
        if plan.whole:  # always, for a whole version: its prefilter is shared by scale
            if plan.sigma not in self._src:
                self._src[plan.sigma] = _blur(src, plan.kernel) if plan.sigma else src
            src = self._src[plan.sigma]
        else:  # pragma: no cover - kept for safety: read the rectangle as _sample does
            src = self.layout.pixel_major(
                self._arr[:, plan.top : plan.bottom, plan.left : plan.right]
            )
            src = _blur(src, plan.kernel) if len(plan.kernel) > 1 else src
        out = np.empty((hv * wv, src.shape[2]), np.float32)
        matrix = version_matrix(version) if self.vectors else None
        _gather_pixels(plan.source_rows(src), *plan.indices, _matrix(matrix), out)
        return out.reshape(hv, wv, src.shape[2])


@cache
def _gaussian_kernel(sigma):
    """Half of a normalised Gaussian, centre first, reaching ``int(4 sigma + 0.5)``."""
    if sigma <= 0:
        return np.ones(1, np.float32)
    radius = int(_TRUNCATE * sigma + 0.5)
    phi = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    return (phi / phi.sum())[radius:].astype(np.float32)


def _blur(src, kernel):
    """Separable Gaussian over axes 0 and 1 of (rows, cols, values), clamped at the edges."""
    src = np.ascontiguousarray(src)  # whole rows as one run of values (the kernels' form)
    tmp = np.empty_like(src)
    out = np.empty_like(src)
    _correlate(src, kernel, 0, tmp)
    _correlate(tmp, kernel, 1, out)
    return out


@njit(cache=True, nogil=True)
def _correlate(src, kernel, axis, out):
    """Correlate axis 0 or 1 of ``src`` (rows, cols, values) with a symmetric kernel.

    ``kernel`` holds the centre weight and then the weights at distance 1, 2, ...;
    neighbours beyond the edge repeat the edge. Every output is ``k0 x[i] + k1 (x[i-1]
    + x[i+1]) + ...`` in this order whatever the array's extent, so overlapping windows
    agree bit for bit. C-contiguous arrays: each term is added over a whole row at once
    (the columns whose neighbours lie inside the row as one contiguous run), which
    the compiler vectorises; every value's operations are the same.
    """
    rows, cols, m = src.shape
    width = cols * m
    flat = src.reshape(rows, width)
    dst = out.reshape(rows, width)
    for i in range(rows):
        o = dst[i]
        _scaled(o, kernel[0], flat[i])
        for d in range(1, kernel.shape[0]):
            k = kernel[d]
            if axis == 0:
                _add_pair(o, k, flat[max(i - d, 0)], flat[min(i + d, rows - 1)])
                continue
            row = flat[i]
            lo = min(d, cols)  # columns [lo, hi) have both neighbours in the row
            hi = max(cols - d, lo)
            _add_pair(o[lo * m : hi * m], k, row[(lo - d) * m : (hi - d) * m], row[(lo + d) * m :])
            for e in range(cols - (hi - lo)):  # the edge columns [0, lo) and [hi, cols)
                j = e if e < lo else e + hi - lo
                a = max(j - d, 0) * m
                b = min(j + d, cols - 1) * m
                for v in range(m):
                    o[j * m + v] += k * (row[a + v] + row[b + v])


@njit(cache=True, nogil=True)
def _scaled(o, k, a):
    """``o = k a`` (1-D, ``o``'s length)."""
    for q in range(o.shape[0]):
        o[q] = k * a[q]


@njit(cache=True, nogil=True)
def _add_pair(o, k, a, b):
    """``o += k (a + b)`` over ``o``'s length (``a``, ``b`` at least as long)."""
    for q in range(o.shape[0]):
        o[q] += k * (a[q] + b[q])


@njit(cache=True, nogil=True, inline="always")
def _bilinear(src, i, ox, oy, a, b, matrix, r):
    """One point's samples of every value: ``r[v]`` from source rows around row ``i``.

    ``top + fy * (bottom - top)`` rather than a four-weight sum: a fraction of 0
    returns the sample bit for bit and a constant stays exactly constant (the form of
    fluidnb.fields.advect and the fluid kernels). With a (2, 2) ``matrix``, each sampled
    (dy, dx) pair is replaced by ``(m00 dy + m01 dx, m10 dy + m11 dx)``, as
    :func:`_apply_matrix` computes it.
    """
    s00 = src[i]
    s01 = src[i + ox]
    s10 = src[i + oy]
    s11 = src[i + oy + ox]
    for v in range(r.shape[0]):
        top = s00[v] + a * (s01[v] - s00[v])
        bottom = s10[v] + a * (s11[v] - s10[v])
        r[v] = top + b * (bottom - top)
    if matrix.shape[0] == 2:
        for v in range(0, r.shape[0], 2):
            dy = r[v]
            dx = r[v + 1]
            r[v] = matrix[0, 0] * dy + matrix[0, 1] * dx
            r[v + 1] = matrix[1, 0] * dy + matrix[1, 1] * dx


@njit(cache=True, nogil=True)
def _gather(src, k, ox, oy, fx, fy, matrix, out):
    """Bilinear samples of all frames at the same points (frame-major output).

    ``src`` is (source pixels, frames x channels) float32; ``out`` is (frames, points)
    of items: float32 for one channel, or uint64 holding a float32 pair for two
    (so that a (dy, dx) vector moves as one item). Results go through a small buffer
    so that both the reads and the writes are contiguous.
    """
    n_frames, n = out.shape
    m = src.shape[1]
    block = 16
    buf = np.empty((block, m), np.float32)
    items = buf.view(out.dtype)
    for p0 in range(0, n, block):
        size = min(block, n - p0)
        for q in range(size):
            p = p0 + q
            _bilinear(src, k[p], ox[p], oy[p], fx[p], fy[p], matrix, buf[q])
        for f in range(n_frames):
            o = out[f]
            for q in range(size):
                o[p0 + q] = items[q, f]


@njit(cache=True, nogil=True)
def _gather_pixels(src, k, ox, oy, fx, fy, matrix, out):
    """:func:`_gather`'s samples, pixel-major: ``out`` is (points, values) float32."""
    for p in range(out.shape[0]):
        _bilinear(src, k[p], ox[p], oy[p], fx[p], fy[p], matrix, out[p])


def _transform(vectors, version):
    m = version_matrix(version).astype(vectors.dtype)
    flat = np.ascontiguousarray(vectors).reshape(-1, 2)
    out = np.empty_like(flat)
    _apply_matrix(flat, m, out)
    return out.reshape(vectors.shape)


@njit(cache=True, nogil=True)
def _apply_matrix(u, m, out):
    """``out[i] = m @ u[i]``: ``m00 dy + m01 dx`` and ``m10 dy + m11 dx``."""
    for i in range(u.shape[0]):
        dy = u[i, 0]
        dx = u[i, 1]
        out[i, 0] = m[0, 0] * dy + m[0, 1] * dx
        out[i, 1] = m[1, 0] * dy + m[1, 1] * dx
