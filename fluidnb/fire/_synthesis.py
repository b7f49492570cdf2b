r"""Texture synthesis with user control (Furukawa et al. (2013), sec. 3.2; Ashikhmin 2001).

The output :math:`I_s` is scanned in raster order (the paper starts it as white noise,
which no comparison ever reads: see :func:`_draws`). For
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
below): in numpy the per-pixel overhead alone is ~0.1 ms, i.e. seconds per 128 x 128
keyframe. What makes the compiled scan fast (measured on 2 cores, one keyframe at
128 x 128 from ~0.4 s to ~0.03 s of one core):

- colours, alpha and target are compared as 8-bit levels, each input pixel's
  neighbourhood stored once as a contiguous row (:func:`_features`), so a
  candidate's sums of squared differences are exact integers in vector code (and
  the same in any order: the reference agrees to the last bit);
- a candidate stops being measured once it cannot win; a repeated coherent
  candidate (most neighbours inside a patch propose the same pixel) is not measured
  again, and nothing is measured after an exact match;
- the random candidates come from a counter-based generator, not a stored array;
- on several threads the pixels are visited in sheared tiles (:func:`_scan_tiles`),
  an order in which every pixel sees what it sees in the raster scan.

``tests/fire/test_fire_reference.py`` checks that all of them choose the same source
for every pixel.
"""

from __future__ import annotations

import os

import numpy as np
from numba import njit, prange

from .._image import as_image
from .._random import resolve_seed, rng
from .._validation import check_array, check_choice, check_shape_match
from ._matte import flame_matte, is_hard
from ._params import FireParams

__all__ = ["alpha_from_photo", "neighbourhood_error", "neighbourhoods", "synthesize"]

# Idle OpenMP threads sleep rather than spin, as in fluidnb.fluid._kernels (a spinning
# thread that loses its core to another program stalls every parallel loop).
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

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
    prepared = _Prepared(photo, alpha, params)
    level = _mean_error(
        prepared.colour,
        prepared.alpha,
        _quantise(image),
        np.ascontiguousarray(src[..., 0] * wa + src[..., 1]),
        _quantise(target),
        prepared.square,
        prepared.lower,
        float(params.weight),
    )
    return float(level / LEVELS**2)


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
    pixels may hold any colour, which must never be copied into the fire). A hard
    (0/1) ``matte``, one painted with a brush, is a hint of which flame is meant:
    :func:`fluidnb.fire.flame_matte` makes it the flame's own soft matte.
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
        if is_hard(alpha):
            alpha = flame_matte(photo, alpha)
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


#: Colours, the photo's alpha and the target are compared as 8-bit levels (0..255).
LEVELS = 255


def _quantise(x):
    """[0, 1] floats as 8-bit levels, rounded: what the distance compares.

    Photos are 8-bit; so is any colour the scan can copy. Comparing levels makes every
    sum of squared differences an exact integer, the same in any order, so the
    compiled scan (vectorised, on several threads) and the plain reference make the
    same choice for every pixel, to the last bit.
    """
    return np.rint(np.clip(np.asarray(x, np.float32), 0.0, 1.0) * LEVELS).astype(np.uint8)


def _offsets(size):
    """The square without p, in raster order: N_U first, then N_L without p."""
    upper, lower = neighbourhoods(size)
    return np.ascontiguousarray(np.concatenate([upper, lower[1:]])), lower


def _features(photo, alpha, size):
    """Each input pixel's neighbourhood as flat 8-bit rows, built once per photo.

    ``colour[i]`` holds the colours of the square around input pixel ``i`` (flat
    index ``row * Wa + col``) without the pixel itself, in the order of
    :func:`_offsets` -- the first half of a row is :math:`N_U`, so the first pass
    reads a prefix; ``alpha[i]`` holds :math:`a_a` over :math:`N_L`. The photo is
    edge-padded so that every pixel has a whole square (the copied colour is always
    the pixel itself, so a source stays exact). Contiguous rows make a candidate's
    distance a few vector instructions.
    """
    h = size // 2
    square, lower = _offsets(size)
    colour_q = np.pad(_quantise(photo), ((h, h), (h, h), (0, 0)), mode="edge")
    alpha_q = np.pad(_quantise(alpha), h, mode="edge")
    return _gather_features(colour_q, alpha_q, square, lower)


