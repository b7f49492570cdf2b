"""A scene: one photo, several methods, one clip."""

from __future__ import annotations

import hashlib
import time
from collections import OrderedDict

import numpy as np

from .._image import as_image
from .._progress import Progress
from .._stream import FrameStream
from .._validation import check_range
from ._composite import composite_pictures, timeline
from ._layer import Layer
from ._methods import LayerStream, run_layer

__all__ = ["Scene", "render"]

#: Layer clips a scene keeps (the last ones made), so a change to one layer re-renders
#: only that layer.
CACHE_SIZE = 8


class Scene:
    """A photo and an ordered list of animated layers (bottom first).

    Parameters
    ----------
    photo : array_like, path or PIL image
        The picture (RGB; grey is made RGB, an alpha channel is dropped).
    layers : list of Layer, optional
    size : int, optional
        Longest side the scene is rendered at; the photo is shrunk to it (default
        480; None keeps the photo's size). The photo as given is kept
        (:attr:`source`): a scene worked on at a small size (a proxy: quick
        previews) is rendered at full size by ``render(scene.resized(), stream=True)``,
        its layers scaled exactly (:meth:`resized`).
    fps : float
        The scene's frames a second (every layer is brought to it).
    duration : float, optional
        Seconds; default the longest layer's (:func:`fluidnb.scene.timeline`).

    Examples
    --------
    >>> import numpy as np
    >>> from fluidnb.data import sample
    >>> from fluidnb.flicker import FlickerParams
    >>> photo = sample("lake", size=64)
    >>> water = np.zeros(photo.shape[:2], bool)
    >>> water[30:, :] = True
    >>> scene = Scene(photo, [Layer("flicker", water, FlickerParams(T=16, fps=8.0))], size=None)
    >>> clip = render(scene)  # 16 frames at 8 fps: 2 s at 24 fps
    >>> clip.n_frames, clip.fps
    (48, 24.0)
    >>> bool(np.array_equal(clip.frames[5, :30], scene.photo[:30]))  # outside: the photo
    True
    """

    def __init__(self, photo, layers=(), *, size=480, fps=24.0, duration=None):
        image = as_image(photo)
        if image.ndim == 2:
            image = np.repeat(image[..., None], 3, axis=-1)
        image = np.ascontiguousarray(image[..., :3], np.float32)
        #: The photo as given, at its full size: :meth:`resized` makes the scene at
        #: another size from it (a preview's proxy exported at full size).
        self.source = image
        if size is not None:
            from ..fields import resize

            size = int(check_range("size", size, 8))
            f = size / max(image.shape[:2])
            if f < 1:
                shape = (max(1, round(image.shape[0] * f)), max(1, round(image.shape[1] * f)))
                image = np.clip(resize(image, shape), 0, 1).astype(np.float32)
        self.photo = image
        self.fps = float(check_range("fps", fps, 0, lo_open=True))
        self.duration = (
            None if duration is None else check_range("duration", duration, 0, lo_open=True)
        )
        self.layers = []
        self.cache = OrderedDict()  #: layer key -> LayerClip (the last CACHE_SIZE made)
        self.renders = 0  #: Layers rendered by their method so far (the cache's misses).
        # Each layer as it was given (name -> (the scene's layer, the given one)), so
        # resized() scales from the coordinates a region was painted in, not from the
        # scene's smaller copy of it: nothing painted at full size is lost.
        self._given = {}
        for layer in layers:
            self.add(layer)

    @property
    def shape(self):
        """(H, W) of the scene."""
        return self.photo.shape[:2]

    @property
    def photo_key(self):
        """A digest of the photo (part of every layer's cache key)."""
        return hashlib.sha256(self.photo.tobytes()).hexdigest()[:20]

    @property
    def full_shape(self):
        """(H, W) of the photo as given (:attr:`source`): what :meth:`resized` ``(None)`` has."""
        return self.source.shape[:2]

    def fit(self, layer):
        """``layer`` at the scene's size: its region resized, strokes, starts, speed scaled.

        A region of another size must be the photo's shape scaled (a proxy's or the
        full photo's): rows and columns are scaled each by their own factor.
        """
        if not isinstance(layer, Layer):
            raise ValueError(f"layer must be a fluidnb.scene.Layer, got {type(layer).__name__}")
        if layer.region.shape == self.shape:
            return layer
        from ..fields import resize

        (h, w), (rh, rw) = self.shape, layer.region.shape
        fy, fx = h / rh, w / rw
        # Each side was rounded to whole pixels (half a pixel), perhaps twice (a
        # preview made from a proxy made from the photo): one pixel a side.
        if abs(fy / fx - 1) > 1 / h + 1 / w + 1 / rh + 1 / rw:
            raise ValueError(
                f"layer {layer.name!r}: region shape {layer.region.shape} is neither the "
                f"scene's {self.shape} nor a scaled copy of it (the photo's aspect "
                f"{w / h:.4g}, the region's {rw / rh:.4g})"
            )
        scale = np.array([fy, fx], np.float32)
        changes = {"region": np.clip(resize(layer.region, self.shape), 0, 1)}
        if layer.strokes:
            changes["strokes"] = tuple(s * scale for s in layer.strokes)
        if layer.starts is not None:
            changes["starts"] = layer.starts * scale.astype(np.float64)
        if layer.speed is not None:
            # px/frame: a speed is a length, scaled with the picture.
            changes["speed"] = resize(layer.speed, self.shape, order=0) * (0.5 * (fy + fx))
        return layer.replace(**changes)

    def add(self, layer, index=None):
        """Add a layer (on top, or at ``index``); its region is the photo's (any size of it).

        A region of another size than the scene's (the full photo's, or a proxy's) is
        resized to it (:meth:`fit`), and the layer as given is kept for :meth:`resized`.
        """
        given = layer
        layer = self.fit(layer)
        if any(other.name == layer.name for other in self.layers):
            raise ValueError(f"a layer named {layer.name!r} is already in the scene")
        self.layers.insert(len(self.layers) if index is None else index, layer)
        self._given[layer.name] = (layer, given)
        return layer

    def resized(self, size=None):
        """The same scene with its photo at another size: a proxy's export at full size.

        Parameters
        ----------
        size : int, optional
            Longest side (>= 8), at most the photo's as given; None: the photo's full
            size (:attr:`full_shape`).

        Returns
        -------
        Scene
            A new scene (its own empty cache) of :attr:`source` at ``size``, the same
            fps, duration and layers in order. A layer is scaled from the coordinates
            it was given in (a region painted at full size comes back unchanged at full
            size); a layer changed on this scene since (:meth:`update`, or
            :attr:`layers` set directly) is scaled from its copy at this scene's size.
            Without a duration of its own, a scene whose visible layers are all
            rendered (in its cache: a proxy previewed) gives the new one its length,
            so the export is as long as what was seen: frost fits its growth rate at
            each size, and its growth at full size ends a few frames from the
            proxy's (95 against 101 frames for the lake at 1920 px), which would make
            the longest layer, and so the scene, longer or shorter.

        Examples
        --------
        >>> import numpy as np
        >>> photo = np.zeros((200, 300, 3), np.float32)
        >>> region = np.zeros((200, 300), bool)
        >>> region[50:150, 100:250] = True
        >>> proxy = Scene(photo, [Layer("flicker", region)], size=60)  # 40 x 60
        >>> proxy.shape, proxy.layers[0].region.shape
        ((40, 60), (40, 60))
        >>> full = proxy.resized()
        >>> full.shape, bool(np.array_equal(full.layers[0].region, region))
        ((200, 300), True)
        """
        duration = self.duration if self.duration is not None else self._rendered_duration()
        scene = Scene(self.source, size=size, fps=self.fps, duration=duration)
        for layer in self.layers:
            kept = self._given.get(layer.name)
            scene.add(kept[1] if kept is not None and kept[0] is layer else layer)
        return scene

    def _rendered_duration(self):
        """The length :func:`render` gives this scene, if every visible layer is cached."""
        visible = [layer for layer in self.layers if layer.visible]
        keys = [layer.key(self.photo_key, self.shape) for layer in visible]
        if not visible or any(key not in self.cache for key in keys):
            return None
        return max(self.cache[key].duration for key in keys)

    def layer(self, name):
        """The layer called ``name``."""
        for layer in self.layers:
            if layer.name == name:
                return layer
        raise ValueError(f"no layer named {name!r}; the scene has {[x.name for x in self.layers]}")

    def update(self, name, **changes):
        """Change a layer's fields (its params, region, ...); only it re-renders."""
        i = self.layers.index(self.layer(name))
        old = self.layers[i]
        self.layers[i] = old.replace(**changes)
        kept = self._given.get(name)
        geometry = {"region", "strokes", "starts", "speed", "name"}
        if kept is not None and kept[0] is old and not geometry & set(changes):
            # Its params, visibility, ...: the layer as given follows (its geometry kept).
            self._given[name] = (self.layers[i], kept[1].replace(**changes))
        return self.layers[i]

    def remove(self, name):
        """Remove the layer called ``name``."""
        self.layers.remove(self.layer(name))

    def move(self, name, index):
        """Put the layer called ``name`` at position ``index`` (0: bottom)."""
        layer = self.layer(name)
        self.layers.remove(layer)
        self.layers.insert(index, layer)

    def __repr__(self):
        h, w = self.shape
        names = ", ".join(f"{x.name} ({x.kind})" for x in self.layers) or "no layers"
        return f"Scene({w}x{h}, {self.fps:g} fps: {names})"


