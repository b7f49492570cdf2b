r"""What the renders of one photo share, made once and kept while its target lives.

An app renders the same photo again and again (after a re-solve, with other rendering
settings): the blend's weights and plan, the colour axes and the matching's reference
side, the advected layer and its grid, and the background behind a moving matte are
made once per target and kept (read-only) in a weak dictionary.
"""

from __future__ import annotations

import threading
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._common._weights import FEATHER
from ._blend import BLEND_LEVELS, MARGIN, _BlendPlan
from ._colour_axes import colour_axes
from ._composite import inpaint_background
from ._flow_render import SUPERSAMPLE, _grid, extend_outside, supersample
from ._histograms import _Matching

__all__ = []


def _behind(target, background):
    """What shows where a moving matte uncovers the scene, on the canvas.

    The given background, or the target filled behind its matte with its own texture
    (made once per target: :func:`_shared`).
    """
    if background is None:
        return _shared(
            target, "behind", lambda: inpaint_background(target.canvas, target.canvas_matte)
        )
    back = target.canvas.copy()
    h, w = target.shape
    back[:h, :w] = background
    return back


# What the renders of one target share, made once and kept while the target lives
# (an app renders the same photo again and again: after a re-solve, with other
# rendering settings): see _shared.
_SHARED = weakref.WeakKeyDictionary()


_SHARED_LOCK = threading.Lock()


def _shared(owner, key, make):
    """``make()`` for ``owner`` (a target) and ``key``, made once and kept while it lives.

    What is kept is read-only: renders hand out views of it (their stages).
    """
    with _SHARED_LOCK:
        kept = _SHARED.setdefault(owner, {})
        if key in kept:
            return kept[key]
    value = make()
    for v in value if isinstance(value, tuple) else (value,):
        if isinstance(v, np.ndarray):
            v.flags.writeable = False
    with _SHARED_LOCK:
        return _SHARED.setdefault(owner, {}).setdefault(key, value)


class _Later:
    """``fn(*args)`` made on a thread of its own while the caller goes on; :attr:`value` waits."""

    def __init__(self, fn, *args):
        pool = ThreadPoolExecutor(1)
        self._future = pool.submit(fn, *args)
        pool.shutdown(wait=False)

    @property
    def value(self):
        return self._future.result()


def _blend_plan(target):
    """The blend's weights for the target's fragments (:class:`_BlendPlan`), kept."""
    shape = target.canvas.shape[:2]
    return _shared(
        target, "blend", lambda: _BlendPlan(target.positions, shape, MARGIN, BLEND_LEVELS, FEATHER)
    )


def _colour_matching(target, cell):
    """The target's colour axes and the matching to it in them (:class:`_Matching`), kept.

    Heeger & Bergen 1995 decorrelate colour by PCA: matching R, G and B independently
    can mix hues the photo does not have (a white-hot flame turned lilac); matching
    decorrelated axes keeps its colours.
    """

    def make():
        centre, axes = colour_axes(target.canvas, target.canvas_matte)
        reference = (target.canvas - centre) @ axes
        return centre, axes, _Matching(reference, target.canvas_matte.astype(np.float64), cell)

    return _shared(target, ("axes", cell), make)


def _advected_layer(target):
    """What the flow moves (the photo, mirrored outside the matte), kept for the target.

    The layer, the same made finer by :func:`supersample` (what the phases are sampled
    from) and the canvas's pixel grid.
    """
    canvas, matte = target.canvas, target.canvas_matte
    layer = _shared(target, "layer", lambda: extend_outside(canvas, matte))
    fine = _shared(target, ("fine", SUPERSAMPLE), lambda: supersample(layer, SUPERSAMPLE))
    return layer, fine, _shared(target, "grid", lambda: _grid(canvas.shape[:2]))
