"""Animating a single fluid image from a database of fluid videos (Okabe et al. 2011).

Work in progress: the database half (seed section 4) and the animation half
(sections 5-6) are being built in this package.
"""

from ._geometry import ANGLES, FRAGMENT, SCALES, STRIDE, VERSIONS
from ._params import AUGMENTATIONS, FLOW_BACKENDS, AnimateParams, DatabaseParams

__all__ = [
    "ANGLES",
    "AUGMENTATIONS",
    "FLOW_BACKENDS",
    "FRAGMENT",
    "SCALES",
    "STRIDE",
    "VERSIONS",
    "AnimateParams",
    "DatabaseParams",
]
