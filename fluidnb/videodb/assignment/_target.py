"""The target image cut into fragments exactly as the database's (Okabe et al., sec. 5).

The target (a photo or painting of fluid) is padded by reflection at its bottom and
right to whole strides and cut into 48 x 48 fragments on the stride-24 grid, the
database's own geometry (:mod:`fluidnb.videodb._common._geometry`); only the fragments that
touch the matte take part (:func:`cut_target`). The user's motion, flow strokes and a
painted speed, is averaged over each of them (:func:`fragment_motion`) for the
retrieval's motion filter (Okabe et al., Fig. 8).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._image import as_image
from ..._validation import check_array, check_shape_match, check_vector_field
from ...sketch import direction_field
from .._common._geometry import FRAGMENT, STRIDE

__all__ = ["Target", "cut_target", "fragment_motion"]


@dataclass(frozen=True, eq=False)
class Target:
    """The target image cut into fragments as the database's (Okabe et al., sec. 5).

    Attributes
    ----------
    image : ndarray, shape (H, W, 3), float32
        The target photo.
    matte : ndarray, shape (H, W), float32
        Its alpha matte in [0, 1] (1 everywhere when none was given).
    canvas : ndarray, shape (Hc, Wc, 3), float32
        The image padded by reflection at the bottom and right to whole strides.
    canvas_matte : ndarray, shape (Hc, Wc), float32
        The matte padded with zeros.
    active : ndarray, shape (R, C), bool
        Fragments of the grid that touch the matte (they take part).
    positions : ndarray, shape (P, 2), int64
        Top-left (row, col) of the taking-part fragments on the canvas, raster order.
    fragments : ndarray, shape (P, 48, 48, 3), float32
        Their pixels.
    """

    image: np.ndarray
    matte: np.ndarray
    canvas: np.ndarray
    canvas_matte: np.ndarray
    active: np.ndarray
    positions: np.ndarray
    fragments: np.ndarray

    @property
    def shape(self):
        """(H, W) of the image."""
        return self.image.shape[:2]

    def __len__(self):
        return len(self.positions)


def cut_target(image, matte=None):
    """Cut a target image into the fragments that take part (Okabe et al., sec. 5, Fig. 2-i).

    Parameters
    ----------
    image : array_like or path, shape (H, W, 3), (H, W) or (H, W, 4)
        The photo or painting (any form :func:`fluidnb.as_image` reads). With an alpha
        channel and no ``matte``, the alpha is the matte.
    matte : array_like or path, shape (H, W), optional
        The fluid region's alpha matte in [0, 1] (a painted mask works too). Default:
        the alpha channel, else the whole image.

    Returns
    -------
    Target

    Raises
    ------
    ValueError
        For an image smaller than a fragment, a matte of another size, an empty matte,
        or NaN.

    Examples
    --------
    >>> t = cut_target(np.zeros((60, 100, 3), np.float32))
    >>> t.canvas.shape, t.active.shape, len(t)
    ((72, 120, 3), (2, 4), 8)
    """
    rgb, alpha = as_image(image, mode="rgb", name="image", return_alpha=True)
    h, w = rgb.shape[:2]
    if min(h, w) < FRAGMENT:
        raise ValueError(
            f"image must be at least {FRAGMENT} x {FRAGMENT} pixels (one fragment), got {h} x {w}"
        )
    if matte is None:
        m = np.ones((h, w), np.float32) if alpha is None else alpha
    else:
        m = as_image(matte, mode="grey", name="matte")
        check_shape_match("matte", m, (h, w))
    if not (m > 0).any():
        raise ValueError("matte is empty: paint the fluid region (at least one pixel)")
    if alpha is not None:
        # Premultiplied: the colour of transparent pixels is junk, not fluid.
        rgb = rgb * alpha[..., None]
    hc = -(-h // STRIDE) * STRIDE
    wc = -(-w // STRIDE) * STRIDE
    canvas = np.pad(rgb, ((0, hc - h), (0, wc - w), (0, 0)), mode="reflect")
    cmatte = np.zeros((hc, wc), np.float32)
    cmatte[:h, :w] = m
    rows, cols = (hc - FRAGMENT) // STRIDE + 1, (wc - FRAGMENT) // STRIDE + 1
    touched = np.zeros((rows, cols), bool)
    inside = cmatte > 0
    for i in range(rows):
        for j in range(cols):
            r, c = i * STRIDE, j * STRIDE
            touched[i, j] = inside[r : r + FRAGMENT, c : c + FRAGMENT].any()
    grid = np.argwhere(touched)
    positions = (grid * STRIDE).astype(np.int64)
    offs = np.arange(FRAGMENT)
    frags = canvas[positions[:, 0, None, None] + offs[:, None], positions[:, 1, None, None] + offs]
    return Target(
        image=rgb.astype(np.float32),
        matte=m.astype(np.float32),
        canvas=canvas.astype(np.float32),
        canvas_matte=cmatte,
        active=touched,
        positions=positions,
        fragments=frags.astype(np.float32),
    )


def fragment_motion(target, direction=None, speed=None):
    """The user's motion over each target fragment (Okabe et al., sec. 5, Fig. 8).

    Parameters
    ----------
    target : Target
    direction : sequence of strokes, or ndarray (H, W, 2), optional
        Flow strokes ((n, 2) polylines in (row, col) pixels, drawn along the flow),
        interpolated over the image with radial basis functions
        (:func:`fluidnb.sketch.direction_field`), or a direction field (dy, dx) whose
        zero vectors mean "no direction here".
    speed : ndarray (H, W), optional
        Speed in px/frame; 0 means "not painted here".

    Returns
    -------
    direction : ndarray, shape (P, 2) or None
        Unit mean direction over each fragment's pixels, NaN where none.
    speed : ndarray, shape (P,) or None
        Mean painted speed over each fragment's painted pixels, NaN where none.
    field : ndarray, shape (H, W, 2) or None
        The direction field over the image.
    """
    h, w = target.shape
    field = dirs = speeds = None
    if direction is not None:
        arr = direction if isinstance(direction, np.ndarray) and direction.ndim == 3 else None
        if arr is None:
            field = direction_field(direction, (h, w))
        else:
            field = check_vector_field("direction", arr, shape=(h, w)).astype(np.float32)
        sums = _fragment_means(target, np.concatenate([field, np.ones((h, w, 1))], axis=2))
        dirs = sums[:, :2]
        norm = np.linalg.norm(dirs, axis=1, keepdims=True)
        dirs = np.where(norm > 1e-6, dirs / np.maximum(norm, 1e-12), np.nan)
    if speed is not None:
        s = check_array("speed", speed, ndim=2, dtype_kinds="biuf").astype(np.float32)
        check_shape_match("speed", s, (h, w))
        if s.min() < 0:
            raise ValueError(f"speed must be >= 0 px/frame (0: not painted), got {s.min():g}")
        painted = (s > 0).astype(np.float32)
        num = _fragment_means(target, (s * painted)[..., None])[:, 0]
        den = _fragment_means(target, painted[..., None])[:, 0]
        speeds = np.where(den > 0, num / np.maximum(den, 1e-12), np.nan)
    return dirs, speeds, field


def _fragment_means(target, field):
    """Mean of an (H, W, C) field over each taking-part fragment's 48 x 48 pixels."""
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    padded = np.zeros((hc, wc, field.shape[2]), np.float64)
    padded[:h, :w] = field
    covered = np.zeros((hc, wc), np.float64)
    covered[:h, :w] = 1.0
    ii = np.pad(padded.cumsum(0).cumsum(1), ((1, 0), (1, 0), (0, 0)))
    ci = np.pad(covered.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    r0, c0 = target.positions[:, 0], target.positions[:, 1]
    r1, c1 = r0 + FRAGMENT, c0 + FRAGMENT
    total = ii[r1, c1] - ii[r0, c1] - ii[r1, c0] + ii[r0, c0]
    count = ci[r1, c1] - ci[r0, c1] - ci[r1, c0] + ci[r0, c0]
    return total / np.maximum(count, 1.0)[:, None]
