"""The fire app: pick a photo, tune the flame and the synthesis, watch fire move."""

from __future__ import annotations

import dataclasses
import io

import ipywidgets as W
import numpy as np
from traitlets import Int

from fluidnb import Clip, Params, as_image
from fluidnb.fire import FireParams, colour_temperature, fire
from fluidnb.fluid import FluidParams, flame_preset, simulate

from ._app import App
from ._canvas import DrawingCanvas
from ._panel import ParamPanel
from ._player import FramePlayer

__all__ = ["FireApp", "FireAppParams"]

# The spec's app controls: the flame (FluidParams) and the synthesis (FireParams).
_FLUID_FIELDS = ("kappa_b", "epsilon", "C_r", "source_radius", "source_T")
_FIRE_FIELDS = ("interval", "overlap", "weight")


def _combined():
    """One panel over fields of two parameter classes, their specs and checks kept."""
    fields = []
    for cls, names in ((FluidParams, _FLUID_FIELDS), (FireParams, _FIRE_FIELDS)):
        by_name = {f.name: f for f in dataclasses.fields(cls)}
        for name in names:
            f = by_name[name]
            fields.append((name, f.type, dataclasses.field(default=f.default, metadata=f.metadata)))

    def check(self):
        self.fluid()
        self.fire()

    def fluid(self, base=None):
        base = flame_preset().params if base is None else base
        return base.replace(**{n: getattr(self, n) for n in _FLUID_FIELDS})

    def fire(self, base=None):
        base = FireParams() if base is None else base
        return base.replace(**{n: getattr(self, n) for n in _FIRE_FIELDS})

    return dataclasses.make_dataclass(
        "FireAppParams",
        fields,
        bases=(Params,),
        frozen=True,
        namespace={
            "check": check,
            "fluid": fluid,
            "fire": fire,
            "__doc__": "The fire app's controls: flame (FluidParams) + synthesis (FireParams).",
            "__module__": __name__,
        },
    )


FireAppParams = _combined()


