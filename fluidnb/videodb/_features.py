r"""What a database keeps of each fragment (Okabe et al., secs. 4-5, Fig. 5 and 7).

For one temporal window of one augmented version of a clip, every 48 x 48 fragment on
the stride-24 grid gets:

- its mean image :math:`A = \frac{1}{N}\sum_i F_i` (colour, rounded to 8 bits);
- the moving-pixel mask: pixels whose flow magnitude, averaged over the window, exceeds
  the threshold (Okabe et al., Fig. 5-d); a fragment with no moving pixel is dropped;
- its mean motion (over the window and its moving pixels) and the same mean per frame
  pair (the motion the render step warps the dynamic matte with);
- the motion spectra :math:`\hat M(x)` over time of each flow component (Eq. 2),
  per 4 x 4-pixel block (12 x 12 per fragment): bins ``f >= 1`` (the paper's
  :math:`f = 2 \ldots N/2`) are the one-sided power spectrum
  :math:`|\mathcal F(M(x))|^2 / n^2` (``n = N - 1`` flows; in (px/frame)^2 whatever
  ``N``); bin 0, the DC term the paper calls the mean motion field, is the mean
  motion itself, signed, in px/frame (our decision: its power, the mean squared,
  would be the same for opposite flows, so neighbours moving left and right would
  count as alike in Eq. (2));
- its textureness :math:`T`: per frame a 4-level Laplacian pyramid, each band's
  magnitude brought back to full resolution and summed over the window's frames
  (Okabe et al., Fig. 7), averaged over 2 x 2-pixel blocks (24 x 24 x 4 per fragment).

Spectra and textureness are computed once over the whole version canvas and cut into
fragments (the stride, 24, is a multiple of both block sizes), so neighbouring
fragments share their overlapping values exactly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._image import LUMA
from ..fields import downsample, expand
from ..fields._pyramid import _laplacian32
from ._geometry import (
    FRAGMENT,
    SPECTRA_BLOCK,
    SPECTRA_SIDE,
    TEXTURE_BLOCK,
    TEXTURE_LEVELS,
    TEXTURE_SIDE,
)

__all__ = [
    "block_mean",
    "grey",
    "motion_spectra",
    "pixel_features",
    "textureness",
    "window_features",
]


def grey(frames):
    """Luminance of RGB frames (uint8 or float in [0, 1]) as float32 in [0, 1]."""
    arr = np.asarray(frames)
    scale = np.float32(1 / 255) if arr.dtype == np.uint8 else np.float32(1)
    return (arr.astype(np.float32) @ LUMA) * scale


def block_mean(field, block):
    """Average ``field`` (..., H, W) over ``block x block`` tiles (a ragged edge is dropped).

    In float32 through OpenCV (:func:`fluidnb.fields.downsample` with
    ``precision="float32"``), the leading axes batched as channels.
    """
    h, w = field.shape[-2:]
    hb, wb = h // block, w // block
    lead = field.shape[:-2]
    flat = np.asarray(field, np.float32)[..., : hb * block, : wb * block].reshape(
        -1, hb * block, wb * block
    )
    stack = np.ascontiguousarray(np.moveaxis(flat, 0, -1))
    out = downsample(stack, block, precision="float32")
    return np.moveaxis(out, -1, 0).reshape(*lead, hb, wb)


def _flow_blocks(flow, moving):
    """Block means (n, 2, Hb, Wb) of the flow with the still pixels' motion set to 0."""
    import cv2

    n, h, w = flow.shape[:3]
    hb, wb = h // SPECTRA_BLOCK, w // SPECTRA_BLOCK
    keep = moving[: hb * SPECTRA_BLOCK, : wb * SPECTRA_BLOCK, None].astype(np.float32)
    out = np.empty((n, hb, wb, 2), np.float32)
    for t in range(n):  # one contiguous (H, W, 2) frame at a time: no transposed copies
        f = flow[t, : hb * SPECTRA_BLOCK, : wb * SPECTRA_BLOCK] * keep
        out[t] = cv2.resize(f, (wb, hb), interpolation=cv2.INTER_AREA)
    return np.moveaxis(out, -1, 1)


def motion_spectra(flow, n_bins):
    r"""Power spectra over time of a flow window, per 4 x 4-pixel block (Eq. 2).

    Parameters
    ----------
    flow : ndarray, shape (n, H, W, 2)
        The window's ``n = N - 1`` flows (dy, dx), moving-pixel mask applied.
    n_bins : int
        Frequency bins to keep, ``f = 0`` (DC) first.

    Returns
    -------
    ndarray, shape (n_bins, 2, H // 4, W // 4), float32
        :math:`|\sum_t M_t e^{-2\pi i f t / n}|^2 / n^2` per component for ``f >= 1``,
        and the signed mean :math:`\frac1n \sum_t M_t` for ``f = 0``, of the motion
        averaged over each block (the flow is smooth at that scale: the spectra of
        the block means are the spectra of the pixels at a sixteenth of the cost).
    """
    return _power(_flow_blocks(flow, np.ones(flow.shape[1:3], bool)), n_bins)


