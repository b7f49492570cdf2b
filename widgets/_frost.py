"""The frost app: paint a region, click start points, tune beta/gamma/alpha/rth, optimise beta."""

from __future__ import annotations

import html
import math
import threading

import ipywidgets as W
import numpy as np

from fluidnb import Cancelled, Progress, as_image, as_mask
from fluidnb.fields import resize
from fluidnb.frost import (
    FrostParams,
    HexLattice,
    estimate_end_frame,
    gamma_for_target,
    grow,
    optimise_beta,
    render,
)

from ._app import App
from ._canvas import DrawingCanvas
from ._common import hint, plural, row
from ._panel import ParamPanel

__all__ = ["FrostApp"]

#: The panel's groups: the automaton open, the lattice and the clip folded.
GROUPS = (
    ("the automaton (Reiter; Eq. 2)", ("beta", "gamma", "alpha", "rth", "target")),
    ("lattice, clip and limits", ("spacing", "fps", "coverage", "max_frames")),
)

# The live preview runs on a lattice at most this many points across the region, a
# few hundred frames at most, on the picture and region shrunk to this size (drawing
# the ice at the photo's size took most of a preview's time), a few frames of it.
# The lattice, the picture and the ice's surface are kept while only the automaton's
# values move; the growth and drawing the frames are then the whole preview, half
# each: 7 frames (6 steps and the last) rather than 11 took 170 -> 126 ms at load 8.
_PREVIEW_CELLS = 28
_PREVIEW_FRAMES = 400
_PREVIEW_SIZE = 160
_PREVIEW_CLIP_FRAMES = 6
# A full run's clip plays every frame at the panel's fps (the clip lasts as long as
# the frost grows). It is drawn smaller for long runs so it stays under this many
# bytes (480 x 360 RGB float32 costs 2 MB a frame), down to _RUN_MIN_SIZE pixels;
# beyond that, every k-th frame (and the fps / k that keeps the duration).
_RUN_BYTES = 400 * 2**20
_RUN_MIN_SIZE = 240


