"""One Stable Fluids step: state in, state out (Furukawa et al. 2013, sec. 3.1; Stam 1999)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._validation import (
    check_array,
    check_int,
    check_range,
    check_shape_match,
    check_vector_field,
)
from . import _kernels
from ._forces import _add_forces, _check_params, source_mask
from ._grid import _centres, _f64, _project
from ._params import FluidParams

__all__ = ["FluidState", "advect_velocity", "step"]


def _frozen(a):
    a.setflags(write=False)
    return a


def _check_shape(shape):
    if not isinstance(shape, (tuple, list)) or len(shape) != 2:
        raise ValueError(f"shape must be (H, W), got {shape!r}")
    return (
        check_int("shape[0] (H)", shape[0], 2, 4096),
        check_int("shape[1] (W)", shape[1], 2, 4096),
    )


@dataclass(frozen=True)
class FluidState:
    """The solver's state at one instant; immutable (its arrays are read-only).

    Attributes
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (MAC) velocity as (dy, dx) in px/frame: ``velocity[i, j, 0]`` on
        the top face of cell (i, j), ``velocity[i, j, 1]`` on its left face (see
        :mod:`fluidnb.fluid`; :attr:`centred_velocity` gives it at the pixels).
        ``dy < 0`` is up.
    temperature : ndarray, shape (H, W)
        Temperature at cell centres.
    density : ndarray, shape (H, W)
        Passive smoke density at cell centres.
    frame : int
        Number of steps taken since the start.

    Examples
    --------
    >>> s = FluidState.zeros((4, 6))
    >>> s.velocity.shape, s.temperature.shape, s.frame
    ((4, 6, 2), (4, 6), 0)
    """

    velocity: np.ndarray
    temperature: np.ndarray
    density: np.ndarray
    frame: int = 0

    def __post_init__(self):
        v = check_vector_field("velocity", self.velocity)
        h, w = v.shape[:2]
        t = check_array("temperature", self.temperature, ndim=2, dtype_kinds="iuf")
        check_shape_match("temperature", t, (h, w), "the velocity")
        d = check_array("density", self.density, ndim=2, dtype_kinds="iuf")
        check_shape_match("density", d, (h, w), "the velocity")
        frame = check_int("frame", self.frame, 0)
        for name, a in (("velocity", v), ("temperature", t), ("density", d)):
            if a.dtype not in (np.float32, np.float64):
                a = a.astype(np.float64)
            a = _frozen(np.array(a, order="C"))  # never share the caller's memory
            object.__setattr__(self, name, a)
        object.__setattr__(self, "frame", frame)

    @classmethod
    def zeros(cls, shape, params=None):
        """Still air at ambient temperature, no smoke.

        Parameters
        ----------
        shape : tuple of int
            (H, W), each at least 2.
        params : FluidParams, optional
            Supplies ``T_amb`` (default 0).
        """
        h, w = _check_shape(shape)
        t_amb = 0.0 if params is None else _check_params(params).T_amb
        return cls._trusted(np.zeros((h, w, 2)), np.full((h, w), t_amb), np.zeros((h, w)), 0)

    @classmethod
    def _trusted(cls, velocity, temperature, density, frame):
        state = cls.__new__(cls)
        for name, a in (("velocity", velocity), ("temperature", temperature), ("density", density)):
            object.__setattr__(state, name, _frozen(a))
        object.__setattr__(state, "frame", frame)
        return state

    @property
    def shape(self):
        """(H, W) of the grid."""
        return self.temperature.shape

    @property
    def centred_velocity(self):
        """The velocity averaged to cell centres, (H, W, 2) (dy, dx) px/frame."""
        return _centres(np.asarray(self.velocity, dtype=np.float64))

    def __eq__(self, other):
        if not isinstance(other, FluidState):
            return NotImplemented
        return self.frame == other.frame and all(
            np.array_equal(getattr(self, n), getattr(other, n))
            for n in ("velocity", "temperature", "density")
        )

    __hash__ = None


def advect_velocity(velocity, dt=1.0):
    """Carry a staggered velocity field along itself: the first term of Eq. (1).

    Each component is backtraced from its own face and sampled as
    :func:`fluidnb.fields.advect` does (semi-Lagrangian, bilinear, clamped; Stam
    1999; the same arithmetic, compiled), using the full velocity vector interpolated
    to that face. The result is not divergence-free; :func:`fluidnb.fluid.project`
    makes it so.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity (see :mod:`fluidnb.fluid`), px/frame.
    dt : float
        Time step in frames.

    Returns
    -------
    ndarray, shape (H, W, 2)
        The advected velocity, float64.

    Examples
    --------
    >>> v = np.zeros((4, 4, 2))
    >>> v[..., 1] = 0.5  # uniform flow to the right: unchanged by advection
    >>> bool(np.all(advect_velocity(v)[:, 1:, 1] == 0.5))
    True
    """
    v = check_vector_field("velocity", velocity)
    return _advect_velocity(np.asarray(v, dtype=np.float64), check_range("dt", dt))


def _advect_velocity(v, dt):
    # The compiled kernel reads the bottom (dy) and right (dx) walls' unstored faces
    # as zero; see fluidnb.fluid._kernels.advect_velocity for why.
    v = _f64(v)
    new = np.empty(v.shape)
    _kernels.advect_velocity(v, float(dt), np.empty(v.shape), new)
    return new


@lru_cache(maxsize=16)
def _mask(shape, source_x, source_y, source_radius):
    """The source's footprint and the flat indices of its cells (where noise is drawn)."""
    params = FluidParams(source_x=source_x, source_y=source_y, source_radius=source_radius)
    m = _frozen(source_mask(shape, params))
    return m, _frozen(np.flatnonzero(m))


