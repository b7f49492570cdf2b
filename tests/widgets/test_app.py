import gc
import sys
import threading
import time
from dataclasses import dataclass

import numpy as np
import pytest

from fluidnb import Clip, Params, Progress, param
from fluidnb.widgets import App, DrawingCanvas, FireApp, ParamPanel, TurbulenceApp


@dataclass(frozen=True)
class Demo(Params):
    level: float = param(0.5, lo=0, hi=1)
    n: int = param(4, lo=2, hi=400, integer=True)
    lo: int = param(1, lo=0, hi=10, integer=True)

    def check(self):
        if self.lo >= self.n:
            raise ValueError(f"lo must be < n = {self.n}, got {self.lo}")


def level_clip(params, n=2):
    return Clip(np.full((n, 6, 6), params.level, np.float32), fps=4, metadata={"method": "demo"})


def make_app(run=None, preview=None, canvas=True):
    c = DrawingCanvas(np.zeros((16, 16)), masks=["region"]) if canvas else None

    def default_run(params, progress):
        report = Progress(progress)
        for i in range(params.n):
            report(i / params.n, f"frame {i}")
            time.sleep(0.01)
        if c is not None and not c.get_mask("region").any():
            raise ValueError("region is empty: paint at least one pixel")
        return level_clip(params, params.n)

    app = App(
        panel=ParamPanel(Demo),
        run=run or default_run,
        preview=preview,
        canvas=c,
        title="Demo",
        min_interval=0.0,
    )
    return app, c


def test_preview_follows_sliders_latest_value_wins():
    calls = []

    def preview(params):
        calls.append(params.level)
        time.sleep(0.02)
        return level_clip(params)

    app, _ = make_app(preview=preview)
    try:
        for v in np.linspace(0, 1, 21):
            app.panel.controls["level"].value = float(v)
        app.wait_preview()
        assert app.player.clip.frames[0, 0, 0] == pytest.approx(1.0)
        # Throttled: far fewer computations than slider events, and the last is the latest.
        assert len(calls) < 21
        assert calls[-1] == pytest.approx(1.0)
    finally:
        app.close()


def test_drawing_triggers_preview():
    seen = []

    def preview(params):
        seen.append(1)
        return level_clip(params)

    app, canvas = make_app(preview=preview)
    try:
        app.wait_preview()
        before = len(seen)
        canvas.paint([[4, 4]], radius=2)
        app.wait_preview()
        assert len(seen) == before + 1
    finally:
        app.close()


def test_run_reports_progress_and_shows_result():
    app, canvas = make_app()
    fractions = []
    app.progress.observe(lambda c: fractions.append(c["new"]), "value")
    canvas.paint([[4, 4]], radius=2)
    clip = app.run(timeout=10)
    assert isinstance(clip, Clip)
    assert app.player.clip is clip
    assert app.progress.value == 1
    assert fractions == sorted(fractions)
    assert len(fractions) >= 3
    assert "done" in app.status
    app.close()


def test_cancel_stops_within_one_unit_of_work_and_keeps_the_drawing():
    started = threading.Event()
    units = []  # units of work finished

    def slow(params, progress):
        report = Progress(progress)
        started.set()
        for i in range(1000):
            report(i / 1000)  # a cancelled run stops here, before the next unit
            units.append(i)
            time.sleep(0.01)
        return level_clip(params)

    app, canvas = make_app(run=slow)
    canvas.paint([[4, 4]], radius=2)
    mask = canvas.get_mask()
    assert app.start()
    assert started.wait(5)
    assert not app.start()  # a second press while running does nothing
    app._cancel_button.click()
    at_cancel = len(units)
    app.wait(timeout=5)
    # At most the unit already under way when the button was pressed finishes.
    assert len(units) <= at_cancel + 1 < 1000
    assert "cancelled" in app.status
    assert app.result is None
    assert np.array_equal(canvas.get_mask(), mask)
    assert not app._run_button.disabled
    app.close()


