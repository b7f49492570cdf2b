r"""Texture synthesis with user control (seed 3.2; Ashikhmin 2001).

The output :math:`I_s` starts as white noise and is scanned in raster order. For
output pixel :math:`p` and input pixel :math:`p_i`, two L-shaped halves of a
:math:`k \times k` square (seed Fig. 4) are compared:

- :math:`N_U(p)`, the upper L: the rows above :math:`p` and the pixels to its left,
  already synthesised; colours of :math:`I_s` against colours of :math:`I_a`;
- :math:`N_L(p)`, the lower L: :math:`p` itself, the rest of its row to the right
  and the rows below; target temperature :math:`I_t` against the photo's alpha
  :math:`a_a`.

The distance is :math:`D = (1 - w)\,\overline{SSD}_U + w\,\overline{SSD}_L`
(means over the pixels of each L inside the output, so the two halves weigh the same
at the border as inside). The best input pixel's colour is copied and its position
recorded.

The raster scan is sequential (each pixel depends on the ones before it), so the scan
itself is compiled with numba: one code path, per pixel a few dozen candidates of
``k * k`` pixels each. In pure numpy the per-pixel overhead alone is ~0.1 ms, i.e.
several seconds per 128 x 128 keyframe; compiled, the candidate search takes a few
hundredths of a second. The exhaustive search (the reference) uses the same distance
over every input pixel, with early termination once a partial sum exceeds the best.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._image import as_image
from .._random import rng
from .._validation import check_array, check_choice, check_shape_match
from ._params import FireParams

__all__ = ["alpha_from_photo", "neighbourhood_error", "neighbourhoods", "synthesize"]

_LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
METHODS = ("candidates", "exhaustive")


def neighbourhoods(size):
    """The offsets of the two L-shaped neighbourhoods of seed Fig. 4.

    Parameters
    ----------
    size : int
        :math:`k`, the odd side of the square.

    Returns
    -------
    upper : ndarray, shape ((k * k - 1) / 2, 2), int
        (dy, dx) offsets of :math:`N_U(p)`: the rows above and the pixels to the left.
    lower : ndarray, shape ((k * k + 1) / 2, 2), int
        (dy, dx) offsets of :math:`N_L(p)`: :math:`p`, the pixels to its right and
        the rows below. Together the two tile the square exactly once.

    Examples
    --------
    >>> upper, lower = neighbourhoods(3)
    >>> upper.tolist()
    [[-1, -1], [-1, 0], [-1, 1], [0, -1]]
    >>> lower.tolist()
    [[0, 0], [0, 1], [1, -1], [1, 0], [1, 1]]
    """
    h = size // 2
    square = [(dy, dx) for dy in range(-h, h + 1) for dx in range(-h, h + 1)]
    upper = [o for o in square if o < (0, 0)]
    lower = [o for o in square if o >= (0, 0)]
    return np.array(upper, dtype=np.int64), np.array(lower, dtype=np.int64)


def alpha_from_photo(photo, matte=None):
    """The photo's alpha :math:`a_a` that the target is compared against.

    Decision (spec 03-fire, Sec. 2): the matte if one is given, else the photo's
    luminance (Rec. 709) normalised to [0, 1] by its minimum and maximum.

    Parameters
    ----------
    photo : ndarray, shape (H, W, 3), float in [0, 1]
    matte : ndarray, shape (H, W), optional

    Returns
    -------
    ndarray, shape (H, W), float32 in [0, 1]

    Examples
    --------
    >>> photo = np.zeros((2, 2, 3), np.float32)
    >>> photo[0, 0] = 0.5
    >>> alpha_from_photo(photo).tolist()
    [[1.0, 0.0], [0.0, 0.0]]
    """
    if matte is not None:
        return np.clip(np.asarray(matte, dtype=np.float32), 0.0, 1.0)
    lum = np.asarray(photo, dtype=np.float32) @ _LUMA
    lo, hi = float(lum.min()), float(lum.max())
    if hi <= lo:
        return np.zeros(lum.shape, np.float32)
    return ((lum - lo) / (hi - lo)).astype(np.float32)


def synthesize(
    photo,
    target,
    params=None,
    *,
    matte=None,
    method="candidates",
    seed=None,
    return_error=False,
):
    r"""Synthesise an image like ``photo`` whose brightness follows ``target``.

    Ashikhmin's texture synthesis with user control, as the seed applies it
    (Sec. 3.2, Fig. 4): see the module docstring for the neighbourhoods and distance.

    Parameters
    ----------
    photo : array_like, shape (Ha, Wa, 3)
        :math:`I_a`, the photograph of fire (any form :func:`fluidnb.as_image`
        takes). Used as given (``params.input_size`` applies in :func:`fire`).
    target : array_like, shape (H, W)
        :math:`I_t`, the target (normalised temperature) in [0, 1].
    params : FireParams, optional
        Uses ``weight``, ``size``, ``n_random`` and ``second_pass``.
    matte : array_like, shape (Ha, Wa), optional
        The photo's alpha matte; default: its normalised luminance
        (:func:`alpha_from_photo`).
    method : {"candidates", "exhaustive"}
        ``"candidates"``: Ashikhmin's candidate set -- for each already synthesised
        neighbour :math:`q` of :math:`p`, :math:`source(q) + (p - q)` (clamped to
        the photo), plus ``n_random`` random positions (and, in the second pass,
        :math:`p`'s own source). ``"exhaustive"``: every input pixel (the
        reference; 150x slower for a 61 x 128 photo, growing with ``Ha * Wa``).
    seed : None, int or numpy.random.Generator
        For the initial white noise and the random candidates.
    return_error : bool
        Also return the per-pixel distance of the chosen source.

    Returns
    -------
    image : ndarray, shape (H, W, 3), float32
        :math:`I_s`; every pixel is exactly ``photo[sources[r, c]]``.
    sources : ndarray, shape (H, W, 2), int64
        (row, col) in ``photo`` of each output pixel.
    error : ndarray, shape (H, W), float64
        Only with ``return_error``: the distance :math:`D` of each pixel's choice
        in the last pass.

    Raises
    ------
    ValueError
        For a photo that is not RGB, a target that is not 2-D or outside [0, 1], a
        matte whose shape differs from the photo's, NaN, or an unknown ``method``.

    References
    ----------
    .. [1] M. Ashikhmin, "Synthesizing natural textures", Proc. ACM Symposium on
       Interactive 3D Graphics (I3D), pp. 217-226, 2001.
    .. [2] A. Kogawa (古川 歩), Y. Dobashi (土橋 宜典), T. Yamamoto (山本 強),
       "実写画像に類似した流体アニメーションの生成" (Creating realistic animation
       of fluids using photographs), Sec. 3.2.

    Examples
    --------
    >>> from fluidnb.data import sample
    >>> photo, matte = sample("flame", size=24, return_alpha=True)
    >>> target = np.zeros((16, 16), np.float32)
    >>> target[4:, 5:11] = 1.0
    >>> image, sources = synthesize(photo, target, matte=matte, seed=0)
    >>> image.shape, sources.shape
    ((16, 16, 3), (16, 16, 2))
    >>> bool(np.array_equal(image, photo[sources[..., 0], sources[..., 1]]))
    True
    """
    params = FireParams() if params is None else params
    if not isinstance(params, FireParams):
        raise ValueError(f"params must be a FireParams, got {type(params).__name__}")
    check_choice("method", method, METHODS)
    photo, alpha = _check_photo(photo, matte)
    target = _check_target(target)
    gen = rng(seed)
    out, src, err = _run(photo, alpha, target, params, method == "exhaustive", gen)
    if return_error:
        return out, src, err
    return out, src


def neighbourhood_error(image, sources, photo, target, params=None, *, matte=None):
    """Mean distance between each output pixel's L neighbourhoods and its source's.

    The quantity both searches minimise pixel by pixel, evaluated on the finished
    image with the causal neighbourhoods of the first pass: colours over
    :math:`N_U`, target against alpha over :math:`N_L`, weighted by ``weight``.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3)
    sources : ndarray, shape (H, W, 2), int
    photo, target, params, matte
        As for :func:`synthesize`.

    Returns
    -------
    float
    """
    params = FireParams() if params is None else params
    photo, alpha = _check_photo(photo, matte)
    target = _check_target(target)
    image = check_array("image", image, ndim=3, dtype_kinds="f")
    check_shape_match("image", image, target.shape, "the target")
    sources = check_array("sources", sources, ndim=3, dtype_kinds="iu")
    check_shape_match("sources", sources, target.shape, "the target")
    src = sources.astype(np.int64)
    ha, wa = photo.shape[:2]
    if src.min() < 0 or src[..., 0].max() >= ha or src[..., 1].max() >= wa:
        raise ValueError("sources must be positions inside the photo")
    upper, lower = neighbourhoods(params.size)
    ap, alp = _pad(photo, alpha, params.size // 2)
    return float(
        _mean_error(image.astype(np.float32), src, ap, alp, target, upper, lower, params.weight)
    )


# ---------------------------------------------------------------------- checks


def _photo_and_matte(photo, matte):
    """The photo as RGB float32 and its optional matte as grey, both checked."""
    photo = as_image(photo, name="photo")
    if photo.ndim != 3 or photo.shape[2] != 3:
        raise ValueError(f"photo must be an RGB image (H, W, 3), got shape {photo.shape}")
    if matte is not None:
        matte = as_image(matte, mode="grey", name="matte")
        check_shape_match("matte", matte, photo.shape[:2], "the photo")
    return photo, matte


def _check_photo(photo, matte):
    photo, matte = _photo_and_matte(photo, matte)
    return photo, alpha_from_photo(photo, matte)


def _check_target(target):
    target = check_array("target", target, ndim=2, dtype_kinds="biuf")
    if target.dtype.kind == "f" and (target.min() < 0 or target.max() > 1):
        raise ValueError(
            f"target must be in [0, 1], got values in [{target.min():g}, {target.max():g}]"
        )
    if target.dtype.kind in "iu":
        raise ValueError("target must be a float or bool array in [0, 1]")
    return target.astype(np.float32)


def _pad(photo, alpha, h):
    # Edge padding makes every input pixel a candidate with a full neighbourhood;
    # the copied colour is always an unpadded pixel, so the source stays exact.
    ap = np.pad(photo, ((h, h), (h, h), (0, 0)), mode="edge")
    alp = np.pad(alpha, ((h, h), (h, h)), mode="edge")
    return np.ascontiguousarray(ap, np.float32), np.ascontiguousarray(alp, np.float32)


def _run(photo, alpha, target, params, exhaustive, gen):
    h, w = target.shape
    ha, wa = photo.shape[:2]
    passes = 2 if params.second_pass else 1
    noise = gen.random((h, w, 3), dtype=np.float32)  # I_s starts as white noise
    rand_r = gen.integers(0, ha, size=(passes, h, w, params.n_random))
    rand_c = gen.integers(0, wa, size=(passes, h, w, params.n_random))
    upper, lower = neighbourhoods(params.size)
    full = np.concatenate([upper, lower[1:]])  # the square without p itself
    ap, alp = _pad(photo, alpha, params.size // 2)
    return _scan(
        ap,
        alp,
        target,
        noise,
        upper,
        lower,
        full,
        float(params.weight),
        rand_r,
        rand_c,
        passes,
        exhaustive,
    )


# ---------------------------------------------------------------------- kernels


@njit(cache=True, nogil=True)
def _distance(out, tgt, ap, alp, r, c, sr, sc, offc, offl, cu, cl, h, best):
    """D of input pixel (sr, sc) for output pixel (r, c); stops once above ``best``."""
    hh, ww = tgt.shape
    d = 0.0
    for k in range(offl.shape[0]):
        y = r + offl[k, 0]
        x = c + offl[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            e = tgt[y, x] - alp[sr + h + offl[k, 0], sc + h + offl[k, 1]]
            d += cl * e * e
    if d > best:
        return d
    for k in range(offc.shape[0]):
        y = r + offc[k, 0]
        x = c + offc[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            iy = sr + h + offc[k, 0]
            ix = sc + h + offc[k, 1]
            e0 = out[y, x, 0] - ap[iy, ix, 0]
            e1 = out[y, x, 1] - ap[iy, ix, 1]
            e2 = out[y, x, 2] - ap[iy, ix, 2]
            d += cu * (e0 * e0 + e1 * e1 + e2 * e2)
            if d > best:
                return d
    return d


@njit(cache=True, nogil=True)
def _weights(r, c, hh, ww, offc, offl, weight):
    nu = 0
    for k in range(offc.shape[0]):
        y = r + offc[k, 0]
        x = c + offc[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            nu += 1
    nl = 0
    for k in range(offl.shape[0]):
        y = r + offl[k, 0]
        x = c + offl[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            nl += 1
    cu = (1.0 - weight) / (3.0 * nu) if nu > 0 else 0.0
    cl = weight / nl
    return cu, cl


@njit(cache=True, nogil=True)
def _scan(ap, alp, tgt, noise, upper, lower, full, weight, rand_r, rand_c, passes, exhaustive):
    hh, ww = tgt.shape
    h = -upper[0, 0]
    ha = ap.shape[0] - 2 * h
    wa = ap.shape[1] - 2 * h
    out = noise.copy()
    src = np.full((hh, ww, 2), -1, dtype=np.int64)
    err = np.zeros((hh, ww))
    for ps in range(passes):
        offc = upper if ps == 0 else full
        for r in range(hh):
            for c in range(ww):
                cu, cl = _weights(r, c, hh, ww, offc, lower, weight)
                best = np.inf
                br = -1
                bc = -1
                if exhaustive:
                    for sr in range(ha):
                        for sc in range(wa):
                            d = _distance(
                                out, tgt, ap, alp, r, c, sr, sc, offc, lower, cu, cl, h, best
                            )
                            if d < best:
                                best = d
                                br = sr
                                bc = sc
                else:
                    if ps > 0:
                        br = src[r, c, 0]
                        bc = src[r, c, 1]
                        best = _distance(
                            out, tgt, ap, alp, r, c, br, bc, offc, lower, cu, cl, h, np.inf
                        )
                    for k in range(offc.shape[0]):
                        y = r + offc[k, 0]
                        x = c + offc[k, 1]
                        if not (0 <= y < hh and 0 <= x < ww) or src[y, x, 0] < 0:
                            continue
                        # Shift the neighbour's source by (p - q), clamped to the photo.
                        sr = min(max(src[y, x, 0] - offc[k, 0], 0), ha - 1)
                        sc = min(max(src[y, x, 1] - offc[k, 1], 0), wa - 1)
                        d = _distance(out, tgt, ap, alp, r, c, sr, sc, offc, lower, cu, cl, h, best)
                        if d < best:
                            best = d
                            br = sr
                            bc = sc
                    for k in range(rand_r.shape[3]):
                        sr = rand_r[ps, r, c, k]
                        sc = rand_c[ps, r, c, k]
                        d = _distance(out, tgt, ap, alp, r, c, sr, sc, offc, lower, cu, cl, h, best)
                        if d < best:
                            best = d
                            br = sr
                            bc = sc
                    if br < 0:
                        # No synthesised neighbour and no random candidate: a random
                        # pixel, as Ashikhmin's initialisation would give.
                        br = (r * 7919 + c) % ha
                        bc = (c * 104729 + r) % wa
                        best = _distance(
                            out, tgt, ap, alp, r, c, br, bc, offc, lower, cu, cl, h, np.inf
                        )
                out[r, c, 0] = ap[br + h, bc + h, 0]
                out[r, c, 1] = ap[br + h, bc + h, 1]
                out[r, c, 2] = ap[br + h, bc + h, 2]
                src[r, c, 0] = br
                src[r, c, 1] = bc
                err[r, c] = best
    return out, src, err


@njit(cache=True, nogil=True)
def _mean_error(out, src, ap, alp, tgt, upper, lower, weight):
    hh, ww = tgt.shape
    h = -upper[0, 0]
    total = 0.0
    for r in range(hh):
        for c in range(ww):
            cu, cl = _weights(r, c, hh, ww, upper, lower, weight)
            total += _distance(
                out, tgt, ap, alp, r, c, src[r, c, 0], src[r, c, 1], upper, lower, cu, cl, h, np.inf
            )
    return total / (hh * ww)
