import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.fields import advect, backward_warp

SCIPY_MODE = {
    "nearest": "nearest",
    "constant": "grid-constant",
    "wrap": "grid-wrap",
    "reflect": "reflect",
}


def _fields(rng, h=23, w=31):
    return {
        "scalar": rng.random((h, w)).astype(np.float32),
        "rgb": rng.random((h, w, 3)).astype(np.float32),
        "vector": rng.normal(0, 2, (h, w, 2)).astype(np.float32),
        "scalar64": rng.random((h, w)),
    }


def _reference(field, y, x, order, mode, cval=0.0):
    coords = np.stack([y, x])
    if field.ndim == 2:
        return ndi.map_coordinates(field, coords, order=order, mode=SCIPY_MODE[mode], cval=cval)
    return np.stack(
        [
            ndi.map_coordinates(
                field[..., c], coords, order=order, mode=SCIPY_MODE[mode], cval=cval
            )
            for c in range(field.shape[2])
        ],
        axis=-1,
    )


@pytest.mark.parametrize("kind", ["scalar", "rgb", "vector", "scalar64"])
@pytest.mark.parametrize("mode", ["nearest", "constant", "wrap", "reflect"])
@pytest.mark.parametrize("order", [0, 1, 3])
def test_zero_motion_is_exact_identity(kind, mode, order):
    field = _fields(np.random.default_rng(0))[kind]
    zero = np.zeros((*field.shape[:2], 2), dtype=np.float32)
    for out in (
        backward_warp(field, zero, order=order, mode=mode),
        advect(field, zero, 3.7, order=order, mode=mode),
    ):
        assert out.dtype == field.dtype
        assert out.shape == field.shape
        if order == 3:  # spline prefilter then evaluation: rounding only
            np.testing.assert_allclose(out, field, rtol=0, atol=1e-5)
        else:
            assert np.array_equal(out, field)
            assert out is not field


def test_dt_zero_is_identity_under_any_velocity():
    rng = np.random.default_rng(1)
    f = rng.random((20, 30, 3)).astype(np.float32)
    v = rng.normal(0, 5, (20, 30, 2))
    assert np.array_equal(advect(f, v, 0.0), f)


def test_velocity_advects_itself():
    rng = np.random.default_rng(2)
    v = rng.normal(0, 1, (16, 16, 2)).astype(np.float32)
    out = advect(v, v, 0.5)
    assert out.shape == v.shape
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, _reference(v, *_coords(v, -0.5), 1, "nearest"), atol=1e-6)


@pytest.mark.parametrize("mode", ["nearest", "constant", "wrap", "reflect"])
def test_constant_field_stays_constant(mode):
    rng = np.random.default_rng(3)
    f = np.full((40, 50, 3), 0.3, dtype=np.float32)
    v = rng.normal(0, 6, (40, 50, 2))
    out = advect(f, v, 1.3, mode=mode, cval=0.3)
    np.testing.assert_allclose(out, 0.3, rtol=0, atol=1e-6)
    if mode != "constant":
        assert np.all(out == np.float32(0.3))  # the lerp form keeps constants exact


def test_integer_translation_moves_content_right_and_down():
    rng = np.random.default_rng(4)
    img = rng.random((30, 40, 3)).astype(np.float32)
    v = np.zeros((30, 40, 2))
    v[..., 1] = 1.0  # dx = +1: content moves to the right
    out = advect(img, v)
    assert np.array_equal(out[:, 1:], img[:, :-1])  # out[r, c] == in[r, c - 1]
    v = np.zeros((30, 40, 2))
    v[..., 0] = 2.0  # dy = +2: content moves down by two rows
    out = advect(img, v)
    assert np.array_equal(out[2:], img[:-2])
    # Two pixels right and three up over dt = 0.5.
    v = np.zeros((30, 40, 2))
    v[..., 0], v[..., 1] = -6.0, 4.0
    out = advect(img, v, 0.5)
    assert np.array_equal(out[:-3, 2:], img[3:, :-2])


def test_translation_clamps_at_border():
    img = np.arange(5, dtype=np.float32)[None, :].repeat(3, axis=0)
    v = np.zeros((3, 5, 2))
    v[..., 1] = 2.0
    out = advect(img, v)
    assert np.array_equal(out[0], [0, 0, 0, 1, 2])


def test_backward_warp_reads_from_displaced_position():
    rng = np.random.default_rng(5)
    img = rng.random((12, 14)).astype(np.float32)
    d = np.zeros((12, 14, 2))
    d[..., 1] = 3.0
    out = backward_warp(img, d)
    assert np.array_equal(out[:, :-3], img[:, 3:])  # out(x) = img(x + d)


def test_subpixel_shift_is_linear_interpolation():
    rng = np.random.default_rng(6)
    img = rng.random((10, 20)).astype(np.float64)
    v = np.zeros((10, 20, 2))
    v[..., 1] = 0.25  # out[c] = img[c - 0.25] = 0.75 img[c] + 0.25 img[c - 1]
    out = advect(img, v)
    expected = 0.75 * img[:, 1:] + 0.25 * img[:, :-1]
    np.testing.assert_allclose(out[:, 1:], expected, rtol=0, atol=1e-12)
    v = np.zeros((10, 20, 2))
    v[..., 0], v[..., 1] = -0.5, -0.5  # read from (r + 0.5, c + 0.5): mean of 4
    out = advect(img, v)
    expected = 0.25 * (img[:-1, :-1] + img[1:, :-1] + img[:-1, 1:] + img[1:, 1:])
    np.testing.assert_allclose(out[:-1, :-1], expected, rtol=0, atol=1e-12)


