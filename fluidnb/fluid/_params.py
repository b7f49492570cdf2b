"""Parameters of the 2-D Stable Fluids flame/smoke solver (Furukawa et al. 2013, sec. 3.1)."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["BOUNDARIES", "FluidParams"]

#: Boundary conditions the pressure projection offers (see :func:`fluidnb.fluid.project`).
BOUNDARIES = ("open_top", "closed")

#: How far (px) buoyancy or side wind may push the hottest gas within one step,
#: ``kappa_b (T - T_amb) dt^2``. A CFL-like bound: at 16 px a 64 x 64 flame still
#: settles near 40 px/frame; far beyond it the gas outruns the grid in a step and the
#: velocities grow without bound (kappa_b = 1e12 reached 1e11 px/frame).
MAX_PUSH_PX = 16.0

#: Largest ``epsilon * dt``: confinement multiplies the swirl by about
#: ``1 + epsilon dt`` a step; measured, 2 stays bounded and 3 diverges.
MAX_EPSILON_DT = 2.0

#: The largest magnitude of a temperature parameter (``T_amb``, ``source_T``): wide
#: enough for kelvins, and with it every field and force stays far from overflow.
MAX_TEMPERATURE = 1e4

#: The largest strength of a force coefficient (``kappa_b``, ``epsilon``, ``|wind|``)
#: and of the cooling and smoke rates (``C_r``, ``density_rate``), per frame. The
#: cross-field rules of :meth:`FluidParams.check` bound the forces more tightly; these
#: close the doors they leave open (a tiny ``dt`` let ``kappa_b = 1e12`` through) and
#: keep a long run's smoke finite (``density_rate`` times the frames).
MAX_RATE = 100.0


@dataclass(frozen=True)
class FluidParams(Params):
    r"""Parameters of :func:`fluidnb.fluid.step` and :func:`fluidnb.fluid.simulate`.

    The paper [1]_ gives the equations but no values. The defaults here were
    chosen by eye to give a convincing 2-D flame at 128 x 128 (the paper's grid) in a
    few dozen frames; they are not the paper's. Temperatures are dimensionless:
    ambient ``T_amb = 0``, source ``source_T = 1``.

    Units: lengths in pixels (grid cells), time in frames (``dt = 1`` is one frame),
    velocities in pixels per frame, as everywhere in fluidnb.

    Every parameter has a range that keeps the simulation finite (temperatures within
    ``MAX_TEMPERATURE``, rates and force coefficients within ``MAX_RATE``), and
    :meth:`check` bounds how far the forces may carry the gas in one step.

    Attributes
    ----------
    dt : float
        Time step :math:`\Delta t` of Eq. (1)-(3), in frames.
    kappa_b : float
        Buoyancy coefficient :math:`\kappa_b` of Eq. (4): the upward acceleration
        per unit of temperature above ambient (px / frame^2).
    epsilon : float
        Vorticity-confinement strength :math:`\epsilon` of Eq. (5) [3]_ (grid
        spacing h = 1 px absorbed).
    C_r : float
        Radiative cooling constant :math:`C_r` of Eq. (3): the hottest cell cools by
        ``C_r`` per frame, cooler cells by ``C_r`` times the fourth power of their
        relative excess temperature.
    T_amb : float
        Ambient temperature :math:`T_{amb}` of Eq. (3), (4).
    source_x, source_y : float
        Centre of the heat source as fractions of the width and height
        (0, 0 = top left). Default: bottom centre.
    source_radius : float
        Radius of the (disc-shaped, soft-edged) source as a fraction of the width;
        0 switches the source off.
    source_T : float
        Temperature the source imposes (cells inside are raised to it).
    source_flicker : float
        Random per-cell, per-step variation of the source temperature, as a
        fraction of ``source_T - T_amb`` (0 = steady source, deterministic run).
    density_rate : float
        Passive smoke density added per frame inside the source (0 = none).
    wind : float
        Side wind: a horizontal acceleration (px / frame^2, > 0 to the right) acting
        on the hot gas in proportion to ``T - T_amb``. A uniform force would be a
        pure pressure gradient in a closed box and be projected away.
    boundary : {"open_top", "closed"}
        ``"open_top"``: solid walls (zero normal velocity) left, right and at the
        bottom, an open top (pressure 0 outside, gas leaves freely).
        ``"closed"``: solid walls on all four sides.

    References
    ----------
    .. [1] 古川 歩, 土橋 宜典, 山本 強 (A. Furukawa, Y. Dobashi, T. Yamamoto, 2013),
       "実写画像に類似した流体アニメーションの生成" ("Generating fluid animations
       that resemble real photographs"), section 3.1, Eq. (1)-(5).
    .. [2] J. Stam, "Stable Fluids", Proceedings of SIGGRAPH 99, pp. 121-128, 1999.
    .. [3] R. Fedkiw, J. Stam, H. W. Jensen, "Visual simulation of smoke",
       Proceedings of SIGGRAPH 2001, pp. 15-22, 2001.

    Examples
    --------
    >>> FluidParams().boundary
    'open_top'
    >>> FluidParams(C_r=-1)
    Traceback (most recent call last):
    ...
    ValueError: C_r must be in [0, 100], got -1
    """

    dt: float = param(
        1.0,
        lo=0,
        hi=10,
        lo_open=True,
        symbol=r"\Delta t",
        eq="Eq. (1)-(3)",
        doc="time step",
        unit="frames",
        ui_range=(0.1, 2.0),
        step=0.05,
    )
    kappa_b: float = param(
        0.15,
        lo=0,
        hi=MAX_RATE,
        symbol=r"\kappa_b",
        eq="Eq. (4)",
        doc="buoyancy per unit temperature",
        ui_range=(0.0, 0.3),
        step=0.005,
    )
    epsilon: float = param(
        0.4,
        lo=0,
        hi=MAX_RATE,
        symbol=r"\epsilon",
        eq="Eq. (5)",
        doc="vorticity confinement strength",
        ui_range=(0.0, 1.5),
        step=0.05,
    )
    C_r: float = param(
        0.05,
        lo=0,
        hi=MAX_RATE,
        symbol=r"C_r",
        eq="Eq. (3)",
        doc="radiative cooling constant",
        ui_range=(0.0, 0.1),
        step=0.001,
    )
    T_amb: float = param(
        0.0,
        lo=-MAX_TEMPERATURE,
        hi=MAX_TEMPERATURE,
        symbol=r"T_{amb}",
        eq="Eq. (3), (4)",
        doc="ambient temperature",
        ui_range=(-1.0, 1.0),
        step=0.05,
    )
    source_x: float = param(0.5, lo=0, hi=1, doc="source centre, fraction of the width", step=0.01)
    source_y: float = param(
        0.92, lo=0, hi=1, doc="source centre, fraction of the height (1 = bottom)", step=0.01
    )
    source_radius: float = param(
        0.05, lo=0, hi=0.5, doc="source radius, fraction of the width (0 = off)", step=0.005
    )
    source_T: float = param(
        1.0,
        lo=-MAX_TEMPERATURE,
        hi=MAX_TEMPERATURE,
        doc="temperature imposed by the source",
        ui_range=(0.0, 3.0),
        step=0.05,
    )
    source_flicker: float = param(
        0.5, lo=0, hi=1, doc="random variation of the source temperature (0 = steady)", step=0.05
    )
    density_rate: float = param(
        0.0,
        lo=0,
        hi=MAX_RATE,
        doc="smoke density added per frame in the source",
        ui_range=(0, 0.5),
        step=0.01,
    )
    wind: float = param(
        0.0,
        lo=-MAX_RATE,
        hi=MAX_RATE,
        doc="side wind on the hot gas (> 0 to the right)",
        unit="px/frame^2",
        ui_range=(-0.1, 0.1),
        step=0.005,
    )
    boundary: str = param("open_top", choices=BOUNDARIES, doc="boundary conditions")

    def check(self):
        """The source is not colder than the air, and the forces stay within a step.

        Semi-Lagrangian advection never blows up by itself, but forces that move the
        gas farther than the grid in one step do: the buoyancy and wind push of the
        hottest gas is bounded by ``MAX_PUSH_PX`` and ``epsilon * dt`` by
        ``MAX_EPSILON_DT`` (see their comments).
        """
        if self.source_T < self.T_amb:
            raise ValueError(f"source_T must be >= T_amb ({self.T_amb:g}), got {self.source_T:g}")
        hot = (self.source_T - self.T_amb) * (1.0 + self.source_flicker)
        for name, coef in (("kappa_b", self.kappa_b), ("wind", abs(self.wind))):
            push = coef * hot * self.dt**2
            if not push <= MAX_PUSH_PX:
                raise ValueError(
                    f"{name} * (source_T - T_amb) * (1 + source_flicker) * dt**2 must be "
                    f"<= {MAX_PUSH_PX:g} px (how far the force carries the hottest gas in "
                    f"one step; beyond it the flow outruns the grid and blows up), got "
                    f"{push:.3g} with {name}={coef:g}, source_T={self.source_T:g}, "
                    f"T_amb={self.T_amb:g}, dt={self.dt:g}: lower {name}, source_T or dt"
                )
        if not self.epsilon * self.dt <= MAX_EPSILON_DT:
            raise ValueError(
                f"epsilon * dt must be <= {MAX_EPSILON_DT:g} (vorticity confinement "
                f"multiplies the swirl by about 1 + epsilon * dt a step and diverges "
                f"beyond), got epsilon={self.epsilon:g}, dt={self.dt:g}"
            )
