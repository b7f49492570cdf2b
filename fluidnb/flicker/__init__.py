"""Flicker ("yuragi") animation of one photo (Yamamoto & Sakamoto)."""

from ._figures import analysis_figure, difference_image
from ._flicker import FlickerModel, base_method, flicker, preview
from ._flow import as_velocity, flow_velocity
from ._params import MAPPINGS, NOISE_NORMS, FlickerParams
from ._shading import apply_shading, feather_weights, light_vector, shade
from ._spectrum import (
    harmonic_height,
    height_from_luminance,
    initial_phase,
    noise_spectrum,
    phase_spectrum,
    region_weights,
    soft_clip,
    temporal_frequencies,
    temporal_signals,
)

__all__ = [
    "MAPPINGS",
    "NOISE_NORMS",
    "FlickerModel",
    "FlickerParams",
    "analysis_figure",
    "apply_shading",
    "as_velocity",
    "base_method",
    "difference_image",
    "feather_weights",
    "flicker",
    "flow_velocity",
    "harmonic_height",
    "height_from_luminance",
    "initial_phase",
    "light_vector",
    "noise_spectrum",
    "phase_spectrum",
    "preview",
    "region_weights",
    "shade",
    "soft_clip",
    "temporal_frequencies",
    "temporal_signals",
]
