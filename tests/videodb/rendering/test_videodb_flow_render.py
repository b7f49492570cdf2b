"""The flow rendering (beyond the paper): loop, frame 0, speed; no fragment in sync."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb import to_uint8
from fluidnb.videodb import AnimateParams, DatabaseParams, assign, build_database, render
from fluidnb.videodb.rendering import (
    blend_differences,
    displacement_maps,
    eulerian_loop,
    exemplar_fill,
    extend_outside,
    flow_field,
    flow_timing,
    loop_crossfade,
    loop_phases,
    mirror_axes,
    phase_offsets,
    reference_eulerian_loop,
    reference_fill,
    reference_supersample,
    reference_variance_blend,
    stagger,
    supersample,
    sync_share,
    temporal_offsets,
    variance_blend,
)

PARAMS = DatabaseParams(N=16, augment="none", words=16, codebook_samples=5000)
FEW = AnimateParams(candidates=10, loop=4)


def texture(seed, shape, blur=1.5):
    gen = np.random.default_rng(seed)
    t = ndi.gaussian_filter(gen.random(shape), blur, mode="wrap")
    return ((t - t.min()) / (t.max() - t.min())).astype(np.float32)


def moving(seed, velocity, shape=(96, 120), frames=32):
    """A periodic texture translated by whole pixels: its flow is ``velocity`` exactly."""
    base = texture(seed, shape)
    dy, dx = velocity
    out = np.stack([np.roll(base, (t * dy, t * dx), axis=(0, 1)) for t in range(frames)])
    return np.repeat(out[..., None], 3, axis=3)


def measured_flow(frames, mask):
    """Mean (dy, dx) of OpenCV DIS (preset MEDIUM) between consecutive frames in ``mask``."""
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    grey = [cv2.cvtColor(to_uint8(f), cv2.COLOR_RGB2GRAY) for f in frames]
    flows = [dis.calc(a, b, None)[mask][:, ::-1].mean(axis=0) for a, b in zip(grey, grey[1:])]
    return np.mean(flows, axis=0)


@pytest.fixture(scope="module")
def db(tmp_path_factory):
    # Everything in the database moves right at 1 px/frame (and left, its mirror image
    # is not built: augment="none"), so the assigned motion is known.
    clips = [(f"right{i}", moving(i, (0, 1))) for i in range(3)]
    path = tmp_path_factory.mktemp("flow") / "db"
    return build_database(clips, path, kind="water", params=PARAMS, seed=0)


@pytest.fixture(scope="module")
def photo():
    img = np.stack([texture(9, (96, 144), blur=2.0)] * 3, axis=-1) * [0.5, 0.7, 0.9]
    matte = np.zeros((96, 144), np.float32)
    matte[12:84, 18:126] = 1.0
    return img.astype(np.float32), ndi.gaussian_filter(matte, 1.0)


@pytest.fixture(scope="module")
def assignment(db, photo):
    return assign(*photo, db, FEW)


# ------------------------------------------------------------------ the Eulerian loop


def test_phases_restart_unseen_and_move_one_frame_a_frame():
    for n, cycle in ((24, 12), (24, 24), (72, 64), (10, 3)):
        age_a, age_b, w = loop_phases(n, cycle)
        assert age_a[0] == 0
        assert w[0] == 1
        period = n / max(1, round(n / cycle))
        assert np.allclose(np.abs(age_a - age_b), period / 2)
        for age, weight in ((age_a, w), (age_b, 1 - w)):
            step = np.diff(np.append(age, age[0]))  # the loop: frame T is frame 0
            jumps = ~np.isclose(step, 1.0)
            # Ages grow one frame a frame, except at a restart, where the weight is 0
            # on one side of the jump.
            ends = np.append(weight, weight[0])
            assert np.all(np.minimum(ends[:-1], ends[1:])[jumps] < 1 / period + 1e-9)


def test_a_zero_flow_gives_the_image_in_every_frame_exactly():
    img = texture(1, (20, 30))
    frames = eulerian_loop(img, np.zeros((20, 30, 2)), 12, cycle=6)
    assert all(np.array_equal(f, img) for f in frames)


def test_the_loop_closes_and_frame_zero_is_the_image():
    img = np.stack([texture(2, (40, 50))] * 3, axis=-1)
    yy, xx = np.mgrid[:40, :50]
    v = np.stack([0.3 * np.sin(xx / 9.0), 1.0 + 0.5 * np.cos(yy / 7.0)], axis=-1)
    once = eulerian_loop(img, v, 12, cycle=6)
    twice = eulerian_loop(img, v, 24, cycle=6)
    assert np.array_equal(once[0], img)
    np.testing.assert_array_equal(twice[12:], once)  # frame T + t is frame t
    # Seamless: the step from the last frame back to the first is an ordinary step.
    steps = np.abs(np.diff(np.concatenate([once, once[:1]]), axis=0)).mean(axis=(1, 2, 3))
    assert steps[-1] < 1.5 * np.median(steps[:-1])


def test_a_uniform_flow_moves_the_image_by_its_speed():
    img = texture(3, (48, 64), blur=1.0)
    v = np.zeros((48, 64, 2), np.float32)
    v[..., 1] = 1.0
    maps = displacement_maps(v, 4)
    # Away from the left border (where clamping holds the edge), D_s = -s v exactly.
    for s in range(-4, 5):
        np.testing.assert_allclose(maps[4 + s][:, 8:-8], np.broadcast_to([0.0, -s], (48, 48, 2)))
    _frames, a, _ = eulerian_loop(img, v, 8, cycle=8, return_phases=True)
    np.testing.assert_allclose(a[2][:, 10:], img[:, 8:-2], atol=1e-6)  # 2 px right at age 2


def test_the_fast_loop_agrees_with_the_reference():
    img = np.stack([texture(4, (36, 44), blur=2.5)] * 3, axis=-1)
    yy, xx = np.mgrid[:36, :44]
    v = np.stack([0.4 * np.sin(xx / 6.0), 0.8 + 0.3 * np.cos(yy / 5.0)], axis=-1)
    offsets = phase_offsets((36, 44), 12)
    # Mutations caught: the phases' weights over the period instead of its half
    # (loop_phases; the plain version has its own phases), the maps' recurrence
    # D_{s+1} = D_s(x - v) - v subtracting half the step (_chain), a pixel's age not
    # shifted by its offset (_staggered), the blend's gain not clipped (_restore).
    for n, cycle, o in ((8, 8, None), (10, 4, None), (8, 8, offsets), (10, 4, offsets)):
        fast = eulerian_loop(img, v, n, cycle=cycle, offsets=o)
        ref = reference_eulerian_loop(img, v, n, cycle=cycle, offsets=o)
        assert np.abs(fast - ref).max() < 1e-2  # OpenCV tabulates its weights per 1/32 px


def test_the_finer_copy_keeps_the_pixels_and_is_lanczos():
    img = np.stack([texture(6, (13, 17))] * 2, axis=-1)
    fine = supersample(img, 2)
    assert fine.shape == (25, 33, 2)
    assert np.array_equal(fine[::2, ::2], img)  # the image's own pixels, bit for bit
    np.testing.assert_allclose(fine, reference_supersample(img, 2), atol=1e-5)
    np.testing.assert_allclose(supersample(img, 3), reference_supersample(img, 3), atol=1e-5)


def test_the_blend_keeps_the_variance_of_its_inputs():
    gen = np.random.default_rng(7)
    a, b = gen.standard_normal((2, 96, 96, 3)).astype(np.float32)

    def sharpness(x):  # what the look's measures call it: the Laplacian's variance
        return cv2.Laplacian(x, cv2.CV_32F).var()

    for w in (0.2, 0.5, 0.7):
        linear = w * a + (1 - w) * b
        out = variance_blend(a, b, w)
        # Independent textures: a linear cross-fade loses up to half their variance,
        # the blend keeps it (within the local estimates' noise).
        assert linear.var() / a.var() < 1 - 0.3 * min(w, 1 - w)
        assert 0.9 < out.var() / (w * a.var() + (1 - w) * b.var()) < 1.1
        assert 0.9 < sharpness(out) / (w * sharpness(a) + (1 - w) * sharpness(b)) < 1.1
        np.testing.assert_allclose(out, reference_variance_blend(a, b, w), atol=1e-4)
    per_pixel = np.linspace(0, 1, 96, dtype=np.float32)[None, :].repeat(96, 0)
    np.testing.assert_allclose(
        variance_blend(a, b, per_pixel), reference_variance_blend(a, b, per_pixel), atol=1e-4
    )
    # Identical inputs are not amplified: the input back, bit for bit; and a weight
    # of 1 or 0 is one input alone.
    assert np.array_equal(variance_blend(a, a, 0.4), a)
    assert np.array_equal(variance_blend(a, b, 1.0), a)
    assert np.array_equal(variance_blend(a, b, 0.0), b)
    # Correlated inputs gain less than independent ones, never beyond sqrt(2).
    c = (0.8 * a + 0.6 * b).astype(np.float32)
    gain = variance_blend(a, c, 0.5).var() / (0.5 * a + 0.5 * c).var()
    assert 1.0 < gain < variance_blend(a, b, 0.5).var() / (0.5 * a + 0.5 * b).var()


def test_the_staggered_loop_closes_and_keeps_a_still_image():
    img = np.stack([texture(2, (40, 50))] * 3, axis=-1)
    offsets = phase_offsets((40, 50), 16)
    assert np.array_equal(
        eulerian_loop(img, np.zeros((40, 50, 2)), 12, cycle=6, offsets=offsets),
        np.broadcast_to(img, (12, 40, 50, 3)),
    )
    yy, xx = np.mgrid[:40, :50]
    v = np.stack([0.3 * np.sin(xx / 9.0), 1.0 + 0.5 * np.cos(yy / 7.0)], axis=-1)
    once = eulerian_loop(img, v, 12, cycle=6, offsets=offsets)
    twice = eulerian_loop(img, v, 24, cycle=6, offsets=offsets)
    np.testing.assert_array_equal(twice[12:], once)
    steps = np.abs(np.diff(np.concatenate([once, once[:1]]), axis=0)).mean(axis=(1, 2, 3))
    assert steps[-1] < 1.5 * np.median(steps[:-1])
    # The offsets spread the restarts: every frame has as many pixels mid-blend.
    hist = np.histogram(offsets, bins=4, range=(0, 1))[0]
    assert hist.min() > 0.9 * hist.max()


def test_the_layer_outside_the_matte_is_the_fluid_mirrored():
    img = np.zeros((20, 20, 3), np.float32)
    img[:, :10] = texture(5, (20, 10))[..., None]
    img[:, 10:] = 1.0  # rock
    matte = np.zeros((20, 20))
    matte[:, :10] = 1.0
    layer = extend_outside(img, matte)
    assert np.array_equal(layer[:, :10], img[:, :10])
    # Column 10 + k mirrors column 9 - k (about the nearest fluid pixel, column 9).
    np.testing.assert_array_equal(layer[:, 10:19], img[:, 8::-1])
    assert layer.max() < 1.0 or img[:, :10].max() == 1.0  # no rock flows in


def test_the_timing_fits_the_travel_in_whole_repeats():
    v = np.zeros((10, 10, 2))
    ones = np.ones((10, 10))
    for speed, n in ((0.25, 24), (0.5, 24), (1.0, 24), (3.0, 24), (1.0, 6)):
        v[..., 1] = speed
        total, cycle = flow_timing(v, ones, n, travel=16)
        assert total % n == 0
        assert total <= 4 * n
        assert abs(total / cycle - round(total / cycle)) < 1e-9  # whole cycles
        if 2 * 16 / speed <= 4 * n:
            assert cycle * speed / 2 >= 16 - 1e-9  # the phases are at least 16 px apart
    assert flow_timing(v, ones, 24, travel=16, repeats=False)[0] == 24
    assert flow_timing(np.zeros((10, 10, 2)), ones, 24, travel=16) == (24, 24.0)


def test_the_timing_takes_a_length_asked_for_in_whole_repeats():
    v = np.zeros((10, 10, 2))
    ones = np.ones((10, 10))
    v[..., 1] = 3.0  # a cycle of 2 * 16 / 3 = 10.7 frames wanted: one repeat of 24, two cycles
    assert flow_timing(v, ones, 24, travel=16) == (24, 12.0)
    total, cycle = flow_timing(v, ones, 24, travel=16, frames=96)  # beyond MAX_REPEATS
    assert (total, cycle) == (96, 96 / 9)  # the most whole cycles at least 32/3 long
    v[..., 1] = 0.25  # slow: one cycle of 128 frames wanted, 48 asked for
    assert flow_timing(v, ones, 24, travel=16, frames=48) == (48, 48.0)
    assert flow_timing(np.zeros((10, 10, 2)), ones, 24, travel=16, frames=72) == (72, 72.0)
    with pytest.raises(ValueError, match="frames must be a multiple of 24"):
        flow_timing(v, ones, 24, travel=16, frames=60)
    with pytest.raises(ValueError, match="frames must be 24"):
        flow_timing(v, ones, 24, travel=16, repeats=False, frames=48)
    with pytest.raises(ValueError, match="frames"):
        flow_timing(v, ones, 24, travel=16, frames=12)


# ------------------------------------------------------------------- the rendering


def test_the_field_is_the_fragments_motion_or_the_painted_speed(assignment, db, photo):
    img, matte = photo
    v = flow_field(assignment)
    inside = assignment.target.canvas_matte > 0.99
    np.testing.assert_allclose(v[inside].mean(axis=0), [0.0, 1.0], atol=0.05)
    painted = assign(img, matte, db, FEW, speed=np.where(matte > 0, 2.0, 0.0))
    v2 = flow_field(painted)
    np.testing.assert_allclose(np.hypot(v2[..., 0], v2[..., 1])[inside], 2.0, rtol=1e-4)


def test_frame_zero_is_the_photo(assignment, photo, monkeypatch):
    img, matte = photo
    out = render(assignment, FEW.replace(detail=0.0)).clip.frames
    assert np.array_equal(out[0][matte == 0], img[matte == 0])  # outside: bit for bit
    # Inside, each pixel starts at its own moment of the loop (phase_offsets); with
    # one cycle for all, frame 0 is the photo matched to itself.
    assert np.abs(out[0] - img).max() > 0.05
    monkeypatch.setattr("fluidnb.videodb.rendering._render.STAGGER", 0.0)
    out = render(assignment, FEW.replace(detail=0.0)).clip.frames
    assert np.abs(out[0] - img).max() < 2e-3
    # With the difference frames on top, frame 0 differs from the photo by them alone.
    anim = render(assignment, FEW)
    d0 = anim.stages["differences"][0]
    assert np.array_equal(anim.clip.frames[0][matte == 0], img[matte == 0])
    fluid = matte > 0
    before = np.clip(img + FEW.detail * d0[..., None], 0, 1)[fluid]
    assert np.abs(anim.stages["unmatched"][0][fluid] - before).max() < 1e-5


def test_a_moving_outline_keeps_the_photo_outside_the_matte_at_frame_zero(assignment, photo):
    img, matte = photo
    anim = render(assignment, FEW.replace(tau=0.5))
    f = anim.clip.frames
    assert np.array_equal(f[0][matte == 0], img[matte == 0])
    assert np.array_equal(anim.stages["matte"][0], assignment.target.canvas_matte[:96, :144])
    assert np.abs(anim.stages["matte"] - matte).max() > 0.1  # it moves


def test_the_rendered_clip_loops(assignment):
    anim = render(assignment, FEW)
    f = anim.clip.frames
    steps = np.abs(np.diff(np.concatenate([f, f[:1]]), axis=0)).mean(axis=(1, 2, 3))
    assert steps[-1] < 1.5 * np.median(steps[:-1])


@pytest.mark.parametrize("painted", [None, 2.0])
def test_the_output_moves_at_the_fragments_or_the_painted_speed(db, photo, painted):
    img, matte = photo
    speed = None if painted is None else np.where(matte > 0, painted, 0.0)
    a = assign(img, matte, db, FEW, speed=speed)
    inside = matte > 0.99
    inside[:, :40] = False  # away from the upstream edge, where the mirror flows in
    flow = measured_flow(render(a).clip.frames, inside)
    wanted = 1.0 if painted is None else painted
    speed_out = np.hypot(*flow)
    assert 0.65 * wanted < speed_out < 1.35 * wanted
    assert abs(np.degrees(np.arctan2(flow[0], flow[1]))) < 20  # to the right


def test_the_rendering_option_round_trips():
    p = AnimateParams(rendering="paper", travel=20.0, detail=0.5)
    assert AnimateParams.from_dict(p.to_dict()) == p
    assert AnimateParams().rendering == "flow"
    with pytest.raises(ValueError, match="rendering must be one of"):
        AnimateParams(rendering="fast")


# ------------------------------------------------------------------ no fragment in sync


def test_neighbours_sharing_a_fragment_get_offsets_a_quarter_loop_apart():
    gen = np.random.default_rng(0)
    rows, cols = np.mgrid[:6, :8]
    pos = np.stack([rows.ravel(), cols.ravel()], axis=1) * 24
    ids = gen.integers(0, 3, len(pos))
    off = temporal_offsets(ids, pos, 24)
    grid = {tuple(p // 24): i for i, p in enumerate(pos)}
    gaps = []
    for (r, c), i in grid.items():
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                j = grid.get((r + dr, c + dc))
                if j is not None and j != i and ids[i] == ids[j]:
                    gap = abs(int(off[i]) - int(off[j])) % 24
                    gaps.append(min(gap, 24 - gap))
    # At most 4 earlier neighbours each rule out 5 offsets: an eighth of the loop is
    # always possible, a quarter almost always.
    assert min(gaps) >= 3
    assert np.mean(np.array(gaps) >= 6) > 0.8
    assert sync_share(ids, pos) > 0.2  # before: a third of the neighbours share one
    assert sync_share(ids, pos, off) == 0.0
    # A fragment with no twin next to it keeps offset 0 (renders as before).
    assert temporal_offsets([1, 2, 3], [[0, 0], [0, 24], [0, 48]], 24).tolist() == [0, 0, 0]


def test_staggered_loops_are_the_whole_clips_loop_when_not_shifted():
    gen = np.random.default_rng(1)
    diffs = gen.standard_normal((4, 8, 72, 72)).astype(np.float32)
    pos = np.array([[0, 0], [0, 24], [24, 0], [24, 24]])
    looped = blend_differences(stagger(diffs, np.zeros(4), overlap=2), pos, (96, 96), margin=12)
    whole = loop_crossfade(blend_differences(diffs, pos, (96, 96), margin=12), overlap=2)
    np.testing.assert_allclose(looped, whole, atol=1e-5)
    shifted = stagger(diffs, [0, 3, 0, 5], overlap=2)
    base = stagger(diffs, np.zeros(4), overlap=2)
    np.testing.assert_array_equal(shifted[1], np.roll(base[1], -3, axis=0))


def test_a_uniform_photo_no_longer_plays_a_fragment_in_sync(db):
    img = np.full((96, 168, 3), 0.5, np.float32) + 0.2 * texture(7, (96, 168))[..., None]
    a = assign(img, None, db, AnimateParams(candidates=3, lam=1.0, loop=4))
    anim = render(a, FEW.replace(rendering="paper"))
    pos = a.target.positions
    st = anim.stages
    assert sync_share(a.fragments, pos) > 0  # the MRF repeats fragments
    assert sync_share(a.fragments, pos, st["offsets"]) == 0.0
    assert sync_share(a.fragments, pos, st["offsets"], st["mirrors"]) == 0.0
    assert (st["mirrors"] >= 0).any()
    # Everything moves right: mirrored fragments are flipped upside down (axis 0),
    # which keeps their motion.
    assert set(st["mirrors"].tolist()) <= {-1, 0}


def test_repeated_neighbours_alternate_mirrors_across_their_motion():
    pos = np.array([[0, 24 * k] for k in range(6)])
    sideways = np.tile([0.1, 1.0], (6, 1))
    assert mirror_axes([4] * 6, pos, sideways).tolist() == [-1, 0, -1, 0, -1, 0]
    upwards = np.tile([-1.0, 0.2], (6, 1))
    assert mirror_axes([4] * 6, pos, upwards).tolist() == [-1, 1, -1, 1, -1, 1]
    assert mirror_axes([1, 2, 3, 4, 5, 6], pos, sideways).tolist() == [-1] * 6
    # The frames of a mirrored fragment are flipped, and only its.
    gen = np.random.default_rng(4)
    diffs = gen.standard_normal((2, 8, 6, 6)).astype(np.float32)
    plain = stagger(diffs, [0, 0], overlap=2)
    flipped = stagger(diffs, [0, 0], overlap=2, mirrors=[-1, 0])
    np.testing.assert_array_equal(flipped[0], plain[0])
    np.testing.assert_array_equal(flipped[1], plain[1][:, ::-1])


# ------------------------------------------------------------------ exemplar fill


def _stripes_and_checks():
    yy, xx = np.mgrid[:64, :80]
    stripes = ((xx // 4) % 2).astype(np.float32)
    checks = (((yy // 6) + (xx // 6)) % 2).astype(np.float32)
    hole = np.zeros((64, 80), bool)
    hole[22:42, 28:52] = True
    return stripes, checks, hole


def test_the_fill_continues_a_texture_where_telea_smears_it():
    stripes, checks, hole = _stripes_and_checks()
    for truth in (stripes, checks):
        rgb = np.repeat(truth[..., None], 3, axis=2)
        given = np.where(hole[..., None], 0.5, rgb)
        ours = exemplar_fill(given, hole)
        telea = cv2.inpaint(to_uint8(given), hole.astype(np.uint8), 3, cv2.INPAINT_TELEA) / 255.0
        err_ours = np.abs(ours - rgb)[hole].mean()
        err_telea = np.abs(telea - rgb)[hole].mean()
        assert err_ours < 0.5 * err_telea  # stripes: 0.0 against 0.4
        assert np.array_equal(ours[~hole], given[~hole])  # outside: untouched


def test_the_fast_fill_matches_almost_as_well_as_the_exhaustive_one():
    gen = np.random.default_rng(3)
    img = np.stack([texture(11, (40, 48), blur=1.0)] * 3, axis=-1)
    img += 0.05 * gen.standard_normal(img.shape).astype(np.float32)
    hole = np.zeros((40, 48), bool)
    hole[14:26, 16:30] = True
    fast = exemplar_fill(img, hole)
    ref = reference_fill(img, hole)
    # Both fills reproduce the texture's statistics; the exhaustive one's matches are
    # the best there are, so ours is at most a little worse at explaining the hole.
    for out in (fast, ref):
        assert abs(out[hole].std() - img[~hole].std()) < 0.5 * img[~hole].std()
    err = [np.abs(out - img)[hole].mean() for out in (fast, ref)]
    assert err[0] < 1.25 * err[1] + 0.02
    # Where exact matches exist (periodic textures; a ramp across the hole, matched
    # above and below it), both find one and fill alike: the same pixels. Mutations
    # caught: the last step copying the pixel beside each match's centre (an
    # off-by-one in _complete); every vote divided by one patch too many (_vote: the
    # ramp's coarse estimate comes out darker, and its matches with it).
    stripes, checks, hole = _stripes_and_checks()
    ramp = np.broadcast_to(np.linspace(0, 1, 80, dtype=np.float32), hole.shape)
    for truth in (stripes, checks, ramp):
        given = np.where(hole[..., None], 0.5, np.repeat(truth[..., None], 3, axis=2))
        np.testing.assert_array_equal(exemplar_fill(given, hole), reference_fill(given, hole))


def test_the_fill_refuses_a_hole_that_leaves_no_patch():
    with pytest.raises(ValueError, match="no 7 x 7 patch"):
        exemplar_fill(np.zeros((10, 10)), np.ones((10, 10)))
    with pytest.raises(ValueError, match="hole must have the image's height and width"):
        exemplar_fill(np.zeros((10, 10)), np.ones((10, 11)))


def test_a_fragment_played_faster_skips_frames_and_still_loops():
    gen = np.random.default_rng(2)
    diffs = gen.standard_normal((2, 12, 4, 4)).astype(np.float32)
    base = stagger(diffs, [0, 0], overlap=4)  # loops of 8 frames
    fast = stagger(diffs, [0, 0], overlap=4, rates=[1, 2], n_frames=8)
    np.testing.assert_array_equal(fast[0], base[0])
    np.testing.assert_array_equal(fast[1], base[1][np.arange(8) * 2 % 8])  # every other frame
    half = stagger(diffs, [0, 0], overlap=4, rates=[1, 0.5], n_frames=16)
    np.testing.assert_allclose(half[1][1], 0.5 * (base[1][0] + base[1][1]), atol=1e-6)
    np.testing.assert_array_equal(half[1][::2], base[1])


def test_the_maps_are_the_recurrence_step_by_step_and_usable_as_made():
    # Both recurrences on their own threads, each sampling point worked out once and
    # each map written in place: the maps warp after warp, bit for bit, and a map can
    # be used as soon as it is made.
    from fluidnb.videodb.rendering._flow_render import _grid, _Maps, _remap

    yy, xx = np.mgrid[:40, :52]
    v = np.stack([0.7 * np.sin(xx / 7.0), 1.3 + 0.4 * np.cos(yy / 6.0)], axis=-1)
    v = v.astype(np.float32)
    steps = 6
    grid = _grid((40, 52))
    expected = np.zeros((2 * steps + 1, 40, 52, 2), np.float32)
    for sign in (1, -1):
        for s in range(1, steps + 1):
            prev = expected[steps + sign * (s - 1)]
            expected[steps + sign * s] = _remap(prev, -sign * v, grid) - sign * v
    maps = displacement_maps(v, steps)
    assert np.array_equal(maps.view(np.uint32), expected.view(np.uint32))
    made = _Maps(v, steps).wait(-2.5, 1)  # the fractional age: both maps around it
    for s in (-3, -2, -1, 0, 1):
        assert np.array_equal(made.maps[steps + s], expected[steps + s])
    assert displacement_maps(v, 0).shape == (1, 40, 52, 2)


def test_compact_maps_read_back_the_maps_to_float16_precision():
    # The renderer keeps its maps as float16 residuals D_s + s v (issue 39: half the
    # bytes); read back they are the float32 maps to well below OpenCV's 1/32 px, and
    # the staggered kernel reads them as the array path does.
    from fluidnb.videodb.rendering._flow_render import _grid, _Loop, _Maps, phase_offsets

    yy, xx = np.mgrid[:40, :52]
    v = np.stack([0.7 * np.sin(xx / 7.0), 1.3 + 0.4 * np.cos(yy / 6.0)], axis=-1)
    v = v.astype(np.float32)
    steps = 12
    exact = displacement_maps(v, steps)
    compact = _Maps(v, steps, compact=True).wait(-steps, steps)
    assert compact.maps.dtype == np.float16
    assert compact.maps.nbytes * 2 == exact.nbytes
    ages = np.arange(-steps, steps + 1, dtype=np.float32)[:, None, None, None]
    residual = np.abs(exact + ages * v).max()
    assert 2 < residual < 16  # the flow bends: residuals of pixels
    error = max(np.abs(compact.at(i) - exact[i]).max() for i in range(2 * steps + 1))
    # Lossy by float16's rounding of the residual (2^-11 relative), far below 1/32 px.
    assert 0 < error <= residual * 2.0**-11 + 1e-5, (error, residual)
    assert error < 1 / 128
    # A uniform flow is carried in straight lines (away from the clamped border): the
    # residuals are 0 and the maps exact.
    uniform = np.broadcast_to(np.float32([0.5, -1.25]), v.shape).copy()
    flat = _Maps(uniform, 4, compact=True).wait(-4, 4)
    for i in range(9):
        inner = (slice(8, -8), slice(8, -8))
        assert np.array_equal(flat.at(i)[inner], displacement_maps(uniform, 4)[i][inner])
    # The staggered coordinates from the compact maps are those of the decoded array.
    loop = _Loop(24, 24, phase_offsets((40, 52), 16), (40, 52))
    grid = _grid((40, 52))
    decoded = np.stack([compact.at(i) for i in range(2 * steps + 1)])
    for t in (0, 5, 17):
        got = loop.coordinates(compact, grid, t, scale=2)
        want = loop.coordinates(decoded, grid, t, scale=2)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)


def test_what_renders_share_is_kept_and_the_clip_stays_the_same(assignment, monkeypatch):
    # What renders of one photo share (the blend's weights, the colour axes and the
    # matching's reference side, the advected layer) is kept with the target; the
    # motion field and the maps with the last assignment, for its loop and travel.
    # Renders from what is kept are renders made afresh, bit for bit.
    from fluidnb.videodb.rendering import _shared

    base = assignment.params
    other = assignment.resolve(lam=0.0)  # another choice of fragments
    cases = [
        (assignment, base),
        (assignment, base.replace(detail=0.2, cell=24)),
        (assignment, base.replace(travel=4.0)),
        (other, base),
        (assignment, base.replace(tau=0.5)),
        (assignment, base.replace(rendering="paper")),
    ]
    kept = [render(a, p, stages=False).clip.frames for a, p in cases]
    assert assignment.target in _shared._SHARED
    shared = _shared._SHARED[assignment.target]
    assert {"blend", "layer", ("axes", 48), ("axes", 24), "behind"} <= set(shared)
    flow = shared["flow"][2]
    assert not flow["velocity"].flags.writeable
    for (a, p), clip in zip(cases, kept):
        _shared._SHARED.clear()
        fresh = render(a, p, stages=False).clip.frames
        assert np.array_equal(fresh.view(np.uint32), clip.view(np.uint32))
    assert not np.array_equal(kept[0], kept[2])  # the travel's own field and maps
    assert not np.array_equal(kept[0], kept[3])


def test_a_process_may_end_while_the_maps_are_being_made():
    # The maps' threads are waited for at exit, also when a daemon thread (an app's
    # worker) made them: a daemon thread inside OpenCV when the interpreter ends
    # aborts the process (a script that renders and exits, a kernel shut down after
    # a prefetch).
    import subprocess
    import sys

    code = (
        "import threading, time\n"
        "import numpy as np\n"
        "from fluidnb.videodb.rendering._flow_render import _Maps\n"
        "v = np.full((384, 480, 2), 0.5, np.float32)\n"
        "threading.Thread(target=_Maps, args=(v, 400), daemon=True).start()\n"
        "time.sleep(0.1)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120)
    assert done.returncode == 0, done.stderr.decode()[-500:]


def test_the_fields_spread_is_the_numpy_loop_bit_for_bit():
    # flow_field spreads the fragments' values with a compiled loop: the numpy
    # loop's sums.
    from fluidnb.videodb.rendering._flow_render import _spread

    gen = np.random.default_rng(4)
    positions = np.array([(r, c) for r in range(0, 97, 24) for c in range(0, 121, 24)])
    weights = gen.random((len(positions), 48, 48))
    values = gen.standard_normal((len(positions), 4))
    acc, covered = np.zeros((144, 168, 4)), np.zeros((144, 168))
    _spread(positions, weights, values, acc, covered)
    want, want_covered = np.zeros_like(acc), np.zeros_like(covered)
    for (r, c), w, v in zip(positions, weights, values):
        want[r : r + 48, c : c + 48] += w[..., None] * v
        want_covered[r : r + 48, c : c + 48] += w
    assert np.array_equal(acc, want)
    assert np.array_equal(covered, want_covered)


def boiling(seed, shape=(96, 120), frames=32):
    """A texture jittered each frame by a fresh fine random warp: its pixels move, but
    a fragment's mean motion is about 0 (the still parts of real footage: sensor noise,
    compression, a plant in the wind)."""
    base = texture(seed, shape)
    gen = np.random.default_rng(seed)
    yy, xx = np.mgrid[: shape[0], : shape[1]].astype(np.float32)
    out = []
    for _ in range(frames):
        d = ndi.gaussian_filter(gen.standard_normal((2,) + shape), (0, 1.0, 1.0)) * 2.0
        out.append(ndi.map_coordinates(base, [yy + d[0], xx + d[1]], order=1, mode="wrap"))
    return np.repeat(np.clip(np.stack(out), 0, 1)[..., None], 3, axis=3).astype(np.float32)


def test_the_output_moves_when_the_chosen_fragments_move(tmp_path, photo):
    # Footage of real scenes holds still parts beside the fluid; a photo's water may
    # look like them. On a database with a still clip among moving ones the
    # assignment chooses moving fragments, and the photo moves with them.
    from fluidnb.videodb.assignment import fragment_speeds, moving_fragments

    img, matte = photo
    clips = [("still", boiling(20))] + [(f"right{i}", moving(i, (0, 3))) for i in range(3)]
    db = build_database(clips, tmp_path / "mixed", kind="water", params=PARAMS, seed=0)
    still = db.clip_of(np.arange(db.n_fragments)) == 0  # its pixels move, it does not
    assert still.any()
    assert not moving_fragments(db)[still].any()
    a = assign(img, matte, db, FEW)
    assert not still[a.fragments].any()
    assert a.chosen_speed() > 0.5
    assert a.stillness_note() is None
    f = render(a, FEW).clip.frames
    inner = ndi.binary_erosion(matte > 0.5, iterations=12)
    assert np.hypot(*measured_flow(f, inner)) > 0.5
    # A database of still footage only: the photo barely moves, and the note says so.
    db = build_database([("still", boiling(20))], tmp_path / "still", kind="water",
                        params=PARAMS, seed=0)  # fmt: skip
    a = assign(img, matte, db, FEW)
    assert np.median(fragment_speeds(db)) < 0.25
    assert "barely move (median" in a.stillness_note()
    f = render(a, FEW).clip.frames
    assert np.hypot(*measured_flow(f, inner)) < 0.25


def test_frames_made_on_the_mattes_box_are_the_whole_canvas_frames(db, monkeypatch):
    # With a still matte (tau = 0) and no stages, each frame is made on the matte's
    # box only (grown by BOX_MARGIN: the phases' cross-fade filters with pyramids) and
    # is the photo elsewhere (_FlowFrames._boxed): the same pixels as the frames made
    # on the whole canvas, bit for bit. Mutations caught: no margin (the cross-fade's
    # pyramids differ near the box's edges), the box's matching with the whole
    # canvas's bilinear roles, the coordinates not shifted to the box (_staggered).
    from fluidnb.videodb.rendering import _steps

    img = np.stack([texture(9, (128, 192), blur=2.0)] * 3, axis=-1) * [0.5, 0.7, 0.9]
    img = img.astype(np.float32)
    matte = np.zeros((128, 192), np.float32)
    matte[40:88, 56:136] = 1.0
    matte = ndi.gaussian_filter(matte, 1.0)
    a = assign(img, matte, db, FEW)
    box = _steps._matte_box(a.target.canvas_matte, img.shape[:2])
    assert box is not None  # there is something outside the box
    assert box[2] > 0
    assert box[3] < 192
    r0, r1, c0, c1 = box
    outside = np.ones(img.shape[:2], bool)
    outside[r0:r1, c0:c1] = False
    for params in (FEW, FEW.replace(cell=24, travel=4.0, detail=0.2)):
        boxed = render(a, params, stages=False).clip.frames
        monkeypatch.setattr(_steps, "_BOX", False)
        whole = render(a, params, stages=False).clip.frames
        monkeypatch.setattr(_steps, "_BOX", True)
        assert np.array_equal(boxed.view(np.uint32), whole.view(np.uint32))
        assert np.array_equal(
            boxed[:, outside], np.broadcast_to(img[outside], boxed[:, outside].shape)
        )
        assert np.abs(np.diff(boxed[:, r0:r1, c0:c1], axis=0)).max() > 0.05  # it moves
    # The frames kept with the stages (made on the whole canvas) are the same frames.
    staged = render(a, FEW).clip.frames
    assert np.array_equal(
        staged.view(np.uint32), render(a, FEW, stages=False).clip.frames.view(np.uint32)
    )


def test_the_matte_box_holds_the_matte_with_a_margin_on_the_grid():
    from fluidnb.videodb.rendering import _steps

    alpha = np.zeros((100, 120), np.float32)
    assert _steps._matte_box(alpha, (100, 120)) is None
    alpha[45, 37] = 0.01
    alpha[50:53, 60:70] = 1.0
    assert _steps._matte_box(alpha, (100, 120), margin=10, grid=8) == (32, 64, 24, 80)
    assert _steps._matte_box(alpha, (100, 120), margin=0, grid=1) == (45, 53, 37, 70)
    # Within the canvas; the whole picture: None.
    assert _steps._matte_box(alpha, (100, 120), margin=40, grid=8) == (0, 96, 0, 112)
    assert _steps._matte_box(alpha, (90, 100), margin=50, grid=8) is None


def _two_mattes():
    """Two pools in opposite corners of their box, and a diagonal stream (160, 192)."""
    pools = np.zeros((192, 256), np.float32)
    pools[48:72, 48:88] = 1.0
    pools[120:144, 160:200] = 1.0
    yy, xx = np.mgrid[:160, :192]
    stream = (np.abs((yy - 48) - 0.6 * (xx - 48)) < 8).astype(np.float32)
    stream[:48] = stream[104:] = 0
    stream[:, :48] = stream[:, 140:] = 0
    return [ndi.gaussian_filter(m, 1.0) for m in (pools, stream)]


def _spans_of(alpha, box):
    """What _FlowFrames makes a frame on: the spans, the blend's groups, the sampled pieces."""
    from fluidnb.videodb.rendering import _steps

    span_box = _steps._matte_box(alpha, (0, 0), _steps.SPAN_MARGIN, 1)
    spans = _steps._band_spans(alpha, span_box, _steps.SPAN_MARGIN)
    groups = _steps._blend_groups(spans, box)
    return spans, groups, _steps._pieces(groups, spans, box)


