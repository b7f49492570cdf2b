r"""The assignment (Okabe et al., sec. 5): which database fragment animates each target fragment.

- :func:`cut_target`, :class:`Target`, :func:`fragment_motion` -- the target cut as the
  database is, and the user's direction and speed over its fragments (Fig. 8).
- :func:`histogram_index`, :class:`HistogramIndex`, :class:`TopK`,
  :func:`moving_fragments`, :func:`fragment_speeds` -- the candidates:
  top-K by spatial-pyramid histogram intersection (Eq. 1), after the motion filter.
- :func:`pair_tables`, :class:`PairTables`, :data:`TEXTURE_SCALE` -- the smoothness
  terms of every edge and label pair (Eq. 2, 3, 6), in bulk; :func:`pair_smoothness`
  their sum :math:`W` alone.
- :func:`grid_edges`, :func:`energy` (Eq. 4, 5), :func:`alpha_expansion`, :func:`icm`,
  :func:`solve`, :func:`solve_from` (a warm start), :class:`MRFSolution`,
  :func:`brute_force` -- the MRF and its solvers.
- :func:`assign`, :class:`Assignment` -- all of it, re-solved for new :math:`\sigma`,
  :math:`\lambda`, :math:`\rho` without recomputation.
- ``reference_*`` -- the plain numpy versions the fast paths are tested against.
"""

from ._assign import Assignment, assign
from ._expansion import alpha_expansion
from ._icm import icm
from ._mrf import brute_force, energy, grid_edges
from ._reference import (
    reference_alpha_expansion,
    reference_icm,
    reference_pair_tables,
    reference_top_k,
)
from ._retrieval import (
    STILL,
    HistogramIndex,
    TopK,
    fragment_speeds,
    histogram_index,
    moving_fragments,
)
from ._smoothness import TEXTURE_SCALE, PairTables, pair_smoothness, pair_tables
from ._solve import MRFSolution, solve, solve_from
from ._target import Target, cut_target, fragment_motion

__all__ = [
    "STILL",
    "TEXTURE_SCALE",
    "Assignment",
    "HistogramIndex",
    "MRFSolution",
    "PairTables",
    "Target",
    "TopK",
    "alpha_expansion",
    "assign",
    "brute_force",
    "cut_target",
    "energy",
    "fragment_motion",
    "fragment_speeds",
    "grid_edges",
    "histogram_index",
    "icm",
    "moving_fragments",
    "pair_smoothness",
    "pair_tables",
    "reference_alpha_expansion",
    "reference_icm",
    "reference_pair_tables",
    "reference_top_k",
    "solve",
    "solve_from",
]
