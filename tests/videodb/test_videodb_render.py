"""Rendering building blocks of the video-database method (Okabe et al., sec. 6)."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.videodb._render import (
    blend_differences,
    composite,
    dynamic_matte,
    fragment_weights,
    inpaint_background,
    loop_crossfade,
    match_histograms_cells,
    motion_blur,
    reference_blend_differences,
    reference_match_histograms_cells,
)

# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def grid(shape):
    """Top-left corners of every fragment of the stride-24 grid on a canvas."""
    h, w = shape
    return np.array([(r, c) for r in range(0, h - 47, 24) for c in range(0, w - 47, 24)])


def crops(video, positions, margin):
    """Each fragment's (48 + 2m)-window of one sequence (N, H, W), reflected at the border."""
    padded = np.pad(video, ((0, 0), (margin, margin), (margin, margin)), mode="reflect")
    s = 48 + 2 * margin
    return np.stack([padded[:, r : r + s, c : c + s] for r, c in positions])


def paste_sum(weights, positions, shape):
    total = np.zeros(shape)
    for w, (r, c) in zip(weights, positions):
        total[r : r + 48, c : c + 48] += w
    return total


def covered(positions, shape):
    return paste_sum(np.ones((len(positions), 48, 48)), positions, shape) > 0


def smooth_texture(gen, shape, blur):
    t = ndi.gaussian_filter(gen.standard_normal(shape), (0, blur, blur), mode="wrap")
    return (t / t.std()).astype(np.float32)


# --------------------------------------------------------------------------------------
# partition-of-unity weights
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("feather", [0, 8, 24])
def test_weights_partition_unity_full_and_partial(feather):
    gen = np.random.default_rng(1)
    shape = (120, 144)
    pos = grid(shape)
    for subset in (pos, pos[gen.random(len(pos)) < 0.5]):
        w = fragment_weights(subset, shape, feather=feather)
        assert w.shape == (len(subset), 48, 48)
        assert w.min() >= 0
        total = paste_sum(w, subset, shape)
        inside = covered(subset, shape)
        np.testing.assert_allclose(total[inside], 1.0, rtol=0, atol=1e-12)
        assert np.all(total[~inside] == 0)


def test_weights_are_the_tent_inside_a_full_grid():
    pos = grid((120, 120))
    w = fragment_weights(pos, (120, 120), feather=24)
    k = next(i for i, (r, c) in enumerate(pos) if r == 48 and c == 48)  # all 8 neighbours
    u = np.arange(48) + 0.5
    tent = np.minimum(u, 48 - u) / 24
    np.testing.assert_allclose(w[k], np.outer(tent, tent), rtol=0, atol=1e-12)


def test_weights_feather_zero_is_nearest_centre():
    pos = grid((120, 120))
    w = fragment_weights(pos, (120, 120), feather=0)
    k = next(i for i, (r, c) in enumerate(pos) if r == 48 and c == 48)
    # Its 24 x 24 cell around the centre, (almost) nothing outside it.
    assert np.all(w[k][12:36, 12:36] > 0.99)
    outside = np.ones((48, 48), dtype=bool)
    outside[12:36, 12:36] = False
    assert w[k][outside].max() < 0.01


# --------------------------------------------------------------------------------------
# blending the difference frames
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(("margin", "feather"), [(12, 8), (0, 8), (20, 24), (12, 0)])
def test_blend_of_identical_inputs_returns_the_sequence(margin, feather):
    gen = np.random.default_rng(2)
    shape = (96, 120)
    video = gen.standard_normal((3, *shape)).astype(np.float32)
    pos = grid(shape)
    out = blend_differences(crops(video, pos, margin), pos, shape, margin=margin, feather=feather)
    assert out.dtype == np.float32
    assert out.shape == video.shape
    np.testing.assert_allclose(out, video, rtol=0, atol=1e-5)


def test_blend_partial_coverage_is_zero_outside_and_exact_inside():
    gen = np.random.default_rng(3)
    shape = (120, 144)
    video = gen.standard_normal((2, *shape)).astype(np.float32)
    pos = grid(shape)
    pos = pos[(pos[:, 0] < 48) | (pos[:, 1] < 48)]  # an L: the bottom right is bare
    out = blend_differences(crops(video, pos, 12), pos, shape, margin=12)
    inside = covered(pos, shape)
    assert 0 < inside.sum() < inside.size
    assert np.all(out[:, ~inside] == 0)  # exactly
    # Where a layer has no fragment it holds the fill, which is the data itself here;
    # only the coverage's edge sees the bands cut off far outside (~2e-5).
    np.testing.assert_allclose(out[:, inside], video[:, inside], rtol=0, atol=1e-4)
    assert np.abs(out[:, inside] - video[:, inside]).mean() < 1e-6


