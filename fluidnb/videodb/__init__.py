r"""Animating a single fluid image from a database of fluid videos (Okabe et al. 2011).

The method's three stages are the three subpackages, and data flows from one to the
next:

- :mod:`fluidnb.videodb.database` (Okabe et al., sec. 4): fluid clips, each flipped,
  scaled and rotated, cut into 48 x 48-pixel fragments of ``N`` frames; per fragment
  its mean image, dense-SIFT visual words, mean motion, motion power spectra and
  textureness, in a zarr store (:func:`build_database`, :func:`open_database`);
- :mod:`fluidnb.videodb.assignment` (sec. 5): the target image cut the same way;
  candidates by spatial-pyramid histogram intersection (Eq. 1); an MRF over the
  fragments solved by alpha-expansion (Eq. 4-6, with :math:`\sigma`, :math:`\lambda`,
  :math:`\rho`) (:func:`assign`);
- :mod:`fluidnb.videodb.rendering` (sec. 6, and the flow rendering beyond it): the
  assigned fragments' difference frames blended with pyramids, pseudo motion blur,
  histogram matching and a dynamic matte (:func:`render`).

Beside them, :mod:`fluidnb.videodb.starter` makes the starter databases from clips
fluidnb generates itself (:func:`starter_database`), and :mod:`fluidnb.videodb.figures`
draws the lessons' pictures. Every compiled or optimised step has a plain numpy
version in the paper's notation in its stage's ``_reference`` module (the
``reference_*`` functions of each subpackage), which the tests compare it with.

Here are the names a user starts from; every step a lesson shows is public in its
stage's subpackage (``fluidnb.videodb.rendering.motion_blur``, ...).
"""

# The stages' subpackages, as attributes (fluidnb.videodb.rendering.motion_blur, ...).
from . import assignment as assignment
from . import database as database
from . import figures as figures
from . import rendering as rendering
from . import starter as starter
from ._animate import animate
from ._common._geometry import FRAGMENT, STRIDE, VERSIONS
from ._common._params import (
    AUGMENTATIONS,
    FLOW_BACKENDS,
    RENDERINGS,
    AnimateParams,
    DatabaseParams,
)
from .assignment import Assignment, assign
from .database import (
    DatabaseBusy,
    Video,
    VideoDatabase,
    add_clips,
    build_database,
    discard_addition,
    open_database,
    read_video,
    verify_database,
)
from .rendering import Animation, prefetch, prefetch_preview, preview_frame, render
from .starter import (
    STARTER_KINDS,
    prebuild_starters,
    starter_database,
    starter_params,
    starter_path,
)

__all__ = [
    "AUGMENTATIONS",
    "FLOW_BACKENDS",
    "FRAGMENT",
    "RENDERINGS",
    "STARTER_KINDS",
    "STRIDE",
    "VERSIONS",
    "AnimateParams",
    "Animation",
    "Assignment",
    "DatabaseBusy",
    "DatabaseParams",
    "Video",
    "VideoDatabase",
    "add_clips",
    "animate",
    "assign",
    "build_database",
    "discard_addition",
    "open_database",
    "prebuild_starters",
    "prefetch",
    "prefetch_preview",
    "preview_frame",
    "read_video",
    "render",
    "starter_database",
    "starter_params",
    "starter_path",
    "verify_database",
]
