"""The method's invariants (spec 01-flicker, "Checks the tests must make")."""

import numpy as np
import pytest

from fluidnb import Cancelled, CancelToken, Clip
from fluidnb.flicker import (
    FlickerModel,
    FlickerParams,
    base_method,
    flicker,
    harmonic_height,
    height_from_luminance,
    initial_phase,
    temporal_frequencies,
)

MAPPINGS = ("plane", "convex", "concave", "flow")
SYMMETRIC = ("plane", "convex", "concave")


def photo(shape=(24, 40, 3), seed=0):
    """A smooth random picture with fine detail, so every spatial frequency is present."""
    rng = np.random.default_rng(seed)
    img = rng.random(shape)
    from scipy import ndimage

    img = 0.6 * ndimage.gaussian_filter(img, (2, 2, 0)[: len(shape)]) + 0.4 * img
    img = (img - img.min()) / (img.max() - img.min())
    return img.astype(np.float32)


def heights(model):
    return np.stack([model.height(t) for t in range(model.n_frames)])


# ---------------------------------------------------------------------- Eq. (1)


@pytest.mark.parametrize("branch", ["rising", "falling"])
@pytest.mark.parametrize(("T", "f0"), [(16, 2), (64, 4), (13, 5)])
def test_plane_without_noise_is_eq1_at_every_pixel_and_frame(branch, T, f0):
    img = photo()
    p = FlickerParams(mapping="plane", beta=0, T=T, f0=f0, branch=branch)
    H = heights(FlickerModel(img, params=p))
    alpha = initial_phase(height_from_luminance(img), p.A, p.C, branch)
    expected = harmonic_height(alpha, np.arange(T), A=p.A, C=p.C, f0=f0, T=T)
    np.testing.assert_allclose(H, expected, rtol=0, atol=2e-6)


def test_plane_without_noise_gives_the_base_methods_frames():
    img = photo()
    p = FlickerParams(mapping="plane", beta=0, T=16, f0=3, bump=4.0)
    ours = flicker(img, params=p).frames
    base = base_method(img, params=p).frames
    np.testing.assert_allclose(ours, base, rtol=0, atol=1e-5)
    assert np.abs(ours[4] - ours[0]).max() > 0.01  # and it does move


# ---------------------------------------------------------------------- frame 0


@pytest.mark.parametrize("mapping", MAPPINGS)
@pytest.mark.parametrize("branch", ["rising", "falling"])
@pytest.mark.parametrize("shape", [(24, 40, 3), (31, 17)])
def test_without_noise_frame0_is_the_input(mapping, branch, shape):
    img = photo(shape)
    p = FlickerParams(mapping=mapping, beta=0, T=16, branch=branch, bump=8.0, k=2.0)
    flow = (0.5, 0.25) if mapping == "flow" else None
    model = FlickerModel(img, params=p, flow=flow)
    np.testing.assert_allclose(model.height(0), height_from_luminance(img), rtol=0, atol=1e-6)
    clip = flicker(img, params=p, flow=flow)
    np.testing.assert_allclose(clip.frames[0], img, rtol=0, atol=1e-5)
    assert np.abs(clip.frames[5] - img).max() > 0.01


# ---------------------------------------------------------------------- the loop


@pytest.mark.parametrize("mapping", MAPPINGS)
def test_the_clip_has_period_T_and_its_end_flows_into_its_start(mapping):
    img = photo()
    T = 16
    p = FlickerParams(mapping=mapping, beta=0, T=T)
    flow = (0.3, -0.2) if mapping == "flow" else None
    model = FlickerModel(img, params=p, flow=flow)
    # Eq. (5) summed directly at a time past the loop, t + T (no index wrapped): each
    # spatial frequency turns f_c times per loop, so it is frame t again -- only
    # because f_c is a whole number of bins.
    F, fc = model.spectrum, model.frequencies
    crop = model._crop
    for t in (0, 3, 15):
        later = np.fft.ifft2(F * np.exp(2j * np.pi * fc * (t + T) / T))[crop]
        np.testing.assert_allclose(later, model.field(t), rtol=0, atol=1e-5)
    H = heights(model)
    steps = np.abs(np.diff(H, axis=0)).max(axis=(1, 2))
    wrap = np.abs(H[0] - H[-1]).max()
    # The step from the last frame back to the first is an ordinary step, not a jump.
    assert wrap <= 1.0001 * steps.max()
    assert wrap >= 0.5 * steps.min()