def test_blend_without_fragments_is_zero():
    out = blend_differences(np.zeros((0, 4, 72, 72)), np.zeros((0, 2)), (48, 96), margin=12)
    assert out.shape == (4, 48, 96)
    assert not out.any()


@pytest.mark.parametrize(("margin", "levels", "feather"), [(12, 3, 8), (4, 2, 0), (16, 4, 24)])
def test_blend_matches_the_reference(margin, levels, feather):
    gen = np.random.default_rng(4)
    shape = (96, 120)
    pos = grid(shape)
    pos = pos[gen.random(len(pos)) < 0.7]
    diffs = gen.standard_normal((len(pos), 2, 48 + 2 * margin, 48 + 2 * margin))
    diffs = diffs.astype(np.float32)
    kw = {"margin": margin, "levels": levels, "feather": feather}
    fast = blend_differences(diffs, pos, shape, **kw)
    slow = reference_blend_differences(diffs, pos, shape, **kw)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=2e-5)
    assert np.abs(fast).max() > 0.5


def _seam_measures(out, texture):
    """Gradient energy across the cell borders (rows and columns at 12 mod 24, where
    neighbours' weights cross and the phase tiles meet).

    Returns the largest energy there normalised by the local variance and by the same
    ratio inside a plain texture (1: no trace of a border), and the mean energy there
    over the mean energy elsewhere.
    """
    inner = out[:, 48:-48, 48:-48]  # away from the canvas border
    kappa = (np.diff(texture, axis=2) ** 2).mean() / (texture**2).mean()
    worst, excess = 0.0, 0.0
    for a in (inner, inner.transpose(0, 2, 1)):
        g = (np.diff(a, axis=2) ** 2).mean(axis=(0, 1))
        v = (a**2).mean(axis=(0, 1))
        r = g / (0.5 * (v[1:] + v[:-1])) / kappa
        border = (np.arange(1, a.shape[2]) + 48) % 24 == 12  # between c - 1 and c
        worst = max(worst, float(r[border].max()))
        excess = max(excess, float(g[border].mean() / g[~border].mean()))
    return worst, excess


