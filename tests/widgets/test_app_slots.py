"""The App's layout slots, the method apps built from them, and when run() waits."""

import ast
import threading
import types
from dataclasses import dataclass
from pathlib import Path

import ipywidgets as W
import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient

import fluidnb.widgets
from fluidnb import Clip, Params, param
from fluidnb.widgets import (
    App,
    DrawingCanvas,
    FireApp,
    FlickerApp,
    FramePlayer,
    FrostApp,
    ParamPanel,
    TurbulenceApp,
    VideoDBApp,
)

WIDGETS = Path(fluidnb.widgets.__file__).resolve().parent
SLOTS = ("canvas_tools", "inputs", "controls", "aside", "views")


@dataclass(frozen=True)
class Demo(Params):
    level: float = param(0.5, lo=0, hi=1)


def clip_of(params, n=2):
    return Clip(np.full((n, 6, 6), params.level, np.float32), fps=4)


def tree(widget):
    """Every widget shown under ``widget``, depth first, in screen order."""
    out = []
    for child in getattr(widget, "children", ()):
        out.append(child)
        out += tree(child)
    return out


def box_holding(app, widget):
    """The box of the app's layout whose children include ``widget``."""
    return next(w for w in [app, *tree(app)] if widget in getattr(w, "children", ()))


def labelled(text):
    return W.HTML(text)


# ---------------------------------------------------------------------- the slots
def test_each_slot_is_shown_where_the_docstring_draws_it():
    canvas = DrawingCanvas(np.zeros((16, 16)), masks=["region"])
    tool, inp, ctl, side, view = (labelled(t) for t in ("tool", "input", "ctl", "aside", "view"))
    panel = ParamPanel(Demo)
    app = App(
        panel=panel,
        run=lambda p, progress: clip_of(p),
        canvas=canvas,
        title="Demo",
        inputs=[inp],
        controls=[ctl],
        canvas_tools=[tool],
        aside=[side],
        views=[App.titled("the clip", W.Label("x")), view],
    )
    try:
        heading, runbar, columns, aside, live = app.children
        assert live is app._live  # hidden: tells the kernel while a slider is held
        assert "Demo" in heading.value
        # Run, Cancel and the progress bar, then the status line, above everything.
        assert app.progress in tree(runbar)
        assert app._run_button in tree(runbar)
        assert app._status in tree(runbar)
        # The canvas, the result beside it, then inputs, panel and controls.
        drawing, views, controls = columns.children
        assert drawing.children == (canvas, tool)
        assert "the clip" in views.children[0].children[0].value
        assert views.children[-1] is view
        assert controls.children == (inp, panel, ctl)
        assert aside.children == (side,)
        # The default views slot is the player alone; the player exists either way.
        assert isinstance(app.player, FramePlayer)
    finally:
        app.close()


def test_empty_slots_take_no_room_and_the_player_is_the_default_view():
    app = App(panel=ParamPanel(Demo), run=lambda p, progress: clip_of(p))
    try:
        _runbar, columns, aside, _live = app.children  # no title, no heading
        views, controls = columns.children  # no canvas column
        assert views.children == (app.player,)
        assert controls.children == (app.panel,)
        assert aside.children == ()
        assert app.canvas is None
        assert app.seed_box is None
    finally:
        app.close()


def test_a_seed_gives_the_app_a_seed_box_and_a_new_seed_a_new_preview():
    seen = []

    def preview(params):
        seen.append(app.seed)
        return clip_of(params)

    app = App(
        panel=ParamPanel(Demo),
        run=lambda p, progress: clip_of(p),
        preview=preview,
        seed=3,
        min_interval=0,
    )
    try:
        app.wait_preview()
        assert app.seed == app.seed_box.value == 3
        app.seed_box.value = 7
        app.wait_preview()
        assert app.seed == 7
        assert seen[-1] == 7
    finally:
        app.close()


def test_setting_a_slot_later_updates_the_layout():
    app = App(panel=ParamPanel(Demo), run=lambda p, progress: clip_of(p))
    try:
        extra = labelled("more")
        app.controls = (extra,)
        assert box_holding(app, extra) is box_holding(app, app.panel)
        view = labelled("a view")
        app.views = (app.player, view)
        assert box_holding(app, view) is box_holding(app, app.player)
        assert box_holding(app, app.panel) is not box_holding(app, app.player)
        app.controls = ()
        assert extra not in tree(app)
    finally:
        app.close()


