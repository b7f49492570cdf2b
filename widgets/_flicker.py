"""The flicker ("yuragi") app: paint a region, move sliders, watch the photo flicker."""

from __future__ import annotations

import io
import threading

import ipywidgets as W

from fluidnb import as_image
from fluidnb.flicker import (
    FlickerModel,
    FlickerParams,
    analysis_figure,
    flicker,
    flow_velocity,
    preview,
)

from ._app import App
from ._canvas import DrawingCanvas
from ._common import hint, row
from ._panel import ParamPanel

__all__ = ["FlickerApp"]

#: The panel's groups: the spectrum open, the rarely touched ones folded.
GROUPS = (
    ("the spectrum (Eq. 7-10)", ("mapping", "T", "f0", "kappa", "beta")),
    ("light and relief", ("azimuth", "elevation", "bump", "k")),
    ("noise", ("noise_norm", "noise_regions")),
    ("height (Eq. 1-3)", ("A", "C", "branch")),
    ("region and playback", ("feather", "fps")),
)


class FlickerApp(App):
    """Flicker animation of one photo (Yamamoto & Sakamoto), interactively.

    Paint the region to animate with the brush (eraser and fill too; nothing painted
    means the whole image), choose the mapping and move the sliders: a low-resolution
    preview of the whole loop follows. **Run** renders the full-resolution clip (with
    progress and Cancel); the player plays it and exports GIF or MP4. **Analyse**
    shows the 2-D spectrum, the mapping surface, the temporal spectrum of the probe
    pixel (click with the points tool) and the paper's Fig. 8-11 difference images.
    For the ``flow`` mapping, draw a stroke along the stream with the stroke tool
    (layer "flow"): its direction is the direction of flow and its length the
    distance the surface travels in one loop (the last stroke counts).

    Parameters
    ----------
    image : array_like, path or PIL image, optional
        The photo; by default the ``"stream"`` sample.
    display_size : int
        Longest side of the canvas on screen, in pixels.
    quick : bool
        Small sizes for a quick look or a headless run: a 96-pixel sample photo, a
        16-frame loop and a 64-pixel preview.
    params : FlickerParams, optional
        Starting parameters (the paper's by default; ``T = 16`` with ``quick``).
    seed : int
        Noise seed (also a control in the app).
    preview_size : int, optional
        Longest side of the live preview (default 128, 64 with ``quick``).

    Examples
    --------
    >>> app = FlickerApp(quick=True)
    >>> app.canvas.paint([[30, 20], [30, 70]], radius=8)
    >>> app.panel.set("mapping", "plane")
    >>> clip = app.run(timeout=60)
    >>> clip.n_frames, clip.shape == app.image.shape[:2]
    (16, True)
    >>> app.close()
    """

    def __init__(
        self,
        image=None,
        *,
        display_size=420,
        quick=False,
        params=None,
        seed=0,
        preview_size=None,
    ):
        if image is None:
            from fluidnb import data

            image = data.sample("stream", size=96 if quick else 480)
        self.image = as_image(image)
        if params is None:
            params = FlickerParams(T=16) if quick else FlickerParams()
        self.preview_size = int(preview_size or (64 if quick else 128))
        self._model_lock = threading.Lock()
        canvas = DrawingCanvas(
            self.image,
            masks=["region"],
            strokes=["flow"],
            points=["probe"],
            display_size=display_size,
        )
        canvas.select("brush", "region")
        canvas.brush_radius = max(2.0, max(self.image.shape[:2]) / 24)
        panel = ParamPanel(params, groups=GROUPS)
        self._new_noise = W.Button(
            description="New noise", icon="random", layout=W.Layout(width="110px")
        )
        self._new_noise.add_class("fluidnb-new-noise")
        self._new_noise.on_click(lambda _: setattr(self, "seed", (self.seed + 1) % 2**31))
        self._analyse = W.Button(
            description="Analyse", icon="bar-chart", layout=W.Layout(width="110px")
        )
        self._analyse.add_class("fluidnb-analyse")
        self._analyse.on_click(lambda _: self.show_analysis())
        # Hidden until Analyse draws it (an empty image shows as a broken-image icon).
        self.analysis = W.Image(format="png", layout=W.Layout(max_width="100%", display="none"))
        self.analysis.add_class("fluidnb-analysis")
        super().__init__(
            panel=panel,
            run=self._run,
            preview=self._preview,
            canvas=canvas,
            seed=seed,
            title="Flicker (yuragi) — Yamamoto & Sakamoto",
        )
        self.controls = (
            row(self.seed_box, self._new_noise, self._analyse),
            hint(
                "Paint the region to animate (nothing painted: the whole photo). Mapping "
                "<i>flow</i>: draw a stroke along the stream (its length = how far it "
                "travels in one loop). Points tool: pick the pixel whose spectrum Analyse "
                "shows."
            ),
        )
        self.views = (self.player, self.analysis)

    # ------------------------------------------------------------------ inputs
    def region(self):
        """The painted region as bool (H, W), or None when nothing is painted (whole image)."""
        mask = self.canvas.get_mask("region")
        return mask if mask.any() else None

    def flow(self, params=None):
        """The velocity (dy, dx) in px/frame of the last flow stroke, or None.

        Only for the flow mapping (None for the others); raises a ValueError that
        says what to draw when the flow mapping has no stroke yet.
        """
        params = self.panel.params if params is None else params
        if params.mapping != "flow":
            return None
        strokes = [s for s in self.canvas.get_strokes("flow") if len(s) >= 2]
        if not strokes:
            raise ValueError(
                "mapping 'flow': draw a stroke along the flow with the stroke tool "
                "(its length is the distance travelled in one loop)"
            )
        return flow_velocity(strokes[-1], params.T)

    def probe(self):
        """The last point placed with the points tool (row, col), or None."""
        points = self.canvas.get_points("probe")
        return None if len(points) == 0 else tuple(points[-1])

    # ------------------------------------------------------------------ library calls
    def _preview(self, params):
        flow = self.flow(params)
        clip = preview(
            self.image, self.region(), params, flow=flow, size=self.preview_size, seed=self.seed
        )
        return clip.with_metadata(smooth=True)  # a photo, enlarged: smoothed on screen

    def _run(self, params, progress):
        flow = self.flow(params)
        return flicker(
            self.image, self.region(), params, flow=flow, seed=self.seed, progress=progress
        )

    def show_analysis(self, pixel=None):
        """Draw the analysis figure for the current settings (at preview resolution).

        Parameters
        ----------
        pixel : (row, col), optional
            Image pixel whose temporal spectrum is shown; default the probe point, or
            the centre of the region.

        Returns
        -------
        bytes
            The PNG shown.
        """
        params = self.panel.params
        try:
            with self._model_lock:  # one analysis at a time (a double click)
                model = FlickerModel.reduced(
                    self.image,
                    self.region(),
                    params,
                    flow=self.flow(params),
                    size=2 * self.preview_size,
                    seed=self.seed,
                )
                pixel = pixel if pixel is not None else self.probe()
                if pixel is not None:
                    h, w = model.shape
                    s = model.pixel_size
                    pixel = (min(pixel[0] / s, h - 1), min(pixel[1] / s, w - 1))
                fig = analysis_figure(model, pixel=pixel)
                buf = io.BytesIO()
                fig.savefig(buf, format="png", dpi=80)
        except ValueError as exc:
            self.say(str(exc), "error")
            return b""
        self.analysis.value = buf.getvalue()
        self.analysis.layout.display = ""
        return self.analysis.value
