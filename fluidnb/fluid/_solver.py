"""One Stable Fluids step: state in, state out (Furukawa et al. 2013, sec. 3.1; Stam 1999)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numba
import numpy as np

from .._validation import (
    check_array,
    check_int,
    check_range,
    check_shape_match,
    check_vector_field,
)
from . import _kernels
from ._forces import _check_params, _cooling_rate, _push, source_mask
from ._grid import _centres, _f64
from ._params import FluidParams
from ._poisson import poisson_solver
from ._threads import CHOOSER

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
    v = _f64(v)
    h, w = v.shape[:2]
    ay, ax = _advected(v, dt)
    new = np.empty(v.shape)
    new[..., 0] = ay[:h]
    new[..., 1] = ax[:, :w]
    return new


def _advected(v, dt):
    """The self-advected velocity as its wall-padded planes (see _kernels._pad_row)."""
    h, w = v.shape[:2]
    size_y, size_x = (h + 1, w), (h, w + 1)
    ay, ax = np.empty(size_y), np.empty(size_x)
    _kernels.advect_velocity(v, float(dt), np.empty(size_y), np.empty(size_x), ay, ax)
    return ay, ax


@lru_cache(maxsize=16)
def _source(shape, source_x, source_y, source_radius):
    """The source's cells (flat indices, row-major: where noise is drawn) and weights."""
    params = FluidParams(source_x=source_x, source_y=source_y, source_radius=source_radius)
    m = source_mask(shape, params)
    cells = np.flatnonzero(m)
    return _frozen(cells), _frozen(m.ravel()[cells])


_NO_NOISE = _frozen(np.zeros(0))


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
    The per-cell work runs in numba-compiled kernels (six fused passes, no whole-grid
    temporaries; see :mod:`fluidnb.fluid._kernels`); the FFTs are scipy's. The very
    first call on a machine compiles them (about 20 s on a busy 2-core machine) and
    caches them on disk; later processes load them in a fraction of a second. A step
    runs on one thread or on numba's (``numba.get_num_threads()``), whichever measured
    faster on this grid (:mod:`fluidnb.fluid._threads`; ``numba.set_num_threads(1)``
    pins one); the result is the same bit for bit either way.

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
    with CHOOSER.step(state.shape) as threads:
        return _step(state, params, rng, threads)


def _step(state, params, rng, threads=None):
    """The body of :func:`step`, on checked arguments: the numbered steps in order.

    ``threads``: numba's thread count for this step (looked up if not given).
    """
    p, dt = params, float(params.dt)
    v = _f64(state.velocity)
    t = _f64(state.temperature)
    d = _f64(state.density)
    shape = t.shape
    # Chunks of rows for the kernels that run bottom-up: one per thread.
    parts = numba.get_num_threads() if threads is None else threads
    # 1. Self-advection.
    ay, ax = _advected(v, dt)
    # 2. Forces: the confinement push from the advected velocity, then, in one pass
    # with the walls and the divergence, buoyancy and the push added on the faces.
    fy, fx = _push(ay, ax, shape, p.epsilon, parts)
    solver = poisson_solver(shape, p.boundary, "fast")
    by, bx, div = np.empty(shape), np.empty(shape), np.empty(shape)
    _kernels.forces_and_divergence(
        ay, ax, t, fy, fx, dt, float(p.kappa_b), float(p.T_amb), float(p.wind),
        p.boundary == "closed", solver.pos, parts, by, bx, div,
    )  # fmt: skip
    # 3. The pressure, and 4. in one pass its gradient subtracted and the scalars
    # carried along the divergence-free velocity (measuring T_max for 5).
    pressure, p0 = solver.pressure(div, parts)
    vy, vx, t_new, d_new = (np.empty(shape) for _ in range(4))
    new = np.empty((*shape, 2))
    t_max = _kernels.gradient_and_scalars(
        by, bx, pressure, solver.pos, p.boundary == "open_top", p0, t, d, dt, parts,
        vy, vx, new, t_new, d_new,
    )  # fmt: skip
    # 5. Radiative cooling with T_max measured now, in place.
    span = t_max - p.T_amb
    if p.C_r != 0 and dt != 0 and span > 0:
        k, k_root = _cooling_rate(p.C_r, dt, span)
        _kernels.cool(t_new, float(p.T_amb), float(span), float(k), float(k_root), t_new)
    # 6. The source, over its own cells.
    if p.source_radius > 0:
        _heat(t_new, d_new, p, rng)
    return FluidState._trusted(new, t_new, d_new, state.frame + 1)


def _heat(t, d, p, rng):
    """Step 6 in place on ``t`` and ``d``: the source disc's heat and smoke."""
    cells, weights = _source(t.shape, p.source_x, p.source_y, p.source_radius)
    hot = p.source_T - p.T_amb
    noisy = p.source_flicker > 0 and hot > 0
    noise = _NO_NOISE
    if noisy:
        # One number per source cell, row-major (a whole-grid draw cost as much as a
        # cosine transform).
        gen = np.random.default_rng() if rng is None else rng
        noise = gen.uniform(-1.0, 1.0, size=cells.size)
    _kernels.heat(
        t, d, cells, weights, float(p.source_T), noisy, float(p.T_amb), float(hot),
        float(p.source_flicker), noise, float(p.density_rate * p.dt),
    )  # fmt: skip