def render(scene, *, quick=None, stream=False, progress=None):
    """Render a scene: each visible layer by its method (cached), composited in order.

    Parameters
    ----------
    scene : Scene
    quick : bool, optional
        The small starter databases for water and clouds (default: on when
        ``FLUIDNB_QUICK`` is set).
    stream : bool
        Return a :class:`fluidnb.FrameStream` of the same frames instead of the
        clip: each layer's method runs now up to its frames (a video database's
        assignment, frost's growth, the fire at its own size), and the frames of
        every layer are made as the scene's are composited and saved, so a file of
        a full-size photo holds a few frames of each layer, not their clips
        (docs/conventions.md, "Streams"). A stream does not use or fill the scene's
        cache.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    Clip or FrameStream
        ``scene.fps`` frames a second, as long as ``scene.duration`` or the longest
        layer; metadata ``method="scene"``, ``layers`` (name, kind, method, frames,
        fps, seconds it took or ``"cached"``) and ``timings``.
    """
    import os

    if quick is None:
        quick = bool(os.environ.get("FLUIDNB_QUICK"))
    visible = [layer for layer in scene.layers if layer.visible]
    if not visible:
        raise ValueError("the scene has no visible layer: add one (or show a hidden one)")
    report = Progress(progress)
    parts = report.split(*[(i + 1) / (len(visible) + 1) for i in range(len(visible))])
    clips, info = [], []
    photo_key = scene.photo_key
    for layer, part in zip(visible, parts):
        key = layer.key(photo_key, scene.shape)
        if not stream and key in scene.cache:
            scene.cache.move_to_end(key)
            clips.append(scene.cache[key])
            seconds = "cached"
        else:
            part(0.0, f"{layer.name}: {layer.method}")
            started = time.perf_counter()
            clips.append(run_layer(layer, scene.photo, quick=quick, progress=part, stream=stream))
            seconds = round(time.perf_counter() - started, 2)
            scene.renders += 1
            if not stream:
                scene.cache[key] = clips[-1]
                while len(scene.cache) > CACHE_SIZE:
                    scene.cache.popitem(last=False)
        c = clips[-1]
        info.append(
            {"name": layer.name, "kind": layer.kind, "method": layer.method,
             "frames": len(c), "fps": c.fps, "loops": c.loops, "seconds": seconds}
        )  # fmt: skip
    last = parts[-1]  # the compositing
    n, indices = timeline(clips, scene.fps, scene.duration)
    blends = [layer.blend for layer in visible]
    photo = scene.photo
    timings = {"composite": 0.0}

    def blocks():
        # About 32 MB of scene frames at a time (a few at 1920 px).
        per = max(1, min(n, (32 << 20) // photo.nbytes))
        for c in clips:
            if isinstance(c, LayerStream):
                c.restart()  # each pass makes every layer's frames again from its start
        for t0 in range(0, n, per):
            started = time.perf_counter()
            out = np.empty((min(per, n - t0), *photo.shape), np.float32)
            for i in range(len(out)):
                t = t0 + i
                pictures = [c.picture(int(index[t])) for c, index in zip(clips, indices)]
                out[i] = composite_pictures(photo, pictures, blends)
            timings["composite"] += time.perf_counter() - started
            last((t0 + len(out)) / n, f"frame {t0 + len(out)} of {n}")
            yield out

    def metadata():
        return {
            "method": "scene",
            "layers": info,
            "timings": {"composite": round(timings["composite"], 3)},
        }

    frames = FrameStream(
        blocks, n_frames=n, shape=scene.shape, color=True, fps=scene.fps, metadata=metadata
    )
    if stream:
        return frames
    # The clip is the stream collected: one code path, the same frames.
    clip = frames.clip()
    last(1.0, "composited")
    return clip
