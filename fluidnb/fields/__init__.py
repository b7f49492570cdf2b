"""Shared field operations: advection, warping, resampling and image pyramids."""

from ._advect import advect, backward_warp
from ._pyramid import collapse, expand, gaussian_pyramid, laplacian_pyramid, pyramid_blend
from ._resample import downsample, resize, resize_vector_field, upsample

__all__ = [
    "advect",
    "backward_warp",
    "collapse",
    "downsample",
    "expand",
    "gaussian_pyramid",
    "laplacian_pyramid",
    "pyramid_blend",
    "resize",
    "resize_vector_field",
    "upsample",
]
