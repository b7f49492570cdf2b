r"""A fragment's difference frames :math:`D_i = F_i - A` (Okabe et al., sec. 6), made at rebuild.

The rendering animates with the fragments' difference frames; they are made from a
fragment's frames as soon as the database rebuilds them
(:func:`~fluidnb.videodb.database._frames.rebuild_fragments`, on its threads) and kept
in the database's frame cache, so a render of the same fragments does nothing with
them but blend. They are kept frame-major, ``(L, h, w)``: a renderer plays them a
frame at a time (:func:`~fluidnb.videodb.rendering._loops.play_loops` reads whole
planes).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._validation import check_int

__all__ = ["difference_frames"]


def difference_frames(frames, loop=0, *, out=None):
    r"""A fragment's difference frames :math:`D_i = F_i - A`, cross-faded to loop, frame-major.

    :math:`A = \frac{1}{N} \sum_i F_i` in float32 (summed in frame order, as
    ``frames.mean(axis=0)``), then, with ``loop`` > 0, :func:`loop_crossfade`'s
    equal-power fade of the last ``loop`` frames into the first, in one pass (in
    float64, as it does). Frame-major, as the frames: ``play_loops`` reads a frame's
    plane in order (the blend's pixel-major input is what it writes).

    Parameters
    ----------
    frames : ndarray, shape (N, h, w), float32
        A fragment's frames :math:`F_i`.
    loop : int
        Frames to cross-fade, in [0, N // 2].
    out : ndarray, shape (N - loop, h, w), float32, optional

    Returns
    -------
    ndarray, shape (N - loop, h, w), float32
    """
    f = np.ascontiguousarray(frames, dtype=np.float32)
    loop = check_int("loop", loop, 0, f.shape[0] // 2)
    if out is None:
        out = np.empty((f.shape[0] - loop, *f.shape[1:]), np.float32)
    theta = 0.5 * np.pi * np.arange(1, loop + 1) / (loop + 1)
    _difference_frames(f, np.sin(theta), np.cos(theta), out)
    return out


@njit(cache=True, nogil=True)
def _difference_frames(f, sin, cos, out):
    n = f.shape[0]
    loop = sin.shape[0]
    length = n - loop
    h, w = f.shape[1:]
    # A: the frames summed in order, whole frames at a time (numpy's float32 mean).
    a = f[0].copy()
    for i in range(1, n):
        a += f[i]
    a /= np.float32(n)
    # A row at a time, frame by frame along the row (each pixel's sums still in frame
    # order): the pixels of a row are independent, so their sums go side by side.
    d = np.empty((n, w), np.float32)
    m = np.empty(w)
    for r in range(h):
        for i in range(n):
            for c in range(w):
                d[i, c] = f[i, r, c] - a[r, c]
        for i in range(loop, length):
            for c in range(w):
                out[i, r, c] = d[i, c]
        if loop == 0:
            continue
        # The fade's mean of D (zero but for rounding), in float64 as loop_crossfade.
        m[:] = 0.0
        for i in range(n):
            for c in range(w):
                m[c] += np.float64(d[i, c])
        for j in range(loop):
            for c in range(w):
                mc = m[c] / n
                head = np.float64(d[j, c]) - mc
                tail = np.float64(d[length + j, c]) - mc
                out[j, r, c] = np.float32(mc + sin[j] * head + cos[j] * tail)