@pytest.mark.parametrize("which", [0, 1])
def test_frames_sampled_band_by_band_are_the_box_and_canvas_frames(db, monkeypatch, which):
    # A matte that fills little of its box: each frame is made on the spans near the
    # matte only (_FlowFrames._spanned): the phases sampled within BLEND_CONTEXT of
    # them, the layer elsewhere in the cross-fade's rectangles (_banded), the colour
    # axes on the spans, the matching's map and the composite on the matte's own
    # spans, the photo elsewhere. Every frame is the box's and the whole canvas's,
    # bit for bit (the histograms' bins span the same pixels near the matte in all
    # three), with the cross-fade on few rectangles or on one per span.
    # Mutations caught: a context of 12 px (the rectangles' borders reach the spans),
    # the phases sampled 12 px around the spans, spans without the rows either side
    # of a band, the coordinates not shifted to the span, the photo written over the
    # matte's spans or not around them.
    from fluidnb.videodb.rendering import _steps

    matte = _two_mattes()[which]
    shape = matte.shape
    img = np.stack([texture(4, shape, blur=2.0)] * 3, axis=-1) * [0.5, 0.7, 0.9]
    img = img.astype(np.float32)
    a = assign(img, matte, db, FEW)
    box = _steps._matte_box(a.target.canvas_matte, shape)
    assert box is not None
    r0, r1, c0, c1 = box
    _, _, (bands, _) = _spans_of(a.target.canvas_matte, box)
    area = ((bands[:, 1] - bands[:, 0]) * (bands[:, 3] - bands[:, 2])).sum()
    # Part of the box left out (the pools: a quarter; this small stream: 4 %, but it
    # is where a context of 12 px leaves pixels the bins read wrong).
    assert area < (0.75, 0.97)[which] * (r1 - r0) * (c1 - c0)
    grouped = _steps._blend_groups

    def apart(spans, box):  # one rectangle a span: the most edges inside the box
        return [grouped(x[None], box)[0] for x in spans]

    calls = []
    banded = _steps._FlowFrames._banded
    monkeypatch.setattr(
        _steps._FlowFrames, "_banded", lambda s, *x: calls.append(1) or banded(s, *x)
    )
    for params in (FEW, FEW.replace(cell=24, travel=4.0, detail=0.2)):
        made = []
        for groups in (grouped, apart):
            monkeypatch.setattr(_steps, "_blend_groups", groups)
            calls.clear()
            made.append(render(a, params, stages=False).clip.frames)
            assert calls  # the bands were used
        monkeypatch.setattr(_steps, "_blend_groups", grouped)
        monkeypatch.setattr(_steps, "_BANDS", False)
        boxed = render(a, params, stages=False).clip.frames
        monkeypatch.setattr(_steps, "_BOX", False)
        whole = render(a, params, stages=False).clip.frames
        monkeypatch.setattr(_steps, "_BOX", True)
        monkeypatch.setattr(_steps, "_BANDS", True)
        for bands_out in made:
            assert np.array_equal(bands_out.view(np.uint32), boxed.view(np.uint32))
            assert np.array_equal(bands_out.view(np.uint32), whole.view(np.uint32))
        inside = a.target.canvas_matte[: shape[0], : shape[1]] > 0.5
        assert np.abs(np.diff(made[0][:, inside], axis=0)).max() > 0.05  # it moves


