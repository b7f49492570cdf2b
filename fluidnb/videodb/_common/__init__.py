"""What the video-database method's stages share, below all of them: sizes, params, weights.

- ``_geometry``: the fragment's size, the grid's stride, the 18 augmented versions, the
  blocks the features are stored at;
- ``_params``: :class:`~fluidnb.videodb.DatabaseParams` (the database, Okabe et al.,
  sec. 4) and :class:`~fluidnb.videodb.AnimateParams` (the assignment and the
  rendering, secs. 5-6);
- ``_sums``: numpy's pairwise summation, compiled (the features and the energies sum
  as numpy does);
- ``_weights``: the partition-of-unity weights of the fragment grid, which the
  assignment spreads its motion with and the rendering blends with.

Nothing here imports a stage: data flows database -> assignment -> rendering.
"""

__all__ = []
