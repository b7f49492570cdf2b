r"""The per-frame passes of flicker, compiled: one pass over the pixels instead of a dozen.

At 1920 x 1080 a frame is 2 million pixels, and the numpy versions -- the bump-mapped
Lambert shading (:func:`fluidnb.flicker._shading._lambert_frame`), the relighting
(``_Relight.frame``) and the noise's soft clip (:func:`fluidnb.flicker.soft_clip`) --
each make a dozen passes over it with temporaries; a 64-frame loop spent more time
there than in the spectrum. These do the same arithmetic in the same order and
precision (float32, no fused multiply-add: numba contracts nothing without
``fastmath``), one pixel at a time, so they give the numpy versions' results (tested
in ``tests/flicker/test_kernels.py``, which keeps those as the reference).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = []


@njit(cache=True, nogil=True, error_model="numpy")
def soft_heights(rows, scale, knee, amplitude):
    r"""``rows = A * soft_clip(rows * scale, knee)`` in place, (n, m) float32.

    As ``row *= scale; soft_clip(row, knee, out=row); row *= A`` (the noise's
    normalisation, :meth:`FlickerModel._heights`).
    """
    k = np.float32(knee)
    span = np.float32(1) - k
    one = np.float32(1)
    flat = rows.reshape(-1)
    for i in range(flat.size):
        u = flat[i] * scale
        inner = min(max(u, -k), k)
        r = (u - inner) / span
        r = r / (abs(r) + one)
        flat[i] = (r * span + inner) * amplitude


@njit(cache=True, nogil=True, error_model="numpy")
def shade_relight(hs, light, kw, offset, cap, clamp_black, channels, out):
    r"""One frame: Lambert shading of the pre-scaled heights, then the relit photo.

    :math:`S = \max(0, n \cdot l)` with :math:`n \propto (-p, q, 1)` from central
    differences (one-sided at the border, twice the slope as ``_lambert_frame``),
    then :math:`O = I \min(\max(0, k w S + (1 - k w S_0)), 1 / \max_c I)`.

    Parameters
    ----------
    hs : (h, w) float32
        Heights times ``bump / (2 pixel_size)``.
    light : (3,) float32
        Towards the light (x right, y up, z out).
    kw, offset, cap : (h, w) float32
        :math:`k w`, :math:`1 - k w S_0` and :math:`1 / \max_c I` (``_Relight``).
    clamp_black : bool
        Whether the factor can go below 0 (``k w > 1`` somewhere).
    channels : (C, h, w) float32
        The photo, channel-first.
    out : (h, w, C) float32
        The frame (may be a strided view of a larger one).
    """
    h, w = hs.shape
    lx, ly, lz = light[0], light[1], light[2]
    nlx = -lx
    one = np.float32(1)
    two = np.float32(2)
    zero = np.float32(0)
    n_channels = channels.shape[0]
    gx = np.zeros(w, np.float32)
    gy = np.zeros(w, np.float32)
    factor = np.empty(w, np.float32)
    for r in range(h):
        # The row's slopes first, border cases outside the loops, so the loops over
        # the columns have no branch and vectorise.
        if w > 1:
            for c in range(1, w - 1):
                gx[c] = hs[r, c + 1] - hs[r, c - 1]
            gx[0] = (hs[r, 1] - hs[r, 0]) * two
            gx[w - 1] = (hs[r, w - 1] - hs[r, w - 2]) * two
        if h > 1:
            if r == 0:
                for c in range(w):
                    gy[c] = (hs[1, c] - hs[0, c]) * two
            elif r == h - 1:
                for c in range(w):
                    gy[c] = (hs[h - 1, c] - hs[h - 2, c]) * two
            else:
                for c in range(w):
                    gy[c] = hs[r + 1, c] - hs[r - 1, c]
        for c in range(w):
            s = gx[c] * nlx + gy[c] * ly + lz
            s = s / np.sqrt(gx[c] * gx[c] + gy[c] * gy[c] + one)
            s = max(s, zero)
            f = s * kw[r, c] + offset[r, c]
            if clamp_black:
                f = max(f, zero)
            factor[c] = min(f, cap[r, c])
        for k in range(n_channels):
            for c in range(w):
                out[r, c, k] = channels[k, r, c] * factor[c]
