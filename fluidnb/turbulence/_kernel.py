"""The energy of Eq. (2) at one window position, compiled: the kernel every search shares.

The weights of Eq. (2) are folded into the channels beforehand (see
:func:`fluidnb.turbulence.local_features`), so the energy is one plain sum of squared
differences over a ``B x B`` patch and its channels. Both arrays are stored with a
patch row as one contiguous run: ``S2`` is the source ``S`` (H, W, C) seen as
(H, W * C) and ``X2`` the target patches (P, B, B, C) as (P, B, B * C).
:func:`fluidnb.turbulence._reference.energy` is the same sum in one line of numpy.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, fastmath=True)
def _row_ssd(S2, X2, p, y, o, i):
    # A patch row is a contiguous run of B * C values in both arrays, so this loop
    # vectorises (fastmath lets it reorder this row's sum; rows add up in order).
    # Both runs are taken as slices: indexing ``row[o + k]`` instead would make
    # numba guard every access against negative (wrap-around) indices, which
    # blocks vectorisation and made every search 2.5-4x slower.
    xr = X2[p, i]
    row = S2[y, o : o + xr.shape[0]]
    e = 0.0
    for k in range(xr.shape[0]):
        d = xr[k] - row[k]
        e += d * d
    return e


@njit(cache=True)
def _ssd(S2, X2, p, y, x, c):
    e = 0.0
    for i in range(X2.shape[1]):
        e += _row_ssd(S2, X2, p, y + i, x * c, i)
    return e
