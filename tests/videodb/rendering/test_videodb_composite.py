"""The last steps of the rendering: moving matte, background, loop, composite (sec. 6)."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.videodb.rendering import composite, dynamic_matte, inpaint_background, loop_crossfade


def smooth_texture(gen, shape, blur):
    t = ndi.gaussian_filter(gen.standard_normal(shape), (0, blur, blur), mode="wrap")
    return (t / t.std()).astype(np.float32)


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
    frames = gen.random((3, 24, 24, 3)).astype(np.float32)
    matte = _blob((24, 24), (12, 12), 5)
    motion = gen.standard_normal((2, 24, 24, 2)).astype(np.float32)
    args = [img, frames, matte, motion]
    before = [a.copy() for a in args]
    dynamic_matte(matte, motion, tau=0.7)
    inpaint_background(img, matte)
    loop_crossfade(frames, overlap=1)
    composite(frames, img, matte)
    for a, b in zip(args, before):
        assert np.array_equal(a, b)


def test_behind_a_moving_matte_the_photo_stays_and_the_fill_shows_where_the_fluid_left():
    from fluidnb.videodb.rendering._composite import _uncovered

    gen = np.random.default_rng(3)
    photo, fill = gen.random((2, 20, 30, 3)).astype(np.float32)
    fill *= 0.2  # a dark fill (the rock behind a white cloud)
    alpha = np.clip(np.linspace(-0.5, 1.5, 30, dtype=np.float32), 0, 1)[None].repeat(20, 0)
    # Where the matte is alpha (frame 0), the soft edge lays the fluid over the photo:
    # nothing of the fill shows (it made a dark band along a cloud's soft edge).
    np.testing.assert_allclose(_uncovered(photo, fill, alpha, alpha)[alpha < 1], photo[alpha < 1])
    # Where the fluid left (B < alpha) the fill shows by what it left; where the fluid
    # comes (B > alpha) the scene is the photo.
    matte = np.clip(alpha + np.linspace(-0.4, 0.4, 20, dtype=np.float32)[:, None], 0, 1)
    u = _uncovered(photo, fill, alpha, matte)
    rest = 1 - matte
    expected = (1 - np.maximum(alpha, matte))[..., None] * photo + np.maximum(alpha - matte, 0)[
        ..., None
    ] * fill
    ok = rest > 1e-3
    np.testing.assert_allclose((rest[..., None] * u)[ok], expected[ok], atol=1e-5)
    assert np.array_equal(u[matte == 1], fill[matte == 1])