def _coords(field, scale, d=None):
    h, w = field.shape[:2]
    if d is None:
        d = field
    y = np.arange(h)[:, None] + scale * d[..., 0].astype(np.float64)
    x = np.arange(w)[None, :] + scale * d[..., 1].astype(np.float64)
    return y, x


@pytest.mark.parametrize("kind", ["scalar", "rgb", "vector", "scalar64"])
@pytest.mark.parametrize("mode", ["nearest", "constant", "wrap", "reflect"])
@pytest.mark.parametrize("order", [0, 1, 3])
def test_agrees_with_map_coordinates(kind, mode, order):
    rng = np.random.default_rng(7)
    field = _fields(rng)[kind]
    # Large displacements reach far outside the grid, exercising every boundary rule.
    v = rng.normal(0, 15, (*field.shape[:2], 2))
    if order == 0:  # fractions of 0.2: away from .5 ties, where rounding rules differ
        v = (np.round(v) + 0.2) / -0.7
    out = advect(field, v, 0.7, order=order, mode=mode, cval=0.4)
    ref = _reference(field, *_coords(field, -0.7, v), order, mode, cval=0.4)
    assert out.dtype == field.dtype
    tol = 1e-12 if field.dtype == np.float64 else 2e-6
    np.testing.assert_allclose(out, ref, rtol=0, atol=tol)


@pytest.mark.parametrize("mode", ["nearest", "constant", "wrap", "reflect"])
@pytest.mark.parametrize("shape", [(200, 150, 3), (3, 9000), (1, 1, 2), (300, 1)])
def test_fast_path_agrees_on_large_and_odd_grids(shape, mode):
    # Several row blocks with a partial last one, a row wider than a block, single
    # pixels: the blocked bilinear path must still match map_coordinates everywhere.
    rng = np.random.default_rng(10)
    field = rng.random(shape).astype(np.float32)
    v = rng.normal(0, 4, (*shape[:2], 2))
    out = advect(field, v, mode=mode, cval=0.2)
    ref = _reference(field, *_coords(field, -1.0, v), 1, mode, cval=0.2)
    np.testing.assert_allclose(out, ref, rtol=0, atol=2e-6)


@pytest.mark.parametrize(
    "view",
    [
        lambda a: a[::-1, ::2],
        lambda a: np.asfortranarray(a),
        lambda a: a[..., ::-1],
        lambda a: a.transpose(1, 0, 2),
    ],
)
def test_non_contiguous_inputs(view):
    rng = np.random.default_rng(11)
    field = view(rng.random((40, 40, 3)).astype(np.float32))
    v = view(rng.normal(0, 2, (40, 40, 2)))
    out = advect(field, v)
    assert out.flags.c_contiguous
    ref = _reference(np.ascontiguousarray(field), *_coords(field, -1.0, v), 1, "nearest")
    np.testing.assert_allclose(out, ref, rtol=0, atol=2e-6)
    zero = np.zeros_like(v)
    assert np.array_equal(advect(field, zero), field)


def test_constant_mode_fades_to_cval():
    img = np.ones((4, 4), dtype=np.float32)
    d = np.zeros((4, 4, 2))
    d[..., 1] = -0.5  # half a pixel outside on the left
    out = backward_warp(img, d, mode="constant", cval=0.0)
    np.testing.assert_allclose(out[:, 0], 0.5)
    np.testing.assert_allclose(out[:, 1:], 1.0)


def test_wrap_is_periodic():
    rng = np.random.default_rng(8)
    img = rng.random((8, 9)).astype(np.float32)
    v = np.zeros((8, 9, 2))
    v[..., 1] = 9.0 * 3 + 2
    assert np.array_equal(advect(img, v, mode="wrap"), np.roll(img, 2, axis=1))


def test_inputs_are_not_modified_and_integer_input_gives_float32():
    rng = np.random.default_rng(9)
    img = (rng.random((6, 7)) * 255).astype(np.uint8)
    v = rng.normal(0, 1, (6, 7, 2))
    img0, v0 = img.copy(), v.copy()
    out = advect(img, v, mode="constant")
    assert out.dtype == np.float32
    assert np.array_equal(img, img0)
    assert np.array_equal(v, v0)


def test_large_grid_uses_accurate_coordinates():
    # 5000 + 0.001 is not representable to that precision in float32 coordinates.
    img = np.tile(np.arange(6000, dtype=np.float64), (2, 1))
    v = np.zeros((2, 6000, 2))
    v[..., 1] = -0.001
    out = advect(img, v)
    np.testing.assert_allclose(out[0, 5000], 5000.001, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"field": np.zeros(5)}, "field"),
        ({"field": np.zeros((2, 3, 4, 5))}, "field"),
        ({"field": np.full((4, 4), np.nan)}, "field"),
        ({"field": np.zeros((0, 4))}, "field"),
        ({"velocity": np.zeros((4, 5, 2))}, "velocity"),
        ({"velocity": np.zeros((4, 4, 3))}, "velocity"),
        ({"velocity": np.zeros((4, 4))}, "velocity"),
        ({"velocity": np.full((4, 4, 2), np.inf)}, "velocity"),
        ({"dt": float("nan")}, "dt"),
        ({"dt": "1"}, "dt"),
        ({"order": 2}, "order"),
        ({"order": 1.5}, "order"),
        ({"mode": "mirror"}, "mode"),
        ({"cval": float("nan")}, "cval"),
    ],
)
def test_bad_inputs_raise(kwargs, match):
    args = {"field": np.zeros((4, 4)), "velocity": np.zeros((4, 4, 2)), "dt": 1.0}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        advect(args.pop("field"), args.pop("velocity"), args.pop("dt"), **args)


def test_bad_displacement_raises():
    with pytest.raises(ValueError, match="displacement"):
        backward_warp(np.zeros((4, 4, 3)), np.zeros((4, 3, 2)))
