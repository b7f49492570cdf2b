"""The app shell every method's app is made of: canvas, panel, run, progress, player."""

from __future__ import annotations

import asyncio
import html
import os
import sys
import threading
import time
import traceback
from pathlib import Path

import anywidget
import ipywidgets as W
from ipywidgets.widgets.trait_types import TypedTuple
from traitlets import Bool, Instance, Int, Unicode, observe

from fluidnb import Cancelled, CancelToken, Clip
from fluidnb._threads import blas_single_threaded

from ._canvas import DrawingCanvas
from ._player import FramePlayer

__all__ = ["App", "LatestWins"]

#: The slots an app fills with sequences of widgets (:attr:`App.canvas` holds one).
SLOTS = ("inputs", "controls", "canvas_tools", "aside", "views")


def _quick_mode():
    """Whether ``FLUIDNB_QUICK`` is set (not "" or "0"): small sizes, blocking runs.

    CI sets it to run every lesson top to bottom in a few minutes.
    """
    return os.environ.get("FLUIDNB_QUICK", "") not in ("", "0")


def _in_kernel():
    """Whether this runs in a Jupyter kernel (not a script, a test or a plain shell)."""
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover - IPython comes with ipywidgets
        return False
    shell = get_ipython()
    return shell is not None and getattr(shell, "kernel", None) is not None


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


#: The kernel's GIL switch interval while an app is open, seconds (Python's default: 5 ms).
GIL_SWITCH = 0.001


def _prompt_gil_handover():
    """Have the kernel's threads hand the GIL over within :data:`GIL_SWITCH` seconds.

    A slider's value reaches the kernel's main thread, which wakes the preview's worker
    and goes on with the message (ipywidgets' echo, the kernel's replies); the worker
    waited up to Python's 5 ms switch interval for the GIL, at every hand-over: before
    it began, and while it computed beside the main thread's messages and drawing (and
    the main thread, for the next value, beside the worker's Python). The interval is
    the interpreter's, so only shortened, in a kernel with an app, never lengthened.
    """
    if sys.getswitchinterval() > GIL_SWITCH:
        sys.setswitchinterval(GIL_SWITCH)


