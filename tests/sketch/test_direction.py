import numpy as np
import pytest

from fluidnb.sketch import direction_field, resample_stroke, stroke_tangents


def test_resample_stroke_is_evenly_spaced_and_keeps_ends():
    pts = resample_stroke([[0, 0], [0, 3], [4, 3]], 0.5)
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert np.allclose(steps, 0.5)
    assert pts[0].tolist() == [0, 0]
    assert pts[-1].tolist() == [4, 3]


def test_resample_stroke_with_repeated_vertices():
    pts = resample_stroke([[0, 0], [0, 0], [0, 2], [0, 2]], 1.0)
    assert pts[:, 1].tolist() == [0.0, 1.0, 2.0]


def test_stroke_tangents_follow_the_drawing_direction():
    points, tangents = stroke_tangents([np.array([[5.0, 0.0], [5.0, 20.0]])], spacing=2)
    assert np.allclose(tangents, [0.0, 1.0])
    assert np.allclose(points[:, 1], np.arange(0, 21, 2))
    _, tangents = stroke_tangents([np.array([[20.0, 3.0], [0.0, 3.0]])], spacing=2)
    assert np.allclose(tangents, [-1.0, 0.0])  # drawn upwards: dy < 0


def test_single_straight_stroke_gives_uniform_unit_field():
    field = direction_field([np.array([[16.0, 4.0], [16.0, 28.0]])], (32, 32))
    assert field.shape == (32, 32, 2)
    assert field.dtype == np.float32
    assert np.allclose(field[..., 0], 0.0, atol=1e-3)
    assert np.allclose(field[..., 1], 1.0, atol=1e-3)


def test_field_is_unit_length_and_matches_strokes_near_them():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 50)
    s1 = np.column_stack([20 + 5 * t, 10 + 80 * t])  # rightwards, top
    s2 = np.column_stack([80 - 60 * t, 70 + 5 * t])  # upwards, right
    field = direction_field([s1, s2], (100, 100), smoothing=0.0)
    norm = np.linalg.norm(field, axis=-1)
    assert np.allclose(norm, 1.0, atol=1e-4)
    for stroke in (s1, s2):
        pts, tan = stroke_tangents([stroke], spacing=10)
        idx = np.round(pts).astype(int).clip(0, 99)
        got = field[idx[:, 0], idx[:, 1]]
        assert np.mean(np.sum(got * tan, axis=1)) > 0.95
    assert rng is not None


def test_reversing_strokes_reverses_the_field():
    s = np.column_stack([np.linspace(10, 50, 20), np.linspace(5, 55, 20) ** 1.05])
    a = direction_field([s], (64, 80))
    b = direction_field([s[::-1]], (64, 80))
    assert np.allclose(a, -b, atol=1e-5)


def test_bad_strokes():
    with pytest.raises(ValueError, match="at least one stroke longer than one pixel"):
        direction_field([np.array([[3.0, 3.0], [3.2, 3.1]])], (10, 10))
    with pytest.raises(ValueError, match="at least one stroke"):
        direction_field([], (10, 10))
    with pytest.raises(ValueError, match=r"strokes\[0\] must have shape \(n, 2\)"):
        direction_field([np.zeros((4, 3))], (10, 10))
    with pytest.raises(ValueError, match=r"strokes\[0\] contains 1 NaN"):
        direction_field([np.array([[0.0, np.nan], [4, 4]])], (10, 10))
    with pytest.raises(ValueError, match="kernel must be one of"):
        direction_field([np.array([[0, 0], [0, 9]])], (10, 10), kernel="nope")


def _wiggly_strokes(seed, count=60):
    gen = np.random.default_rng(seed)
    strokes = []
    for i in range(count):
        pts = np.cumsum(gen.normal(0, 6, (gen.integers(1, 12), 2)), axis=0) + 50
        if i % 7 == 0 and len(pts) > 2:
            pts[1] = pts[0]  # a repeated vertex
        if i % 11 == 0:
            pts = np.repeat(pts[:1], 3, axis=0)  # a dot: no direction
        strokes.append(pts)
    strokes.append(np.array([[3.0, 3.0], [3.2, 3.1]]))  # shorter than a pixel
    return strokes


@pytest.mark.parametrize("spacing", [0.7, 2.0, 8.0, 50.0])
def test_all_strokes_at_once_sample_as_the_loop_over_strokes(spacing):
    from fluidnb.sketch import _reference

    strokes = _wiggly_strokes(1)
    points, tangents = stroke_tangents(strokes, spacing)
    want_points, want_tangents = _reference.stroke_tangents(strokes, spacing)
    assert points.shape == want_points.shape
    np.testing.assert_allclose(points, want_points, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tangents, want_tangents, rtol=0, atol=1e-9)


def test_many_short_strokes_are_merged_into_at_most_max_samples():
    # 20,000 strokes of two points: rightwards in the top half, leftwards below.
    gen = np.random.default_rng(2)
    starts = gen.uniform([0, 0], [100, 150], (20_000, 2))
    sign = np.where(starts[:, 0] < 50, 1.0, -1.0)
    strokes = list(np.stack([starts, starts + np.column_stack([0 * sign, 3 * sign])], axis=1))
    from fluidnb.sketch._direction import _merge_samples, _tangents

    points, tangents = _tangents(strokes, 5.0)
    assert len(points) == 40_000  # two samples a stroke: what the RBF could not take
    merged, directions = _merge_samples(points, tangents, 400)
    assert 300 <= len(merged) <= 400
    assert np.allclose(np.linalg.norm(directions, axis=1)[np.abs(merged[:, 0] - 50) > 10], 1)
    field = direction_field(strokes, (100, 150))
    assert np.all(field[10:40, :, 1] > 0.95)  # right, well inside the top half
    assert np.all(field[60:90, :, 1] < -0.95)  # left below