@njit(cache=True, nogil=True)
def _gather_features(colour_q, alpha_q, square, lower):
    h = -square[0, 0]
    ha = alpha_q.shape[0] - 2 * h
    wa = alpha_q.shape[1] - 2 * h
    colour = np.empty((ha * wa, 3 * square.shape[0]), np.uint8)
    alpha = np.empty((ha * wa, lower.shape[0]), np.uint8)
    for r in range(ha):
        for c in range(wa):
            i = r * wa + c
            for j in range(square.shape[0]):
                for ch in range(3):
                    colour[i, 3 * j + ch] = colour_q[r + h + square[j, 0], c + h + square[j, 1], ch]
            for j in range(lower.shape[0]):
                alpha[i, j] = alpha_q[r + h + lower[j, 0], c + h + lower[j, 1]]
    return colour, alpha


def _draws(gen, params):
    """The random numbers of one keyframe: a 64-bit key and how many candidates a pixel.

    The ``k``-th random candidate of pixel (r, c) in pass ``ps`` is drawn from the key
    by a counter-based generator, :func:`_random_word` of ``key + n`` with
    ``n = ((ps H + r) W + c) n_r + k``: each pixel's numbers are the same whatever
    order the pixels are visited in (the parallel scan's) and none is stored (a
    256 x 256 keyframe uses two million).

    The paper starts :math:`I_s` as white noise. No noise pixel is ever compared: the
    first pass compares only :math:`N_U(p)`, which the raster scan has already
    synthesised, and the neighbourhoods are cut at the output's border. So none is
    drawn.
    """
    key = np.uint64(gen.integers(0, 2**63, dtype=np.int64))
    return key, (2 if params.second_pass else 1), int(params.n_random)


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _random_word(x):
    """SplitMix64 (Steele, Lea & Flood 2014) of counter(s) ``x``: uniform 64-bit words."""
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


def _random_index(word, n):
    """A flat input index in [0, n) of a random 64-bit ``word``.

    Lemire's multiply-shift on its top 32 bits: uniform to within n / 2**32.
    """
    return ((word >> np.uint64(32)) * np.uint64(n)) >> np.uint64(32)


_random_word_jit = njit(cache=True, nogil=True)(_random_word)
_random_index_jit = njit(cache=True, nogil=True)(_random_index)


class _Prepared:
    """A photo made ready for the scan: its features, built once for many keyframes."""

    def __init__(self, photo, alpha, params):
        self.photo = np.ascontiguousarray(photo, np.float32)
        self.shape = alpha.shape
        self.size = params.size
        self.colour, self.alpha = _features(photo, alpha, params.size)
        self.own = np.ascontiguousarray(_quantise(photo).reshape(-1, 3))
        self.square, self.lower = _offsets(params.size)


