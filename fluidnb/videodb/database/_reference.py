r"""The database's steps as one would first write them, in numpy (Okabe et al., sec. 4; slow).

Each fast path of :mod:`fluidnb.videodb.database` (numba kernels, sampling plans,
features cut from block sums) has its plain version here, in the paper's notation, one
pixel, one frame or one fragment at a time. They are written from the method, not from
the fast path's code: this module imports none of the database's kernels or helpers,
only the grid's sizes and the 18 versions (:mod:`fluidnb.videodb._common._geometry`)
and :mod:`fluidnb.fields` (pyramids and resampling, tested against their own plain
versions). So a test comparing a fast path with its plain version fails when the fast
path is broken (each test says which deliberate breakage it catches); a reader finds
the maths in its most readable form.

=====================================  =============================================
plain version                          fast path (tested against it)
=====================================  =============================================
:func:`reference_sample_version`       :func:`~fluidnb.videodb.database.sample_version`
:func:`reference_transform_vectors`    :func:`~fluidnb.videodb.database.transform_vectors`
:func:`reference_fragment_frames`      :meth:`~fluidnb.videodb.VideoDatabase.fragment_frames`
:func:`reference_pixel_features`       ``pixel_features`` (the build's features)
:func:`reference_textureness`          :func:`~fluidnb.videodb.database.textureness`
:func:`reference_window_sums`          ``_window_sums`` (bit for bit)
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

from ...fields import expand, laplacian_pyramid
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


# ----------------------------------------------------------------- augmentation (sec. 4)


def _version(version):
    r"""The version's flip, scale and angle: :math:`(F, s, \theta)`."""
    if not 0 <= int(version) < len(VERSIONS):
        raise ValueError(f"version must be in [0, {len(VERSIONS) - 1}], got {version}")
    return VERSIONS[int(version)]


def reference_sample_version(frames, version, *, origin=(0, 0), size=None):
    r""":func:`sample_version` written out literally, frame by frame and pixel by pixel.

    The version :math:`(F, s, \theta)` of an :math:`H \times W` source is the bounding
    box of the scaled, rotated source, :math:`H_v = \max(1, [s (H |\cos\theta| + W
    |\sin\theta|)])` and :math:`W_v = \max(1, [s (W |\cos\theta| + H |\sin\theta|)])`
    (``[.]`` rounds half up); its pixel :math:`(r, c)` shows the source at

    .. math::

        (y, x) = F R(-\theta) \big((r, c) - (\tfrac{H_v - 1}{2}, \tfrac{W_v - 1}{2})\big)
            / s + (\tfrac{H - 1}{2}, \tfrac{W - 1}{2}),

    each pixel's coordinates from explicit matrices. Each frame is prefiltered whole
    with a Gaussian of standard deviation :math:`(1/s - 1)/2` when :math:`s < 1`
    (scikit-image's rule; :func:`scipy.ndimage.gaussian_filter`, 4 sigma, edge
    clamped) and sampled with :func:`scipy.ndimage.map_coordinates` (order 1, edge
    clamped). ``origin`` and ``size`` cut a window of the version (default: from
    ``origin`` to the canvas's end). Agrees with the fast path to float32 round-off,
    not bit for bit.
    """
    arr = np.asarray(frames, dtype=np.float64)
    h, w = arr.shape[1:3]
    flip, s, angle = _version(version)
    theta = math.radians(angle)
    hv = max(1, math.floor(s * (h * abs(math.cos(theta)) + w * abs(math.sin(theta))) + 0.5))
    wv = max(1, math.floor(s * (w * abs(math.cos(theta)) + h * abs(math.sin(theta))) + 0.5))
    r0, c0 = (int(v) for v in origin)
    hh, ww = (hv - r0, wv - c0) if size is None else (int(v) for v in size)
    rot = np.array([[math.cos(-theta), -math.sin(-theta)], [math.sin(-theta), math.cos(-theta)]])
    mirror = np.diag([1.0, -1.0 if flip else 1.0])
    centre_v = np.array([(hv - 1) / 2, (wv - 1) / 2])
    centre_s = np.array([(h - 1) / 2, (w - 1) / 2])
    coords = np.empty((2, hh, ww))
    for i in range(hh):
        for j in range(ww):
            p = np.array([r0 + i, c0 + j]) - centre_v
            coords[:, i, j] = mirror @ rot @ p / s + centre_s
    sigma = (1.0 / s - 1.0) / 2.0 if s < 1 else 0.0
    out = np.empty((arr.shape[0], hh, ww, *arr.shape[3:]))
    for t in range(arr.shape[0]):
        for ch in np.ndindex(arr.shape[3:]):
            plane = arr[(t, slice(None), slice(None), *ch)]
            if sigma > 0:
                plane = ndi.gaussian_filter(plane, sigma, mode="nearest", truncate=4.0)
            out[(t, slice(None), slice(None), *ch)] = ndi.map_coordinates(
                plane, coords, order=1, mode="nearest"
            )
    return out.astype(np.float32)