def test_errors_appear_in_plain_words_and_nothing_is_lost():
    app, canvas = make_app()
    assert not canvas.get_mask("region").any()  # nothing painted: the run must refuse
    app.run(timeout=10)
    assert app.status == "region is empty: paint at least one pixel"
    assert app.progress.bar_style == "danger"
    canvas.paint([[4, 4]], radius=2)
    assert app.run(timeout=10) is not None
    app.close()


def test_unexpected_exceptions_are_shown_not_raised(capsys):
    def broken(params, progress):
        raise RuntimeError("boom")

    app, _ = make_app(run=broken)
    app.run(timeout=10)
    assert app.status == "RuntimeError: boom"
    assert "boom" in capsys.readouterr().err
    app.close()


def test_invalid_parameters_disable_run_and_explain():
    app, _ = make_app(canvas=False)
    assert app.panel.controls["lo"].max == 3  # the slider offers lo < n = 4 only
    with pytest.raises(ValueError, match="lo must be < n"):
        app.panel.set("lo", 9)  # from code: lo >= n = 4, an invalid combination
    assert app._run_button.disabled
    assert "lo must be < n" in app.status
    assert not app.start()
    app.panel.controls["n"].value = 20
    assert not app._run_button.disabled
    app.close()


def test_a_preview_finishing_after_a_run_does_not_replace_the_result():
    release = threading.Event()
    entered = threading.Event()

    def slow_preview(params):
        entered.set()
        release.wait(5)
        return Clip(np.zeros((2, 6, 6), np.float32), fps=4)

    app, canvas = make_app(preview=slow_preview)
    canvas.paint([[4, 4]], radius=2)
    assert entered.wait(5)  # the preview is computing
    result = app.run(timeout=10)
    release.set()
    app.wait_preview()
    assert app.player.clip is result
    assert "done" in app.status
    app.close()


@pytest.mark.parametrize(
    ("make", "why"),
    [
        (lambda: FireApp(photo=np.full((3, 3), np.nan)), "photo"),
        (lambda: TurbulenceApp(size="huge"), "size must be one of"),
    ],
    ids=["fire", "turbulence"],
)
def test_an_app_that_refuses_its_arguments_is_collected_cleanly(make, why):
    # ipywidgets closes a widget when it is collected, even one whose __init__ raised
    # before App.__init__ ran: close() must not fail on the missing parts.
    seen = []
    old, sys.unraisablehook = sys.unraisablehook, seen.append
    try:
        with pytest.raises(ValueError, match=why):
            make()
        gc.collect()
    finally:
        sys.unraisablehook = old
    assert not seen, [str(u.exc_value) for u in seen]


def test_exports_land_in_the_output_folder_and_the_status_line_says_where(tmp_path, monkeypatch):
    # Issue 22, point 8: a class's exports made `git status` dirty among the notebooks.
    lesson = tmp_path / "notebooks"
    lesson.mkdir()
    monkeypatch.chdir(lesson)
    monkeypatch.delenv("FLUIDNB_OUTPUT_DIR", raising=False)
    app = FireApp(quick=True, n_frames=4)
    try:
        app.run(timeout=120)
        app.player._gif.click()
        app.compare._mp4.click()
        written = sorted(p.relative_to(lesson).as_posix() for p in lesson.rglob("*.*"))
        assert [w.split("/")[0] for w in written] == ["fluidnb-output"] * len(written)
        assert any(w.endswith(".mp4") for w in written)
        assert app.status.startswith("saved fluidnb-output/fluidnb-fire-")
        assert app.status.endswith(".mp4")
    finally:
        app.close()


def test_the_repository_ignores_the_output_folder():
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    for path in ("notebooks/fluidnb-output/fluidnb-fire-1.gif", "fluidnb-output/strokes.json"):
        ignored = subprocess.run(
            ["git", "check-ignore", "-q", path], cwd=root, check=False
        ).returncode
        assert ignored == 0, f"{path} is not ignored by .gitignore"


