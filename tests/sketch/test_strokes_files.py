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
    with pytest.raises(ValueError, match=r"strokes\[0\] must have 2 dimensions"):
        save_strokes(tmp_path / "t.json", [[0, 1, 2]], (5, 5))
