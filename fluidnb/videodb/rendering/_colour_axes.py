r"""Frames in the target's principal colour axes, and back (Heeger & Bergen 1995).

Matching R, G and B independently can mix hues the photo does not have (a white-hot
flame turned lilac); matching decorrelated axes keeps its colours. So the rendering
makes each frame straight in the axes of the target's colours inside its matte
(:func:`colour_axes`), matches it there, and turns it back into RGB as it composites
it (one compiled pass each).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["colour_axes", "colours_in_axes", "frames_from_axes", "frames_in_axes"]


def colour_axes(image, matte):
    """Mean colour and principal axes of the image's pixels inside the matte (Heeger & Bergen).

    Returns
    -------
    centre : ndarray, shape (3,), float32
    axes : ndarray, shape (3, 3), float32
        Orthonormal columns, largest variance first: ``(x - centre) @ axes`` are a
        colour's coordinates in them.
    """
    pix = image[matte > 0.5] if (matte > 0.5).any() else image.reshape(-1, 3)
    centre = pix.mean(axis=0)
    cov = np.cov((pix - centre).T.astype(np.float64)) + 1e-9 * np.eye(3)
    _, vecs = np.linalg.eigh(cov)
    return centre.astype(np.float32), vecs[:, ::-1].astype(np.float32)


def frames_in_axes(mean, differences, centre, axes, *, unmatched=None):
    """The frames ``mean + D_i`` in the colour axes: ``((A + D_i) - centre) @ axes``.

    One compiled pass over (T, H, W) differences and an (H, W, 3) mean image, float32,
    each coordinate summed as ``(g_0 a_0 + g_1 a_1) + g_2 a_2``; it differs from
    numpy's matrix product (BLAS) by float32 rounding (measured 2.4e-7).

    Parameters
    ----------
    unmatched : tuple of int, optional
        ``(h, w)``: also return the frames themselves, ``clip(A + D_i, 0, 1)`` on
        their top-left ``h x w`` pixels (the rendering's "before matching" picture),
        made in the same pass.

    Returns
    -------
    ndarray, shape (T, H, W, 3), float32
        And, with ``unmatched``, the frames (T, h, w, 3).
    """
    d = np.ascontiguousarray(differences, dtype=np.float32)
    a = np.ascontiguousarray(mean, dtype=np.float32)
    out = np.empty(d.shape + (3,), np.float32)
    h, w = (0, 0) if unmatched is None else unmatched
    frames = np.empty((d.shape[0], h, w, 3), np.float32)
    axes = np.ascontiguousarray(axes, np.float32)
    _in_axes(a, d, centre.astype(np.float32), axes, out, frames)
    return out if unmatched is None else (out, frames)


def colours_in_axes(frames, centre, axes):
    """Colours (..., 3) in the colour axes: ``(x - centre) @ axes`` (float32, one pass).

    Each coordinate summed as ``(g_0 a_0 + g_1 a_1) + g_2 a_2``, as
    :func:`frames_in_axes`.
    """
    x = np.ascontiguousarray(frames, dtype=np.float32)
    out = np.empty_like(x)
    _colours_in_axes(
        x.reshape(-1, 3), centre.astype(np.float32), np.ascontiguousarray(axes, np.float32),
        out.reshape(-1, 3),
    )  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def _colours_in_axes(x, centre, axes, out):
    for i in range(x.shape[0]):
        g0 = x[i, 0] - centre[0]
        g1 = x[i, 1] - centre[1]
        g2 = x[i, 2] - centre[2]
        for k in range(3):
            out[i, k] = (g0 * axes[0, k] + g1 * axes[1, k]) + g2 * axes[2, k]


def frames_from_axes(coordinates, centre, axes):
    """Colours back from the colour axes, in place: ``x @ axes.T + centre`` (float32)."""
    x = np.ascontiguousarray(coordinates, dtype=np.float32)
    _from_axes(x.reshape(-1, 3), centre.astype(np.float32), np.ascontiguousarray(axes, np.float32))
    return x


@njit(cache=True, nogil=True)
def _in_axes(mean, d, centre, axes, out, frames):
    n_t, h, w = d.shape
    fh, fw = frames.shape[1:3]
    for t in range(n_t):
        for r in range(h):
            for c in range(w):
                delta = d[t, r, c]
                f0 = mean[r, c, 0] + delta
                f1 = mean[r, c, 1] + delta
                f2 = mean[r, c, 2] + delta
                if r < fh and c < fw:
                    frames[t, r, c, 0] = min(max(f0, np.float32(0.0)), np.float32(1.0))
                    frames[t, r, c, 1] = min(max(f1, np.float32(0.0)), np.float32(1.0))
                    frames[t, r, c, 2] = min(max(f2, np.float32(0.0)), np.float32(1.0))
                g0 = f0 - centre[0]
                g1 = f1 - centre[1]
                g2 = f2 - centre[2]
                for k in range(3):
                    out[t, r, c, k] = (g0 * axes[0, k] + g1 * axes[1, k]) + g2 * axes[2, k]


@njit(cache=True, nogil=True)
def _from_axes(x, centre, axes):
    for i in range(x.shape[0]):
        a0 = x[i, 0]
        a1 = x[i, 1]
        a2 = x[i, 2]
        for k in range(3):
            x[i, k] = ((a0 * axes[k, 0] + a1 * axes[k, 1]) + a2 * axes[k, 2]) + centre[k]


@njit(cache=True, nogil=True)
def _advected_in_axes(moved, detail, d, centre, axes, out):
    """One flow-rendered frame in the colour axes, in one pass (float32).

    The phases' blend ``moved`` plus ``detail * d``, in the axes as
    :func:`colours_in_axes`: the numpy steps' operations in their order.
    """
    h, w = d.shape
    for r in range(h):
        for c in range(w):
            dd = detail * d[r, c]
            g0 = (moved[r, c, 0] + dd) - centre[0]
            g1 = (moved[r, c, 1] + dd) - centre[1]
            g2 = (moved[r, c, 2] + dd) - centre[2]
            for k in range(3):
                out[r, c, k] = (g0 * axes[0, k] + g1 * axes[1, k]) + g2 * axes[2, k]


@njit(cache=True, nogil=True)
def _composite_from_axes(x, centre, axes, back, matte, out):
    """Colours back from the axes, over the background through the matte, in [0, 1].

    :func:`frames_from_axes`, then :func:`fluidnb.videodb.rendering.composite`'s
    ``back + matte (x - back)`` and the clip to [0, 1], on the top-left ``out``-sized
    part of the (larger) canvas, in one pass with the numpy steps' float32 operations.
    """
    h, w = out.shape[:2]
    for r in range(h):
        for c in range(w):
            a0 = x[r, c, 0]
            a1 = x[r, c, 1]
            a2 = x[r, c, 2]
            m = matte[r, c]
            for k in range(3):
                v = ((a0 * axes[k, 0] + a1 * axes[k, 1]) + a2 * axes[k, 2]) + centre[k]
                bg = back[r, c, k]
                v = (v - bg) * m + bg
                out[r, c, k] = min(max(v, np.float32(0.0)), np.float32(1.0))
