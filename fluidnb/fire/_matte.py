"""A painted matte made into the flame's own soft matte (beyond the paper).

The paper takes the photo's alpha :math:`a_a` as given. A user who paints the matte
with a brush paints a hard-edged (0/1) mask that covers part of the flame and some of
the background around it. Used as it is, that mask made the fire out of hard-edged,
holed blobs: the exemplar :math:`I_a` (the photo composited onto black with the
matte) held the flame cut off along the brush's edge, bits of the background inside
the painted area as dim "flame", and none of the flame the brush missed; the
synthesis copies patches of it, cut edges and gaps included. :func:`flame_matte`
reads the painted mask as a hint of which flame is meant and finds that flame in the
photo.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["flame_matte", "is_hard"]

_LUMA = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)


def is_hard(matte):
    """Whether a matte holds only 0 and 1: painted with a brush, not an alpha channel."""
    m = np.asarray(matte)
    return bool(np.all((m == 0) | (m == 1)))


def flame_matte(photo, hint, *, reach=0.25):
    r"""The soft matte of the flame(s) a painted ``hint`` touches.

    Fire is light added to the scene, so the flame's own light is the photo's
    luminance above the background's, :math:`E = \max(L - L_{bg}, 0)`:

    1. :math:`L_{bg}`: the median luminance of the photo away from the hint (beyond
       4 % of its size), the photo's darkest 5 % if little is left;
       :math:`L_f`, the flame's level: the 90th percentile inside the hint.
    2. The flame: the connected parts of :math:`E > 0.1 (L_f - L_{bg})` that the
       hint touches, their holes filled, within ``reach`` of the photo's longer
       side from the hint -- the whole flame, however little of it was painted,
       and none of the background the brush covered.
    3. The matte is :math:`E / L` on that region (so the photo times the matte has
       the luminance :math:`E`: the flame's light over black), the region's edge
       feathered by a Gaussian of 1.5 pixels. The flame's own fall-off gives it
       soft edges where the brush's edge was hard.

    When the hinted region is not brighter than the rest (:math:`L_f - L_{bg} <
    0.05`) there is no flame to find: the hint itself is used, its gaps closed and
    its edge feathered.

    Parameters
    ----------
    photo : ndarray, shape (H, W, 3), float in [0, 1]
    hint : ndarray, shape (H, W)
        The painted matte; > 0.5 is painted.
    reach : float
        How far beyond the hint the flame may extend, as a fraction of the photo's
        longer side.

    Returns
    -------
    ndarray, shape (H, W), float32 in [0, 1]

    Examples
    --------
    A bright blob on a grey background, painted only in its middle:

    >>> yy, xx = np.mgrid[:40, :40]
    >>> glow = np.exp(-((yy - 20.0) ** 2 + (xx - 20.0) ** 2) / 60)
    >>> photo = np.repeat((0.2 + 0.8 * glow)[..., None], 3, axis=2).astype(np.float32)
    >>> hint = (abs(yy - 20) < 3) & (abs(xx - 20) < 3)
    >>> m = flame_matte(photo, hint)
    >>> bool(m[20, 20] > 0.7), bool(m[20, 28] > 0.2), float(m[2, 2])
    (True, True, 0.0)
    """
    photo = np.asarray(photo, np.float32)
    painted = np.asarray(hint) > 0.5
    if not painted.any() or painted.all():
        return painted.astype(np.float32)
    lum = photo @ _LUMA
    size = max(lum.shape)
    near = ndimage.binary_dilation(painted, iterations=max(2, round(0.04 * size)))
    away = lum[~near]
    background = (
        float(np.median(away)) if away.size >= 0.01 * lum.size else float(np.percentile(lum, 5))
    )
    level = float(np.percentile(lum[painted], 90))
    if level - background < 0.05:
        closed = ndimage.binary_closing(painted, iterations=2) | painted
        region = ndimage.binary_fill_holes(closed).astype(np.float32)
        return np.clip(ndimage.gaussian_filter(region, 1.5), 0, 1).astype(np.float32)
    light = np.maximum(lum - background, 0.0)
    lit = light > 0.1 * (level - background)
    within = ndimage.distance_transform_edt(~painted) <= reach * size
    labels, _ = ndimage.label(lit & within)
    touched = np.unique(labels[painted & lit])
    region = np.isin(labels, touched[touched > 0])
    region = ndimage.binary_fill_holes(region).astype(np.float32)
    soft = ndimage.gaussian_filter(region, 1.5)
    matte = np.where(lum > 1e-6, light / np.maximum(lum, 1e-6), 0.0) * soft
    return np.clip(matte, 0.0, 1.0).astype(np.float32)
