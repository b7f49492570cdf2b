import io

import pytest

from fluidnb import Cancelled, CancelToken, Progress, TextProgress


def test_progress_none_reports_nothing_anywhere(capsys):
    report = Progress(None)
    assert report.callback is None
    assert report(0.5, "x") is None
    first, second = report.split(0.5)
    assert first.callback is None
    assert second.sub(0.2, 0.4).callback is None
    second(1.0, "done")
    assert capsys.readouterr() == ("", "")


def test_progress_substages_map_into_parent_range():
    seen = []
    report = Progress(lambda f, m: seen.append(f))
    a, b = report.split(0.5)
    b1, b2 = b.split(0.5)
    a(1.0)
    b1(0.0)
    b2(1.0)
    b2(7.0)  # clamped
    assert seen == [0.5, 0.5, 1.0, 1.0]


def test_progress_refuses_non_callable():
    with pytest.raises(ValueError, match="progress must be None or a callable"):
        Progress(42)


def test_cancel_token_raises_after_cancel_and_forwards_before():
    seen = []
    token = CancelToken(lambda f, m: seen.append(m))
    token(0.1, "a")
    token.cancel()
    assert token.cancelled
    with pytest.raises(Cancelled):
        token(0.2, "b")
    assert seen == ["a"]


def test_cancellation_stops_a_loop_through_progress():
    token = CancelToken()
    done = []

    def work(progress):
        report = Progress(progress)
        for i in range(100):
            report(i / 100, f"step {i}")
            done.append(i)
            if i == 9:
                token.cancel()

    with pytest.raises(Cancelled):
        work(token)
    assert len(done) == 10


def test_text_progress_writes_final_line():
    out = io.StringIO()
    bar = TextProgress(stream=out, interval=0)
    bar(0.5, "half")
    bar(1.0, "done")
    text = out.getvalue()
    assert "50%" in text
    assert text.endswith("\n")
    assert "100%" in text


def test_progress_bar_outside_a_notebook_is_a_text_bar_on_stderr(capsys):
    from fluidnb import progress_bar

    bar = progress_bar("building")
    assert isinstance(bar, TextProgress)
    bar(1.0, "done")
    err = capsys.readouterr().err
    assert err.startswith("building: [")
    assert "100%" in err
