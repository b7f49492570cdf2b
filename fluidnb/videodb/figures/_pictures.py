r"""One drawing rule for an assignment, shared by the lesson's figures and the app's map.

Each source clip's colour (:func:`clip_colour`), the photo tinted by the clip of each
fragment's cell (:func:`clip_map_picture`), and each fragment's mean motion as an
arrow (:func:`motion_arrows`): arrays, no matplotlib, so
:class:`fluidnb.widgets.VideoDBApp` draws them on its canvas as they are.
"""

from __future__ import annotations

import numpy as np

from ...fields import resize
from .._common._geometry import FRAGMENT, STRIDE
from ..assignment._retrieval import MIN_MOTION
from ._common import _check_assignment

__all__ = ["CLIP_PALETTE", "clip_colour", "clip_map_picture", "motion_arrows"]

#: The source clips' colours in every picture of an assignment, RGB 0-255: Okabe &
#: Ito's colour-blind-safe set, then a few more; clip ``k`` has colour ``k mod 12``.
CLIP_PALETTE = np.array(
    [
        (0, 114, 178),
        (230, 159, 0),
        (0, 158, 115),
        (204, 121, 167),
        (86, 180, 233),
        (213, 94, 0),
        (240, 228, 66),
        (120, 94, 240),
        (170, 170, 170),
        (140, 86, 75),
        (23, 190, 207),
        (188, 189, 34),
    ],
    np.uint8,
)


# The assignment map's picture: the photo at this brightness around the fragments'
# cells, and inside them mixed with its clip's colour in this share.
_SHADE = 0.35


_TINT = 0.6


def clip_colour(index):
    """The colour of source clip ``index`` in the pictures of an assignment, RGB in [0, 1].

    Examples
    --------
    >>> clip_colour(0), clip_colour(12) == clip_colour(0)
    ((0.0, 0.4470588235294118, 0.6980392156862745), True)
    """
    return tuple(float(v) / 255 for v in CLIP_PALETTE[int(index) % len(CLIP_PALETTE)])


def clip_map_picture(photo, clip_map=None, *, shape=None):
    """The assignment map's picture: the photo tinted by the clip animating each cell.

    Parameters
    ----------
    photo : ndarray, shape (H, W, 3)
        The target photo, in [0, 1].
    clip_map : ndarray of int, shape (H, W), optional
        The source clip of each pixel's fragment, -1 for none
        (:meth:`Assignment.clip_map`); None before there is an assignment.
    shape : (int, int), optional
        The picture's size (a canvas's): the photo resized bilinearly, the clip map
        sampled at the nearest pixel. Default the photo's.

    Returns
    -------
    ndarray, shape (h, w, 3), float
        Inside a fragment's cell 0.4 of the photo plus 0.6 of its clip's colour
        (:func:`clip_colour`), elsewhere the photo at 0.35 of its brightness.
    """
    photo = np.asarray(photo)
    h, w = photo.shape[:2]
    ch, cw = (h, w) if shape is None else (int(shape[0]), int(shape[1]))
    shown = np.clip(resize(photo, (ch, cw)) if (ch, cw) != (h, w) else photo, 0, 1)
    if clip_map is None:
        return _SHADE * shown
    rows = np.minimum((np.arange(ch) * h / ch).astype(int), h - 1)
    cols = np.minimum((np.arange(cw) * w / cw).astype(int), w - 1)
    k = np.asarray(clip_map)[rows][:, cols]
    inside = k >= 0
    # One table lookup per pixel, no masks (an app redraws this as a slider moves):
    # the photo's weight and the colour added, the last row for pixels outside.
    n = len(CLIP_PALETTE)
    which = np.where(inside, k % n, n)
    scale = np.array([1 - _TINT, _SHADE], dtype=shown.dtype)[np.where(inside, 0, 1)]
    added = np.vstack([_TINT * (CLIP_PALETTE / 255.0), np.zeros((1, 3))])
    return shown * scale[..., None] + added[which]


def motion_arrows(assignment, *, gain=None, thin=False):
    """Each assigned fragment's mean motion as an arrow centred on its fragment.

    Parameters
    ----------
    assignment : Assignment
    gain : float, optional
        Arrow length in pixels per px/frame; default: the 90th percentile of the
        fragments' speeds spans 0.9 of a stride (24 px).
    thin : bool
        Every other fragment in each direction only (arrows that do not overlap).

    Returns
    -------
    segments : ndarray, shape (k, 2, 2)
        Start and end (row, col) in image pixels, for every fragment whose centre lies
        in the image and that moves (speed above
        :data:`~fluidnb.videodb.assignment._retrieval.MIN_MOTION`).
    gain : float
        The gain used.
    """
    a = _check_assignment(assignment)
    h, w = a.target.shape
    pos = a.target.positions
    centres = pos + FRAGMENT / 2 - 0.5
    motion = a.db.mean_motion[a.fragments].astype(np.float64)
    inside = (centres[:, 0] < h) & (centres[:, 1] < w)
    if thin:
        cell = pos // STRIDE
        inside &= (cell[:, 0] % 2 == 0) & (cell[:, 1] % 2 == 0)
    c, m = centres[inside], motion[inside]
    speed = np.hypot(m[:, 0], m[:, 1])
    if gain is None:
        top = float(np.percentile(speed, 90)) if len(m) else 0.0
        gain = 0.9 * STRIDE / top if top > MIN_MOTION else 1.0
    moving = speed > MIN_MOTION
    vec = m[moving] * gain
    return np.stack([c[moving] - vec / 2, c[moving] + vec / 2], axis=1), float(gain)
