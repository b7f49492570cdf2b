r"""The video-database app: mask a photo, draw its flow, paint its speed, watch it move.

Okabe, Anjyo & Onai (2011) animate one still image of fluid from a database of fluid
videos: the photo is cut into 48 x 48 fragments, each gets candidates by appearance
(Eq. 1), an MRF (Eq. 4-6) picks one per fragment, and the frames are rendered from
the chosen fragments' motion. Here every step is a call into :mod:`fluidnb.videodb`
and :mod:`fluidnb.sketch`; the widget only gathers what the user drew and shows what
came back.
"""

from __future__ import annotations

import contextlib
import time

import ipywidgets as W
import numpy as np
from traitlets import Any, Int

from fluidnb import Cancelled, Clip, Progress
from fluidnb.videodb import (
    FRAGMENT,
    STARTER_KINDS,
    AnimateParams,
    assign,
    prefetch,
    prefetch_preview,
    preview_frame,
    render,
)
from fluidnb.videodb.starter import suggest_kind

from ._app import App, _quick_mode
from ._common import hint, plural, row
from ._panel import ParamPanel
from ._photo import PhotoInput, load_photo
from ._player import FramePlayer
from ._videodb_database import DatabaseChoice
from ._videodb_sketch import SPEED_MAX, FlowSketch
from ._videodb_views import MAP_WIDTH, AssignmentMap, energy_html, stats_html

__all__ = ["SPEED_MAX", "VideoDBApp"]

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


def _rendering(params):
    """The values of ``params`` that change the clip but not the assignment."""
    values = params.to_dict()
    return tuple(values.get(k) for k in _RENDER_FIELDS)


# Live previews: one frame, FACTOR times smaller than the photo; their cache of
# difference frames is dropped beyond this many fragments (~9 KB each).
_PREVIEW_FACTOR = 2
_PREVIEW_LEVELS = 1  # a plain weighted blend: a quarter faster, no seam shows at half size
_PREVIEW_CACHE = 4096
#: The re-solve while a slider is held: the full solve on float32 smoothness (its
#: labels those of float64's in all 78 moves measured, ~12 against ~16 ms of CPU).
#: A warm start from the labels shown (``resolve(warm=...)``, ~3 ms) was tried: it
#: converges near where the drag began (after 8 steps it agrees with the full solve
#: on 22-31 % of fragments; in the app a drag left the map 169 of 171 one clip, its
#: energy 43 % above the full solve's), so the preview would not show what the
#: slider's value does.
_HELD_RESOLVE = {"dtype": np.float32}


