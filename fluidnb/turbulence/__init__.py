"""Example-based turbulence synthesis with adaptive patch search (Watanabe et al.).

The high-frequency detail of a high-resolution source flow is pasted, patch by
patch, onto a low-resolution target flow: a global search on the coarse grid
(Eq. 1) then a local search on the fine grid (Eq. 2) find, for every ``B x B``
patch, the source patch whose low frequencies, smoke mask and (for temporal
coherence) previous detail match best. The local search can visit its window
exhaustively, at a uniform interval, adaptively coarse-to-fine (the paper's
contribution, sec. 3 and Table 1) -- compiled, with the same three searches in plain
numpy in :mod:`fluidnb.turbulence._reference` -- or, beyond the paper, exactly and fast
(:mod:`fluidnb.turbulence._exact`; :data:`STRATEGIES`).
"""

from ._flows import PAPER_SHAPES, Flow, cache_dir, sample_flows
from ._params import STRATEGIES, TurbulenceParams
from ._prepare import Prepared, check_settings, global_search, prepare
from ._reference import window_positions
from ._render import dye_clip, injection, render, side_by_side, vorticity, vorticity_clip
from ._search import SearchResult, local_search
from ._synthesis import PAPER_TABLE1, Synthesis, compare, local_features, synthesize, table1

__all__ = [
    "PAPER_SHAPES",
    "PAPER_TABLE1",
    "STRATEGIES",
    "Flow",
    "Prepared",
    "SearchResult",
    "Synthesis",
    "TurbulenceParams",
    "cache_dir",
    "check_settings",
    "compare",
    "dye_clip",
    "global_search",
    "injection",
    "local_features",
    "local_search",
    "prepare",
    "render",
    "sample_flows",
    "side_by_side",
    "synthesize",
    "table1",
    "vorticity",
    "vorticity_clip",
    "window_positions",
]