def test_the_cross_fade_on_its_rectangles_is_the_boxs_on_the_spans():
    # The spans' frames cross-fade the phases on a few rectangles (_blend_groups)
    # around the spans, each grown by BLEND_CONTEXT and started on the box's grid:
    # on every span, the box's blend bit for bit, whatever the phases (random: the
    # pyramids' borders reach farthest), with the phases sampled only within
    # BLEND_CONTEXT of the spans (_pieces) and the layer elsewhere. A context of 12
    # px, or a rectangle started off the grid, or the phases sampled 12 px around
    # the spans, leaves pixels of the spans off: the test fails if a span is cut
    # too short.
    from fluidnb.videodb.rendering import _steps
    from fluidnb.videodb.rendering._phase_blend import _blend

    yy, xx = np.mgrid[:260, :320]
    alpha = (np.abs(yy - 0.6 * xx - 20) < 10).astype(np.float32)
    alpha[:48] = alpha[200:] = 0
    alpha[:, :56] = alpha[:, 270:] = 0
    alpha = ndi.gaussian_filter(alpha, 1.0)
    h, w = alpha.shape
    box = _steps._matte_box(alpha, (h, w))
    r0, r1, c0, c1 = box
    gen = np.random.default_rng(11)
    pa, pb, layer = gen.random((3, h, w, 3), dtype=np.float32)
    pw = gen.random((h, w), dtype=np.float32)

    def blended(a, b, wa):
        out = np.empty(a.shape, np.float32)
        a, b, wa = (np.ascontiguousarray(x) for x in (a, b, wa))
        return _blend(a, b, wa, out)

    truth = blended(pa[r0:r1, c0:c1], pb[r0:r1, c0:c1], pw[r0:r1, c0:c1])

    def off(context=_steps.BLEND_CONTEXT, grid=_steps.BLEND_GRID, reach=_steps.BLEND_CONTEXT):
        """Pixels of the spans where the rectangles' blend is not the box's."""
        span_box = _steps._matte_box(alpha, (0, 0), _steps.SPAN_MARGIN, 1)
        spans = _steps._band_spans(alpha, span_box, _steps.SPAN_MARGIN)
        # One rectangle a span: the most edges inside the box.
        groups = [_steps._blend_groups(x[None], box, context, grid)[0] for x in spans]
        sampled, layered = _steps._pieces(groups, spans, box, reach)
        a, b = (np.full((h, w, 3), np.nan, np.float32) for _ in range(2))
        wa = np.full((h, w), np.nan, np.float32)
        for p0, p1, q0, q1 in sampled:
            cut = np.s_[p0:p1, q0:q1]
            a[cut], b[cut], wa[cut] = pa[cut], pb[cut], pw[cut]
        for p0, p1, q0, q1 in layered:
            cut = np.s_[p0:p1, q0:q1]
            assert np.isnan(wa[cut]).all()  # sampled and layer are disjoint
            a[cut], b[cut], wa[cut] = layer[cut], layer[cut], 1
        wrong = 0
        for (g0, g1, f0, f1), held in groups:
            assert r0 <= g0 < g1 <= r1
            assert c0 <= f0 < f1 <= c1
            assert (g0 - r0) % grid == 0
            assert (f0 - c0) % grid == 0
            assert not np.isnan(wa[g0:g1, f0:f1]).any()  # the rectangles are whole
            moved = blended(a[g0:g1, f0:f1], b[g0:g1, f0:f1], wa[g0:g1, f0:f1])
            for s0, s1, e0, e1 in held:
                part = moved[s0 - g0 : s1 - g0, e0 - f0 : e1 - f0]
                want = truth[s0 - r0 : s1 - r0, e0 - c0 : e1 - c0]
                wrong += int((part.view(np.uint32) != want.view(np.uint32)).sum())
        assert np.array_equal(np.concatenate([x for _, x in groups]), spans)  # in order
        return wrong, len(groups)

    wrong, n = off()
    assert wrong == 0
    assert n >= 6
    assert off(context=12)[0] > 0
    assert off(grid=2)[0] > 0
    assert off(reach=12)[0] > 0