def test_blend_of_different_textures_shows_no_seam():
    gen = np.random.default_rng(6)
    shape, margin = (168, 192), 12
    size = (4, shape[0] + 2 * margin, shape[1] + 2 * margin)
    a, b = smooth_texture(gen, size, 1.5), smooth_texture(gen, size, 1.5)
    pos = grid(shape)
    s = 48 + 2 * margin
    diffs = np.stack(
        [(a if (r // 24 + c // 24) % 2 == 0 else b)[:, r : r + s, c : c + s] for r, c in pos]
    )
    plain = a[:, 60:-60, 60:-60]
    blended = blend_differences(diffs, pos, shape, margin=margin)
    worst, excess = _seam_measures(blended, plain)
    assert worst < 2.0
    assert excess < 1.1
    # The finest detail keeps most of its contrast (a tent would halve the variance
    # halfway between fragments).
    assert (blended[:, 48:-48, 48:-48] ** 2).mean() > 0.7
    # The measures do see a seam: fragments pasted side by side without blending.
    mosaic = blend_differences(diffs, pos, shape, margin=margin, levels=1, feather=0)
    worst, excess = _seam_measures(mosaic, plain)
    assert worst > 5.0
    assert excess > 1.5


def test_blend_validates_and_leaves_inputs_alone():
    shape = (96, 96)
    pos = grid(shape)
    diffs = np.random.default_rng(8).standard_normal((len(pos), 2, 72, 72)).astype(np.float32)
    before = diffs.copy(), pos.copy()
    blend_differences(diffs, pos, shape, margin=12)
    assert np.array_equal(diffs, before[0])
    assert np.array_equal(pos, before[1])
    with pytest.raises(ValueError, match="positions must be multiples of the stride 24"):
        blend_differences(diffs, pos + 1, shape, margin=12)
    with pytest.raises(ValueError, match="positions must place every"):
        blend_differences(diffs, pos + 24, shape, margin=12)
    with pytest.raises(ValueError, match="positions must not repeat"):
        blend_differences(diffs[:2], np.zeros((2, 2)), shape, margin=12)
    with pytest.raises(ValueError, match="diffs must be 48 \\+ 2 \\* margin = 64"):
        blend_differences(diffs, pos, shape, margin=8)
    with pytest.raises(ValueError, match="diffs must hold one fragment per position"):
        blend_differences(diffs[:3], pos, shape, margin=12)
    with pytest.raises(ValueError, match="levels must be"):
        blend_differences(diffs, pos, shape, margin=12, levels=0)
    with pytest.raises(ValueError, match="feather must be in \\[0, 24\\]"):
        blend_differences(diffs, pos, shape, margin=12, feather=30)
    with pytest.raises(ValueError, match="canvas_shape"):
        blend_differences(diffs, pos, (96,), margin=12)
    bad = diffs.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="diffs contains 1 NaN"):
        blend_differences(bad, pos, shape, margin=12)


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


# --------------------------------------------------------------------------------------
# dynamic matte, background, loop, composite
# --------------------------------------------------------------------------------------


def _blob(shape, centre, radius):
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    d = np.hypot(yy - centre[0], xx - centre[1])
    return np.clip(radius + 0.5 - d, 0, 1).astype(np.float32)


def test_dynamic_matte_keeps_its_area_and_moves():
    shape = (40, 48)
    alpha = _blob(shape, (20, 16), 8)
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    # A swirl (its bilinear advection spreads and shrinks values) plus a drift right.
    swirl = np.stack([(xx - 24) * 0.08, -(yy - 20) * 0.08 + 1.0], axis=-1)
    motion = np.broadcast_to(swirl, (9, *shape, 2)).astype(np.float32)
    b = dynamic_matte(alpha, motion, tau=0.9)
    assert b.shape == (10, *shape)
    assert b.dtype == np.float32
    assert np.array_equal(b[0], alpha)
    assert b.min() >= 0
    assert b.max() <= 1
    area = alpha.sum()
    for frame in b:
        assert abs(frame.sum() - area) < 0.01 * area
    # it moved: the centroid drifted right
    cx = [(frame * xx).sum() / frame.sum() for frame in b]
    assert cx[-1] > cx[0] + 1.0
    assert not np.array_equal(b[-1], alpha)


def test_dynamic_matte_tau_zero_is_static_exactly():
    alpha = _blob((24, 24), (12, 12), 6)
    motion = np.random.default_rng(15).standard_normal((5, 24, 24, 2))
    b = dynamic_matte(alpha, motion, tau=0.0)
    assert all(np.array_equal(frame, alpha) for frame in b)


def test_dynamic_matte_validates():
    alpha = np.zeros((8, 8), dtype=np.float32)
    with pytest.raises(ValueError, match="alpha must be in \\[0, 1\\]"):
        dynamic_matte(alpha + 2, np.zeros((2, 8, 8, 2)), tau=0.5)
    with pytest.raises(ValueError, match="motion must have shape"):
        dynamic_matte(alpha, np.zeros((2, 8, 9, 2)), tau=0.5)
    with pytest.raises(ValueError, match="tau must be in \\[0, 1\\]"):
        dynamic_matte(alpha, np.zeros((2, 8, 8, 2)), tau=1.5)


def test_inpainting_fills_only_the_region():
    gen = np.random.default_rng(16)
    img = gen.random((40, 48, 3)).astype(np.float32)
    matte = np.zeros((40, 48))
    matte[10:20, 15:30] = 0.5
    before = img.copy()
    out = inpaint_background(img, matte, dilate=2)
    assert np.array_equal(img, before)
    region = ndi.binary_dilation(matte > 0, np.ones((3, 3)), 2)
    assert np.array_equal(out[~region], img[~region])
    assert not np.array_equal(out[region], img[region])


def test_inpainting_a_constant_background_gives_the_constant():
    img = np.full((40, 48, 3), (0.2, 0.5, 0.9), dtype=np.float32)
    matte = _blob((40, 48), (20, 24), 9)
    img[matte > 0] = (1.0, 0.0, 0.0)  # the fluid in front
    out = inpaint_background(img, matte)
    np.testing.assert_allclose(out, np.broadcast_to([0.2, 0.5, 0.9], out.shape), atol=1e-4)


def test_inpainting_edge_cases():
    img = np.full((10, 10), 0.5, dtype=np.float32)
    assert np.array_equal(inpaint_background(img, np.zeros((10, 10))), img)
    with pytest.raises(ValueError, match="matte covers the whole image"):
        inpaint_background(img, np.ones((10, 10)))
    with pytest.raises(ValueError, match="matte must have the image's height and width"):
        inpaint_background(img, np.ones((10, 11)))
    with pytest.raises(ValueError, match="dilate must be an integer >= 0"):
        inpaint_background(img, np.zeros((10, 10)), dilate=-1)


def _moving_texture(gen, frames, shape):
    base = smooth_texture(gen, (1, shape[0], shape[1] + frames), 3.0)[0]
    return np.stack([base[:, t : t + shape[1]] for t in range(frames)])  # 1 px/frame


def test_loop_crossfade_makes_the_wrap_an_ordinary_step():
    gen = np.random.default_rng(17)
    clip = _moving_texture(gen, 40, (24, 32))
    loop = loop_crossfade(clip, overlap=8)
    assert loop.shape == (32, 24, 32)
    steps = [np.abs(loop[t + 1] - loop[t]).mean() for t in range(len(loop) - 1)]
    typical = np.median(steps)
    wrap = np.abs(loop[0] - loop[-1]).mean()
    assert wrap < 1.5 * typical
    assert max(steps) < 2.0 * typical
    # without the fade the wrap is a jump
    assert np.abs(clip[0] - clip[31]).mean() > 3 * typical


def test_loop_crossfade_keeps_the_variance_and_the_mean():
    gen = np.random.default_rng(18)
    noise = gen.standard_normal((64, 32, 32)).astype(np.float32)
    loop = loop_crossfade(noise + 0.5, overlap=16)
    variances = loop[:16].var(axis=(1, 2))
    assert variances.min() > 0.85  # a linear fade would drop to ~0.5
    assert variances.max() < 1.15
    np.testing.assert_allclose(loop.mean(), 0.5, atol=0.02)
    constant = np.full((10, 4, 4), 0.3, dtype=np.float32)
    assert np.array_equal(loop_crossfade(constant, overlap=5), constant[:5])


def test_loop_crossfade_zero_overlap_and_validation():
    clip = np.random.default_rng(19).random((6, 3, 3)).astype(np.float32)
    out = loop_crossfade(clip, overlap=0)
    assert np.array_equal(out, clip)
    assert out is not clip
    with pytest.raises(ValueError, match="overlap must be an integer in \\[0, 3\\]"):
        loop_crossfade(clip, overlap=4)


def test_composite_is_the_background_where_the_matte_is_zero():
    gen = np.random.default_rng(20)
    anim = gen.random((3, 10, 12, 3)).astype(np.float32)
    bg = gen.random((10, 12, 3)).astype(np.float32)
    matte = gen.random((10, 12)).astype(np.float32)
    matte[:, :5] = 0
    out = composite(anim, bg, matte)
    assert out.dtype == np.float32
    assert np.array_equal(out[:, :, :5], np.broadcast_to(bg[:, :5], out[:, :, :5].shape))
    np.testing.assert_allclose(
        out[:, :, 5:], (bg + matte[..., None] * (anim - bg))[:, :, 5:], atol=1e-6
    )
    # per-frame matte and background, grey frames
    bgs = gen.random((3, 10, 12)).astype(np.float32)
    mattes = np.zeros((3, 10, 12), dtype=np.float32)
    mattes[1] = 1.0
    out = composite(anim[..., 0], bgs, mattes)
    assert np.array_equal(out[0], bgs[0])
    assert np.array_equal(out[2], bgs[2])
    np.testing.assert_allclose(out[1], anim[1, ..., 0], atol=1e-6)


def test_composite_validates():
    anim = np.zeros((2, 4, 4, 3), dtype=np.float32)
    with pytest.raises(ValueError, match="background must have shape"):
        composite(anim, np.zeros((4, 5, 3)), np.zeros((4, 4)))
    with pytest.raises(ValueError, match="matte must have shape"):
        composite(anim, np.zeros((4, 4, 3)), np.zeros((3, 4, 4)))
    with pytest.raises(ValueError, match="matte must be in \\[0, 1\\]"):
        composite(anim, np.zeros((4, 4, 3)), np.full((4, 4), 2.0))


def test_inputs_are_never_modified():
    gen = np.random.default_rng(21)
    img = gen.random((24, 24, 3)).astype(np.float32)
    v = gen.standard_normal((24, 24, 2)).astype(np.float32)
    frames = gen.random((3, 24, 24, 3)).astype(np.float32)
    matte = _blob((24, 24), (12, 12), 5)
    motion = gen.standard_normal((2, 24, 24, 2)).astype(np.float32)
    args = [img, v, frames, matte, motion]
    before = [a.copy() for a in args]
    motion_blur(img, v, shutter=2, denoise=0.5)
    match_histograms_cells(frames, img, matte, cell=8)
    dynamic_matte(matte, motion, tau=0.7)
    loop_crossfade(frames, overlap=1)
    composite(frames, img, matte)
    for a, b in zip(args, before):
        assert np.array_equal(a, b)
