"""Fire from a photograph: texture synthesis on a simulated temperature (Kogawa et al.)."""

from ._params import FireParams
from ._pipeline import (
    FireResult,
    colour_temperature,
    dissolve_weights,
    fire,
    fire_flame,
    fire_from_simulation,
)
from ._synthesis import alpha_from_photo, neighbourhood_error, neighbourhoods, synthesize

__all__ = [
    "FireParams",
    "FireResult",
    "alpha_from_photo",
    "colour_temperature",
    "dissolve_weights",
    "fire",
    "fire_flame",
    "fire_from_simulation",
    "neighbourhood_error",
    "neighbourhoods",
    "synthesize",
]
