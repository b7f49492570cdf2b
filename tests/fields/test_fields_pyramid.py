import math

import numpy as np
import pytest

from fluidnb.fields import (
    collapse,
    downsample,
    expand,
    gaussian_pyramid,
    laplacian_pyramid,
    pyramid_blend,
)


@pytest.mark.parametrize("shape", [(37, 53), (37, 53, 3), (64, 64), (128, 192, 2), (5, 9)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_collapse_returns_input(shape, dtype):
    img = np.random.default_rng(0).random(shape).astype(dtype)
    pyr = laplacian_pyramid(img)
    assert all(p.dtype == dtype for p in pyr)
    out = collapse(pyr)
    assert out.dtype == dtype
    assert out.shape == img.shape
    atol = 1e-6 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(out, img, rtol=0, atol=atol)


@pytest.mark.parametrize("levels", [1, 2, 4, 7])
def test_collapse_explicit_levels_and_sigma(levels):
    img = np.random.default_rng(1).random((37, 53, 3))
    pyr = laplacian_pyramid(img, levels, sigma=1.6)
    assert len(pyr) == levels
    np.testing.assert_allclose(collapse(pyr, sigma=1.6), img, rtol=0, atol=1e-12)


def test_pyramid_level_shapes():
    pyr = gaussian_pyramid(np.zeros((37, 53, 3), dtype=np.float32), 5)
    assert [p.shape for p in pyr] == [
        (37, 53, 3),
        (19, 27, 3),
        (10, 14, 3),
        (5, 7, 3),
        (3, 4, 3),
    ]
    lap = laplacian_pyramid(np.zeros((37, 53)), 5)
    assert [p.shape for p in lap] == [p.shape[:2] for p in pyr]


@pytest.mark.parametrize(
    ("shape", "n"), [((37, 53), 3), ((128, 192), 5), ((7, 100), 1), ((16, 16), 2)]
)
def test_default_levels_stop_near_eight_pixels(shape, n):
    pyr = gaussian_pyramid(np.zeros(shape))
    assert len(pyr) == n
    assert min(pyr[-1].shape) >= 8 or n == 1
    h, w = pyr[-1].shape
    assert min(math.ceil(h / 2), math.ceil(w / 2)) < 8


def test_gaussian_pyramid_first_level_is_a_copy_and_channels_do_not_mix():
    rng = np.random.default_rng(2)
    img = rng.random((40, 30, 3)).astype(np.float32)
    pyr = gaussian_pyramid(img, 3)
    assert np.array_equal(pyr[0], img)
    assert pyr[0] is not img
    single = gaussian_pyramid(img[..., 1], 3)
    for level, level1 in zip(pyr, single, strict=True):
        np.testing.assert_allclose(level[..., 1], level1, atol=1e-7)


def test_gaussian_pyramid_smooths():
    checker = (np.indices((64, 64)).sum(axis=0) % 2).astype(np.float64)
    pyr = gaussian_pyramid(checker, 3)
    assert pyr[1].std() < 0.1 * checker.std()


@pytest.mark.parametrize("channels", [(), (3,)])
def test_laplacian_bands_of_constant_are_zero_except_residual(channels):
    img = np.full((37, 53, *channels), 0.6, dtype=np.float32)
    pyr = laplacian_pyramid(img, 4)
    for band in pyr[:-1]:
        np.testing.assert_allclose(band, 0.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(pyr[-1], 0.6, rtol=0, atol=1e-6)


def test_expand_constant_and_shape():
    out = expand(np.full((10, 14, 3), 0.2, dtype=np.float32), (19, 27))
    assert out.shape == (19, 27, 3)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, 0.2, atol=1e-6)


@pytest.mark.parametrize("shape", [(37, 53), (40, 60, 3)])
def test_blend_identical_inputs_returns_input(shape):
    rng = np.random.default_rng(3)
    img = rng.random(shape).astype(np.float32)
    w = rng.random(shape[:2])
    out = pyramid_blend(img, img, w)
    assert out.dtype == np.float32
    assert out.shape == img.shape
    np.testing.assert_allclose(out, img, rtol=0, atol=1e-6)


def test_blend_weight_ones_and_zeros():
    rng = np.random.default_rng(4)
    a = rng.random((37, 53, 3)).astype(np.float32)
    b = rng.random((37, 53, 3)).astype(np.float32)
    np.testing.assert_allclose(pyramid_blend(a, b, np.ones((37, 53))), a, atol=1e-6)
    np.testing.assert_allclose(pyramid_blend(a, b, np.zeros((37, 53))), b, atol=1e-6)
    # A boolean mask is accepted as a weight.
    np.testing.assert_allclose(
        pyramid_blend(a, b, np.ones((37, 53), dtype=bool), levels=3), a, atol=1e-6
    )


def test_blend_hard_edge_gives_smooth_monotone_seam():
    a = np.ones((48, 64), dtype=np.float64)  # white
    b = np.zeros((48, 64), dtype=np.float64)  # black
    w = np.zeros((48, 64))
    w[:, :32] = 1.0
    out = pyramid_blend(a, b, w)
    assert out.min() >= -1e-12
    assert out.max() <= 1 + 1e-12
    for row in out:
        assert np.all(np.diff(row) <= 1e-12)  # monotone: white to black, left to right
    # Several pixels lie strictly inside the transition: the seam is soft, not a step.
    transition = np.count_nonzero((out[24] > 0.05) & (out[24] < 0.95))
    assert transition >= 6
    np.testing.assert_allclose(out[:, 0], 1.0, atol=1e-3)
    np.testing.assert_allclose(out[:, -1], 0.0, atol=1e-3)
    # With one level it is the plain per-pixel mix.
    assert np.array_equal(pyramid_blend(a, b, w, levels=1), w)


def test_blend_keeps_detail_far_from_seam():
    rng = np.random.default_rng(5)
    a = rng.random((64, 64)).astype(np.float32)
    b = rng.random((64, 64)).astype(np.float32)
    w = np.zeros((64, 64))
    w[:, :32] = 1.0
    out = pyramid_blend(a, b, w, levels=3)
    np.testing.assert_allclose(out[:, :8], a[:, :8], atol=0.02)
    np.testing.assert_allclose(out[:, -8:], b[:, -8:], atol=0.02)


def test_inputs_not_modified():
    rng = np.random.default_rng(6)
    a = rng.random((20, 20)).astype(np.float32)
    b = rng.random((20, 20)).astype(np.float32)
    w = rng.random((20, 20))
    copies = [x.copy() for x in (a, b, w)]
    pyramid_blend(a, b, w)
    pyr = laplacian_pyramid(a, 3)
    pyr_copy = [p.copy() for p in pyr]
    collapse(pyr)
    for x, x0 in zip((a, b, w), copies, strict=True):
        assert np.array_equal(x, x0)
    for p, p0 in zip(pyr, pyr_copy, strict=True):
        assert np.array_equal(p, p0)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: gaussian_pyramid(np.zeros((8, 8)), 0), "levels"),
        (lambda: gaussian_pyramid(np.zeros((8, 8)), 2.5), "levels"),
        (lambda: laplacian_pyramid(np.zeros((8, 8)), -1), "levels"),
        (lambda: laplacian_pyramid(np.zeros(8), 2), "image"),
        (lambda: laplacian_pyramid(np.full((8, 8), np.nan), 2), "image"),
        (lambda: gaussian_pyramid(np.zeros((8, 8)), 2, sigma=-1), "sigma"),
        (lambda: expand(np.zeros((4, 4)), (0, 8)), "shape"),
        (lambda: collapse([]), "pyramid"),
        (lambda: collapse(np.zeros((4, 4))), "pyramid"),
        (lambda: collapse([np.zeros((4, 4, 3)), np.zeros((2, 2))]), "pyramid"),
        (lambda: pyramid_blend(np.zeros((8, 8)), np.zeros((8, 9)), np.zeros((8, 8))), "b"),
        (lambda: pyramid_blend(np.zeros((8, 8, 3)), np.zeros((8, 8)), np.zeros((8, 8))), "b"),
        (lambda: pyramid_blend(np.zeros((8, 8)), np.zeros((8, 8)), np.zeros((8, 7))), "weight"),
        (lambda: pyramid_blend(np.zeros((8, 8)), np.zeros((8, 8)), np.full((8, 8), 2.0)), "weight"),
        (lambda: pyramid_blend(np.zeros((8, 8)), np.zeros((8, 8)), np.zeros((8, 8, 1))), "weight"),
        (lambda: pyramid_blend(np.zeros((8, 8)), np.zeros((8, 8)), np.zeros((8, 8)), 0), "levels"),
    ],
)
def test_bad_inputs_raise(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize(("shape", "target"), [((10, 14, 3), (19, 27)), ((19, 27), (37, 53))])
def test_expand_without_blur_is_bilinear_resize(shape, target):
    from fluidnb.fields import resize

    x = np.random.default_rng(7).random(shape)
    np.testing.assert_allclose(
        expand(x, target, sigma=0), resize(x, target, anti_aliasing=False), atol=1e-12
    )


@pytest.mark.parametrize(
    "shape", [(37, 53, 3), (48, 72, 130), (5, 9, 1), (37, 53), (64, 96, 12), (6, 10, 2), (64, 53)]
)
@pytest.mark.parametrize("sigma", [1.0, 0.7, 0.0])
def test_float32_pyramids_are_the_float64_pyramids(shape, sigma):
    """precision="float32" equals the float64 pyramids to float32 rounding: beyond
    OpenCV's channel limit (chunks), on tiny odd levels, without blur, and where the
    levels halve exactly (the fused reduce and expand; on tiny levels the kernel
    reaches past the border more than once)."""
    x = np.random.default_rng(5).random(shape).astype(np.float32)
    levels = 4
    kw = {"sigma": sigma}
    fast = laplacian_pyramid(x, levels, precision="float32", **kw)
    for f, lib in zip(fast, laplacian_pyramid(x, levels, **kw), strict=True):
        assert f.dtype == np.float32
        assert f.shape == lib.shape
        np.testing.assert_allclose(f, lib, rtol=0, atol=2e-6)
    for f, lib in zip(
        gaussian_pyramid(x, levels, precision="float32", **kw), gaussian_pyramid(x, levels, **kw)
    ):
        assert f.shape == lib.shape
        np.testing.assert_allclose(f, lib, rtol=0, atol=2e-6)
    np.testing.assert_allclose(collapse(fast, precision="float32", **kw), x, rtol=0, atol=2e-6)
    coarse = fast[-1]
    np.testing.assert_allclose(
        expand(coarse, x.shape[:2], precision="float32", **kw),
        expand(coarse, x.shape[:2], **kw),
        rtol=0,
        atol=2e-6,
    )


def test_float32_pyramids_hand_out_new_arrays():
    """Like the float64 ones: the input is never a level, nor changed by editing one."""
    x = np.random.default_rng(6).random((16, 20, 3)).astype(np.float32)
    keep = x.copy()
    for pyr in (
        gaussian_pyramid(x, 1, precision="float32"),
        laplacian_pyramid(x, 1, precision="float32"),
        gaussian_pyramid(x, 3, precision="float32"),
    ):
        assert not np.shares_memory(pyr[0], x)
        pyr[0] += 1.0
    one = laplacian_pyramid(x, 1, precision="float32")
    back = collapse(one, precision="float32")
    assert not np.shares_memory(back, one[0])
    same = expand(x, x.shape[:2], sigma=0, precision="float32")
    np.testing.assert_array_equal(same, x)
    assert not np.shares_memory(same, x)
    np.testing.assert_array_equal(x, keep)


def test_float32_precision_is_checked():
    with pytest.raises(ValueError, match="precision must be one of"):
        gaussian_pyramid(np.zeros((8, 8)), precision="float16")
    with pytest.raises(ValueError, match="precision"):
        collapse([np.zeros((8, 8))], precision="half")


@pytest.mark.parametrize("shape", [(24, 36), (24, 36, 3), (12, 16, 200)])
def test_float32_block_means_are_the_block_means(shape):
    x = np.random.default_rng(8).random(shape).astype(np.float32)
    fast = downsample(x, 4, precision="float32")
    assert fast.dtype == np.float32
    np.testing.assert_allclose(fast, downsample(x, 4), rtol=0, atol=1e-6)
    v = np.random.default_rng(9).standard_normal((24, 36, 2)).astype(np.float32)
    np.testing.assert_allclose(
        downsample(v, 3, vector=True, precision="float32"),
        downsample(v, 3, vector=True),
        rtol=0,
        atol=1e-6,
    )
    with pytest.raises(ValueError, match="factor must divide"):
        downsample(x, 5, precision="float32")


@pytest.mark.parametrize("shape", [(64, 96, 12), (6, 10, 2), (24, 42, 1)])
@pytest.mark.parametrize("sigma", [1.0, 0.7])
def test_fused_reduce_and_expand_are_blur_and_resample(shape, sigma):
    """On even sides the float32 reduce (expand) filters and resamples in one step:
    the blur then the halving (the doubling then the blur) in OpenCV, to float32
    round-off, with the Laplacian's difference and the collapse's sum fused in."""
    from fluidnb.fields._pyramid import _blur32, _expand32, _half, _reduce32, _resize32

    rng = np.random.default_rng(11)
    x = rng.random(shape).astype(np.float32)
    np.testing.assert_allclose(
        _reduce32(x, sigma), _resize32(_blur32(x, sigma), _half(shape)), rtol=0, atol=1e-6
    )
    coarse = np.ascontiguousarray(x[::2, ::2])
    steps = _blur32(_resize32(coarse, shape[:2]), sigma)
    np.testing.assert_allclose(_expand32(coarse, shape[:2], sigma), steps, rtol=0, atol=1e-6)
    np.testing.assert_allclose(
        _expand32(coarse, shape[:2], sigma, x, -1.0), x - steps, rtol=0, atol=1e-6
    )
    np.testing.assert_allclose(
        _expand32(coarse, shape[:2], sigma, x, 1.0), x + steps, rtol=0, atol=1e-6
    )


def _weights_with_holes(rng, shape, levels):
    """A blend layer's weight pyramid: tents on a few cells of the left half, 0
    between and around them and on the right half."""
    from fluidnb.fields._pyramid import _gaussian32

    w = np.zeros(shape[:2] + (1,), np.float32)
    for r in range(4, shape[0] - 20, 30):
        for c in range(2, shape[1] // 2 - 20, 26):
            if rng.random() < 0.7:
                w[r : r + 16, c : c + 16, 0] = rng.random((16, 16)) + 0.1
    return _gaussian32(w, levels)


@pytest.mark.parametrize(
    ("shape", "levels", "gap"),
    [((96, 256, 1), 4, 0), ((96, 192, 3), 3, 32), ((90, 250, 2), 3, 5), ((96, 128, 1), 1, 0)],
)
def test_weighted_bands_on_spans_are_the_bands_weighted_bit_for_bit(shape, levels, gap):
    """The blend's bands made only where the weight is not 0: on every pixel with a
    weight, ``_laplacian32(x)[l] * G_l(W)`` bit for bit (the same float32 sums, the
    same product), and the spans leave no weighted pixel out but skip the rest
    (gap 0); the input is read only where ``need`` says (NaN elsewhere changes
    nothing). Odd sizes (90 x 250: a level of odd size) take OpenCV's reduce and
    expansion. Mutations caught: a run one pixel short (a weighted pixel skipped),
    the expansion's coarse row one off, the weight left out of a level, the reduce's
    reads one column short."""
    from fluidnb.fields._pyramid import _laplacian32, _weight_spans32, _weighted_laplacian32
    from fluidnb.fields._pyramid_fused import spans_mask

    rng = np.random.default_rng(5)
    x = rng.standard_normal(shape).astype(np.float32)
    weights = _weights_with_holes(rng, shape, levels)
    spans = _weight_spans32(weights, gap=gap)
    want = [band * g for band, g in zip(_laplacian32(x.copy(), levels), weights, strict=True)]
    partial = x.copy()
    need = spans[0][3]
    if need is not None:
        partial[~spans_mask(*need, shape[1])] = np.nan
        assert np.isnan(partial).mean() > 0.1
    got = _weighted_laplacian32(partial, weights, spans)
    for level, (a, b, g, (ptr, runs, _, _)) in enumerate(
        zip(got, want, weights, spans, strict=True)
    ):
        inside = spans_mask(ptr, runs, g.shape[1])
        assert np.all(inside[g[..., 0] != 0]), level  # no weighted pixel skipped
        if gap == 0:
            assert np.array_equal(inside, g[..., 0] != 0)  # and nothing else made
        assert np.array_equal(a[inside].view(np.uint32), b[inside].view(np.uint32)), level
    assert np.mean(want[0] == 0) > 0.3  # zeros to skip at level 0


def test_mask_spans_are_the_runs_merged_across_small_gaps():
    from fluidnb.fields._pyramid_fused import mask_spans

    mask = np.array([[0, 1, 1, 0, 0, 1, 0, 0, 0, 0, 1, 1], [0] * 12, [1] * 12], bool)
    ptr, runs = mask_spans(mask)
    assert ptr.tolist() == [0, 3, 3, 4]
    assert runs.tolist() == [[1, 3], [5, 6], [10, 12], [0, 12]]
    ptr, runs = mask_spans(mask, 4)  # a gap of 2 merged, of 4 not
    assert ptr.tolist() == [0, 2, 2, 3]
    assert runs.tolist() == [[1, 6], [10, 12], [0, 12]]
