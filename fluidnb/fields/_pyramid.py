"""Gaussian and Laplacian image pyramids and multiband blending (Burt & Adelson).

One implementation for the whole library: the fire, turbulence and video-database
methods all build their pyramids here, so their levels line up.

Each level halves the size, rounding up: ``(H, W) -> (ceil(H/2), ceil(W/2))``, so
odd sizes such as 37 x 53 work at every level. ``reduce`` is a Gaussian blur of
standard deviation ``sigma`` (in pixels of the finer level; 1.0 is close to Burt and
Adelson's 5-tap kernel with a = 0.4) followed by pixel-centre-aligned bilinear
resampling; :func:`expand` is bilinear resampling to the exact finer shape followed
by the same blur. Channels are never mixed.

All arithmetic is float64 whatever the input (``precision="float64"``, the
default, through ``scipy.ndimage``), and each returned level is cast back to the
input's float dtype. With ``precision="float32"`` the same pyramids run in float32
through OpenCV's separable filter and bilinear resize, or, where a level halves
exactly (even sides), a compiled filter that blurs and resamples in one step and
computes only the pixels kept (:mod:`._pyramid_fused`): about 15 times as fast on
images of many channels (a video-database fragment's frames batched as channels),
equal to the float64 pyramids to float32 round-off (the tests check it), and every
level is float32. The Laplacian pyramid is exactly invertible by construction (each
band stores what ``expand`` misses), so :func:`collapse` gives back the input to
~1e-12 for float64 and to float32 rounding (~1e-7) for float32.
"""

from __future__ import annotations

import functools
import math
from itertools import pairwise

import numpy as np
from scipy import ndimage as ndi

from .._validation import check_array, check_choice, check_int, check_range, check_shape_match
from . import _pyramid_fused as _fused
from ._resample import _check_field, _check_shape, _per_chunk

__all__ = ["collapse", "expand", "gaussian_pyramid", "laplacian_pyramid", "pyramid_blend"]

# levels=None stops before the smaller side would drop below this many pixels.
_MIN_SIDE = 8
#: The arithmetic of the pyramids: float64 (scipy.ndimage) or float32 (OpenCV).
PRECISIONS = ("float64", "float32")


def gaussian_pyramid(image, levels=None, *, sigma=1.0, precision="float64"):
    """Build a Gaussian pyramid: the image, then ever smaller blurred copies.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        Any number of channels, each filtered independently.
    levels : int, optional
        Number of levels including the image itself (at least 1). By default,
        as many as keep the smaller side at 8 pixels or more.
    sigma : float
        Standard deviation of the Gaussian blur applied before each halving, in
        pixels of the finer level (>= 0).
    precision : {"float64", "float32"}
        The arithmetic: float64 (scipy.ndimage), or float32 (OpenCV, about 15 times
        as fast on many channels; equal to float64 to float32 round-off).

    Returns
    -------
    list of ndarray
        ``[G0, G1, ...]`` with ``G0`` a copy of ``image`` and ``G(i+1)`` of shape
        ``(ceil(Hi / 2), ceil(Wi / 2)[, C])``. Float32 for float32 (and integer or
        bool) input or ``precision="float32"``, float64 for float64 input.

    References
    ----------
    .. [1] P. J. Burt and E. H. Adelson, "The Laplacian pyramid as a compact image
       code", IEEE Transactions on Communications 31(4), pp. 532-540, 1983.

    Examples
    --------
    >>> pyr = gaussian_pyramid(np.zeros((37, 53, 3), dtype=np.float32))
    >>> [p.shape for p in pyr]
    [(37, 53, 3), (19, 27, 3), (10, 14, 3)]
    """
    arr, levels, sigma = _check_pyramid_args(image, levels, sigma)
    if _float32(precision):
        x = _channels(arr)
        pyr = _gaussian32(x, levels, sigma)
        pyr[0] = pyr[0].copy()  # _gaussian32's G0 is its input
        return [_unchannel(g, arr) for g in pyr]
    return [g.astype(arr.dtype) for g in _gaussian64(arr, levels, sigma)]


