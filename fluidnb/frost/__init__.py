"""Frost growth on a hexagonal lattice (Amano, Sato, Itoh; Reiter 2005).

Paint a region, pick start points, and frost grows over it by Reiter's cellular
automaton for snow crystals with the paper's random threshold ``rth``; the
initial vapour ``beta`` can be optimised so the growth ends at a chosen frame.

- :class:`HexLattice` -- lattice points in the region and the boundary ring around it.
- :func:`grow` / :func:`step` -- the automaton (vectorised), per-cell freeze frames.
- :func:`estimate_end_frame` / :func:`gamma_for_target` -- how long a run takes, from
  the balance of vapour, and the gamma that ends it at a target frame.
- :func:`optimise_beta` -- steepest descent (the paper) or bracketing + secant.
- :func:`direction_beta` -- a beta that varies with direction (the paper's future work).
- :func:`render` / :func:`frost` -- draw the frost as ice on an image, a :class:`fluidnb.Clip`;
  :func:`render_ice` / :func:`ice_mass` -- one frame of it, from the cells' ice mass.
"""

from ._direction import DirectionBeta, direction_beta
from ._estimate import EndFrameEstimate, GammaFit, estimate_end_frame, gamma_for_target
from ._lattice import DIRECTIONS, HexLattice
from ._optimise import OptimiseResult, OptimiseStep, optimise_beta
from ._params import FrostParams
from ._pipeline import frost
from ._reference import reference_setup
from ._reiter import FrostResult, grow, step
from ._render import FrostLook, ice_mass, render, render_ice

__all__ = [
    "DIRECTIONS",
    "DirectionBeta",
    "EndFrameEstimate",
    "FrostLook",
    "FrostParams",
    "FrostResult",
    "GammaFit",
    "HexLattice",
    "OptimiseResult",
    "OptimiseStep",
    "direction_beta",
    "estimate_end_frame",
    "frost",
    "gamma_for_target",
    "grow",
    "ice_mass",
    "optimise_beta",
    "reference_setup",
    "render",
    "render_ice",
    "step",
]