def test_a_new_canvas_takes_the_old_ones_place_and_drives_the_preview():
    seen = []

    def preview(params):
        seen.append(1)
        return clip_of(params)

    first = DrawingCanvas(np.zeros((16, 16)), masks=["region"])
    tool = labelled("tool")
    app = App(
        panel=ParamPanel(Demo),
        run=lambda p, progress: clip_of(p),
        preview=preview,
        canvas=first,
        canvas_tools=[tool],
        min_interval=0.0,
    )
    try:
        app.wait_preview()
        second = DrawingCanvas(np.zeros((24, 24)), masks=["region"])
        app.canvas = second
        assert first not in tree(app)
        assert box_holding(app, second).children == (second, tool)
        app.drawing_width = "300px"  # the column keeps its width, its tool rows wrap
        assert box_holding(app, second).layout.width == "300px"
        app.wait_preview()
        before = len(seen)
        first.paint([[4, 4]], radius=2)  # the old canvas no longer drives the preview
        app.wait_preview()
        assert len(seen) == before
        second.paint([[4, 4]], radius=2)
        app.wait_preview()
        assert len(seen) == before + 1
    finally:
        app.close()


def test_slots_take_widgets_only():
    app = App(panel=ParamPanel(Demo), run=lambda p, progress: clip_of(p))
    try:
        with pytest.raises(Exception, match="controls"):
            app.controls = ("not a widget",)
    finally:
        app.close()


# ---------------------------------------------------------------------- the method apps
@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


APPS = {
    "flicker": lambda: FlickerApp(quick=True),
    "frost": lambda: FrostApp(quick=True),
    "fire": lambda: FireApp(quick=True),
    "turbulence": lambda: TurbulenceApp(n_frames=4),
    "videodb": lambda: VideoDBApp("stream", size=96, db="water", quick=True),
}


@pytest.mark.parametrize("name", APPS)
def test_every_app_fills_the_slots_and_keeps_the_apps_layout(name):
    app = APPS[name]()
    try:
        shown = tree(app)
        # The App's own structure: a heading, the run bar, the columns, the aside row.
        heading, _runbar, columns, _aside, _live = app.children
        assert "<h3" in heading.value
        assert app.views
        # The result beside the canvas: the views' column follows the canvas's.
        boxes = columns.children
        views = next(b for b in boxes if b.children == app.views)
        if app.canvas is not None:
            assert boxes.index(views) == boxes.index(box_holding(app, app.canvas)) + 1
        assert app.player in shown
        assert app.panel in shown
        for slot in SLOTS:
            for widget in getattr(app, slot):
                assert widget in shown, (slot, widget)
        if name == "turbulence":
            assert app.canvas is None
            assert app.aside
            assert app.inputs
        else:
            assert isinstance(app.canvas, DrawingCanvas)
            assert app.canvas in shown
        # Each widget is placed once (no copy left behind by a re-layout).
        placed = [id(w) for w in shown if not isinstance(w, (W.HTML, W.Label))]
        assert len(placed) == len(set(placed))
    finally:
        app.close()


def test_fire_swaps_its_canvas_through_the_slot():
    app = FireApp(quick=True)
    try:
        old = app.canvas
        column = box_holding(app, old)
        app.set_photo(np.zeros((40, 60, 3)))
        assert app.canvas is not old
        assert app.canvas.image.shape[:2] == (40, 60)
        assert old not in tree(app)
        assert box_holding(app, app.canvas) is column
    finally:
        app.close()


def test_the_turbulence_players_are_built_with_the_players_public_options(tmp_path):
    app = TurbulenceApp(n_frames=4, display_width=300, export_dir=tmp_path)
    try:
        for player in (app.player, app.vorticity):
            assert player.display_width == 300
            assert player.export_dir == tmp_path
            assert player.view.slider_width == "200px"
        # One group in the page: the vorticity shows the dye's frame as it plays.
        assert app.player.view.group == app.vorticity.view.group != ""
        app.player.clip = Clip(np.zeros((4, 6, 6)), fps=4)
        app.vorticity.clip = Clip(np.zeros((4, 6, 6)), fps=4)
        app.player.show(2)
        assert app.vorticity.frame == 2
        app.player.play()
        assert app.vorticity.playing
    finally:
        app.close()


def test_the_canvas_leaves_out_the_value_slider_when_asked():
    def sliders(canvas):
        return [w.description for w in tree(canvas) if isinstance(w, W.FloatSlider)]

    assert sliders(DrawingCanvas(np.zeros((8, 8)), masks=["m"])) == ["value", "radius"]
    assert sliders(DrawingCanvas(np.zeros((8, 8)), masks=["m"], value_slider=False)) == ["radius"]