def laplacian_pyramid(image, levels=None, *, sigma=1.0, precision="float64"):
    """Build a Laplacian pyramid: band-pass detail levels plus a low-pass residual.

    ``L_i = G_i - expand(G_(i+1), shape of G_i)`` for every level but the last,
    which is the residual ``G_(n-1)`` itself (Burt & Adelson 1983).

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        Any number of channels, each filtered independently.
    levels : int, optional
        Number of levels including the residual (at least 1; 1 returns just a copy
        of the image). By default, as for :func:`gaussian_pyramid`.
    sigma : float
        Blur of reduce and expand, see :func:`gaussian_pyramid`. Pass the same
        value to :func:`collapse`.
    precision : {"float64", "float32"}
        The arithmetic, see :func:`gaussian_pyramid`.

    Returns
    -------
    list of ndarray
        ``[L0, ..., L(n-2), G(n-1)]`` with the shapes of the Gaussian pyramid.
        Float32 for float32 (and integer or bool) input or ``precision="float32"``,
        float64 for float64 input.

    See Also
    --------
    collapse : The inverse.

    References
    ----------
    .. [1] P. J. Burt and E. H. Adelson, "The Laplacian pyramid as a compact image
       code", IEEE Transactions on Communications 31(4), pp. 532-540, 1983.

    Examples
    --------
    >>> img = np.random.default_rng(0).random((37, 53)).astype(np.float32)
    >>> pyr = laplacian_pyramid(img, 3)
    >>> [p.shape for p in pyr]
    [(37, 53), (19, 27), (10, 14)]
    >>> bool(np.abs(collapse(pyr) - img).max() < 1e-6)
    True
    """
    arr, levels, sigma = _check_pyramid_args(image, levels, sigma)
    if _float32(precision):
        x = _channels(arr)
        bands = _laplacian32(x, levels, sigma)
        if bands[-1] is x:  # one level: the residual is the input itself
            bands[-1] = x.copy()
        return [_unchannel(b, arr) for b in bands]
    return [band.astype(arr.dtype) for band in _laplacian64(arr, levels, sigma)]


def expand(image, shape, *, sigma=1.0, precision="float64"):
    """Enlarge one pyramid level to the exact shape of the next finer level.

    Bilinear, pixel-centre-aligned resampling to ``shape`` followed by the pyramid's
    Gaussian blur, so ``expand(G1, G0.shape)`` is the prediction of ``G0`` that the
    Laplacian band ``L0`` corrects.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, C)
        A coarse level.
    shape : tuple of int, (H, W)
        The target height and width (usually about twice ``(h, w)``).
    sigma : float
        Standard deviation of the blur, in pixels of the target grid (>= 0); 0 is
        the pixel-centre-aligned bilinear resize alone.
    precision : {"float64", "float32"}
        The arithmetic, see :func:`gaussian_pyramid`.

    Returns
    -------
    ndarray, shape (H, W) or (H, W, C)
        Float32 for float32 (and integer or bool) input or ``precision="float32"``,
        float64 for float64 input.

    Examples
    --------
    >>> expand(np.full((3, 4), 0.25), (5, 7)).round(12)[0]
    array([0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25])
    """
    arr = _check_field(image, "image")
    shape = _check_shape(shape, arr)
    sigma = check_range("sigma", sigma, 0)
    if _float32(precision):
        x = _channels(arr)
        return _unchannel(_expand32(x, shape, sigma), arr)
    return _expand64(arr.astype(np.float64), shape, sigma).astype(arr.dtype)


def collapse(pyramid, *, sigma=1.0, precision="float64"):
    """Rebuild an image from its Laplacian pyramid (the inverse of :func:`laplacian_pyramid`).

    Starting from the residual, repeatedly expand to the next finer shape and add
    that level's band. The sum is done in float64.

    Parameters
    ----------
    pyramid : list of ndarray
        ``[L0, ..., L(n-2), G(n-1)]`` as returned by :func:`laplacian_pyramid`,
        possibly edited (that is the point: blend, swap or scale bands first).
    sigma : float
        The ``sigma`` the pyramid was built with.
    precision : {"float64", "float32"}
        The arithmetic, see :func:`gaussian_pyramid`.

    Returns
    -------
    ndarray, shape of ``pyramid[0]``
        In the float dtype of ``pyramid[0]`` (float32 with ``precision="float32"``).

    Raises
    ------
    ValueError
        If the pyramid is empty or its levels disagree on dimensions or channels.

    Examples
    --------
    >>> img = np.linspace(0, 1, 40 * 30).reshape(40, 30)
    >>> bool(np.allclose(collapse(laplacian_pyramid(img)), img, rtol=0, atol=1e-12))
    True
    """
    if isinstance(pyramid, np.ndarray) or not isinstance(pyramid, list | tuple) or not pyramid:
        raise ValueError(
            f"pyramid must be a non-empty list of arrays, got {type(pyramid).__name__}"
        )
    levels = [_check_field(p, f"pyramid[{i}]") for i, p in enumerate(pyramid)]
    for i, p in enumerate(levels[1:], 1):
        if p.shape[2:] != levels[0].shape[2:]:
            raise ValueError(
                f"pyramid[{i}] must have the channels of pyramid[0] {levels[0].shape[2:]}, "
                f"got shape {p.shape}"
            )
    sigma = check_range("sigma", sigma, 0)
    if _float32(precision):
        bands = [_channels(p) for p in levels]
        out = _collapse32(bands, sigma)
        return _unchannel(out.copy() if out is bands[-1] else out, levels[0])
    return _collapse64(levels, sigma).astype(levels[0].dtype)


