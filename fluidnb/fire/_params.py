"""Parameters of fire synthesis and cross-dissolve (Furukawa et al. 2013, sec. 3.2-3.4)."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["SIMULATION_FPS", "FireParams"]

#: Frames a second of the simulation's own frames (one solver frame each): the pace at
#: which the flame preset looks like a flame, and the paper's clip rate (one output
#: frame per simulation frame). ``fps`` above it adds in-between frames.
SIMULATION_FPS = 8.0


@dataclass(frozen=True)
class FireParams(Params):
    r"""Parameters of the fire texture synthesis and its animation (Furukawa et al. 2013).

    The paper gives no values for these; the defaults are ours, chosen so that a
    keyframe takes a fraction of a second and follows the target's shape (measured in
    ``tests/fire`` and ``benchmarks/bench_fire_synthesis.py``).

    Two defaults go beyond the paper, so that the clip looks right at the size and
    pace a screen shows it: the keyframes are synthesised at ``output_size`` = 256
    pixels on the longer side over the paper's 128 x 128 simulation (its temperature
    and velocity resampled smoothly), and the clip has ``fps`` = 24 frames a second,
    the in-between frames advected along the flow (not repeated).
    :meth:`FireParams.paper` gives the paper's set-up: keyframes on the simulation's
    grid, one frame per simulation frame (8 fps).

    Attributes
    ----------
    weight : float
        :math:`w`, the user-control weight of Ashikhmin's method (Furukawa et al.
        (2013), sec. 3.2, Fig. 4): the distance of a candidate is
        :math:`(1 - w)\,\overline{SSD}_{N_U} + w\,\overline{SSD}_{N_L}`, the mean
        squared colour difference over the upper L :math:`N_U(p)` and the mean
        squared difference of target temperature :math:`I_t` against the photo's
        alpha :math:`a_a` over the lower L :math:`N_L(p)`. 0 copies texture only,
        1 follows the target only.
    size : int
        :math:`k`, the side of the square neighbourhood split into the two L shapes
        (odd, >= 3): :math:`N_U` has :math:`(k^2-1)/2` pixels and :math:`N_L`
        :math:`(k^2+1)/2`.
    n_random : int
        Random input positions added to Ashikhmin's candidate set for each pixel.
    coherence : float
        :math:`\kappa`, the coherence factor of Hertzmann et al. (2001): a random
        candidate's distance is multiplied by :math:`1 + \kappa` before it is
        compared with the coherent candidates' (Ashikhmin's shifted neighbour
        sources), so the keyframe is made of patches (flame tongues) rather than a
        mosaic of single pixels. Beyond the paper; 0 is the paper's plain search.
    second_pass : bool
        Run a second raster scan comparing colours over the whole square
        neighbourhood (all of it is synthesised by then), as Ashikhmin suggests.
    cutoff : float
        :math:`\tau`: gas cooler than this fraction of the sequence's temperature
        range does not glow, so the cooled plume fades to black; above it the
        temperature is matched to the photo's alpha by rank
        (:func:`fluidnb.fire.temperature_target`). Beyond the paper, which maps the
        normalised temperature as it is (``cutoff=0`` keeps the cut-off out but
        still matches ranks).
    interval : int
        :math:`N`, the number of simulation frames of one segment (Furukawa et al.
        (2013), sec. 3.4, Fig. 6): a keyframe is synthesised, then advected for the
        rest of the segment. At ``fps`` above :data:`SIMULATION_FPS` a segment has
        ``N * fps / 8`` clip frames (rounded): the same time, more frames.
    overlap : int
        :math:`m`, the simulation frames two consecutive segments share and
        cross-dissolve over (Fig. 6); ``-1`` means :math:`N / 2` (rounded down, the
        paper's choice). Must be < ``interval``. Keyframes are :math:`N - m`
        simulation frames apart.
    input_size : int
        The photo is resized so its longest side has this many pixels before it is
        used as the texture source: ``-1`` (default) as many as the keyframes'
        longest side, 0 keeps its size. The flame in the photo should be about as
        large, in pixels, as the simulated flame.
    output_size : int
        The longest side, in pixels, of the synthesised keyframes and the clip
        (beyond the paper): the simulation's temperature (the target
        :math:`I_t`) is resampled to it by cubic interpolation and its velocity
        bilinearly (scaled to pixels of the finer grid). 0 keeps the simulation's
        grid, the paper's set-up (its 128 x 128 keyframes look blocky when a screen
        shows them larger).
    fps : float
        Frames a second of the clip (beyond the paper, which shows one frame per
        simulation frame, :data:`SIMULATION_FPS`). Above it, each simulation frame
        is divided into ``fps / 8`` clip frames, each advected by that fraction of
        the frame's velocity (sec. 3.3's backtrace in smaller steps), so motion is
        smooth and the clip lasts as long.
    """

    weight: float = param(
        0.6,
        lo=0,
        hi=1,
        symbol="w",
        eq="Sec. 3.2, Fig. 4",
        doc="user control: 0 matches colour (upper L), 1 matches the target (lower L)",
        step=0.05,
    )
    size: int = param(
        5,
        lo=3,
        hi=15,
        integer=True,
        symbol="k",
        eq="Fig. 4",
        doc="side of the neighbourhood split into the two L shapes (odd)",
        step=2,
        unit="px",
    )
    n_random: int = param(
        16,
        lo=0,
        hi=64,
        integer=True,
        symbol="n_r",
        eq="Ashikhmin (2001)",
        doc="random positions added to each pixel's candidate set",
    )
    coherence: float = param(
        1.0,
        lo=0,
        hi=10,
        symbol=r"\kappa",
        eq="Hertzmann et al. (2001)",
        doc="coherence penalty: a random candidate's distance is multiplied by 1 + kappa",
        step=0.1,
    )
    second_pass: bool = param(
        True,
        symbol="",
        eq="Ashikhmin (2001)",
        doc="second scan with full square neighbourhoods",
    )
    cutoff: float = param(
        0.2,
        lo=0,
        hi=0.95,
        symbol=r"\tau",
        doc="fraction of the temperature range below which gas does not glow (black)",
        step=0.05,
    )
    interval: int = param(
        10,
        lo=1,
        hi=1000,
        integer=True,
        symbol="N",
        eq="Sec. 3.4, Fig. 6",
        doc="frames per segment (keyframe, then advection)",
        unit="frames",
        ui_range=(2, 40),
    )
    overlap: int = param(
        -1,
        lo=-1,
        hi=999,
        integer=True,
        symbol="m",
        eq="Sec. 3.4, Fig. 6",
        doc="frames two segments cross-dissolve over (-1: N/2)",
        unit="frames",
        ui_range=(-1, 39),
    )
    input_size: int = param(
        -1,
        lo=-1,
        hi=4096,
        integer=True,
        doc="longest side the photo is resized to (-1: the keyframes', 0: as given)",
        unit="px",
        ui_range=(-1, 512),
    )
    output_size: int = param(
        256,
        lo=0,
        hi=4096,
        integer=True,
        doc="longest side of the keyframes and the clip (0: the simulation's grid)",
        unit="px",
        ui_range=(0, 512),
        step=32,
    )
    fps: float = param(
        24.0,
        lo=1,
        hi=120,
        doc="frames a second; above 8 the in-between frames are advected",
        unit="fps",
        ui_range=(8, 60),
        step=1,
    )

    @classmethod
    def paper(cls, **changes):
        """The paper's set-up: keyframes on the simulation's grid, 8 frames a second.

        Furukawa et al. (2013) synthesise on the 128 x 128 simulation grid and show
        one frame per simulation frame; fluidnb's defaults synthesise at 256 pixels
        and add in-between frames for 24 fps. Keyword arguments change fields.

        Examples
        --------
        >>> FireParams.paper().output_size, FireParams.paper().fps
        (0, 8.0)
        """
        return cls(output_size=0, fps=SIMULATION_FPS, **changes)

    def check(self):
        """Cross-field rules: odd ``size``, ``overlap < interval``, the sizes."""
        if self.size % 2 == 0:
            raise ValueError(f"size must be an odd integer in [3, 15], got {self.size}")
        if self.overlap >= self.interval:
            raise ValueError(
                f"overlap must be < interval ({self.interval}) or -1 for interval // 2, "
                f"got {self.overlap}"
            )
        if 0 < self.input_size < 8:
            raise ValueError(f"input_size must be -1, 0 or >= 8, got {self.input_size}")
        if 0 < self.output_size < 16:
            raise ValueError(
                f"output_size must be 0 (the simulation's grid) or >= 16 pixels, "
                f"got {self.output_size}"
            )

    @property
    def m(self):
        """The overlap :math:`m` in frames, with ``-1`` resolved to ``interval // 2``."""
        return self.interval // 2 if self.overlap < 0 else self.overlap
