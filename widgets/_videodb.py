r"""The video-database app: mask a photo, draw its flow, paint its speed, watch it move.

Okabe, Anjyo & Onai (2011) animate one still image of fluid from a database of fluid
videos: the photo is cut into 48 x 48 fragments, each gets candidates by appearance
(Eq. 1), an MRF (Eq. 4-6) picks one per fragment, and the frames are rendered from
the chosen fragments' motion. Here every step is a call into :mod:`fluidnb.videodb`
and :mod:`fluidnb.sketch`; the widget only gathers what the user drew and shows what
came back.
"""

from __future__ import annotations

import asyncio
import contextlib
import html
import io
import os
import threading
import time
import traceback

import ipywidgets as W
import numpy as np
from ipycanvas import MultiCanvas, hold_canvas
from PIL import Image
from traitlets import Any, Int

from fluidnb import Cancelled, Progress, as_image, to_uint8
from fluidnb.fields import resize
from fluidnb.sketch import (
    direction_field,
    load_strokes,
    quiver_segments,
    save_strokes,
    segment_heads,
)
from fluidnb.videodb import (
    FRAGMENT,
    STARTER_KINDS,
    STRIDE,
    AnimateParams,
    VideoDatabase,
    assign,
    open_database,
    prefetch,
    prefetch_preview,
    preview_frame,
    render,
    starter_database,
    starter_params,
    starter_path,
)
from fluidnb.videodb.figures import clip_colour, clip_map_picture, motion_arrows

from ._app import App, LatestWins, _in_kernel, _quick_mode
from ._canvas import DrawingCanvas
from ._common import Choice, hint, jpeg, output_dir, plural, row, shown_path
from ._panel import ParamPanel
from ._player import FramePlayer

__all__ = ["SPEED_MAX", "VideoDBApp"]

#: The speed (px/frame) painted by a full-value brush: the speed layer stores
#: ``speed / SPEED_MAX`` in [0, 1] (0 = not painted). The starter databases' fragments
#: move up to ~4 px/frame.
SPEED_MAX = 5.0

#: The bundled photos offered, and the database each suits.
PHOTOS = {"stream": "water", "clouds": "smoke", "fire": "fire", "lake": "water"}

#: The panel's groups: what a lecturer moves (the MRF's weights and the search's K)
#: open, the rendering's settings folded. ``rendering`` (the flow or the paper's
#: rendering, where the library has it) is shown as a toggle beside Render.
GROUPS = (
    ("the assignment (Eq. 1-6)", ("sigma", "lam", "rho", "candidates")),
    ("rendering (sec. 6)", ("shutter", "tau", "loop", "rendering", "travel", "detail")),
)
# The fields the panel shows (the rest keep their values: max_angle, max_speed_ratio,
# denoise, cell).
_HIDDEN = ("max_angle", "max_speed_ratio", "denoise", "cell")
_SOLVE_FIELDS = ("sigma", "lam", "rho")
_RETRIEVAL_FIELDS = ("candidates", "max_angle", "max_speed_ratio")
#: Fields that change the clip but not the assignment.
_RENDER_FIELDS = ("shutter", "denoise", "cell", "tau", "loop", "rendering", "travel", "detail")

_QUIVER = "rgba(255, 214, 10, 0.95)"
_MAP_WIDTH = 300  # the assignment map's width on screen, as the player's picture
_TILE = 60  # pixels per tile of the fragment view
# Live previews: one frame, FACTOR times smaller than the photo; their cache of
# difference frames is dropped beyond this many fragments (~9 KB each).
_PREVIEW_FACTOR = 2
_PREVIEW_LEVELS = 1  # a plain weighted blend: a quarter faster, no seam shows at half size
_PREVIEW_CACHE = 4096


def _kernel_loop():
    """The kernel's running event loop, or None outside a kernel (scripts, tests).

    Only a kernel's loop serves callbacks while a worker thread waits on it: in a
    plain process another library may leave a loop "running" in the main thread
    that never runs what is queued on it (Playwright's sync API does).
    """
    if not _in_kernel():
        return None
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        return None


class _AssignmentMap(W.VBox):
    """Which source clip each target fragment came from; a click shows that fragment.

    Drawn by the library's rule for pictures of an assignment
    (:func:`fluidnb.videodb.figures.clip_map_picture`,
    :func:`fluidnb.videodb.figures.motion_arrows`), the one the lesson's figures use.
    """

    def __init__(self, width=_MAP_WIDTH):
        self.width = int(width)
        self.photo = None
        self.assignment = None
        self.selected = None  #: index of the picked target fragment, or None
        self.on_pick = None  #: called with the picked index
        self.canvas = MultiCanvas(2, width=self.width, height=int(0.75 * self.width))
        self.canvas.layout.width = "100%"
        self.canvas.layout.max_width = f"{self.width}px"
        self.canvas.layout.height = "auto"
        self.canvas.add_class("fluidnb-vdb-map")
        self.canvas.on_mouse_down(self._clicked)
        # Voila drops drawing sent while the notebook runs: redraw for every new view.
        self.canvas.on_client_ready(self.redraw)
        self.legend = W.HTML()
        self.legend.add_class("fluidnb-vdb-legend")
        self.caption = W.HTML(layout=W.Layout(max_width=f"{self.width}px"))
        self.caption.add_class("fluidnb-vdb-fragment")
        self.strip = W.Image(format="png", layout=W.Layout(display="none"))
        self.strip.add_class("fluidnb-vdb-fragment-frames")
        super().__init__([self.canvas, self.legend, self.caption, self.strip])
        self.add_class("fluidnb-vdb-mapbox")

    @property
    def scale(self):
        """Canvas pixels per image pixel."""
        return self.canvas.width / self.photo.shape[1]

    def set_photo(self, photo):
        self.photo = photo
        self.assignment = None
        self.selected = None
        h, w = photo.shape[:2]
        self.canvas.width = self.width
        self.canvas.height = ch = max(1, round(h * self.width / w))
        # The photo at the canvas's size once (each re-solve only re-tints it), and the
        # image pixel under each canvas pixel, as clip_map_picture samples the clips.
        self._shown = resize(photo, (ch, self.width))
        self._rows = np.minimum((np.arange(ch) * h / ch).astype(int), h - 1)
        self._cols = np.minimum((np.arange(self.width) * w / self.width).astype(int), w - 1)
        self.strip.layout.display = "none"
        self.caption.value = ""
        self.legend.value = (
            "<span style='opacity:0.7'>Press Run: each fragment is coloured by the "
            "source clip it came from; click one to see it.</span>"
        )
        self.redraw()

    def set_assignment(self, assignment):
        self.assignment = assignment
        if self.selected is not None and self.selected >= len(assignment.target):
            self.selected = None
        self.legend.value = self._legend()
        self.redraw()
        if self.selected is not None and self.on_pick is not None:
            self.on_pick(self.selected)

    # ------------------------------------------------------------------ drawing
    def picture(self):
        """The map as RGB uint8 at canvas size: the photo tinted by source clip."""
        a = self.assignment
        clips = None if a is None else a.clip_map()[self._rows][:, self._cols]
        return to_uint8(clip_map_picture(self._shown, clips))

    def redraw(self, *_):
        if self.photo is None:
            return
        with hold_canvas():
            self.canvas[0].put_image_data(self.picture(), 0, 0)
            self._draw_marks()

    def _draw_marks(self):
        layer = self.canvas[1]
        layer.clear()
        a = self.assignment
        if a is None:
            return
        s = self.scale
        pos = a.target.positions.astype(float)
        # Cell outlines (each fragment owns the 24 x 24 cell at its centre), and the
        # arrows with their heads, each in one batched command: a re-solve redraws
        # them while a slider moves.
        layer.stroke_style = "rgba(0, 0, 0, 0.35)"
        layer.line_width = 1
        corner = (pos[:, ::-1] + STRIDE / 2) * s  # (x, y)
        layer.stroke_rects(corner[:, 0], corner[:, 1], STRIDE * s, STRIDE * s)
        arrows = (self.motion_segments()[..., ::-1] + 0.5) * s  # (row, col) -> (x, y)
        if len(arrows):
            lines = np.concatenate([arrows, segment_heads(arrows, size=3.5)])
            layer.stroke_style = "rgba(255, 255, 255, 0.95)"
            layer.line_width = 1.5
            layer.stroke_line_segments(lines.reshape(-1, 2), np.full(len(lines), 2))
        if self.selected is not None:
            r, c = pos[self.selected]
            layer.stroke_style = "rgba(255, 214, 10, 1)"
            layer.line_width = 2
            layer.stroke_rect(c * s, r * s, FRAGMENT * s, FRAGMENT * s)

    def motion_segments(self):
        """The assigned fragments' mean motion as arrows (k, 2, 2) (row, col) in the image.

        :func:`fluidnb.videodb.figures.motion_arrows`: one per moving fragment, centred on it.
        """
        if self.assignment is None:
            return np.empty((0, 2, 2))
        return motion_arrows(self.assignment)[0]

    def _legend(self):
        a = self.assignment
        clips = a.db.clip_of(a.fragments)
        used, counts = np.unique(clips, return_counts=True)
        items = []
        for k, n in zip(used, counts):
            r, g, b = (round(255 * v) for v in clip_colour(k))
            name = html.escape(str(a.db.clips[int(k)]["name"]))
            items.append(
                f"<span class='fluidnb-vdb-clip' data-clip='{int(k)}' style='display:inline-flex;"
                "align-items:center;margin-right:10px;white-space:nowrap'>"
                f"<span style='display:inline-block;width:11px;height:11px;margin-right:4px;"
                f"background:rgb({r},{g},{b});border:1px solid rgba(127,127,127,0.6)'></span>"
                f"{name} ({n})</span>"
            )
        return (
            f"<div style='font-size:12px;line-height:1.6;max-width:{self.width}px'>"
            f"{''.join(items)}</div>"
        )

    # ------------------------------------------------------------------ picking
    def fragment_at(self, row, col):
        """The target fragment under image pixel (row, col), or None (see the library's)."""
        return None if self.assignment is None else self.assignment.fragment_at(row, col)

    def _clicked(self, x, y):
        if self.photo is None:
            return
        s = self.scale
        i = self.fragment_at(y / s - 0.5, x / s - 0.5)
        if i is None:
            return
        self.selected = i
        with hold_canvas():
            self._draw_marks()
        if self.on_pick is not None:
            self.on_pick(i)