def pyramid_blend(a, b, weight, levels=None, *, sigma=1.0):
    """Blend two images band by band, so the seam is as wide as each band's detail.

    Multiband blending (Burt & Adelson 1983): the Laplacian pyramids of ``a`` and
    ``b`` are mixed level by level with the Gaussian pyramid of ``weight``, then
    collapsed. Coarse structure is blended over a wide transition and fine detail
    over a narrow one, which hides seams without ghosting.

    Parameters
    ----------
    a, b : ndarray, shape (H, W) or (H, W, C)
        The two images, of identical shapes.
    weight : ndarray, shape (H, W)
        How much of ``a`` to take, in [0, 1] (1 is all ``a``, 0 all ``b``); a hard
        mask is fine, the pyramid softens it.
    levels : int, optional
        Pyramid levels, at least 1 (1 is a plain per-pixel mix). By default, as for
        :func:`gaussian_pyramid`.
    sigma : float
        The pyramid blur, see :func:`gaussian_pyramid`.

    Returns
    -------
    ndarray, shape of ``a``
        Float32 unless ``a`` or ``b`` is float64. Identical inputs, or a weight of
        all ones (zeros), return ``a`` (``b``) up to rounding. Band mixing can
        overshoot the inputs' range slightly near strong edges; clip if needed.

    Raises
    ------
    ValueError
        If the shapes differ, ``weight`` is outside [0, 1], or an input holds NaN.

    References
    ----------
    .. [1] P. J. Burt and E. H. Adelson, "A multiresolution spline with application
       to image mosaics", ACM Transactions on Graphics 2(4), pp. 217-236, 1983.
    .. [2] P. J. Burt and E. H. Adelson, "The Laplacian pyramid as a compact image
       code", IEEE Transactions on Communications 31(4), pp. 532-540, 1983.

    Examples
    --------
    >>> a = np.ones((32, 32), dtype=np.float32)
    >>> b = np.zeros((32, 32), dtype=np.float32)
    >>> w = np.zeros((32, 32))
    >>> w[:, :16] = 1.0  # left half from a
    >>> out = pyramid_blend(a, b, w)
    >>> out[0, [0, 15, 16, 31]].round(2)
    array([1.  , 0.55, 0.45, 0.  ], dtype=float32)
    """
    a = _check_field(a, "a")
    b = _check_field(b, "b")
    if a.shape != b.shape:
        raise ValueError(f"b must have the same shape as a {a.shape}, got shape {b.shape}")
    w = check_array("weight", weight, ndim=2, dtype_kinds="biuf")
    check_shape_match("weight", w, a.shape[:2], "a")
    w = w.astype(np.float64)
    lo, hi = float(w.min()), float(w.max())
    if lo < 0.0 or hi > 1.0:
        raise ValueError(f"weight must be in [0, 1], got values in [{lo:g}, {hi:g}]")
    levels = _check_levels(levels, a.shape)
    sigma = check_range("sigma", sigma, 0)
    la = _laplacian64(a.astype(np.float64), levels, sigma)
    lb = _laplacian64(b.astype(np.float64), levels, sigma)
    gw = _gaussian64(w, levels, sigma)
    bands = []
    for band_a, band_b, g in zip(la, lb, gw, strict=True):
        if a.ndim == 3:
            g = g[..., None]
        # b + g (a - b) rather than g a + (1 - g) b: equal inputs give b exactly.
        bands.append(band_b + g * (band_a - band_b))
    return _collapse64(bands, sigma).astype(np.result_type(a.dtype, b.dtype))


