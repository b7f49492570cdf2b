r"""The database's steps as one would first write them, in numpy (Okabe et al., sec. 4; slow).

Each fast path of :mod:`fluidnb.videodb.database` has its plain version here, in the
paper's notation, one pixel or one fragment at a time; the tests check the fast path
against it, and a reader finds the maths in its most readable form.

=====================================  =============================================
plain version                          fast path (tested against it)
=====================================  =============================================
:func:`reference_sample_version`       :func:`~fluidnb.videodb.database.sample_version`
:func:`reference_transform_vectors`    :func:`~fluidnb.videodb.database.transform_vectors`
:func:`reference_fragment_frames`      :meth:`~fluidnb.videodb.VideoDatabase.fragment_frames`
:func:`reference_pixel_features`       ``pixel_features`` (the build's features)
:func:`reference_textureness`          :func:`~fluidnb.videodb.database.textureness`
:func:`reference_window_sums`          ``_window_sums``
:func:`reference_dense_sift`           :func:`~fluidnb.videodb.database.dense_sift`
:func:`reference_quantise`             :func:`~fluidnb.videodb.database.quantise`
=====================================  =============================================

How closely each pair agrees, and why not bit for bit where it does not, is said in
each function's docstring.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage as ndi

from ...fields import expand
from ...fields._pyramid import _laplacian32
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
from ._features import _flow_blocks, _power, block_mean
from ._sift import _EPS, BINS, ORIENTATIONS, _check_images
from ._versions import _TRUNCATE, _window, prefilter_sigma, version_shape
from ._words import _check_pair, _squared_distances

__all__ = [
    "reference_dense_sift",
    "reference_fragment_frames",
    "reference_pixel_features",
    "reference_quantise",
    "reference_sample_version",
    "reference_textureness",
    "reference_transform_vectors",
    "reference_window_sums",
]


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