class FireApp(App):
    """Fire from a photograph on a fluid simulation (Kogawa, Dobashi & Yamamoto).

    Choose a fire photo (a sample or an upload), optionally paint its matte (white =
    flame; nothing painted uses the photo's own matte, else its luminance), set the
    flame's buoyancy, vorticity confinement, cooling and source, and the synthesis's
    keyframe interval, cross-dissolve overlap and user-control weight. **Run**
    simulates the flame, synthesises the keyframes and advects and blends them (with
    progress and Cancel); the player plays the fire and exports it, and the
    comparison shows temperature | latest keyframe | fire side by side.

    Parameters
    ----------
    photo : array_like, path or PIL image, optional
        The photo of fire; by default the ``"fire"`` sample with its matte.
    matte : array_like, optional
        The photo's alpha matte (used when nothing is painted).
    quick : bool
        Small sizes for a quick look or a headless run: a 64 x 64 grid, 16 frames.
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
    >>> clip.n_frames, clip.metadata["method"]
    (16, 'fire')
    >>> app.close()
    """

    #: Seed of the simulation and the synthesis.
    seed = Int(0)

    def __init__(
        self, photo=None, *, matte=None, quick=False, n_frames=None, seed=0, display_size=320
    ):
        from fluidnb import data

        self.quick = bool(quick)
        if photo is None:
            photo, matte = data.sample("fire", size=128, return_alpha=True)
        self.photo, self.photo_matte = self._load(photo, matte)
        self.shape = (64, 64) if quick else (128, 128)
        self.fire_result = None  #: The last run's FireResult.
        self._display_size = int(display_size)
        canvas = DrawingCanvas(self.photo, masks=["matte"], display_size=display_size)
        canvas.select("brush", "matte")
        canvas.brush_radius = max(2.0, max(self.photo.shape[:2]) / 20)
        panel = ParamPanel(FireAppParams)

        self._frames = W.BoundedIntText(
            value=n_frames or (16 if quick else 72),
            min=2,
            max=1000,
            description="frames",
            layout=W.Layout(width="180px"),
        )
        self._seed = W.BoundedIntText(
            value=seed, min=0, max=2**31 - 1, description="seed", layout=W.Layout(width="180px")
        )
        W.link((self._seed, "value"), (self, "seed"))
        self._sample = W.Dropdown(
            options=["fire", "flame"],
            value="fire",
            description="photo",
            layout=W.Layout(width="200px"),
        )
        self._sample.observe(lambda c: self.set_photo(c["new"]), "value")
        self._upload = W.FileUpload(accept="image/*", multiple=False, description="Upload")
        self._upload.observe(self._uploaded, "value")
        for wid, cls in [
            (self._frames, "fluidnb-frames"),
            (self._seed, "fluidnb-seed"),
            (self._sample, "fluidnb-photo"),
            (self._upload, "fluidnb-upload"),
        ]:
            wid.add_class(cls)
        self.compare = FramePlayer(display_width=3 * 160, label="compare")
        hint = W.HTML(
            "<span style='opacity:0.7'>Paint the flame's matte on the photo (white = "
            "flame) or leave it empty to use the photo's own matte / luminance.</span>"
        )
        super().__init__(
            panel=panel,
            run=self._run,
            canvas=canvas,
            title="Fire from a photograph — Kogawa, Dobashi & Yamamoto",
            extra=[
                W.HBox([self._sample, self._upload]),
                W.HBox([self._frames, self._seed]),
                hint,
            ],
        )
        self.children = (
            *self.children,
            W.HTML("<b>temperature | latest keyframe | fire</b>"),
            self.compare,
        )

    # ------------------------------------------------------------------ inputs
    @staticmethod
    def _load(photo, matte):
        image, alpha = as_image(photo, mode="rgb", name="photo", return_alpha=True)
        if matte is not None:
            alpha = as_image(matte, mode="grey", name="matte")
            if alpha.shape != image.shape[:2]:
                raise ValueError(
                    f"matte must have the photo's size {image.shape[:2]}, got {alpha.shape}"
                )
        return image, alpha

    def set_photo(self, photo, matte=None):
        """Use another photo: a sample name (``"fire"``, ``"flame"``) or an image."""
        from fluidnb import data

        if isinstance(photo, str) and photo in data.names():
            photo, matte = data.sample(photo, size=128, return_alpha=True)
        try:
            self.photo, self.photo_matte = self._load(photo, matte)
        except ValueError as exc:
            self.say(str(exc), "error")
            return
        # A canvas keeps its image's size: a photo of another size gets a new canvas,
        # swapped into the same place in the layout.
        old = self.canvas
        canvas = DrawingCanvas(self.photo, masks=["matte"], display_size=self._display_size)
        canvas.select("brush", "matte")
        canvas.brush_radius = max(2.0, max(self.photo.shape[:2]) / 20)
        for box in self.children:
            if isinstance(box, W.HBox) and old in box.children:
                box.children = tuple(canvas if c is old else c for c in box.children)
        self.canvas = canvas
        old.close()

    def _uploaded(self, change):
        files = change["new"]
        if not files:
            return
        from PIL import Image

        content = files[0]["content"]
        try:
            image = Image.open(io.BytesIO(bytes(content)))
            image.load()
        except Exception as exc:  # a broken or foreign file: say so, keep the old photo
            self.say(f"could not read the upload: {exc}", "error")
            return
        self.set_photo(image)

    def matte(self):
        """The matte used: the painted one, else the photo's own (None: luminance)."""
        painted = self.canvas.get_mask("matte")
        if painted.any():
            return painted.astype(np.float32)
        return self.photo_matte

    # ------------------------------------------------------------------ library calls
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
        fire_params = params.fire(FireParams(input_size=max(self.shape)))
        # An uploaded cut-out's alpha is photo_matte: fire composites the colour onto
        # black with it, so the clear pixels' colour never shows.
        result = fire(
            self.photo, sim, fire_params, matte=self.matte(), seed=self.seed, progress=second
        )
        self.fire_result = result
        self.compare.clip = comparison_clip(result)
        return result.clip


def comparison_clip(result):
    """Temperature | the keyframe in effect | fire, side by side, as one clip."""
    n = result.clip.n_frames
    temp = colour_temperature(result.target)
    latest = np.searchsorted(result.starts, np.arange(n), side="right") - 1
    keys = result.keyframes[latest]
    frames = np.concatenate([temp, keys, result.clip.frames], axis=2)
    return Clip(frames, fps=result.clip.fps, metadata={"method": "fire", "what": "comparison"})
