"""Fire from a photograph: texture synthesis on a simulated flame (Furukawa et al. 2013).

:func:`fire` is the entry point: ``fire(photo)`` simulates a flame and paints it with
the photo; ``fire(photo, simulation)`` uses your own simulation. The other names are
the steps it is made of, for lessons and experiments: :func:`synthesize` (one
keyframe), :func:`dissolve_weights` (the cross-dissolve), :func:`clip_times` (the
clip's frames in simulation time), :func:`output_shape`, :func:`flame_matte` (a
painted matte made the flame's own), :func:`alpha_from_photo`, :func:`neighbourhoods`
and :func:`neighbourhood_error` (the search), :func:`synthesize_reference`, the
same keyframe scan written out in plain numpy, and :func:`keyframe_preview`, one
keyframe on a small flame (what an app shows while a slider moves).
:class:`FireParams` holds the parameters; :meth:`FireParams.paper` the paper's set-up.
"""

from ._matte import flame_matte
from ._params import SIMULATION_FPS, FireParams
from ._pipeline import (
    FireResult,
    clip_times,
    colour_temperature,
    dissolve_weights,
    fire,
    output_shape,
    temperature_target,
)
from ._preview import keyframe_preview
from ._reference import synthesize_reference
from ._synthesis import alpha_from_photo, neighbourhood_error, neighbourhoods, synthesize

__all__ = [
    "SIMULATION_FPS",
    "FireParams",
    "FireResult",
    "alpha_from_photo",
    "clip_times",
    "colour_temperature",
    "dissolve_weights",
    "fire",
    "flame_matte",
    "keyframe_preview",
    "neighbourhood_error",
    "neighbourhoods",
    "output_shape",
    "synthesize",
    "synthesize_reference",
    "temperature_target",
]
