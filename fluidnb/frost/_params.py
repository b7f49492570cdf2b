"""The frost method's parameters, with the paper's values as defaults."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["FrostParams"]


@dataclass(frozen=True)
class FrostParams(Params):
    r"""Parameters of the frost growth (Reiter's automaton with a random threshold).

    Defaults are the paper's experiment (Sec. 4: :math:`\beta = 0.35`,
    :math:`\gamma = 0.005`, :math:`r_{th} = 0`, a 24 fps clip, target 130 frames) and
    Reiter's diffusion weight :math:`\alpha = 1` (the paper leaves :math:`\alpha` to
    the user; Reiter's figures use 1).

    Parameters
    ----------
    beta : float
        :math:`\beta`, the initial vapour level :math:`u_0(p) = \beta` of every cell
        (Sec. 3.2); larger is faster growth. In [0, 1].
    gamma : float
        :math:`\gamma`, the constant vapour added each step to ice cells and to
        frontier cells whose random number exceeds :math:`r_{th}` (Eq. (1)). In [0, 1].
    alpha : float
        :math:`\alpha`, the diffusion weight of :math:`D_t(p) = \frac{\alpha}{12}
        (-6 u_t(p) + \sum_{q \in nn(p)} u_t(q))` (Eq. (1)). In [0, 2]: up to 2 each
        new value is a weighted mean of the old ones (weight :math:`1 - \alpha/2` on the
        cell itself), so vapour never turns negative or oscillates.
    rth : float
        :math:`r_{th}`, the random threshold: a frontier cell gets :math:`\gamma` only
        when its fresh :math:`r_t(p) \sim U[0, 1]` exceeds it (Eq. (1)). 0 is Reiter's
        model; larger values give more irregular, frost-like growth. In [0, 1].
    spacing : float
        Distance between lattice points in pixels (Sec. 3.1). Smaller means more cells:
        finer frost that takes more frames to fill the region.
    coverage : float
        The run ends at the first frame with at least this fraction of the region's
        cells frozen (Sec. 3.4: 9 in 10). In (0, 1].
    max_frames : int
        Frame limit of one run (a run that has not ended by then reports so).
    target : int
        :math:`T`, the target end frame of the optimisation, Eq. (2).
    fps : float
        Frames per second of the clip. The optimiser stops when
        :math:`|T - T_{sim}|` is within 1/6 s of frames (24 fps: 4 frames, Sec. 3.4).

    Examples
    --------
    >>> FrostParams().replace(rth=0.8).rth
    0.8
    >>> FrostParams(alpha=3)
    Traceback (most recent call last):
    ...
    ValueError: alpha must be in [0, 2], got 3
    >>> FrostParams().tolerance  # frames within 1/6 s at 24 fps
    4.0
    """

    beta: float = param(
        0.35,
        lo=0,
        hi=1,
        symbol=r"\beta",
        eq="Sec. 3.2, $u_0(p)=\\beta$",
        doc="initial vapour level of every cell (faster growth when larger)",
        step=0.005,
    )
    gamma: float = param(
        0.005,
        lo=0,
        hi=1,
        symbol=r"\gamma",
        eq="Eq. (1)",
        doc="vapour added each step to ice and (if r > rth) frontier cells",
        log=True,
        ui_range=(1e-4, 1.0),  # up to 1: hand-painted regions need gamma >> 0.005 to end soon
    )
    alpha: float = param(
        1.0,
        lo=0,
        hi=2,
        symbol=r"\alpha",
        eq="Eq. (1), $D_t$",
        doc="diffusion weight (Reiter's default 1)",
        step=0.05,
    )
    rth: float = param(
        0.0,
        lo=0,
        hi=1,
        symbol=r"r_{th}",
        eq="Eq. (1)",
        doc="random threshold: frontier cells get gamma only when r > rth",
        step=0.05,
    )
    spacing: float = param(
        4.0,
        lo=0,
        hi=256,
        lo_open=True,
        doc="distance between lattice points",
        unit="px",
        step=0.5,
        ui_range=(2, 24),
    )
    coverage: float = param(
        0.9,
        lo=0,
        hi=1,
        lo_open=True,
        doc="end frame: first frame with this fraction of the region frozen",
        step=0.01,
        ui_range=(0.5, 1.0),
    )
    max_frames: int = param(
        1000,
        lo=1,
        hi=100_000,
        integer=True,
        doc="frame limit of one run",
        unit="frames",
        ui_range=(50, 3000),
        step=10,
    )
    target: int = param(
        130,
        lo=1,
        hi=100_000,
        integer=True,
        symbol="T",
        eq="Eq. (2)",
        doc="target end frame for the beta optimisation",
        unit="frames",
        ui_range=(10, 1000),
    )
    fps: float = param(
        24.0,
        lo=0,
        hi=240,
        lo_open=True,
        doc="frames per second; the optimiser stops within 1/6 s of frames",
        unit="fps",
        step=1,
        ui_range=(1, 60),
    )

    def check(self):
        """The target end frame must lie within the frame limit."""
        if self.target > self.max_frames:
            raise ValueError(f"target must be <= max_frames ({self.max_frames}), got {self.target}")

    @property
    def tolerance(self):
        """Frames within 1/6 s at :attr:`fps`: the optimiser's stopping band (Sec. 3.4)."""
        return self.fps / 6.0