def _tiles(shape, size):
    """Rows per band and sheared columns per tile of the parallel scan (see _scan)."""
    w = shape[1]
    skew = size // 2 + 1
    band = 8
    # About 5 tiles a band: enough tiles in a wavefront for two threads to share, few
    # enough wavefronts (each a rendezvous of the threads, ~40 us here).
    chunk = max(8, (w + skew * band) // 5)
    return band, chunk


def _run(photo, alpha, target, params, exhaustive, gen, prepared=None, threads=None, tiles=None):
    """One keyframe: (image, sources, error). ``prepared`` reuses a photo's features.

    ``threads`` (default numba's count) above 1 runs the tiled scan on keyframes of
    at least 64 x 64 pixels, or on any size when ``tiles`` (band, chunk) is given.
    """
    import numba

    if prepared is None:
        prepared = _Prepared(photo, alpha, params)
    key, passes, n_random = _draws(gen, params)
    target_q = _quantise(target)
    threads = numba.get_num_threads() if threads is None else threads
    band, chunk = _tiles(target.shape, params.size) if tiles is None else tiles
    args = (
        prepared.colour,
        prepared.alpha,
        prepared.own,
        target_q,
        prepared.square,
        prepared.lower,
        prepared.shape[1],
        float(params.weight),
        1.0 + float(params.coherence),
        key,
        passes,
        n_random,
        exhaustive,
    )
    # Small keyframes (and the exhaustive search, which has work enough in each
    # pixel) gain nothing from the parallel scan's rendezvous.
    if threads > 1 and not exhaustive and (target.size >= 64 * 64 or tiles is not None):
        src, err = _scan_tiles(*args, band, chunk)
    else:
        src, err = _scan(*args)
    wa = prepared.shape[1]
    sources = np.stack([src // wa, src % wa], axis=-1).astype(np.int64)
    image = prepared.photo[sources[..., 0], sources[..., 1]]
    return image, sources, err / LEVELS**2


# ---------------------------------------------------------------------- kernels


@njit(cache=True, nogil=True)
def _gather(r, c, n_colour, target_q, synth_q, square, lower, oc, mc, ot, mt, weight):
    """The output pixel's side of the distance: levels, masks and the two weights.

    ``oc``/``mc``: the synthesised colours over the first ``n_colour`` pixels of the
    square (N_U in the first pass, the whole square in the second) and 1 where the
    pixel is inside the output; ``ot``/``mt`` the same for the target over N_L.
    Returns :math:`(1 - w) / (3 |N_U|)` and :math:`w / |N_L|` counting the pixels
    inside the output.
    """
    hh, ww = target_q.shape
    inside_c = 0
    for j in range(n_colour):
        y = r + square[j, 0]
        x = c + square[j, 1]
        if 0 <= y < hh and 0 <= x < ww:
            inside_c += 1
            for ch in range(3):
                oc[3 * j + ch] = synth_q[y, x, ch]
                mc[3 * j + ch] = 1
        else:
            for ch in range(3):
                oc[3 * j + ch] = 0
                mc[3 * j + ch] = 0
    inside_t = 0
    for j in range(lower.shape[0]):
        y = r + lower[j, 0]
        x = c + lower[j, 1]
        if 0 <= y < hh and 0 <= x < ww:
            inside_t += 1
            ot[j] = target_q[y, x]
            mt[j] = 1
        else:
            ot[j] = 0
            mt[j] = 0
    w_colour = (1.0 - weight) / (3.0 * inside_c) if inside_c > 0 else 0.0
    w_target = weight / inside_t
    return w_colour, w_target


@njit(cache=True, nogil=True)
def _ssd(o, m, row, lo, hi):
    """Sum over k in [lo, hi) of (m_k (o_k - row_k))^2, exact in integers."""
    # Unsigned indices: numba then adds no wrap-around test to each access and LLVM
    # vectorises the loop (4x faster measured). At most 3 * 224 terms of at most
    # 255^2: the sum fits an int32.
    s = np.int32(0)
    for k in range(np.uint64(lo), np.uint64(hi)):
        e = (o[k] - np.int32(row[k])) * m[k]
        s += e * e
    return s


@njit(cache=True, nogil=True)
def _distance(
    i, colour, alpha, oc, mc, ot, mt, n_colour, w_colour, w_target, penalty, best
):  # fmt: skip
    r""":math:`D` of input pixel ``i``; stops once ``penalty * D >= best`` is sure.

    :math:`D = w / |N_L| \cdot SSD_L + (1 - w) / (3 |N_U|) \cdot SSD_U` in levels
    squared. The sums are exact integers, and a partial sum never exceeds the whole,
    so stopping early never changes which candidate wins.
    """
    s_t = _ssd(ot, mt, alpha[i], 0, ot.shape[0])
    d = w_target * s_t
    if penalty * d >= best:
        return d
    # Colours over N_U (the first half of the square), then in the second pass over
    # the rest of the square.
    half = oc.shape[0] // 2
    s_c = _ssd(oc, mc, colour[i], 0, half)
    d = w_target * s_t + w_colour * s_c
    if 3 * n_colour > half:
        if penalty * d >= best:
            return d
        s_c += _ssd(oc, mc, colour[i], half, 3 * n_colour)
        d = w_target * s_t + w_colour * s_c
    return d


@njit(cache=True, nogil=True)
def _pixel(
    r, c, ps, colour, alpha, own, target_q, synth_q, src, error, square, lower, wa, weight,
    penalty, key, n_random, exhaustive, oc, mc, ot, mt, seen,
):  # fmt: skip
    """Choose the source of output pixel (r, c) in pass ``ps`` and copy its levels."""
    n_photo = colour.shape[0]
    n_colour = square.shape[0] // 2 if ps == 0 else square.shape[0]
    ha = n_photo // wa
    w_colour, w_target = _gather(
        r, c, n_colour, target_q, synth_q, square, lower, oc, mc, ot, mt, weight
    )
    best = np.inf  # the (penalised) distance to beat
    best_d = np.inf  # its plain D
    bi = -1
    if exhaustive:
        for i in range(n_photo):
            d = _distance(
                i,
                colour,
                alpha,
                oc,
                mc,
                ot,
                mt,
                n_colour,
                w_colour,
                w_target,
                1.0,
                best,
            )
            if d < best:
                best = d
                best_d = d
                bi = i
    else:
        n_seen = 0
        if ps > 0:
            # Second pass: p's own source from the first is the first candidate.
            bi = src[r, c]
            best = _distance(
                bi,
                colour,
                alpha,
                oc,
                mc,
                ot,
                mt,
                n_colour,
                w_colour,
                w_target,
                1.0,
                np.inf,
            )
            best_d = best
            seen[0] = bi
            n_seen = 1
        # Coherent candidates: neighbour q's source shifted by (p - q). Inside a patch
        # most neighbours propose the same pixel: a repeat cannot win (a win needs a
        # strictly smaller D), so it is not measured again.
        for k in range(n_colour):
            if best <= 0.0:
                break  # nothing beats an exact match
            y = r + square[k, 0]
            x = c + square[k, 1]
            if not (0 <= y < target_q.shape[0] and 0 <= x < target_q.shape[1]) or src[y, x] < 0:
                continue
            sr = min(max(src[y, x] // wa - square[k, 0], 0), ha - 1)
            sc = min(max(src[y, x] % wa - square[k, 1], 0), wa - 1)
            i = sr * wa + sc
            repeat = False
            for j in range(n_seen):
                if seen[j] == i:
                    repeat = True
                    break
            if repeat:
                continue
            seen[n_seen] = i
            n_seen += 1
            d = _distance(
                i,
                colour,
                alpha,
                oc,
                mc,
                ot,
                mt,
                n_colour,
                w_colour,
                w_target,
                1.0,
                best,
            )
            if d < best:
                best = d
                best_d = d
                bi = i
        # Random candidates pay the coherence penalty (1 + kappa).
        hh, ww = target_q.shape
        counter = key + np.uint64(((ps * hh + r) * ww + c) * n_random)
        for k in range(n_random):
            if best <= 0.0:
                break
            word = _random_word_jit(counter + np.uint64(k))
            i = np.int64(_random_index_jit(word, np.uint64(n_photo)))
            d = _distance(
                i,
                colour,
                alpha,
                oc,
                mc,
                ot,
                mt,
                n_colour,
                w_colour,
                w_target,
                penalty,
                best,
            )
            if penalty * d < best:
                best = penalty * d
                best_d = d
                bi = i
        if bi < 0:
            # No synthesised neighbour and no random candidate: a fixed
            # pseudo-random pixel, as Ashikhmin's initialisation would give.
            bi = ((r * 7919 + c) % ha) * wa + (c * 104729 + r) % wa
            best_d = _distance(
                bi,
                colour,
                alpha,
                oc,
                mc,
                ot,
                mt,
                n_colour,
                w_colour,
                w_target,
                1.0,
                np.inf,
            )
    src[r, c] = bi
    error[r, c] = best_d
    for ch in range(3):
        synth_q[r, c, ch] = own[bi, ch]


def _buffers(n_square, n_lower):
    """One thread's scratch rows for :func:`_pixel`."""
    return (
        np.empty(3 * n_square, np.int32),
        np.empty(3 * n_square, np.int32),
        np.empty(n_lower, np.int32),
        np.empty(n_lower, np.int32),
        np.empty(n_square + 1, np.int64),
    )


_buffers = njit(cache=True, nogil=True)(_buffers)


@njit(cache=True, nogil=True)
def _scan(
    colour, alpha, own, target_q, square, lower, wa, weight, penalty, key, passes, n_random,
    exhaustive,
):  # fmt: skip
    """The raster scan(s); ``_reference.synthesize_reference`` is the same in numpy."""
    hh, ww = target_q.shape
    synth_q = np.zeros((hh, ww, 3), np.uint8)  # never read before it is written
    src = np.full((hh, ww), -1, np.int64)
    error = np.zeros((hh, ww))
    oc, mc, ot, mt, seen = _buffers(square.shape[0], lower.shape[0])
    for ps in range(passes):
        for r in range(hh):
            for c in range(ww):
                _pixel(
                    r, c, ps, colour, alpha, own, target_q, synth_q, src, error, square,
                    lower, wa, weight, penalty, key, n_random, exhaustive, oc, mc, ot, mt, seen,
                )  # fmt: skip
    return src, error


@njit(cache=True, nogil=True, parallel=True)
def _scan_tiles(
    colour, alpha, own, target_q, square, lower, wa, weight, penalty, key, passes, n_random,
    exhaustive, band, chunk,
):  # fmt: skip
    """The same scan on several threads, pixel for pixel the raster scan's result.

    Pixel p = (r, c) reads only its upper L (in the second pass also its lower L, which
    must still hold first-pass values). Shear the columns, u = c + s r with
    s = k // 2 + 1: every pixel of p's upper L has a smaller u and a row <= r, every
    pixel of its lower L a larger u and a row >= r. Cut (r, u) into tiles, ``band``
    rows by ``chunk`` sheared columns, (i, j) = (r // band, u // chunk): p's upper L
    lies in tiles (i' <= i, j' <= j), its lower L in tiles (i' >= i, j' >= j). Tiles on
    one anti-diagonal i + j therefore share no neighbourhood: they run side by side,
    each in raster order, one anti-diagonal after the other, and every pixel sees
    exactly what it sees in the raster scan.
    """
    hh, ww = target_q.shape
    skew = -square[0, 0] + 1  # k // 2 + 1
    synth_q = np.zeros((hh, ww, 3), np.uint8)
    src = np.full((hh, ww), -1, np.int64)
    error = np.zeros((hh, ww))
    n_bands = (hh + band - 1) // band
    n_chunks = (ww - 1 + skew * (hh - 1)) // chunk + 1
    for ps in range(passes):
        for t in range(n_bands + n_chunks - 1):
            lo = max(0, t - n_chunks + 1)
            hi = min(n_bands, t + 1)
            for i in prange(lo, hi):
                j = t - i
                oc, mc, ot, mt, seen = _buffers(square.shape[0], lower.shape[0])
                for r in range(i * band, min((i + 1) * band, hh)):
                    c0 = max(j * chunk - skew * r, 0)
                    c1 = min((j + 1) * chunk - skew * r, ww)
                    for c in range(c0, c1):
                        _pixel(
                            r, c, ps, colour, alpha, own, target_q, synth_q, src, error,
                            square, lower, wa, weight, penalty, key, n_random, exhaustive, oc,
                            mc, ot, mt, seen,
                        )  # fmt: skip
    return src, error


@njit(cache=True, nogil=True)
def _mean_error(colour, alpha, synth_q, src, target_q, square, lower, weight):
    """Mean first-pass distance of every output pixel to its recorded source."""
    hh, ww = target_q.shape
    oc, mc, ot, mt, _ = _buffers(square.shape[0], lower.shape[0])
    n_upper = square.shape[0] // 2
    total = 0.0
    for r in range(hh):
        for c in range(ww):
            w_colour, w_target = _gather(
                r, c, n_upper, target_q, synth_q, square, lower, oc, mc, ot, mt, weight
            )
            total += _distance(
                src[r, c], colour, alpha, oc, mc, ot, mt, n_upper, w_colour,
                w_target, 1.0, np.inf,
            )  # fmt: skip
    return total / (hh * ww)
