"""Blending the fragments' difference frames (Okabe et al., sec. 6; Burt & Adelson 1983)."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.videodb._common._weights import blend_values
from fluidnb.videodb.rendering import (
    blend_differences,
    fragment_weights,
    reference_blend_differences,
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


@pytest.mark.parametrize("feather", [8, 0, 24])
@pytest.mark.parametrize(("margin", "levels"), [(12, 4), (4, 2), (0, 1), (12, 3)])
@pytest.mark.parametrize("subset", [False, True])
def test_blend_is_the_per_fragment_blend_where_no_fragments_share_a_phase(
    margin, levels, feather, subset
):
    """Up to 3 x 3 fragments every phase layer holds one fragment: the fast path is then
    Burt & Adelson's blend written per fragment, to float32 round-off.

    Mutations caught: the bands weighted by the weight squared (_weighted_band_spans); the boundary
    between two cells one pixel off (_common._weights._profile; the plain version has
    its own weights)."""
    gen = np.random.default_rng(4)
    shape = (96, 96)
    pos = grid(shape)
    if subset:  # missing neighbours: the fill stands in, in both
        pos = pos[[0, 1, 4, 5, 7]]
    s = 48 + 2 * margin
    for diffs in (
        gen.standard_normal((len(pos), 2, s, s)).astype(np.float32),
        np.stack([smooth_texture(gen, (2, s, s), 2.0) for _ in pos]),  # unrelated textures
    ):
        kw = {"margin": margin, "levels": levels, "feather": feather}
        fast = blend_differences(diffs, pos, shape, **kw)
        slow = reference_blend_differences(diffs, pos, shape, **kw)
        assert slow.dtype == np.float32
        np.testing.assert_allclose(fast, slow, rtol=0, atol=5e-6)
        assert np.abs(fast).max() > 0.5


@pytest.mark.parametrize(("shape", "levels"), [((120, 144), 3), ((168, 192), 3), ((168, 192), 4)])
def test_blend_on_larger_grids_differs_from_the_per_fragment_blend_at_the_coarsest_band(
    shape, levels
):
    """Beyond 3 x 3 fragments a phase layer holds several: past its tile a fragment's
    coarse bands see its phase-mates' frames where the per-fragment blend has the fill.
    Up to 3 levels the weights hardly reach there (round-off); at the fourth (the
    default) they do, and the blends differ by a small, bounded amount."""
    gen = np.random.default_rng(5)
    pos = grid(shape)
    diffs = np.stack([smooth_texture(gen, (2, 72, 72), 2.0) for _ in pos])
    fast = blend_differences(diffs, pos, shape, margin=12, levels=levels)
    slow = reference_blend_differences(diffs, pos, shape, margin=12, levels=levels)
    gap = np.abs(fast - slow)
    if levels <= 3:
        assert gap.max() < 5e-6
    else:
        assert gap.max() < 2e-3 * np.abs(fast).max()  # measured: 5e-4 of unit variance
        assert np.sqrt((gap**2).mean()) < 3e-4


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


def test_blend_values_spreads_each_fragments_value_over_its_cell():
    shape = (96, 120)
    pos = grid(shape)[[0, 1, 2, 4, 5]]
    values = np.arange(len(pos) * 2, dtype=np.float64).reshape(-1, 2)
    out = blend_values(values, pos, shape)
    assert out.shape == shape + (2,)
    assert out.dtype == np.float32
    # In the middle of its core a fragment's own value (its neighbours' floored weights,
    # 1e-3 of its own, count a little); off every core, 0.
    for (r, c), v in zip(pos, values):
        middle = out[r + 20 : r + 28, c + 20 : c + 28]
        np.testing.assert_allclose(middle, np.broadcast_to(v, (8, 8, 2)), atol=0.02)
    assert (out[~covered(pos, shape)] == 0).all()
    # A constant value stays constant wherever the cores reach.
    same = blend_values(np.ones((len(pos), 2)), pos, shape)
    np.testing.assert_allclose(same[covered(pos, shape)], 1.0, atol=1e-6)


def test_blend_on_threads_is_the_blend_on_one(monkeypatch):
    # The phase layers' pyramids are made on threads and summed in layer order: the
    # result is the one-thread result bit for bit.
    from fluidnb.videodb.rendering import _blend, _threads

    gen = np.random.default_rng(8)
    shape = (168, 192)
    pos = grid(shape)[::2]
    diffs = np.stack([smooth_texture(gen, (3, 72, 72), 1.5) for _ in pos])
    threads = blend_differences(diffs, pos, shape, margin=12)
    for module in (_blend, _threads):
        monkeypatch.setattr(module, "_THREADS", 1)
    assert np.array_equal(blend_differences(diffs, pos, shape, margin=12), threads)
    for module in (_blend, _threads):
        monkeypatch.setattr(module, "_THREADS", 4)
    assert np.array_equal(blend_differences(diffs, pos, shape, margin=12), threads)


@pytest.mark.parametrize(
    ("margin", "feather", "frames", "every"),
    # 2 frames: batches of one frame, the renderer's at 1920 px (the compiled
    # kernels' one-channel paths).
    [(12, 8.0, 12, 2), (16, 24.0, 4, 3), (6, 0.0, 6, 1), (12, 8.0, 2, 1)],
)
def test_blend_is_the_numpy_layer_blend_bit_for_bit(margin, feather, frames, every):
    # The compiled fill, weighting and normalisation and the weights made once give
    # the phase-layer blend written in numpy exactly; fragments missing here and
    # there (every), zero weights far from the cores, margins short and long.
    # Mutations caught: the fill summed without its tent (_accumulate_windows), the
    # bands weighted by the weight squared (_weighted_band_spans), the cell boundary one pixel off.
    from fluidnb.videodb.rendering._blend import _blend, _BlendPlan
    from fluidnb.videodb.rendering._reference import reference_layer_blend

    gen = np.random.default_rng(11)
    shape = (192, 240)
    pos = grid(shape)[::every]
    s = 48 + 2 * margin
    diffs = np.stack([smooth_texture(gen, (frames, s, s), 1.0) for _ in pos])
    ref = reference_layer_blend(diffs, pos, shape, margin=margin, feather=feather)
    fast = blend_differences(diffs, pos, shape, margin=margin, feather=feather)
    assert fast.dtype == ref.dtype
    assert np.array_equal(fast.view(np.uint32), ref.view(np.uint32))
    # The renderer's entry with one plan for several batches of frames: each batch
    # is the blend of that batch alone.
    plan = _BlendPlan(pos, shape, margin, 4, feather)
    pixel_major = np.ascontiguousarray(np.moveaxis(diffs, 1, 3))
    for part in (slice(0, frames // 2), slice(frames // 2, frames)):
        got = _blend(np.ascontiguousarray(pixel_major[..., part]), pos, shape, margin, 4,
                     feather, plan)  # fmt: skip
        alone = blend_differences(diffs[:, part], pos, shape, margin=margin, feather=feather)
        assert np.array_equal(got.view(np.uint32), alone.view(np.uint32))
        assert np.array_equal(got.view(np.uint32), ref[part].view(np.uint32))


def test_play_loops_is_stagger_on_loops_already_made():
    from fluidnb.videodb.rendering import loop_crossfade, stagger
    from fluidnb.videodb.rendering._loops import play_loops

    gen = np.random.default_rng(4)
    diffs = gen.standard_normal((5, 10, 8, 8)).astype(np.float32)
    offsets = np.array([0, 3, 5, 1, 0])
    rates = np.array([1.0, 0.5, 1.5, 1.0, 0.25])
    mirrors = np.array([-1, 0, 1, -1, 0])
    loops = np.moveaxis(loop_crossfade(np.moveaxis(diffs, 1, 0), overlap=3), 0, 1)
    frame_major = list(loops)  # (L, 8, 8) each, as the frame cache keeps them
    for kw in ({}, {"mirrors": mirrors}, {"rates": rates, "n_frames": 14, "mirrors": mirrors}):
        want = np.moveaxis(stagger(diffs, offsets, overlap=3, **kw), 1, 3)
        assert np.array_equal(play_loops(frame_major, offsets, **kw), want)
    assert np.array_equal(play_loops(frame_major, np.zeros(5)), np.moveaxis(loops, 1, 3))
    with pytest.raises(ValueError, match="offsets must have shape"):
        play_loops(frame_major, offsets[:2])
    with pytest.raises(ValueError, match="frame-major"):
        play_loops([np.moveaxis(x, 0, 2) for x in loops], offsets)  # pixel-major (8, 8, 7)
    # Any frames of the clip, in any order: those frames of the whole clip (a
    # renderer makes the clip a run of frames at a time).
    kw = {"rates": rates, "mirrors": mirrors}
    whole = play_loops(frame_major, offsets, n_frames=14, **kw)
    for frames in ([0, 1, 2], [13, 5, 5], [9]):
        part = play_loops(frame_major, offsets, frames=np.array(frames), **kw)
        assert np.array_equal(part, whole[..., frames])
    with pytest.raises(ValueError, match="frames must be a 1-D array"):
        play_loops(frame_major, offsets, frames=np.array([-1, 2]))
    # Into a given array (a renderer's runs reuse one): every value written.
    buf = np.full(whole[..., :3].shape, np.nan, np.float32)
    for frames in ([0, 1, 2], [13, 5, 5]):
        got = play_loops(frame_major, offsets, frames=np.array(frames), out=buf, **kw)
        assert got is buf
        assert np.array_equal(buf, whole[..., frames])
    with pytest.raises(ValueError, match="out must be"):
        play_loops(frame_major, offsets, frames=np.array([0, 1]), out=buf, **kw)


@pytest.mark.parametrize(
    ("shape", "rows", "cols", "levels"),
    [
        ((456, 600), (168, 312), (192, 384), 4),  # inside: a box on every side
        ((456, 600), (0, 120), (432, 600), 4),  # at the canvas's top right corner
        ((460, 600), (168, 312), (192, 384), 4),  # 460 rows, off the grid: every row
        ((456, 600), (168, 312), (192, 384), 2),
    ],
)
def test_blend_on_the_fragments_box_is_the_whole_canvas_blend_bit_for_bit(
    monkeypatch, shape, rows, cols, levels
):
    # The blend runs on the box around the fragments' windows grown by the pyramids'
    # reach, its edges on the coarsest level's grid; outside it the canvas's blend is 0.
    # Mutations caught: the box's reach 3 (not 0 at the coarse levels), an edge off
    # the grid (the bilinear resampling then samples other points).
    from fluidnb.videodb.rendering import _blend

    gen = np.random.default_rng(11)
    pos = np.array(
        [(r, c) for r in range(*rows, 24) for c in range(*cols, 24) if gen.random() < 0.8]
    )
    pos = pos[(pos[:, 0] + 48 <= shape[0]) & (pos[:, 1] + 48 <= shape[1])]
    diffs = gen.standard_normal((len(pos), 3, 72, 72)).astype(np.float32)
    box = _blend._fragments_box(pos, shape, 12, levels)
    assert (box[1] - box[0]) * (box[3] - box[2]) < 0.75 * shape[0] * shape[1]  # a gain
    if shape[0] % 8:
        assert box[:2] == (0, shape[0])
    boxed = blend_differences(diffs, pos, shape, margin=12, levels=levels)
    monkeypatch.setattr(_blend, "_BOX", False)
    whole = blend_differences(diffs, pos, shape, margin=12, levels=levels)
    assert np.array_equal(boxed.view(np.uint32), whole.view(np.uint32))
    assert np.abs(whole).max() > 0.5


def test_blend_plan_skips_only_pixels_of_weight_zero():
    # Each layer's bands are made and summed only on its spans: every pixel of a
    # non-zero weight G_l(W) lies on them (a skipped one would drop its product from
    # the sum), and at the finest level they leave out the pixels far from the
    # layer's cores (the gain). Mutations caught: a run one pixel short, the spans
    # of the weights' level below.
    from fluidnb.videodb.rendering._blend import _BlendPlan

    shape = (240, 288)
    pos = grid(shape)
    plan = _BlendPlan(pos, shape, 12, 4, 8.0)
    for weights, spans in zip(plan.weights, plan.spans, strict=True):
        for level, (g, (ptr, runs, _, _)) in enumerate(zip(weights, spans, strict=True)):
            inside = np.zeros(g.shape[:2], bool)
            for i in range(g.shape[0]):
                for c0, c1 in runs[ptr[i] : ptr[i + 1]]:
                    inside[i, c0:c1] = True
            assert np.all(inside[g[..., 0] != 0]), level
            if level == 0:
                assert inside.mean() < 0.6
