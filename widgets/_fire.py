"""The fire app: pick a photo, tune the flame and the synthesis, watch fire move."""

from __future__ import annotations

import dataclasses

import ipywidgets as W
import numpy as np

from fluidnb import Clip, Params
from fluidnb.fire import FireParams, colour_temperature, fire, keyframe_preview
from fluidnb.fluid import FluidParams, flame_preset, simulate

from ._app import App
from ._canvas import DrawingCanvas
from ._common import hint, row
from ._panel import ParamPanel
from ._photo import PhotoInput, load_photo
from ._player import FramePlayer

__all__ = ["FireApp", "FireAppParams"]

#: The panel's groups: the flame and the synthesis's main settings open, the rest folded.
GROUPS = (
    ("flame and synthesis", ("kappa_b", "epsilon", "C_r", "interval", "weight")),
    ("the flame's source", ("source_radius", "source_T")),
    ("synthesis details", ("overlap", "coherence", "cutoff", "output_size", "fps")),
)
#: Side of the live preview's keyframe (fluidnb.fire.keyframe_preview: ~30 ms).
_PREVIEW_SIZE = 48
#: The sample photos the photo menu offers ("upload" joins them after an upload).
SAMPLES = ("fire", "flame")
#: Longest side of a sample photo: as large as the default keyframes (256 px).
SAMPLE_SIZE = 256


def _field_of(cls, name):
    """A dataclass field with the default and the slider spec of ``cls``'s ``name``.

    The app's parameters are fields of two classes; sharing their specs keeps one
    source for each range, symbol and tooltip.
    """
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return dataclasses.field(default=f.default, metadata=f.metadata)


@dataclasses.dataclass(frozen=True)
class FireAppParams(Params):
    """The fire app's controls: the flame's (FluidParams) and the synthesis's (FireParams)."""

    # The flame: a fluidnb.fluid.FluidParams on flame_preset()'s.
    kappa_b: float = _field_of(FluidParams, "kappa_b")
    epsilon: float = _field_of(FluidParams, "epsilon")
    C_r: float = _field_of(FluidParams, "C_r")
    source_radius: float = _field_of(FluidParams, "source_radius")
    source_T: float = _field_of(FluidParams, "source_T")
    # The synthesis: a fluidnb.fire.FireParams.
    interval: int = _field_of(FireParams, "interval")
    overlap: int = _field_of(FireParams, "overlap")
    weight: float = _field_of(FireParams, "weight")
    coherence: float = _field_of(FireParams, "coherence")
    cutoff: float = _field_of(FireParams, "cutoff")
    fps: float = _field_of(FireParams, "fps")
    output_size: int = _field_of(FireParams, "output_size")

    def check(self):
        # Each class checks its own combinations (overlap < interval, say).
        self.fluid()
        self.fire()

    def fluid(self, base=None):
        """These flame fields on ``base`` (default :func:`flame_preset`'s FluidParams)."""
        base = flame_preset().params if base is None else base
        return base.replace(
            kappa_b=self.kappa_b,
            epsilon=self.epsilon,
            C_r=self.C_r,
            source_radius=self.source_radius,
            source_T=self.source_T,
        )

    def fire(self, base=None):
        """These synthesis fields on ``base`` (default ``FireParams()``)."""
        base = FireParams() if base is None else base
        return base.replace(
            interval=self.interval,
            overlap=self.overlap,
            weight=self.weight,
            coherence=self.coherence,
            cutoff=self.cutoff,
            fps=self.fps,
            output_size=self.output_size,
        )