def test_the_full_result_waits_for_the_slider_to_be_let_go_and_rest():
    # Issue 36: a render started while the handle was still held (a pause in a drag
    # looked like a release). The page says when a slider is held; the full run
    # starts only once it is let go and the values rest.
    runs, previews = [], []

    def run(params, progress):
        runs.append(params.level)
        return level_clip(params, 3)

    def preview(params):
        previews.append(params.level)
        return level_clip(params)

    app = App(panel=ParamPanel(Demo), run=run, preview=preview, min_interval=0.0, run_on_rest=True)
    try:
        app.settle = 0.05
        app.wait_preview()
        app._live.held = True  # the page: a slider's handle is pressed
        for v in (0.2, 0.3, 0.4):
            app.panel.controls["level"].value = v
            time.sleep(0.1)  # pauses longer than settle: still held
        app.wait_preview()
        assert previews[-1] == pytest.approx(0.4)  # the preview follows while held
        assert runs == []
        assert not app.running
        app._live.held = False  # let go
        app.wait_live()
        assert runs == [pytest.approx(0.4)]
        assert app.result.frames[0, 0, 0] == pytest.approx(0.4)
        assert app.player.clip is app.result
        assert app.player.playing  # it plays at once
        # A key press (no hold): the full result follows once the value rests.
        app.panel.controls["level"].value = 0.6
        app.wait_live()
        assert runs[-1] == pytest.approx(0.6)
    finally:
        app.close()


def test_no_warm_up_while_a_slider_is_held_one_after_its_release():
    # Issue 36: a warm-up between two values of a drag took a core from the next
    # value's preview (the video-database app's prefetch: 230 ms instead of 100). While
    # the handle is held, pauses longer than warm_after warm nothing; the release does.
    warmed = []

    class Warming(App):
        def warm(self, params):
            warmed.append(params.level)

    app = Warming(panel=ParamPanel(Demo), run=lambda p, g: level_clip(p), preview=level_clip)
    try:
        app.warm_after = 0.02
        app.wait_preview()
        time.sleep(0.1)
        assert warmed == [pytest.approx(0.5)]  # at rest, not held: the warm-up runs
        app._live.held = True
        for v in (0.2, 0.3):
            app.panel.controls["level"].value = v
            time.sleep(0.1)  # far longer than warm_after
            app.wait_preview()
        assert warmed == [pytest.approx(0.5)]  # nothing while held
        app._live.held = False
        deadline = time.monotonic() + 10
        while len(warmed) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        app.wait_preview()
        assert warmed == [pytest.approx(0.5), pytest.approx(0.3)]  # once, the last value
        # A key press (no hold) warms after its preview, as before.
        app.panel.controls["level"].value = 0.4
        app.wait_preview()
        time.sleep(0.1)
        app.wait_preview()
        assert warmed[-1] == pytest.approx(0.4)
    finally:
        app.close()


def test_a_newer_value_stops_the_full_result_of_the_old_one_quietly():
    started = threading.Event()
    runs = []

    def run(params, progress):
        runs.append(params.level)
        if params.level == pytest.approx(0.2):
            started.set()
            while True:  # slow and cancellable
                progress(0.5, "working")
                time.sleep(0.01)
        return level_clip(params)

    app = App(
        panel=ParamPanel(Demo), run=run, preview=level_clip, min_interval=0.0, run_on_rest=True
    )
    try:
        app.settle = 0.05
        app.panel.controls["level"].value = 0.2
        assert started.wait(10)
        app.panel.controls["level"].value = 0.7  # the slider moves again
        app.wait_live()
        assert runs == [pytest.approx(0.2), pytest.approx(0.7)]
        assert app.result.frames[0, 0, 0] == pytest.approx(0.7)
        assert "cancelled" not in app.status
        assert app.progress.bar_style == "success"
    finally:
        app.close()


