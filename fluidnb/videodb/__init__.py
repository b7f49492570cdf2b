r"""Animating a single fluid image from a database of fluid videos (Okabe et al. 2011).

The database (Okabe et al., sec. 4): fluid clips, each flipped, scaled and rotated, cut into
48 x 48-pixel fragments of ``N`` frames; per fragment its mean image, dense-SIFT
visual words, mean motion, motion power spectra and textureness, in a zarr store
(:func:`build_database`, :func:`open_database`, :func:`starter_database`).

The animation (sections 5-6): the target image cut the same way; candidates by
spatial-pyramid histogram intersection (Eq. 1); an MRF over the fragments solved by
alpha-expansion (Eq. 4-6, with :math:`\sigma`, :math:`\lambda`, :math:`\rho`);
rendering from the assigned fragments' difference frames with pyramid blending,
pseudo motion blur, histogram matching and a dynamic matte.

Every compiled or optimised step has a plain numpy version beside it (the
``reference_*`` functions) that the tests compare it with.
"""

from ._animate import (
    TEXTURE_SCALE,
    Animation,
    Assignment,
    Target,
    animate,
    assign,
    cut_target,
    fragment_motion,
    render,
)
from ._augment import (
    reference_sample_version,
    reference_transform_vectors,
    sample_version,
    transform_flow,
    transform_vectors,
    valid_positions,
    version_coordinates,
    version_shape,
)
from ._build import add_clips, build_database, clip_fragments
from ._features import motion_spectra, textureness, window_features
from ._figures import (
    assignment_figure,
    clip_fragments_figure,
    fragment_figure,
    mean_image_mosaic,
    motion_coherence,
    rendering_figure,
    retrieval_figure,
    spectra_figure,
    sweep_figure,
    version_label,
    versions_figure,
)
from ._flow import optical_flow
from ._geometry import ANGLES, FRAGMENT, SCALES, STRIDE, VERSIONS
from ._lock import DatabaseBusy
from ._mrf import (
    MRFSolution,
    PairTables,
    alpha_expansion,
    brute_force,
    energy,
    grid_edges,
    icm,
    pair_tables,
    reference_pair_tables,
    solve,
)
from ._params import AUGMENTATIONS, FLOW_BACKENDS, AnimateParams, DatabaseParams
from ._render import (
    blend_differences,
    composite,
    dynamic_matte,
    fragment_weights,
    inpaint_background,
    loop_crossfade,
    match_histograms_cells,
    motion_blur,
    reference_blend_differences,
    reference_match_histograms_cells,
)
from ._retrieval import HistogramIndex, reference_top_k
from ._sift import dense_sift, reference_dense_sift
from ._starter import starter_database, starter_params, starter_path
from ._starter_clips import STARTER_KINDS, flow_map_texture, starter_clips
from ._store import VideoDatabase, open_database, verify_database
from ._video import Video, read_video
from ._words import fit_codebook, intersection, pyramid_histograms, quantise, reference_quantise

__all__ = [
    "ANGLES",
    "AUGMENTATIONS",
    "FLOW_BACKENDS",
    "FRAGMENT",
    "SCALES",
    "STARTER_KINDS",
    "STRIDE",
    "TEXTURE_SCALE",
    "VERSIONS",
    "AnimateParams",
    "Animation",
    "Assignment",
    "DatabaseBusy",
    "DatabaseParams",
    "HistogramIndex",
    "MRFSolution",
    "PairTables",
    "Target",
    "Video",
    "VideoDatabase",
    "add_clips",
    "alpha_expansion",
    "animate",
    "assign",
    "assignment_figure",
    "blend_differences",
    "brute_force",
    "build_database",
    "clip_fragments",
    "clip_fragments_figure",
    "composite",
    "cut_target",
    "dense_sift",
    "dynamic_matte",
    "energy",
    "fit_codebook",
    "flow_map_texture",
    "fragment_figure",
    "fragment_motion",
    "fragment_weights",
    "grid_edges",
    "icm",
    "inpaint_background",
    "intersection",
    "loop_crossfade",
    "match_histograms_cells",
    "mean_image_mosaic",
    "motion_blur",
    "motion_coherence",
    "motion_spectra",
    "open_database",
    "optical_flow",
    "pair_tables",
    "pyramid_histograms",
    "quantise",
    "read_video",
    "reference_blend_differences",
    "reference_dense_sift",
    "reference_match_histograms_cells",
    "reference_pair_tables",
    "reference_quantise",
    "reference_sample_version",
    "reference_top_k",
    "reference_transform_vectors",
    "render",
    "rendering_figure",
    "retrieval_figure",
    "sample_version",
    "solve",
    "spectra_figure",
    "starter_clips",
    "starter_database",
    "starter_params",
    "starter_path",
    "sweep_figure",
    "textureness",
    "transform_flow",
    "transform_vectors",
    "valid_positions",
    "verify_database",
    "version_coordinates",
    "version_label",
    "version_shape",
    "versions_figure",
    "window_features",
]
