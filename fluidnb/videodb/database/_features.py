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

from ..._image import LUMA
from ...fields import downsample, expand
from ...fields._pyramid import _expand32, _gaussian32
from .._common._geometry import (
    FRAGMENT,
    SPECTRA_BLOCK,
    SPECTRA_SIDE,
    TEXTURE_BLOCK,
    TEXTURE_LEVELS,
    TEXTURE_SIDE,
)
from .._common._sums import _pairwise_sum

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
    # resumed by a newer fluidnb). These are _laplacian32(..., fused=False)'s steps,
    # but each band L = G - expand(G_next) is never stored: one kernel takes it, its
    # magnitude and the sum over frames in one pass (the same float32 values as
    # np.abs(band).sum(axis=-1, dtype=np.float32); the tests check it bit for bit).
    gauss = _gaussian32(np.ascontiguousarray(stack, np.float32), TEXTURE_LEVELS, fused=False)
    levels = []
    for g, g_next in zip(gauss, [*gauss[1:], None]):
        mag = np.empty(g.shape[:2], np.float32)
        # The last level is the residual itself, no band: its magnitude is |G|.
        e = None if g_next is None else _expand32(g_next, g.shape[:2], 1.0, fused=False)
        _band_magnitudes(g, e, mag)
        # Summing over frames first is exact (resampling is linear) and N times cheaper;
        # back to the full grid by bilinear resampling (expand without its blur).
        full = mag.shape == (h, w)
        levels.append(mag if full else expand(mag, (h, w), sigma=0, precision="float32"))
    return block_mean(np.stack(levels), TEXTURE_BLOCK).astype(np.float32)


