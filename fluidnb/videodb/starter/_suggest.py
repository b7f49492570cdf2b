"""Which starter database suits a photo: a first guess from its colours."""

from __future__ import annotations

import numpy as np

from ..._image import as_image

__all__ = ["suggest_kind"]


def suggest_kind(image, matte=None):
    """The starter database (``"water"``, ``"smoke"`` or ``"fire"``) a photo looks like.

    Beyond the paper (Okabe et al. pick the database by hand): a first guess from the
    colours inside the matte (the whole photo without one), for an app to suggest
    when a photo is uploaded -- flames are warm and saturated, smoke, steam and
    clouds show bright near-white areas, water the rest (grey, blue, green or dark).
    On the bundled photos: stream and lake water, clouds smoke, fire fire. A
    suggestion in words, never a choice made for the user.

    Parameters
    ----------
    image : array_like or path
        The photo (RGB).
    matte : array_like of bool or float, shape (H, W), optional
        Where the fluid is (> 0.5).

    Returns
    -------
    kind : str
        ``"water"``, ``"smoke"`` or ``"fire"``.
    reason : str
        The measure it rests on, in words.

    Examples
    --------
    >>> from fluidnb import data
    >>> [suggest_kind(data.sample(n, size=64))[0] for n in ("stream", "clouds", "fire", "lake")]
    ['water', 'smoke', 'fire', 'water']
    """
    from skimage.color import rgb2hsv

    rgb = as_image(image, mode="rgb", name="image")
    inside = np.ones(rgb.shape[:2], bool)
    if matte is not None:
        mask = np.asarray(matte, np.float32) > 0.5
        if mask.shape != inside.shape:
            raise ValueError(f"matte must have the image's size {inside.shape}, got {mask.shape}")
        if mask.any():
            inside = mask
    hsv = rgb2hsv(rgb)[inside]
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    lit = v > 0.25
    warm = lit & (s > 0.35) & ((h < 0.17) | (h > 0.95))
    white = (v > 0.75) & (s < 0.2)
    n = max(int(lit.sum()), 1)
    if warm.sum() / n > 0.4:
        return "fire", f"{100 * warm.sum() / n:.0f} % of its lit pixels are warm and saturated"
    if white.sum() / n > 0.12:
        return "smoke", f"{100 * white.sum() / n:.0f} % of its lit pixels are near-white"
    return "water", "it is neither flame-warm nor near-white"