class VideoDBApp(App):
    r"""Animate a still photo of fluid from a video database (Okabe, Anjyo & Onai 2011).

    On the photo (a bundled one or an upload; an RGBA cut-out's alpha is its matte):

    * **brush**, layer *matte*: paint the fluid region (the eraser removes it);
    * **stroke**: draw the flow's direction; each stroke shows an arrow while you
      drag, and the interpolated direction field
      (:func:`fluidnb.sketch.direction_field`) appears as a yellow quiver over the
      matte, updated as strokes change;
    * **brush**, layer *speed*: paint the speed map with the *speed* slider's value in
      px/frame (white, translucent; unpainted = no constraint); after a run, *Use the
      result's speed map* loads :meth:`~fluidnb.videodb.Assignment.speed_map` there
      for editing, as the paper advises;
    * Undo, and Clear per layer; the strokes can be saved and loaded
      (:func:`fluidnb.sketch.save_strokes` JSON).

    The panel holds :math:`\sigma` (Eq. 2), :math:`\lambda` (Eq. 4), :math:`\rho`
    (Eq. 6) on log scales over the decades the lessons sweep, at the paper's values,
    and the candidate count; folded under them the rendering's settings (shutter,
    :math:`\tau`, loop, and the flow rendering's travel and detail), the rendering
    itself (flow or the paper's) being a toggle beside **Render**. ``N`` (frames per
    fragment) belongs to the database and is shown beside it. **Run** retrieves
    candidates, solves the MRF and renders the clip (:func:`fluidnb.videodb.assign`
    then :func:`~fluidnb.videodb.render`, with progress and Cancel; a starter database
    is built on the first Run). After a run, every value of a dragged :math:`\sigma`,
    :math:`\lambda` or :math:`\rho` is re-solved from the kept tables
    (:meth:`~fluidnb.videodb.Assignment.resolve`: no new retrieval; the latest value
    wins) and redraws the assignment map and the energy plot, and a preview frame
    (:func:`fluidnb.videodb.preview_frame`, one frame at half size) shows in the
    player; once the values rest for :attr:`settle` seconds (the kernel hears no
    "mouse released") the clip is rendered. A rendering setting renders again the
    same way; **Render** renders on demand. While the values rest, the re-solve's new
    fragments are rebuilt ahead (:func:`fluidnb.videodb.prefetch`); every clip streams
    into the player as it is made (``render(on_frames=...)``,
    :meth:`FramePlayer.stream`), its first frames playing while the rest come.

    Views: the clip in the player (play, loop, GIF/MP4 export); the assignment map
    (each fragment tinted by its source clip, with the assigned motion as arrows and
    a legend; a click shows the database fragment it got: mean image and frames);
    the energy of Eq. (4) per alpha-expansion sweep with ICM's as a reference line.

    Headless driving (what the tests and notebooks do)::

        app = VideoDBApp("stream", db="water")
        app.paint_matte([[300, 40], [300, 300]], radius=30)  # (row, col) points
        app.draw_stroke([[300, 40], [300, 300]])  # along the flow
        app.paint_speed([[320, 100], [320, 200]], speed=3.0)  # px/frame
        app.panel.set("candidates", 50)
        clip = app.run(timeout=300)  # press Run and wait -> fluidnb.Clip
        app.panel.set("sigma", 1e3)  # re-solves from the kept tables (map, preview)...
        app.wait_live()  # ...in the background, then renders the clip when it rests
        app.render_clip(timeout=120)  # press Render and wait -> Clip
        app.use_result_speed()  # the result's speed into the speed layer
        app.pick_fragment(300, 150)  # what a click on the map shows
        app.state()  # counters, energies, labels... as a dict

    plus :meth:`select` (tool and layer), :meth:`matte`, :meth:`strokes`,
    :meth:`speed_map`, :meth:`direction_field`, :meth:`set_photo`,
    :meth:`set_database`, :meth:`save_strokes` / :meth:`load_strokes`,
    :meth:`start` / :meth:`cancel` / :meth:`wait`, :meth:`wait_live` (re-solves,
    previews and the render on rest), and the counters :attr:`retrievals`,
    :attr:`resolves`, :attr:`renders`, :attr:`previews`.

    Parameters
    ----------
    photo : str, array_like, path or PIL image
        A bundled photo's name (``"stream"``, ``"clouds"``, ``"fire"``, ``"lake"``) or
        an image; with an alpha channel (or ``matte``) the matte layer starts from it.
    matte : array_like, shape (H, W), optional
        A matte to start with (> 0.5 is inside; soft edges are kept for the run).
    db : str, path or VideoDatabase, optional
        ``"water"``, ``"smoke"``, ``"fire"`` (starter databases, built on first use
        and cached), a database folder, or an opened database. Default: the kind the
        photo suits (water for an upload).
    params : AnimateParams, optional
        Starting parameters (default :meth:`AnimateParams.for_kind` of the database).
    quick : bool, optional
        The small starter databases and a 256-pixel photo (default: on when the
        environment variable ``FLUIDNB_QUICK`` is set, as in CI).
    size : int, optional
        Longest side of the photo worked on (default 480, 256 with ``quick``); larger
        photos are shrunk.
    display_size : int
        Longest side of the drawing canvas on screen.

    Examples
    --------
    >>> app = VideoDBApp("stream", size=96, db="water", quick=True)
    >>> app.paint_matte([[40, 10], [40, 80]], radius=12)
    >>> app.draw_stroke([[40, 10], [40, 80]])
    >>> dy, dx = app.direction_field()[40, 40]  # a unit (dy, dx) field, pointing right
    >>> bool(abs(dy) < 0.01 and dx > 0.99)
    True
    >>> app.close()
    """

    #: Retrievals made (each Run: candidates by Eq. 1 and the pair tables).
    retrievals = Int(0)
    #: Re-solves from kept tables (a sigma, lambda or rho change after a run).
    resolves = Int(0)
    #: Clips rendered (by Run or Render).
    renders = Int(0)
    #: The current :class:`fluidnb.videodb.Assignment` (None before the first run).
    assignment = Any(None, allow_none=True)

    def __init__(
        self,
        photo="stream",
        *,
        matte=None,
        db=None,
        params=None,
        quick=None,
        size=None,
        display_size=480,
    ):
        if quick is None:
            quick = _quick_mode()
        self.quick = bool(quick)
        self.size = int(size or (256 if self.quick else 480))
        self._display_size = int(display_size)
        self.animation = None  #: The last rendered :class:`fluidnb.videodb.Animation`.
        self._base = None  # the assignment of the last retrieval (its tables are reused)
        self._databases = {}
        self._given_db = None
        self._run_version = None  # canvas version the current assignment was made from
        self._field_key = None
        self._field = None
        self._loop = _kernel_loop()
        self._main_thread = threading.get_ident()
        # Re-solves (and their previews) run on the app shell's latest-wins worker, as
        # previews do.
        self._resolves = LatestWins(
            self._resolve_once,
            say=self.say,
            interval=lambda: self.resolve_interval,
            name="re-solve",
        )
        #: Least seconds between two live re-solves.
        self.resolve_interval = 0.02
        #: Whether new assignments show a preview frame (one frame at half size).
        self.live_preview = True
        #: Seconds after which a drag's re-solve shows a preview even with a newer
        #: value waiting (otherwise only maps are drawn until the slider pauses).
        self.preview_every = 0.3
        self._preview_shown = 0.0  # time.monotonic() of the last preview
        #: Seconds σ, λ, ρ (or a rendering setting) must rest before the clip is
        #: rendered: the kernel hears no "mouse released", only values.
        self.settle = 0.2
        #: Seconds the values must rest before a re-solve's fragments are prefetched.
        self.prefetch_after = 0.08
        self.quiver_segments = 0  #: Arrows of the direction field on the canvas now.
        self.previews = 0  #: Preview frames shown.
        self._preview_cache = (None, {})  # (database, fragment id -> D_t)
        self._previewed = None  # the assignment whose preview frame was shown last
        self._previewing = False  # a preview, not the clip, is in the player's picture
        self._was_playing = False  # the player played when the first preview came
        self._settle_timer = None
        self._settle_lock = threading.Lock()
        self._live_render = False  # the running task is a render on release
        self._superseded = False  # ... that newer values made obsolete

        name = photo if isinstance(photo, str) and photo in PHOTOS else None
        self.photo, self.photo_alpha = self._load_photo(photo, matte)
        self.photo_name = name or "upload"

        # ---------------------------------------------------------------- inputs
        # Choice: adding "upload" to the options must not pick the first photo.
        self._photo_pick = Choice(
            options=[*PHOTOS, *([] if name else ["upload"])],
            value=name or "upload",
            description="photo",
            style={"description_width": "44px"},
            layout=W.Layout(width="170px"),
        )
        self._upload = W.FileUpload(
            accept="image/*", multiple=False, description="Upload", layout=W.Layout(width="110px")
        )
        db_options = [(f"{k} (starter)", k) for k in STARTER_KINDS]
        db_options.append(("a database folder…", "folder"))
        if isinstance(db, VideoDatabase):
            self._given_db = db
            db_options.insert(0, (f"given: {db.kind}, {db.n_fragments} fragments", "given"))
            choice, path = "given", ""
        elif db is None:
            choice, path = PHOTOS.get(name, "water"), ""
        elif isinstance(db, str) and db in STARTER_KINDS:
            choice, path = db, ""
        else:
            choice, path = "folder", os.fspath(db)
        self._db_pick = Choice(
            options=db_options,
            value=choice,
            description="database",
            style={"description_width": "64px"},
            layout=W.Layout(width="290px"),
        )
        self._db_path = W.Text(
            value=path,
            placeholder="path/to/database",
            layout=W.Layout(width="290px", display="" if choice == "folder" else "none"),
        )
        self._n_label = W.HTML(layout=W.Layout(max_width="320px"))

        canvas = self._make_canvas()
        if params is None:
            params = AnimateParams.for_kind(self._kind_of_choice(choice))
        panel = ParamPanel(params, exclude=_HIDDEN, groups=GROUPS)

        self._speed = W.FloatSlider(
            value=2.0,
            min=0.25,
            max=SPEED_MAX,
            step=0.25,
            description="speed",
            readout_format=".2f",
            tooltip="speed brush value in px/frame (Okabe et al. 2011, Fig. 8-c); 0 = not painted",
            layout=W.Layout(width="260px"),
        )
        self._speed_unit = W.HTML("<span style='opacity:0.7'>px/frame</span>")
        self._clear_buttons = {
            layer: W.Button(
                description=f"Clear {label}",
                icon="trash",
                tooltip=f"erase every {label} drawn (undoable)",
                layout=W.Layout(width="125px"),
            )
            for layer, label in (("matte", "matte"), ("flow", "flow"), ("speed", "speed"))
        }
        self._show_quiver = W.Checkbox(
            value=True,
            description="direction field",
            indent=False,
            tooltip="show the strokes' interpolated direction as a quiver",
            layout=W.Layout(width="130px"),
        )
        self._strokes_file = W.Text(
            value="strokes.json",
            description="strokes",
            tooltip=(
                "the strokes file (fluidnb.strokes JSON) Save writes and Load reads; a "
                "name without a folder is in the output folder (fluidnb-output/)"
            ),
            style={"description_width": "52px"},
            layout=W.Layout(width="170px"),
        )
        self._save_button = W.Button(description="Save", icon="save", layout=W.Layout(width="72px"))
        self._load_button = W.Button(
            description="Load", icon="folder-open", layout=W.Layout(width="72px")
        )
        self._render_button = W.Button(
            description="Render",
            icon="film",
            tooltip=(
                "make the clip of the current assignment (done by itself when σ, λ, ρ "
                "or a rendering setting rests)"
            ),
            disabled=True,
            layout=W.Layout(width="100px"),
        )
        self._use_speed_button = W.Button(
            description="Use the result's speed map",
            icon="tachometer",
            tooltip="load the assigned motion's speed into the speed layer for editing",
            disabled=True,
            layout=W.Layout(width="220px"),
        )
        # The rendering (AnimateParams.rendering, when the library has it) as a toggle
        # bound to the panel's own control, which stays hidden.
        self._rendering = None
        if "rendering" in panel.controls:
            control = panel.controls["rendering"]
            self._rendering = W.ToggleButtons(
                options=list(control.options),
                value=control.value,
                tooltip=control.tooltip,
                style={"button_width": "64px"},
                layout=W.Layout(width="auto"),
            )
            W.link((self._rendering, "value"), (control, "value"))
            control.layout.display = "none"
        self.map = _AssignmentMap()
        self.map.on_pick = self._show_fragment
        self.energy = W.HTML()
        self.stats = W.HTML()
        for wid, cls in [
            (self._photo_pick, "fluidnb-photo"),
            (self._upload, "fluidnb-upload"),
            (self._db_pick, "fluidnb-vdb-db"),
            (self._db_path, "fluidnb-vdb-db-path"),
            (self._n_label, "fluidnb-vdb-N"),
            (self._speed, "fluidnb-vdb-speed"),
            (self._show_quiver, "fluidnb-vdb-show-quiver"),
            (self._strokes_file, "fluidnb-vdb-strokes-file"),
            (self._save_button, "fluidnb-vdb-save-strokes"),
            (self._load_button, "fluidnb-vdb-load-strokes"),
            (self._render_button, "fluidnb-vdb-render"),
            (self._use_speed_button, "fluidnb-vdb-use-speed"),
            (self.energy, "fluidnb-vdb-energy"),
            (self.stats, "fluidnb-vdb-stats"),
        ]:
            wid.add_class(cls)
        if self._rendering is not None:
            self._rendering.add_class("fluidnb-vdb-rendering")
        for layer, button in self._clear_buttons.items():
            button.add_class(f"fluidnb-vdb-clear-{layer}")
            button.on_click(lambda _, layer=layer: self.canvas.clear(layer))

        # One layout for every app (App): the canvas and its tools | the clip and the
        # assignment map | the photo, the database and the compact panel (σ, λ, ρ, K
        # open; the rendering folded), so the map changes beside σ as it moves.
        super().__init__(
            panel=panel,
            run=self._run_task,
            canvas=canvas,
            player=FramePlayer(display_width=_MAP_WIDTH),
            title="Fluid animation from one image — Okabe, Anjyo & Onai (video database)",
            inputs=[
                row(self._photo_pick, self._upload),
                row(self._db_pick, self._db_path),
                self._n_label,
            ],
            controls=[
                row(
                    self._render_button,
                    *([self._rendering] if self._rendering is not None else []),
                    self._use_speed_button,
                ),
                W.HTML("<b>energy (Eq. 4) per sweep</b>", layout=W.Layout(margin="0.6em 0 0 0")),
                self.energy,
                self.stats,
                hint(
                    "<b>brush</b> on <i>matte</i>: paint the fluid · <b>stroke</b>: draw the "
                    "flow (arrows; the yellow quiver is the interpolated direction) · "
                    "<b>brush</b> on <i>speed</i>: paint px/frame (white) · Run, then move "
                    "σ, λ, ρ: the map and a preview frame follow as you drag, the clip when "
                    "you let go.",
                    max_width="320px",
                ),
            ],
            canvas_tools=[
                row(self._speed, self._speed_unit),
                row(*self._clear_buttons.values()),
                row(self._show_quiver, self._strokes_file, self._save_button, self._load_button),
            ],
        )
        self.views = (
            self.titled("clip", self.player, margin="0 0 0.4em 0"),
            self.titled("assignment (click a fragment)", self.map, margin="0"),
        )
        self.views_width = f"{_MAP_WIDTH + 8}px"
        self.add_class("fluidnb-vdb-app")

        # ---------------------------------------------------------------- wiring
        self._photo_pick.on_pick(self._photo_picked)
        self._upload.observe(self._uploaded, "value")
        self._db_pick.on_pick(self._db_picked)
        self._db_path.observe(lambda _: self._show_n(), "value")
        self._speed.observe(lambda _: self._sync_brush(), "value")
        self._show_quiver.observe(lambda _: self._update_quiver(), "value")
        self._save_button.on_click(lambda _: self._save_clicked())
        self._load_button.on_click(lambda _: self._load_clicked())
        self._render_button.on_click(lambda _: self.start_render())
        self._use_speed_button.on_click(lambda _: self.use_result_speed())
        self.panel.observe(self._panel_changed, "params")
        self.observe(lambda _: self._show_stats(), ["retrievals", "resolves", "renders"])
        self._wire_canvas(canvas)
        self.map.set_photo(self.photo)
        self._show_n()
        self._show_energy()
        self._show_stats()

    # ------------------------------------------------------------------ photo
    def _load_photo(self, photo, matte=None):
        from fluidnb import data

        if isinstance(photo, str) and photo in PHOTOS:
            image, alpha = data.sample(photo, return_alpha=True)
            if max(image.shape[:2]) > self.size:
                image, alpha = data.sample(photo, size=self.size, return_alpha=True)
        else:
            if isinstance(photo, Image.Image) and max(photo.size) > self.size:
                photo = photo.copy()
                photo.thumbnail((self.size, self.size), Image.LANCZOS)
            image, alpha = as_image(photo, mode="rgb", name="photo", return_alpha=True)
            if max(image.shape[:2]) > self.size:
                h, w = image.shape[:2]
                f = self.size / max(h, w)
                new = (max(1, round(h * f)), max(1, round(w * f)))
                image = resize(image, new)
                alpha = None if alpha is None else resize(alpha, new)
        if min(image.shape[:2]) < FRAGMENT:
            raise ValueError(
                f"photo must be at least {FRAGMENT} x {FRAGMENT} pixels (one fragment), got "
                f"{image.shape[0]} x {image.shape[1]}"
            )
        if matte is not None:
            alpha = as_image(matte, mode="grey", name="matte")
            if alpha.shape != image.shape[:2]:
                raise ValueError(
                    f"matte must have the photo's size {image.shape[:2]}, got {alpha.shape}"
                )
        return np.ascontiguousarray(image, np.float32), alpha

    def _make_canvas(self):
        # The speed brush's value comes from the app's px/frame slider and the matte
        # brush always paints "inside": no 0..1 value slider.
        canvas = DrawingCanvas(
            self.photo,
            strokes=["flow"],
            masks=["matte"],
            maps=["speed"],
            display_size=self._display_size,
            value_slider=False,
            button_width="88px",
        )
        speed = canvas.layers["speed"]
        speed.color, speed.opacity = (1.0, 1.0, 1.0), 0.95  # grey levels: white = fast
        canvas.brush_radius = max(2.0, max(self.photo.shape[:2]) / 24)
        if self.photo_alpha is not None:
            canvas.set_mask(self.photo_alpha > 0.5, "matte")
        canvas.select("brush", "matte")
        return canvas

    def _wire_canvas(self, canvas):
        # The canvas column as wide as the canvas (with room for the tools), narrower
        # on a narrower page -- the canvas shrinks with it -- so the clip, the map and
        # the panel stay beside it (at 1280 px they wrapped under it). 700 px: the
        # clip-and-map column and the panel, with their margins.
        widest = max(canvas.canvas.width, 440)
        self.drawing_width = f"clamp(360px, calc(100% - 700px), {widest}px)"
        canvas.observe(self._drawing_changed, "version")
        canvas.observe(lambda _: self._sync_brush(), ["tool", "layer"])
        self._field_key = self._field = None
        self._sync_brush()
        self._update_quiver()

    def set_photo(self, photo, matte=None):
        """Use another photo: a bundled name or an image (the drawing starts afresh).

        Returns False (and says why in the status line) if the image is refused.
        """
        if self.running:
            self.say("wait for the run to finish (or cancel it) before changing the photo")
            return False
        try:
            image, alpha = self._load_photo(photo, matte)
        except ValueError as exc:
            self.say(str(exc), "error")
            return False
        name = photo if isinstance(photo, str) and photo in PHOTOS else "upload"
        self.photo, self.photo_alpha, self.photo_name = image, alpha, name
        old = self.canvas
        self.canvas = canvas = self._make_canvas()  # shown in the old one's place
        old.close()
        self._wire_canvas(canvas)
        self._forget_result()
        self.map.set_photo(self.photo)
        # Options and value together: a plain Dropdown given new options picks its
        # first ("stream") on the way, which loaded the stream over the upload.
        options = [*PHOTOS, *(["upload"] if name == "upload" else [])]
        self._photo_pick.set_options(options, name)
        if name in PHOTOS and self._db_pick.value in STARTER_KINDS:
            self.set_database(PHOTOS[name])
        h, w = image.shape[:2]
        shown = "your upload" if name == "upload" else f"the {name} photo"
        self.say(f"photo: {shown}, {w} x {h} pixels; paint its matte")
        return True

    def _photo_picked(self, name):
        if name != self.photo_name and name in PHOTOS:
            self.set_photo(name)

    def _uploaded(self, change):
        files = change["new"]
        if not files:
            return
        try:
            image = Image.open(io.BytesIO(bytes(files[0]["content"])))
            image.load()
        except Exception as exc:  # a broken or foreign file: say so, keep the photo
            self.say(f"could not read the upload: {exc}", "error")
            return
        self.set_photo(image)

    def _forget_result(self):
        self._supersede_render()
        self._previewing = False
        self.assignment = None
        self._base = None
        self._run_version = None
        self._render_button.disabled = True
        self._use_speed_button.disabled = True
        self._show_energy()

    # ------------------------------------------------------------------ database
    @staticmethod
    def _kind_of_choice(choice):
        return choice if choice in STARTER_KINDS else "water"

    def set_database(self, db):
        """Choose the database: a starter kind, a folder, or an opened database."""
        if isinstance(db, VideoDatabase):
            self._given_db = db
            label = (f"given: {db.kind}, {db.n_fragments} fragments", "given")
            others = [o for o in self._db_pick.options if o[1] != "given"]
            self._db_pick.set_options([label, *others], "given")
        elif isinstance(db, str) and db in STARTER_KINDS:
            self._db_pick.value = db
        else:
            self._db_path.value = os.fspath(db)
            self._db_pick.value = "folder"
        self._show_n()

    def _db_picked(self, choice):
        self._db_path.layout.display = "" if choice == "folder" else "none"
        kind = self._given_db.kind if choice == "given" else self._kind_of_choice(choice)
        tau = AnimateParams.for_kind(kind).tau
        if "tau" in self.panel.controls and self.panel.params.tau != tau:
            self.panel.set("tau", tau)  # fire and smoke move their outline (Sec. 6)
        self._show_n()
        if self.assignment is not None:
            self.say("the database changed: press Run for a new retrieval")

    def _db_key(self):
        choice = self._db_pick.value
        if choice == "given":
            return ("given",)
        if choice == "folder":
            return ("folder", os.path.abspath(os.path.expanduser(self._db_path.value.strip())))
        return ("starter", choice, self.quick)

    def database(self, progress=None):
        """The chosen database, opened (a starter one is built on first use, cached)."""
        key = self._db_key()
        if key[0] == "given":
            return self._given_db
        db = self._databases.get(key)
        if db is None:
            if key[0] == "folder":
                if not self._db_path.value.strip():
                    raise ValueError("database folder is empty: type the path of a video database")
                if not os.path.isdir(key[1]):
                    raise ValueError(f"database folder {key[1]!r} does not exist")
                db = open_database(key[1], progress=progress)
            else:
                db = starter_database(key[1], quick=self.quick, progress=progress)
            self._databases[key] = db
        self._show_n(db)
        return db

    def _database_ready(self):
        """Whether :meth:`database` opens the chosen database without building it."""
        key = self._db_key()
        return (
            key[0] != "starter"
            or key in self._databases
            or starter_path(key[1], quick=self.quick).exists()
        )

    def _show_n(self, db=None):
        key = self._db_key()
        if db is None:
            db = self._given_db if key[0] == "given" else self._databases.get(key)
        style = "font-size:12px;opacity:0.85;line-height:1.4;display:inline-block"
        if db is not None:
            text = (
                f"N = <b>{db.params.N}</b> frames per fragment (the database's) · "
                f"{plural(db.n_fragments, 'fragment')}, {plural(len(db.clips), 'clip')}"
            )
        elif key[0] == "starter":
            built = starter_path(key[1], quick=self.quick).exists()
            when = "cached" if built else "built on the first Run, then cached"
            size = "quick" if self.quick else "full"
            text = (
                f"N = <b>{starter_params().N}</b> frames per fragment (the database's) · "
                f"{size} starter database, {when}"
            )
        else:
            text = "N (frames per fragment): read from the database when it opens"
        self._n_label.value = f"<span style='{style}'>{text}</span>"

    # ------------------------------------------------------------------ drawing
    def select(self, tool, layer=None):
        """Choose the tool (stroke, brush, eraser, fill) and layer (matte, flow, speed)."""
        self.canvas.select(tool, layer)

    def _sync_brush(self):
        c = self.canvas
        speed = c.layer == "speed" and c.tool in ("brush", "fill")
        self._speed.layout.display = "" if speed else "none"
        self._speed_unit.layout.display = "" if speed else "none"
        c.brush_value = self._speed.value / SPEED_MAX if c.layer == "speed" else 1.0

    def paint_matte(self, points, *, radius=None):
        """Paint the matte along ``points`` ((row, col) image pixels) with the brush."""
        self.canvas.paint(points, radius=radius, layer="matte")

    def erase_matte(self, points, *, radius=None):
        """Erase the matte along ``points`` with the eraser."""
        self.canvas.paint(points, radius=radius, layer="matte", erase=True)

    def draw_stroke(self, points):
        """Draw one flow stroke through ``points`` ((row, col)), in the flow's direction."""
        self.canvas.draw_stroke(points, layer="flow")

    def paint_speed(self, points, speed=None, *, radius=None):
        """Paint the speed map along ``points`` with ``speed`` px/frame (the slider's)."""
        if speed is not None:
            if not 0 < speed <= SPEED_MAX:
                raise ValueError(f"speed must be in (0, {SPEED_MAX:g}] px/frame, got {speed}")
            self._speed.value = float(speed)
        self.canvas.select("brush", "speed")
        self.canvas.paint(points, radius=radius, value=self._speed.value / SPEED_MAX)

    def set_matte(self, matte):
        """Replace the matte (bool or > 0.5 inside; undoable)."""
        self.canvas.set_mask(np.asarray(matte), "matte")

    def set_strokes(self, strokes):
        """Replace the flow strokes, each an (n, 2) (row, col) array (undoable)."""
        self.canvas.set_strokes(strokes, "flow")

    def set_speed(self, speed):
        """Replace the speed map, (H, W) px/frame, 0 = not painted (undoable)."""
        arr = np.asarray(speed, np.float32)
        if arr.size and (arr.min() < 0 or arr.max() > SPEED_MAX):
            raise ValueError(
                f"speed must lie in [0, {SPEED_MAX:g}] px/frame, got [{arr.min():g}, {arr.max():g}]"
            )
        self.canvas.set_map(arr / SPEED_MAX, "speed")

    def matte(self):
        """The matte a run uses, float32 (H, W) in [0, 1].

        The painted mask; where it covers the photo's own soft alpha (an RGBA
        cut-out), that alpha's values, so the edge stays soft.
        """
        painted = self.canvas.get_mask("matte")
        m = painted.astype(np.float32)
        if self.photo_alpha is not None:
            m = np.where(painted & (self.photo_alpha > 0), self.photo_alpha, m)
        return m.astype(np.float32)

    def strokes(self):
        """The flow strokes: a list of (n, 2) (row, col) arrays."""
        return self.canvas.get_strokes("flow")

    def speed_map(self):
        """The painted speed in px/frame, float32 (H, W); 0 where not painted."""
        return self.canvas.get_map("speed") * np.float32(SPEED_MAX)

    def direction_field(self):
        """The strokes' interpolated unit direction field (H, W, 2) (dy, dx), or None."""
        strokes = self.strokes()
        if not strokes:
            return None
        key = tuple(s.tobytes() for s in strokes)
        if key != self._field_key:
            self._field = direction_field(strokes, self.photo.shape[:2])
            self._field_key = key
        return self._field

    def _update_quiver(self):
        try:
            field = self.direction_field() if self._show_quiver.value else None
        except ValueError as exc:
            self.say(str(exc), "error")
            field = None
        if field is None:
            self.quiver_segments = 0
            self.canvas.show_segments(None)
            return
        matte = self.canvas.get_mask("matte")
        if matte.any():  # the field matters only where the fluid is
            field = field * matte[..., None]
        step = max(8, round(max(self.photo.shape[:2]) / 16))
        segments = quiver_segments(field, step=step, length=0.7 * step)
        self.quiver_segments = len(segments)
        self.canvas.show_segments(segments if len(segments) else None, _QUIVER)

    def _drawing_changed(self, change):
        self._update_quiver()
        if self._run_version is not None and change["new"] != self._run_version:
            self._run_version = None
            if not self.running:
                self.say("the drawing changed since the run: press Run for a new retrieval")

    # ------------------------------------------------------------------ strokes file
    def _strokes_path(self, path):
        """Where the strokes file ``path`` is: a bare name lies in the output folder."""
        path = os.path.expanduser(
            os.fspath(path or self._strokes_file.value.strip() or "strokes.json")
        )
        return path if os.path.dirname(path) else os.path.join(output_dir(), path)

    def save_strokes(self, path=None):
        """Write the strokes as a ``fluidnb.strokes`` JSON file; returns the path.

        ``path`` (default: the file box's, ``strokes.json``) is a bare file name in the
        output folder (:func:`fluidnb.widgets._common.output_dir`, ``fluidnb-output/``
        beside the notebook), or a path with its folder.
        """
        strokes = self.strokes()
        out = save_strokes(self._strokes_path(path), strokes, self.photo.shape[:2])
        self.say(f"saved {plural(len(strokes), 'stroke')} to {shown_path(out)}", "ok")
        return out

    def load_strokes(self, path=None):
        """Replace the strokes by those of a JSON file (undoable); ValueError if refused.

        ``path`` as for :meth:`save_strokes`.
        """
        path = self._strokes_path(path)
        strokes, _ = load_strokes(path, shape=self.photo.shape[:2])
        self.set_strokes(strokes)
        self.say(f"loaded {plural(len(strokes), 'stroke')} from {shown_path(path)}", "ok")
        return strokes

    def _save_clicked(self):
        try:
            self.save_strokes()
        except (ValueError, OSError) as exc:
            self.say(f"could not save the strokes: {exc}", "error")

    def _load_clicked(self):
        try:
            self.load_strokes()
        except (ValueError, OSError) as exc:
            self.say(str(exc), "error")

    # ------------------------------------------------------------------ run
    def _inputs(self):
        """What the user drew, as the library takes it; ValueError in plain words."""
        matte = self.matte()
        if not (matte > 0).any():
            raise ValueError(
                "matte is empty: paint the fluid region on the photo with the brush "
                "(layer matte); your strokes and speed are kept"
            )
        strokes = self.strokes() or None
        speed = self.speed_map()
        return matte, strokes, (speed if speed.any() else None)

    @property
    def _busy_widgets(self):
        # Render stays clickable (refused while busy) so a failed run cannot leave it
        # enabled without an assignment.
        return (self._photo_pick, self._upload, self._db_pick, self._db_path, self._load_button)

    def start(self):
        """Retrieve, solve and render in the worker (what **Run** does).

        Returns False (and says why) when nothing starts: a run is going on, the
        parameters are invalid, or the matte is empty.
        """
        if self.running:
            return False
        try:
            inputs = self._inputs()
        except ValueError as exc:
            self.say(str(exc), "error")
            return False
        version = self.canvas.version
        image = self.photo

        def task(params, progress):
            return self._run_task(params, progress, inputs, image, version)

        self._superseded = False
        return self.start_task(
            task, self._ran, message="retrieving candidates…", busy=self._busy_widgets
        )

    def _run_task(self, params, progress, inputs=None, image=None, version=None):
        matte, strokes, speed = self._inputs() if inputs is None else inputs
        image = self.photo if image is None else image
        # A starter database built on first use takes most of the run (minutes in full
        # size): give it most of the bar, so the bar does not creep in its first 15 %.
        building = not self._database_ready()
        cuts = (0.8, 0.93) if building else (0.15, 0.65)
        opening, assigning, rendering = Progress(progress).split(*cuts)
        db = self.database(progress=opening)
        a = assign(image, matte, db, params, direction=strokes, speed=speed, progress=assigning)
        self.retrievals += 1
        animation = self._render_streamed(a, params, rendering)
        self._base = a
        self.animation = animation
        self.assignment = a
        self._run_version = version
        return animation.clip

    def _ran(self, clip, seconds):
        self._show_clip(clip, seconds)
        self._previewing = False
        self._on_main(self._show_assignment)
        self._render_button.disabled = False
        self._use_speed_button.disabled = False
        a = self.assignment
        # A slider moved during the run gets its re-solve; otherwise the worker fills
        # the preview's cache, so the first drag shows its preview at once.
        self.request_resolve()
        return (
            f"done in {seconds:.1f} s: {plural(len(a.target), 'fragment')}, K = "
            f"{a.candidates.shape[1]}, E = {a.solution.energy:.4g} after "
            f"{plural(a.solution.sweeps, 'sweep')} (ICM {a.solution.icm_energy:.4g}), "
            f"{plural(len(clip), 'frame')}"
        )

    def start_render(self):
        """Render the clip of the current assignment in the worker (what **Render** does)."""
        if self.running:
            return False
        if self.assignment is None:
            self.say("nothing to render yet: press Run first", "error")
            return False
        self._superseded = False
        return self.start_task(
            self._render_task, self._rendered, message="rendering…", busy=self._busy_widgets
        )

    def _render_task(self, params, progress):
        self.wait_resolve()
        a = self.assignment
        # The assignment's own sigma, lambda, rho (they made it); the panel's rendering
        # settings.
        params = params.replace(**{k: getattr(a.params, k) for k in _SOLVE_FIELDS})
        if self.live_preview and self._previewed is not a and not self._clip_is_current():
            # One frame first (a few percent of the clip's time): the new assignment is
            # on screen at once, its clip follows. A drag has shown it already.
            progress(0.0, "a first frame")
            self._show_preview(a, params)
        animation = self._render_streamed(a, params, progress)
        self.animation = animation
        return animation.clip

    def _render_streamed(self, a, params, progress):
        """:func:`~fluidnb.videodb.render`, its frames shown in the player as they are made."""
        try:
            # No stages: the app plays the clip (they would take ~1 GB at 480 px).
            animation = render(a, params, progress=progress, on_frames=self._stream, stages=False)
        except Cancelled:
            if not self._superseded and self.result is not None:
                self.player.clip = self.result  # the user's Cancel: the last clip again
            raise
        self.renders += 1
        return animation

    def _stream(self, clip, done):
        """The clip's first frames into the player while the rest are made (render's on_frames)."""
        if self._superseded:
            return  # newer values are on their way: their preview shows, not this
        first = self.player.clip is not clip  # the first frames: they replace the preview
        self.player.stream(clip, done)
        if first:
            self._previewing = False
            if self._was_playing:  # the previews stopped the player: play the new clip
                self._was_playing = False
                self.player.play(True)

    def _rendered(self, clip, seconds):
        if clip is None:  # a render on release that newer values made obsolete
            return self.status
        self._show_clip(clip, seconds)
        self._previewing = False
        if self._was_playing:  # the previews stopped it: play the new clip
            self._was_playing = False
            self.player.play(True)
        self._render_button.disabled = False
        self._use_speed_button.disabled = False
        p = clip.metadata["params"]
        return (
            f"rendered in {seconds:.2f} s: {plural(len(clip), 'frame')} "
            f"(σ={p['sigma']:.3g}, λ={p['lam']:.3g}, ρ={p['rho']:.3g})"
        )

    def render_clip(self, timeout=None):
        """Press Render and wait (headless); returns the clip."""
        if self.start_render():
            self.wait(timeout)
        return self.result

    # ------------------------------------------------------------------ live: σ, λ, ρ
    def _panel_changed(self, change):
        new, old, base = change["new"], change["old"], self._base
        if base is None:
            return
        if any(getattr(new, k) != getattr(base.params, k) for k in _RETRIEVAL_FIELDS):
            self.say("candidates changed: press Run for a new retrieval")
        solve = any(getattr(new, k) != getattr(self.assignment.params, k) for k in _SOLVE_FIELDS)
        look = any(getattr(new, k, None) != getattr(old, k, None) for k in _RENDER_FIELDS)
        if solve or look:
            self._supersede_render()
        if solve:
            self.request_resolve()  # its preview, then the clip once the slider rests
        elif look:
            self._schedule_render()

    def request_resolve(self):
        """Re-solve for the panel's sigma, lambda, rho in the background (latest wins).

        Each re-solve redraws the assignment map and shows a preview frame in the
        player (:func:`fluidnb.videodb.preview_frame`: one frame at half size); once
        the values rest for :attr:`settle` seconds the clip is rendered.
        """
        if not self._closed:
            self._resolves.request()

    def _resolve_once(self):
        base, current, params = self._base, self.assignment, self.panel.params
        if base is None or current is None:
            return
        wanted = {k: getattr(params, k) for k in _SOLVE_FIELDS}
        if all(getattr(current.params, k) == v for k, v in wanted.items()):
            if self.live_preview:
                # After a run: ready for the first drag, and the candidates' mean images
                # read (0.3-0.5 s once; a re-solve's preview then reads one frame per
                # new fragment). A value arriving meanwhile stops it between clips.
                cache = self._preview_cache_for(current)
                with contextlib.suppress(Cancelled):
                    prefetch_preview(current, cache, progress=self._stop_when_moved(current))
            return
        started = time.perf_counter()
        new = base.resolve(**wanted)
        if self._base is not base:  # a run replaced the tables meanwhile
            return
        solved = time.perf_counter() - started
        changed = int((new.labels != current.labels).sum())
        self.assignment = new
        self.resolves += 1
        self._on_main(self._show_assignment)
        # The map first; the preview when no newer value waits, or when the last one is
        # older than preview_every (a drag faster than re-solve and preview together
        # shows every map it can, a preview now and then, and the last one). The
        # preview is made here while the kernel's thread draws the map (its kernels
        # release the GIL).
        stale = time.monotonic() - self._preview_shown > self.preview_every
        if self.live_preview and (stale or not self._values_changed()):
            self._show_preview(new, params)
        if not self.running or self._live_render:
            # One line (a second would move the app under the mouse while it drags).
            # (σ, λ, ρ are on their sliders and under the energy plot.)
            self.say(
                f"re-solved from the kept tables in {solved:.2f} s: {changed} of "
                f"{plural(len(new.labels), 'fragment')} changed"
            )
        self._schedule_render()
        self._prefetch(new)

    def _prefetch(self, a):
        """While the values rest, rebuild the fragments ``a``'s clip needs (its render waits).

        :func:`fluidnb.videodb.prefetch` on this worker, after the map and the preview:
        the render on rest (or a press of Render) waits for the re-solves, so it starts
        with them. A newer value stops it between source clips.
        """
        # Only once the values rest (prefetch_after seconds without a new one): a drag
        # sends a value every ~30 ms, and a prefetch for each would hold this worker
        # (30-90 ms measured in Chromium) while the next value waits for its map. A
        # render that started meanwhile rebuilds what it needs itself.
        deadline = time.monotonic() + self.prefetch_after
        while True:
            if self._closed or self.running or self._values_changed():
                return
            if time.monotonic() >= deadline:
                break
            time.sleep(0.005)
        # Stopped by a newer value, or settings the render will refuse (and say so).
        with contextlib.suppress(Cancelled, ValueError):
            prefetch(a, self.panel.params, progress=self._stop_when_moved(a))

    def _stop_when_moved(self, a):
        """A progress callback that stops background work for ``a`` once it is stale.

        Raises :class:`Cancelled` when the app closes, another assignment replaces
        ``a``, or σ, λ, ρ no longer match it.
        """

        def moved(fraction, message):
            if self._closed or self.assignment is not a or self._values_changed():
                raise Cancelled

        return moved

    def wait_resolve(self, timeout=30):
        """Block until every re-solve asked for so far, and its preview, is done (tests)."""
        self._resolves.wait(timeout)

    def _preview_cache_for(self, a):
        """The difference frames kept for previews of ``a``'s database (filled for ``a``)."""
        db, cache = self._preview_cache
        if db is not a.db or len(cache) > _PREVIEW_CACHE:
            cache = {}
            self._preview_cache = (a.db, cache)
        if not set(a.fragments.tolist()) <= cache.keys():
            preview_frame(a, factor=_PREVIEW_FACTOR, levels=_PREVIEW_LEVELS, cache=cache)
        return cache

    def _values_changed(self):
        """Whether the panel's σ, λ, ρ differ from the current assignment's."""
        a, params = self.assignment, self.panel.params
        return a is not None and any(
            getattr(params, k) != getattr(a.params, k) for k in _SOLVE_FIELDS
        )

    def _show_preview(self, a, params):
        """One frame of ``a`` at half size in the player, until its clip comes."""
        cache = self._preview_cache_for(a)
        picture = preview_frame(
            a, params, factor=_PREVIEW_FACTOR, levels=_PREVIEW_LEVELS, cache=cache
        )
        data = jpeg(picture)  # the player's format
        if self.assignment is not a:
            return  # a newer one is on its way
        # One line under the picture (a longer one would push the map down); the rest
        # in its tooltip.
        follows = "rendering the clip" if self.running else "the clip follows when the values rest"
        note = f"preview: σ = {a.params.sigma:.3g}, λ = {a.params.lam:.3g}, ρ = {a.params.rho:.3g}"
        title = (
            f"one frame at half size, made in a moment (fluidnb.videodb.preview_frame); {follows}"
        )

        def show():
            if self.assignment is not a or self._clip_is_current():
                return
            self._previewed = a
            if not self._previewing:
                self._was_playing = self.player.playing
            self._previewing = True
            self._preview_shown = time.monotonic()
            self.player.play(False)
            # The caption first: each widget sends its own message, and the picture
            # should never show under the caption of the one before.
            self.player.info.value = (
                f"<span class='fluidnb-vdb-preview' title='{html.escape(title)}' "
                f"style='opacity:0.85;white-space:nowrap'>{html.escape(note)}</span>"
            )
            self.player.image.value = data
            self.player.image.layout.display = None
            self.previews += 1

        self._on_main(show)

    def _clip_is_current(self):
        """Whether the player's clip is the current assignment with the panel's rendering."""
        a, animation = self.assignment, self.animation
        if a is None or animation is None or animation.assignment is not a:
            return False
        made, wanted = animation.clip.metadata["params"], self.panel.params.to_dict()
        return all(made.get(k) == wanted[k] for k in _RENDER_FIELDS if k in wanted)

    def _schedule_render(self):
        """Render the clip once the values have rested for :attr:`settle` seconds.

        The kernel is told each value of a dragged slider but not that the mouse was
        released: a pause stands for the release. Every new value restarts the wait.
        """
        with self._settle_lock:
            if self._settle_timer is not None:
                self._settle_timer.cancel()
            if self._closed:
                return
            self._settle_timer = threading.Timer(self.settle, self._settled)
            self._settle_timer.daemon = True
            self._settle_timer.start()

    def _settled(self):
        if self._closed or self.running or self.assignment is None:
            return
        if self._values_changed():
            return  # a re-solve is on its way; it schedules the render again
        if self._clip_is_current():
            return
        self._live_render, self._superseded = True, False
        if not self.start_task(
            self._live_render_task,
            self._rendered,
            message="rendering the clip…",
            busy=self._busy_widgets,
        ):
            self._live_render = False

    def _live_render_task(self, params, progress):
        try:
            return self._render_task(params, progress)
        except Cancelled:
            if self._superseded:  # newer values: their render comes when they rest
                return None
            raise  # the user's Cancel
        finally:
            self._live_render = False

    def _supersede_render(self):
        """Stop a render on release that newer values made obsolete."""
        token = self._token
        if self._live_render and self.running and token is not None:
            self._superseded = True
            token.cancel()

    def wait_live(self, timeout=60):
        """Block until re-solves, previews and the render on release are done (tests)."""
        deadline = time.monotonic() + timeout
        while True:
            self.wait_resolve(max(0.1, deadline - time.monotonic()))
            timer = self._settle_timer
            if timer is not None:
                timer.join(max(0.1, deadline - time.monotonic()))
            self.wait(max(0.1, deadline - time.monotonic()))
            if timer is self._settle_timer and not self.running:
                return  # no newer value came meanwhile
            if time.monotonic() > deadline:
                raise TimeoutError("the live re-solve and render did not finish in time")

    # ------------------------------------------------------------------ results
    def use_result_speed(self):
        """Load the result's speed map (px/frame, inside the matte) into the speed layer.

        The paper's advice: start from the speed the assignment produced and edit it.
        Returns the speed layer's new map (px/frame); ValueError before the first run.
        """
        if self.assignment is None:
            raise ValueError("there is no result yet: press Run first")
        speed = self.assignment.speed_map()
        if speed.shape != self.photo.shape[:2]:
            raise ValueError("the result belongs to another photo: press Run first")
        speed = np.where(self.matte() > 0, speed, 0.0).astype(np.float32)
        clipped = float(speed.max()) > SPEED_MAX
        speed = np.minimum(speed, SPEED_MAX)
        self.set_speed(speed)
        self.select("brush", "speed")
        note = f" (clipped at {SPEED_MAX:g})" if clipped else ""
        self.say(
            f"the speed layer now holds the result's speed, up to {speed.max():.2f} "
            f"px/frame{note}: edit it and press Run"
        )
        return self.speed_map()

    def pick_fragment(self, row, col):
        """Show the database fragment given to the target fragment at (row, col).

        What a click on the assignment map does; returns its description (a dict) or
        None where no fragment takes part.
        """
        i = self.map.fragment_at(row, col)
        if i is None:
            return None
        self.map.selected = i
        self.map.redraw()
        return self._show_fragment(i)

    def fragment_info(self, i):
        """What the assignment gave target fragment ``i`` (a dict of plain values).

        :meth:`fluidnb.videodb.Assignment.fragment_info` of the current assignment.
        """
        return self.assignment.fragment_info(i)

    def _show_fragment(self, i):
        info = self.fragment_info(i)
        db = self.assignment.db
        n = db.params.N
        mean = db.mean_images([info["fragment"]])[0]
        picks = np.linspace(0, n - 1, 4).round().astype(int)
        frames = db.fragment_frames([info["fragment"]])[0][picks]
        self.map.strip.value = _strip_png([mean, *frames])
        self.map.strip.layout.display = ""
        v = info["version"]
        flip = "flipped, " if v["flip"] else ""
        dy, dx = info["mean_motion"]
        self.map.caption.value = (
            "<div style='font-size:12px;line-height:1.4'>"
            f"fragment <b>{info['fragment']}</b> from <b>{html.escape(info['clip_name'])}</b> "
            f"({flip}scale {v['scale']:g}, {v['angle']:g}°), frames {info['frames'][0]}–"
            f"{info['frames'][1]}; mean motion ({dy:.2f}, {dx:.2f}) px/frame (dy, dx); "
            f"candidate {info['rank'] + 1} of {self.assignment.candidates.shape[1]}, "
            f"I = {info['score']:.2f}.<br><span style='opacity:0.75'>mean image A, then "
            f"frames {', '.join(str(p) for p in picks)}</span></div>"
        )
        return info

    def _show_assignment(self):
        a = self.assignment
        if a is None or a.target.shape != self.photo.shape[:2]:
            return
        # The energy and its sigma, lambda, rho first: the map never shows under the
        # values of the one before (each widget sends its own message).
        self._show_energy()
        self.map.set_assignment(a)

    def _show_energy(self):
        a = self.assignment
        if a is None:
            self.energy.value = (
                "<div style='opacity:0.75;font-size:12px;line-height:1.4'>The energy of "
                "Eq. (4) after each alpha-expansion sweep appears here after a run, with "
                "ICM's as a reference.</div>"
            )
            return
        s = a.solution
        self.energy.value = _energy_svg(np.asarray(s.energies, float), float(s.icm_energy)) + (
            "<div style='font-size:12px;line-height:1.4'>"
            f"alpha-expansion: E = {s.energy:.5g} after {plural(s.sweeps, 'sweep')} (from the "
            f"{html.escape(s.start)} start) · ICM: {s.icm_energy:.5g}<br>"
            f"σ = {a.params.sigma:.3g}, λ = {a.params.lam:.3g}, ρ = {a.params.rho:.3g}</div>"
        )

    def _show_stats(self):
        self.stats.value = (
            "<div style='font-size:12px;opacity:0.85;margin-top:4px'>"
            f"retrievals <b class='fluidnb-vdb-retrievals'>{self.retrievals}</b> · "
            f"re-solves <b class='fluidnb-vdb-resolves'>{self.resolves}</b> · "
            f"renders <b class='fluidnb-vdb-renders'>{self.renders}</b></div>"
        )

    def state(self):
        """A summary of the app as plain values (for tests and notebooks to record)."""
        a, clip = self.assignment, self.result
        out = {
            "status": self.status,
            "running": self.running,
            "photo": self.photo_name,
            "shape": list(self.photo.shape[:2]),
            "database": self._db_pick.value,
            "tool": self.canvas.tool,
            "layer": self.canvas.layer,
            "retrievals": self.retrievals,
            "resolves": self.resolves,
            "renders": self.renders,
            "matte_pixels": int(self.canvas.get_mask("matte").sum()),
            "strokes": [s.tolist() for s in self.strokes()],
            "speed_pixels": int((self.speed_map() > 0).sum()),
            "speed_max": float(self.speed_map().max()),
            "quiver_segments": self.quiver_segments,
            "params": self.panel.params.to_dict(),
            "frames": None if clip is None else len(clip),
        }
        if a is not None:
            out.update(
                fragments=len(a.target),
                labels=a.labels.tolist(),
                clips=a.db.clip_of(a.fragments).tolist(),
                tables=id(a.tables),
                energy=float(a.solution.energy),
                energies=[float(e) for e in a.energies],
                icm_energy=float(a.solution.icm_energy),
                solved_with={k: float(getattr(a.params, k)) for k in _SOLVE_FIELDS},
                N=a.db.params.N,
            )
        if self.map.selected is not None and a is not None:
            out["selected"] = self.fragment_info(self.map.selected)
        return out

    # ------------------------------------------------------------------ plumbing
    def _on_main(self, fn):
        """Run ``fn`` on the kernel's main thread (ipycanvas drawing is not thread-safe).

        Without a running event loop (a script, the tests), run it here.
        """
        loop = self._loop
        if loop is None or not loop.is_running() or threading.get_ident() == self._main_thread:
            fn()
            return

        def call():
            try:
                fn()
            except Exception:
                traceback.print_exc()

        loop.call_soon_threadsafe(call)

    def close(self):
        """Stop the workers and close the widgets."""
        self._closed = True
        resolves = getattr(self, "_resolves", None)
        if resolves is not None:
            resolves.close()
        with getattr(self, "_settle_lock", threading.Lock()):
            timer = getattr(self, "_settle_timer", None)
            if timer is not None:
                timer.cancel()
        if hasattr(self, "map"):
            self.map.close()
        super().close()