def step(state, params, *, rng=None):
    r"""Advance the flow by one time step ``params.dt``.

    In order (Stam 1999 [2]_, Furukawa et al. (2013), sec. 3.1 [1]_):

    1. advect the velocity through itself, semi-Lagrangian (the first term of
       Eq. (1)), each staggered component backtraced from its own face and
       sampled as :func:`fluidnb.fields.advect` does (bilinear, clamped);
    2. add the forces f of Eq. (1): buoyancy, Eq. (4), upward (dy < 0), and
       vorticity confinement, Eq. (5) [3]_;
    3. project onto divergence-free fields, Eq. (2) and the pressure term of
       Eq. (1): an exact solve of the pressure Poisson equation, a cosine
       transform along x and one tridiagonal solve per x-mode along y (see
       :func:`fluidnb.fluid.project`);
    4. advect temperature and density with the new velocity (Eq. (3), first term);
    5. radiative cooling, the second term of Eq. (3), with :math:`T_{max}` the
       field's maximum measured this step (see :func:`fluidnb.fluid.cool`);
    6. the source: cells in the source disc are raised to ``source_T`` (with
       ``source_flicker`` random variation) and gain ``density_rate * dt`` smoke.

    Parameters
    ----------
    state : FluidState
        The current state (not modified).
    params : FluidParams
        The parameters.
    rng : numpy.random.Generator, optional
        Randomness of the source flicker (only drawn from when
        ``source_flicker > 0``); pass the same generator to every step, e.g.
        ``numpy.random.default_rng(seed)`` made once, for a reproducible run. None:
        fresh entropy, not reproducible. :func:`simulate` takes ``seed=`` and does
        this for you.

    Returns
    -------
    FluidState
        The next state, ``frame`` increased by one.

    Raises
    ------
    ValueError
        If ``state``, ``params`` or ``rng`` is of the wrong type.

    Notes
    -----
    The per-cell work runs in numba-compiled kernels (fused passes, no whole-grid
    temporaries); the cosine transforms are scipy's. The very first call on a machine
    compiles them (several seconds) and caches them on disk; later processes load
    them in a fraction of a second.

    References
    ----------
    .. [1] 古川 歩, 土橋 宜典, 山本 強 (A. Furukawa, Y. Dobashi, T. Yamamoto, 2013),
       "実写画像に類似した流体アニメーションの生成" ("Generating fluid animations
       that resemble real photographs"), section 3.1.
    .. [2] J. Stam, "Stable Fluids", Proceedings of SIGGRAPH 99, pp. 121-128, 1999.
    .. [3] R. Fedkiw, J. Stam, H. W. Jensen, "Visual simulation of smoke",
       Proceedings of SIGGRAPH 2001, pp. 15-22, 2001.

    Examples
    --------
    >>> params = FluidParams(source_flicker=0.0)
    >>> s = FluidState.zeros((32, 32), params)
    >>> for _ in range(10):
    ...     s = step(s, params)
    >>> s.frame, bool(s.velocity[..., 0].min() < 0)  # hot gas rises (dy < 0)
    (10, True)
    """
    if not isinstance(state, FluidState):
        raise ValueError(f"state must be a FluidState, got {type(state).__name__}")
    params = _check_params(params)
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise ValueError(
            "rng must be a numpy Generator (or None), got "
            f"{type(rng).__name__}: make one with numpy.random.default_rng(seed) and "
            "pass the same generator to every step (an int would replay the same "
            "noise on every step)"
        )
    with _kernels.threads_for(state.shape):
        return _step(state, params, rng)


def _step(state, params, rng):
    """The body of :func:`step`, on checked arguments."""
    dt = params.dt
    v = _f64(state.velocity)
    t = _f64(state.temperature)
    d = _f64(state.density)
    shape = t.shape

    # 1. Self-advection.
    new = _advect_velocity(v, dt)

    # 2. Forces, added in place: buoyancy and (epsilon > 0) confinement.
    _add_forces(new, t, params)

    # 3. Projection (walls enforced inside).
    _project(new, params.boundary)

    # 4. Scalars ride the divergence-free velocity, both in one pass, which also
    # measures T_max for step 5.
    t_new, d_new = np.empty(shape), np.empty(shape)
    t_max = _kernels.advect_scalars(t, d, new, float(dt), np.empty(new.shape), t_new, d_new)
    t, d = t_new, d_new

    # 5. Radiative cooling with T_max measured now, and 6. the source: one pass.
    c_r, t_amb = params.C_r, params.T_amb
    span = t_max - t_amb
    cooling = c_r != 0 and dt != 0 and span > 0
    k = 3.0 * c_r * dt / span if cooling else 0.0
    heat = params.source_radius > 0
    hot = params.source_T - t_amb
    noisy = heat and params.source_flicker > 0 and hot > 0
    if heat:
        m, cells = _mask(shape, params.source_x, params.source_y, params.source_radius)
    else:
        m = _frozen(np.zeros((1, 1)))  # unused; read-only like _mask's, one compilation
    if noisy:
        # Only the source's cells read the noise: draw it there alone (row-major order),
        # not over the whole grid (which cost as much as a cosine transform).
        noise = np.zeros(shape)
        gen = np.random.default_rng() if rng is None else rng
        noise.ravel()[cells] = gen.uniform(-1.0, 1.0, size=cells.size)
    else:
        noise = np.zeros((1, 1))
    _kernels.cool_and_heat(
        t, d, cooling, float(t_amb), float(span), float(k), m, heat, float(params.source_T),
        noisy, float(hot), float(params.source_flicker), noise,
        float(params.density_rate * dt) if params.density_rate > 0 else 0.0,
    )  # fmt: skip
    return FluidState._trusted(new, t, d, state.frame + 1)
