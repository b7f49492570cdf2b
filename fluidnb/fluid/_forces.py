"""Forces (Eq. (4), (5)), radiative cooling (Eq. (3)) and the heat source."""

from __future__ import annotations

import numba
import numpy as np

from .._validation import check_array, check_range, check_vector_field
from . import _kernels
from ._grid import _f64
from ._params import FluidParams

__all__ = ["buoyancy", "cool", "source_mask", "vorticity_confinement"]


def _check_params(params):
    if not isinstance(params, FluidParams):
        raise ValueError(f"params must be a FluidParams, got {type(params).__name__}")
    return params


def buoyancy(temperature, params):
    r"""Buoyancy force of Eq. (4), :math:`f_{buo} = \kappa_b (T - T_{amb})\,\hat y`.

    :math:`\hat y` points up, which in fluidnb's (dy, dx) convention is ``dy < 0``.
    The force is sampled where the staggered velocity lives (dy on the top faces),
    with the temperature averaged across each face. ``params.wind`` adds a horizontal
    push ``wind * (T - T_amb)`` on the left faces.

    Parameters
    ----------
    temperature : ndarray, shape (H, W)
        Temperature at cell centres.
    params : FluidParams
        Supplies ``kappa_b``, ``T_amb`` and ``wind``.

    Returns
    -------
    ndarray, shape (H, W, 2)
        Acceleration (px/frame^2) in the staggered layout (see :mod:`fluidnb.fluid`).

    Examples
    --------
    >>> T = np.zeros((3, 2))
    >>> T[2] = 1.0  # the bottom row is hot
    >>> buoyancy(T, FluidParams(kappa_b=0.1))[..., 0]
    array([[ 0.  ,  0.  ],
           [ 0.  ,  0.  ],
           [-0.05, -0.05]])
    """
    params = _check_params(params)
    t = check_array("temperature", temperature, ndim=2).astype(np.float64)
    return _buoyancy(t, params)


def _buoyancy(t, params):
    t = _f64(t)
    f = np.empty((*t.shape, 2))
    zero = np.zeros(t.shape)  # no confinement push
    _kernels.face_forces(t, zero, zero, float(params.kappa_b), float(params.T_amb),
                         float(params.wind), f)  # fmt: skip
    return f


def _padded(v):
    """The wall-padded planes of a staggered velocity (see _kernels._pad_row)."""
    h, w = v.shape[:2]
    qy, qx = np.empty((h + 1, w)), np.empty((h, w + 1))
    _kernels.pad(v, qy, qx)
    return qy, qx


def _push(qy, qx, shape, epsilon, parts=None):
    """The confinement push epsilon (N x omega) at the centres, from padded planes.

    Zeros for ``epsilon == 0`` or a grid of a single row or column (no curl).
    ``parts``: chunks of rows, one per thread (numba's count if not given).
    """
    h, w = shape
    if epsilon == 0 or h < 2 or w < 2:
        zero = np.zeros((h, w))
        return zero, zero
    fy, fx = np.empty((h, w)), np.empty((h, w))
    parts = numba.get_num_threads() if parts is None else parts
    _kernels.confinement(qy, qx, float(epsilon), parts, fy, fx)
    return fy, fx


def vorticity_confinement(velocity, epsilon):
    r"""Vorticity-confinement force of Eq. (5), :math:`\epsilon\,(N \times \omega)`.

    :math:`\omega` is :func:`fluidnb.fluid.curl` and
    :math:`N = \nabla|\omega| / |\nabla|\omega||` points towards stronger vortices; the
    force spins each vortex up, putting back the small eddies numerical dissipation
    of the semi-Lagrangian step removes (Fedkiw, Stam & Jensen 2001; grid spacing
    h = 1 px). Computed at cell centres with central differences, then averaged to
    the faces.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity, px/frame.
    epsilon : float
        :math:`\epsilon` >= 0.

    Returns
    -------
    ndarray, shape (H, W, 2)
        Acceleration (px/frame^2) in the staggered layout.

    References
    ----------
    .. [1] R. Fedkiw, J. Stam, H. W. Jensen, "Visual simulation of smoke",
       Proceedings of SIGGRAPH 2001, pp. 15-22, 2001.

    Examples
    --------
    >>> vorticity_confinement(np.zeros((4, 4, 2)), 0.5).any()
    np.False_
    """
    v = check_vector_field("velocity", velocity)
    epsilon = check_range("epsilon", epsilon, 0)
    v = _f64(v)
    t = np.zeros(v.shape[:2])
    fy, fx = _push(*_padded(v), t.shape, epsilon)
    f = np.empty(v.shape)
    _kernels.face_forces(t, fy, fx, 0.0, 0.0, 0.0, f)
    return f


