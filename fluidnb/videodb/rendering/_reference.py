r"""The video-database method's steps as one would first write them, in numpy (slow).

Each fast path of :mod:`fluidnb.videodb` (numba kernels, sparse posting lists, matrix
products in bulk, OpenCV pyramids over phase layers) has its plain version here, in
the paper's notation, one pixel, one pair or one fragment at a time. They exist so
that the tests can check every fast path against the method written out literally,
the benchmarks can show what the optimisation buys, and a reader can find the maths
in its most readable form. Use the functions of :mod:`fluidnb.videodb` for real work.

=====================================  =============================================
plain version                          fast path (tested against it)
=====================================  =============================================
:func:`reference_sample_version`       :func:`~fluidnb.videodb.sample_version`
:func:`reference_transform_vectors`    :func:`~fluidnb.videodb.transform_vectors`
:func:`reference_fragment_frames`      :meth:`~fluidnb.videodb.VideoDatabase.fragment_frames`
:func:`reference_pixel_features`       ``pixel_features`` (the build's features, bits)
:func:`reference_textureness`          :func:`~fluidnb.videodb.textureness` (bits)
:func:`reference_window_sums`          ``_window_sums`` (bits)
:func:`reference_dense_sift`           :func:`~fluidnb.videodb.dense_sift`
:func:`reference_quantise`             :func:`~fluidnb.videodb.quantise`
:func:`reference_top_k`                :meth:`~fluidnb.videodb.HistogramIndex.top_k`
:func:`reference_pair_tables`          :func:`~fluidnb.videodb.pair_tables`
:func:`reference_blend_differences`    :func:`~fluidnb.videodb.blend_differences`
:func:`reference_layer_blend`          :func:`~fluidnb.videodb.blend_differences` (bits)
:func:`reference_match_histograms_cells` :func:`~fluidnb.videodb.match_histograms_cells`
:func:`reference_motion_blur`          :func:`~fluidnb.videodb.motion_blur`
:func:`reference_eulerian_loop`        :func:`~fluidnb.videodb.eulerian_loop`
:func:`reference_fill`                 :func:`~fluidnb.videodb.exemplar_fill`
:func:`reference_alpha_expansion`      :func:`~fluidnb.videodb.alpha_expansion`
:func:`reference_icm`                  :func:`~fluidnb.videodb.icm`
:func:`reference_water_flow`           the starter water clips' flows (``_water_flow``)
=====================================  =============================================

How closely each pair agrees, and why not bit for bit where it does not, is said in
each function's docstring.
"""

from __future__ import annotations

import math
import time

import maxflow
import numpy as np
from scipy import ndimage as ndi

from ..._progress import Progress
from ..._validation import check_int, check_vector_field
from ...fields import backward_warp, collapse, expand, gaussian_pyramid, laplacian_pyramid
from ...fields._pyramid import _collapse32, _gaussian32, _laplacian32
from .._common._geometry import (
    FRAGMENT,
    GRID,
    SPECTRA_BLOCK,
    SPECTRA_SIDE,
    TEXTURE_BLOCK,
    TEXTURE_LEVELS,
    TEXTURE_SIDE,
    VERSIONS,
)
from ..assignment._mrf import _finished, _icm, _problem, _start
from ..assignment._retrieval import _SLACK, MIN_MOTION, TopK, _check_filter
from ..assignment._smoothness import PairTables, _check_tables_input
from ..database._augment import _TRUNCATE, _window, prefilter_sigma, version_shape
from ..database._features import _flow_blocks, _power, block_mean
from ..database._sift import _EPS, BINS, ORIENTATIONS, _check_images
from ..database._words import _check_pair, _squared_distances, pyramid_histograms
from ..starter._clips import _curl, _envelope, _steady_flow, _stream_function, _wavenumbers
from ._appearance import (
    _QUANTILES,
    _SLOPE_RANGE,
    HISTOGRAM_BINS,
    _Cells,
    _check_image,
    _shutter_samples,
    _variable_blur,
)
from ._blend import (
    _TINY,
    FEATHER,
    _check_diffs,
    _check_feather,
    _check_levels,
    _check_positions,
    _layers,
    _raw_weights,
)
from ._blend import MARGIN as _BLEND_MARGIN
from ._blend import _window as _blend_window
from ._flow_render import loop_phases

__all__ = [
    "reference_alpha_expansion",
    "reference_blend_differences",
    "reference_dense_sift",
    "reference_eulerian_loop",
    "reference_fill",
    "reference_fragment_frames",
    "reference_icm",
    "reference_match_histograms_cells",
    "reference_motion_blur",
    "reference_pair_tables",
    "reference_pixel_features",
    "reference_quantise",
    "reference_sample_version",
    "reference_textureness",
    "reference_top_k",
    "reference_transform_vectors",
    "reference_water_flow",
    "reference_window_sums",
]


# ----------------------------------------------------------------- augmentation (sec. 4)


def reference_sample_version(frames, version, *, origin=(0, 0), size=None):
    r""":func:`sample_version` written out literally, frame by frame and pixel by pixel.

    Each version pixel's coordinates come from the module's formula with explicit
    matrices, each frame is prefiltered whole with :func:`scipy.ndimage.gaussian_filter`
    and sampled with :func:`scipy.ndimage.map_coordinates` (order 1, edge clamped).
    Agrees with the fast path to float32 round-off, not bit for bit.
    """
    arr = np.asarray(frames, dtype=np.float64)
    h, w = arr.shape[1:3]
    hv, wv = version_shape((h, w), version)
    (r0, c0), (hh, ww) = _window(h, w, version, origin, size)
    flip, s, _ = VERSIONS[version]
    theta = math.radians(-VERSIONS[version][2])
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    mirror = np.diag([1.0, -1.0 if flip else 1.0])
    centre_v = np.array([(hv - 1) / 2, (wv - 1) / 2])
    centre_s = np.array([(h - 1) / 2, (w - 1) / 2])
    coords = np.empty((2, hh, ww))
    for i in range(hh):
        for j in range(ww):
            p = np.array([r0 + i, c0 + j]) - centre_v
            coords[:, i, j] = mirror @ rot @ p / s + centre_s
    sigma = prefilter_sigma(version)
    out = np.empty((arr.shape[0], hh, ww, *arr.shape[3:]))
    for t in range(arr.shape[0]):
        for ch in np.ndindex(arr.shape[3:]):
            plane = arr[(t, slice(None), slice(None), *ch)]
            if sigma > 0:
                plane = ndi.gaussian_filter(plane, sigma, mode="nearest", truncate=_TRUNCATE)
            out[(t, slice(None), slice(None), *ch)] = ndi.map_coordinates(
                plane, coords, order=1, mode="nearest"
            )
    return out.astype(np.float32)


