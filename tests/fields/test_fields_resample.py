import numpy as np
import pytest

from fluidnb.fields import downsample, resize, resize_vector_field, upsample


@pytest.mark.parametrize("shape", [(5, 7), (37, 53), (80, 120), (128, 192)])
@pytest.mark.parametrize("order", [0, 1, 3])
@pytest.mark.parametrize("channels", [(), (3,)])
def test_resize_of_constant_is_constant(shape, order, channels):
    img = np.full((40, 60, *channels), 0.7, dtype=np.float32)
    out = resize(img, shape, order=order)
    assert out.shape == (*shape, *channels)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, 0.7, rtol=0, atol=1e-6)


def test_resize_keeps_float64_and_converts_integers():
    assert resize(np.zeros((4, 4)), (8, 8)).dtype == np.float64
    assert resize(np.zeros((4, 4), dtype=np.uint8), (8, 8)).dtype == np.float32
    assert resize(np.zeros((4, 4), dtype=bool), (2, 2)).dtype == np.float32


def test_resize_accepts_full_shape_and_same_shape_is_a_copy():
    img = np.random.default_rng(0).random((6, 8, 3)).astype(np.float32)
    out = resize(img, img.shape)
    assert np.array_equal(out, img)
    assert out is not img


def test_resize_anti_aliasing_default_blurs_when_shrinking():
    noise = np.random.default_rng(4).random((64, 64)).astype(np.float32)
    smooth = resize(noise, (16, 16))
    sharp = resize(noise, (16, 16), anti_aliasing=False)
    assert smooth.std() < 0.5 * sharp.std()
    np.testing.assert_allclose(smooth, resize(noise, (16, 16), anti_aliasing=True))
    # Upsampling is never blurred by default.
    assert np.array_equal(resize(noise, (128, 128)), resize(noise, (128, 128), anti_aliasing=False))


def test_resize_channels_are_independent():
    rng = np.random.default_rng(1)
    img = rng.random((20, 30, 3)).astype(np.float32)
    out = resize(img, (13, 41))
    for c in range(3):
        np.testing.assert_allclose(out[..., c], resize(img[..., c], (13, 41)), atol=1e-7)


def test_resize_vector_field_rescales_uniform_field():
    v = np.zeros((16, 24, 2), dtype=np.float32)
    v[..., 0], v[..., 1] = 0.5, -1.25
    out = resize_vector_field(v, (128, 96))
    assert out.shape == (128, 96, 2)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out[..., 0], 0.5 * 8, atol=1e-5)
    np.testing.assert_allclose(out[..., 1], -1.25 * 4, atol=1e-5)
    back = resize_vector_field(out, (16, 24))
    np.testing.assert_allclose(back, v, atol=1e-5)


def test_vector_up_and_downsample_rescale():
    v = np.zeros((16, 24, 2), dtype=np.float32)
    v[..., 1] = 1.0
    up = upsample(v, 8, vector=True)
    assert up.shape == (128, 192, 2)
    np.testing.assert_allclose(up[..., 1], 8.0, atol=1e-5)
    np.testing.assert_allclose(up[..., 0], 0.0, atol=1e-6)
    down = downsample(up, 8, vector=True)
    np.testing.assert_allclose(down, v, atol=1e-6)


@pytest.mark.parametrize("channels", [(), (3,), (2,)])
def test_downsample_inverts_block_upsample(channels):
    rng = np.random.default_rng(2)
    small = rng.random((16, 24, *channels)).astype(np.float32)
    big = upsample(small, 8, order=0)
    assert big.shape == (128, 192, *channels)
    assert np.array_equal(big[:8, :8], np.broadcast_to(small[0, 0], (8, 8, *channels)))
    assert np.array_equal(downsample(big, 8), small)
    # And block-constant data at full resolution survives the round trip.
    assert np.array_equal(upsample(downsample(big, 8), 8, order=0), big)


def test_downsample_is_block_mean_and_keeps_constants_exact():
    x = np.arange(36, dtype=np.float64).reshape(6, 6)
    out = downsample(x, 3)
    np.testing.assert_allclose(out, [[7.0, 10.0], [25.0, 28.0]])
    c = np.full((9, 12), 0.1, dtype=np.float32)
    assert np.all(downsample(c, 3) == np.float32(0.1))


def test_downsample_non_divisible_shape_rounds_up():
    img = np.full((37, 53, 3), 0.25, dtype=np.float32)
    out = downsample(img, 4)
    assert out.shape == (10, 14, 3)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, 0.25, atol=1e-6)


def test_upsample_bilinear_of_constant_and_factor_one():
    img = np.full((5, 6), 0.4, dtype=np.float32)
    out = upsample(img, 3)
    assert out.shape == (15, 18)
    np.testing.assert_allclose(out, 0.4, atol=1e-6)
    assert np.array_equal(upsample(img, 1), img)
    assert np.array_equal(downsample(img, 1), img)


def test_inputs_not_modified():
    rng = np.random.default_rng(3)
    v = rng.random((8, 8, 2)).astype(np.float32)
    v0 = v.copy()
    resize_vector_field(v, (4, 4))
    upsample(v, 2, vector=True)
    downsample(v, 2, vector=True)
    assert np.array_equal(v, v0)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: resize(np.zeros((4, 4)), (0, 4)), "shape"),
        (lambda: resize(np.zeros((4, 4)), (4, -1)), "shape"),
        (lambda: resize(np.zeros((4, 4)), (4,)), "shape"),
        (lambda: resize(np.zeros((4, 4)), (4, 4, 3)), "shape"),
        (lambda: resize(np.zeros((4, 4)), (4.5, 4)), "shape"),
        (lambda: resize(np.zeros((4, 4)), 4), "shape"),
        (lambda: resize(np.zeros(4), (4, 4)), "field"),
        (lambda: resize(np.full((4, 4), np.nan), (2, 2)), "field"),
        (lambda: resize(np.zeros((4, 4)), (2, 2), order=2), "order"),
        (lambda: resize(np.zeros((4, 4)), (2, 2), anti_aliasing="yes"), "anti_aliasing"),
        (lambda: resize_vector_field(np.zeros((4, 4, 3)), (2, 2)), "velocity"),
        (lambda: resize_vector_field(np.zeros((4, 4, 2)), (0, 2)), "shape"),
        (lambda: downsample(np.zeros((4, 4)), 0), "factor"),
        (lambda: downsample(np.zeros((4, 4)), -2), "factor"),
        (lambda: downsample(np.zeros((4, 4)), 1.5), "factor"),
        (lambda: downsample(np.zeros((4, 4)), 2, vector=True), "field"),
        (lambda: upsample(np.zeros((4, 4)), 0), "factor"),
        (lambda: upsample(np.zeros((4, 4)), 2.5), "factor"),
        (lambda: upsample(np.zeros((4, 4)), 2, order=5), "order"),
        (lambda: upsample(np.zeros((4, 4, 3)), 2, vector=True), "field"),
    ],
)
def test_bad_inputs_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call()
