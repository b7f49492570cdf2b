"""Each layer by its own method: the call a method's app makes, on the scene's photo.

Every function here returns the layer as a :class:`LayerClip`: frames the size of the
photo, what they add or put over the picture, and how they are timed. Nothing here
composites (that is :mod:`._composite`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from .._clip import Clip

__all__ = [
    "LayerClip",
    "LayerStream",
    "default_params",
    "innermost_point",
    "run_layer",
    "seamless_loop",
]

#: Seconds of fire a fire layer simulates (its loop, before the cross-fade).
FIRE_SECONDS = 4.0
#: Seconds over which a clip that does not loop by itself is cross-faded into its start.
LOOP_SECONDS = 0.5
#: The scene size the default parameters are chosen for (frost's lattice spacing).
DEFAULT_SIZE = 480


@dataclass(frozen=True, eq=False)
class LayerClip:
    """One layer's animation, ready to composite.

    Attributes
    ----------
    colour : ndarray, shape (T, H, W, 3), float32
        ``replace``: the picture inside the layer's reach; ``light``: the light it
        adds; ``cover``: the premultiplied colour of what covers (ice).
    alpha : ndarray, shape (T, H, W) or (H, W), float32
        How much of the picture under it the layer replaces or covers (0-1); for
        ``light``, how much of its light reaches each pixel.
    fps : float
        Its frames a second.
    loops : bool
        Whether it repeats (else it holds its last frame).
    clip : Clip
        The method's own clip, as its method returned it.
    """

    colour: np.ndarray
    alpha: np.ndarray
    fps: float
    loops: bool
    clip: Clip

    def __len__(self):
        return len(self.colour)

    @property
    def duration(self):
        """Seconds the layer lasts (one loop, or its growth)."""
        return len(self) / self.fps

    def picture(self, k):
        """Its frame ``k`` to composite: ``(colour (H, W, 3), alpha (H, W))``."""
        return self.colour[k], self.alpha[k] if self.alpha.ndim == 3 else self.alpha


class LayerStream:
    """One layer's animation made in order as it is composited (a streamed scene).

    What :class:`LayerClip` holds, made a frame at a time from its method's stream,
    so a scene of a full-size photo holds a few frames of each layer, not its clip
    (``render(scene, stream=True)``; docs/conventions.md, "Streams"). The frames are
    those of the layer's clip.

    Parameters
    ----------
    n_frames : int
    fps : float
    loops : bool
    pictures : callable
        ``pictures()`` returns an iterator over ``(colour, alpha)`` of each frame in
        order (one pass of the method's stream).
    """

    def __init__(self, n_frames, fps, loops, pictures):
        self.n_frames = int(n_frames)
        self.fps = float(fps)
        self.loops = bool(loops)
        self._pictures = pictures
        self.restart()

    def __len__(self):
        return self.n_frames

    @property
    def duration(self):
        """Seconds the layer lasts (one loop, or its growth)."""
        return self.n_frames / self.fps

    def restart(self):
        """Start the next :meth:`picture` from a new pass (a scene's pass starts so)."""
        self._frames, self._k, self._value = None, -1, None

    def picture(self, k):
        """Frame ``k``: onwards from the last one asked for, or a new pass if earlier.

        A scene asks for its layers' frames in order, a loop starting again at 0, so
        each frame is made once per time it is shown in a new place of the loop.
        """
        if self._frames is None or k < self._k:
            self._frames, self._k = iter(self._pictures()), -1
        while self._k < k:
            self._value = next(self._frames)
            self._k += 1
        return self._value


def default_params(kind):
    r"""The parameters a layer of ``kind`` gets when it has none: chosen to look good.

    ``water``/``clouds``: :meth:`AnimateParams.for_kind` of the water/smoke database;
    ``flicker``: the paper's (:class:`FlickerParams`) at 24 fps over 96 frames (4 s,
    as long as the other loops); ``fire``: :class:`FireParams` (256 px, 24 fps);
    ``frost``: :class:`FrostParams` with the target at 96 frames (4 s at 24 fps), a
    3-pixel lattice and the ragged growth of frost on a window (:math:`\beta = 0.6`,
    :math:`r_{th} = 0.4`: a frontier cell gains vapour only when its random number
    exceeds :math:`r_{th}`, so arms branch and fill the region; the paper's
    :math:`r_{th} = 0` is Reiter's model, a deterministic six-armed snowflake that
    ignores the seed); :func:`run_layer` then scales the lattice with a scene larger
    than 480 px (the same cells at any size) and fits its gamma to the region.
    """
    if kind in ("water", "clouds"):
        from ..videodb import AnimateParams

        return AnimateParams.for_kind("water" if kind == "water" else "smoke")
    if kind == "flicker":
        from ..flicker import FlickerParams

        return FlickerParams(T=96, fps=24.0)
    if kind == "fire":
        from ..fire import FireParams

        return FireParams()
    if kind == "frost":
        from ..frost import FrostParams

        # beta and rth as benchmarks/contact_scene.py's frost (docs/contact/scene_lake.png).
        return FrostParams(beta=0.6, rth=0.4, target=96, spacing=3.0)
    raise ValueError(f"kind must be water, clouds, flicker, fire or frost, got {kind!r}")


def innermost_point(region):
    """The (row, col) of the region's pixel farthest from its edge (frost's default start).

    Of several equally deep pixels (a long strip), the one nearest the region's centroid.
    """
    inside = np.pad(region > 0.5, 1)
    depth = ndi.distance_transform_edt(inside)[1:-1, 1:-1]
    rows, cols = np.nonzero(depth >= depth.max() - 1e-6)
    ys, xs = np.nonzero(region > 0.5)
    i = int(np.argmin((rows - ys.mean()) ** 2 + (cols - xs.mean()) ** 2))
    return np.array([[rows[i], cols[i]]], np.float64)


def _reach(region, margin):
    """The soft weight a ``replace`` layer puts its picture in with.

    The region grown by ``margin`` pixels and feathered, so motion the method carries
    a little past the painted edge (a cloud's outline, sec. 6 of Okabe et al.) is not
    cut off.
    """
    grown = ndi.grey_dilation(region, size=(2 * margin + 1, 2 * margin + 1))
    soft = ndi.gaussian_filter(grown, margin / 2) if margin else grown
    return np.clip(np.maximum(soft, region), 0, 1).astype(np.float32)


def run_layer(layer, photo, *, quick=False, progress=None, stream=False):
    """Animate one layer on ``photo`` with its method; returns a :class:`LayerClip`.

    Parameters
    ----------
    layer : Layer
    photo : ndarray, shape (H, W, 3), float32
        The scene's photo at the size it is rendered.
    quick : bool
        The small starter databases (tests, CI).
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.
    stream : bool
        A :class:`LayerStream` instead: what can be made before the frames (a
        video database's assignment, frost's growth, the fire at its own size) is
        made now, the frames at the photo's size as they are composited.
    """
    params = layer.params if layer.params is not None else default_params(layer.kind)
    run = {
        "water": _videodb,
        "clouds": _videodb,
        "flicker": _flicker,
        "fire": _fire,
        "frost": _frost,
    }[layer.kind]
    return run(layer, photo, params, quick, progress, stream)


def _looping(clip, reach):
    """A looping method's clip (or its stream) as the layer of a scene, with its ``reach``."""
    if isinstance(clip, Clip):
        return LayerClip(_rgb(clip), reach, clip.fps, True, clip)
    return LayerStream(len(clip), clip.fps, True, lambda: ((f, reach) for f in _frames_of(clip)))


def _frames_of(stream):
    """A method's stream as ``(colour, alpha)`` pictures need it: RGB frames, in order."""
    for frame in stream.frames():
        yield frame if frame.ndim == 3 else np.repeat(frame[..., None], 3, axis=-1)


def _videodb(layer, photo, params, quick, progress, stream=False):
    from ..videodb import animate, starter_database

    db = starter_database("water" if layer.kind == "water" else "smoke", quick=quick)
    anim = animate(
        photo,
        layer.region,
        db,
        params,
        direction=list(layer.strokes) or None,
        speed=layer.speed,
        progress=progress,
        stream=stream,
    )
    clip = anim.clip
    margin = max(2, round(max(photo.shape[:2]) / 24))
    return _looping(clip, _reach(layer.region, margin))


def _flicker(layer, photo, params, quick, progress, stream=False):
    from ..flicker import flicker

    mask = layer.region > 0.5
    clip = flicker(photo, mask, params, seed=layer.seed, progress=progress, stream=stream)
    # Outside its mask every frame is the photo: the mask itself is the reach.
    return _looping(clip, mask.astype(np.float32))


def _fire(layer, photo, params, quick, progress, stream=False):
    from ..data import sample
    from ..fire import SIMULATION_FPS, fire

    exemplar, matte = sample(layer.exemplar, return_alpha=True)
    # About FIRE_SECONDS of the flame preset's simulation, then made a seamless loop.
    n_sim = math.ceil(FIRE_SECONDS * SIMULATION_FPS) + 1
    result = fire(exemplar, None, params, matte=matte, n_frames=n_sim, seed=layer.seed,
                  progress=progress)  # fmt: skip
    clip = result.clip
    # The fire's own frames are small (its keyframes' size): held, and each placed in
    # the region at the photo's size as it is needed (a stream) or all at once.
    frames = seamless_loop(_rgb(clip), max(1, round(LOOP_SECONDS * clip.fps)))
    place = _Placement(frames, layer.region)
    # Its own region at full strength, and a faint glow a little beyond it.
    rows, cols = np.nonzero(layer.region > 0.5)
    extent = max(rows.max() - rows.min(), cols.max() - cols.min()) + 1
    glow = ndi.gaussian_filter(layer.region, max(1.0, extent / 6))
    reach = np.clip(np.maximum(layer.region, 0.35 * glow / max(glow.max(), 1e-6)), 0, 1)
    reach = reach.astype(np.float32)
    if stream:
        return LayerStream(
            len(frames), clip.fps, True, lambda: ((place(i), reach) for i in range(len(frames)))
        )
    light = np.stack([place(i) for i in range(len(frames))])
    return LayerClip(light, reach, clip.fps, True, clip)


def seamless_loop(frames, k):
    """A clip that loops without a jump: its last ``k`` frames cross-faded into its first.

    Frame :math:`i < k` of the result is :math:`w_i f_i + (1 - w_i) f_{n-k+i}` with
    :math:`w_i = (i + 1)/(k + 1)`, the others are :math:`f_i`, and the result has
    :math:`n - k` frames: after its last frame, :math:`f_{n-k-1}`, comes frame 0, almost
    :math:`f_{n-k}` -- the frame that followed it in the original.

    Examples
    --------
    >>> f = np.arange(6, dtype=np.float32)[:, None]
    >>> [round(float(v), 2) for v in seamless_loop(f, 2).ravel()]  # 4 fades into 0, 5 into 1
    [2.67, 2.33, 2.0, 3.0]
    """
    n = len(frames)
    if not 0 < k < n:
        raise ValueError(f"k must be in [1, {n - 1}] (the clip has {n} frames), got {k}")
    out = np.array(frames[: n - k], np.float32, copy=True)
    w = ((np.arange(k) + 1) / (k + 1)).astype(np.float32).reshape((k,) + (1,) * (out.ndim - 1))
    out[:k] = w * frames[:k] + (1 - w) * frames[n - k :]
    return out


class _Placement:
    """Fire frames (T, s, s, 3) on black scaled into ``region``'s bounding box.

    The flame's own extent (where any frame is bright) is stretched to the box, its
    base on the box's bottom: a flame fills the region painted for it. Called with a
    frame's index, returns that frame placed, (H, W, 3) float32.
    """

    def __init__(self, frames, region):
        lum = frames.max(axis=(0, 3))
        ys, xs = np.nonzero(lum > 0.05 * max(float(lum.max()), 1e-6))
        if not len(ys):
            ys, xs = np.nonzero(np.ones_like(lum))
        self.flame = frames[:, ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
        rows, cols = np.nonzero(region > 0.5)
        self.box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
        self.shape = region.shape

    def __call__(self, i):
        from ..fields import resize

        rows, cols = self.box
        out = np.zeros((*self.shape, 3), np.float32)
        out[rows, cols] = resize(self.flame[i], (rows.stop - rows.start, cols.stop - cols.start))
        return np.clip(out, 0, None, out=out)


def _frost(layer, photo, params, quick, progress, stream=False):
    from .._progress import Progress
    from ..frost import HexLattice, gamma_for_target, grow, render

    report = Progress(progress)
    mask = layer.region > 0.5
    starts = layer.starts if layer.starts is not None else innermost_point(layer.region)
    if layer.params is None:
        # The same lattice at any size: its spacing is for a 480-px scene, and a 1920-px
        # photo with a 3-px lattice had 16 times the cells, too far apart to freeze in
        # the target's frames (issue 39).
        scale = max(1.0, max(photo.shape[:2]) / DEFAULT_SIZE)
        params = params.replace(spacing=params.spacing * scale)
    lattice = HexLattice.from_mask(mask, params.spacing)
    cells = lattice.snap(starts)
    if layer.params is None:  # the scene's default: the growth lasts about its target
        report(0.0, "fitting gamma to the region")
        fit = gamma_for_target(lattice, cells, params.target, params, seed=layer.seed)
        params = params.replace(gamma=fit.gamma)
    grow_report, draw_report = report.split(0.5)
    result = grow(lattice, cells, params, seed=layer.seed, progress=grow_report)
    # Drawn on a black and a white plate: the ice's premultiplied colour and its
    # opacity, so it covers whatever the layers under it show (not only the photo).
    h, w = photo.shape[:2]
    black = render(np.zeros((h, w, 3), np.float32), lattice, result, stream=True)
    white = render(np.ones((h, w, 3), np.float32), lattice, result, stream=True)

    def pictures():
        for colour, light in zip(_frames_of(black), _frames_of(white)):
            alpha = np.clip(1.0 - (light - colour).mean(axis=-1), 0, 1).astype(np.float32)
            yield colour, alpha

    if stream:
        return LayerStream(len(black), black.fps, False, pictures)
    made = list(pictures())
    colour = np.stack([c for c, _ in made])
    alpha = np.stack([a for _, a in made])
    del made
    clip = render(photo, lattice, result, progress=draw_report)
    return LayerClip(colour, alpha, clip.fps, False, clip)


def _rgb(clip):
    frames = np.asarray(clip.frames, np.float32)
    if frames.ndim == 3:
        frames = np.repeat(frames[..., None], 3, axis=-1)
    return frames