class FireApp(App):
    """Fire from a photograph on a fluid simulation (Furukawa, Dobashi & Yamamoto 2013).

    Choose a fire photo (a sample or an upload), optionally paint its matte (white =
    flame; nothing painted uses the photo's own matte, else its luminance), set the
    flame's buoyancy, vorticity confinement, cooling and source, and the synthesis's
    keyframe interval, cross-dissolve overlap and user-control weight. **Run**
    simulates the flame, synthesises the keyframes and advects and blends them (with
    progress and Cancel); the player plays the fire at its own size and exports it,
    and the comparison shows temperature | latest keyframe | fire side by side on the
    simulation's grid. The defaults synthesise at 256 pixels, 24 frames a second;
    **Paper defaults** sets the paper's set-up (keyframes on the 128 x 128 grid, 8
    fps: :meth:`fluidnb.fire.FireParams.paper`), and the other parameters to their
    defaults. A painted matte may cover only part of the flame: the library finds
    the whole flame (:func:`fluidnb.fire.flame_matte`).

    Parameters
    ----------
    photo : array_like, path or PIL image, optional
        The photo of fire; by default the ``"fire"`` sample with its matte.
    matte : array_like, optional
        The photo's alpha matte (used when nothing is painted).
    quick : bool
        Small sizes for a quick look or a headless run: a 64 x 64 grid, 16 frames,
        keyframes of 128 pixels.
    n_frames : int, optional
        Frames to simulate (default 72, 16 with ``quick``).
    seed : int
        Seed of the simulation's source flicker and of the synthesis.
    display_size : int
        Longest side of the canvas on screen.

    Examples
    --------
    >>> app = FireApp(quick=True)
    >>> app.panel.set("weight", 0.7)
    >>> clip = app.run(timeout=120)
    >>> clip.n_frames, clip.shape, clip.fps, clip.metadata["method"]
    (46, (128, 128), 24.0, 'fire')
    >>> app.close()
    """

    def __init__(
        self, photo=None, *, matte=None, quick=False, n_frames=None, seed=0, display_size=320
    ):
        self.quick = bool(quick)
        name = "fire" if photo is None else photo if _is_sample(photo) else "upload"
        self.photo, self.photo_matte = self._load(name if name != "upload" else photo, matte)
        self.photo_name = name  #: The photo shown: a sample's name or "upload".
        self.shape = (64, 64) if quick else (128, 128)
        self.fire_result = None  #: The last run's FireResult.
        self._display_size = int(display_size)
        panel = ParamPanel(FireAppParams, groups=GROUPS)

        self._frames = W.BoundedIntText(
            value=n_frames or (16 if quick else 72),
            min=2,
            max=1000,
            description="frames",
            style={"description_width": "50px"},
            layout=W.Layout(width="150px"),
        )
        self._photo = PhotoInput(SAMPLES, name, on_photo=self.set_photo, say=self.say)
        self._sample, self._upload = self._photo.menu, self._photo.upload
        self._frames.add_class("fluidnb-frames")
        # Both players show their clips at their own size (a clip is drawn as it is,
        # never enlarged: _show sets the width from the clip).
        self.compare = FramePlayer(display_width=3 * self.shape[1], label="compare")
        self._paper = W.Button(description="Paper defaults", icon="book")
        self._paper.add_class("fluidnb-paper-defaults")
        self._paper.on_click(lambda _: self.paper_defaults())
        super().__init__(
            panel=panel,
            player=FramePlayer(display_width=FireParams().output_size),
            run=self._run,
            preview=self._preview,
            canvas=self._make_canvas(),
            seed=seed,
            title="Fire from a photograph — Furukawa, Dobashi & Yamamoto",
            inputs=[self._photo],
        )
        if self.quick:
            panel.set("output_size", 128)
        self.controls = (
            row(self._frames, self.seed_box, self._paper),
            hint(
                "Paint the flame's matte on the photo (white = flame) or leave it empty "
                "to use the photo's own matte / luminance."
            ),
        )
        comparison = self.titled("temperature | latest keyframe | fire", self.compare)
        self.views = (self.player, comparison)

    def paper_defaults(self):
        """Set the panel to the paper's set-up: grid-sized keyframes, 8 fps.

        Every other parameter goes back to its default (the paper gives no values for
        them: :class:`fluidnb.fire.FireParams`, :func:`fluidnb.fluid.flame_preset`).
        """
        paper = FireParams.paper()
        defaults = FireAppParams()
        for name in self.panel.controls:
            value = getattr(defaults, name)
            if name in ("fps", "output_size"):
                value = getattr(paper, name)
            self.panel.set(name, value)
        self.say("the paper's set-up: keyframes on the simulation's grid, 8 fps")

    # ------------------------------------------------------------------ inputs
    def _make_canvas(self):
        """A canvas over the photo, the brush on its matte."""
        # Shown as fire uses it: a cut-out's colour over black, so the junk colour its
        # transparent pixels may hold never shows.
        shown = self.photo if self.photo_matte is None else self.photo * self.photo_matte[..., None]
        canvas = DrawingCanvas(shown, masks=["matte"], display_size=self._display_size)
        canvas.select("brush", "matte")
        canvas.brush_radius = max(2.0, max(self.photo.shape[:2]) / 20)
        return canvas

    @staticmethod
    def _load(photo, matte):
        # A sample at SAMPLE_SIZE pixels with its own matte; an upload as it is.
        return load_photo(photo, matte, samples=SAMPLES, sample_size=SAMPLE_SIZE)

    def set_photo(self, photo, matte=None):
        """Use another photo: a sample name (``"fire"``, ``"flame"``) or an image.

        The photo menu follows: a sample's name, or "upload" for an image. Returns
        False (and says why in the status line) if the photo is refused; the old one
        stays.
        """
        name = photo if _is_sample(photo) else "upload"
        try:
            self.photo, self.photo_matte = self._load(photo, matte)
        except ValueError as exc:
            self.say(str(exc), "error")
            return False
        self.photo_name = name
        # A canvas keeps its image's size: a photo of another size gets a new canvas
        # (the canvas slot shows it in the old one's place).
        old = self.canvas
        self.canvas = self._make_canvas()
        old.close()
        # "upload" is offered only while an uploaded photo is shown.
        self._photo.shown(name)
        h, w = self.photo.shape[:2]
        shown = "your upload" if name == "upload" else f"the {name} sample"
        self.say(f"photo: {shown}, {w} x {h} pixels")
        return True

    def matte(self):
        """The matte used: the painted one, else the photo's own (None: luminance)."""
        painted = self.canvas.get_mask("matte")
        if painted.any():
            return painted.astype(np.float32)
        return self.photo_matte

    # ------------------------------------------------------------------ library calls
    def _preview(self, params):
        """One keyframe on a small flame while a slider moves (the clip comes at rest)."""
        clip = keyframe_preview(
            self.photo,
            params.fire(),
            fluid_params=params.fluid(flame_preset().params),
            size=_PREVIEW_SIZE,
            matte=self.matte(),
            seed=self.seed,
        )
        # A photo's flame, enlarged 5x on screen: smoothed, not a mosaic of 48 x 48 cells
        # (a 64-px keyframe costs twice as much when a slider of the fluid moves).
        return clip.with_metadata(
            note=f"one keyframe at {_PREVIEW_SIZE} x {_PREVIEW_SIZE}", smooth=True
        )

    def _run(self, params, progress):
        from fluidnb import Progress

        first, second = Progress(progress).split(0.3)
        preset = flame_preset()
        sim = simulate(
            params.fluid(preset.params),
            int(self._frames.value),
            shape=self.shape,
            seed=self.seed,
            progress=first,
            warmup=preset.warmup_for(self.shape),
        )
        # An uploaded cut-out's alpha is photo_matte: fire composites the colour onto
        # black with it, so the clear pixels' colour never shows.
        result = fire(
            self.photo, sim, params.fire(), matte=self.matte(), seed=self.seed, progress=second
        )
        self.fire_result = result
        compare = comparison_clip(result)
        self.compare.display_width = compare.shape[1]
        self.compare.clip = compare
        # The fire at its own size: the player never enlarges it.
        self.player.display_width = result.clip.shape[1]
        return result.clip


def _is_sample(photo):
    return isinstance(photo, str) and photo in SAMPLES


def comparison_clip(result):
    """Temperature | the keyframe in effect | fire, side by side, as one clip.

    One frame per simulation frame, on the simulation's grid (the keyframes and the
    fire resized to it): the three at the size the simulation computes, and a clip
    that stays small at any keyframe size and frame rate.
    """
    from fluidnb.fields import resize

    temp = colour_temperature(result.target)
    n, h, w = result.target.shape
    # The clip frames at whole simulation frames (the clip has fps / 8 per frame).
    at = np.searchsorted(result.times, np.arange(n) - 1e-9)
    at = np.minimum(at, result.clip.n_frames - 1)
    latest = np.searchsorted(result.starts, at, side="right") - 1

    def small(image):
        return image if image.shape[:2] == (h, w) else np.clip(resize(image, (h, w)), 0, 1)

    keys = np.stack([small(result.keyframes[k]) for k in latest])
    fires = np.stack([small(result.clip.frames[t]) for t in at])
    frames = np.concatenate([temp, keys, fires], axis=2)
    fps = result.temperature_clip.fps
    return Clip(frames, fps=fps, metadata={"method": "fire", "what": "comparison"})