def test_the_spans_groups_cost_less_than_the_box_and_hold_every_span():
    from fluidnb.videodb.rendering import _steps

    alpha = _two_mattes()[0]
    box = _steps._matte_box(alpha, alpha.shape)
    spans, groups, _ = _spans_of(alpha, box)
    area = sum((g1 - g0) * (f1 - f0) for (g0, g1, f0, f1), _ in groups)
    assert area < 0.8 * (box[1] - box[0]) * (box[3] - box[2])  # the pools: the corners left
    for (g0, g1, f0, f1), held in groups:
        for s0, s1, e0, e1 in held:  # each span BLEND_CONTEXT inside, or at the box's edge
            assert s0 - g0 >= _steps.BLEND_CONTEXT or g0 == box[0]
            assert g1 - s1 >= _steps.BLEND_CONTEXT or g1 == box[1]
            assert e0 - f0 >= _steps.BLEND_CONTEXT or f0 == box[2]
            assert f1 - e1 >= _steps.BLEND_CONTEXT or f1 == box[3]
    # At a huge cost per call, one rectangle for all.
    assert len(groups) > 1
    assert len(_steps._blend_groups(spans, box, call=10**9)) == 1
    assert _steps._blend_groups(np.zeros((0, 4), int), box) == []


def test_the_band_spans_hold_every_pixel_near_the_matte():
    from fluidnb.videodb.rendering import _steps

    rng = np.random.default_rng(3)
    alpha = np.zeros((150, 130), np.float32)
    alpha[rng.integers(20, 130, 12), rng.integers(10, 120, 12)] = 0.3
    alpha[60:64, 30:90] = 1.0
    box = (8, 144, 0, 128)
    for margin, band in ((0, 1), (5, 8), (16, 32), (32, 32)):
        spans = _steps._band_spans(alpha, box, margin, band)
        covered = np.zeros(alpha.shape, int)
        for s0, s1, t0, t1 in spans:
            assert box[0] <= s0 < s1 <= box[1]
            assert box[2] <= t0 < t1 <= box[3]
            assert (s0 - box[0]) % band == 0
            covered[s0:s1, t0:t1] += 1
        assert covered.max() == 1  # the bands do not overlap
        near = ndi.maximum_filter(alpha > 0, size=2 * margin + 1, mode="constant")
        near[: box[0]] = near[box[1] :] = False
        near[:, : box[2]] = near[:, box[3] :] = False
        assert covered[near].all()
        assert covered.sum() < near.size
    assert _steps._band_spans(np.zeros((20, 20)), (0, 20, 0, 20), 4).shape == (0, 4)


