"""The flicker method's parameters, with the paper's values as defaults."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["MAPPINGS", "NOISE_NORMS", "FlickerParams"]

#: The mapping surfaces: the paper's Eq. (7) plane, Eq. (8) convex, Eq. (9) concave
#: (Yamamoto & Sakamoto, sec. 3.2), and "flow", a plane tilted by a velocity (beyond
#: the paper: ripples carried one way, for streams).
MAPPINGS = ("plane", "convex", "concave", "flow")
#: How the noisy field is brought to the height's range (Eq. (10) leaves it open).
NOISE_NORMS = ("rms", "peak")
#: Which half of the sine each pixel starts on (Eq. (3) and the text after it).
BRANCHES = ("rising", "falling")

# 128/255: the paper's A = C = 128 on the 0..255 scale, so C - A = 0 and every
# luminance has an initial phase (Eq. (3) needs |H(0) - C| <= A).
_HALF = 128 / 255


@dataclass(frozen=True)
class FlickerParams(Params):
    r"""Parameters of the flicker ("yuragi") animation (Yamamoto & Sakamoto).

    The defaults are the paper's experiment (Sec. 4.1): a loop of ``T = 64``
    frames at 8 fps, ``f0 = 4`` oscillations per loop (0.5 Hz), the convex mapping of
    Eq. (8) with 1/f² noise (Eq. (10), ``beta = 2``), ``A = C = 128/255``.

    Attributes
    ----------
    mapping : {"convex", "plane", "concave"}
        The surface the 2-D spectrum is mapped onto (Sec. 3.2): ``"plane"``
        :math:`f_c = f_0` (Eq. (7): the simple harmonic motion of Eq. (1)),
        ``"convex"`` :math:`f_c = f_0 + \kappa' (\nu_x^2 + \nu_y^2)` (Eq. (8): fine
        detail moves faster), ``"concave"`` :math:`f_c = f_0 - \kappa' (\nu_x^2 +
        \nu_y^2)` (Eq. (9): fine detail moves slower, the paper's unnatural case),
        ``"flow"`` :math:`f_c = f_0 - T \, (v \cdot \nu)` (beyond the paper: every
        spatial frequency travels along the velocity :math:`v` given to
        :func:`~fluidnb.flicker.flicker` as ``flow=``; :math:`v = 0` is the plane).
    T : int
        :math:`T`, the number of frames, which is also the period of the loop
        (Eq. (5)); >= 2.
    f0 : int
        :math:`f_0`, the temporal frequency of the plane and of the surfaces' apex, in
        oscillations per loop (Eq. (7)-(9)); ``f0 < T / 2``. The dominant frequency
        is ``f0 * fps / T`` Hz.
    kappa : float
        :math:`\kappa`, the curvature of the convex and concave surfaces, relative:
        ``kappa = 1`` maps the finest spatial frequency of the full-resolution image
        (the Nyquist corner, :math:`\nu_x^2 + \nu_y^2 = 1/2` cycles²/pixel²) to the
        highest temporal bin below :math:`T/2`; 0 gives the plane. The absolute
        curvature is :math:`\kappa' = \kappa \, (\lceil T/2 \rceil - 1 - f_0) / (1/2)`
        bins per (cycle/pixel)².
    beta : float
        :math:`\beta`, the noise exponent: the power at :math:`\Delta f` bins from
        :math:`f_c` is :math:`1/\Delta f^\beta` (Eq. (10), the paper's
        :math:`\beta = 2`). 0 switches the noise off.
    noise_norm : {"rms", "peak"}
        How the noisy field is scaled to the height's range. ``"rms"`` (default, our
        decision): the same RMS height swing as the clip without noise, then a soft
        clip into :math:`[C - A, C + A]` (which takes a fifth to a quarter off the
        loudest frames). ``"peak"``: divided by its peak over the
        loop (Eq. (10) taken literally): every height stays in range, but the few
        frames where the random phases add up set the scale, so the typical swing
        is about half the noise-free one.
    noise_regions : int
        Beyond the paper. Eq. (10)'s random phase :math:`\phi(f_t)` is shared by every
        spatial frequency, so the noise swells and calms the whole region at once (the
        paper names this its open problem, sec. 5, and suggests flickering regions
        differently). With ``n > 1`` the region is split into ``n`` soft regions
        (a smooth partition of unity around random centres), each with its own
        :math:`\phi`; 1 (default) is Eq. (10) as written.
    A : float
        :math:`A`, the amplitude of the height's oscillation (Eq. (1), (3)), on the
        [0, 1] scale (the paper's 128 of 255).
    C : float
        :math:`C`, the centre of the oscillation (Eq. (1), (3)).
    branch : {"rising", "falling"}
        Whether every pixel starts on the rising half of the sine,
        :math:`|\alpha| \le \pi/2`, or on the falling half,
        :math:`\pi/2 < |\alpha| \le \pi` (Eq. (3)).
    azimuth : float
        Direction the parallel light comes from, degrees counter-clockwise from the
        image's +x axis (0 = from the right, 90 = from the top).
    elevation : float
        Height of the light above the image plane, degrees (90 = straight down).
    bump : float
        Relief of the bump map [6]: a height change of 1 (the full [0, 1] range)
        rises ``bump`` pixels.
    k : float
        Shading strength: output :math:`O_t = I \, (1 + k (S_t - S_0))`.
    feather : float
        Width in pixels of the soft inner edge of the painted region (pixels outside
        the region never change).
    fps : float
        Frames per second of the clip (the paper: 8).
    """

    mapping: str = param(
        "convex",
        choices=MAPPINGS,
        eq="Sec. 3.2, Eq. (7)-(9)",
        doc="surface the spectrum is mapped onto: plane = Eq. (1); convex = fine detail faster",
    )
    T: int = param(
        64,
        lo=2,
        hi=1024,
        integer=True,
        symbol="T",
        eq="Eq. (5)",
        doc="frames in the loop (its period)",
        unit="frames",
        ui_range=(8, 128),
    )
    f0: int = param(
        4,
        lo=0,
        hi=511,
        integer=True,
        symbol="f_0",
        eq="Eq. (7)-(9)",
        doc="oscillations per loop of the plane / the surface's apex; f0 < T/2",
        unit="per loop",
        ui_range=(0, 16),
    )
    kappa: float = param(
        1.0,
        lo=0,
        hi=16,
        symbol=r"\kappa",
        eq="Eq. (8)-(9)",
        doc="curvature: 1 maps the finest detail just below T/2, 0 is the plane",
        step=0.05,
        ui_range=(0, 2),
    )
    beta: float = param(
        2.0,
        lo=0,
        hi=8,
        symbol=r"\beta",
        eq="Eq. (10)",
        doc="noise exponent, power 1/df^beta around fc; 0 = no noise",
        step=0.1,
        ui_range=(0, 4),
    )
    noise_norm: str = param(
        "rms",
        choices=NOISE_NORMS,
        eq="Eq. (10)",
        doc="scale the noisy field to the no-noise RMS swing (soft clip) or to its peak",
    )
    noise_regions: int = param(
        1,
        lo=1,
        hi=16,
        integer=True,
        eq="Eq. (10)",
        doc="beyond the paper: independent noise in this many soft regions; 1 = Eq. (10)",
        ui_range=(1, 9),
    )
    A: float = param(
        _HALF,
        lo=0,
        hi=1,
        lo_open=True,
        symbol="A",
        eq="Eq. (1), (3)",
        doc="amplitude of the height's oscillation (paper: 128/255)",
        step=1 / 255,
        ui_range=(1 / 255, 1),
    )
    C: float = param(
        _HALF,
        lo=0,
        hi=1,
        symbol="C",
        eq="Eq. (1), (3)",
        doc="centre of the height's oscillation (paper: 128/255)",
        step=1 / 255,
        ui_range=(0, 1),
    )
    branch: str = param(
        "rising",
        choices=BRANCHES,
        eq="Eq. (3)",
        doc="start on the rising (|alpha| <= pi/2) or falling half of the sine",
    )
    azimuth: float = param(
        135.0,
        lo=-360,
        hi=360,
        doc="light direction, degrees counter-clockwise from +x (135 = top left)",
        step=5,
        unit="deg",
        ui_range=(0, 360),
    )
    elevation: float = param(
        45.0,
        lo=0,
        hi=90,
        lo_open=True,
        doc="light height above the image plane (90 = overhead)",
        step=1,
        unit="deg",
        ui_range=(5, 90),
    )
    bump: float = param(
        2.0,
        lo=0,
        hi=1000,
        doc="bump-map relief: pixels of rise per unit of height",
        step=0.5,
        unit="px",
        ui_range=(0, 16),
    )
    k: float = param(
        1.0,
        lo=0,
        hi=20,
        symbol="k",
        doc="shading strength, O = I (1 + k (S_t - S_0))",
        step=0.05,
        ui_range=(0, 4),
    )
    feather: float = param(
        4.0,
        lo=0,
        hi=256,
        doc="soft inner edge of the painted region",
        step=0.5,
        unit="px",
        ui_range=(0, 32),
    )
    fps: float = param(
        8.0,
        lo=0,
        hi=120,
        lo_open=True,
        eq="Sec. 4.1",
        doc="frames per second (paper: 8, so f0 = 4 is 0.5 Hz)",
        step=0.5,
        unit="fps",
        ui_range=(1, 30),
    )

    def check(self):
        """Cross-field rule: ``f0 < T / 2`` (below the temporal Nyquist frequency)."""
        if 2 * self.f0 >= self.T:
            raise ValueError(
                f"f0 must be < T/2 = {self.T / 2:g} (below the temporal Nyquist frequency), "
                f"got f0={self.f0}"
            )