def test_the_loop_closes_with_noise_too():
    model = FlickerModel(photo(), params=FlickerParams(T=32), seed=4)
    H = heights(model)
    steps = np.abs(np.diff(H, axis=0)).mean(axis=(1, 2))
    wrap = np.abs(H[0] - H[-1]).mean()
    assert wrap <= steps.max()


def test_unrounded_frequencies_would_not_loop():
    # What the rounding of f_c buys: a non-integer frequency leaves a jump at the wrap.
    T = 16
    fc = temporal_frequencies((8, 8), FlickerParams(T=T), rounded=False)
    t = np.arange(T + 1)
    rotation = np.exp(2j * np.pi * fc[..., None] * t / T)
    assert np.abs(rotation[..., T] - rotation[..., 0]).max() > 0.1
    fc = temporal_frequencies((8, 8), FlickerParams(T=T))
    rotation = np.exp(2j * np.pi * fc[..., None] * t / T)
    np.testing.assert_allclose(rotation[..., T], rotation[..., 0], atol=1e-12)


# ---------------------------------------------------------------------- the spectrum


@pytest.mark.parametrize("mapping", ["convex", "concave"])
def test_each_spatial_frequency_oscillates_at_its_mapped_frequency(mapping):
    img = photo((20, 28))
    T = 32
    p = FlickerParams(mapping=mapping, beta=0, T=T, f0=6)
    model = FlickerModel(img, params=p)
    fc = model.frequencies
    assert len(np.unique(fc)) > 5
    # The complex field of Eq. (5): every spatial frequency sits in exactly one bin.
    field = np.stack([model.field(t) for t in range(T)])
    spec = np.abs(np.fft.fft(np.fft.fft2(field), axis=0))  # (f_t, f_y, f_x)
    strong = spec.max(axis=0) > 1e-6 * spec.max()
    assert strong.mean() > 0.99
    peak = spec.argmax(axis=0)
    np.testing.assert_array_equal(peak[strong], np.mod(fc, T)[strong])
    off = spec.sum(axis=0) - spec.max(axis=0)
    assert off.max() < 1e-3 * spec.max()