def _power(blocks, n_bins):
    n = blocks.shape[0]
    spec = np.fft.rfft(blocks, axis=0)[:n_bins]
    out = ((spec.real**2 + spec.imag**2) / np.float32(n * n)).astype(np.float32)
    # Bin 0 is the mean motion itself, signed (our decision): its power, the mean
    # squared, is the same for a flow to the left and one to the right, so Eq. (2)'s
    # DC term could not tell opposite neighbours apart.
    out[0] = spec[0].real / np.float32(n)
    return out


def textureness(frames):
    r"""Laplacian-pyramid magnitudes summed over frames (Okabe et al., Fig. 7), per 2 x 2 block.

    Parameters
    ----------
    frames : ndarray, shape (N, H, W)
        Grey frames of the window.

    Returns
    -------
    ndarray, shape (4, H // 2, W // 2), float32
        Level ``l`` is :math:`\sum_i |L_l(F_i)|` resampled to the full grid.
    """
    return _textureness(np.ascontiguousarray(np.moveaxis(frames, 0, -1), np.float32))


def _textureness(stack):
    """:func:`textureness` of the frames as the channels of one (H, W, N) image."""
    h, w = stack.shape[:2]
    # The frames are the channels of one pyramid (channels never mix): N pyramids for
    # the price of one call, in float32 through OpenCV (the library's pyramid to
    # float32 round-off, ~15 times as fast as its float64 version). Not the fused
    # float32 steps the renderer's blend uses: this is what databases store, and the
    # same sources must keep giving the same database (the starter caches, a build
    # resumed by a newer fluidnb).
    bands = _laplacian32(np.ascontiguousarray(stack, np.float32), TEXTURE_LEVELS, fused=False)
    levels = []
    for band in bands:
        # Summing over frames first is exact (resampling is linear) and N times cheaper;
        # back to the full grid by bilinear resampling (expand without its blur).
        mag = np.abs(band).sum(axis=-1, dtype=np.float32)
        full = mag.shape == (h, w)
        levels.append(mag if full else expand(mag, (h, w), sigma=0, precision="float32"))
    return block_mean(np.stack(levels), TEXTURE_BLOCK).astype(np.float32)


def window_features(frames, colour_mean, flow, positions, *, threshold, n_bins):
    """Features of the fragments at ``positions`` in one window of one version.

    Parameters
    ----------
    frames : ndarray, shape (N, Hv, Wv)
        Grey frames of the window (float32 in [0, 1]).
    colour_mean : ndarray, shape (Hv, Wv, 3)
        The window's mean colour image (float32 in [0, 1]).
    flow : ndarray, shape (N - 1, Hv, Wv, 2)
        The window's flows (dy, dx), px/frame.
    positions : ndarray, shape (n, 2)
        Top-left (row, col) of fragments, multiples of 24, wholly inside the canvas.
    threshold : float
        Mean flow magnitude (px/frame) above which a pixel moves.
    n_bins : int
        Frequency bins of the spectra.

    Returns
    -------
    keep : ndarray, shape (n,), bool
        Fragments with at least one moving pixel.
    features : dict of ndarray or None
        For the kept fragments (None if none is kept): ``mean`` (k, 48, 48, 3) uint8,
        ``mean_motion`` (k, 2), ``motion`` (k, N - 1, 2), ``spectra`` (k, n_bins, 2,
        12, 12) float16, ``texture`` (k, 4, 24, 24) float16, ``moving`` (k,) the
        fraction of moving pixels.
    """
    n, h, w = flow.shape[:3]
    return pixel_features(
        np.ascontiguousarray(np.moveaxis(frames, 0, -1), np.float32),
        np.asarray(colour_mean, np.float32),
        np.ascontiguousarray(np.moveaxis(flow, 0, 2), np.float32).reshape(h, w, 2 * n),
        positions,
        threshold=threshold,
        n_bins=n_bins,
    )