class FrostApp(App):
    """Frost growing over a painted region (Amano, Sato & Itoh; Reiter 2005), interactively.

    Paint the region with the brush (eraser and fill too), click one or more start
    points with the points tool, and move the sliders: a coarse live preview follows.
    Under the sliders the app says how long the run will take (the mass-balance
    estimate of the end frame, :func:`fluidnb.frost.estimate_end_frame`) and which γ
    would end at the target; **Use γ** fits γ to the target with a few short runs
    (:func:`fluidnb.frost.gamma_for_target`) -- with the paper's γ = 0.005 a painted
    region takes thousands of frames.
    **Optimise β** runs the optimiser for the target end frame in the background and
    fills its table (step, β, end frame) as it goes, then sets the β slider.
    **Run** grows the frost on the full lattice and draws it as ice on the image (with
    progress and Cancel); the player plays it and exports GIF or MP4.

    Parameters
    ----------
    image : array_like, path or PIL image, optional
        The picture; by default the ``"leaf"`` sample.
    region : array_like of bool, optional
        A region to start with (the image's size).
    starts : array_like, shape (n, 2), optional
        Start points to start with, (row, col) in image pixels.
    params : FrostParams, optional
        Starting parameters (the paper's by default).
    seed : int
        Random seed of :math:`r_t(p)` for the preview, the optimiser and the run.
    quick : bool
        Small sizes for a quick look or a headless run (a 128-pixel sample image).
    display_size : int
        Longest side of the canvas on screen, in pixels.

    Examples
    --------
    >>> app = FrostApp(quick=True)
    >>> app.canvas.paint([[48, 30], [48, 90]], radius=20)
    >>> app.canvas.click([48, 60], layer="starts")
    >>> app.panel.set("beta", 0.6)
    >>> clip = app.run(timeout=120)
    >>> clip.metadata["method"]
    'frost'
    >>> app.close()
    """

    def __init__(
        self,
        image=None,
        *,
        region=None,
        starts=None,
        params=None,
        seed=0,
        quick=False,
        display_size=420,
    ):
        if image is None:
            from fluidnb import data

            image = data.sample("leaf", size=128 if quick else 480)
        self.image = as_image(image, mode="rgb")
        if params is None:
            params = FrostParams(spacing=3.0) if quick else FrostParams()
        self.optimised = None  #: The last OptimiseResult.
        self.frost_result = None  #: The last full run's FrostResult (freeze frames).
        self._rows = []
        self._rows_lock = threading.Lock()
        canvas = DrawingCanvas(
            self.image, masks=["region"], points=["starts"], display_size=display_size
        )
        canvas.brush_radius = max(2.0, max(self.image.shape[:2]) / 16)
        panel = ParamPanel(params, groups=GROUPS)
        self._solver = W.Dropdown(
            options=[("secant (robust)", "secant"), ("steepest descent (paper)", "steepest")],
            value="secant",
            description="solver",
            layout=W.Layout(width="300px"),
        )
        self._solver.add_class("fluidnb-solver")
        self._eta = W.FloatLogSlider(
            value=1e-6,
            base=10,
            min=-8,
            max=-3,
            step=0.1,
            description="η (steepest)",
            readout_format=".1e",
            layout=W.Layout(width="320px"),
            style={"description_width": "90px"},
        )
        self._eta.add_class("fluidnb-eta")
        self._optimise_button = W.Button(
            description="Optimise β", icon="bullseye", tooltip="fit beta to the target end frame"
        )
        self._optimise_button.add_class("fluidnb-optimise")
        self._optimise_button.on_click(lambda _: self.optimise())
        self.table = W.HTML()
        self.table.add_class("fluidnb-optimise-table")
        # How long the run will take, from the balance of vapour, before anyone waits.
        self.length = W.HTML()
        self.length.add_class("fluidnb-frost-length")
        self._gamma_button = W.Button(
            description="Fit γ to the target",
            icon="clock-o",
            tooltip="set gamma so the frost ends near the target end frame",
            layout=W.Layout(width="max-content"),
        )
        self._gamma_button.add_class("fluidnb-fit-gamma")
        self._gamma_button.on_click(lambda _: self.fit_gamma())
        self.estimate = None  #: The last EndFrameEstimate (full lattice), or None.
        self._small_image = None  # (picture, scale) of the live preview
        self._lattices = {}  # "run" / "preview" -> ((spacing, drawing version), lattices)
        self.gamma_fit = None  #: The last GammaFit.
        super().__init__(
            panel=panel,
            run=self._run,
            preview=self._preview,
            canvas=canvas,
            seed=seed,
            title="Frost — Amano, Sato & Itoh (Reiter's automaton)",
        )
        self.controls = (
            self.length,
            row(self.seed_box, self._gamma_button),
            row(self._solver, self._optimise_button),
            self._eta,
            self.table,
            hint(
                "Brush: paint where frost may grow. Points tool (layer <b>starts</b>): "
                "click start points. The preview runs on a coarse lattice; Run uses the "
                "spacing you set."
            ),
        )
        canvas.select("brush", "region")
        if region is not None:
            self.set_region(region)
        if starts is not None:
            self.set_starts(starts)
        self._show_table()

    # ------------------------------------------------------------------ inputs
    def set_region(self, mask):
        """Replace the painted region (undoable on the canvas)."""
        self.canvas.set_mask(as_mask(mask, self.image.shape[:2], name="region"), "region")

    def set_starts(self, points):
        """Replace the start points, (n, 2) (row, col) in image pixels."""
        self.canvas.set_points(np.asarray(points, float).reshape(-1, 2), "starts")

    def region(self):
        """The painted region as bool (H, W); ValueError if nothing is painted."""
        mask = self.canvas.get_mask("region")
        if not mask.any():
            raise ValueError("region is empty: paint where frost may grow with the brush")
        return mask

    def starts(self):
        """The start points (n, 2) (row, col); ValueError if there are none."""
        points = self.canvas.get_points("starts")
        if len(points) == 0:
            raise ValueError(
                "no start point: choose the points tool, layer 'starts', and click in the region"
            )
        return points

    def _lattice(self, spacing):
        """(the region's lattice at ``spacing``, the start cells), kept while the drawing is.

        A slider move asks for them again (the length estimate): the same drawing
        and spacing give the same lattice.
        """
        key = (float(spacing), self.canvas.version)
        kept = self._lattices.get("run")
        if kept is None or kept[0] != key:
            lattice = HexLattice.from_mask(self.region(), spacing)
            kept = self._lattices["run"] = (key, (lattice, lattice.snap(self.starts())))
        return kept[1]

    def _preview_lattice(self, params):
        """(small picture, the coarse lattice, its start cells, its spacing) of the preview.

        Kept while the drawing and the spacing are: a slider of the automaton changes
        only the growth.
        """
        key = (float(params.spacing), self.canvas.version)
        kept = self._lattices.get("preview")
        if kept is not None and kept[0] == key:
            return kept[1]
        region, starts = self.region(), self.starts()
        small, f = self._small()
        region = resize(region.astype(np.float32), small.shape[:2]) > 0.5
        if not region.any():
            raise ValueError("region is too small for the preview: paint a larger one")
        rows, cols = np.nonzero(region)
        extent = max(rows.max() - rows.min(), cols.max() - cols.min()) + 1
        spacing = max(params.spacing * f, extent / _PREVIEW_CELLS)
        lattice = HexLattice.from_mask(region, spacing)
        value = (small, lattice, lattice.snap(starts * f), spacing)
        self._lattices["preview"] = (key, value)
        return value

    # ------------------------------------------------------------------ library calls
    def _small(self):
        """(the picture shrunk to the preview's size, the scale factor), made once."""
        if self._small_image is None:
            f = min(1.0, _PREVIEW_SIZE / max(self.image.shape[:2]))
            h, w = self.image.shape[:2]
            shape = (max(8, round(h * f)), max(8, round(w * f)))
            self._small_image = (resize(self.image, shape), shape[0] / h)
        return self._small_image

    def _preview(self, params):
        try:
            small, lattice, cells, spacing = self._preview_lattice(params)
        except ValueError:
            self._show_length(params)  # what it says about the region, too
            raise
        coarse = params.replace(
            spacing=spacing,
            max_frames=min(params.max_frames, _PREVIEW_FRAMES),
            target=min(params.target, _PREVIEW_FRAMES),
        )
        result = grow(lattice, cells, coarse, seed=self.seed)
        every = max(1, math.ceil(result.n_frames / _PREVIEW_CLIP_FRAMES))
        # Played at a fixed 8 fps: the coarse lattice shows the pattern, not the timing.
        clip = render(small, lattice, result, every=every, fps=8.0 * every)
        return clip.with_metadata(
            preview=True,
            preview_spacing=spacing,
            smooth=True,
            note=f"a coarse lattice, {every * 8 / params.fps:.3g}× faster than the run",
        )

    def after_preview(self, params):
        """The Length line for the values previewed (after the picture: it can wait)."""
        self._show_length(params)

    def _run(self, params, progress):
        self._show_length(params)  # the estimate of this very run (no preview came after)
        lattice, cells = self._lattice(params.spacing)
        grow_report, draw_report = Progress(progress).split(0.6)
        result = grow(lattice, cells, params, seed=self.seed, progress=grow_report)
        self.frost_result = result
        if result.end_frame is not None:  # the run's own end frame: no estimate left to show
            self._show_length(params, dry_run=result.end_frame)
        last = result.n_frames if result.end_frame is None else result.end_frame
        size, every = _run_size(last + 1, lattice.image_shape, min(480, max(self.image.shape[:2])))
        clip = render(self.image, lattice, result, every=every, size=size, progress=draw_report)
        return clip.with_metadata(seed=self.seed, n_cells=lattice.n_cells)

    def _show_clip(self, clip, seconds):
        super()._show_clip(clip, seconds)
        meta, params = clip.metadata, self.frost_result.params
        end = meta["end_frame"]
        last = meta["frames"][-1]
        ended = (
            f"frost ended at frame {end:,} (target {params.target:,})"
            if end is not None
            else f"the frost did not cover the region by the frame limit {last:,}"
        )
        played = f"{plural(len(clip), 'frame')} at {clip.fps:g} fps = {len(clip) / clip.fps:.1f} s"
        if meta["every"] > 1:
            played += (
                f" (every {_ordinal(meta['every'])} of the {last + 1:,} frames at "
                f"{params.fps:g} fps, to keep the clip in memory)"
            )
        return f"{ended}: {played}; done in {seconds:.1f} s"

    # ------------------------------------------------------------------ length
    def _show_length(self, params, dry_run=None):
        """Say up front how long the run will take (and how surely), and what gamma fits.

        The likely end frame and the band 90 % of measured runs fell in
        (:class:`fluidnb.frost.EndFrameEstimate`); once the values rest, the end
        frame of the run itself (``dry_run``: the automaton without drawing, see
        :meth:`warm`).
        """
        try:
            lattice, cells = self._lattice(params.spacing)
            est = estimate_end_frame(lattice, cells, params)
            gamma = est.likely_gamma_for(params.target)
        except ValueError as exc:
            self.estimate = None
            self.length.value = f"<span style='color:#b00020'>{html.escape(str(exc))}</span>"
            return
        self.estimate = est
        fps = params.fps
        if math.isinf(est.frames):
            text = "At these settings the frost never covers the region."
            likely = math.inf
        elif dry_run is not None:
            likely = dry_run
            text = (
                f"Length: this run ends at frame <b>{dry_run:,}</b> ({dry_run / fps:,.1f} s at "
                f"{fps:g} fps; the automaton run without drawing, seed {self.seed})"
            )
        else:
            likely = est.likely
            text = (
                f"Length: at γ = {params.gamma:g} this region ends near frame "
                f"<b>{est.likely:,.0f}</b> ({est.likely / fps:,.0f} s at {fps:g} fps; likely "
                f"{est.low:,.0f}–{est.high:,.0f}: 90 % of measured runs; at most "
                f"{est.frames:,.0f} by the mass balance); the exact frame follows when the "
                "sliders rest"
            )
        if likely > params.max_frames and not math.isinf(likely):
            text += f", beyond the frame limit {params.max_frames}: a run would stop first"
        if not math.isnan(gamma):
            long = likely > 1.5 * params.target
            colour = "#b00020" if long else "inherit"
            text = f"<span style='color:{colour}'>{text}.</span> "
            text += f"γ ≈ {gamma:.3g} ends near the target {params.target}."
            self._gamma_button.description = f"Use γ for {params.target} frames (≈ {gamma:.3g})"
        self.length.value = text

    def warm(self, params):
        """While the values rest: the run's own end frame, by the automaton without drawing.

        :func:`fluidnb.frost.grow` with the run's lattice, parameters and seed (the
        run is the same, then drawn): the Length line says the exact frame. Stopped
        by a newer value (a preview waits for it).
        """
        try:
            lattice, cells = self._lattice(params.spacing)
        except ValueError:
            return

        def stop(fraction, message):
            if self._closed or self._previews.pending() or self.panel.params != params:
                raise Cancelled

        try:
            result = grow(lattice, cells, params, seed=self.seed, progress=stop)
        except (Cancelled, ValueError):
            return
        if result.end_frame is not None and self.panel.params == params:
            self._show_length(params, dry_run=result.end_frame)

    def fit_gamma(self):
        """Set gamma so the run ends near the target (what the **Use γ** button does).

        Runs :func:`fluidnb.frost.gamma_for_target` in the background (the mass-balance
        gamma, corrected by a few runs of about the target's length) and sets the γ
        slider. Returns False if another computation is running.
        """
        seed = self.seed

        def task(params, progress):
            lattice, cells = self._lattice(params.spacing)
            progress(0.1, "fitting γ…")
            return gamma_for_target(lattice, cells, params.target, params, seed=seed)

        return self.start_task(
            task, self._gamma_fitted, message="fitting γ to the target…", busy=(self._gamma_button,)
        )

    def _gamma_fitted(self, fit, seconds):
        self.gamma_fit = fit
        self.panel.set("gamma", fit.gamma)
        end = "never" if fit.end_frame is None else fit.end_frame
        return (
            f"γ = {fit.gamma:.4g} ends at frame {end} (target {fit.target}; the "
            f"mass balance alone gave {fit.mass_balance_gamma:.4g}) in {seconds:.1f} s"
        )

    # ------------------------------------------------------------------ optimiser
    def optimise(self):
        """Run the optimiser in the background (what **Optimise β** does).

        Returns False if another computation is running or the inputs are not ready.
        """
        with self._rows_lock:
            self._rows = []
        self._show_table()
        solver, eta, seed = self._solver.value, self._eta.value, self.seed

        def task(params, progress):
            lattice, cells = self._lattice(params.spacing)
            return optimise_beta(
                lattice,
                cells,
                params.target,
                params,
                method=solver,
                eta=eta,
                seed=seed,
                progress=progress,
                on_step=self._add_row,
            )

        return self.start_task(
            task,
            self._optimised,
            message=f"optimising β ({solver})…",
            busy=(self._optimise_button,),
        )

    def _add_row(self, row):
        with self._rows_lock:
            self._rows.append(row)
        self._show_table()

    def _optimised(self, result, seconds):
        self.optimised = result
        self._show_table(result)
        self.panel.set("beta", result.beta)
        end = "never" if result.end_frame is None else result.end_frame
        verdict = "converged" if result.converged else "not converged"
        return (
            f"{verdict} in {seconds:.1f} s ({result.evaluations} runs): β = {result.beta:.4f} "
            f"ends at frame {end}, target {result.target} ± {result.tolerance:g}"
        )

    def _show_table(self, result=None):
        with self._rows_lock:
            rows = list(self._rows)
        body = "".join(
            f"<tr><td>{r.step}</td><td>{r.beta:.6f}</td>"
            f"<td>{'never' if r.end_frame is None else r.end_frame}</td>"
            f"<td>{html.escape(r.note)}</td></tr>"
            for r in rows
        )
        caption = "Optimiser: step, β, end frame"
        if result is not None:
            caption += f" — {html.escape(result.message)}"
        # JupyterLab's rendered tables have no cell padding of their own.
        cell = "padding:2px 10px;text-align:right"
        self.table.value = (
            "<table style='border-collapse:collapse;font-family:monospace'>"
            f"<caption style='text-align:left;white-space:nowrap'>{caption}</caption>"
            + "<tr>"
            + "".join(f"<th style='{cell}'>{h}</th>" for h in ("step", "β", "end frame", "note"))
            + "</tr>"
            + body.replace("<td>", f"<td style='{cell}'>")
            + "</table>"
        )


def _run_size(n_frames, shape, size):
    """(longest side, every) for a clip of ``n_frames`` of a ``shape`` lattice image."""
    h, w = shape[:2]
    per_pixel = 3 * 4 * (h * w) / max(h, w) ** 2  # bytes per (longest side)^2

    def fits(side, every):
        return math.ceil(n_frames / every) * per_pixel * side**2 <= _RUN_BYTES

    side = size
    while not fits(side, 1) and side > _RUN_MIN_SIZE:
        side = max(_RUN_MIN_SIZE, int(side * 0.9))
    every = 1
    while not fits(side, every):
        every += 1
    return side, every


def _ordinal(k):
    return {1: "1st", 2: "2nd", 3: "3rd"}.get(k, f"{k}th")
