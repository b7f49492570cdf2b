import numpy as np
import pytest

from fluidnb.sketch import (
    arrow_heads,
    flood_fill,
    paint_disk,
    paint_segment,
    quiver_segments,
    scalar_to_rgba,
    segment_heads,
)


def test_paint_disk_area_and_value():
    a = np.zeros((41, 41), np.float32)
    paint_disk(a, (20, 20), 10, 0.7)
    assert set(np.unique(a)) == {0.0, np.float32(0.7)}
    assert abs(np.count_nonzero(a) - np.pi * 100) < 0.05 * np.pi * 100


def test_paint_segment_is_a_continuous_band_and_returns_box():
    a = np.zeros((20, 50), bool)
    box = paint_segment(a, (10, 2), (10, 47), 1.5, True)
    assert a[10, 2:48].all()
    assert not a[:7].any()
    assert not a[14:].any()
    assert a[box].sum() == a.sum()


def test_paint_off_map_is_harmless():
    a = np.zeros((5, 5))
    paint_segment(a, (-20, -20), (-10, -10), 2, 1.0)
    assert not a.any()
    paint_disk(a, (0, 0), 0, 1.0)
    assert a[0, 0] == 1.0
    assert a.sum() == 1.0


def test_flood_fill_returns_copy():
    a = np.zeros((6, 6), np.float32)
    a[:, 3] = 1
    out = flood_fill(a, (0, 0), 0.5)
    assert np.all(out[:, :3] == 0.5)
    assert np.all(out[:, 4:] == 0)
    assert np.all(a[:, :3] == 0)
    with pytest.raises(ValueError, match="start must lie inside"):
        flood_fill(a, (9, 0), 1)


def test_arrow_heads_point_back_along_last_segment():
    heads = arrow_heads(np.array([[5.0, 0.0], [5.0, 10.0]]), size=3, angle=30)
    assert heads.shape == (2, 2, 2)
    for tip, end in heads:
        assert tip.tolist() == [5.0, 10.0]
        assert end[1] < 10.0
        assert np.isclose(np.linalg.norm(end - tip), 3.0)
    assert arrow_heads([[1, 1], [1, 1]]).shape == (0, 2, 2)


def test_segment_heads_are_each_segments_arrow_heads():
    rng = np.random.default_rng(3)
    segs = rng.normal(0, 20, (40, 2, 2))
    segs[7, 1] = segs[7, 0]  # no length: no head
    heads = segment_heads(segs, size=3.5, angle=25)
    expected = np.concatenate([arrow_heads(s, size=3.5, angle=25) for s in segs])
    assert heads.shape == (78, 2, 2)
    np.testing.assert_allclose(heads, expected, rtol=0, atol=1e-12)
    assert segment_heads(np.empty((0, 2, 2))).shape == (0, 2, 2)
    with pytest.raises(ValueError, match="segments must have shape"):
        segment_heads(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="segments"):
        segment_heads(np.full((1, 2, 2), np.nan))


def test_quiver_segments():
    field = np.zeros((32, 32, 2), np.float32)
    field[..., 1] = 2.0
    segs = quiver_segments(field, step=8)
    assert segs.shape == (16, 2, 2)
    d = segs[:, 1] - segs[:, 0]
    assert np.allclose(d, [0.0, 7.2])
    assert quiver_segments(np.zeros((8, 8, 2)), step=4).shape == (0, 2, 2)
    fixed = quiver_segments(field, step=8, length=5)
    assert np.allclose(np.linalg.norm(fixed[:, 1] - fixed[:, 0], axis=1), 5)


def test_scalar_to_rgba():
    rgba = scalar_to_rgba(np.array([[0.0, 1.0]]), (1.0, 0.0, 0.0), opacity=0.5)
    assert rgba.dtype == np.uint8
    assert rgba[0, 0, 3] == 0
    assert rgba[0, 1].tolist() == [255, 0, 0, 128]
