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

Every compiled or optimised step has a plain numpy version, in the paper's notation,
in one module (:mod:`fluidnb.videodb._reference`, the ``reference_*`` functions),
that the tests compare it with.

One idea per module, in the order of the method:

- the database (sec. 4): ``_geometry`` (fragment sizes, the 18 versions), ``_params``,
  ``_video`` (reading clips), ``_flow`` (optical flow), ``_augment`` (the versions'
  pixels and motion), ``_features`` (mean image, motion spectra, textureness),
  ``_sift`` (dense SIFT), ``_words`` (codebook, visual words, pyramid histograms,
  Eq. 1), ``_build`` and ``_store`` (building and reading the zarr store), ``_frames``
  (rebuilding fragments' frames for rendering, the frame cache),
  ``_starter_clips``, ``_flow_map`` and ``_starter`` (the starter databases' clips and
  their cache);
- the assignment (sec. 5): ``_target`` (the target cut into fragments, the user's
  motion), ``_retrieval`` (top-K by Eq. 1, the motion filter), ``_smoothness`` (Eq. 2,
  3, 6 in bulk), ``_mrf`` (Eq. 4, 5 and the solvers), ``_maxflow`` (the expansion
  moves' minimum cuts, Boykov & Kolmogorov 2004), ``_assign`` (the :class:`Assignment`);
- the rendering (sec. 6): ``_blend`` (multi-band blending of the differences),
  ``_appearance`` (motion blur, histogram matching), ``_composite`` (moving matte,
  background, loop, composite), ``_fill`` (exemplar-based fill of the background,
  beyond the paper), ``_desync`` (neighbours sharing a fragment play it at
  different times, beyond the paper), ``_flow_render`` (the flow rendering's motion
  field and Eulerian loop, beyond the paper), ``_render`` (the pipeline: the paper's
  rendering or the flow rendering), ``_animate`` (the entry point), ``_preview``
  (one quick low-resolution frame, for live previews);
- ``_reference`` (the plain versions) and ``_figures`` (the lesson's pictures).
"""

from ._animate import animate
from ._common._geometry import ANGLES, FRAGMENT, SCALES, STRIDE, VERSIONS
from ._common._params import AUGMENTATIONS, FLOW_BACKENDS, RENDERINGS, AnimateParams, DatabaseParams
from .assignment._assign import Assignment, assign
from .assignment._mrf import (
    MRFSolution,
    alpha_expansion,
    brute_force,
    energy,
    grid_edges,
    icm,
    solve,
)
from .assignment._retrieval import HistogramIndex
from .assignment._smoothness import TEXTURE_SCALE, PairTables, pair_tables
from .assignment._target import Target, cut_target, fragment_motion
from .database._augment import (
    sample_version,
    transform_flow,
    transform_vectors,
    valid_positions,
    version_coordinates,
    version_shape,
)
from .database._build import add_clips, build_database, clip_fragments
from .database._features import motion_spectra, textureness, window_features
from .database._flow import optical_flow
from .database._frames import FrameCache
from .database._lock import DatabaseBusy
from .database._sift import dense_sift
from .database._store import VideoDatabase, open_database, verify_database
from .database._video import Video, read_video
from .database._words import fit_codebook, intersection, pyramid_histograms, quantise
from .figures._database import (
    assignment_figure,
    clip_colour,
    clip_fragments_figure,
    clip_map_picture,
    fragment_figure,
    motion_arrows,
    rendering_figure,
    retrieval_figure,
    spectra_figure,
    sweep_figure,
    version_label,
    versions_figure,
)
from .rendering._appearance import match_histograms_cells, motion_blur
from .rendering._blend import blend_differences, fragment_weights
from .rendering._composite import composite, dynamic_matte, inpaint_background, loop_crossfade
from .rendering._desync import mirror_axes, stagger, sync_share, temporal_offsets
from .rendering._fill import exemplar_fill
from .rendering._flow_render import (
    displacement_maps,
    eulerian_loop,
    extend_outside,
    flow_field,
    flow_timing,
    loop_phases,
)
from .rendering._preview import prefetch_preview, preview_frame
from .rendering._reference import (
    reference_alpha_expansion,
    reference_blend_differences,
    reference_dense_sift,
    reference_eulerian_loop,
    reference_fill,
    reference_fragment_frames,
    reference_icm,
    reference_match_histograms_cells,
    reference_motion_blur,
    reference_pair_tables,
    reference_quantise,
    reference_sample_version,
    reference_top_k,
    reference_transform_vectors,
)
from .rendering._render import Animation, prefetch, render
from .starter._clips import STARTER_KINDS, starter_clips
from .starter._databases import prebuild_starters, starter_database, starter_params, starter_path
from .starter._flow_map import flow_map_texture

__all__ = [
    "ANGLES",
    "AUGMENTATIONS",
    "FLOW_BACKENDS",
    "FRAGMENT",
    "RENDERINGS",
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
    "FrameCache",
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
    "clip_colour",
    "clip_fragments",
    "clip_fragments_figure",
    "clip_map_picture",
    "composite",
    "cut_target",
    "dense_sift",
    "displacement_maps",
    "dynamic_matte",
    "energy",
    "eulerian_loop",
    "exemplar_fill",
    "extend_outside",
    "fit_codebook",
    "flow_field",
    "flow_map_texture",
    "flow_timing",
    "fragment_figure",
    "fragment_motion",
    "fragment_weights",
    "grid_edges",
    "icm",
    "inpaint_background",
    "intersection",
    "loop_crossfade",
    "loop_phases",
    "match_histograms_cells",
    "mirror_axes",
    "motion_arrows",
    "motion_blur",
    "motion_spectra",
    "open_database",
    "optical_flow",
    "pair_tables",
    "prebuild_starters",
    "prefetch",
    "prefetch_preview",
    "preview_frame",
    "pyramid_histograms",
    "quantise",
    "read_video",
    "reference_alpha_expansion",
    "reference_blend_differences",
    "reference_dense_sift",
    "reference_eulerian_loop",
    "reference_fill",
    "reference_fragment_frames",
    "reference_icm",
    "reference_match_histograms_cells",
    "reference_motion_blur",
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
    "stagger",
    "starter_clips",
    "starter_database",
    "starter_params",
    "starter_path",
    "sweep_figure",
    "sync_share",
    "temporal_offsets",
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