def _float32(precision):
    return check_choice("precision", precision, PRECISIONS) == "float32"


def _channels(arr):
    """A C-contiguous float32 (H, W, C) array of ``arr`` (a view where it can)."""
    return np.ascontiguousarray(arr if arr.ndim == 3 else arr[..., None], dtype=np.float32)


def _unchannel(x, like):
    """``x`` (h, w, C) back to the number of dimensions of ``like``."""
    return x if like.ndim == 3 else x[..., 0]


def _check_pyramid_args(image, levels, sigma):
    arr = _check_field(image, "image")
    return arr, _check_levels(levels, arr.shape), check_range("sigma", sigma, 0)


def _check_levels(levels, shape):
    if levels is None:
        return _auto_levels(shape[0], shape[1])
    return check_int("levels", levels, 1)


def _auto_levels(h, w):
    n = 1
    while min(math.ceil(h / 2), math.ceil(w / 2)) >= _MIN_SIDE:
        h, w = math.ceil(h / 2), math.ceil(w / 2)
        n += 1
    return n


def _blur64(x, sigma):
    if sigma == 0:
        return x
    # sigma 0 on the channel axis: gaussian_filter skips it, channels never mix.
    sigmas = (sigma, sigma) + (0,) * (x.ndim - 2)
    # "reflect" (half-sample symmetric) keeps constants constant and monotone
    # profiles monotone at the border.
    return ndi.gaussian_filter(x, sigmas, mode="reflect")


def _resize64(x, shape):
    """Pixel-centre-aligned bilinear resize with edge clamping, axis by axis.

    The same mapping as :func:`fluidnb.fields.resize` without anti-aliasing (and as
    scikit-image's), but separable: two gathers per axis instead of a generic
    N-d spline evaluation, several times faster on colour images.
    """
    for axis, n_out in enumerate(shape):
        n_in = x.shape[axis]
        if n_in == n_out:
            continue
        t = (np.arange(n_out, dtype=np.float64) + 0.5) * (n_in / n_out) - 0.5
        np.clip(t, 0.0, n_in - 1.0, out=t)
        lo = t.astype(np.intp)
        frac = (t - lo).reshape((-1,) + (1,) * (x.ndim - axis - 1))
        hi = np.minimum(lo + 1, n_in - 1)
        a = np.take(x, lo, axis=axis)
        b = np.take(x, hi, axis=axis)
        b -= a
        b *= frac
        b += a
        x = b
    return x


def _reduce64(x, sigma):
    shape = (math.ceil(x.shape[0] / 2), math.ceil(x.shape[1] / 2))
    return _resize64(_blur64(x, sigma), shape)


def _expand64(x, shape, sigma):
    return _blur64(_resize64(x, shape), sigma)


def _gaussian64(arr, levels, sigma):
    pyr = [arr.astype(np.float64)]
    for _ in range(levels - 1):
        pyr.append(_reduce64(pyr[-1], sigma))
    return pyr


def _laplacian64(arr, levels, sigma):
    gauss = _gaussian64(arr, levels, sigma)
    bands = [g - _expand64(g_next, g.shape[:2], sigma) for g, g_next in pairwise(gauss)]
    bands.append(gauss[-1])
    return bands


def _collapse64(levels, sigma):
    out = levels[-1].astype(np.float64)
    for band in reversed(levels[:-1]):
        out = band.astype(np.float64) + _expand64(out, band.shape[:2], sigma)
    return out


# --------------------------------------------------------------------------------------
# The float32 pyramids (OpenCV): the pyramids above, to float32 round-off
# --------------------------------------------------------------------------------------

# OpenCV's separable filter and bilinear resize, about 15 times as fast as
# scipy.ndimage on many channels (frames batched as channels): the video-database
# method builds thousands of pyramids. Every function below takes and returns
# C-contiguous float32 (h, w, C) arrays.


@functools.lru_cache(maxsize=16)
def _kernel(sigma):
    """The 1-D Gaussian of ``sigma``, made once (read-only): the pyramids blur many times."""
    r = int(4.0 * sigma + 0.5)  # scipy.ndimage.gaussian_filter's default truncation
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k = k / k.sum()
    k.flags.writeable = False
    return k


@functools.lru_cache(maxsize=16)
def _fused_kernels(sigma):
    """The fused reduce's kernel and expand's polyphase kernels of ``sigma`` (made once)."""
    k = _kernel(sigma)
    return _fused.reduce_kernel(k), _fused.expand_kernels(k)


