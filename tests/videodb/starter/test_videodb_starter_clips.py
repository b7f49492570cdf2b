"""The clips the starter databases are built from: smoke, fire and water (quick mode)."""

import cv2
import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb import Cancelled, Clip
from fluidnb.fields import resize
from fluidnb.videodb.starter import _clips, _solver_clips, _water, flow_map_texture
from fluidnb.videodb.starter._clips import STARTER_KINDS, starter_clips

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
        recipes = _clips._RECIPES[kind]
        names = [r["name"] for r in recipes]
        assert 6 <= len(recipes) <= 8
        assert len(set(names)) == len(names)
    flows = {r["flow"]["type"] for r in _water._WATER}
    assert flows == {"uniform", "shear", "swirl", "falling"}
    assert _clips._FULL.shape == (180, 320)
    assert _clips._FULL.n_frames >= 64


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
    frames, velocity, texture = _clips._water_clip("river", quick=True, seed=0)
    assert np.array_equal(frames, quick["water"][0][1].frames)
    assert velocity.shape == (35, 96, 160, 2)
    assert texture.shape == (96, 160, 3)
    with pytest.raises(ValueError, match="recipe must be one of"):
        _clips._water_clip("ocean")


def dis_flow(frames):
    """OpenCV DIS (preset MEDIUM) between consecutive frames, as (dy, dx)."""
    u8 = np.clip(np.rint(grey(frames) * 255), 0, 255).astype(np.uint8)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    return np.stack([dis.calc(u8[t], u8[t + 1], None)[..., ::-1] for t in range(len(u8) - 1)])


def test_water_motion_is_what_optical_flow_measures():
    # The spec's check: DIS recovers the known flow of a shear clip to ~0.15-0.2 px
    # (median endpoint error) on the frame pairs away from the phases' restarts.
    frames, velocity, _ = _clips._water_clip("river", quick=True, seed=0)
    period = _water._WATER[0]["period"]
    measured = dis_flow(frames)
    error = np.linalg.norm(measured - velocity, axis=-1)[:, 8:-8, 8:-8]
    pairs = [t for t in range(len(error)) if t % (period // 2) and (t + 1) % (period // 2)]
    medians = np.median(error[pairs].reshape(len(pairs), -1), axis=1)
    assert np.median(medians) < 0.2
    assert medians.max() < 0.3
    speed = np.linalg.norm(velocity, axis=-1)
    assert 1.0 < np.median(speed) < 2.0  # a real motion, not a trivial one
    # The falling water goes down, fast.
    frames, velocity, _ = _clips._water_clip("cascade", quick=True, seed=0)
    measured = dis_flow(frames[:8])
    assert np.median(measured[..., 0]) > 2.5
    assert np.median(np.abs(measured - velocity[:7])) < 0.5


def test_water_motion_changes_in_time_as_filmed_water_does():
    # Gusts, eddies carried downstream and waves: the motion spectra (Eq. 2) hold
    # power beyond the mean (DC), in the known flow and in what optical flow measures,
    # so that sigma matters on water. Steady flows (the clips before 2026-11-25) had
    # a non-DC/DC ratio of ~0.004 (river) and ~0 (cascade).
    from fluidnb.videodb.database import motion_spectra

    for recipe in ("river", "cascade"):
        frames, velocity, _ = _clips._water_clip(recipe, quick=True, seed=0)
        for flow in (velocity[:31], dis_flow(frames[:32])[:, 8:-8, 8:-8]):
            spectra = motion_spectra(np.ascontiguousarray(flow), 16).astype(np.float64)
            dc = (spectra[0] ** 2).sum(axis=0)
            rest = spectra[1:].sum(axis=(0, 1))
            assert np.median(rest / dc) > 0.015, recipe


def test_water_texture_does_not_stretch():
    # Advected too long, a texture is drawn out into thin filaments and its fine
    # detail (high frequencies) grows; with the phases restarting every period it
    # stays like the texture itself (a little softer: bilinear sampling).
    for recipe in ("cascade", "river"):
        frames, velocity, texture = _clips._water_clip(recipe, quick=True, seed=0)
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
    doubled = _solver_clips._double(frames)
    expected = np.stack([resize(f, (14, 18)) for f in frames])
    assert doubled.shape == (3, 14, 18, 3)
    np.testing.assert_allclose(doubled, expected, atol=1e-6)
    grey_frames = frames[..., 0]
    np.testing.assert_allclose(_solver_clips._double(grey_frames), doubled[..., 0], atol=0)


def test_mosaic_is_periodic_and_keeps_the_sources_statistics():
    gen = np.random.default_rng(0)
    source = ndi.gaussian_filter(gen.random((40, 60, 3)), (1, 1, 0))
    texture = _water._mosaic([source], (48, 64), (24, 32), np.random.default_rng(1))
    assert texture.shape == (48, 64, 3)
    assert texture.dtype == np.float32
    np.testing.assert_allclose(texture.mean(axis=(0, 1)), source.mean(axis=(0, 1)), atol=0.02)
    assert abs(texture.std() / source.std() - 1) < 0.2
    # Seamless when tiled: a step across the wrap-around is like any other step.
    inner = np.abs(np.diff(texture, axis=1)).mean()
    seam = np.abs(texture[:, 0] - texture[:, -1]).mean()
    assert seam < 2 * inner


@pytest.mark.parametrize("recipe", [r["name"] for r in _water._WATER])
def test_water_flow_equals_the_frame_by_frame_reference(recipe):
    # _water_flow makes the whole sequence at once in float32 (products of functions of
    # time and of space, one batched FFT); the reference writes each frame's formula
    # out in float64. Same random draws, so the same flow to float32 round-off.
    # Mutation caught: the waves' sway added along dy in place of dx (_assemble_flow).
    from fluidnb.videodb.starter._reference import reference_water_flow

    spec = next(r for r in _water._WATER if r["name"] == recipe)
    shape, n_frames = _clips._QUICK.shape, 12
    fast = _water._water_flow(spec, shape, n_frames, np.random.default_rng(3))
    plain = reference_water_flow(spec, shape, n_frames, np.random.default_rng(3))
    assert fast.dtype == np.float32
    assert fast.shape == plain.shape == (n_frames - 1, *shape, 2)
    np.testing.assert_allclose(fast, plain, rtol=0, atol=1e-5)
    # The time-varying part is there (not only the steady flow).
    assert np.abs(np.diff(plain, axis=0)).max() > 0.05


@pytest.mark.parametrize("sigma", [6.0, 18.0])
def test_smooth_noise_is_a_periodic_gaussian_blur_of_the_noise(sigma):
    # The blur is applied to the noise's spectrum; in space it is scipy's periodic
    # Gaussian filter (with a kernel long enough that its truncation does not show).
    import scipy.fft
    from scipy import ndimage as ndi

    shape = (96, 160)
    noise = np.random.default_rng(1).standard_normal(shape)
    expected = ndi.gaussian_filter(noise, sigma, mode="wrap", truncate=8.0)
    spectrum = _water._smooth_noise(shape, np.random.default_rng(1), sigma)
    got = scipy.fft.irfft2(spectrum, s=shape)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