class LatestWins:
    """A worker thread that runs ``work()`` when asked, the latest request winning.

    :meth:`request` returns at once; the worker then runs ``work()`` once for every
    request made so far (it reads the latest state itself, so requests made while it
    works are served together by one more run), at most once every ``interval()``
    seconds. ``work``'s ValueErrors are shown with ``say`` as plain messages, other
    errors as ``"<what> failed: ..."``; none reaches the kernel. The apps' live
    previews and the video-database app's re-solves run on it.

    Parameters
    ----------
    work : callable
        ``work()``, called in the worker thread.
    say : callable
        ``say(text, kind)``: the app's status line.
    interval : callable
        ``interval() -> float``: least seconds between two runs (read each time).
    name : str
        The thread's name, and what ``work`` does in messages ("preview").
    """

    def __init__(self, work, *, say, interval, name):
        self._work = work
        self._say = say
        self._interval = interval
        self.name = name
        self._lock = threading.Condition()
        self._requested = 0
        self._serving = 0  # requests the run going on serves
        self._done = 0
        self._thread = None
        self._closed = False

    def request(self):
        """Ask for a run; returns at once (the worker thread starts on the first)."""
        with self._lock:
            if self._closed:
                return
            self._requested += 1
            self._lock.notify_all()
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._loop, name=f"fluidnb-{self.name}", daemon=True
                )
                self._thread.start()

    def pending(self):
        """Whether a request waits that no run has started serving yet."""
        with self._lock:
            return self._requested > self._serving

    def skip_pending(self):
        """Count every request so far as served (their runs are obsolete)."""
        with self._lock:
            self._serving = self._done = self._requested
            self._lock.notify_all()

    def wait(self, timeout=30):
        """Block until every run requested so far is done; TimeoutError after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        with self._lock:
            target = self._requested
            while self._done < target:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"the {self.name} did not finish in time")
                self._lock.wait(left)

    def close(self):
        """Stop the worker thread (after the run going on, if any)."""
        with self._lock:
            self._closed = True
            self._lock.notify_all()

    def _loop(self):
        while True:
            with self._lock:
                while self._done >= self._requested and not self._closed:
                    self._lock.wait()
                if self._closed:
                    return
                # Everything requested so far is served by this one run, which reads
                # the latest parameters and drawing: the latest state wins.
                target = self._serving = self._requested
            started = time.monotonic()
            try:
                self._work()
            except ValueError as exc:
                self._say(str(exc), "error")
            except Exception as exc:  # shown, never raised into the kernel's thread
                self._say(f"{self.name} failed: {type(exc).__name__}: {exc}", "error")
                traceback.print_exc()
            with self._lock:
                self._done = max(self._done, target)
                self._lock.notify_all()
            time.sleep(max(0.0, self._interval() - (time.monotonic() - started)))


class _LiveChannel(anywidget.AnyWidget):
    """Hidden in every app: :attr:`held` is True while a slider of the app is held.

    The kernel is told a dragged slider's values but not the mouse; this tells it
    (``_live.js``: one message on the press, one on the release), so a render waits
    for the hand to let go.
    """

    _esm = (Path(__file__).resolve().parent / "_live.js").read_text(encoding="utf-8")
    #: Whether the user holds a slider of the app (pressed, not yet released).
    held = Bool(False).tag(sync=True)


def _players(widgets):
    """Every FramePlayer among ``widgets`` and inside them."""
    for widget in widgets:
        if isinstance(widget, FramePlayer):
            yield widget
        else:
            yield from _players(getattr(widget, "children", ()))


class App(W.VBox):
    """A drawing canvas, a parameter panel, a run button with progress and a player.

    The app holds no algorithm: it calls the method's library functions through the
    two callables it is given, with plain arrays and a parameter object.

    A method's app is laid out in named *slots*, filled by keyword at construction
    (or later, by setting the attribute of the same name: the layout follows)::

        title
        Run  Cancel  progress bar ............ status line
        ┌──────────────┬──────────────────┬──────────────────────┐
        │ canvas       │ views            │ inputs               │
        │ canvas_tools │ (the player      │ panel (first group;  │
        │              │  first, then the │  the others folded)  │
        │              │  app's others)   │ controls             │
        └──────────────┴──────────────────┴──────────────────────┘
        aside: under the three columns (wide tables)

    What a person draws on and what it makes sit side by side, with the run bar and
    the status line above them: at 1400 x 900 the canvas, the player's picture, Run
    and the status are all in view at once. The columns wrap under each other on a
    narrow page; empty slots take no room; :attr:`drawing_width`,
    :attr:`views_width` and :attr:`controls_width` fix a column's width. The
    parameters' groups are the panel's (:class:`ParamPanel` ``groups=``). The status
    line is written with :meth:`say` (its text is :attr:`status`). An app never
    rebuilds this layout itself, nor reaches into these boxes: it sets its slots.

    Parameters
    ----------
    panel : ParamPanel
        The method's parameters.
    run : callable
        ``run(params, progress) -> Clip``: the full computation, started by the Run
        button in a worker thread (the kernel stays responsive); ``progress`` is the
        library's progress callable, which raises :class:`fluidnb.Cancelled` after
        Cancel.
    preview : callable, optional
        ``preview(params) -> Clip``: a cheap version recomputed live (the latest state
        wins) whenever a parameter or the drawing changes, also while a slider is
        held; ``None`` means nothing to show for this change.
    run_on_rest : bool, optional
        Whether a parameter change starts the full run by itself once the sliders
        rest: released (the page tells the kernel, see :class:`_LiveChannel`) and
        unchanged for :attr:`settle` seconds -- "a cheap preview while the slider
        moves, the full result when it rests". A newer change stops that run (quietly)
        and previews again. :meth:`rest_task` says what runs (the Run button's task
        by default). Default: on in a notebook kernel, off in scripts and tests (which
        press Run themselves).
    canvas : DrawingCanvas, optional
        Where the user draws (slot :attr:`canvas`); its changes trigger the preview.
    title : str
        A heading shown above the app.
    inputs, controls, canvas_tools, aside : sequence of widgets
        The slots of the same names (see :attr:`inputs` and the others).
    views : sequence of widgets, optional
        The result views (slot :attr:`views`), one under the other beside the
        canvas; default: the player alone.
    player : FramePlayer, optional
        The player the Run button's clip goes to (:attr:`player`), for a player of
        another size or export folder; default ``FramePlayer()``.
    min_interval : float
        Least seconds between two previews (0: as fast as they are made; the latest
        state wins anyway).
    seed : int, optional
        Give the app a random seed: the trait :attr:`seed`, shown in
        :attr:`seed_box` (which the app places in a slot); a new seed asks for a
        new preview.
    """

    #: The status line's text (errors appear here in plain words; see :meth:`say`).
    status = Unicode("")
    #: Slot: the drawing canvas (a DrawingCanvas or None); set another to swap it in.
    canvas = Instance(DrawingCanvas, allow_none=True)
    #: Slot: widgets under the canvas, in its column (the app's own drawing tools).
    canvas_tools = TypedTuple(trait=Instance(W.Widget))
    #: Slot: widgets above the parameter panel: what a run works on (photo, size...).
    inputs = TypedTuple(trait=Instance(W.Widget))
    #: Slot: widgets under the parameter panel (more actions, hints).
    controls = TypedTuple(trait=Instance(W.Widget))
    #: Slot: widgets under the three columns (a wide table of results, say).
    aside = TypedTuple(trait=Instance(W.Widget))
    #: Slot: the result views, one under the other beside the canvas (the player first).
    views = TypedTuple(trait=Instance(W.Widget))
    #: CSS widths of the canvas, views and controls columns ("": as wide as their
    #: widgets). A fixed width makes long rows and messages wrap instead of widening
    #: the column (which would push the next column under the others).
    drawing_width = Unicode("")
    views_width = Unicode("")  #: see :attr:`drawing_width`
    controls_width = Unicode("330px")  #: see :attr:`drawing_width`
    #: The random seed of the preview and the run (apps made with ``seed=``).
    seed = Int(0)

    def __init__(
        self,
        *,
        panel,
        run,
        preview=None,
        canvas=None,
        title="",
        inputs=(),
        controls=(),
        canvas_tools=(),
        aside=(),
        views=None,
        player=None,
        min_interval=0.0,
        seed=None,
        run_on_rest=None,
    ):
        self.panel = panel
        self._run_fn = run
        self._preview_fn = preview
        self.min_interval = float(min_interval)
        #: Whether the full result follows by itself when the values rest.
        self.run_on_rest = _in_kernel() if run_on_rest is None else bool(run_on_rest)
        #: Seconds the values must rest, the sliders released, before the full result.
        self.settle = 0.25
        self._settle_timer = None
        self._settle_lock = threading.Lock()
        self._rest_wanted = False  # a change waits for its full result
        self._rest_running = False  # the running task was started by a rest
        self._superseded = False  # ... and newer values made it obsolete
        self._preview_refused = False  # the last preview was refused (inputs not ready)
        self._changed_at = None  # ms since the epoch of the last change heard
        #: Seconds without a newer value after a preview before :meth:`warm` runs.
        self.warm_after = 0.08
        self._warm_only = False  # the next preview run only warms
        self._warm_pending = False  # a warm-up waits for the run going on
        self._warm_on_release = False  # a warm-up waits for the slider's release
        self._task_active = False  # a task's worker has not finished yet
        self._live = _LiveChannel()
        self._live.observe(self._held_changed, "held")
        self.player = FramePlayer() if player is None else player
        self.player.add_class("fluidnb-app-player")  # the one Run fills
        #: The player the live previews go to (the app's player unless the app says).
        self.preview_player = self.player
        self.player.add_class("fluidnb-preview-player")
        self.result = None  #: The last full run's Clip.
        self._token = None
        self._thread = None
        self._busy = ()  # widgets start_task disables while a task runs
        self._previews = LatestWins(
            self._preview_once, say=self.say, interval=lambda: self.min_interval, name="preview"
        )
        self._closed = False
        # ipycanvas drawing from a worker goes through the kernel's loop (on_main).
        self._loop = _kernel_loop()
        if self._loop is not None:
            _prompt_gil_handover()
        self._main_thread = threading.get_ident()
        self._tasks_started = 0  # a preview begun before a task started is stale
        self._watched = set()  # ids of the players whose exports the status line reports

        self._run_button = W.Button(description="Run", icon="play", button_style="primary")
        self._cancel_button = W.Button(description="Cancel", icon="stop", disabled=True)
        self.progress = W.FloatProgress(value=0, min=0, max=1, layout=W.Layout(width="220px"))
        self._progress_text = W.Label()
        self._status = W.HTML(layout=W.Layout(min_height="1.6em"))
        for wid, cls in [
            (self._run_button, "fluidnb-run"),
            (self._cancel_button, "fluidnb-cancel"),
            (self.progress, "fluidnb-progress"),
            (self._status, "fluidnb-status"),
        ]:
            wid.add_class(cls)
        self._run_button.on_click(lambda _: self.start())
        self._cancel_button.on_click(lambda _: self.cancel())
        panel.observe(self._params_changed, "params")
        panel.observe(self._validity_changed, "valid")
        # The slots (before the boxes exist: nothing is laid out twice).
        self.canvas = canvas
        self.inputs = tuple(inputs)
        self.controls = tuple(controls)
        self.canvas_tools = tuple(canvas_tools)
        self.aside = tuple(aside)
        self.views = (self.player,) if views is None else tuple(views)

        # The boxes the slots are shown in (see _layout).
        self._runbar = W.HBox(
            [self._run_button, self._cancel_button, self.progress, self._progress_text],
            layout=W.Layout(align_items="center", flex="0 0 auto"),
        )
        self._status.layout.margin = "0 0 0 1em"
        self._status.layout.flex = "1 1 320px"
        header = W.HBox(
            [self._runbar, self._status],
            layout=W.Layout(flex_flow="row wrap", align_items="center", margin="0 0 0.3em 0"),
        )
        header.add_class("fluidnb-app-runbar")
        self._drawing_column = W.VBox(layout=W.Layout(margin="0 1em 0.5em 0"))
        self._views_column = W.VBox(layout=W.Layout(margin="0 1em 0.5em 0"))
        self._controls_column = W.VBox(layout=W.Layout(margin="0 0 0.5em 0"))
        self._columns = W.HBox(layout=W.Layout(flex_flow="row wrap", align_items="flex-start"))
        self._aside_row = W.VBox()
        for box, cls in [
            (self._columns, "fluidnb-app-columns"),
            (self._drawing_column, "fluidnb-app-drawing"),
            (self._views_column, "fluidnb-app-views"),
            (self._controls_column, "fluidnb-app-controls"),
            (self._aside_row, "fluidnb-app-aside"),
        ]:
            box.add_class(cls)
        heading = []
        if title:
            heading.append(W.HTML(f"<h3 style='margin:0.1em 0 0.3em 0'>{html.escape(title)}</h3>"))
        super().__init__([*heading, header, self._columns, self._aside_row, self._live])
        self.add_class("fluidnb-app")
        if seed is not None:
            self.seed = int(seed)
            #: The seed's input box (apps made with ``seed=``; None otherwise).
            self.seed_box = W.BoundedIntText(
                value=self.seed,
                min=0,
                max=2**31 - 1,
                description="seed",
                style={"description_width": "40px"},
                layout=W.Layout(width="170px"),
            )
            self.seed_box.add_class("fluidnb-seed")
            W.link((self.seed_box, "value"), (self, "seed"))
            self.observe(lambda _: self._changed(), "seed")
        else:
            self.seed_box = None
        self._layout()
        if preview is not None:
            self.request_preview()

    # ------------------------------------------------------------------ layout
    @observe("canvas")
    def _canvas_changed(self, change):
        old, new = change["old"], change["new"]
        if old is not None:
            old.unobserve(self._drawing_changed, "version")
        if new is not None:
            new.observe(self._drawing_changed, "version")
        if self._layout_ready():
            self._layout()
            self.request_preview()

    @observe(*SLOTS, "drawing_width", "views_width", "controls_width")
    def _slots_changed(self, change):
        if self._layout_ready():
            self._layout()

    def _layout_ready(self):
        # Slots set before App.__init__ built the boxes are laid out by __init__.
        return "_aside_row" in self.__dict__

    def _layout(self):
        """Put every slot's widgets in their boxes (empty slots take no room)."""
        drawing = [self.canvas] if self.canvas is not None else []
        drawing += self.canvas_tools
        columns = []
        controls = (*self.inputs, self.panel, *self.controls)
        # The canvas column as wide as the canvas: its tool rows wrap under it rather
        # than widen the column (which would push the result under the canvas).
        drawing_width = self.drawing_width
        if not drawing_width and self.canvas is not None:
            drawing_width = f"{max(self.canvas.canvas.width, 300)}px"
        for box, widgets, width in (
            (self._drawing_column, drawing, drawing_width),
            (self._views_column, self.views, self.views_width),
            (self._controls_column, controls, self.controls_width),
        ):
            box.children = tuple(widgets)
            box.layout.width = width or None
            if widgets:
                columns.append(box)
        self._columns.children = columns
        self._aside_row.children = self.aside
        for player in _players(self.views):
            if id(player) not in self._watched:
                self._watched.add(id(player))
                player.observe(self._exported, "exported")

    def _exported(self, change):
        if change["new"]:
            self.say(f"saved {change['new']}", "ok")

    @staticmethod
    def titled(heading, *widgets, margin="0 1.5em 0.6em 0"):
        """A column of ``widgets`` under a bold ``heading``: a view for :attr:`views`."""
        return W.VBox(
            [W.HTML(f"<b>{html.escape(heading)}</b>"), *widgets], layout=W.Layout(margin=margin)
        )

    def _drawing_changed(self, change):
        self._changed_at = time.time() * 1000
        self.request_preview()

    # ------------------------------------------------------------------ status
    def say(self, text, kind="info"):
        """Show a message in the status line (kind: info, ok, error)."""
        color = {
            "error": "var(--jp-error-color1, #d32f2f)",
            "ok": "var(--jp-success-color1, #388e3c)",
        }.get(kind, "inherit")
        self.status = text
        self._status.value = f"<span style='color:{color}'>{html.escape(text)}</span>"

    def _validity_changed(self, change):
        self._run_button.disabled = not change["new"] or self.running
        if not change["new"]:
            self.say(f"Fix the parameters: {self.panel.message}", "error")
        else:
            self.say("")

    def _params_changed(self, change):
        self._changed()

    # ------------------------------------------------------------------ live
    def _changed(self):
        """A parameter (or the seed) changed: preview now, the full result at rest."""
        self._changed_at = time.time() * 1000  # when the kernel heard it (a preview's timeline)
        self._supersede()
        self.request_preview()
        if self.run_on_rest:
            self._rest_wanted = True
            self._schedule_rest()

    @property
    def held(self):
        """Whether the user holds one of the app's sliders (the page says so)."""
        return self._live.held

    def _held_changed(self, change):
        if change["new"]:
            return
        self.released()
        with self._settle_lock:
            warm, self._warm_on_release = self._warm_on_release, False
        if warm:
            self._request_warm()  # the warm-up skipped while the slider was held
        if self._rest_wanted:
            self._schedule_rest()  # let go: the full result once the values rest

    def released(self):
        """What the app does when the user lets go of its slider (before the rest's wait).

        Nothing by default; the video-database app solves in full what it previewed
        with a warm start while the slider was held.
        """

    def _schedule_rest(self):
        """Start :meth:`rest_task` once the values rest for :attr:`settle` seconds.

        Every new value restarts the wait; while a slider is held nothing starts
        (its release schedules it again).
        """
        with self._settle_lock:
            if self._settle_timer is not None:
                self._settle_timer.cancel()
            if self._closed:
                return
            self._settle_timer = threading.Timer(self.settle, self._rested)
            self._settle_timer.daemon = True
            self._settle_timer.start()

    def _rested(self):
        if self._closed or self.held or not self._rest_wanted:
            return
        if self.running:
            return  # the task going on schedules it again when it ends
        if not self.panel.valid or self._preview_refused:
            self._rest_wanted = False  # the panel or the preview says what is wrong
            return
        rest = self.rest_task()
        self._rest_wanted = False
        if rest is None:
            return
        task, done, message = rest
        self._rest_running, self._superseded = True, False
        if not self.start_task(task, done, message=message, busy=self._rest_busy()):
            self._rest_running = False

    def rest_task(self):
        """What runs when the values rest: ``(task, done, message)``, or None.

        The Run button's task by default; an app whose full result is another task
        (the video-database app renders its assignment again) says so here.
        """
        return self._run_fn, self._show_clip, "making the full clip…"

    def _rest_busy(self):
        """Widgets a rest task disables (as its Run would)."""
        return ()

    def _supersede(self):
        """Stop a run the values started that newer values made obsolete."""
        token = self._token
        if self._rest_running and self.running and token is not None:
            self._superseded = True
            token.cancel()

    def wait_live(self, timeout=60):
        """Block until previews, the wait for rest and the full result are done (tests)."""
        deadline = time.monotonic() + timeout
        while True:
            self.wait_preview(max(0.1, deadline - time.monotonic()))
            with self._settle_lock:  # never a timer made but not yet started
                timer = self._settle_timer
            if timer is not None:
                timer.join(max(0.1, deadline - time.monotonic()))
            self.wait(max(0.1, deadline - time.monotonic()))
            if timer is self._settle_timer and not self.running and not self._rest_pending():
                return  # no newer value came meanwhile
            if time.monotonic() > deadline:
                raise TimeoutError("the live preview and full result did not finish in time")

    def _rest_pending(self):
        return self._rest_wanted and not self.held and self.panel.valid

    # ------------------------------------------------------------------ preview
    def request_preview(self):
        """Ask for a fresh preview; returns at once (a worker computes it)."""
        if self._preview_fn is None or self._closed:
            return
        with self._settle_lock:  # not between _request_warm's check and its request
            self._warm_only = False
            self._previews.request()

    def _preview_once(self):
        with self._settle_lock:
            warm_only, self._warm_only = self._warm_only, False
        if warm_only:
            self._warm_up()
            return
        started = time.monotonic()
        timeline = {"changed": self._changed_at, "started": time.time() * 1000}
        # CPU seconds of this thread and of the whole kernel while the preview is made:
        # beside the wall time, they tell computing from waiting (for the GIL or a core).
        cpu = time.thread_time(), time.process_time()
        generation = self._tasks_started
        params = self.panel.params
        try:
            # A preview's products are small: OpenBLAS's second thread only spins on a
            # core the page and the kernel need (measured, FlickerApp at load 10: 240
            # -> 100 ms a preview; FireApp 180 -> 100 ms).
            with blas_single_threaded():
                clip = self.preview(params)
        except ValueError:
            self._preview_refused = True
            raise
        self._preview_refused = False
        if clip is None:
            self._warm_up()
            return
        if not isinstance(clip, Clip):
            raise TypeError(f"preview must return a fluidnb.Clip, got {type(clip).__name__}")
        # A run that started (or finished) meanwhile owns the player now: drop this
        # preview rather than cover the run's result with it -- unless that run is a
        # rest run this very change stopped.
        with self._settle_lock:
            show = (not self._task_active or self._superseded) and (
                generation == self._tasks_started
            )
        if show:
            timeline["made"] = time.time() * 1000
            timeline["cpu"] = 1000 * (time.thread_time() - cpu[0])
            timeline["kernel_cpu"] = 1000 * (time.process_time() - cpu[1])
            self.preview_player.show_timed(clip, timeline)
            if len(clip) > 1:  # a loop (flicker) or a growth (frost) is seen playing:
                self.preview_player.play(True)  # paused, frost's first frame shows no ice
            note = clip.metadata.get("note")
            note = f": {note}" if note else ""
            self.say(f"preview ({time.monotonic() - started:.2f} s){note}")
            if not self._task_active:  # the last result's full green bar: not these values'
                self.progress.value = 0
                self.progress.bar_style = ""
        if not self._previews.pending():  # a newer value's preview comes first
            self.after_preview(params)
        self._warm_up()

    def _warm_up(self):
        """:meth:`warm` on the preview's worker, once no newer value came for a moment.

        Not while a slider is held: the next value comes any moment, and a warm-up
        beside its preview took a core from it (the video-database app's preview
        waited for its prefetch's threads: 230 ms instead of 100 at load 6). The
        release asks for it (:meth:`_held_changed`).
        """
        deadline = time.monotonic() + self.warm_after
        while time.monotonic() < deadline:
            if self._closed or self._previews.pending():
                return  # a newer value waits for its preview: that comes first
            with self._settle_lock:
                if self._task_active:
                    self._warm_pending = True  # after the task (it may be waiting on us)
                    return
                if self.held:
                    self._warm_on_release = True
                    return
            time.sleep(0.005)
        self.warm(self.panel.params)

    def _request_warm(self):
        """:meth:`warm` on the preview's worker, with no preview before it."""
        with self._settle_lock:  # a preview asked for meanwhile must not become a warm-up
            if self._closed or self._previews.pending():
                return
            self._warm_only = True
            self._previews.request()

    def after_preview(self, params):
        """What follows a preview once it is on its way to the page (on the preview's worker).

        For what the values change but the picture need not wait for (the frost app's
        length estimate): skipped when a newer value already waits. Nothing by default.
        """

    def warm(self, params):
        """Get ready for the full result while the values rest (after a preview).

        Runs on the preview's worker; a newer value waits for it, so it should stop
        soon when the values move again. Nothing by default.
        """

    def preview(self, params):
        """The live preview for ``params`` (a Clip, or None): the ``preview`` callable's."""
        return self._preview_fn(params)

    def preview_pending(self):
        """Whether a newer value waits for its preview (work after a preview can give way)."""
        return self._previews.pending()

    @property
    def in_kernel(self):
        """Whether the app runs in a notebook kernel with a page (not a script or a test)."""
        return self._loop is not None

    def wait_preview(self, timeout=30):
        """Block until every preview requested so far has been shown (for scripts/tests)."""
        self._previews.wait(timeout)

    # ------------------------------------------------------------------ run / cancel
    @property
    def running(self):
        """Whether a full run is in progress."""
        return self._thread is not None and self._thread.is_alive()

    def start(self):
        """Start the full run in a worker thread (what the Run button does)."""
        return self.start_task(self._run_fn, self._show_clip)

    def start_task(self, task, done=None, *, message="running…", busy=()):
        """Run ``task(params, progress)`` in the worker thread, as the Run button does.

        The generic part of :meth:`start`, for a method's other long actions (an
        optimiser button, say): the same progress bar, Cancel button, status line and
        error handling, and one task at a time (:attr:`running`, :meth:`wait`).

        Parameters
        ----------
        task : callable
            ``task(params, progress)`` with the panel's current parameters and the
            cancellable progress callable; its ValueErrors are shown as plain messages.
        done : callable, optional
            ``done(result, seconds) -> str`` called in the worker with what ``task``
            returned; its text is the status line's success message.
        message : str
            Status line while the task runs.
        busy : sequence of widgets
            More buttons to disable while the task runs (the Run button always is);
            they are enabled again before the worker ends, so :meth:`wait` returns
            with them usable.

        Returns
        -------
        bool
            False (nothing started) while another task runs or the parameters are
            invalid.
        """
        if self.running:
            return False
        if not self.panel.valid:
            self.say(f"Fix the parameters: {self.panel.message}", "error")
            return False
        params = self.panel.params
        self._token = CancelToken(self._report)
        self._run_button.disabled = True
        self._busy = tuple(busy)
        for widget in self._busy:
            widget.disabled = True
        self._cancel_button.disabled = False
        self.progress.value = 0
        self.progress.bar_style = ""
        self.say(message)
        self._tasks_started += 1
        self._task_active = True
        self._rest_wanted = False  # this task uses the values as they are now
        # Previews asked for before this run are obsolete: its result will show.
        self._previews.skip_pending()
        self._thread = threading.Thread(
            target=self._run_worker,
            args=(task, done, params, self._token),
            name="fluidnb-run",
            daemon=True,
        )
        self._thread.start()
        return True

    def _show_clip(self, clip, seconds):
        if not isinstance(clip, Clip):
            raise TypeError(f"run must return a fluidnb.Clip, got {type(clip).__name__}")
        self.result = clip
        self.player.clip = clip
        self.player.play(True)  # it plays at once, in the page
        return f"done in {seconds:.1f} s: {len(clip)} frames"

    def _report(self, fraction, message=""):
        self.progress.value = fraction
        self._progress_text.value = message

    def _run_worker(self, task, done, params, token):
        started = time.monotonic()
        try:
            result = task(params, token)
            seconds = time.monotonic() - started
            text = done(result, seconds) if done is not None else f"done in {seconds:.1f} s"
            self.progress.value = 1
            self.progress.bar_style = "success"
            self.say(text, "ok")
        except Cancelled:
            if self._superseded:  # newer values stopped it: their preview shows
                self.progress.value = 0
            else:
                self.progress.bar_style = "warning"
                self.say("cancelled; your drawing and settings are unchanged")
        except ValueError as exc:
            self.progress.bar_style = "danger"
            self.say(str(exc), "error")
        except Exception as exc:
            self.progress.bar_style = "danger"
            self.say(f"{type(exc).__name__}: {exc}", "error")
            traceback.print_exc()
        finally:
            self._run_button.disabled = not self.panel.valid
            for widget in self._busy:
                widget.disabled = False
            self._cancel_button.disabled = True
            self._progress_text.value = ""
            self._rest_running = False
            if self._rest_wanted and not self._closed:
                self._schedule_rest()  # values changed while it ran
            with self._settle_lock:
                # Together: a preview that ends meanwhile sees either a task still
                # active and superseded, or no task (never an active one that looks
                # current, whose result would never come: the preview was dropped).
                self._task_active = self._superseded = False
                warm, self._warm_pending = self._warm_pending, False
            if warm:
                self._request_warm()

    def cancel(self):
        """Ask the running computation to stop at its next progress report."""
        if self._token is not None and self.running:
            self._rest_wanted = False  # the user's Cancel: no full result by itself
            self._token.cancel()
            self.say("cancelling…")

    def wait(self, timeout=None):
        """Block until the current run ends (for scripts and tests); returns the result."""
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise TimeoutError("the run did not finish in time")
        return self.result

    def run(self, timeout=None, *, block=None):
        """Press Run; wait for the clip unless that would freeze a live notebook.

        In a notebook kernel a person works in, ``run`` returns at once: the run goes
        on in the background with its progress in the app, and its clip appears in
        the player and in :attr:`result` (:meth:`wait` blocks for it), while the
        notebook stays usable -- a lesson's last cell must not hold a class for
        minutes. It waits (at most ``timeout`` seconds) and returns the clip outside a
        kernel (scripts, tests) and in quick mode (``FLUIDNB_QUICK=1``, how CI runs
        the lessons top to bottom).

        Parameters
        ----------
        timeout : float, optional
            Longest wait in seconds when waiting (TimeoutError after it).
        block : bool, optional
            Wait (True) or not (False) whatever the context; by default, as above.

        Returns
        -------
        fluidnb.Clip or None
            The run's clip when waited for (the previous result if the run was
            refused), else None.
        """
        self.start()
        if block is None:
            block = _quick_mode() or not _in_kernel()
        return self.wait(timeout) if block else None

    # ------------------------------------------------------------------ plumbing
    def on_main(self, fn):
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
        """Stop the preview worker and close the widgets."""
        self._closed = True
        # A subclass that refused its arguments never reached App.__init__; ipywidgets
        # still closes it when it is collected.
        previews = getattr(self, "_previews", None)
        if previews is not None:
            previews.close()
        with getattr(self, "_settle_lock", threading.Lock()):
            timer = getattr(self, "_settle_timer", None)
            if timer is not None:
                timer.cancel()
        token = getattr(self, "_token", None)
        if token is not None:
            token.cancel()
        super().close()
