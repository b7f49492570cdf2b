import json

import numpy as np
import pytest

from fluidnb.sketch import load_strokes, save_strokes


def test_strokes_round_trip(tmp_path):
    strokes = [np.array([[1.5, 2.0], [3.0, 4.25]]), np.array([[0, 0], [5, 5], [9, 1]])]
    p = save_strokes(tmp_path / "s.json", strokes, (20, 30))
    back, shape = load_strokes(p, (20, 30))
    assert shape == (20, 30)
    assert len(back) == 2
    for a, b in zip(back, strokes):
        np.testing.assert_array_equal(a, b)


def test_bad_strokes_files_are_refused(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        load_strokes(tmp_path / "missing.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ValueError, match="cannot read"):
        load_strokes(tmp_path / "bad.json")
    (tmp_path / "other.json").write_text(json.dumps({"format": "something"}))
    with pytest.raises(ValueError, match="not a fluidnb strokes file"):
        load_strokes(tmp_path / "other.json")
    p = save_strokes(tmp_path / "s.json", [[[0, 0], [1, 1]]], (20, 30))
    with pytest.raises(ValueError, match="drawn on a 20 x 30 image"):
        load_strokes(p, (30, 20))
    with pytest.raises(ValueError, match=r"strokes\[0\] point 0 is 0: each point must be a pair"):
        save_strokes(tmp_path / "t.json", [[0, 1, 2]], (5, 5))


# ---------------------------------------------------------------- issue 37


def _strokes_file(path, strokes, shape=(48, 64)):
    data = {"format": "fluidnb.strokes", "version": 1, "shape": list(shape), "strokes": strokes}
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("strokes", "message"),
    [
        # Reshaped into the points (30, 5), (0, 30), (60, 0) before: different, accepted.
        (
            [[[30, 5, 0], [30, 60, 0]]],
            r"strokes\[0\] point 0 is \[30, 5, 0\]: it has 3 coordinates; a point has two",
        ),
        ([[[1, 2], [30, 60]], [[5, 5], [6]]], r"strokes\[1\] point 1 is \[6\]: it has 1 coord"),
        ([[[30, 5], [True, 60]]], r"strokes\[0\] point 1 is \[True, 60\]: coordinates must"),
        ([[[30, False], [30, 60]]], r"strokes\[0\] point 0 is \[30, False\]: coordinates must"),
        ([[[30, "5"], [30, 60]]], r"strokes\[0\] point 0 is \[30, '5'\]: coordinates must be"),
        ([[[30, None], [30, 60]]], r"strokes\[0\] point 0 is \[30, None\]: coordinates must"),
    ],
)
def test_points_that_are_not_two_numbers_are_refused_naming_stroke_and_point(
    tmp_path, strokes, message
):
    path = _strokes_file(tmp_path / "s.json", strokes)
    with pytest.raises(ValueError, match=r"strokes file '.*s.json': " + message):
        load_strokes(path)
    with pytest.raises(ValueError, match=message):
        save_strokes(tmp_path / "t.json", strokes, (48, 64))
    assert not (tmp_path / "t.json").exists()


def test_well_formed_points_of_any_number_type_are_kept(tmp_path):
    strokes = [[[1, 2.5], (3, 4)], np.array([[5, 6], [7, 8]], np.int16)]
    path = save_strokes(tmp_path / "s.json", strokes, (48, 64))
    back, _ = load_strokes(path)
    assert [s.tolist() for s in back] == [[[1, 2.5], [3, 4]], [[5, 6], [7, 8]]]


def test_a_strokes_file_nested_too_deeply_or_a_fifo_is_one_clear_error(tmp_path):
    import os

    head = '{"format": "fluidnb.strokes", "version": 1, "shape": [48, 64], "strokes": '
    (tmp_path / "deep.json").write_text(head + "[" * 200_000 + "]" * 200_000 + "}")
    with pytest.raises(ValueError, match=r"strokes: cannot read '.*deep.json' as JSON \(it is"):
        load_strokes(tmp_path / "deep.json")
    os.mkfifo(tmp_path / "pipe.json")
    with pytest.raises(ValueError, match=r"strokes: '.*pipe.json' is a named pipe \(FIFO\)"):
        load_strokes(tmp_path / "pipe.json")


def test_saving_strokes_replaces_the_file_only_once_they_are_written(tmp_path, monkeypatch):
    path = save_strokes(tmp_path / "s.json", [[[1, 1], [2, 2]]], (48, 64))
    before = path.read_bytes()

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    from pathlib import Path

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError, match=r"cannot write '.*s.json': No space left on device"):
        save_strokes(path, [[[3, 3], [4, 4]]], (48, 64))
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]
