"""Progress in a notebook: the widget bar fluidnb.progress_bar returns there."""

import threading

import pytest

import fluidnb
from fluidnb import Cancelled, Progress
from fluidnb._progress import set_progress_bar
from fluidnb.widgets import ProgressBar
from fluidnb.widgets._progress import _shown_bar


def test_the_bar_follows_the_reports_and_ends_green():
    bar = ProgressBar("building", interval=0)
    report = Progress(bar).sub(0.5, 1.0)
    report(0.5, "clip 3 of 4")
    assert bar.bar.value == pytest.approx(0.75)
    assert "75%" in bar.text.value
    assert "clip 3 of 4" in bar.text.value
    report(1.0, "done")
    assert bar.bar.value == 1.0
    assert bar.bar.bar_style == "success"
    assert "done in" in bar.text.value


def test_reports_are_throttled_but_the_end_always_shows():
    bar = ProgressBar(interval=60)
    bar(0.1)
    bar(0.5, "later")  # within the interval: remembered, not sent
    assert bar.bar.value == pytest.approx(0.1)
    assert bar.fraction == 0.5
    bar(1.0)
    assert bar.bar.value == 1.0


def test_cancel_stops_work_running_in_a_thread():
    bar = ProgressBar("long work", cancel=True, interval=0)
    assert bar._cancel.layout.display != "none"
    started, steps, outcome = threading.Event(), [], []

    def work():
        try:
            for i in range(10_000):
                bar(i / 10_000)
                steps.append(i)
                started.set()
                threading.Event().wait(0.001)
            outcome.append("finished")
        except Cancelled:
            outcome.append("cancelled")

    worker = threading.Thread(target=work)
    worker.start()
    started.wait(10)
    bar._cancel.click()
    worker.join(10)
    assert outcome == ["cancelled"]
    assert len(steps) < 10_000
    assert bar.bar.bar_style == "warning"
    assert "cancelled" in bar.text.value
    assert ProgressBar("short").layout is not None
    assert ProgressBar("short")._cancel.layout.display == "none"


def test_the_hook_makes_progress_bar_a_widget_and_text_again_without_it(capsys):
    old = set_progress_bar(_shown_bar)
    try:
        bar = fluidnb.progress_bar("a database", cancel=True)
        assert isinstance(bar, ProgressBar)
        assert bar._cancel.layout.display != "none"
    finally:
        set_progress_bar(old)
    text = fluidnb.progress_bar("a database")
    assert isinstance(text, fluidnb.TextProgress)
    text(1.0, "done")
    assert capsys.readouterr().err.startswith("a database: [")
    with pytest.raises(ValueError, match="factory must be None or callable"):
        set_progress_bar(42)