def test_bins_over_parts_are_the_bins_of_their_pixels():
    from fluidnb.videodb.rendering._histograms import _bins, _bins_over

    rng = np.random.default_rng(5)
    img = rng.random((40, 50, 3)).astype(np.float32)
    rects = [(0, 10, 5, 20), (10, 25, 30, 50), (30, 40, 0, 3), (5, 5, 0, 50)]
    pixels = np.concatenate([img[r0:r1, c0:c1].reshape(-1, 3) for r0, r1, c0, c1 in rects])
    for want, got in zip(_bins(pixels[None]), _bins_over(img, rects)):
        assert np.array_equal(want, got)
    assert not np.array_equal(_bins(img)[0], _bins_over(img, rects)[0])


def test_histograms_counted_on_the_mattes_spans_are_the_whole_frames():
    # _Matching.match's counted: only the spans that hold every pixel of weight > 0
    # are read for the histograms, which add the same weights in the same order:
    # the matched frame is the whole frame's, bit for bit. Spans that leave a
    # weighted pixel out change it.
    from fluidnb.videodb.rendering import _steps
    from fluidnb.videodb.rendering._histograms import _Matching

    alpha = _two_mattes()[1]
    gen = np.random.default_rng(8)
    reference = gen.random(alpha.shape + (3,), dtype=np.float32)
    frame = (reference + 0.1 * gen.standard_normal(reference.shape)).astype(np.float32)
    matching = _Matching(reference, alpha.astype(np.float64), 24)
    spans = _steps._band_spans(alpha, (0, alpha.shape[0], 0, alpha.shape[1]), 0)
    assert (spans[:, 3] - spans[:, 2]).sum() * 32 < 0.5 * alpha.size  # most left out
    want = matching.match(frame, np.empty_like(frame))
    got = matching.match(frame, np.empty_like(frame), counted=spans)
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    short = spans.copy()
    short[:, 3] -= 2  # the last weighted columns of each band left out
    assert not np.array_equal(matching.match(frame, np.empty_like(frame), counted=short), want)