def reference_transform_vectors(vectors, version):
    r""":math:`u_v = s R(\theta) F u_s`, one explicit matrix product per vector."""
    flip, s, angle = VERSIONS[version]
    theta = math.radians(angle)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    mirror = np.diag([1.0, -1.0 if flip else 1.0])
    u = np.asarray(vectors, dtype=np.float64)
    out = np.empty_like(u)
    for idx in np.ndindex(u.shape[:-1]):
        out[idx] = s * rot @ mirror @ u[idx]
    return out


def reference_fragment_frames(db, ids, *, margin=0, grey=False):
    r""":meth:`~fluidnb.videodb.VideoDatabase.fragment_frames` written out, one fragment at a time.

    Each fragment's :math:`N` frames are read from its source clip (its own window,
    every time), divided by 255 and, for ``grey``, made grey with the Rec. 709 weights
    :math:`0.2125 R + 0.7154 G + 0.0721 B`, all in float64; then its version's pixels
    with ``margin`` pixels of context are sampled by :func:`reference_sample_version`
    and clipped to [0, 1]. No cache, no shared reads. Agrees with the fast path to
    float32 round-off (its luminance and sampling are float32).

    Returns
    -------
    ndarray, shape (n, N, 48 + 2 margin, 48 + 2 margin[, 3]), float32
    """
    n, side = db.params.N, FRAGMENT + 2 * margin
    out = []
    for fid in np.asarray(ids, np.int64).ravel().tolist():
        clip, version, start, row, col = (int(v) for v in db.source[fid])
        frames = db.clip_frames(clip, start, start + n).astype(np.float64) / 255.0
        if grey:
            frames = frames @ np.array([0.2125, 0.7154, 0.0721])
        rebuilt = reference_sample_version(
            frames, version, origin=(row - margin, col - margin), size=(side, side)
        )
        out.append(np.clip(rebuilt, 0.0, 1.0))
    shape = (0, n, side, side) + (() if grey else (3,))
    return np.stack(out).astype(np.float32) if out else np.zeros(shape, np.float32)


# --------------------------------------------------------- fragment features (secs. 4-5)