def _blur32(x, sigma=1.0):
    import cv2

    if sigma == 0:
        return x
    k = _kernel(sigma)
    # BORDER_REFLECT is "fedcba|abcdef", scipy's "reflect", the library's border.
    return _per_chunk(
        x, lambda a: cv2.sepFilter2D(a, -1, k, k, borderType=cv2.BORDER_REFLECT), x.shape[:2]
    )


def _resize32(x, shape):
    import cv2

    if x.shape[:2] == tuple(shape):
        return x
    size = (shape[1], shape[0])
    return _per_chunk(
        x, lambda a: cv2.resize(a, size, interpolation=cv2.INTER_LINEAR), tuple(shape)
    )


def _half(shape):
    return (math.ceil(shape[0] / 2), math.ceil(shape[1] / 2))


def _reduce32(x, sigma, fused=True):
    """The blur then the halving; filtered and decimated in one step for even sides.

    ``fused=False``: always OpenCV's blur then resize (see :func:`_laplacian32`).
    """
    h, w = x.shape[:2]
    if fused and sigma > 0 and h % 2 == 0 and w % 2 == 0:
        out = np.empty((h // 2, w // 2, x.shape[2]), np.float32)
        _fused._reduce_fused(x, _fused_kernels(sigma)[0], out)
        return out
    g = _resize32(_blur32(x, sigma), _half(x.shape))
    return g.copy() if g is x else g  # sigma 0 on a 1-pixel level


def _expand32(x, shape, sigma, base=None, sign=1.0, fused=True):
    """``base + sign * expand(x, shape)`` (``base`` None: the expansion alone), a new array.

    For an exact doubling with a blur, the doubling and the blur in one step
    (``fused=False``: always OpenCV's resize then blur).
    """
    h, w = x.shape[:2]
    if fused and sigma > 0 and tuple(shape) == (2 * h, 2 * w):
        kernels, d0 = _fused_kernels(sigma)[1]
        out = np.empty((2 * h, 2 * w, x.shape[2]), np.float32)
        _fused._expand_fused(x, kernels, d0, base, np.float32(sign), out)
        return out
    out = _blur32(_resize32(x, shape), sigma)
    if out is x:  # sigma 0 on a level that does not change size
        out = out.copy()
    if base is not None:
        out *= np.float32(sign)
        out += base
    return out


def _gaussian32(x, levels, sigma=1.0, fused=True):
    pyr = [x]
    for _ in range(levels - 1):
        pyr.append(_reduce32(pyr[-1], sigma, fused))
    return pyr


def _laplacian32(x, levels, sigma=1.0, fused=True):
    """The float32 Laplacian pyramid of ``x`` (h, w, C).

    ``fused=False`` keeps every level on OpenCV's blur and resample, the arithmetic the
    stored video databases' textureness was computed with: the two paths differ by
    float32 round-off, enough to change a few stored float16 values, so a database
    built again would no longer be the same database.
    """
    gauss = _gaussian32(x, levels, sigma, fused)
    bands = [_expand32(g_next, g.shape[:2], sigma, g, -1.0, fused) for g, g_next in pairwise(gauss)]
    bands.append(gauss[-1])
    return bands


def _collapse32(bands, sigma=1.0):
    out = bands[-1]
    for band in reversed(bands[:-1]):
        out = _expand32(out, band.shape[:2], sigma, band, 1.0)
    return out


# --------------------------------------------------------------------------------------
# The weighted Laplacian pyramid of a multiband blend, where the weights are not 0
# --------------------------------------------------------------------------------------


#: Runs of non-zero weights closer than this (pixels) are made one run: the blend's
#: kernels' work per run costs about as much as 30 pixels' (measured at 1920 px).
_GAP = 32


def _weight_spans32(weights, sigma=1.0, gap=_GAP):
    """Where the weights' Gaussian pyramid ``[G_l(W)]`` (each (h_l, w_l, 1)) is not 0.

    Per level ``(ptr, spans, across, need)``: the runs of each row with a non-zero
    weight (:func:`._pyramid_fused.mask_spans`; runs less than ``gap`` pixels apart
    made one, the weights of 0 between them included); where the level's band is
    made by the fused expansion (an exact doubling), the runs of the coarser level's
    width-doubled rows that those runs need (else None); and the runs of the
    Gaussian level :func:`_weighted_laplacian32` makes (reads): those of the weights,
    what the finer level's expansion reads and what the reduce to the next level
    reads there (None: the whole level). They depend on the weights only: a blend
    makes them once for all its images.
    """
    levels = len(weights)
    k2, (kernels, d0) = _fused_kernels(sigma) if sigma > 0 else (None, (None, 0))
    shapes = [g.shape[:2] for g in weights]
    runs, reads, whole = [], [], [False] * levels
    for level, g in enumerate(weights):
        ptr, spans = _fused.mask_spans(g[..., 0] != 0, gap)
        across = None
        if level + 1 < levels and _doubles(weights[level + 1], g.shape[:2], sigma):
            rows = _fused.expand_rows_needed(g[..., 0] != 0, shapes[level + 1][0], kernels, d0)
            across = _fused.mask_spans(rows, gap)
        runs.append((ptr, spans, across))
        reads.append(_fused.spans_mask(ptr, spans, shapes[level][1]))
    for level in range(levels - 1):
        across = runs[level][2]
        if across is None:  # OpenCV's expansion reads the whole coarser level
            whole[level + 1] = True
        else:
            reads[level + 1] |= _fused.expand_reads(*across, *shapes[level + 1], kernels, d0)
    needs = [None] * levels
    for level in range(levels - 2, -1, -1):
        h, w = shapes[level]
        if whole[level + 1] or not _halves((h, w), sigma):
            # The whole reduce: it reads the whole finer level (or all of the
            # coarser level is needed anyway).
            whole[level] = True
            continue
        needs[level + 1] = _fused.mask_spans(reads[level + 1], gap)
        reads[level] |= _fused.reduce_reads(*needs[level + 1], h, w, k2)
    if not whole[0]:
        needs[0] = _fused.mask_spans(reads[0], gap)
    return [r + (need,) for r, need in zip(runs, needs, strict=True)]


def _halves(shape, sigma):
    """Whether :func:`_reduce32` of a level of ``shape`` takes the fused path."""
    return sigma > 0 and shape[0] % 2 == 0 and shape[1] % 2 == 0


def _doubles(x, shape, sigma):
    """Whether :func:`_expand32` of ``x`` to ``shape`` takes the fused path."""
    return sigma > 0 and tuple(shape) == (2 * x.shape[0], 2 * x.shape[1])


def _weighted_laplacian32(x, weights, spans, sigma=1.0):
    """``[G_l(W) * L_l(x)]``, the bands of :func:`_laplacian32` weighted, on ``spans`` only.

    ``weights`` (each (h_l, w_l, 1)) and ``spans`` their :func:`_weight_spans32`; ``x``
    (h, w, C) is overwritten, and read only on the runs of ``spans[0]``'s ``need``
    (if not None). Each band holds the value of ``_laplacian32(x)[l] *
    weights[l]`` (the same float32 sums and product) on the runs where the weight is
    not 0, and anything elsewhere: a blend that multiplies the bands by the weights
    need not make the pixels it multiplies by 0, and reads the bands on the spans
    only. The Gaussian levels are made where those bands read them.
    """
    levels = len(weights)
    gauss = [x]
    for _, _, _, need in spans[1:]:
        if need is None:
            gauss.append(_reduce32(gauss[-1], sigma))
        else:  # only the pixels the bands and the coarser levels read
            g = gauss[-1]
            out = np.empty((g.shape[0] // 2, g.shape[1] // 2, g.shape[2]), np.float32)
            _fused._reduce_spans(g, _fused_kernels(sigma)[0], *need, out)
            gauss.append(out)
    bands = []
    for level, (g, (ptr, runs, across, _)) in enumerate(zip(gauss, spans, strict=True)):
        if level + 1 == levels:
            band = g  # the residual, weighted in place
            _fused.weigh_spans(band, weights[level], ptr, runs)
        elif across is not None:
            kernels, d0 = _fused_kernels(sigma)[1]
            band = np.empty_like(g)
            a_ptr, a_runs = across
            _fused._weighted_band_spans(
                gauss[level + 1], kernels, d0, g, weights[level], a_ptr, a_runs, ptr, runs, band
            )
        else:
            band = _expand32(gauss[level + 1], g.shape[:2], sigma, g, -1.0)
            _fused.weigh_spans(band, weights[level], ptr, runs)
        bands.append(band)
    return bands