def test_convex_height_power_peaks_at_fc_per_spatial_frequency():
    img = photo((20, 28))
    T = 32
    p = FlickerParams(mapping="convex", beta=0, T=T, f0=3)
    model = FlickerModel(img, params=p)
    fc = model.frequencies
    assert fc.min() >= 1
    assert fc.max() < T / 2
    H = heights(model) - p.C
    power = np.abs(np.fft.fft(np.fft.fft2(H), axis=0)) ** 2
    positive = power[1 : T // 2]  # the height is real: f_t and -f_t mirror each other
    strong = positive.max(axis=0) > 1e-8 * positive.max()
    assert strong.mean() > 0.99
    np.testing.assert_array_equal(1 + positive.argmax(axis=0)[strong], fc[strong])


@pytest.mark.parametrize("beta", [1.0, 2.0, 3.0])
def test_noise_power_falls_as_distance_to_the_minus_beta(beta):
    img = photo((16, 24))
    T = 64
    p = FlickerParams(mapping="convex", beta=beta, T=T)
    model = FlickerModel(img, params=p, seed=1)
    field = np.stack([model.field(t) for t in range(T)])
    power = np.abs(np.fft.fft(np.fft.fft2(field), axis=0)) ** 2
    fc = np.mod(model.frequencies, T)
    ft = np.arange(T)
    checked = 0
    energy = power.sum(axis=0)
    for iy, ix in zip(*np.nonzero(energy > 1e-3 * energy.max())):
        d = np.abs(ft - fc[iy, ix])
        d = np.minimum(d, T - d)
        keep = d > 0
        slope = np.polyfit(np.log(d[keep]), np.log(power[keep, iy, ix]), 1)[0]
        assert abs(slope + beta) < 0.15, (iy, ix, slope)
        # Weight 1 at f_c and at f_c +- 1 (1/1): the peak is that plateau.
        assert power[fc[iy, ix], iy, ix] >= (1 - 1e-5) * power[:, iy, ix].max()
        checked += 1
    assert checked > 20


@pytest.mark.parametrize("mapping", SYMMETRIC)
def test_peak_normalised_noise_spans_exactly_c_minus_a_to_c_plus_a(mapping):
    img = photo()
    p = FlickerParams(mapping=mapping, T=16, A=0.4, C=0.55, noise_norm="peak")
    model = FlickerModel(img, params=p, seed=2)
    H = heights(model)
    assert H.min() >= p.C - p.A - 1e-6
    assert H.max() <= p.C + p.A + 1e-6
    assert max(p.C - H.min(), H.max() - p.C) == pytest.approx(p.A, abs=1e-5)


def swing(H, C):
    """RMS of the height about C in each frame, over the region: (T,)."""
    return np.sqrt(np.mean((H - C) ** 2, axis=(1, 2)))


@pytest.mark.parametrize("mapping", SYMMETRIC)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rms_normalised_noise_keeps_the_swing_of_the_clip_without_noise(mapping, seed):
    # The decision of spec 01-flicker (Eq. (10)): the noise changes the rhythm, not the
    # size of the swing. Divided by its peak (Eq. (10) literally) the swing halves.
    img = photo((32, 48))
    p = FlickerParams(mapping=mapping, T=64, A=0.4, C=0.5)
    quiet = swing(heights(FlickerModel(img, params=p.replace(beta=0))), p.C)
    target = np.sqrt(np.mean(quiet**2))
    model = FlickerModel(img, params=p, seed=seed)
    rms = swing(heights(model), p.C)
    peak = swing(heights(FlickerModel(img, params=p.replace(noise_norm="peak"), seed=seed)), p.C)
    # Over the loop: the scaled field has the RMS of the clip without noise (measured on
    # a sample of the pixels)...
    field = np.stack([model.field(t).imag for t in range(p.T)])
    assert np.sqrt(np.mean((p.A * field) ** 2)) == pytest.approx(target, rel=0.02)
    # ...and the soft clip takes a little off the loudest frames only.
    assert 0.7 * target <= np.sqrt(np.mean(rms**2)) < target
    assert np.sqrt(np.mean(peak**2)) < 0.6 * target
    # Frame by frame: the typical frame swings nearly as much as without noise...
    assert np.median(rms) >= 0.65 * np.median(quiet)
    assert np.median(rms) >= 1.4 * np.median(peak)

    # ...and the swing is steadier over the loop: the soft clip tames the swells where
    # the random phases add up, which the peak scaling lets set the scale.
    def unsteadiness(s):
        return s.std() / s.mean()

    assert unsteadiness(rms) < 0.85 * unsteadiness(peak)
    assert rms.min() / rms.max() > 1.3 * peak.min() / peak.max()


@pytest.mark.parametrize("mapping", SYMMETRIC)
def test_rms_normalised_heights_stay_inside_c_minus_a_to_c_plus_a(mapping):
    img = photo()
    p = FlickerParams(mapping=mapping, T=16, A=0.4, C=0.55)
    model = FlickerModel(img, params=p, seed=2)
    H = heights(model)
    assert H.min() > p.C - p.A
    assert H.max() < p.C + p.A
    # the soft clip is the identity inside its knee: most heights are Eq. (5) as it is
    f = np.stack([model.field(t).imag for t in range(p.T)])
    inner = np.abs(f) <= 0.7
    assert inner.mean() > 0.5
    np.testing.assert_allclose((H - p.C)[inner], p.A * f[inner], rtol=0, atol=1e-5)


def test_noise_makes_the_oscillation_irregular():
    img = photo()
    plain = heights(FlickerModel(img, params=FlickerParams(mapping="plane", beta=0, T=32)))
    noisy = heights(FlickerModel(img, params=FlickerParams(mapping="plane", T=32), seed=0))

    # Without noise each pixel swings with the same amplitude every cycle (Eq. (1));
    # with it the swings vary.
    def swing(H):
        return np.ptp(H[:8], axis=0) / np.maximum(np.ptp(H[16:24], axis=0), 1e-9)

    np.testing.assert_allclose(swing(plain), 1.0, atol=1e-4)
    assert np.abs(swing(noisy) - 1).max() > 0.05


# ---------------------------------------------------------------------- the region


@pytest.mark.parametrize("shape", [(30, 44, 3), (30, 44)])
@pytest.mark.parametrize("feather", [0.0, 3.0])
def test_pixels_outside_the_mask_never_change(shape, feather):
    img = photo(shape)
    mask = np.zeros(shape[:2], bool)
    mask[6:20, 10:31] = True
    mask[22:26, 3:6] = True
    p = FlickerParams(T=12, f0=2, feather=feather, bump=6.0, k=2.0)
    clip = flicker(img, mask, p, seed=0)
    for frame in clip.frames:
        assert np.array_equal(frame[~mask], img[~mask])
    moved = np.abs(clip.frames - img).max(axis=0)
    assert moved[mask].max() > 0.05


def test_mask_may_be_painted_floats_or_an_image():
    img = photo()
    painted = np.zeros(img.shape[:2], np.float32)
    painted[5:15, 5:25] = 0.9
    a = flicker(img, painted, FlickerParams(T=8, f0=2), seed=0)
    b = flicker(img, painted > 0.5, FlickerParams(T=8, f0=2), seed=0)
    assert np.array_equal(a.frames, b.frames)


# ---------------------------------------------------------------------- seeds


def test_same_seed_same_frames_and_different_seeds_different_noise():
    img = photo()
    p = FlickerParams(T=16)
    a = flicker(img, params=p, seed=5)
    b = flicker(img, params=p, seed=5)
    c = flicker(img, params=p, seed=6)
    assert np.array_equal(a.frames, b.frames)
    assert np.abs(a.frames - c.frames).max() > 0.01
    # A Generator gives one int, recorded, which remakes the clip.
    gen = flicker(img, params=p, seed=np.random.default_rng(5))
    assert isinstance(gen.metadata["seed"], int)
    assert np.array_equal(flicker(img, params=p, seed=gen.metadata["seed"]).frames, gen.frames)
    quiet = FlickerParams(T=16, beta=0)
    assert np.array_equal(
        flicker(img, params=quiet, seed=1).frames, flicker(img, params=quiet, seed=2).frames
    )


def test_a_drawn_seed_is_recorded_and_remakes_the_clip():
    img = photo()
    p = FlickerParams(T=8, f0=2)
    first = flicker(img, params=p)
    seed = first.metadata["seed"]
    assert isinstance(seed, int)
    assert np.array_equal(flicker(img, params=p, seed=seed).frames, first.frames)


# ---------------------------------------------------------------------- one frame vs the clip


@pytest.mark.parametrize("T", [13, 16])
@pytest.mark.parametrize("masked", [False, True])
def test_single_frames_are_bit_identical_to_the_whole_clip(T, masked):
    img = photo((26, 38, 3))
    mask = None
    if masked:
        mask = np.zeros(img.shape[:2], bool)
        mask[4:19, 7:30] = True
    p = FlickerParams(T=T, f0=3)
    clip = flicker(img, mask, p, seed=9)
    model = FlickerModel(img, mask, p, seed=9)
    for t in (T - 1, 0, 7, 8, 3, T - 1, 12):
        assert np.array_equal(model.frame(t), clip.frames[t]), t
    assert np.array_equal(model.frames(), clip.frames)


@pytest.mark.parametrize("T", [64, 13])
def test_a_stream_kept_block_by_block_holds_the_clip(T):
    # The stream writes a block again once nothing holds it (at 1920 px fresh memory
    # for every block cost time): blocks a consumer keeps must never be overwritten,
    # blocks it lets go of are reused, and either way the frames are the clip's.
    img = photo((24, 30, 3), seed=4)
    mask = np.zeros(img.shape[:2], bool)
    mask[3:20, 5:26] = True
    model = FlickerModel(img, mask, FlickerParams(T=T, f0=3), seed=2)
    clip = model.clip()
    kept = list(model.stream())  # every block held at once
    assert np.array_equal(np.concatenate(kept), clip.frames)
    seen, owners = [], set()
    for block in model.stream():  # one block at a time, copied
        seen.append(block.copy())
        owners.add(id(block.base))
    assert np.array_equal(np.concatenate(seen), clip.frames)
    if T == 64:  # 4 blocks of 16: the fourth is the first, let go of, used again
        assert len(owners) < len(seen)


# ---------------------------------------------------------------------- the result


def test_clip_metadata_and_shape():
    img = photo((20, 30, 3))
    clip = flicker(img, params=FlickerParams(T=10, f0=2, fps=5), seed=0)
    assert isinstance(clip, Clip)
    assert clip.frames.shape == (10, 20, 30, 3)
    assert clip.fps == 5
    meta = clip.metadata
    assert meta["method"] == "flicker"
    assert meta["params"] == FlickerParams(T=10, f0=2, fps=5).to_dict()
    assert meta["seed"] == 0
    assert set(meta["timings"]) == {"analyse", "spectrum", "synthesis", "normalise", "render"}
    assert clip.frames.min() >= 0
    assert clip.frames.max() <= 1


def test_progress_is_reported_and_cancel_stops():
    seen = []
    flicker(photo(), params=FlickerParams(T=32), seed=0, progress=lambda f, m: seen.append(f))
    assert len(seen) >= 8  # every stage, every bin chunk and every block of frames
    assert seen == sorted(seen)
    assert seen[-1] == 1.0
    token = CancelToken()
    calls = []

    def cancel_half_way(fraction, message):
        calls.append(fraction)
        if fraction > 0.5:
            token.cancel()
        token(fraction, message)

    with pytest.raises(Cancelled):
        flicker(photo(), params=FlickerParams(T=32), seed=0, progress=cancel_half_way)
    assert calls[-1] < 1.0


# ---------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"mask": np.zeros((24, 40), bool)}, "mask is empty"),
        ({"mask": np.ones((24, 41), bool)}, r"mask must have the same height and width"),
        ({"params": {"T": 16}}, "params must be a FlickerParams"),
        ({"seed": -1}, "seed must be"),
    ],
)
def test_bad_input_raises_a_clear_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        flicker(photo(), **kwargs)


