"""Fire from a photograph: texture synthesis on a simulated flame (Furukawa et al. 2013).

:func:`fire` is the entry point: ``fire(photo)`` simulates a flame and paints it with
the photo; ``fire(photo, simulation)`` uses your own simulation. The other names are
the steps it is made of, for lessons and experiments: :func:`synthesize` (one
keyframe), :func:`dissolve_weights` (the cross-dissolve), :func:`alpha_from_photo`,
:func:`neighbourhoods` and :func:`neighbourhood_error` (the search), and
:func:`synthesize_reference`, the same keyframe scan written out in plain numpy, and
:func:`keyframe_preview`, one keyframe on a small flame (what an app shows while a
slider moves).
"""

from ._params import FireParams
from ._pipeline import FireResult, colour_temperature, dissolve_weights, fire, temperature_target
from ._preview import keyframe_preview
from ._reference import synthesize_reference
from ._synthesis import alpha_from_photo, neighbourhood_error, neighbourhoods, synthesize

__all__ = [
    "FireParams",
    "FireResult",
    "alpha_from_photo",
    "colour_temperature",
    "dissolve_weights",
    "fire",
    "keyframe_preview",
    "neighbourhood_error",
    "neighbourhoods",
    "synthesize",
    "synthesize_reference",
    "temperature_target",
]