class VideoDBApp(FlowSketch, App):
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
    (Eq. 6) on log scales at the paper's values and the candidate count K (up to the
    database's size); folded under them the rendering's settings, the rendering
    itself (flow or the paper's) a toggle beside **Render**; ``N`` belongs to the
    database and is shown beside it. **Run** retrieves candidates, solves the MRF and
    renders (:func:`fluidnb.videodb.assign`, :func:`~fluidnb.videodb.render`; a
    starter database is built on the first Run). Then, as the app shell's live
    preview (:class:`App`), every value of a dragged :math:`\sigma`,
    :math:`\lambda` or :math:`\rho` is re-solved from the kept tables
    (:meth:`~fluidnb.videodb.Assignment.resolve`), redraws the assignment map and
    the energy plot and shows a preview frame (:func:`fluidnb.videodb.preview_frame`,
    half size); when the slider is let go and the values rest, the clip is rendered
    (so is a changed rendering setting), its fragments rebuilt ahead while they rest
    (:meth:`warm`), its frames streaming into the player as they are made.

    Views: the clip (play, loop, GIF/MP4); the assignment map (fragments tinted by
    source clip, the assigned motion as arrows, a legend; a click shows the database
    fragment it got); the energy of Eq. (4) per alpha-expansion sweep, ICM's dashed.

    Headless driving (what the tests and notebooks do)::

        app = VideoDBApp("stream", db="water")
        app.paint_matte([[300, 40], [300, 300]], radius=30)  # (row, col) points
        app.draw_stroke([[300, 40], [300, 300]])  # along the flow
        app.paint_speed([[320, 100], [320, 200]], speed=3.0)  # px/frame
        clip = app.run(timeout=300)  # press Run and wait -> fluidnb.Clip
        app.panel.set("sigma", 1e3)  # re-solves from the kept tables (map, preview)
        app.wait_preview()
        app.render_clip(timeout=120)  # press Render and wait -> Clip
        app.use_result_speed()  # the result's speed into the speed layer
        app.pick_fragment(300, 150)  # what a click on the map shows
        app.state()  # counters, energies, labels... as a dict

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
        self._run_version = None  # canvas version the current assignment was made from
        #: Whether new assignments show a preview frame (one frame at half size).
        self.live_preview = True
        self.quiver_segments = 0  #: Arrows of the direction field on the canvas now.
        self.previews = 0  #: Preview frames shown.
        self._preview_cache = (None, {})  # (database, fragment id -> D_t)
        self._previewed = None  # (assignment, rendering values) of the last preview
        self._mapped, self._mapped_at = None, 0.0  # the assignment the map shows, since
        self._rough = None  # the assignment solved in float32 while a slider was held
        #: Longest wait (s) for the page to draw a preview frame before the map follows.
        self.map_pause = 0.3
        #: Longest seconds the map lags a drag that never pauses.
        self.map_every = 0.6

        name = photo if isinstance(photo, str) and photo in PHOTOS else None
        self.photo, self.photo_alpha = self._load_photo(photo, matte)
        self.photo_name = name or "upload"

        # ---------------------------------------------------------------- inputs
        self._photo = PhotoInput(PHOTOS, name or "upload", on_photo=self.set_photo, say=self.say)
        self._photo_pick, self._upload = self._photo.menu, self._photo.upload
        self.databases = DatabaseChoice(db, default=PHOTOS.get(name, "water"), quick=self.quick)
        self._db_pick, self._db_path = self.databases.pick, self.databases.path
        self._n_label = self.databases.label

        sketch_tools = self._make_sketch_tools()
        canvas = self._make_canvas()
        if params is None:
            params = AnimateParams.for_kind(self.databases.kind)
        self._fragments = None  # the chosen database's fragment count, once known
        # The candidate slider ends at the database's size (more are refused).
        panel = ParamPanel(params, exclude=_HIDDEN, groups=GROUPS, check=self._db_check)

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
        # The rendering (AnimateParams.rendering, when the library has it) as a toggle.
        self._rendering = panel.toggle("rendering") if "rendering" in panel.controls else None
        self.map = AssignmentMap()
        self.map.on_pick = self._show_fragment
        self.energy = W.HTML()
        self.stats = W.HTML()
        for wid, cls in [
            (self._render_button, "fluidnb-vdb-render"),
            (self._use_speed_button, "fluidnb-vdb-use-speed"),
            (self.energy, "fluidnb-vdb-energy"),
            (self.stats, "fluidnb-vdb-stats"),
        ]:
            wid.add_class(cls)
        if self._rendering is not None:
            self._rendering.add_class("fluidnb-vdb-rendering")

        # One layout for every app (App): the canvas and its tools | the clip and the
        # assignment map | the photo, the database and the compact panel (σ, λ, ρ, K
        # open; the rendering folded), so the map changes beside σ as it moves.
        super().__init__(
            panel=panel,
            run=self._run_task,
            preview=self._preview,
            canvas=canvas,
            player=FramePlayer(display_width=MAP_WIDTH),
            title="Fluid animation from one image — Okabe, Anjyo & Onai (video database)",
            inputs=[
                self._photo,
                self.databases,
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
            canvas_tools=sketch_tools,
        )
        self.views = (
            self.titled("clip", self.player, margin="0 0 0.4em 0"),
            self.titled("assignment (click a fragment)", self.map, margin="0"),
        )
        self.views_width = f"{MAP_WIDTH + 8}px"
        self.player.view.tell_drawn = True  # the map waits for the preview's picture
        self.add_class("fluidnb-vdb-app")
        self.settle = 0.2  # the map and preview frame show the values; the clip at rest

        # ---------------------------------------------------------------- wiring
        self._db_pick.on_pick(self._db_picked)
        self._db_path.observe(lambda _: self._show_n(), "value")
        self._render_button.on_click(lambda _: self.start_render())
        self._use_speed_button.on_click(lambda _: self.use_result_speed())
        self.panel.observe(self._panel_changed, "params")
        # (re-solves are counted with the map: _show_assignment)
        self.observe(lambda _: self._show_stats(), ["retrievals", "renders"])
        self._wire_canvas(canvas)
        self.map.set_photo(self.photo)
        self._show_n()
        self._show_energy()
        self._show_stats()

    # ------------------------------------------------------------------ photo
    def _load_photo(self, photo, matte=None):
        try:
            image, alpha = load_photo(
                photo, matte, samples=PHOTOS, size=self.size, min_side=FRAGMENT
            )
        except ValueError as exc:
            if "at least" not in str(exc):
                raise
            raise ValueError(f"{exc} (one {FRAGMENT} x {FRAGMENT} fragment)") from None
        return np.ascontiguousarray(image, np.float32), alpha

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
        self._photo.shown(name)
        if name in PHOTOS and self._db_pick.value in STARTER_KINDS:
            self.set_database(PHOTOS[name])
        h, w = image.shape[:2]
        if name != "upload":
            self.say(f"photo: the {name} photo, {w} x {h} pixels; paint its matte")
            return True
        # An upload keeps the database chosen before: say which, and what the photo
        # looks like (fluidnb.videodb.suggest_kind, a first guess from its colours).
        kind, why = suggest_kind(image, alpha)
        using = self.databases.name
        advice = (
            f"it looks like {kind} ({why}): choose the {kind} database"
            if kind != self.databases.kind
            else f"it looks like {kind} too ({why})"
        )
        self.say(f"photo: your upload, {w} x {h} pixels; using {using}: {advice}; paint its matte")
        return True

    def _forget_result(self):
        self._supersede()
        self.assignment = None
        self._base = None
        self._run_version = None
        self._render_button.disabled = True
        self._use_speed_button.disabled = True
        self._show_energy()

    # ------------------------------------------------------------------ database
    def set_database(self, db):
        """Choose the database: a starter kind, a folder, or an opened database."""
        self.databases.set(db)
        self._show_n()

    def _db_picked(self, choice):
        tau = AnimateParams.for_kind(self.databases.kind).tau
        if "tau" in self.panel.controls and self.panel.params.tau != tau:
            self.panel.set("tau", tau)  # fire and smoke move their outline (Sec. 6)
        self._show_n()
        if self.assignment is not None:
            self.say("the database changed: press Run for a new retrieval")

    def database(self, progress=None):
        """The chosen database, opened (a starter one is built on first use, cached)."""
        db = self.databases.opened(progress)
        self._show_n()
        return db

    def _db_check(self, params):
        n = self._fragments
        if n is not None and params.candidates > n:
            raise ValueError(
                f"candidates must be <= the database's {n} fragments, got {params.candidates}"
            )

    def _show_n(self):
        """The candidate slider ends at the open database's size."""
        db = self.databases.known()
        fragments = None if db is None else db.n_fragments
        if fragments != self._fragments and hasattr(self, "panel"):
            self._fragments = fragments
            self.panel.follow()

    # ------------------------------------------------------------------ drawing
    def _drawing_changed(self, change):
        self._update_quiver()
        if self._run_version is not None and change["new"] != self._run_version:
            self._run_version = None
            if not self.running:
                self.say("the drawing changed since the run: press Run for a new retrieval")

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
        return (self._photo, self._db_pick, self._db_path, self._load_button)

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

        return self.start_task(
            task, self._ran, message="retrieving candidates…", busy=self._busy_widgets
        )

    def _rest_busy(self):
        return self._busy_widgets

    def _run_task(self, params, progress, inputs=None, image=None, version=None):
        matte, strokes, speed = self._inputs() if inputs is None else inputs
        image = self.photo if image is None else image
        # A starter database built on first use takes most of the run (minutes in full
        # size): give it most of the bar, so the bar does not creep in its first 15 %.
        building = not self.databases.ready()
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
        self._render_button.disabled = False
        self._use_speed_button.disabled = False
        self._show_map_soon()
        a = self.assignment
        # A slider moved during the run gets its re-solve; otherwise the preview worker
        # fills the preview's cache, so the first drag shows its preview at once.
        self.request_preview()
        note = a.stillness_note()
        return (
            f"done in {seconds:.1f} s: {plural(len(a.target), 'fragment')}, K = "
            f"{a.candidates.shape[1]}, E = {a.solution.energy:.4g} after "
            f"{plural(a.solution.sweeps, 'sweep')} (ICM {a.solution.icm_energy:.4g}), "
            f"{plural(len(clip), 'frame')}" + ("" if note is None else f"; {note}")
        )

    def start_render(self):
        """Render the clip of the current assignment in the worker (what **Render** does)."""
        if self.running:
            return False
        if self.assignment is None:
            self.say("nothing to render yet: press Run first", "error")
            return False
        return self.start_task(
            self._render_task, self._rendered, message="rendering…", busy=self._busy_widgets
        )

    def _render_task(self, params, progress):
        self.wait_preview()  # the re-solve of the latest values
        a = self.assignment
        if a is not None and a is self._rough:  # (a held slider's, never let go of)
            a = self._base.resolve(**{k: getattr(a.params, k) for k in _SOLVE_FIELDS})
            self.assignment, self._rough = a, None
            self.resolves += 1
            self._show_map_soon()
        # The assignment's own sigma, lambda, rho (they made it); the panel's rendering
        # settings.
        params = params.replace(**{k: getattr(a.params, k) for k in _SOLVE_FIELDS})
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
            self.player.play(True)

    def _rendered(self, clip, seconds):
        self._show_clip(clip, seconds)
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
        base = self._base
        if base is not None and any(
            getattr(change["new"], k) != getattr(base.params, k) for k in _RETRIEVAL_FIELDS
        ):
            self.say("candidates changed: press Run for a new retrieval")

    def request_resolve(self):
        """Re-solve for the panel's sigma, lambda, rho in the background (latest wins).

        The app shell's live preview (:meth:`App.request_preview`): the assignment map
        and a preview frame follow; the clip once the values rest.
        """
        self.request_preview()

    def wait_resolve(self, timeout=30):
        """Block until every re-solve asked for so far, and its preview, is done (tests)."""
        self.wait_preview(timeout)

    def _preview(self, params):
        """Re-solve for the values from the kept tables: the map, then one preview frame.

        :meth:`~fluidnb.videodb.Assignment.resolve` (no new retrieval), the map
        redrawn, and :func:`fluidnb.videodb.preview_frame` (one frame at half size)
        for the player; None when σ, λ, ρ are those of the assignment shown (a
        rendering setting changed: its clip comes at rest).
        """
        base, current = self._base, self.assignment
        if base is None or current is None:
            return None
        wanted = {k: getattr(params, k) for k in _SOLVE_FIELDS}
        rough = current is self._rough and not self.held  # let go: the full solve now
        if not rough and all(getattr(current.params, k) == v for k, v in wanted.items()):
            # A second request for the values a preview already showed (it read them
            # while their own request still waited): nothing changed, keep its note.
            shown = self._previewed
            if shown is not None and shown[0] is current and shown[1] == _rendering(params):
                self._follow_map()  # (its own preview's gave way to this request)
                return None
            if self.live_preview and not self._clip_is_current():
                return self._preview_clip(current, params, "a rendering setting changed")
            self._follow_map()
            return None
        started = time.perf_counter()
        # While a slider is held: the full solve in float32 (_HELD_RESOLVE); the
        # float64 one, the reference, once it is let go.
        held = self.held and self.live_preview
        new = base.resolve(**wanted, **(_HELD_RESOLVE if held else {}))
        if self._base is not base:  # a run replaced the tables meanwhile
            return None
        solved = time.perf_counter() - started
        changed = int((new.labels != current.labels).sum())
        self.assignment = new
        self._rough = new if held else None
        self.resolves += 1
        how = "in float32" if held else "from the kept tables"
        note = (
            f"re-solved {how} in {solved:.2f} s: {changed} of "
            f"{plural(len(new.labels), 'fragment')} changed"
        )
        if not self.live_preview:
            self._show_map_soon()
            self.say(note)
            return None
        # The map follows once the frame is on its way (after_preview).
        return self._preview_clip(new, params, note)

    def released(self):
        """The slider let go: the float32 assignment is solved in float64 (a preview)."""
        if self._rough is not None and self._rough is self.assignment:
            self.request_preview()

    def after_preview(self, params):
        """The assignment map, the energy plot and the counters, after the preview frame."""
        self._follow_map()

    def _follow_map(self):
        """Show the current assignment in the map, the energy plot and the counters.

        In a kernel, first the page draws the preview frame (it says so:
        :meth:`FramePlayer.wait_drawn`; at most :attr:`map_pause` seconds): sent right
        behind the frame, the map's picture and marks (36 KB, ~6 ms of the kernel's
        thread), the energy plot and the counters were handled by the page before the
        frame's decoded picture, and the frame waited (decode+draw 18-21 ms quiet, 40
        at load 6). A newer value arriving meanwhile skips the map: that value's
        preview comes first, and its map after it -- but during a long drag the map is
        at most :attr:`map_every` seconds behind (still after its own frame is drawn:
        under load the page decodes slowly, and a map sent at once was drawn first).
        """
        a = self.assignment
        if a is None or self._mapped is a or self._closed:
            return
        deadline = time.monotonic() + (self.map_pause if self.in_kernel else 0.0)
        while time.monotonic() < deadline:
            if self.preview_pending() and time.monotonic() - self._mapped_at < self.map_every:
                return
            if self.preview_player.wait_drawn(0.005):
                break
        self._show_map_soon()

    def _show_map_soon(self):
        """The map, energy and counters of the current assignment, on the kernel's thread."""
        self._mapped, self._mapped_at = self.assignment, time.monotonic()
        self.on_main(self._show_assignment)  # (ipycanvas drawing is not thread-safe)

    def _preview_clip(self, a, params, note):
        """One frame of ``a``'s clip at half size (:func:`fluidnb.videodb.preview_frame`)."""
        cache = self._preview_cache_for(a)
        picture = preview_frame(
            a, params, factor=_PREVIEW_FACTOR, levels=_PREVIEW_LEVELS, cache=cache
        )
        self.previews += 1
        self._previewed = (a, _rendering(params))
        caption = (
            f"preview: σ = {a.params.sigma:.3g}, λ = {a.params.lam:.3g}, ρ = {a.params.rho:.3g}"
        )
        meta = {"method": "videodb", "preview": True, "note": note, "caption": caption}
        meta["smooth"] = True  # half size, enlarged on screen: a photo, smoothed
        return Clip(picture[None], fps=24.0, metadata=meta)

    def warm(self, params):
        """While the values rest: the fragments the render will need, rebuilt ahead.

        After a run, the candidates' mean images for the first drag's preview
        (:func:`fluidnb.videodb.prefetch_preview`, 0.3-0.5 s once; a re-solve's
        preview then reads one frame per new fragment); after a re-solve, the new
        fragments' frames (:func:`fluidnb.videodb.prefetch`), so the render at rest
        starts with them. A value arriving meanwhile stops either between clips.
        """
        a = self.assignment
        if a is None or not self.live_preview:
            return
        stop = self._stop_when_moved(a)
        # Stopped by a newer value, or settings the render will refuse (and say so).
        with contextlib.suppress(Cancelled, ValueError):
            prefetch_preview(a, self._preview_cache_for(a, fill=True), progress=stop)
            if a is not self._base:
                prefetch(a, params, progress=stop)

    def _stop_when_moved(self, a):
        """A progress callback that stops background work for ``a`` once it is stale.

        Raises :class:`Cancelled` when the app closes, another assignment replaces
        ``a``, or σ, λ, ρ no longer match it.
        """

        def moved(fraction, message):
            if self._closed or self.assignment is not a or self._values_changed():
                raise Cancelled

        return moved

    def _preview_cache_for(self, a, fill=False):
        """The difference frames kept for previews of ``a``'s database.

        With ``fill``, those of ``a``'s fragments are made now (while the values rest);
        a preview fills the cache itself as it makes its frame (filling first made the
        frame twice: a third of a preview's time).
        """
        db, cache = self._preview_cache
        if db is not a.db or len(cache) > _PREVIEW_CACHE:
            cache = {}
            self._preview_cache = (a.db, cache)
        if fill and not set(a.fragments.tolist()) <= cache.keys():
            preview_frame(a, factor=_PREVIEW_FACTOR, levels=_PREVIEW_LEVELS, cache=cache)
        return cache

    def _values_changed(self):
        """Whether the panel's σ, λ, ρ differ from the current assignment's."""
        a, params = self.assignment, self.panel.params
        return a is not None and any(
            getattr(params, k) != getattr(a.params, k) for k in _SOLVE_FIELDS
        )

    def _clip_is_current(self):
        """Whether the player's clip is the current assignment with the panel's rendering."""
        a, animation = self.assignment, self.animation
        if a is None or animation is None or animation.assignment is not a:
            return False
        made, wanted = animation.clip.metadata["params"], self.panel.params.to_dict()
        return all(made.get(k) == wanted[k] for k in _RENDER_FIELDS if k in wanted)

    def rest_task(self):
        """Once σ, λ, ρ or a rendering setting rest: render the clip of the assignment."""
        if self._base is None or self.assignment is None:
            return None  # before the first Run there is nothing to render
        self.wait_preview()
        if self._clip_is_current() or self._values_changed():
            return None
        return self._render_task, self._rendered, "rendering the clip…"

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
        self.map.show_fragment(info, self.assignment)
        return info

    def _show_assignment(self):
        a = self.assignment
        if a is None or a.target.shape != self.photo.shape[:2]:
            return
        # The energy and its sigma, lambda, rho first: the map never shows under the
        # values of the one before (each widget sends its own message).
        self._show_energy()
        self._show_stats()
        self.map.set_assignment(a)

    def _show_energy(self):
        self.energy.value = energy_html(self.assignment)

    def _show_stats(self):
        self.stats.value = stats_html(self.retrievals, self.resolves, self.renders)

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

    def close(self):
        """Stop the workers and close the widgets."""
        self._closed = True
        if hasattr(self, "map"):
            self.map.close()
        super().close()
