"""Starter databases (beyond the paper): water, smoke and fire clips fluidnb makes itself, cached.

- :func:`starter_clips`, :data:`STARTER_KINDS` -- the clips: water textures advected
  along varied flows (:func:`flow_map_texture`), smoke from the fluid solver, fire
  from the fire method.
- :func:`starter_database`, :func:`starter_path`, :func:`starter_params`,
  :func:`prebuild_starters` -- their databases, built on first use into the cache.
- :func:`reference_water_flow` -- the water clips' flows, one frame at a time.
- :func:`suggest_kind` -- which starter database a photo looks like (a first guess
  from its colours, for an app to suggest).

Importing it lets ``db="water"`` (and the other kinds) name a starter database
wherever a database is asked for (:mod:`fluidnb.videodb.database._kinds`).
"""

from ..database._kinds import register_kinds
from ._clips import STARTER_KINDS, starter_clips
from ._databases import prebuild_starters, starter_database, starter_params, starter_path
from ._flow_map import flow_map_texture
from ._reference import reference_water_flow
from ._suggest import suggest_kind

register_kinds(STARTER_KINDS, starter_database)

__all__ = [
    "STARTER_KINDS",
    "flow_map_texture",
    "prebuild_starters",
    "reference_water_flow",
    "starter_clips",
    "starter_database",
    "starter_params",
    "starter_path",
    "suggest_kind",
]
