"""The clips the starter databases are built from: smoke, fire and water (quick mode)."""

import cv2
import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb import Cancelled, Clip
from fluidnb.fields import resize
from fluidnb.videodb import _starter_clips as sc
from fluidnb.videodb._starter_clips import STARTER_KINDS, flow_map_texture, starter_clips

LUMA = np.array([0.2125, 0.7154, 0.0721], np.float32)


@pytest.fixture(scope="module")
def quick():
    """Every kind's quick clips with seed 0, made once for the module."""
    return {kind: starter_clips(kind, quick=True, seed=0) for kind in STARTER_KINDS}


def grey(frames):
    return frames @ LUMA


def high_frequency_energy(image):
    return float(np.mean(ndi.laplace(image.astype(np.float64)) ** 2))


# ------------------------------------------------------------------- starter_clips


@pytest.mark.parametrize("kind", STARTER_KINDS)
def test_each_kind_gives_the_promised_clips(quick, kind):
    clips = quick[kind]
    assert len(clips) == 2
    names = [name for name, _ in clips]
    assert len(set(names)) == 2
    assert all(name.startswith(f"{kind}-") for name in names)
    for name, clip in clips:
        assert isinstance(clip, Clip)
        assert clip.frames.shape == (36, 96, 160, 3)
        assert clip.frames.dtype == np.float32
        assert np.all(np.isfinite(clip.frames))
        assert clip.frames.min() >= 0.0
        assert clip.frames.max() <= 1.0
        assert clip.fps == 24.0
        meta = clip.metadata
        assert meta["method"] == f"starter-{kind}"
        assert meta["kind"] == kind
        assert name == f"{kind}-{meta['recipe']}"
        assert meta["seed"] == 0
        assert meta["quick"] is True
        assert isinstance(meta["clip_seed"], int)
        assert meta["params"]["n_frames"] == 36


def test_full_mode_recipes_are_many_and_distinct():
    # Full mode makes every recipe (too slow to run here): several per kind, all
    # different, the quick ones first.
    for kind in STARTER_KINDS:
        recipes = sc._RECIPES[kind]
        names = [r["name"] for r in recipes]
        assert 6 <= len(recipes) <= 8
        assert len(set(names)) == len(names)
    flows = {r["flow"]["type"] for r in sc._WATER}
    assert flows == {"uniform", "shear", "swirl", "falling"}
    assert sc._FULL.shape == (180, 320)
    assert sc._FULL.n_frames >= 64


@pytest.mark.parametrize("kind", STARTER_KINDS)
def test_same_seed_same_clips_bit_for_bit(quick, kind):
    again = starter_clips(kind, quick=True, seed=0)
    for (name, clip), (name2, clip2) in zip(quick[kind], again):
        assert name == name2
        assert np.array_equal(clip.frames, clip2.frames)


@pytest.mark.parametrize("kind", ["water", "smoke"])
def test_another_seed_gives_other_clips(quick, kind):
    other = starter_clips(kind, quick=True, seed=1)
    for (_, clip), (_, clip2) in zip(quick[kind], other):
        assert np.mean(np.abs(clip.frames - clip2.frames)) > 1e-3


@pytest.mark.parametrize("kind", STARTER_KINDS)
def test_the_clips_of_a_kind_differ(quick, kind):
    (_, a), (_, b) = quick[kind]
    assert np.mean(np.abs(a.frames - b.frames)) > 0.03
    assert a.metadata["params"] != b.metadata["params"]


@pytest.mark.parametrize("kind", STARTER_KINDS)
def test_every_clip_keeps_moving_to_its_end(quick, kind):
    for name, clip in quick[kind]:
        change = np.abs(np.diff(clip.frames, axis=0)).mean(axis=(1, 2, 3))
        # Every frame pair moves, and the end moves about as much as the start.
        assert change.min() > 1e-3, name
        assert change[-8:].mean() > 0.3 * change[:8].mean(), name


def test_water_clip_helper_gives_the_starter_frames_and_their_flow(quick):
    frames, velocity, texture = sc._water_clip("river", quick=True, seed=0)
    assert np.array_equal(frames, quick["water"][0][1].frames)
    assert velocity.shape == (35, 96, 160, 2)
    assert texture.shape == (96, 160, 3)
    with pytest.raises(ValueError, match="recipe must be one of"):
        sc._water_clip("ocean")


def dis_flow(frames):
    """OpenCV DIS (preset MEDIUM) between consecutive frames, as (dy, dx)."""
    u8 = np.clip(np.rint(grey(frames) * 255), 0, 255).astype(np.uint8)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    return np.stack([dis.calc(u8[t], u8[t + 1], None)[..., ::-1] for t in range(len(u8) - 1)])