def reference_transform_vectors(vectors, version):
    r""":math:`u_v = s R(\theta) F u_s`, one explicit matrix product per vector."""
    flip, s, angle = _version(version)
    theta = math.radians(angle)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    mirror = np.diag([1.0, -1.0 if flip else 1.0])
    u = np.asarray(vectors, dtype=np.float64)
    out = np.empty_like(u)
    for idx in np.ndindex(u.shape[:-1]):
        out[idx] = s * rot @ mirror @ u[idx]
    return out


def reference_fragment_frames(db, ids, *, margin=0, grey=False):
    r""":meth:`~fluidnb.videodb.VideoDatabase.fragment_frames` written out, one at a time.

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
    r"""The build's fragment features, one fragment at a time in float64 (Okabe et al., sec. 4).

    Arguments and result as ``pixel_features`` (:func:`window_features` of pixel-major
    arrays: ``stack`` the grey frames (H, W, N), ``flow`` each pixel's (dy, dx) pairs
    frame after frame (H, W, 2 (N - 1))). A pixel moves if its mean flow magnitude
    over the window exceeds ``threshold``; a fragment is kept if any of its pixels
    moves. For a kept fragment:

    - ``motion``: per frame pair, the mean flow over its moving pixels (the still
      pixels count as 0 motion, not as pixels), and ``mean_motion`` its mean;
    - ``spectra``: per 4 x 4-pixel block of its 12 x 12, the block's mean motion
      :math:`M_t` (still pixels 0), then :math:`\hat M_f = |\sum_t M_t e^{-2\pi i f t
      / n}|^2 / n^2` for ``f >= 1`` and the signed mean :math:`\frac1n \sum_t M_t` for
      ``f = 0`` (Eq. 2), each DFT term summed explicitly;
    - ``texture``: :func:`reference_textureness` of the window, cut at its 24 x 24
      blocks; ``mean``: the colour mean image rounded to 8 bits; ``moving``: its share
      of moving pixels.

    The fast path works on block sums in float32 (an integral image of the blocks,
    compiled kernels, the textureness on OpenCV's float32 pyramid): the two agree to
    float32 round-off before the spectra and textureness are stored as float16 (the
    tests allow one float16 rounding step).
    """
    h, w, m = flow.shape
    n = m // 2
    f = flow.reshape(h, w, n, 2).astype(np.float64)  # f[y, x, t] = (dy, dx)
    moving = np.sqrt((f**2).sum(axis=-1)).mean(axis=-1) > threshold
    f = f * moving[..., None, None]  # a still pixel's motion is 0
    keep = np.array([moving[r : r + FRAGMENT, c : c + FRAGMENT].any() for r, c in positions])
    if not keep.any():
        return keep, None
    hb, wb = h // SPECTRA_BLOCK, w // SPECTRA_BLOCK
    blocks = (
        f[: hb * SPECTRA_BLOCK, : wb * SPECTRA_BLOCK]
        .reshape(hb, SPECTRA_BLOCK, wb, SPECTRA_BLOCK, n, 2)
        .mean(axis=(1, 3))
    )  # (Hb, Wb, n, 2): M_t per block
    spectra = np.zeros((n_bins, 2, hb, wb))
    for freq in range(n_bins):
        term = np.exp(-2j * np.pi * freq * np.arange(n) / n)  # e^{-2 pi i f t / n}
        dft = (blocks * term[None, None, :, None]).sum(axis=2)  # (Hb, Wb, 2)
        value = dft.real / n if freq == 0 else np.abs(dft) ** 2 / n**2
        spectra[freq] = np.moveaxis(value, -1, 0)
    texture = reference_textureness(stack)
    mean = (np.clip(colour_mean, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    out = {name: [] for name in ("mean", "mean_motion", "motion", "spectra", "texture", "moving")}
    for r, c in np.asarray(positions)[keep]:
        core = (slice(r, r + FRAGMENT), slice(c, c + FRAGMENT))
        count = moving[core].sum()
        motion = f[core].sum(axis=(0, 1)) / count  # (n, 2)
        br, bc = r // SPECTRA_BLOCK, c // SPECTRA_BLOCK
        tr, tc = r // TEXTURE_BLOCK, c // TEXTURE_BLOCK
        out["mean"].append(mean[core])
        out["motion"].append(motion)
        out["mean_motion"].append(motion.mean(axis=0))
        out["spectra"].append(spectra[:, :, br : br + SPECTRA_SIDE, bc : bc + SPECTRA_SIDE])
        out["texture"].append(texture[:, tr : tr + TEXTURE_SIDE, tc : tc + TEXTURE_SIDE])
        out["moving"].append(count / FRAGMENT**2)
    types = {"mean": np.uint8, "spectra": np.float16, "texture": np.float16}
    return keep, {k: np.array(v).astype(types.get(k, np.float32)) for k, v in out.items()}


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
    r""":func:`textureness` of the frames as the channels of one (H, W, N) image, in float64.

    Okabe et al., Fig. 7: per frame :math:`F_i` its 4-level Laplacian pyramid
    :math:`L_l(F_i)` (:func:`fluidnb.fields.laplacian_pyramid`, float64; the last
    level the residual), each band's magnitudes summed over the frames, :math:`\sum_i
    |L_l(F_i)|`, brought back to the full grid by bilinear resampling and averaged
    over 2 x 2 blocks: (4, H // 2, W // 2). The stored textureness is made on
    OpenCV's float32 pyramid in one fused kernel per band: the two agree to float32
    round-off.
    """
    h, w = stack.shape[:2]
    bands = laplacian_pyramid(np.asarray(stack, np.float64), TEXTURE_LEVELS)
    levels = []
    for band in bands:
        mag = np.abs(band).sum(axis=-1)
        levels.append(mag if mag.shape == (h, w) else expand(mag, (h, w), sigma=0))
    hb, wb = h // TEXTURE_BLOCK, w // TEXTURE_BLOCK
    full = np.stack(levels)[:, : hb * TEXTURE_BLOCK, : wb * TEXTURE_BLOCK]
    return full.reshape(-1, hb, TEXTURE_BLOCK, wb, TEXTURE_BLOCK).mean(axis=(2, 4))


# ------------------------------------------------------------ appearance (secs. 4-5, Eq. 1)


def reference_dense_sift(image):
    """Dense SIFT as the recipe reads, literally: one descriptor, one pixel at a time.

    On the 9 x 9 grid of step 4, each descriptor's 16 x 16 pixels: central-difference
    gradients; each pixel's magnitude, weighted by a Gaussian window of sigma 8 about
    the descriptor's centre, shared out bilinearly between the 4 x 4 spatial bins of
    4 pixels and linearly between the two nearest of 8 orientations; the 128 values
    normalised, clipped at 0.2, normalised again and quantised to ``min(255,
    floor(512 v))`` (Lowe 2004).

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
    img = np.asarray(image)
    if img.shape != (FRAGMENT, FRAGMENT):
        raise ValueError(f"image must have shape (48, 48), got {img.shape}")
    img = img.astype(np.float32).astype(np.float64)
    gy, gx = np.gradient(img)  # central differences, one-sided at the border
    eps = float(np.finfo(np.float32).eps)  # keeps a flat patch's zeros zeros
    out = np.zeros((GRID, GRID, 128), np.uint8)
    for ky in range(GRID):
        for kx in range(GRID):
            hist = np.zeros((4, 4, 8))  # 4 x 4 spatial bins, 8 orientations
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
            v = v / (np.linalg.norm(v) + eps)
            v = np.minimum(v, 0.2)
            v = v / (np.linalg.norm(v) + eps)
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
    x = np.asarray(descriptors)
    c = np.asarray(centres, np.float64)
    if c.ndim != 2 or x.ndim < 1 or x.shape[-1] != c.shape[1]:
        raise ValueError(f"descriptors must be (..., {c.shape[-1]}), got {x.shape}")
    rows = x.reshape(-1, x.shape[-1]).astype(np.float64)
    words = np.empty(len(rows), np.int64)
    for i in range(0, len(rows), 256):
        diff = rows[i : i + 256, None, :] - c  # (m, k, D): x_i - c_i
        words[i : i + 256] = (diff * diff).sum(axis=-1).argmin(axis=1)
    return words.reshape(x.shape[:-1])
