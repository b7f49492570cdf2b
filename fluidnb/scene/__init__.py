"""One photo, several methods: a scene of animated layers composited into one clip.

A :class:`Scene` holds a photo and an ordered list of :class:`Layer` s, each animated
by its own method with its own parameters -- water and clouds by the video database
(Okabe et al. 2011), flicker (Yamamoto & Sakamoto), fire (Furukawa et al. 2013),
frost (Amano et al.) -- in its own painted region. :func:`render` runs each layer
(caching its clip, so a change to one layer re-renders only that one), brings them to
one frame rate and length (loops repeat; frost grows once and holds) and composites
them over the photo in order: water and flicker replace, frost covers, fire adds
light. Outside every region each frame is the photo. :func:`save_scene` and
:func:`load_scene` keep a scene in a folder (JSON and PNG masks).
"""

from ._composite import composite, composite_pictures, frame_index, timeline
from ._file import SCENE_VERSION, load_scene, save_scene
from ._layer import KINDS, Layer
from ._methods import (
    LayerClip,
    LayerStream,
    default_params,
    innermost_point,
    run_layer,
    seamless_loop,
)
from ._scene import Scene, render

__all__ = [
    "KINDS",
    "SCENE_VERSION",
    "Layer",
    "LayerClip",
    "LayerStream",
    "Scene",
    "composite",
    "composite_pictures",
    "default_params",
    "frame_index",
    "innermost_point",
    "load_scene",
    "render",
    "run_layer",
    "save_scene",
    "seamless_loop",
    "timeline",
]
