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

from .._image import LUMA
from ..fields import downsample, expand, laplacian_pyramid
from ._geometry import (
    FRAGMENT,
    SPECTRA_BLOCK,
    SPECTRA_SIDE,
    TEXTURE_BLOCK,
    TEXTURE_LEVELS,
    TEXTURE_SIDE,
)

__all__ = ["block_mean", "grey", "motion_spectra", "textureness", "window_features"]


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
    h, w = frames.shape[1:]
    # The frames are the channels of one pyramid (channels never mix): N pyramids for
    # the price of one call, in float32 through OpenCV (the library's pyramid to
    # float32 round-off, ~15 times as fast as its float64 version).
    frames = np.ascontiguousarray(np.moveaxis(frames, 0, -1), np.float32)
    bands = laplacian_pyramid(frames, TEXTURE_LEVELS, precision="float32")
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
    moving = np.sqrt(flow[..., 0] ** 2 + flow[..., 1] ** 2).mean(axis=0) > threshold
    # Everything per fragment comes from sums over 4 x 4-pixel blocks: a fragment is
    # 12 x 12 of them on a grid of step 6 blocks.
    count = _window_sums(block_mean(moving.astype(np.float32), SPECTRA_BLOCK), positions)
    count *= np.float32(SPECTRA_BLOCK**2)
    keep = count > 0.5
    if not keep.any():
        return keep, None
    positions, count = positions[keep], count[keep]
    blocks = _flow_blocks(flow, moving)  # (n, 2, Hb, Wb)
    sums = _window_sums(blocks, positions) * np.float32(SPECTRA_BLOCK**2)  # (n, 2, k)
    motion = (np.moveaxis(sums, -1, 0) / count[:, None, None]).astype(np.float32)

    spectra = _power(blocks, n_bins)
    texture = textureness(frames)
    spec = spectra[(slice(None), slice(None), *_windows(positions, SPECTRA_BLOCK, SPECTRA_SIDE))]
    tex = texture[(slice(None), *_windows(positions, TEXTURE_BLOCK, TEXTURE_SIDE))]
    mean = colour_mean[_windows(positions, 1, FRAGMENT)]
    return keep, {
        "mean": (np.clip(mean, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8),
        "mean_motion": motion.mean(axis=1).astype(np.float32),
        "motion": motion,
        "spectra": np.moveaxis(spec, 2, 0).astype(np.float16),
        "texture": np.moveaxis(tex, 1, 0).astype(np.float16),
        "moving": (count / FRAGMENT**2).astype(np.float32),
    }


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
