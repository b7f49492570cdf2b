"""Parameters of example-based turbulence synthesis (Watanabe et al., secs. 2-3)."""

from __future__ import annotations

from dataclasses import dataclass

from .._params import Params, param

__all__ = ["STRATEGIES", "TurbulenceParams"]

#: The local-search strategies (Watanabe et al., sec. 3 and Table 1, plus two exact ones
#: beyond the paper):
#:
#: - ``"exhaustive"``: every position of the window (the paper's reference);
#: - ``"interval"``: a uniform sample of the window every ``interval`` positions;
#: - ``"adaptive"``: the paper's coarse-to-fine search from interval ``m0``;
#: - ``"exact-fft"``: every position at once, by correlation through FFTs;
#: - ``"exact-bounds"``: every position ruled in or out by lower bounds from
#:   box sums, the survivors measured in full (the exhaustive answer, faster).
STRATEGIES = ("exhaustive", "interval", "adaptive", "exact-fft", "exact-bounds")


@dataclass(frozen=True)
class TurbulenceParams(Params):
    r"""Parameters of :func:`fluidnb.turbulence.synthesize`.

    The paper's experiment (Watanabe et al., sec. 4) uses ``B = 16`` and ``b = 4`` with a 16 x 24
    target (:math:`\Delta x = 0.25`) and a 128 x 192 source
    (:math:`\Delta X = 0.03125`), and the adaptive search from ``m0 = 8``. It gives
    no values for :math:`\alpha`, :math:`\beta` or :math:`D_{th}`; ours are chosen
    so that the three terms of Eq. (2) are of a similar size on the sample flows
    (:func:`fluidnb.turbulence.sample_flows`).

    Attributes
    ----------
    B : int
        Side of a local patch :math:`X(p)` on the high-resolution grid, in source
        cells (sec. 2.1, Fig. 1). The high-resolution target is tiled by
        ``B x B`` patches, so ``B`` must divide both sides of the source grid.
    b : int
        Side of a global patch :math:`x(p)` on the low-resolution grid, in target
        cells; the paper requires :math:`b > B\,\Delta X / \Delta x`. The local
        search window spans the global patch: :math:`n = b\,\Delta x / \Delta X`
        positions per axis (our reading; 32 in the paper's setting).
    alpha : float
        :math:`\alpha`, the weight of the density-mask terms of Eq. (1) and (2).
    beta : float
        :math:`\beta`, the weight of the temporal-coherence term of Eq. (2): the
        previous frame's synthesised detail, advected, against the source's.
    D_th : float
        :math:`D_{th}`, the density above which a cell belongs to the smoke mask
        :math:`d_t`, :math:`D_s` (sec. 2.1).
    strategy : str
        How the local search visits its window; one of :data:`STRATEGIES`.
    m0 : int
        :math:`m_0`, the adaptive search's first sampling interval (a power of 2;
        halved each round until it is 1; sec. 3). ``m0 = 1`` is the exhaustive
        search.
    interval : int
        :math:`m`, the sampling interval of the ``"interval"`` strategy (Table 1's
        rows 2-4 use 2, 4 and 8).
    blend : int
        Width in source cells of a feathered overlap between neighbouring pasted
        patches; 0 pastes the tiles side by side as the paper does.
    """

    B: int = param(
        16,
        lo=2,
        hi=256,
        integer=True,
        symbol="B",
        eq="Sec. 2.1, Fig. 1",
        doc="side of a local patch on the high-resolution grid",
        unit="cells",
        ui_range=(4, 32),
        step=4,
    )
    b: int = param(
        4,
        lo=1,
        hi=64,
        integer=True,
        symbol="b",
        eq="Sec. 2.1, Fig. 1",
        doc="side of a global patch on the low-resolution grid (b > B dX/dx)",
        unit="cells",
        ui_range=(2, 8),
    )
    alpha: float = param(
        1.0,
        lo=0,
        hi=1e6,
        symbol=r"\alpha",
        eq="(1), (2)",
        doc="weight of the density-mask term",
        ui_range=(0, 4),
        step=0.1,
    )
    beta: float = param(
        1.0,
        lo=0,
        hi=1e6,
        symbol=r"\beta",
        eq="(2)",
        doc="weight of the temporal-coherence term",
        ui_range=(0, 4),
        step=0.1,
    )
    D_th: float = param(
        0.1,
        lo=0,
        hi=1e6,
        symbol=r"D_{th}",
        eq="Sec. 2.1",
        doc="density above which a cell is smoke (the mask d, D)",
        ui_range=(0, 1),
        step=0.01,
    )
    strategy: str = param(
        "adaptive",
        choices=STRATEGIES,
        eq="Sec. 3, Table 1",
        doc="how the local search visits its window",
    )
    m0: int = param(
        8,
        lo=1,
        hi=64,
        integer=True,
        symbol="m_0",
        eq="Sec. 3",
        doc="first sampling interval of the adaptive search (power of 2)",
        ui_range=(1, 16),
    )
    interval: int = param(
        2,
        lo=1,
        hi=64,
        integer=True,
        symbol="m",
        eq="Table 1",
        doc="sampling interval of the uniform search",
        ui_range=(1, 16),
    )
    blend: int = param(
        0,
        lo=0,
        hi=64,
        integer=True,
        doc="feathered overlap between pasted patches (0: paste tiles)",
        unit="cells",
        ui_range=(0, 8),
    )

    def check(self):
        """Cross-field rule: ``m0`` is a power of 2, so halving reaches 1."""
        if self.m0 & (self.m0 - 1):
            raise ValueError(f"m0 must be a power of 2 (1, 2, 4, ...), got {self.m0}")
