"""The rendering (Okabe et al., sec. 6; the flow rendering beyond it): an assignment made a clip.

- :func:`fragment_weights`, :func:`blend_differences` -- the fragments' difference
  frames blended with Laplacian pyramids (Burt & Adelson).
- :func:`loop_crossfade`, :func:`temporal_offsets`, :func:`mirror_axes`,
  :func:`stagger`, :func:`sync_share` -- loops, and neighbours that share a fragment
  played at different times (beyond the paper).
- :func:`motion_blur`, :func:`match_histograms_cells` -- the approximate mean image
  and the appearance matching.
- :func:`dynamic_matte`, :func:`inpaint_background`, :func:`exemplar_fill`,
  :func:`composite` -- the moving matte and what it uncovers.
- :func:`flow_field`, :func:`flow_timing`, :func:`loop_phases`,
  :func:`displacement_maps`, :func:`eulerian_loop`, :func:`extend_outside`,
  :func:`phase_offsets`, :func:`supersample`, :func:`variance_blend` -- the flow
  rendering (beyond the paper).
- :func:`render`, :class:`Animation`, :func:`prefetch` -- the pipeline;
  :func:`preview_frame`, :func:`prefetch_preview` -- one quick frame for live previews.
- ``reference_*`` -- the plain numpy versions the fast paths are tested against.
"""

from .._common._params import RENDERINGS
from .._common._weights import fragment_weights
from ._blend import blend_differences
from ._composite import composite, dynamic_matte, inpaint_background, loop_crossfade
from ._desync import mirror_axes, stagger, sync_share, temporal_offsets
from ._fill import exemplar_fill
from ._flow_render import (
    displacement_maps,
    eulerian_loop,
    extend_outside,
    flow_field,
    flow_timing,
    loop_phases,
    phase_offsets,
    supersample,
)
from ._histograms import match_histograms_cells
from ._motion_blur import motion_blur
from ._phase_blend import variance_blend
from ._preview import prefetch_preview, preview_frame
from ._reference import (
    reference_blend_differences,
    reference_eulerian_loop,
    reference_fill,
    reference_layer_blend,
    reference_match_histograms_cells,
    reference_motion_blur,
    reference_supersample,
    reference_variance_blend,
)
from ._render import Animation, prefetch, render

__all__ = [
    "RENDERINGS",
    "Animation",
    "blend_differences",
    "composite",
    "displacement_maps",
    "dynamic_matte",
    "eulerian_loop",
    "exemplar_fill",
    "extend_outside",
    "flow_field",
    "flow_timing",
    "fragment_weights",
    "inpaint_background",
    "loop_crossfade",
    "loop_phases",
    "match_histograms_cells",
    "mirror_axes",
    "motion_blur",
    "phase_offsets",
    "prefetch",
    "prefetch_preview",
    "preview_frame",
    "reference_blend_differences",
    "reference_eulerian_loop",
    "reference_fill",
    "reference_layer_blend",
    "reference_match_histograms_cells",
    "reference_motion_blur",
    "reference_supersample",
    "reference_variance_blend",
    "render",
    "stagger",
    "supersample",
    "sync_share",
    "temporal_offsets",
    "variance_blend",
]
