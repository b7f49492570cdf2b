"""The fixed geometry of fragments shared by the database and the target (Okabe et al., secs. 4-5).

Every length here is in pixels of the image a fragment is cut from (a database clip's
augmented version, or the target image).

- A fragment is ``FRAGMENT x FRAGMENT`` = 48 x 48 pixels (Okabe et al., sec. 4); neighbours
  overlap by half: their top-left corners lie on a grid of step ``STRIDE`` = 24
  (our decision; the paper only says they overlap, Fig. 4-b).
- Appearance: 9 x 9 dense SIFT descriptors per fragment. Descriptor ``k`` (per axis,
  ``k = 0 .. 8``) covers pixels ``[4k, 4k + 16)``: 4 x 4 spatial bins of 4 px, step 4,
  exactly tiling the 48 px.
- Motion spectra are kept at ``SPECTRA_SIDE`` = 12 x 12 (4 x 4 pixel blocks) and
  textureness at ``TEXTURE_SIDE`` = 24 x 24 (2 x 2 blocks), so the overlap of two
  neighbours (half a fragment) is a whole number of blocks: 6 or 12 of them.
"""

from __future__ import annotations

__all__ = [
    "ANGLES",
    "FRAGMENT",
    "GRID",
    "LEVELS",
    "SCALES",
    "SPECTRA_BLOCK",
    "SPECTRA_SIDE",
    "STRIDE",
    "TEXTURE_BLOCK",
    "TEXTURE_LEVELS",
    "TEXTURE_SIDE",
    "VERSIONS",
]

#: Side of a fragment in pixels (Okabe et al., sec. 4).
FRAGMENT = 48
#: Step between neighbouring fragments' top-left corners (half a fragment).
STRIDE = 24
#: Dense SIFT descriptors per axis on a fragment (Okabe et al., sec. 4: a 9 x 9 grid).
GRID = 9
#: Spatial-pyramid levels 0, 1, 2 (Lazebnik et al. 2006): 1 + 4 + 16 = 21 cells.
LEVELS = 3
#: Pixels per side of the blocks the motion spectra are averaged over, and the side
#: of the stored spectra (48 / 4 = 12).
SPECTRA_BLOCK = 4
SPECTRA_SIDE = FRAGMENT // SPECTRA_BLOCK
#: Levels of the Laplacian pyramid of the textureness (Okabe et al., Fig. 7), pixels per side
#: of the blocks it is averaged over, and the side of the stored map (48 / 2 = 24).
TEXTURE_LEVELS = 4
TEXTURE_BLOCK = 2
TEXTURE_SIDE = FRAGMENT // TEXTURE_BLOCK

#: Augmentation (Okabe et al., sec. 4, Fig. 4-a): scales of the original size and rotations
#: in degrees (counter-clockwise on screen), each with and without a horizontal flip.
SCALES = (0.5, 0.75, 1.0)
ANGLES = (-22.5, 0.0, 22.5)

#: The 18 versions of a clip as ``(flip, scale, angle)``; a fragment's ``version`` is
#: an index into this tuple: ``index = 9 * flip + 3 * scale_index + angle_index``.
#: Version 7 is the clip itself (no flip, 100 %, 0 degrees); 16 is its mirror image.
VERSIONS = tuple(
    (flip, scale, angle) for flip in (False, True) for scale in SCALES for angle in ANGLES
)
