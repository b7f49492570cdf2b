"""Flicker ("yuragi") animation of one photo (Yamamoto & Sakamoto)."""

from ._figures import analysis_figure, difference_image
from ._flicker import FlickerModel, base_method, flicker, preview
from ._params import MAPPINGS, FlickerParams
from ._shading import apply_shading, feather_weights, light_vector, shade
from ._spectrum import (
    harmonic_height,
    height_from_luminance,
    initial_phase,
    noise_spectrum,
    phase_spectrum,
    temporal_frequencies,
    temporal_signals,
)

__all__ = [
    "MAPPINGS",
    "FlickerModel",
    "FlickerParams",
    "analysis_figure",
    "apply_shading",
    "base_method",
    "difference_image",
    "feather_weights",
    "flicker",
    "harmonic_height",
    "height_from_luminance",
    "initial_phase",
    "light_vector",
    "noise_spectrum",
    "phase_spectrum",
    "preview",
    "shade",
    "temporal_frequencies",
    "temporal_signals",
]
