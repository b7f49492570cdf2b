r"""Layers over the photo: one timeline, then each layer composited in order.

With :math:`P` the photo, :math:`O_k(t)` the picture after layer :math:`k` at time
:math:`t` (:math:`O_0 = P`), a layer's picture :math:`C_k`, its weight
:math:`a_k \in [0, 1]`:

.. math::

    \text{replace (water, clouds, flicker):}\quad O_k = (1 - a_k) O_{k-1} + a_k C_k

    \text{cover (frost):}\quad O_k = (1 - a_k) O_{k-1} + C_k \quad (C_k\ \text{premultiplied})

    \text{light (fire):}\quad O_k = \min\big(1,\ O_{k-1} + a_k C_k\big)

The result is clipped to [0, 1]. Where no layer reaches (every :math:`a_k = 0`, and
a fire's light is black there), each frame is the photo exactly.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["composite", "composite_pictures", "frame_index", "timeline"]


def timeline(layers, fps, duration=None):
    """The scene's frame count and each layer's frame at every scene frame.

    Parameters
    ----------
    layers : list of LayerClip
    fps : float
        The scene's frames a second.
    duration : float, optional
        Seconds; default the longest layer's (a loop's one cycle, a growth's
        length): shorter loops repeat, a growth holds its last frame.

    Returns
    -------
    n : int
    indices : list of ndarray (n,) of int
    """
    if duration is None:
        duration = max(layer.duration for layer in layers)
    n = max(1, math.ceil(duration * fps - 1e-9))
    return n, [frame_index(np.arange(n), fps, layer) for layer in layers]


def frame_index(t, fps, layer):
    """Which of ``layer``'s frames shows at scene frames ``t`` (at ``fps``)."""
    i = np.floor(np.asarray(t) * (layer.fps / fps) + 1e-9).astype(np.int64)
    return i % len(layer) if layer.loops else np.minimum(i, len(layer) - 1)


def composite(photo, layers, blends, indices, t):
    """Scene frame ``t``: the photo, then every layer in order (module docstring)."""
    pictures = [layer.picture(int(index[t])) for layer, index in zip(layers, indices)]
    return composite_pictures(photo, pictures, blends)


def composite_pictures(photo, pictures, blends):
    """One scene frame from each layer's ``(colour, alpha)`` at that moment, in order.

    What :func:`composite` does with the layers' frames at ``t``; a streamed scene
    (``render(..., stream=True)``) calls it with frames made as they are needed, so
    both give the same frames.
    """
    out = np.array(photo, np.float32, copy=True)
    for (colour, alpha), blend in zip(pictures, blends):
        a = alpha[..., None]
        if blend == "replace":
            out += a * (colour - out)
        elif blend == "cover":
            out *= 1.0 - a
            out += colour
        elif blend == "light":
            out += a * colour
            np.minimum(out, 1.0, out=out)
        else:
            raise ValueError(f"blend must be replace, cover or light, got {blend!r}")
    return np.clip(out, 0.0, 1.0, out=out)
