"""Colour maps for temperature and smoke fields (library-side, for Clips and canvases)."""

from __future__ import annotations

import numpy as np

from .._validation import check_array, check_range

__all__ = ["temperature_to_rgb"]

# A black-body-like ramp: black, deep red, orange, yellow, near-white.
_STOPS = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
_COLOURS = np.array(
    [
        [0.0, 0.0, 0.0],
        [0.55, 0.05, 0.0],
        [0.95, 0.35, 0.02],
        [1.0, 0.75, 0.15],
        [1.0, 1.0, 0.85],
    ]
)


def temperature_to_rgb(temperature, *, T_amb=0.0, T_max=1.0):
    """Colour-map a temperature field (or a stack of them) like glowing gas.

    Parameters
    ----------
    temperature : array_like, shape (..., H, W)
        Temperatures; one frame or many.
    T_amb, T_max : float
        The temperatures drawn black and near-white; values outside are clipped.

    Returns
    -------
    ndarray, shape (..., H, W, 3)
        float32 RGB in [0, 1], ready for :class:`fluidnb.Clip`.

    Examples
    --------
    >>> temperature_to_rgb(np.array([[0.0, 1.0]]))
    array([[[0.  , 0.  , 0.  ],
            [1.  , 1.  , 0.85]]], dtype=float32)
    """
    t = check_array("temperature", temperature, dtype_kinds="iuf")
    T_amb = check_range("T_amb", T_amb)
    T_max = check_range("T_max", T_max, T_amb, lo_open=True)
    x = np.clip((t.astype(np.float64) - T_amb) / (T_max - T_amb), 0.0, 1.0)
    out = np.empty((*x.shape, 3), dtype=np.float32)
    for k in range(3):
        out[..., k] = np.interp(x, _STOPS, _COLOURS[:, k])
    return out
