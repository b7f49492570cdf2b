"""The animation's appearance: pseudo motion blur and per-cell histogram matching (sec. 6)."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.videodb.rendering import (
    match_histograms_cells,
    motion_blur,
    reference_match_histograms_cells,
    reference_motion_blur,
)


def smooth_texture(gen, shape, blur):
    t = ndi.gaussian_filter(gen.standard_normal(shape), (0, blur, blur), mode="wrap")
    return (t / t.std()).astype(np.float32)


# --------------------------------------------------------------------------------------
# approximate mean image
# --------------------------------------------------------------------------------------


def test_motion_blur_identity_cases_are_exact():
    gen = np.random.default_rng(9)
    img = gen.random((20, 24, 3)).astype(np.float32)
    v = gen.standard_normal((20, 24, 2)).astype(np.float32)
    assert np.array_equal(motion_blur(img, v, shutter=0, denoise=0), img)
    assert np.array_equal(motion_blur(img, np.zeros_like(v), shutter=3, denoise=2), img)
    out = motion_blur(img, v, shutter=0, denoise=0)
    assert out is not img


def test_motion_blur_equals_its_plain_version():
    # The compiled line average and blur against the plain float64 whole-image warps
    # and blurs (reference_motion_blur), also past the border (fast motion near the
    # edges clamps) and for grey and colour images: one float32 rounding apart.
    # Mutation caught: the trapezoid's end weights made 1 (_shutter_samples).
    gen = np.random.default_rng(4)
    for shape in ((23, 31, 3), (17, 12)):
        img = gen.random(shape).astype(np.float32)
        v = 3 * gen.standard_normal((*shape[:2], 2)).astype(np.float32)
        for shutter, denoise in ((1.0, 0.0), (2.5, 0.0), (0.7, 0.5), (1.5, 1.2)):
            fast = motion_blur(img, v, shutter=shutter, denoise=denoise)
            slow = reference_motion_blur(img, v, shutter=shutter, denoise=denoise)
            assert fast.dtype == slow.dtype == np.float32
            np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6)
            assert np.abs(fast - img).max() > 0.3  # it did blur


def test_motion_blur_smears_along_the_motion_not_across():
    img = np.tile(np.array([0, 0, 1, 1], dtype=np.float32), (16, 8))  # vertical stripes
    v = np.zeros((16, 32, 2), dtype=np.float32)
    v[..., 0] = 2.0  # vertical motion: along the stripes
    along = motion_blur(img, v, shutter=2, denoise=0)
    assert np.array_equal(along, img)
    v = v[..., ::-1].copy()  # horizontal motion: across them
    across = motion_blur(img, v, shutter=2, denoise=0)
    inner = across[:, 6:-6]  # away from the clamped border
    assert inner.std() < 0.1 * img.std()
    np.testing.assert_allclose(inner.mean(), 0.5, atol=0.02)
    # only where it moves
    v[:, :16] = 0
    half = motion_blur(img, v, shutter=2, denoise=0)
    assert np.array_equal(half[:, :16], img[:, :16])
    assert half[:, 22:-6].std() < 0.1 * img.std()


def test_motion_blur_gaussian_grows_with_speed():
    gen = np.random.default_rng(10)
    img = gen.random((32, 64)).astype(np.float32)
    v = np.zeros((32, 64, 2), dtype=np.float32)
    v[:, 32:, 1] = 2.0  # the right half moves
    out = motion_blur(img, v, shutter=0, denoise=0.5)
    assert np.array_equal(out[:, :32], img[:, :32])  # sigma 0: untouched
    # sigma = 0.5 * 2 = 1 px, one of the pre-blurred levels: the plain Gaussian.
    expected = ndi.gaussian_filter(img, 1.0, mode="reflect")
    np.testing.assert_allclose(out[:, 40:], expected[:, 40:], rtol=0, atol=1e-6)
    # Between levels (sigma 1.2) the interpolation stays close to the true blur.
    v[:, 32:, 1] = 2.4
    out = motion_blur(img, v, shutter=0, denoise=0.5)
    expected = ndi.gaussian_filter(img, 1.2, mode="reflect")
    err = np.abs(out[:, 40:] - expected[:, 40:]).max()
    assert err < 0.1 * np.abs(img[:, 40:] - expected[:, 40:]).max()


def test_motion_blur_validates():
    img = np.zeros((8, 8), dtype=np.float32)
    with pytest.raises(ValueError, match="shutter must be >= 0"):
        motion_blur(img, np.zeros((8, 8, 2)), shutter=-1, denoise=0)
    with pytest.raises(ValueError, match="velocity"):
        motion_blur(img, np.zeros((8, 9, 2)), shutter=1, denoise=0)
    with pytest.raises(ValueError, match="denoise must be >= 0"):
        motion_blur(img, np.zeros((8, 8, 2)), shutter=1, denoise=-0.1)


# --------------------------------------------------------------------------------------
# per-cell histogram matching
# --------------------------------------------------------------------------------------


def test_matching_a_frame_to_itself_is_the_identity():
    gen = np.random.default_rng(11)
    ref = ndi.gaussian_filter(gen.random((40, 52, 3)), (2, 2, 0)).astype(np.float32)
    weight = gen.random((40, 52))
    weight[:, :10] = 0  # no fluid on the left
    for frames, reference in ((ref[None], ref), (ref[None, ..., 1], ref[..., 1])):
        out = match_histograms_cells(frames, reference, weight, cell=12)
        assert out.shape == frames.shape
        assert out.dtype == np.float32
        np.testing.assert_allclose(out, frames, rtol=0, atol=1e-6)


def _per_cell_distance(a, b, weight, cell):
    """Largest mean |sorted(a) - sorted(b)| over the cells (1-D Wasserstein distance of
    the weighted pixels), per channel."""
    worst = 0.0
    for r in range(0, a.shape[0], cell):
        for c in range(0, a.shape[1], cell):
            m = weight[r : r + cell, c : c + cell] > 0
            if m.sum() < 10:
                continue
            for ch in range(a.shape[2]):
                x = np.sort(a[r : r + cell, c : c + cell, ch][m])
                y = np.sort(b[r : r + cell, c : c + cell, ch][m])
                worst = max(worst, float(np.abs(x - y).mean()))
    return worst


def test_matching_undoes_a_brightness_and_contrast_change_per_cell():
    gen = np.random.default_rng(12)
    h, w = 48, 64
    ramp = np.linspace(0.1, 0.7, w, dtype=np.float32)[None, :, None]
    ref = np.clip(ramp + 0.15 * gen.standard_normal((h, w, 3)), 0, 1).astype(np.float32)
    weight = np.ones((h, w))
    weight[30:, 40:] = 0
    frames = np.stack([0.5 * ref + 0.3, 0.8 * ref**1.5])
    before = _per_cell_distance(frames[0], ref, weight, 16)
    out = match_histograms_cells(frames, ref, weight, cell=16)
    for t in range(2):
        assert _per_cell_distance(out[t], ref, weight, 16) < 0.01
    assert before > 0.1


def test_matching_blends_cells_without_a_seam():
    h, w, cell = 32, 64, 16
    ramp = np.tile(np.linspace(0.2, 0.6, w, dtype=np.float32), (h, 1))
    # The reference is the ramp lifted by a different amount in every cell column, so
    # the cells' maps differ a lot from one cell to the next.
    lift = np.repeat(np.array([0.0, 0.2, 0.05, 0.25], dtype=np.float32), cell)
    ref = ramp + lift
    weight = np.ones((h, w))
    out = match_histograms_cells(ramp[None], ref, weight, cell=cell)[0]
    # Matching each cell on its own (the same maps, no blending) jumps at the borders.
    own = np.empty_like(ramp)
    for c in range(0, w, cell):
        x = ramp[:, c : c + cell]
        y = ref[:, c : c + cell]
        own[:, c : c + cell] = np.interp(x, np.sort(x.ravel()), np.sort(y.ravel()))
    steps = np.abs(np.diff(out, axis=1)).max()
    assert np.abs(np.diff(own, axis=1)).max() > 0.15
    assert steps < 0.05
    # and the cells keep their own appearance around their centres
    centre = slice(cell // 2 - 1, cell // 2 + 1)
    for c in range(0, w, cell):
        np.testing.assert_allclose(
            out[:, c : c + cell][:, centre].mean(), ref[:, c + 7 : c + 9].mean(), atol=0.03
        )


def test_matching_kernels_match_the_reference():
    gen = np.random.default_rng(13)
    frames = gen.random((3, 37, 45, 3)).astype(np.float32)
    ref = ndi.gaussian_filter(gen.random((37, 45, 3)), (3, 3, 0)).astype(np.float32)
    weight = gen.random((37, 45))
    weight[:, :9] = 0
    weight[gen.random((37, 45)) < 0.2] = 0
    for cell in (7, 16):
        # Mutation caught: the histograms counting every pixel once, whatever its
        # weight in the matte (_histogram_kernel; the plain version bins on its own).
        fast = match_histograms_cells(frames, ref, weight, cell=cell)
        slow = reference_match_histograms_cells(frames, ref, weight, cell=cell)
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6)
        assert np.abs(fast - frames).max() > 0.05


def test_matching_keeps_frames_where_there_is_no_fluid():
    gen = np.random.default_rng(14)
    frames = gen.random((2, 20, 20)).astype(np.float32)
    out = match_histograms_cells(frames, gen.random((20, 20)), np.zeros((20, 20)), cell=8)
    assert np.array_equal(out, frames)


def test_matching_validates():
    frames = np.zeros((2, 8, 8, 3), dtype=np.float32)
    with pytest.raises(ValueError, match="reference must have the shape of one frame"):
        match_histograms_cells(frames, np.zeros((8, 8)), np.ones((8, 8)), cell=4)
    with pytest.raises(ValueError, match="weight must be >= 0"):
        match_histograms_cells(frames, frames[0], -np.ones((8, 8)), cell=4)
    with pytest.raises(ValueError, match="weight must have the frames' height and width"):
        match_histograms_cells(frames, frames[0], np.ones((8, 9)), cell=4)
    with pytest.raises(ValueError, match="cell must be an integer >= 2"):
        match_histograms_cells(frames, frames[0], np.ones((8, 8)), cell=1)


def test_inputs_are_never_modified():
    gen = np.random.default_rng(21)
    img = gen.random((24, 24, 3)).astype(np.float32)
    v = gen.standard_normal((24, 24, 2)).astype(np.float32)
    frames = gen.random((3, 24, 24, 3)).astype(np.float32)
    weight = gen.random((24, 24))
    args = [img, v, frames, weight]
    before = [a.copy() for a in args]
    motion_blur(img, v, shutter=2, denoise=0.5)
    match_histograms_cells(frames, img, weight, cell=8)
    for a, b in zip(args, before):
        assert np.array_equal(a, b)


def test_frames_go_into_the_colour_axes_and_back_as_numpy_computes_it():
    from fluidnb.videodb.rendering._colour_axes import colour_axes, frames_from_axes, frames_in_axes

    gen = np.random.default_rng(2)
    mean = gen.random((13, 17, 3)).astype(np.float32)
    d = (0.1 * gen.standard_normal((5, 13, 17))).astype(np.float32)
    matte = (gen.random((13, 17)) > 0.3).astype(np.float32)
    centre, axes = colour_axes(mean, matte)
    np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-6)  # orthonormal
    inside = mean[matte > 0.5]
    np.testing.assert_allclose(centre, inside.mean(axis=0), rtol=1e-6)
    variances = ((inside - centre) @ axes).var(axis=0)
    assert variances[0] >= variances[1] >= variances[2]  # largest first
    frames = mean[None] + d[..., None]
    rotated = frames_in_axes(mean, d, centre, axes)
    np.testing.assert_allclose(rotated, (frames - centre) @ axes, rtol=0, atol=1e-6)
    again, shown = frames_in_axes(mean, d, centre, axes, unmatched=(10, 12))
    assert np.array_equal(again, rotated)
    assert np.array_equal(shown, np.clip(frames[:, :10, :12], 0, 1))  # the same pass, exact
    back = frames_from_axes(rotated.copy(), centre, axes)
    np.testing.assert_allclose(back, rotated @ axes.T + centre, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back, frames, rtol=0, atol=2e-6)  # and back again


def test_matching_on_threads_is_matching_on_one(monkeypatch):
    from fluidnb.videodb.rendering import _threads

    gen = np.random.default_rng(6)
    frames = smooth_texture(gen, (5, 40, 56), 2.0)[..., None] * [1.0, 0.8, 0.6]
    ref = smooth_texture(gen, (1, 40, 56), 3.0)[0, ..., None] * [0.9, 1.0, 0.7]
    weight = gen.random((40, 56))
    threads = match_histograms_cells(frames, ref, weight, cell=16)
    monkeypatch.setattr(_threads, "_THREADS", 1)
    assert np.array_equal(match_histograms_cells(frames, ref, weight, cell=16), threads)


def test_matching_a_clip_in_parts_is_matching_it_at_once():
    # Each frame is binned over its own range: a frame's result does not depend on
    # the frames matched with it, so a renderer may match a clip a few frames at a
    # time (the app streams its clips so) and get the clip matched at once.
    gen = np.random.default_rng(13)
    ref = ndi.gaussian_filter(gen.random((30, 44, 3)), (2, 2, 0)).astype(np.float32)
    weight = gen.random((30, 44))
    # Frames of very different ranges: one alone would have had other bins in a batch.
    frames = np.stack([0.5 * ref + 0.2, 3.0 * ref - 1.0, ref**2]).astype(np.float32)
    whole = match_histograms_cells(frames, ref, weight, cell=10)
    for t in range(len(frames)):
        part = match_histograms_cells(frames[t : t + 1], ref, weight, cell=10)
        np.testing.assert_array_equal(part[0], whole[t])
    ref_whole = reference_match_histograms_cells(frames, ref, weight, cell=10)
    ref_part = reference_match_histograms_cells(frames[1:2], ref, weight, cell=10)
    np.testing.assert_array_equal(ref_part[0], ref_whole[1])


def test_the_renderers_one_pass_kernels_are_the_numpy_steps_bit_for_bit():
    # What render makes of a flow frame in one pass each: the phases' blend plus the
    # detail, into the colour axes; and back, composited, clipped, cropped.
    from fluidnb.videodb.rendering import composite
    from fluidnb.videodb.rendering._colour_axes import (
        _advected_in_axes,
        _composite_from_axes,
        colour_axes,
        colours_in_axes,
        frames_from_axes,
    )

    gen = np.random.default_rng(21)
    moved, back = (gen.random((14, 19, 3)).astype(np.float32) for _ in range(2))
    d = (0.2 * gen.standard_normal((14, 19))).astype(np.float32)
    matte = np.clip(gen.random((14, 19)) * 1.5 - 0.25, 0, 1).astype(np.float32)
    centre, axes = colour_axes(moved, matte)
    detail = np.float32(0.5)
    expected = colours_in_axes(moved + detail * d[..., None], centre, axes)
    got = np.empty_like(moved)
    _advected_in_axes(moved, detail, d, centre, axes, got)
    assert np.array_equal(got.view(np.uint32), expected.view(np.uint32))
    # Coordinates beyond [0, 1] once back in RGB: the clip shows.
    x = (3.0 * expected).astype(np.float32)
    rgb = composite(frames_from_axes(x.copy(), centre, axes)[None], back, matte)[0]
    expected = np.clip(rgb, 0, 1)[:11, :16]
    got = np.empty((11, 16, 3), np.float32)
    _composite_from_axes(x, centre, axes, back, matte, got)
    assert np.array_equal(got.view(np.uint32), expected.view(np.uint32))