def test_water_motion_is_what_optical_flow_measures():
    # The spec's check: DIS recovers the known flow of a shear clip to ~0.15-0.2 px
    # (median endpoint error) on the frame pairs away from the phases' restarts.
    frames, velocity, _ = sc._water_clip("river", quick=True, seed=0)
    period = sc._WATER[0]["period"]
    measured = dis_flow(frames)
    error = np.linalg.norm(measured - velocity, axis=-1)[:, 8:-8, 8:-8]
    pairs = [t for t in range(len(error)) if t % (period // 2) and (t + 1) % (period // 2)]
    medians = np.median(error[pairs].reshape(len(pairs), -1), axis=1)
    assert np.median(medians) < 0.2
    assert medians.max() < 0.3
    speed = np.linalg.norm(velocity, axis=-1)
    assert 1.0 < np.median(speed) < 2.0  # a real motion, not a trivial one
    # The falling water goes down, fast.
    frames, velocity, _ = sc._water_clip("cascade", quick=True, seed=0)
    measured = dis_flow(frames[:8])
    assert np.median(measured[..., 0]) > 2.5
    assert np.median(np.abs(measured - velocity[:7])) < 0.5


def test_water_texture_does_not_stretch():
    # Advected too long, a texture is drawn out into thin filaments and its fine
    # detail (high frequencies) grows; with the phases restarting every period it
    # stays like the texture itself (a little softer: bilinear sampling).
    for recipe in ("cascade", "river"):
        frames, velocity, texture = sc._water_clip(recipe, quick=True, seed=0)
        reference = high_frequency_energy(grey(texture))
        energy = np.array([high_frequency_energy(f) for f in grey(frames)]) / reference
        assert energy.min() > 0.6, recipe
        assert energy.max() < 1.2, recipe
    # The river's texture left to shear for up to 100 frames: filaments.
    stretched = flow_map_texture(texture, velocity, period=100, seed=0)
    energy = np.array([high_frequency_energy(f) for f in grey(stretched)]) / reference
    assert energy.min() > 1.5


def test_smoke_is_grey_over_a_black_background(quick):
    for name, clip in quick["smoke"]:
        frames = clip.frames
        # Most of each frame has no smoke and is black, exactly or nearly.
        black = (frames.max(axis=-1) < 0.01).mean(axis=(1, 2))
        assert black.min() > 0.4, name
        assert (frames == 0).mean() > 0.2, name
        # Smoke: light grey where dense, hardly any colour.
        assert frames.max() > 0.6, name
        assert np.ptp(frames, axis=-1).max() < 0.1, name


def test_fire_is_flames_over_black(quick):
    for name, clip in quick["fire"]:
        frames = clip.frames
        luma = grey(frames)
        assert (luma < 0.02).mean(axis=(1, 2)).min() > 0.4, name
        assert luma.max(axis=(1, 2)).min() > 0.5, name  # a bright flame in every frame
        # Flame colours where it burns: red >= green >= blue, but for the white-hot
        # core, near-neutral as in the photo (its brightest pixels have g ~ r + 0.01).
        r, g, b = np.moveaxis(frames[luma > 0.2], -1, 0)
        assert np.mean((r >= g - 0.03) & (g >= b)) > 0.95, name
        assert np.mean(r - b) > 0.2, name


def test_starter_clips_refuses_bad_arguments():
    with pytest.raises(ValueError, match="kind must be one of 'water', 'smoke', 'fire'"):
        starter_clips("lava")
    with pytest.raises(ValueError, match="quick must be True or False, got 'yes'"):
        starter_clips("water", quick="yes")
    with pytest.raises(ValueError, match="seed must be"):
        starter_clips("water", quick=True, seed=-1)
    with pytest.raises(ValueError, match="progress must be None or a callable"):
        starter_clips("water", quick=True, progress=3)


def test_progress_is_reported_and_can_cancel():
    seen = []
    starter_clips("water", quick=True, seed=0, progress=lambda f, m: seen.append(f))
    assert seen == sorted(seen)
    assert seen[-1] == 1.0
    assert len(seen) > 36  # at least once a frame

    def cancel_half_way(fraction, message):
        if fraction > 0.5:
            raise Cancelled("stop")

    with pytest.raises(Cancelled):
        starter_clips("water", quick=True, seed=0, progress=cancel_half_way)


def test_doubling_is_bilinear_resizing():
    frames = np.random.default_rng(0).random((3, 7, 9, 3)).astype(np.float32)
    doubled = sc._double(frames)
    expected = np.stack([resize(f, (14, 18)) for f in frames])
    assert doubled.shape == (3, 14, 18, 3)
    np.testing.assert_allclose(doubled, expected, atol=1e-6)
    grey_frames = frames[..., 0]
    np.testing.assert_allclose(sc._double(grey_frames), doubled[..., 0], atol=0)


def test_mosaic_is_periodic_and_keeps_the_sources_statistics():
    gen = np.random.default_rng(0)
    source = ndi.gaussian_filter(gen.random((40, 60, 3)), (1, 1, 0))
    texture = sc._mosaic([source], (48, 64), (24, 32), np.random.default_rng(1))
    assert texture.shape == (48, 64, 3)
    assert texture.dtype == np.float32
    np.testing.assert_allclose(texture.mean(axis=(0, 1)), source.mean(axis=(0, 1)), atol=0.02)
    assert abs(texture.std() / source.std() - 1) < 0.2
    # Seamless when tiled: a step across the wrap-around is like any other step.
    inner = np.abs(np.diff(texture, axis=1)).mean()
    seam = np.abs(texture[:, 0] - texture[:, -1]).mean()
    assert seam < 2 * inner


# ---------------------------------------------------------------- flow_map_texture


def test_flow_map_texture_is_exact_where_both_phases_agree():
    # Zero flow, no jitter: both phases are the texture itself, every frame too.
    tex = np.random.default_rng(0).random((12, 20, 3)).astype(np.float32)
    still = flow_map_texture(tex, np.zeros((12, 20, 2)), 10, jitter=False, preserve_contrast=False)
    assert all(np.array_equal(f, tex) for f in still)
    # Texture constant along a whole-pixel flow: nothing changes either.
    rows = np.repeat(np.random.default_rng(1).random((12, 1)), 20, axis=1).astype(np.float32)
    v = np.zeros((12, 20, 2))
    v[..., 1] = 2.0
    frames = flow_map_texture(rows, v, 9, period=4, jitter=False, preserve_contrast=False)
    assert all(np.array_equal(f, rows) for f in frames)


def test_flow_map_texture_shifts_by_the_flow():
    # A texture of period P v / 2 along a uniform whole-pixel flow v: the two phases
    # agree and frame t is the texture shifted by t v, exactly.
    tile = np.random.default_rng(2).random((6, 4)).astype(np.float32)
    tex = np.tile(tile, (1, 6))  # period 4 = P v / 2 with P = 8, v = 1
    v = np.zeros((12, 6, 24, 2))
    v[..., 1] = 1.0
    frames = flow_map_texture(tex, v, period=8, jitter=False, preserve_contrast=False)
    assert frames.shape == (13, 6, 24)
    for t, frame in enumerate(frames):
        assert np.array_equal(frame, np.roll(tex, t, axis=1))


def test_flow_map_texture_cross_fades_two_phases():
    # Each phase is the texture moved since its last restart: phase a restarts at
    # multiples of P, phase b half a period later; w_a = 1 - |2 (t mod P) / P - 1|.
    tex = np.random.default_rng(3).random((5, 32)).astype(np.float32)
    v = np.zeros((5, 32, 2))
    v[..., 1] = 1.0
    period = 8
    frames = flow_map_texture(tex, v, 20, period=period, jitter=False, preserve_contrast=False)
    for t, frame in enumerate(frames):
        age_a, age_b = t % period, (t - period // 2) % period
        wa = 1 - abs(2 * age_a / period - 1)
        expected = wa * np.roll(tex, age_a, axis=1) + (1 - wa) * np.roll(tex, age_b, axis=1)
        np.testing.assert_allclose(frame, expected, atol=1e-6)


def test_flow_map_texture_contrast_stays_constant():
    # Jittered phases are uncorrelated: a plain cross-fade dims the contrast by up to
    # 1/sqrt(2) at mid-fade, the variance-preserving blend keeps it.
    tex = (0.5 + 0.25 * (np.random.default_rng(4).random((64, 64)) - 0.5)).astype(np.float32)
    still = np.zeros((64, 64, 2))
    kept = flow_map_texture(tex, still, 17, period=16, seed=0).std(axis=(1, 2))
    plain = flow_map_texture(tex, still, 17, period=16, seed=0, preserve_contrast=False)
    plain = plain.std(axis=(1, 2))
    assert kept.min() > 0.95 * kept.max()
    assert plain.min() < 0.75 * plain.max()
    np.testing.assert_allclose(plain[4] / tex.std(), 1 / np.sqrt(2), atol=0.03)  # w_a = 1/2


def test_flow_map_texture_leaves_its_inputs_alone():
    tex = np.random.default_rng(5).random((8, 8, 3)).astype(np.float32)
    v = np.full((3, 8, 8, 2), 0.7)
    tex0, v0 = tex.copy(), v.copy()
    flow_map_texture(tex, v, seed=0)
    assert np.array_equal(tex, tex0)
    assert np.array_equal(v, v0)


def test_flow_map_texture_refuses_bad_arguments():
    tex = np.zeros((4, 6), np.float32)
    v = np.zeros((4, 6, 2))
    with pytest.raises(ValueError, match=r"texture must hold floats in \[0, 1\]"):
        flow_map_texture(tex + 2, v, 3)
    with pytest.raises(ValueError, match="texture must hold floats"):
        flow_map_texture(np.zeros((4, 6), np.uint8), v, 3)
    with pytest.raises(ValueError, match="velocity must have shape"):
        flow_map_texture(tex, np.zeros((4, 5, 2)), 3)
    with pytest.raises(ValueError, match="n_frames is required"):
        flow_map_texture(tex, v)
    with pytest.raises(ValueError, match="n_frames must be len"):
        flow_map_texture(tex, np.zeros((2, 4, 6, 2)), 5)
    with pytest.raises(ValueError, match="period must be an even integer"):
        flow_map_texture(tex, v, 3, period=7)
    with pytest.raises(ValueError, match="velocity contains"):
        flow_map_texture(tex, np.full((4, 6, 2), np.nan), 3)