def cool(temperature, params, dt=None, *, T_max=None):
    r"""Radiative cooling of Eq. (3) over one step, with the velocity term left out.

    Integrates :math:`dT/dt = -C_r \left(\frac{T - T_{amb}}{T_{max} - T_{amb}}\right)^4`
    exactly over ``dt`` with :math:`T_{max}` held at its value at the start of the
    step (measured as the field's maximum, as in the paper). Writing
    :math:`x = (T - T_{amb}) / (T_{max} - T_{amb})` and :math:`c = C_r / (T_{max} -
    T_{amb})`, :math:`x \leftarrow x / (1 + 3 c\,\Delta t\,x^3)^{1/3}`. Unlike an
    explicit Euler step this can never cool a cell below ambient, whatever ``dt``.
    Cells at or below ambient are unchanged.

    Parameters
    ----------
    temperature : ndarray, shape (H, W)
        Temperature at cell centres.
    params : FluidParams
        Supplies ``C_r``, ``T_amb`` and (if ``dt`` is None) ``dt``.
    dt : float, optional
        Step length in frames (default ``params.dt``).
    T_max : float, optional
        Override the measured maximum (the paper measures it each step).

    Returns
    -------
    ndarray, shape (H, W)
        The cooled temperature, float64.

    Examples
    --------
    The hottest cell cools by about ``C_r`` per frame:

    >>> T = np.array([[1.0, 0.5, 0.0]])
    >>> np.round(cool(T, FluidParams(C_r=0.01)), 3)
    array([[0.99 , 0.499, 0.   ]])
    """
    params = _check_params(params)
    t = check_array("temperature", temperature, ndim=2).astype(np.float64)
    dt = params.dt if dt is None else check_range("dt", dt, 0)
    if T_max is not None:
        T_max = check_range("T_max", T_max)
    return _cool(t, params.C_r, params.T_amb, dt, T_max)


def _cool(t, c_r, t_amb, dt, t_max=None):
    if t_max is None:
        t_max = float(t.max()) if t.size else t_amb
    span = t_max - t_amb
    if c_r == 0 or dt == 0 or span <= 0:
        return t.copy()
    t = _f64(t)
    out = np.empty(t.shape)
    _kernels.cool(t, float(t_amb), float(span), *_cooling_rate(c_r, dt, span), out)
    return out


#: The cooling rate ``k`` is capped here: beyond it every cell above ambient cools to
#: ambient within 1e-100 of the span in one step anyway, and an infinite k (a span
#: of a few 1e-308) would turn 0 * k into NaN.
_MAX_RATE = 1e300


def _cooling_rate(c_r, dt, span):
    """``k = 3 C_r dt / span`` of the exact cooling step, and ``k ** (-1/3)``."""
    k = min(3.0 * c_r * dt / span, _MAX_RATE)
    return k, 1.0 / float(np.cbrt(k))


def source_mask(shape, params):
    """The heat source's footprint: 1 inside the disc, a one-pixel soft edge, 0 outside.

    Parameters
    ----------
    shape : tuple of int
        (H, W) of the grid.
    params : FluidParams
        Supplies ``source_x``, ``source_y`` (fractions) and ``source_radius``
        (fraction of the width).

    Returns
    -------
    ndarray, shape (H, W)
        Weights in [0, 1], float64.

    Examples
    --------
    >>> m = source_mask((32, 32), FluidParams())
    >>> bool(m[29, 16] == 1.0), bool(m[5, 16] == 0.0)
    (True, True)
    """
    params = _check_params(params)
    h, w = shape
    if params.source_radius == 0:
        return np.zeros((h, w))
    cy = params.source_y * h - 0.5
    cx = params.source_x * w - 0.5
    r = max(params.source_radius * w, 0.5)
    yy, xx = np.mgrid[0:h, 0:w]
    dist = np.hypot(yy - cy, xx - cx)
    return np.clip(r + 0.5 - dist, 0.0, 1.0)
