r"""Every fragment's loop of difference frames played from its offset, mirrored, at its rate.

:func:`~fluidnb.videodb.rendering.stagger` on loops already made (the database's frame
cache keeps each fragment's :math:`D_i`, cross-faded into a loop, frame-major), written
pixel-major as the blend reads them (beyond the paper: neighbours that share a
fragment start it at different times, :mod:`fluidnb.videodb.rendering._desync`).

The loops are kept frame-major, ``(L, s, s)``: a frame :math:`t` of the clip reads
two whole planes of each fragment's loop (the frames below and above its time), one
after the other. Kept pixel-major, ``(s, s, L)``, each pixel's value was one float of
a different cache line: a 1920-px frame (one frame per run, 1960 fragments) read
every line of every loop, ten times the bytes it used (issue 39: ~10 s of CPU of the
96-frame clip).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._validation import check_int
from .._common._geometry import FRAGMENT
from ._threads import _THREADS, _in_order

__all__ = ["play_loops"]


def play_loops(loops, offsets, *, rates=None, n_frames=None, mirrors=None, frames=None, out=None):
    r"""Every fragment's loop played from its offset, mirrored, at its rate, pixel-major.

    What :func:`fluidnb.videodb.rendering.stagger` does after making the loops, for loops
    already made (:func:`difference_frames`, kept frame-major in the frame cache),
    written pixel-major as the blend reads them: fragment ``p`` shows frame
    :math:`(o_p + r_p t) \bmod L` of its loop at time :math:`t` (linear between frames
    at fractional times), flipped across ``mirrors[p]`` (0: upside down, 1: left to
    right, -1: not). The times are computed as ``stagger`` computes them and the
    interpolation is the same float32 ``a + f (b - a)``, so the frames are
    ``stagger``'s bit for bit (tested).

    Parameters
    ----------
    loops : sequence of ndarray, shape (L, s, s), float32
        Each fragment's loop, frame-major (as the frame cache keeps it).
    offsets : ndarray, shape (P,)
        :math:`o_p`, in frames.
    rates : ndarray, shape (P,), optional
        :math:`r_p`, frames of the loop played per frame (default 1).
    n_frames : int, optional
        Frames to make (default :math:`L`).
    mirrors : ndarray, shape (P,), optional
        Per fragment -1, 0 or 1 (default -1).
    frames : array_like of int, optional
        Which frames :math:`t` to make (default ``range(n_frames)``): a renderer
        makes a clip a few frames at a time; each frame is the same however the clip
        is cut.
    out : ndarray, shape (P, s, s, len(frames)), float32, C-contiguous, optional
        Where to write them: a renderer plays a run of frames after another into the
        same array (at 1920 px a run's is 40 MB, which numpy would otherwise map
        afresh, page by page, for every frame).

    Returns
    -------
    ndarray, shape (P, s, s, len(frames)), float32
    """
    p = len(loops)
    offs = np.asarray(offsets, np.float64)
    if offs.shape != (p,):
        raise ValueError(f"offsets must have shape ({p},), got {offs.shape}")
    if frames is not None:
        t = np.asarray(frames)
        if t.ndim != 1 or t.dtype.kind not in "iu" or (len(t) and t.min() < 0):
            raise ValueError("frames must be a 1-D array of frame numbers >= 0")
    if p == 0:
        n = len(t) if frames is not None else (0 if n_frames is None else n_frames)
        return np.zeros((0, FRAGMENT, FRAGMENT, n), np.float32)
    length, side = loops[0].shape[0], loops[0].shape[1]
    if any(x.shape != (length, side, side) for x in loops):
        # Also what a pixel-major (s, s, L) loop of another length than s looks like.
        raise ValueError(
            "loops must be frame-major loops (L, s, s) of one shape, got "
            f"{sorted({x.shape for x in loops})[:3]}"
        )
    if frames is None:
        n_frames = length if n_frames is None else check_int("n_frames", n_frames, 1)
        t = np.arange(n_frames)
    n_frames = len(t)
    r = np.ones(p) if rates is None else np.asarray(rates, np.float64)
    flips = np.full(p, -1, np.int64) if mirrors is None else np.asarray(mirrors, np.int64)
    if r.shape != (p,) or flips.shape != (p,):
        raise ValueError(f"rates and mirrors must have shape ({p},)")
    # As stagger: times mod L in float64, the frame below and the fraction in float32.
    times = np.mod(offs[:, None] + r[:, None] * t[None, :], length)
    i0 = np.floor(times).astype(np.int64)
    frac = (times - i0).astype(np.float32)
    below, above = i0 % length, (i0 + 1) % length
    shape = (p, side, side, n_frames)
    if out is None:
        out = np.empty(shape, np.float32)
    elif out.shape != shape or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ValueError(
            f"out must be a C-contiguous float32 array of shape {shape}, got "
            f"{out.dtype} {out.shape}"
        )
    loops = [np.ascontiguousarray(x, np.float32) for x in loops]

    def play(k0, k1):
        for k in range(k0, k1):
            _play_loop(loops[k], below[k], above[k], frac[k], flips[k], out[k])

    # Each fragment on its own (the kernel releases the GIL): half of them on each core.
    bounds = np.linspace(0, p, _THREADS + 1).astype(int)
    list(_in_order(lambda k: play(bounds[k], bounds[k + 1]), range(_THREADS)))
    return out


@njit(cache=True, nogil=True)
def _play_loop(loop, below, above, frac, mirror, out):
    # A row of the output at a time, frame by frame: each frame reads a row of its two
    # planes in order (backwards when mirrored left to right) and writes that frame's
    # slot of the row's pixels, which stay in the L1 cache across the run's frames.
    # Whether the frame is interpolated is decided once per row, not per pixel.
    side = loop.shape[1]
    for r in range(side):
        rr = side - 1 - r if mirror == 0 else r
        dst = out[r]
        for t in range(frac.shape[0]):
            a = loop[below[t], rr]
            f = frac[t]
            if f == 0:
                if mirror == 1:
                    for c in range(side):
                        dst[c, t] = a[side - 1 - c]
                else:
                    for c in range(side):
                        dst[c, t] = a[c]
                continue
            b = loop[above[t], rr]
            if mirror == 1:
                for c in range(side):
                    v = a[side - 1 - c]
                    dst[c, t] = v + f * (b[side - 1 - c] - v)
            else:
                for c in range(side):
                    v = a[c]
                    dst[c, t] = v + f * (b[c] - v)
