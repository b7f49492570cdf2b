"""The video-database lessons' pictures: one module per lesson (07a, 07b), and the app's.

- 07a (the database): :func:`versions_figure`, :func:`clip_fragments_figure`,
  :func:`fragment_figure`, :func:`spectra_figure`, :func:`retrieval_figure`,
  :func:`version_label`.
- 07b (the animation): :func:`assignment_figure`, :func:`sweep_figure`,
  :func:`rendering_figure`.
- The app's (and 07b's) pictures: :func:`clip_colour`, :func:`clip_map_picture`,
  :func:`motion_arrows`.
"""

from ._animation import assignment_figure, rendering_figure, sweep_figure
from ._database import (
    clip_fragments_figure,
    fragment_figure,
    retrieval_figure,
    spectra_figure,
    version_label,
    versions_figure,
)
from ._pictures import clip_colour, clip_map_picture, motion_arrows

__all__ = [
    "assignment_figure",
    "clip_colour",
    "clip_fragments_figure",
    "clip_map_picture",
    "fragment_figure",
    "motion_arrows",
    "rendering_figure",
    "retrieval_figure",
    "spectra_figure",
    "sweep_figure",
    "version_label",
    "versions_figure",
]