def test_the_layer_choice_keeps_its_room_when_some_tool_has_several_layers():
    def pick(canvas):
        return next(w for w in tree(canvas) if isinstance(w, W.Dropdown))

    c = DrawingCanvas(np.zeros((8, 8)), strokes=["flow"], masks=["matte"], maps=["speed"])
    c.select("brush", "matte")
    assert pick(c).layout.visibility == "visible"
    assert pick(c).layout.display != "none"
    c.select("stroke")  # one stroke layer: hidden, its room kept (nothing jumps)
    assert pick(c).layout.visibility == "hidden"
    assert pick(c).layout.display != "none"
    single = DrawingCanvas(np.zeros((8, 8)), masks=["region"], points=["seeds"])
    assert pick(single).layout.display == "none"  # never needed: no room taken


def private_reaches(path):
    """(line, text) of every access to another object's private attribute or children.

    An app may use its own private attributes (``self._x``) and its base class's
    hooks (``super()._x``), and set its own slots; it must not set or read the
    ``children`` of a box, nor ``thing._x`` of another widget.
    """
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.Attribute):
            continue
        owner = node.value
        own = isinstance(owner, ast.Name) and owner.id in ("self", "cls")
        base = isinstance(owner, ast.Call) and getattr(owner.func, "id", "") == "super"
        private = node.attr.startswith("_") and not node.attr.startswith("__")
        if (private and not (own or base)) or node.attr == "children":
            found.append((node.lineno, ast.unparse(node)))
    return found


@pytest.mark.parametrize(
    "module", ["_fire.py", "_flicker.py", "_frost.py", "_turbulence.py", "_videodb.py"]
)
def test_no_app_reaches_into_another_widgets_children_or_private_attributes(module):
    assert private_reaches(WIDGETS / module) == []


# ---------------------------------------------------------------------- run()
def waiting_app():
    release = threading.Event()

    def run(params, progress):
        release.wait(30)
        return clip_of(params)

    return App(panel=ParamPanel(Demo), run=run), release


@pytest.fixture
def live_kernel(monkeypatch):
    """Pretend to be a notebook kernel a person works in (not quick mode)."""
    import IPython

    shell = types.SimpleNamespace(kernel=object())
    monkeypatch.setattr(IPython, "get_ipython", lambda: shell)
    monkeypatch.delenv("FLUIDNB_QUICK", raising=False)


def test_run_returns_at_once_in_a_live_kernel_and_the_work_goes_on(live_kernel):
    app, release = waiting_app()
    try:
        assert app.run(timeout=600) is None
        assert app.running  # still working, the notebook is free
        release.set()
        clip = app.wait(timeout=10)
        assert isinstance(clip, Clip)
        assert app.player.clip is clip
        assert "done" in app.status
    finally:
        app.close()


def test_run_waits_in_quick_mode_even_in_a_kernel(live_kernel, monkeypatch):
    monkeypatch.setenv("FLUIDNB_QUICK", "1")
    app, release = waiting_app()
    threading.Timer(0.2, release.set).start()
    try:
        clip = app.run(timeout=30)
        assert isinstance(clip, Clip)
        assert not app.running
    finally:
        release.set()
        app.close()


def test_run_waits_outside_a_kernel_and_block_overrides(monkeypatch):
    monkeypatch.delenv("FLUIDNB_QUICK", raising=False)
    app, release = waiting_app()
    try:
        with pytest.raises(TimeoutError):
            app.run(timeout=0.2)  # a script waits (here: not long enough)
        release.set()
        assert isinstance(app.wait(timeout=10), Clip)
        release.clear()
        assert app.run(block=False) is None
        assert app.running
        release.set()
        app.wait(timeout=10)
    finally:
        release.set()
        app.close()


KERNEL_CELLS = [
    """\
import os, threading
from dataclasses import dataclass
import numpy as np
from fluidnb import Clip, Params, param
from fluidnb.widgets import App, ParamPanel

@dataclass(frozen=True)
class Demo(Params):
    level: float = param(0.5, lo=0, hi=1)

release = threading.Event()
def run(params, progress):
    release.wait(60)
    return Clip(np.zeros((2, 4, 4), np.float32), fps=4)

app = App(panel=ParamPanel(Demo), run=run)
""",
    "got = app.run(timeout=600)\nprint('live', got is None, app.running)",
    "release.set()\nprint('then', type(app.wait(30)).__name__)",
    """\
os.environ["FLUIDNB_QUICK"] = "1"
release.clear()
threading.Timer(0.5, release.set).start()
print('quick', type(app.run(timeout=60)).__name__, app.running)
app.close()
""",
]


@pytest.mark.slow
def test_in_a_real_kernel_run_waits_only_in_quick_mode(tmp_path, monkeypatch):
    monkeypatch.delenv("FLUIDNB_QUICK", raising=False)
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in KERNEL_CELLS])
    NotebookClient(
        nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    ).execute()
    printed = "".join(
        out.get("text", "") for cell in nb.cells for out in cell.outputs if out.name == "stdout"
    )
    assert printed.splitlines() == ["live True True", "then Clip", "quick Clip False"]