@njit(cache=True, nogil=True)
def _band_magnitudes(g, e, out):
    """``out[i, j] = sum_c |g[i, j, c] - e[i, j, c]|`` (``e`` None: ``sum_c |g[i, j, c]|``).

    ``g`` a Gaussian level (H, W, C) and ``e`` the next level's expansion: the
    Laplacian band's magnitudes summed over the channels (frames) in float32, the
    values of ``np.abs(g - e).sum(axis=-1, dtype=np.float32)`` (summed in numpy's
    order, :func:`~fluidnb.videodb._common._sums._pairwise_sum`), without the band, its
    absolute value or its negation ever being written out (``g + (-1) e``, what
    ``_laplacian32`` computes, is ``g - e`` exactly).
    """
    row = np.empty(g.shape[2], np.float32)
    for i in range(g.shape[0]):
        for j in range(g.shape[1]):
            for q in range(g.shape[2]):
                row[q] = abs(g[i, j, q] if e is None else g[i, j, q] - e[i, j, q])
            out[i, j] = _pairwise_sum(row)


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
    (:class:`~fluidnb.videodb.database._augment.VersionSampler`'s layout); the results are
    :func:`window_features`'s, bit for bit. So are those of the numpy and OpenCV
    version it replaced: its kernels write each stored array once, in its final
    layout, with numpy's and OpenCV's operations in their order (a database built
    again is the same database). ``reference_pixel_features`` writes the features per
    fragment in float64; the tests compare the two to round-off.
    """
    h, w, m = flow.shape
    moving = np.empty((h, w), bool)
    blocks = np.empty((m // 2, h // SPECTRA_BLOCK, w // SPECTRA_BLOCK, 2), np.float32)
    _moving_blocks(flow, np.float32(threshold), moving, blocks)
    # Everything per fragment comes from sums over 4 x 4-pixel blocks: a fragment is
    # 12 x 12 of them on a grid of step 6 blocks.
    moving_blocks = block_mean(moving.astype(np.float32), SPECTRA_BLOCK)
    count = _window_sums(moving_blocks[None, :, :, None], positions)[:, 0, 0]
    count *= np.float32(SPECTRA_BLOCK**2)
    keep = count > 0.5
    if not keep.any():
        return keep, None
    positions, count = positions[keep], count[keep]
    sums = _window_sums(blocks, positions) * np.float32(SPECTRA_BLOCK**2)  # (k, n, 2)
    motion = sums / count[:, None, None]

    # Rounded to the stored types before being cut into fragments: the same values,
    # converted once per block instead of once per overlapping fragment.
    spectra = _to_half(_power(np.moveaxis(blocks, -1, 1), n_bins))
    texture = _to_half(_textureness(stack))
    mean = (np.clip(colour_mean, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    k = len(positions)
    out = {
        "mean": np.empty((k, FRAGMENT, FRAGMENT, 3), np.uint8),
        "spectra": np.empty((k, n_bins, 2, SPECTRA_SIDE, SPECTRA_SIDE), np.float16),
        "texture": np.empty((k, TEXTURE_LEVELS, TEXTURE_SIDE, TEXTURE_SIDE), np.float16),
    }
    # numba has no float16: the halves are copied as their bit patterns.
    _cut_fragments(
        positions,
        (mean, spectra.view(np.uint16), texture.view(np.uint16)),
        (out["mean"], out["spectra"].view(np.uint16), out["texture"].view(np.uint16)),
    )
    out["mean_motion"] = motion.mean(axis=1).astype(np.float32)
    out["motion"] = motion
    out["moving"] = (count / FRAGMENT**2).astype(np.float32)
    return keep, out


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


@njit(cache=True, nogil=True)
def _half_bits(f):
    """The float16 bit pattern of the float32 of bits ``f``: nearest, ties to even.

    A line-by-line port of numpy's ``npy_floatbits_to_halfbits`` (what ``astype``
    does): integer operations on the bits, so the same halves, whatever the value.
    numpy's own cast slows down about 25-fold on values that underflow to half
    subnormals or zero (measured 67 against 2.6 ns a value), which a window's
    spectra are full of: most blocks barely move at most frequencies.
    """
    f = np.int64(f)  # numba types mixed unsigned / signed integers as floats
    h_sgn = (f & 0x80000000) >> 16
    f_exp = f & 0x7F800000
    if f_exp >= 0x47800000:  # exponent overflow, inf or NaN: signed inf or NaN
        f_sig = f & 0x007FFFFF
        if f_exp == 0x7F800000 and f_sig != 0:
            ret = 0x7C00 + (f_sig >> 13)  # NaN: the payload's top bits...
            if ret == 0x7C00:
                ret += 1  # ... but still a NaN
            return np.uint16(h_sgn + ret)
        return np.uint16(h_sgn + 0x7C00)
    if f_exp <= 0x38000000:  # exponent underflow: a half subnormal or signed zero
        if f_exp < 0x33000000:
            return np.uint16(h_sgn)
        f_sig = (0x00800000 + (f & 0x007FFFFF)) >> (113 - (f_exp >> 23))  # 1-11 more bits
        # Round half to even: not when the half is even and the rest exactly a half
        # (the bits shifted out of f_sig are checked in f).
        if (f_sig & 0x3FFF) != 0x1000 or (f & 0x7FF) != 0:
            f_sig += 0x1000
        return np.uint16(h_sgn + (f_sig >> 13))  # a carry makes it the smallest normal
    h_exp = (f_exp - 0x38000000) >> 13
    f_sig = f & 0x007FFFFF
    if (f_sig & 0x3FFF) != 0x1000:  # round half to even
        f_sig += 0x1000
    # A carry out of the significand increments the exponent (to inf at most).
    return np.uint16(h_sgn + h_exp + (f_sig >> 13))


@njit(cache=True, nogil=True)
def _halves(x, out):
    """``out`` = the bits of ``x.astype(np.float16)``, ``x`` float32 bits (uint32, 4-d)."""
    for i in range(x.shape[0]):
        for j in range(x.shape[1]):
            for k in range(x.shape[2]):
                for m in range(x.shape[3]):
                    out[i, j, k, m] = _half_bits(x[i, j, k, m])


def _to_half(x):
    """``x.astype(np.float16)`` (float32 x, up to 4-d) through :func:`_half_bits`."""
    out = np.empty(x.shape, np.float16)
    lead = (1,) * (4 - x.ndim)
    bits = x.view(np.uint32).reshape(lead + x.shape)  # numba has no float16: bits
    _halves(bits, out.view(np.uint16).reshape(lead + x.shape))
    return out


@njit(cache=True, nogil=True)
def _window_sums(blocks, positions):
    """Sums of ``blocks`` (P, Hb, Wb, Q) over each fragment's 12 x 12 blocks: (k, P, Q).

    An integral image, four lookups a fragment whatever its size, in float64 and then
    rounded to float32: the operations, in their order, of numpy's
    ``np.pad(b.astype(np.float64).cumsum(-2).cumsum(-1), ((1, 0), (1, 0)))`` and
    ``ii[r1, c1] - ii[r0, c1] - ii[r1, c0] + ii[r0, c0]`` per (P, Q) plane
    (``reference_window_sums``, which the tests check it against bit for bit).
    """
    n_p, hb, wb, n_q = blocks.shape
    k = positions.shape[0]
    out = np.empty((k, n_p, n_q), np.float32)
    ii = np.zeros((hb + 1, wb + 1))  # row and column 0: the padding's zeros
    for p in range(n_p):
        for q in range(n_q):
            # cumsum(-2): each column's running sum down the rows, the first row as it
            # is (not 0 + it: a -0.0 stays -0.0).
            for r in range(hb):
                for c in range(wb):
                    v = np.float64(blocks[p, r, c, q])
                    ii[r + 1, c + 1] = v if r == 0 else ii[r, c + 1] + v
            # cumsum(-1): then each row's running sum across the columns.
            for r in range(1, hb + 1):
                for c in range(2, wb + 1):
                    ii[r, c] = ii[r, c - 1] + ii[r, c]
            for i in range(k):
                r0, c0 = positions[i, 0] // SPECTRA_BLOCK, positions[i, 1] // SPECTRA_BLOCK
                r1, c1 = r0 + SPECTRA_SIDE, c0 + SPECTRA_SIDE
                out[i, p, q] = ii[r1, c1] - ii[r0, c1] - ii[r1, c0] + ii[r0, c0]
    return out


@njit(cache=True, nogil=True)
def _cut_fragments(positions, maps, out):
    """Copy each fragment's cells of the whole-canvas maps into its rows of ``out``.

    ``maps`` is the rounded mean image (Hv, Wv, 3), the spectra (NB, 2, Hv / 4, Wv / 4)
    and the textureness (L, Hv / 2, Wv / 2) (the halves as uint16 bits); ``out`` the
    stored arrays (k, 48, 48, 3), (k, NB, 2, 12, 12) and (k, L, 24, 24), written once
    in their final layout (the fancy-index gathers of the numpy version it replaced
    made (NB, 2, k, 12, 12) and needed a transposed copy).
    """
    mean, spectra, texture = maps
    out_mean, out_spectra, out_texture = out
    for i in range(positions.shape[0]):
        r, c = positions[i, 0], positions[i, 1]
        out_mean[i] = mean[r : r + FRAGMENT, c : c + FRAGMENT]
        rs, cs = r // SPECTRA_BLOCK, c // SPECTRA_BLOCK
        for f in range(spectra.shape[0]):
            for a in range(spectra.shape[1]):
                out_spectra[i, f, a] = spectra[f, a, rs : rs + SPECTRA_SIDE, cs : cs + SPECTRA_SIDE]
        rt, ct = r // TEXTURE_BLOCK, c // TEXTURE_BLOCK
        for lev in range(texture.shape[0]):
            out_texture[i, lev] = texture[lev, rt : rt + TEXTURE_SIDE, ct : ct + TEXTURE_SIDE]