def pixel_features(stack, colour_mean, flow, positions, *, threshold, n_bins):
    """:func:`window_features` of pixel-major arrays (the build's layout, no copies).

    ``stack`` is the grey frames as (Hv, Wv, N) and ``flow`` the flows as (Hv, Wv,
    2 (N - 1)), each pixel's (dy, dx) pairs frame after frame
    (:class:`~fluidnb.videodb._augment.VersionSampler`'s layout); the results are
    :func:`window_features`'s, bit for bit.
    """
    h, w, m = flow.shape
    moving = np.empty((h, w), bool)
    blocks = np.empty((m // 2, h // SPECTRA_BLOCK, w // SPECTRA_BLOCK, 2), np.float32)
    _moving_blocks(flow, np.float32(threshold), moving, blocks)
    # Everything per fragment comes from sums over 4 x 4-pixel blocks: a fragment is
    # 12 x 12 of them on a grid of step 6 blocks.
    count = _window_sums(block_mean(moving.astype(np.float32), SPECTRA_BLOCK), positions)
    count *= np.float32(SPECTRA_BLOCK**2)
    keep = count > 0.5
    if not keep.any():
        return keep, None
    positions, count = positions[keep], count[keep]
    blocks = np.moveaxis(blocks, -1, 1)  # (n, 2, Hb, Wb)
    sums = _window_sums(blocks, positions) * np.float32(SPECTRA_BLOCK**2)  # (n, 2, k)
    motion = (np.moveaxis(sums, -1, 0) / count[:, None, None]).astype(np.float32)

    # Rounded to the stored types before being cut into fragments: the same values,
    # converted once per block instead of once per overlapping fragment.
    spectra = _power(blocks, n_bins).astype(np.float16)
    texture = _textureness(stack).astype(np.float16)
    mean = (np.clip(colour_mean, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    spec = spectra[(slice(None), slice(None), *_windows(positions, SPECTRA_BLOCK, SPECTRA_SIDE))]
    tex = texture[(slice(None), *_windows(positions, TEXTURE_BLOCK, TEXTURE_SIDE))]
    return keep, {
        "mean": mean[_windows(positions, 1, FRAGMENT)],
        "mean_motion": motion.mean(axis=1).astype(np.float32),
        "motion": motion,
        "spectra": np.ascontiguousarray(np.moveaxis(spec, 2, 0)),
        "texture": np.ascontiguousarray(np.moveaxis(tex, 1, 0)),
        "moving": (count / FRAGMENT**2).astype(np.float32),
    }


@njit(cache=True, nogil=True)
def _moving_rows(flow, lo, hi, threshold, moving):
    """``moving[i] = mean_t |flow[i, t]| > threshold`` for rows ``lo .. hi - 1``.

    In float32, the frames summed in order and the sum divided by their number: the
    operations of ``np.sqrt(dy ** 2 + dx ** 2).mean(axis=0) > threshold`` on (T, H, W)
    arrays, so the same pixels move.
    """
    n = np.float32(flow.shape[2] // 2)
    for i in range(lo, hi):
        for j in range(flow.shape[1]):
            f = flow[i, j]
            acc = np.float32(0.0)
            for q in range(0, f.shape[0], 2):
                acc += np.sqrt(f[q] * f[q] + f[q + 1] * f[q + 1])
            moving[i, j] = acc / n > threshold


@njit(cache=True, nogil=True)
def _moving_blocks(flow, threshold, moving, out):
    """The moving pixels, and the flow's means over 4 x 4 blocks with the still ones at 0.

    ``flow`` is pixel-major (H, W, 2 n); ``out`` (n, H // 4, W // 4, 2). Each block
    mean is summed as OpenCV's area resize (``cv2.INTER_AREA`` at an integer factor)
    sums it -- row by row, each row's four values left to right, then times 1/16 --
    so it equals ``cv2.resize`` of the masked flow, frame by frame, bit for bit (the
    tests check it), in one pass over the flow instead of a masked copy and a resize
    per frame.
    """
    h, m = flow.shape[0], flow.shape[2]
    hb, wb = out.shape[1], out.shape[2]
    sixteenth = np.float32(1.0 / 16.0)
    zero = np.float32(0.0)
    acc = np.empty(m, np.float32)
    for bi in range(hb):
        _moving_rows(flow, 4 * bi, 4 * bi + 4, threshold, moving)
        for bj in range(wb):
            acc[:] = 0.0
            for y in range(4 * bi, 4 * bi + 4):
                x = 4 * bj
                f0, f1, f2, f3 = flow[y, x], flow[y, x + 1], flow[y, x + 2], flow[y, x + 3]
                k0, k1, k2, k3 = moving[y, x], moving[y, x + 1], moving[y, x + 2], moving[y, x + 3]
                for q in range(m):
                    v0 = f0[q] if k0 else zero
                    v1 = f1[q] if k1 else zero
                    v2 = f2[q] if k2 else zero
                    v3 = f3[q] if k3 else zero
                    acc[q] += ((v0 + v1) + v2) + v3
            for q in range(m):
                out[q // 2, bi, bj, q % 2] = acc[q] * sixteenth
    _moving_rows(flow, 4 * hb, h, threshold, moving)


def _windows(positions, block, side):
    """Index arrays (k, side, side) of each fragment's cells on a grid of ``block`` px."""
    offs = np.arange(side)
    rows, cols = positions[:, 0] // block, positions[:, 1] // block
    return rows[:, None, None] + offs[None, :, None], cols[:, None, None] + offs[None, None, :]


def _window_sums(blocks, positions):
    """Sums of ``blocks`` (..., Hb, Wb) over each fragment's 12 x 12 blocks."""
    # An integral image: four lookups a fragment, whatever its size.
    pad = [(0, 0)] * (blocks.ndim - 2) + [(1, 0), (1, 0)]
    ii = np.pad(blocks.astype(np.float64).cumsum(-2).cumsum(-1), pad)
    r0, c0 = positions[:, 0] // SPECTRA_BLOCK, positions[:, 1] // SPECTRA_BLOCK
    r1, c1 = r0 + SPECTRA_SIDE, c0 + SPECTRA_SIDE
    out = ii[..., r1, c1] - ii[..., r0, c1] - ii[..., r1, c0] + ii[..., r0, c0]
    return out.astype(np.float32)
