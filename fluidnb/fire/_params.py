"""Parameters of fire synthesis and cross-dissolve (Furukawa et al. 2013, sec. 3.2-3.4)."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["FireParams"]


@dataclass(frozen=True)
class FireParams(Params):
    r"""Parameters of the fire texture synthesis and its animation (Furukawa et al. 2013).

    The paper gives no values for these; the defaults are ours, chosen so that a
    128 x 128 keyframe takes well under a second and follows the target's shape
    (measured in ``tests/fire`` and ``benchmarks/bench_fire_synthesis.py``).

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
        :math:`N`, the number of frames of one segment (Furukawa et al. (2013), sec. 3.4, Fig. 6): a
        keyframe is synthesised, then advected for :math:`N - 1` frames.
    overlap : int
        :math:`m`, the frames two consecutive segments share and cross-dissolve
        over (Fig. 6); ``-1`` means :math:`N / 2` (rounded down, the paper's
        choice). Must be < ``interval``. Keyframes are :math:`N - m` frames apart.
    input_size : int
        The photo is resized so its longest side has this many pixels before it is
        used as the texture source (0 keeps its size). The flame in the photo should
        be about as large, in pixels, as the simulated flame.
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
        128,
        lo=0,
        hi=4096,
        integer=True,
        doc="longest side the photo is resized to (0: as given)",
        unit="px",
        ui_range=(32, 256),
    )

    def check(self):
        """Cross-field rules: odd ``size``, ``overlap < interval``, ``input_size``."""
        if self.size % 2 == 0:
            raise ValueError(f"size must be an odd integer in [3, 15], got {self.size}")
        if self.overlap >= self.interval:
            raise ValueError(
                f"overlap must be < interval ({self.interval}) or -1 for interval // 2, "
                f"got {self.overlap}"
            )
        if 0 < self.input_size < 8:
            raise ValueError(f"input_size must be 0 or >= 8, got {self.input_size}")

    @property
    def m(self):
        """The overlap :math:`m` in frames, with ``-1`` resolved to ``interval // 2``."""
        return self.interval // 2 if self.overlap < 0 else self.overlap