def reference_pixel_features(stack, colour_mean, flow, positions, *, threshold, n_bins):
    """The build's fragment features in numpy and OpenCV, as first written.

    Arguments and result as ``pixel_features`` (:func:`window_features` of
    pixel-major arrays), which must equal it bit for bit: a database built again is
    the same database. Here the moving mask and the flow's block means are numpy's
    mean and OpenCV's area resize, the window sums numpy's integral image
    (:func:`reference_window_sums`), the textureness the OpenCV pyramid's bands
    (:func:`reference_textureness`), and each fragment's cells are gathered with
    fancy indices, then moved to the stored layout.
    """
    h, w, m = flow.shape
    n = m // 2
    # Frame-major (n, H, W, 2) and contiguous: numpy's mean over frames then adds the
    # frames one after the other, as the build's kernel does.
    frame_major = np.ascontiguousarray(np.moveaxis(flow.reshape(h, w, n, 2), 2, 0))
    speed = np.sqrt(frame_major[..., 0] ** 2 + frame_major[..., 1] ** 2)
    moving = speed.mean(axis=0) > np.float32(threshold)
    count = reference_window_sums(block_mean(moving.astype(np.float32), SPECTRA_BLOCK), positions)
    count *= np.float32(SPECTRA_BLOCK**2)
    keep = count > 0.5
    if not keep.any():
        return keep, None
    positions, count = positions[keep], count[keep]
    blocks = _flow_blocks(frame_major, moving)  # (n, 2, Hb, Wb)
    sums = reference_window_sums(blocks, positions) * np.float32(SPECTRA_BLOCK**2)  # (n, 2, k)
    motion = (np.moveaxis(sums, -1, 0) / count[:, None, None]).astype(np.float32)
    spectra = _power(blocks, n_bins).astype(np.float16)
    texture = reference_textureness(stack).astype(np.float16)
    mean = (np.clip(colour_mean, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)

    def cells(block, side):  # index arrays (k, side, side) of each fragment's cells
        offs = np.arange(side)
        rows, cols = positions[:, 0] // block, positions[:, 1] // block
        return rows[:, None, None] + offs[None, :, None], cols[:, None, None] + offs[None, None, :]

    spec = spectra[(slice(None), slice(None), *cells(SPECTRA_BLOCK, SPECTRA_SIDE))]
    tex = texture[(slice(None), *cells(TEXTURE_BLOCK, TEXTURE_SIDE))]
    return keep, {
        "mean": mean[cells(1, FRAGMENT)],
        "mean_motion": motion.mean(axis=1).astype(np.float32),
        "motion": motion,
        "spectra": np.ascontiguousarray(np.moveaxis(spec, 2, 0)),
        "texture": np.ascontiguousarray(np.moveaxis(tex, 1, 0)),
        "moving": (count / FRAGMENT**2).astype(np.float32),
    }


def reference_window_sums(blocks, positions):
    """Sums of ``blocks`` (..., Hb, Wb) over each fragment's 12 x 12 blocks: (..., k).

    An integral image in float64 (numpy's cumulative sums, padded with a zero row
    and column), four lookups a fragment, rounded to float32; ``_window_sums``, on
    (P, Hb, Wb, Q) planes, equals it bit for bit.
    """
    pad = [(0, 0)] * (blocks.ndim - 2) + [(1, 0), (1, 0)]
    ii = np.pad(blocks.astype(np.float64).cumsum(-2).cumsum(-1), pad)
    r0, c0 = positions[:, 0] // SPECTRA_BLOCK, positions[:, 1] // SPECTRA_BLOCK
    r1, c1 = r0 + SPECTRA_SIDE, c0 + SPECTRA_SIDE
    out = ii[..., r1, c1] - ii[..., r0, c1] - ii[..., r1, c0] + ii[..., r0, c0]
    return out.astype(np.float32)


def reference_textureness(stack):
    """:func:`textureness` of the frames as the channels of one (H, W, N) image, in numpy.

    The Laplacian pyramid's bands on OpenCV's steps (``_laplacian32(..., fused=False)``),
    each band's magnitude summed over the frames by numpy, brought back to the full
    grid and averaged over 2 x 2 blocks. The library's version fuses the band, its
    magnitude and the sum in one kernel and must equal this bit for bit.
    """
    h, w = stack.shape[:2]
    bands = _laplacian32(np.ascontiguousarray(stack, np.float32), TEXTURE_LEVELS, fused=False)
    levels = []
    for band in bands:
        mag = np.abs(band).sum(axis=-1, dtype=np.float32)
        full = mag.shape == (h, w)
        levels.append(mag if full else expand(mag, (h, w), sigma=0, precision="float32"))
    return block_mean(np.stack(levels), TEXTURE_BLOCK).astype(np.float32)


# ------------------------------------------------------------ appearance (secs. 4-5, Eq. 1)


def reference_dense_sift(image):
    """The recipe of the module notes, literally: one descriptor, one pixel at a time.

    Slow on purpose (pure Python loops, ~0.1 s a fragment); the tests compare
    :func:`dense_sift` with it. Results agree to within one count of the uint8
    values (sums in a different order), almost always exactly.

    Parameters
    ----------
    image : array_like, shape (48, 48)
        A grey fragment, floats in [0, 1].

    Returns
    -------
    ndarray, shape (9, 9, 128), uint8
    """
    img = _check_images(image)
    if img.ndim != 2:
        raise ValueError(f"image must have shape (48, 48), got {img.shape}")
    img = img.astype(np.float32).astype(np.float64)
    gy, gx = np.gradient(img)  # central differences, one-sided at the border
    out = np.zeros((GRID, GRID, 128), np.uint8)
    for ky in range(GRID):
        for kx in range(GRID):
            hist = np.zeros((BINS, BINS, ORIENTATIONS))
            cy, cx = 4 * ky + 7.5, 4 * kx + 7.5  # the descriptor's centre
            for y in range(4 * ky, 4 * ky + 16):
                for x in range(4 * kx, 4 * kx + 16):
                    mag = math.sqrt(gx[y, x] ** 2 + gy[y, x] ** 2)
                    if mag == 0:
                        continue
                    theta = math.atan2(gy[y, x], gx[y, x])
                    if theta < 0:
                        theta += 2 * math.pi
                    # Orientation: linear interpolation between the two nearest bins.
                    u = theta / (2 * math.pi) * 8
                    t = math.floor(u)
                    orient = {t % 8: 1 - (u - t), (t + 1) % 8: u - t}
                    # Space: the pixel's position in bin units, bin b's centre at b.
                    ry = (y - 4 * ky + 0.5) / 4 - 0.5
                    rx = (x - 4 * kx + 0.5) / 4 - 0.5
                    window = math.exp(-((y - cy) ** 2 + (x - cx) ** 2) / (2 * 8.0**2))
                    for by in (math.floor(ry), math.floor(ry) + 1):
                        for bx in (math.floor(rx), math.floor(rx) + 1):
                            if not (0 <= by < 4 and 0 <= bx < 4):
                                continue
                            wy = 1 - abs(ry - by)
                            wx = 1 - abs(rx - bx)
                            for o, wo in orient.items():
                                hist[by, bx, o] += mag * window * wy * wx * wo
            v = hist.ravel()
            v = v / (np.linalg.norm(v) + _EPS)
            v = np.minimum(v, 0.2)
            v = v / (np.linalg.norm(v) + _EPS)
            out[ky, kx] = np.minimum(255, np.floor(512 * v)).astype(np.uint8)
    return out


def reference_quantise(descriptors, centres):
    """Nearest centre by brute force: every distance computed directly (for the tests).

    Parameters
    ----------
    descriptors : array_like, shape (..., D)
    centres : array_like, shape (k, D)

    Returns
    -------
    ndarray of int64, shape (...)
        ``argmin`` over the centres of ``sum_i (x_i - c_i)^2`` in float64 (ties to
        the lowest index, as ``numpy.argmin``).
    """
    x, c = _check_pair(descriptors, centres)
    rows = np.asarray(x.reshape(-1, x.shape[-1]), dtype=np.float64)
    words = [
        _squared_distances(rows[i : i + 256], c).argmin(axis=1) for i in range(0, len(rows), 256)
    ]
    out = np.concatenate(words) if words else np.empty(0, np.int64)
    return out.reshape(x.shape[:-1])


def reference_top_k(
    words,
    n_words,
    query_words,
    k,
    *,
    mean_motion=None,
    direction=None,
    speed=None,
    max_angle=45.0,
    max_speed_ratio=2.0,
):
    """:meth:`HistogramIndex.top_k` written densely: every histogram, every score, a sort.

    Memory (Q, F, 21 k): for the tests' small databases only.

    Parameters
    ----------
    words : array_like of int, shape (F, 9, 9)
    n_words : int
        The codebook's size :math:`k`.
    query_words : array_like of int, shape (Q, 9, 9)
    k : int
        Candidates per query.
    mean_motion, direction, speed, max_angle, max_speed_ratio
        As :class:`HistogramIndex` and :meth:`HistogramIndex.top_k`.

    Returns
    -------
    TopK
    """
    he = pyramid_histograms(words, n_words).astype(np.int64)  # (F, 21 k)
    k = check_int("k", k, 1, len(he))
    ht = pyramid_histograms(query_words, n_words).astype(np.int64)  # (Q, 21 k)
    n_frag, n_q = len(he), len(ht)
    has_motion = mean_motion is not None
    unit, s, cos_max, ratio = _check_filter(
        n_q, direction, speed, max_angle, max_speed_ratio, has_motion
    )
    if has_motion:
        m = np.asarray(mean_motion, dtype=np.float64)
        mag = np.sqrt(m[:, 0] * m[:, 0] + m[:, 1] * m[:, 1])
    ids = np.empty((n_q, k), np.int64)
    scores = np.empty((n_q, k), np.int32)
    n_eligible = np.empty(n_q, np.int64)
    for q in range(n_q):
        score = np.minimum(ht[q][None, :], he).sum(axis=1)  # Eq. (1)
        ok = np.ones(n_frag, bool)
        if not np.isnan(unit[q, 0]):
            dot = m[:, 0] * unit[q, 0] + m[:, 1] * unit[q, 1]  # |m| cos(angle)
            ok &= (mag >= MIN_MOTION) & (dot >= (cos_max - _SLACK) * mag)
        if not np.isnan(s[q]):
            hi, lo = np.maximum(mag, s[q]), np.minimum(mag, s[q])
            ok &= hi <= ratio * lo * (1.0 + _SLACK)
        filtered = not (np.isnan(unit[q, 0]) and np.isnan(s[q]))
        n_eligible[q] = ok.sum() if filtered else n_frag
        pool = np.flatnonzero(ok) if ok.any() else np.arange(n_frag)
        order = pool[np.lexsort((pool, -score[pool]))][:k]  # score down, then id up
        order = np.concatenate([order, np.repeat(order[:1], k - len(order))])
        ids[q], scores[q] = order, score[order]
    return TopK(ids, scores, n_eligible)


# ------------------------------------------------------------ smoothness tables (Eq. 2, 3, 6)


def reference_pair_tables(candidates, edges, horizontal, spectra, texture):
    r"""The smoothness tables written out pair by pair (Eq. 2, 3 and 6), slowly.

    The literal definition that :func:`pair_tables` is tested against: for every edge,
    every label of ``p`` and every label of ``q``, the squared differences over the
    overlap :math:`\Omega` summed in float64, frequency bin by frequency bin.
    Arguments and result as :func:`pair_tables`.
    """
    cand, edges, hor, spectra, texture = _check_tables_input(
        candidates, edges, horizontal, spectra, texture
    )
    n_edges, k = len(edges), cand.shape[1]
    n_bins = spectra.shape[1]
    dc = np.zeros((n_edges, k, k))
    rest = np.zeros((n_edges, k, k))
    tex = np.zeros((n_edges, k, k))
    hs, ht = SPECTRA_SIDE // 2, TEXTURE_SIDE // 2
    for e in range(n_edges):
        p, q = edges[e]
        for i in range(k):
            m_i = spectra[cand[p, i]].astype(np.float64)  # M^ of label i: (NB, 2, 12, 12)
            t_i = texture[cand[p, i]].astype(np.float64)  # T of label i: (L, 24, 24)
            for j in range(k):
                m_j = spectra[cand[q, j]].astype(np.float64)
                t_j = texture[cand[q, j]].astype(np.float64)
                if hor[e]:  # Omega: right half of p, left half of q
                    mp, mq = m_i[:, :, :, hs:], m_j[:, :, :, :hs]
                    tp, tq = t_i[:, :, ht:], t_j[:, :, :ht]
                else:  # Omega: bottom half of p, top half of q
                    mp, mq = m_i[:, :, hs:, :], m_j[:, :, :hs, :]
                    tp, tq = t_i[:, ht:, :], t_j[:, :ht, :]
                # Eq. (3), with the block areas 4 x 4 (spectra) and 2 x 2 (texture).
                dc[e, i, j] = SPECTRA_BLOCK**2 * np.sum((mp[0] - mq[0]) ** 2)
                for f in range(1, n_bins):
                    rest[e, i, j] += SPECTRA_BLOCK**2 * np.sum((mp[f] - mq[f]) ** 2)
                tex[e, i, j] = TEXTURE_BLOCK**2 * np.sum((tp - tq) ** 2)
    return PairTables(dc=dc, rest=rest, tex=tex, edges=edges.copy(), horizontal=hor.copy())


# ------------------------------------------------------------------- rendering (sec. 6)


def reference_blend_differences(
    diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER
):
    r"""Multi-band blending of the fragments' differences written per fragment (slow).

    Burt & Adelson's multiresolution spline as one would first write it for many
    overlapping pieces. For every fragment :math:`p`:

    1. its difference frames on the whole canvas, :math:`D^p`: its own data on its
       :math:`(48 + 2m)`-pixel window, and beyond the window the *fill*, the
       tent-weighted average of all fragments' windows. A fragment's weight spreads
       past its data at the coarse levels, so its frames need some extension there;
       the fill is the one that gives identical inputs back exactly (it equals the
       data wherever the fragments agree);
    2. its weight :math:`W^p`: the flat-topped tent over its core of
       :func:`~fluidnb.videodb.fragment_weights` before the normalisation, 0 off the
       core;
    3. the Laplacian pyramid :math:`L_l(D^p)` and the Gaussian pyramid
       :math:`G_l(W^p)` (float64, :mod:`fluidnb.fields`; frames as channels);

    then per level :math:`L_l = \sum_p G_l(W^p) L_l(D^p) / \sum_p G_l(W^p)` (0 where
    no weight reaches), collapsed, and 0 off the cores.

    How :func:`~fluidnb.videodb.blend_differences` differs: it builds the same sums
    from 9 *phase layers* (fragments whose grid positions are equal modulo 3 share one
    canvas and one pyramid), so in a layer the neighbourhood of a fragment's 72 x 72
    tile holds its phase-mates' frames (72 px away) rather than the fill, and it keeps
    at most 12 px of a fragment's margin (the tile). Everything else is the same. So
    where no two fragments share a phase (grids of up to 3 x 3 fragments) and
    ``margin <= 12`` the two agree to float32 round-off (the fast path's arithmetic),
    and with up to 3 levels also on larger grids: a fragment's weights at levels 0-2
    hardly reach past its tile. At the fourth level (the default) they do, and the
    blends differ there: by at most 4.6e-3 of luminance at one pixel of the quick
    starter render of the stream (49 fragments of 32 frames; 1e-4 rms), by at most
    5e-4 on independent unit-variance textures. (Extending each fragment by its
    phase layer instead of the fill gives back the fast path to float32 round-off.)

    Arguments and result as :func:`~fluidnb.videodb.blend_differences`.
    """
    pos, shape = _check_positions(positions, canvas_shape)
    m = int(margin)
    d = _check_diffs(diffs, len(pos)).astype(np.float64)
    if d.shape[2] != FRAGMENT + 2 * m:
        raise ValueError(f"diffs must be {FRAGMENT + 2 * m} pixels wide, got shape {d.shape}")
    levels = _check_levels(levels)
    weight = _raw_weights(_check_feather(feather))  # W^p on the 48 x 48 core
    n = d.shape[1]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    size = FRAGMENT + 2 * m

    def window(r, c):
        """Canvas slices of a fragment's window, and the same pixels in its data."""
        r0, r1 = max(r - m, 0), min(r + FRAGMENT + m, shape[0])
        c0, c1 = max(c - m, 0), min(c + FRAGMENT + m, shape[1])
        data = (slice(r0 - (r - m), r1 - (r - m)), slice(c0 - (c - m), c1 - (c - m)))
        return (slice(r0, r1), slice(c0, c1)), data

    # The fill: every fragment's window weighted by a tent (its distance to the
    # window's nearer edge, on each axis), averaged.
    u = np.arange(size) + 0.5
    tent = np.outer(np.minimum(u, size - u), np.minimum(u, size - u))
    fill = np.zeros(shape + (n,))
    den = np.zeros(shape)
    for k, (r, c) in enumerate(pos):
        on_canvas, data = window(r, c)
        fill[on_canvas] += np.moveaxis(d[k][(slice(None), *data)], 0, -1) * tent[data][..., None]
        den[on_canvas] += tent[data]
    fill = np.divide(fill, den[..., None], out=np.zeros_like(fill), where=den[..., None] > 0)

    num = wsum = None
    for k, (r, c) in enumerate(pos):
        frames = fill.copy()  # D^p on the canvas
        on_canvas, data = window(r, c)
        frames[on_canvas] = np.moveaxis(d[k][(slice(None), *data)], 0, -1)
        w = np.zeros(shape)  # W^p on the canvas
        w[r : r + FRAGMENT, c : c + FRAGMENT] = weight
        bands = laplacian_pyramid(frames, levels)
        gw = gaussian_pyramid(w, levels)
        terms = [g[..., None] * b for g, b in zip(gw, bands)]
        num = terms if num is None else [a + t for a, t in zip(num, terms)]
        wsum = gw if wsum is None else [a + g for a, g in zip(wsum, gw)]
    blended = [
        np.where(s[..., None] > _TINY, a / np.where(s > _TINY, s, 1.0)[..., None], 0.0)
        for a, s in zip(num, wsum)
    ]
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = collapse(blended) * covered[..., None]
    return np.ascontiguousarray(np.moveaxis(out, -1, 0)).astype(np.float32)


def reference_layer_blend(diffs, positions, canvas_shape, *, margin, levels=None, feather=FEATHER):
    r"""The phase-layer blend of :func:`~fluidnb.videodb.blend_differences` in numpy (float32).

    The fast path's own design (9 phase layers, the fill, OpenCV's float32 pyramids)
    with every step of its own arithmetic written as numpy array operations, one
    layer after the other: the fill summed fragment by fragment, each layer's bands
    weighted by :math:`G_l(W)` and summed in layer order, divided by the summed
    weights (0 where none reaches), collapsed, 0 off the cores. The fast path (its
    compiled fill, weighting and normalisation, its weights made once, its layers on
    threads) gives the same frames bit for bit (tested).

    Arguments and result as :func:`~fluidnb.videodb.blend_differences`.
    """
    pos, shape = _check_positions(positions, canvas_shape)
    m = int(margin)
    d = np.moveaxis(_check_diffs(diffs, len(pos)), 1, 3).astype(np.float32)  # (P, s, s, N)
    levels = _check_levels(levels)
    raw = _raw_weights(_check_feather(feather)).astype(np.float32)
    n = d.shape[3]
    if len(pos) == 0:
        return np.zeros((n,) + shape, dtype=np.float32)
    size = FRAGMENT + 2 * m
    u = np.arange(size, dtype=np.float64) + 0.5
    tent = np.outer(np.minimum(u, size - u), np.minimum(u, size - u)).astype(np.float32)
    fill = np.zeros(shape + (n,), np.float32)
    den = np.zeros(shape, np.float32)
    for k, (r, c) in enumerate(pos):
        (rs, cs), (wr, wc) = _blend_window(r, c, m, size, shape)
        fill[rs, cs] += d[k, wr, wc] * tent[wr, wc][..., None]
        den[rs, cs] += tent[wr, wc]
    np.divide(fill, den[..., None], out=fill, where=den[..., None] > 0)
    tile = FRAGMENT + 2 * min(m, _BLEND_MARGIN)
    num = wsum = None
    for members in _layers(pos):
        layer = fill.copy()
        weight = np.zeros(shape + (1,), np.float32)
        for k in members:
            r, c = pos[k]
            (rs, cs), (wr, wc) = _blend_window(r, c, m, tile, shape)
            layer[rs, cs] = d[k, wr, wc]
            weight[r : r + FRAGMENT, c : c + FRAGMENT, 0] = raw
        gw = _gaussian32(weight, levels)
        terms = [b * g for b, g in zip(_laplacian32(layer, levels), gw)]
        num = terms if num is None else [a + t for a, t in zip(num, terms)]
        wsum = gw if wsum is None else [a + g for a, g in zip(wsum, gw)]
    for a, s in zip(num, wsum):
        np.divide(a, s, out=a, where=s > _TINY)
        a[np.broadcast_to(s <= _TINY, a.shape)] = 0.0
    covered = np.zeros(shape, bool)
    for r, c in pos:
        covered[r : r + FRAGMENT, c : c + FRAGMENT] = True
    out = _collapse32(num) * covered[..., None]
    return np.ascontiguousarray(out.transpose(2, 0, 1))


def reference_motion_blur(image, velocity, *, shutter, denoise):
    r""":func:`~fluidnb.videodb.motion_blur` as whole-image warps (Okabe et al., sec. 6).

    The approximate mean image: the target averaged along its motion, sample by
    sample, each sample a whole image warped by
    :func:`fluidnb.fields.backward_warp` to ``x + t v(x)``, accumulated with the
    trapezoid weights; then the speed-dependent Gaussian blur. The fast path gives the
    same result bit for bit. Arguments and result as
    :func:`~fluidnb.videodb.motion_blur`.
    """
    img = _check_image("image", image)
    v = check_vector_field("velocity", velocity, shape=img.shape[:2]).astype(np.float32)
    speed = np.hypot(v[..., 0], v[..., 1])
    out = img
    times, weights = _shutter_samples(shutter, float(speed.max()))
    if len(times):
        acc = np.zeros_like(img, dtype=np.float64)
        for t, w in zip(times, weights):
            acc += w * backward_warp(img, t * v)  # img(x + t v(x))
        out = (acc / (len(times) - 1)).astype(np.float32)
    if denoise > 0:
        out = _variable_blur(out, denoise * speed)
    return out


def reference_match_histograms_cells(frames, reference, weight, *, cell):
    """:func:`match_histograms_cells` in plain numpy, for tests and teaching.

    ``np.bincount`` histograms, quantiles by (vectorised) binary search, and, for every
    pixel, the four neighbouring cells' maps gathered and blended. The compiled
    kernels of :func:`match_histograms_cells` are checked against it.
    """
    cells = _Cells(frames, reference, weight, cell)
    f = cells.frames
    n_ch, n_cells, bins = f.shape[3], cells.n_cells, HISTOGRAM_BINS

    def bins_of(lo, step):  # one image's bins -> per (channel, cell) row
        return np.repeat(lo, n_cells)[:, None], np.repeat(step, n_cells)[:, None]

    def bin_of(img, lo, step):
        z = (img.astype(np.float64) - lo) * (1.0 / step)
        return z, np.minimum(np.where(z > 0, z, 0).astype(np.intp), bins - 1)

    def histograms(img, lo, step):  # (H, W, C) -> (C * cells, bins)
        idx = (np.arange(n_ch) * n_cells + cells.cid[..., None]) * bins + bin_of(img, lo, step)[1]
        wt = np.broadcast_to(cells.weight[..., None], idx.shape)
        counts = np.bincount(idx.ravel(), weights=wt.ravel(), minlength=n_ch * n_cells * bins)
        return counts.reshape(n_ch * n_cells, bins)

    # Every image over its own range: the reference's bins, then each frame's.
    lo_r, step_r = cells.lo_ref, cells.step_ref
    q_ref = _quantiles_np(histograms(cells.reference, lo_r, step_r), *bins_of(lo_r, step_r))
    (y0, y1, fy), (x0, x1, fx) = cells.rows, cells.cols
    roles = []
    for ys, wy in ((y0, 1 - fy), (y1, fy)):
        for xs, wx in ((x0, 1 - fx), (x1, fx)):
            c = ys[:, None] * cells.nx + xs[None, :]
            roles.append((c, wy[:, None] * wx[None, :] * cells.mass[c]))
    total = sum(wt for _, wt in roles)[..., None]
    inv_total = np.divide(1.0, total, out=np.zeros(total.shape), where=total > 0)
    ch = np.arange(n_ch)
    out = np.empty_like(f)
    for t in range(f.shape[0]):
        lo, step = cells.lo[t], cells.step[t]
        row_lo, row_step = bins_of(lo, step)
        q_f = _quantiles_np(histograms(f[t], lo, step), row_lo, row_step)
        edges = row_lo + row_step * np.arange(bins + 1)
        lut = _maps_np(edges, q_f, q_ref).reshape(n_ch, n_cells, bins + 1)
        z, j = bin_of(f[t], lo, step)
        frac = z - j
        acc = np.zeros(z.shape)
        for c, w_c in roles:
            v0 = lut[ch, c[..., None], j]
            v1 = lut[ch, c[..., None], j + 1]
            acc += w_c[..., None] * (v0 + frac * (v1 - v0))
        out[t] = np.where(total > 0, acc * inv_total, f[t])
    return cells.result(out)


def _searchsorted_rows(a, v, side):
    """Row-wise ``np.searchsorted``: ``a`` (R, K) non-decreasing rows, ``v`` (R, M).

    A vectorised binary search (exact, ``log2 K`` gathers) instead of one call per row.
    """
    k = a.shape[1]
    lo = np.zeros(v.shape, dtype=np.intp)
    hi = np.full(v.shape, k, dtype=np.intp)
    for _ in range(max(1, math.ceil(math.log2(k + 1)))):
        mid = (lo + hi) >> 1
        am = np.take_along_axis(a, np.minimum(mid, k - 1), axis=1)
        go = (am < v) if side == "left" else (am <= v)
        go &= lo < hi
        lo = np.where(go, mid + 1, lo)
        hi = np.where(go | (lo >= hi), hi, mid)
    return lo


def _quantiles_np(counts, lo, step):
    """Quantiles at p = 0, 1/K, ..., 1 of piecewise-uniform histograms (R, B) -> (R, K+1).

    The distribution is uniform within each bin (the CDF piecewise linear through the
    bin edges), so the quantile function is continuous and strictly increasing, from
    the lower edge of the first non-empty bin to the upper edge of the last, and a
    histogram matched to itself maps every value to itself.
    """
    n_rows, bins = counts.shape
    mass = counts.sum(axis=1, keepdims=True)
    cdf = np.zeros((n_rows, bins + 1))
    np.cumsum(counts, axis=1, out=cdf[:, 1:])
    cdf /= np.where(mass > 0, mass, 1.0)
    p = np.broadcast_to(np.arange(_QUANTILES + 1) / _QUANTILES, (n_rows, _QUANTILES + 1))
    i = np.clip(_searchsorted_rows(cdf, p, "left"), 1, bins)
    c0 = np.take_along_axis(cdf, i - 1, axis=1)
    c1 = np.take_along_axis(cdf, i, axis=1)
    frac = np.divide(p - c0, c1 - c0, out=np.ones(c0.shape), where=c1 > c0)
    q = lo + step * (i - 1 + np.clip(frac, 0.0, 1.0))
    filled = counts > 0
    first = np.argmax(filled, axis=1)
    last = bins - np.argmax(filled[:, ::-1], axis=1)
    q[:, :1] = lo + step * first[:, None]
    q[:, -1:] = lo + step * last[:, None]
    return np.where(mass > 0, q, lo + step * bins)


def _interp_rows(x, xp, fp):
    """Row-wise ``np.interp(x, xp, fp)``, clamped; a zero-width segment gives its start.

    ``x``, ``xp``, ``fp``: (R, M), (R, K), (R, K).
    """
    i = np.clip(_searchsorted_rows(xp, x, "right"), 1, xp.shape[1] - 1)
    x0 = np.take_along_axis(xp, i - 1, axis=1)
    x1 = np.take_along_axis(xp, i, axis=1)
    f0 = np.take_along_axis(fp, i - 1, axis=1)
    f1 = np.take_along_axis(fp, i, axis=1)
    width = x1 - x0
    frac = np.divide(x - x0, width, out=np.zeros(x.shape), where=width > 0)
    return f0 + np.clip(frac, 0.0, 1.0) * (f1 - f0)


def _maps_np(edges, q_f, q_r):
    """Each cell's map from frame values to reference values, sampled at the bin edges.

    Between the quantiles it interpolates them; beyond the frame's range in the cell
    (values met only through the blending with neighbouring cells) it continues
    linearly with the slope of the whole range (clipped to [1/4, 4]) rather than
    clamping, so a frame matched to itself maps every value to itself.
    """
    lut = _interp_rows(edges, q_f, q_r)
    span_f = q_f[:, -1:] - q_f[:, :1]
    span_r = q_r[:, -1:] - q_r[:, :1]
    slope = np.divide(span_r, span_f, out=np.ones(span_f.shape), where=span_f > 0)
    np.clip(slope, *_SLOPE_RANGE, out=slope)
    lut = np.where(edges < q_f[:, :1], q_r[:, :1] + slope * (edges - q_f[:, :1]), lut)
    return np.where(edges > q_f[:, -1:], q_r[:, -1:] + slope * (edges - q_f[:, -1:]), lut)


# ------------------------------------------------------ the flow rendering (beyond the paper)


def reference_eulerian_loop(image, velocity, n_frames, *, cycle):
    r"""The flow rendering's Eulerian loop, one frame and one phase at a time (slow).

    For every frame :math:`t`, each phase's age :math:`s` (:func:`loop_phases`) is
    walked from 0, one frame at a time, with the semi-Lagrangian recurrence of the
    displacement map, :math:`D_{s+1}(x) = D_s(x - v(x)) - v(x)` forwards and
    :math:`D_{s-1}(x) = D_s(x + v(x)) + v(x)` backwards
    (:func:`fluidnb.fields.backward_warp`); a fractional age interpolates linearly
    between the two whole ones around it. The frame is

    .. math::

        I_t(x) = w_a(t)\, I\big(x + D_{s_a(t)}(x)\big)
            + (1 - w_a(t))\, I\big(x + D_{s_b(t)}(x)\big).

    :func:`~fluidnb.videodb.eulerian_loop` makes every map once and warps with
    OpenCV's ``remap``, whose bilinear weights are rounded to 1/32 of a pixel: the
    two agree to about ``|grad I| / 32`` (checked in the tests to 1e-2 on smooth
    images).
    """
    img = np.asarray(image, np.float64)
    v = np.asarray(velocity, np.float64)
    age_a, age_b, weight_a = loop_phases(n_frames, cycle)

    def displacement(age):
        def walk(steps):
            sign = 1.0 if steps >= 0 else -1.0
            d = np.zeros_like(v)
            for _ in range(abs(steps)):
                d = backward_warp(d, -sign * v) - sign * v
            return d

        lo = math.floor(age)
        frac = age - lo
        d = walk(lo)
        return d if frac == 0 else (1 - frac) * d + frac * walk(lo + 1)

    frames = []
    for sa, sb, wa in zip(age_a, age_b, weight_a):
        a = backward_warp(img, displacement(sa))
        b = backward_warp(img, displacement(sb))
        frames.append(wa * a + (1 - wa) * b)
    return np.array(frames, np.float32)


def reference_fill(image, hole, *, seed=0):
    r"""Exemplar-based fill with an exhaustive search for every patch's match (slow).

    The completion of :func:`~fluidnb.videodb.exemplar_fill` (Wexler et al. 2007:
    coarse to fine, match every patch that touches the hole, each hole pixel the mean
    of what the matches say), but each 7 x 7 patch is compared with *every* patch
    wholly outside the hole, in numpy, where the fast path's PatchMatch samples a
    few. Its matches are the best there are, so the fast path's patch distances can
    only be as low or higher (the tests check they stay close), and the fills look
    alike. Only for small images.
    """
    from ._fill import PATCH_RADIUS, _check, _complete, _pyramid, _sources

    img, h, grey = _check(image, hole)
    r = PATCH_RADIUS
    offsets = np.stack(np.mgrid[-r : r + 1, -r : r + 1], axis=-1).reshape(-1, 2)

    def patches(im, centres):
        # out-of-image pixels are clamped here and excluded by the mask below
        yy = centres[:, None, 0] + offsets[None, :, 0]
        xx = centres[:, None, 1] + offsets[None, :, 1]
        inside = (yy >= 0) & (yy < im.shape[0]) & (xx >= 0) & (xx < im.shape[1])
        yy = np.clip(yy, 0, im.shape[0] - 1)
        xx = np.clip(xx, 0, im.shape[1] - 1)
        return im[yy, xx].astype(np.float64), inside

    def exhaustive(im, hole_, targets, sources, nnf, gen):
        src, _ = patches(im, sources)
        tgt, inside = patches(im, targets)
        best = np.empty((len(targets), 2), np.int64)
        for i in range(len(targets)):
            diff = (src - tgt[i][None]) ** 2 * inside[i][None, :, None]
            best[i] = sources[np.argmin(diff.sum(axis=(1, 2)))]
        return best

    if not h.any():
        out = img
    else:
        if len(_sources(h, r)) == 0:
            raise ValueError("hole leaves no 7 x 7 patch of the image to fill it from")
        out = _complete(_pyramid(img, h), exhaustive, seed)
        out = np.where(h[..., None], out, img)
    return out[..., 0] if grey else out


# --------------------------------------------------------------- the MRF solvers (Eq. 4)


def reference_alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Alpha-expansion (Eq. 4), each move built in plain numpy and cut by PyMaxflow.

    What :func:`~fluidnb.videodb.alpha_expansion` computes, bit for bit (the tests
    check labels, energies, sweeps and the truncated share). For each :math:`\alpha`
    in turn, every node either keeps its label (:math:`x = 0`) or takes its
    :math:`\alpha`-th candidate (:math:`x = 1`); the move's binary energy per edge is
    :math:`(E_{00}, E_{01}, E_{10}, E_{11})`, truncated where it is non-submodular
    (Rother et al. 2005), and written as a graph (Kolmogorov & Zabih 2004) whose
    minimum cut (PyMaxflow's Boykov-Kolmogorov max-flow) is the move, kept only if the
    true energy falls. Sweeps repeat until one brings no improvement.

    The fast path does the same in compiled code, its own Boykov-Kolmogorov max-flow
    (:mod:`fluidnb.videodb._maxflow`) following the library's steps so that the
    residuals, hence the cuts, are the same to the bit; it also skips a move that
    failed on the same labels (it would fail again). Arguments and result as
    :func:`~fluidnb.videodb.alpha_expansion` (without ``progress``).
    """
    t0 = time.perf_counter()
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    prob = _problem(unary, pairwise, edges, lam)
    p, q, lam, n_nodes = prob.p, prob.q, prob.lam, prob.n_nodes
    rows = np.arange(n_nodes)

    def move_terms(labels, alpha):
        lp, lq = labels[p], labels[q]
        # The move's binary energy per edge: x = 0 keeps the label, x = 1 takes alpha.
        e00 = lam * prob.pair(lp, lq)
        e01 = lam * prob.pair(lp, alpha)
        e10 = lam * prob.pair(alpha, lq)
        e11 = lam * prob.pair(alpha, alpha)
        cap = e01 + e10 - e00 - e11
        bad = cap < 0
        free = (lp != alpha) & (lq != alpha)
        # Rother et al. 2005: lower E11 to E01 + E10 - E00 (a lower bound of the true
        # move energy, exact at x = 0); the true energy is checked after the cut.
        e11 = np.where(bad, e01 + e10 - e00, e11)
        cap = np.where(bad, 0.0, cap)
        # Kolmogorov & Zabih 2004: E = E00 + (E10 - E00) x_p + (E11 - E10) x_q
        #                              + cap (1 - x_p) x_q.
        cost1 = prob.unary[:, alpha] - prob.unary[rows, labels]
        cost1 = cost1 + np.bincount(p, e10 - e00, minlength=n_nodes)
        cost1 += np.bincount(q, e11 - e10, minlength=n_nodes)
        return cap, cost1, np.count_nonzero(bad & free), np.count_nonzero(free)

    def min_cut(cap, cost1):
        """Which nodes take alpha (x = 1, the sink side) by the move's minimum cut."""
        g = maxflow.Graph[float](n_nodes, len(p))
        nodes = g.add_nodes(n_nodes)
        g.add_edges(nodes[p], nodes[q], cap, np.zeros(len(p)))
        # A node in the sink segment (x = 1) pays its source capacity.
        g.add_grid_tedges(nodes, np.maximum(cost1, 0.0), np.maximum(-cost1, 0.0))
        g.maxflow()
        return g.get_grid_segments(nodes)

    labels = _start(prob, init).copy()
    current = prob.energy(labels)
    energies = [current]
    truncated = free_terms = sweeps = 0
    for _ in range(max_sweeps):
        improved = False
        for alpha in range(prob.n_labels):
            cap, cost1, n_trunc, n_free = move_terms(labels, alpha)
            truncated += n_trunc
            free_terms += n_free
            take = min_cut(cap, cost1) & (labels != alpha)
            if take.any():
                proposal = np.where(take, alpha, labels)
                new = prob.energy(proposal)
                if new < current:
                    labels, current, improved = proposal, new, True
        sweeps += 1
        energies.append(current)
        if not improved:
            break
    return _finished(labels, energies, sweeps, t0, truncated, free_terms)


def reference_icm(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Iterated conditional modes (Eq. 4) node by node, in plain numpy.

    What :func:`~fluidnb.videodb.icm` computes, bit for bit: in raster order, each
    node takes the label minimising :math:`V_p(l) + \lambda \sum_q W_{pq}` with its
    neighbours fixed (a strict decrease only), sweep after sweep until nothing
    changes (the sweeps are counted as the fast path does; its sweep is compiled).
    Arguments and result as :func:`~fluidnb.videodb.icm` (without ``progress``).
    """
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    prob = _problem(unary, pairwise, edges, lam)
    lam, w = prob.lam, prob.pairwise
    # For node n: (edge, other node) pairs where n is p (a column of W[e]) or q (a row).
    as_p = [[] for _ in range(prob.n_nodes)]
    as_q = [[] for _ in range(prob.n_nodes)]
    for e, (a, b) in enumerate(zip(prob.p.tolist(), prob.q.tolist())):
        as_p[a].append((e, b))
        as_q[b].append((e, a))

    def sweep(labels):
        changed = False
        for n in range(prob.n_nodes):
            cost = prob.unary[n].copy()
            for e, m in as_p[n]:
                cost += lam * w[e, :, labels[m]]
            for e, m in as_q[n]:
                cost += lam * w[e, labels[m], :]
            best = int(np.argmin(cost))
            if cost[best] < cost[labels[n]]:
                labels[n] = best
                changed = True
        return changed

    return _icm(prob, _start(prob, init), max_sweeps, Progress(None), sweep=sweep)


# ------------------------------------------------------------- the starter water clips


def reference_water_flow(spec, shape, n_frames, gen):
    r"""A starter water recipe's velocity (T - 1, H, W, 2), one frame at a time in float64.

    Frame :math:`k` is :math:`\bar v (1 + a \sin(2\pi (k / P - s / L) + \phi))` (the
    gust) plus, scaled by the envelope, the curl of the eddies' stream function
    (:math:`\cos\theta_k \hat\psi_1 + \sin\theta_k \hat\psi_2`, shifted by
    :math:`k` times the carry) and each wave :math:`A \cos(2\pi (s / L - k / P) + \phi)
    \hat k_\perp`. :func:`~fluidnb.videodb._starter_clips._water_flow` (the starter
    clips' path) makes the whole sequence at once in float32, each term a product of a
    function of time and one of space, from the same random draws: the two agree to
    float32 round-off.
    """
    h, w = shape
    flow = spec["flow"]
    base = _steady_flow(flow, shape, gen)
    n = max(n_frames - 1, 0)
    mean = base.reshape(-1, 2).mean(axis=0)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    envelope = _envelope(flow, shape, gen)[..., None]
    if not n:
        return np.empty((0, h, w, 2), np.float32)
    # The random draws in _water_flow's order: gust phase, eddies, waves' phases.
    gust = flow.get("gust")
    gust_phase = gen.uniform(0, 2 * np.pi) if gust else 0.0
    turbulence = flow.get("turbulence", 0.0)
    scale = flow.get("eddy", 0.14) * min(h, w)
    psi = [_stream_function(shape, gen, scale) for _ in range(2)] if turbulence > 0 else []
    waves = [(*wave, gen.uniform(0, 2 * np.pi)) for wave in flow.get("waves", ())]
    ky, kx = _wavenumbers(shape)
    carry = flow.get("carried", 1.0) * mean
    out = np.empty((n, h, w, 2))
    for k in range(n):
        v = base.copy()
        if gust:
            amplitude, period, wavelength = gust
            along = mean / max(float(np.hypot(*mean)), 1e-12)
            s = yy * along[0] + xx * along[1]
            swell = amplitude * np.sin(2 * np.pi * (k / period - s / wavelength) + gust_phase)
            v *= (1.0 + swell)[..., None]
        unsteady = np.zeros((h, w, 2))
        if psi:
            theta = 2.0 * np.pi * k / flow.get("cycle", 24.0)
            spectrum = math.cos(theta) * psi[0] + math.sin(theta) * psi[1]
            spectrum = spectrum * np.exp(-1j * k * (ky * carry[0] + kx * carry[1]))
            unsteady += turbulence * np.stack(_curl(spectrum, shape), axis=-1)
        for amplitude, period, wavelength, angle, phi in waves:
            rad = math.radians(angle)
            direction = np.array([-math.sin(rad), math.cos(rad)])
            s = yy * direction[0] + xx * direction[1]
            wave = amplitude * np.cos(2 * np.pi * (s / wavelength - k / period) + phi)
            unsteady += wave[..., None] * np.array([direction[1], -direction[0]])
        out[k] = v + unsteady * envelope
    return out.astype(np.float32)