def _strip_png(images):
    """Tiles side by side (float RGB (48, 48, 3) each) as a PNG with transparent gaps."""
    gap = 4
    n = len(images)
    out = np.zeros((_TILE, n * _TILE + (n - 1) * gap, 4), np.uint8)
    for k, img in enumerate(images):
        x = k * (_TILE + gap)
        out[:, x : x + _TILE, :3] = to_uint8(np.clip(resize(img, (_TILE, _TILE)), 0, 1))
        out[:, x : x + _TILE, 3] = 255
    buf = io.BytesIO()
    Image.fromarray(out).save(buf, format="png")
    return buf.getvalue()


def _tick(value):
    """An axis label of at most 6 characters: 7738, 1.72e4, 0.0123 (the SVG's margin)."""
    text = f"{value:.4g}"
    if len(text) > 6:
        text = f"{value:.2e}".replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")
    return text


def _energy_svg(energies, icm, width=280, height=150):
    """A small line plot (inline SVG, theme colours) of the energy after each sweep."""
    left, right, top, bottom = 52, 10, 10, 26
    values = np.append(energies, icm)
    lo, hi = float(values.min()), float(values.max())
    pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
    lo, hi = lo - pad, hi + pad
    n = len(energies)

    def x(i):
        return left + (i / max(n - 1, 1)) * (width - left - right)

    def y(v):
        return top + (hi - v) / (hi - lo) * (height - top - bottom)

    pts = " ".join(f"{x(i):.1f},{y(v):.1f}" for i, v in enumerate(energies))
    dots = "".join(
        f"<circle cx='{x(i):.1f}' cy='{y(v):.1f}' r='3' fill='var(--jp-brand-color1, #1976d2)'/>"
        for i, v in enumerate(energies)
    )
    ticks = "".join(
        f"<text x='{x(i):.1f}' y='{height - 10}' text-anchor='middle'>{i}</text>" for i in range(n)
    )
    axis = "stroke='currentColor' stroke-opacity='0.5'"
    return (
        f"<svg class='fluidnb-vdb-energy-plot' width='{width}' height='{height}' "
        "style='color:var(--jp-ui-font-color1, #333);font-size:10px' "
        f"data-energies='{','.join(f'{e:.6g}' for e in energies)}' data-icm='{icm:.6g}'>"
        f"<line x1='{left}' y1='{top}' x2='{left}' y2='{height - bottom}' {axis}/>"
        f"<line x1='{left}' y1='{height - bottom}' x2='{width - right}' y2='{height - bottom}' "
        f"{axis}/>"
        f"<text x='{left - 4}' y='{y(hi - pad) + 3:.1f}' text-anchor='end' "
        f"fill='currentColor'>{_tick(hi - pad)}</text>"
        f"<text x='{left - 4}' y='{y(lo + pad) + 3:.1f}' text-anchor='end' "
        f"fill='currentColor'>{_tick(lo + pad)}</text>"
        f"<g fill='currentColor' fill-opacity='0.8'>{ticks}</g>"
        f"<text x='{width - right}' y='{height - 1}' text-anchor='end' fill='currentColor' "
        "fill-opacity='0.8'>sweep</text>"
        f"<line x1='{left}' y1='{y(icm):.1f}' x2='{width - right}' y2='{y(icm):.1f}' "
        "stroke='var(--jp-warn-color1, #f57c00)' stroke-width='1.5' stroke-dasharray='5,4'/>"
        f"<text x='{width - right}' y='{y(icm) - 4:.1f}' text-anchor='end' "
        "fill='var(--jp-warn-color1, #f57c00)'>ICM</text>"
        f"<polyline points='{pts}' fill='none' stroke='var(--jp-brand-color1, #1976d2)' "
        "stroke-width='2'/>"
        f"{dots}</svg>"
    )