def test_nan_image_and_bad_parameters_are_refused():
    img = photo()
    img[3, 4, 1] = np.nan
    with pytest.raises(ValueError, match="image contains NaN"):
        flicker(img)
    with pytest.raises(ValueError, match="T must be an integer"):
        flicker(photo(), params=FlickerParams(T=1))
    with pytest.raises(ValueError, match="f0 must be < T/2"):
        FlickerParams(T=16, f0=8)
    with pytest.raises(ValueError, match="t must be an integer"):
        FlickerModel(photo(), params=FlickerParams(T=8, f0=2)).frame(1.5)


def test_inputs_are_not_modified():
    img = photo()
    mask = np.zeros(img.shape[:2], bool)
    mask[2:9, 3:20] = True
    img0, mask0 = img.copy(), mask.copy()
    flicker(img, mask, FlickerParams(T=8, f0=2), seed=0)
    assert np.array_equal(img, img0)
    assert np.array_equal(mask, mask0)


# ---------------------------------------------------------------------- noise regions


def _speed(H, cols):
    """Mean |H(t+1) - H(t)| of the columns ``cols`` in each frame: (T,)."""
    part = H[:, :, cols]
    return np.abs(np.roll(part, -1, axis=0) - part).mean(axis=(1, 2))


@pytest.mark.parametrize("mapping", ["plane", "convex"])
def test_noise_regions_let_distant_parts_speed_up_at_different_times(mapping):
    # Eq. (10)'s phi(f_t) is shared by every spatial frequency: the two ends of the
    # picture speed up and slow down in lockstep (the paper's open problem, sec. 5).
    # With independent noise per soft region they no longer do.
    img = photo((48, 144))
    left, right = slice(0, 36), slice(108, 144)
    for regions, low, high in ((1, 0.95, 1.0), (4, -0.5, 0.5)):
        corr = []
        for seed in range(4):
            p = FlickerParams(mapping=mapping, T=64, noise_regions=regions)
            H = heights(FlickerModel(img, params=p, seed=seed))
            corr.append(np.corrcoef(_speed(H, left), _speed(H, right))[0, 1])
        assert low <= np.mean(corr) <= high, (regions, corr)


def test_noise_regions_are_a_partition_and_one_region_is_eq10():
    from fluidnb.flicker import region_weights

    w = region_weights((30, 50), 5, seed=1)
    np.testing.assert_allclose(w.sum(axis=0), 1.0)
    assert (w.max(axis=(1, 2)) > 0.8).all()  # each region has a core of its own
    img = photo()
    one = FlickerModel(img, params=FlickerParams(T=16, noise_regions=1), seed=3)
    paper = FlickerModel(img, params=FlickerParams(T=16), seed=3)
    assert np.array_equal(one.frames(), paper.frames())
    quiet = FlickerParams(T=16, beta=0)  # no noise: nothing to split
    assert np.array_equal(
        FlickerModel(img, params=quiet.replace(noise_regions=4), seed=3).frames(),
        FlickerModel(img, params=quiet, seed=3).frames(),
    )
