"""A 2-D Stable Fluids solver for flames and smoke (Stam 1999; Furukawa et al. 2013, sec. 3.1).

The shared fluid building block of fluidnb: incompressible Navier-Stokes (Eq. (1),
(2)) with semi-Lagrangian advection, buoyancy (Eq. (4)), vorticity confinement
(Eq. (5), Fedkiw, Stam & Jensen 2001), an exact pressure projection, and a
temperature with radiative cooling (Eq. (3)).

Grid: temperature, density and pressure at cell centres; the velocity is staggered
(MAC) but stored as fluidnb's usual (H, W, 2) (dy, dx) array: ``velocity[i, j, 0]`` on
the top face of cell (i, j), ``velocity[i, j, 1]`` on its left face. Use
:func:`centred_velocity` for the velocity at the pixels. Walls: solid left, right and
bottom; the top open (default) or solid. See :mod:`fluidnb.fluid._grid`.

- :class:`FluidParams`, :class:`FluidState`, :func:`step` -- one step, state in,
  state out.
- :func:`simulate` -> :class:`Simulation` (save / load as .npz); :func:`flame_preset`,
  :func:`smoke_preset`.
- Teaching pieces: :func:`advect_velocity`, :func:`divergence`, :func:`curl`, :func:`project`,
  :func:`buoyancy`, :func:`vorticity_confinement`, :func:`cool`, :func:`source_mask`,
  :func:`temperature_to_rgb`.
"""

from ._colour import temperature_to_rgb
from ._forces import buoyancy, cool, source_mask, vorticity_confinement
from ._grid import centred_velocity, curl, divergence, enforce_walls, project
from ._params import BOUNDARIES, FluidParams
from ._simulate import Preset, Simulation, flame_preset, simulate, smoke_preset
from ._solver import FluidState, advect_velocity, step

__all__ = [
    "BOUNDARIES",
    "FluidParams",
    "FluidState",
    "Preset",
    "Simulation",
    "advect_velocity",
    "buoyancy",
    "centred_velocity",
    "cool",
    "curl",
    "divergence",
    "enforce_walls",
    "flame_preset",
    "project",
    "simulate",
    "smoke_preset",
    "source_mask",
    "step",
    "temperature_to_rgb",
    "vorticity_confinement",
]
