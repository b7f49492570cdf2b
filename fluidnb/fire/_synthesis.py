r"""Texture synthesis with user control (Furukawa et al. (2013), sec. 3.2; Ashikhmin 2001).

The output :math:`I_s` starts as white noise and is scanned in raster order. For
output pixel :math:`p` and input pixel :math:`p_i`, two L-shaped halves of a
:math:`k \times k` square (Furukawa et al. (2013), Fig. 4) are compared:

- :math:`N_U(p)`, the upper L: the rows above :math:`p` and the pixels to its left,
  already synthesised; colours of :math:`I_s` against colours of :math:`I_a`;
- :math:`N_L(p)`, the lower L: :math:`p` itself, the rest of its row to the right
  and the rows below; target temperature :math:`I_t` against the photo's alpha
  :math:`a_a`.

The distance is :math:`D = (1 - w)\,\overline{SSD}_U + w\,\overline{SSD}_L`
(means over the pixels of each L inside the output, so the two halves weigh the same
at the border as inside). The best input pixel's colour is copied and its position
recorded.

Ashikhmin's candidates -- each synthesised neighbour's source shifted by the offset
to :math:`p` -- are what make the result out of coherent patches rather than single
pixels. The random candidates added to them pay a coherence penalty
:math:`(1 + \kappa)` on their distance (the coherence factor of Hertzmann et al.'s
Image Analogies, 2001), so a random jump wins only when it is clearly better: without
it the first keyframes were a grainy mosaic of one-pixel fragments.

:mod:`fluidnb.fire._reference` writes the scan out in plain numpy, pixel by pixel, in
this notation; read it first. The scan is sequential (each pixel depends on the ones
before it), so the version the library runs is compiled with numba (:func:`_scan`
below, the same steps with early termination): in numpy the per-pixel overhead alone
is ~0.1 ms, i.e. seconds per 128 x 128 keyframe, compiled it is a few hundredths of a
second. ``tests/fire/test_fire_reference.py`` checks that both choose the same source
for every pixel.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._image import as_image
from .._random import resolve_seed, rng
from .._validation import check_array, check_choice, check_shape_match
from ._params import FireParams

__all__ = ["alpha_from_photo", "neighbourhood_error", "neighbourhoods", "synthesize"]

_LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
METHODS = ("candidates", "exhaustive")
#: The smallest photo side accepted: a texture needs some pixels to copy patches from.
MIN_PHOTO_SIDE = 8


def neighbourhoods(size):
    """The offsets of the two L-shaped neighbourhoods (Furukawa et al. (2013), Fig. 4).

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
    """The photo's alpha :math:`a_a` that the target temperature is compared against.

    Decision (the paper does not say how its alpha image was made): the luminance
    (Rec. 709) of the photo composited onto black with its matte (``photo * matte``;
    without a matte the photo as it is), normalised to [0, 1] by its minimum and
    maximum. A flame is brightest where it is hottest, so the hottest target
    temperature (1) is matched with the photo's brightest flame colours, the coolest
    (0) with the black around the flame; the matte only says which pixels are flame.
    (Using the matte itself as :math:`a_a` made every flame pixel of a near-binary
    matte an equally good match for the hottest gas, so hot regions came out in the
    dim orange of the flame's edge.)

    Parameters
    ----------
    photo : ndarray, shape (H, W, 3), float in [0, 1]
    matte : ndarray, shape (H, W), optional
        The photo's alpha matte (its alpha channel for a cut-out).

    Returns
    -------
    ndarray, shape (H, W), float32 in [0, 1]

    Examples
    --------
    >>> photo = np.zeros((2, 2, 3), np.float32)
    >>> photo[0, 0] = 0.5
    >>> photo[1, 1] = 0.25
    >>> alpha_from_photo(photo).tolist()
    [[1.0, 0.0], [0.0, 0.5]]
    >>> alpha_from_photo(photo, matte=np.array([[0.5, 1], [1, 1]])).tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    photo = np.asarray(photo, dtype=np.float32)
    if matte is not None:
        photo = photo * np.clip(np.asarray(matte, dtype=np.float32), 0.0, 1.0)[..., None]
    lum = photo @ _LUMA
    lo, hi = float(lum.min()), float(lum.max())
    if hi <= lo:
        return np.zeros(lum.shape, np.float32)
    return np.clip((lum - lo) / (hi - lo), 0.0, 1.0).astype(np.float32)


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
    r"""Synthesise one keyframe like ``photo`` whose brightness follows ``target``.

    The building block :func:`fluidnb.fire.fire` calls at every keyframe; use that for
    animation. Ashikhmin's texture synthesis with user control, as Furukawa et al.
    (2013), sec. 3.2, Fig. 4 apply it: see the module docstring for the
    neighbourhoods and the distance, and :func:`fluidnb.fire._reference.synthesize_reference`
    for the same scan in plain numpy.

    Parameters
    ----------
    photo : array_like, shape (Ha, Wa, 3) or (Ha, Wa, 4)
        :math:`I_a`, the photograph of fire (any form :func:`fluidnb.as_image`
        takes), at least 8 x 8 pixels. An RGBA cut-out's alpha is its matte.
        Used at its size (``params.input_size`` applies in :func:`fire`).
    target : array_like, shape (H, W)
        :math:`I_t`, the target (normalised temperature) in [0, 1].
    params : FireParams, optional
        Uses ``weight``, ``size``, ``n_random``, ``coherence`` and ``second_pass``.
    matte : array_like, shape (Ha, Wa), optional
        The photo's alpha matte (overrides an alpha channel). The colour is
        composited onto black with it, so whatever colour transparent pixels hold
        is never copied; :math:`a_a` is :func:`alpha_from_photo`.
    method : {"candidates", "exhaustive"}
        ``"candidates"``: Ashikhmin's candidate set -- for each already synthesised
        neighbour :math:`q` of :math:`p`, :math:`source(q) + (p - q)` (clamped to
        the photo), plus ``n_random`` random positions whose distance is multiplied
        by :math:`1 + \kappa` (and, in the second pass, :math:`p`'s own source).
        ``"exhaustive"``: every input pixel, no penalty (the reference search;
        150x slower for a 61 x 128 photo, growing with ``Ha * Wa``).
    seed : None, int or numpy.random.Generator
        For the initial white noise and the random candidates.
    return_error : bool
        Also return the per-pixel distance of the chosen source.

    Returns
    -------
    image : ndarray, shape (H, W, 3), float32
        :math:`I_s`; every pixel is exactly the (matted) photo at ``sources[r, c]``.
    sources : ndarray, shape (H, W, 2), int64
        (row, col) in ``photo`` of each output pixel.
    error : ndarray, shape (H, W), float64
        Only with ``return_error``: the distance :math:`D` of each pixel's choice
        in the last pass (before the coherence penalty).

    Raises
    ------
    ValueError
        For a photo that is not RGB(A) or smaller than 8 x 8, a target that is not
        2-D or outside [0, 1], a matte whose shape differs from the photo's, NaN, or
        an unknown ``method``.

    References
    ----------
    .. [1] M. Ashikhmin, "Synthesizing natural textures", Proc. ACM Symposium on
       Interactive 3D Graphics (I3D), pp. 217-226, 2001.
    .. [2] A. Furukawa (古川 歩), Y. Dobashi (土橋 宜典), T. Yamamoto (山本 強),
       "実写画像に類似した流体アニメーションの生成" (Creating realistic animation
       of fluids using photographs), IPSJ SIG Technical Report CG-152, 2013, sec. 3.2.
    .. [3] A. Hertzmann, C. Jacobs, N. Oliver, B. Curless, D. Salesin, "Image
       analogies", Proc. SIGGRAPH 2001 (the coherence factor :math:`\kappa`).

    Examples
    --------
    >>> from fluidnb.data import sample
    >>> photo, matte = sample("flame", size=24, return_alpha=True)
    >>> target = np.zeros((16, 16), np.float32)
    >>> target[4:, 5:11] = 1.0
    >>> image, sources = synthesize(photo, target, matte=matte, seed=0)
    >>> image.shape, sources.shape
    ((16, 16, 3), (16, 16, 2))
    >>> matted = photo * matte[..., None]
    >>> bool(np.array_equal(image, matted[sources[..., 0], sources[..., 1]]))
    True
    """
    params = _check_params(params)
    check_choice("method", method, METHODS)
    photo, alpha = _check_photo(photo, matte)
    target = _check_target(target)
    gen = rng(resolve_seed(seed))
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
    params = _check_params(params)
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
    photo_padded, alpha_padded = _pad(photo, alpha, params.size // 2)
    return float(
        _mean_error(
            image.astype(np.float32),
            src,
            photo_padded,
            alpha_padded,
            target,
            upper,
            lower,
            params.weight,
        )
    )


# ---------------------------------------------------------------------- checks


def _check_params(params):
    params = FireParams() if params is None else params
    if not isinstance(params, FireParams):
        raise ValueError(f"params must be a FireParams, got {type(params).__name__}")
    return params


def _photo_and_matte(photo, matte):
    """The photo as RGB float32 composited onto black with its matte, and the matte.

    An RGBA photo's alpha channel is its matte unless ``matte`` is given. Colour is
    premultiplied by the matte (PNG's alpha is "straight": a cut-out's transparent
    pixels may hold any colour, which must never be copied into the fire).
    """
    photo, alpha = as_image(photo, name="photo", return_alpha=True)
    if photo.ndim != 3 or photo.shape[2] != 3:
        raise ValueError(
            f"photo must be an RGB or RGBA image (H, W, 3) or (H, W, 4), got shape {photo.shape}"
        )
    ha, wa = photo.shape[:2]
    if min(ha, wa) < MIN_PHOTO_SIDE:
        raise ValueError(
            f"photo must be at least {MIN_PHOTO_SIDE} x {MIN_PHOTO_SIDE} pixels (a texture "
            f"to copy patches from), got {ha} x {wa}"
        )
    if matte is not None:
        alpha = as_image(matte, mode="grey", name="matte")
        check_shape_match("matte", alpha, photo.shape[:2], "the photo")
        if not alpha.any():
            raise ValueError(
                "matte has no flame region: it is 0 (black) everywhere; white marks the "
                "flame to copy"
            )
    elif alpha is not None and not alpha.any():
        raise ValueError(
            "photo's alpha channel (its matte) has no flame region: it is fully "
            "transparent; give a cut-out whose flame is opaque, or matte="
        )
    if alpha is not None:
        photo = photo * alpha[..., None]
    return photo, alpha


def _check_photo(photo, matte):
    """The matted photo :math:`I_a` and its alpha :math:`a_a`; refuses a flat photo."""
    photo, matte = _photo_and_matte(photo, matte)
    alpha = alpha_from_photo(photo)  # photo is already composited with the matte
    if not alpha.any():
        raise ValueError(
            "photo has no flame to copy: it is uniform"
            + (" or its matte is empty" if matte is not None else "")
            + " (a photo of fire on a dark background is needed)"
        )
    return photo, alpha


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
    photo_padded = np.pad(photo, ((h, h), (h, h), (0, 0)), mode="edge")
    alpha_padded = np.pad(alpha, ((h, h), (h, h)), mode="edge")
    return (
        np.ascontiguousarray(photo_padded, np.float32),
        np.ascontiguousarray(alpha_padded, np.float32),
    )


def _draws(gen, shape, photo_shape, params):
    """The random numbers one keyframe uses, in the order both scans consume them."""
    h, w = shape
    ha, wa = photo_shape
    passes = 2 if params.second_pass else 1
    noise = gen.random((h, w, 3), dtype=np.float32)  # I_s starts as white noise
    random_rows = gen.integers(0, ha, size=(passes, h, w, params.n_random))
    random_cols = gen.integers(0, wa, size=(passes, h, w, params.n_random))
    return noise, random_rows, random_cols


def _run(photo, alpha, target, params, exhaustive, gen):
    noise, random_rows, random_cols = _draws(gen, target.shape, photo.shape[:2], params)
    upper, lower = neighbourhoods(params.size)
    full = np.concatenate([upper, lower[1:]])  # the square without p itself
    photo_padded, alpha_padded = _pad(photo, alpha, params.size // 2)
    return _scan(
        photo_padded,
        alpha_padded,
        target,
        noise,
        upper,
        lower,
        full,
        float(params.weight),
        float(params.coherence),
        random_rows,
        random_cols,
        exhaustive,
    )


# ---------------------------------------------------------------------- kernels


@njit(cache=True, nogil=True)
def _distance(
    synth,
    target,
    photo_padded,
    alpha_padded,
    r,
    c,
    sr,
    sc,
    colour_offsets,
    target_offsets,
    w_colour,
    w_target,
    pad,
    bound,
):
    """D of input pixel (sr, sc) for output pixel (r, c); stops once above ``bound``.

    ``w_colour`` and ``w_target`` are :math:`(1 - w) / (3 |N_U|)` and
    :math:`w / |N_L|` for the pixels of each L inside the output.
    """
    hh, ww = target.shape
    d = 0.0
    # Lower L, N_L(p): target temperature I_t against the photo's alpha a_a.
    for k in range(target_offsets.shape[0]):
        y = r + target_offsets[k, 0]
        x = c + target_offsets[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            e = (
                target[y, x]
                - alpha_padded[sr + pad + target_offsets[k, 0], sc + pad + target_offsets[k, 1]]
            )
            d += w_target * e * e
    if d > bound:
        return d
    # Upper L, N_U(p) (the full square in the second pass): synthesised colours I_s
    # against the photo's colours I_a.
    for k in range(colour_offsets.shape[0]):
        y = r + colour_offsets[k, 0]
        x = c + colour_offsets[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            iy = sr + pad + colour_offsets[k, 0]
            ix = sc + pad + colour_offsets[k, 1]
            e0 = synth[y, x, 0] - photo_padded[iy, ix, 0]
            e1 = synth[y, x, 1] - photo_padded[iy, ix, 1]
            e2 = synth[y, x, 2] - photo_padded[iy, ix, 2]
            d += w_colour * (e0 * e0 + e1 * e1 + e2 * e2)
            if d > bound:
                return d
    return d


@njit(cache=True, nogil=True)
def _weights(r, c, hh, ww, colour_offsets, target_offsets, weight):
    """(1 - w) / (3 |N_U|) and w / |N_L|, counting the pixels inside the output."""
    n_colour = 0
    for k in range(colour_offsets.shape[0]):
        y = r + colour_offsets[k, 0]
        x = c + colour_offsets[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            n_colour += 1
    n_target = 0
    for k in range(target_offsets.shape[0]):
        y = r + target_offsets[k, 0]
        x = c + target_offsets[k, 1]
        if 0 <= y < hh and 0 <= x < ww:
            n_target += 1
    w_colour = (1.0 - weight) / (3.0 * n_colour) if n_colour > 0 else 0.0
    w_target = weight / n_target
    return w_colour, w_target


@njit(cache=True, nogil=True)
def _scan(
    photo_padded,
    alpha_padded,
    target,
    noise,
    upper,
    lower,
    full,
    weight,
    coherence,
    random_rows,
    random_cols,
    exhaustive,
):
    """The raster scan(s); see ``_reference.synthesize_reference`` for the same in numpy."""
    hh, ww = target.shape
    pad = -upper[0, 0]
    ha = photo_padded.shape[0] - 2 * pad
    wa = photo_padded.shape[1] - 2 * pad
    penalty = 1.0 + coherence
    synth = noise.copy()
    sources = np.full((hh, ww, 2), -1, dtype=np.int64)
    error = np.zeros((hh, ww))
    for ps in range(random_rows.shape[0]):
        colour_offsets = upper if ps == 0 else full
        for r in range(hh):
            for c in range(ww):
                w_colour, w_target = _weights(r, c, hh, ww, colour_offsets, lower, weight)
                best = np.inf  # the (penalised) distance to beat
                best_d = np.inf  # its plain D
                br = -1
                bc = -1
                if exhaustive:
                    for sr in range(ha):
                        for sc in range(wa):
                            d = _distance(
                                synth, target, photo_padded, alpha_padded, r, c, sr, sc,
                                colour_offsets, lower, w_colour, w_target, pad, best,
                            )  # fmt: skip
                            if d < best:
                                best = d
                                best_d = d
                                br = sr
                                bc = sc
                else:
                    if ps > 0:
                        # Second pass: p's own source from the first is the first candidate.
                        br = sources[r, c, 0]
                        bc = sources[r, c, 1]
                        best = _distance(
                            synth, target, photo_padded, alpha_padded, r, c, br, bc,
                            colour_offsets, lower, w_colour, w_target, pad, np.inf,
                        )  # fmt: skip
                        best_d = best
                    # Coherent candidates: neighbour q's source shifted by (p - q).
                    for k in range(colour_offsets.shape[0]):
                        y = r + colour_offsets[k, 0]
                        x = c + colour_offsets[k, 1]
                        if not (0 <= y < hh and 0 <= x < ww) or sources[y, x, 0] < 0:
                            continue
                        sr = min(max(sources[y, x, 0] - colour_offsets[k, 0], 0), ha - 1)
                        sc = min(max(sources[y, x, 1] - colour_offsets[k, 1], 0), wa - 1)
                        d = _distance(
                            synth, target, photo_padded, alpha_padded, r, c, sr, sc,
                            colour_offsets, lower, w_colour, w_target, pad, best,
                        )  # fmt: skip
                        if d < best:
                            best = d
                            best_d = d
                            br = sr
                            bc = sc
                    # Random candidates pay the coherence penalty (1 + kappa).
                    for k in range(random_rows.shape[3]):
                        sr = random_rows[ps, r, c, k]
                        sc = random_cols[ps, r, c, k]
                        d = _distance(
                            synth, target, photo_padded, alpha_padded, r, c, sr, sc,
                            colour_offsets, lower, w_colour, w_target, pad, best / penalty,
                        )  # fmt: skip
                        if penalty * d < best:
                            best = penalty * d
                            best_d = d
                            br = sr
                            bc = sc
                    if br < 0:
                        # No synthesised neighbour and no random candidate: a fixed
                        # pseudo-random pixel, as Ashikhmin's initialisation would give.
                        br = (r * 7919 + c) % ha
                        bc = (c * 104729 + r) % wa
                        best_d = _distance(
                            synth, target, photo_padded, alpha_padded, r, c, br, bc,
                            colour_offsets, lower, w_colour, w_target, pad, np.inf,
                        )  # fmt: skip
                synth[r, c, 0] = photo_padded[br + pad, bc + pad, 0]
                synth[r, c, 1] = photo_padded[br + pad, bc + pad, 1]
                synth[r, c, 2] = photo_padded[br + pad, bc + pad, 2]
                sources[r, c, 0] = br
                sources[r, c, 1] = bc
                error[r, c] = best_d
    return synth, sources, error


@njit(cache=True, nogil=True)
def _mean_error(synth, sources, photo_padded, alpha_padded, target, upper, lower, weight):
    hh, ww = target.shape
    pad = -upper[0, 0]
    total = 0.0
    for r in range(hh):
        for c in range(ww):
            w_colour, w_target = _weights(r, c, hh, ww, upper, lower, weight)
            total += _distance(
                synth, target, photo_padded, alpha_padded, r, c,
                sources[r, c, 0], sources[r, c, 1], upper, lower, w_colour, w_target, pad, np.inf,
            )  # fmt: skip
    return total / (hh * ww)
