"""The video database (Okabe et al., sec. 4): fluid clips cut into fragments, in a zarr store.

- :func:`read_video`, :class:`Video` -- a clip as it goes in (MP4, GIF, frames).
- :func:`optical_flow` -- the clip's motion (OpenCV DIS, or TV-L1 as the paper).
- :func:`sample_version`, :func:`transform_flow`, :func:`transform_vectors`,
  :func:`version_shape`, :func:`version_coordinates`, :func:`valid_positions` -- the 18
  flipped, scaled and rotated versions (:data:`VERSIONS`) and where fragments lie.
- :func:`window_features`, :func:`motion_spectra`, :func:`textureness` -- a fragment's
  mean image, motion spectra (Eq. 2) and textureness (Fig. 7).
- :func:`dense_sift`, :func:`fit_codebook`, :func:`quantise`,
  :func:`pyramid_histograms`, :func:`intersection` -- visual words and Eq. 1.
- :func:`clip_fragments`, :func:`build_database`, :func:`add_clips`,
  :func:`discard_addition` -- the build;
  :func:`open_database`, :class:`VideoDatabase`, :func:`verify_database`,
  :class:`FrameCache`, :class:`DatabaseBusy` -- the store, read; :func:`luminance` --
  the grey fragments' frames are rebuilt from.
- ``reference_*`` -- the plain numpy versions the fast paths are tested against.
"""

from .._common._geometry import ANGLES, FRAGMENT, SCALES, STRIDE, VERSIONS
from .._common._params import AUGMENTATIONS, FLOW_BACKENDS, DatabaseParams
from ._augment import sample_version, transform_flow, transform_vectors
from ._build import add_clips, build_database, discard_addition
from ._cut import clip_fragments
from ._features import motion_spectra, textureness, window_features
from ._flow import optical_flow
from ._frames import FrameCache, luminance
from ._lock import DatabaseBusy
from ._reference import (
    reference_dense_sift,
    reference_fragment_frames,
    reference_pixel_features,
    reference_quantise,
    reference_sample_version,
    reference_textureness,
    reference_transform_vectors,
    reference_window_sums,
)
from ._sift import dense_sift
from ._store import VideoDatabase, open_database
from ._verify import verify_database
from ._versions import valid_positions, version_coordinates, version_shape
from ._video import Video, read_video
from ._words import fit_codebook, intersection, pyramid_histograms, quantise

__all__ = [
    "ANGLES",
    "AUGMENTATIONS",
    "FLOW_BACKENDS",
    "FRAGMENT",
    "SCALES",
    "STRIDE",
    "VERSIONS",
    "DatabaseBusy",
    "DatabaseParams",
    "FrameCache",
    "Video",
    "VideoDatabase",
    "add_clips",
    "build_database",
    "clip_fragments",
    "dense_sift",
    "discard_addition",
    "fit_codebook",
    "intersection",
    "luminance",
    "motion_spectra",
    "open_database",
    "optical_flow",
    "pyramid_histograms",
    "quantise",
    "read_video",
    "reference_dense_sift",
    "reference_fragment_frames",
    "reference_pixel_features",
    "reference_quantise",
    "reference_sample_version",
    "reference_textureness",
    "reference_transform_vectors",
    "reference_window_sums",
    "sample_version",
    "textureness",
    "transform_flow",
    "transform_vectors",
    "valid_positions",
    "verify_database",
    "version_coordinates",
    "version_shape",
    "window_features",
]