def test_a_preview_after_a_result_empties_the_bar_it_left_full():
    # The full, green bar says a result of the values shown is done; a preview of
    # newer values shows something else (seen in FlickerApp: green beside "preview").
    app, canvas = make_app(preview=level_clip)
    try:
        canvas.paint([[4, 4]], radius=2)
        app.run(timeout=10)
        assert (app.progress.value, app.progress.bar_style) == (1, "success")
        app.panel.controls["level"].value = 0.9
        app.wait_preview()
        assert "preview" in app.status
        assert (app.progress.value, app.progress.bar_style) == (0, "")
    finally:
        app.close()


def test_a_preview_that_ends_while_a_superseded_run_winds_down_is_shown():
    # Seen in the browser under load: the slider held, a preview came while the run
    # its press stopped was still winding down, and was dropped as if that run's
    # result would cover it -- the player stayed on the old picture.
    started = threading.Event()
    shown, moved = [], []

    def run(params, progress):
        if params.level == pytest.approx(0.2):
            started.set()
            while True:  # slow and cancellable
                progress(0.5, "working")
                time.sleep(0.01)
        return level_clip(params)

    app = App(
        panel=ParamPanel(Demo), run=run, preview=level_clip, min_interval=0.0, run_on_rest=True
    )
    schedule = app._schedule_rest

    def winding_down():  # in the run's worker, after its cancellation, before it ends
        if not moved and threading.current_thread() is app._thread:
            moved.append(True)
            app.panel.controls["level"].value = 0.55  # the held slider moves on
            app.wait_preview()
            shown.append(float(app.player.clip.frames[0, 0, 0]))
        schedule()

    app._schedule_rest = winding_down
    try:
        app.settle = 0.05
        app.panel.controls["level"].value = 0.2
        assert started.wait(10)
        app._live.held = True  # pressed: the run of 0.2 is obsolete
        app.panel.controls["level"].value = 0.4
        app.wait(timeout=10)
        assert shown == [pytest.approx(0.55)]
    finally:
        app._live.held = False
        app.close()


def test_runs_start_by_themselves_only_in_a_notebook():
    # Scripts and tests press Run themselves: no run starts behind their back.
    app, _ = make_app(preview=level_clip)
    try:
        assert not app.run_on_rest
        app.settle = 0.01
        app.panel.controls["level"].value = 0.9
        time.sleep(0.1)
        assert not app.running
        assert app.result is None
    finally:
        app.close()


def test_a_preview_of_several_frames_plays_one_frame_is_shown_still():
    app, _ = make_app(preview=lambda params: level_clip(params, 1 if params.level <= 0.5 else 3))
    try:
        app.panel.controls["level"].value = 0.25
        app.wait_preview()
        assert len(app.player.clip) == 1
        assert not app.player.playing  # one frame: nothing to play
        app.panel.controls["level"].value = 0.75
        app.wait_preview()
        assert len(app.player.clip) == 3
        assert app.player.playing  # a loop or a growth is seen moving
    finally:
        app.close()


def test_an_app_in_a_kernel_shortens_the_gil_switch_interval_never_lengthens_it():
    # Issue 36: the preview's worker waited up to Python's 5 ms for the GIL at every
    # hand-over with the kernel's main thread (queued 8-13 ms -> 5-7 ms in Chromium).
    from fluidnb.widgets import _app

    before = sys.getswitchinterval()
    try:
        sys.setswitchinterval(0.005)
        _app._prompt_gil_handover()
        assert sys.getswitchinterval() == pytest.approx(_app.GIL_SWITCH)
        sys.setswitchinterval(0.0002)  # someone wants it shorter still: kept
        _app._prompt_gil_handover()
        assert sys.getswitchinterval() == pytest.approx(0.0002)
    finally:
        sys.setswitchinterval(before)
