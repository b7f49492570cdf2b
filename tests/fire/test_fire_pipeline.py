"""fire(): keyframes, advection, cross-dissolve (Furukawa et al. 2013, sec. 3.3-3.4)."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import ndimage

from fluidnb import Cancelled, CancelToken
from fluidnb.data import sample
from fluidnb.fields import advect, backward_warp
from fluidnb.fire import FireParams, clip_times, dissolve_weights, fire


def rising_blob(n_frames=12, n=32, speed=1.0):
    """A Gaussian blob of temperature rising ``speed`` px/frame, and that velocity."""
    yy, xx = np.mgrid[:n, :n].astype(np.float32)
    temp = np.stack(
        [
            np.exp(-(((xx - n / 2) / (n / 6)) ** 2 + ((yy - 0.65 * n + speed * t) / (n / 4)) ** 2))
            for t in range(n_frames)
        ]
    )
    vel = np.zeros((n_frames, n, n, 2), np.float32)
    vel[..., 0] = -speed  # dy < 0 is up
    return temp.astype(np.float32), vel


@pytest.fixture(scope="module")
def photo():
    return sample("fire", size=48, return_alpha=True)


@pytest.mark.parametrize(
    ("n_frames", "interval", "overlap"),
    [(20, 8, 4), (20, 8, 0), (21, 7, 3), (20, 8, 6), (5, 10, 5), (1, 4, 2), (30, 2, 1)],
)
def test_cross_dissolve_weights_sum_to_one_on_every_frame(n_frames, interval, overlap):
    starts, w = dissolve_weights(n_frames, interval, overlap)
    np.testing.assert_allclose(w.sum(axis=0), 1.0, atol=1e-12)
    assert (w >= 0).all()
    np.testing.assert_array_equal(starts, np.arange(0, n_frames, interval - overlap))
    for k, s in enumerate(starts):
        # Zero outside the segment [s, s + N).
        assert not w[k, :s].any()
        assert not w[k, s + interval :].any()


def test_the_blend_is_linear_over_the_overlap_as_in_fig_6():
    _, w = dissolve_weights(24, 8, 4)
    # Segment 1 starts at frame 4 and shares frames 4-7 with segment 0.
    np.testing.assert_allclose(w[1, 4:8], [0.2, 0.4, 0.6, 0.8])
    np.testing.assert_allclose(w[0, 4:8], [0.8, 0.6, 0.4, 0.2])
    np.testing.assert_allclose(np.diff(w[1, 4:8]), 0.2)
    # m = 0: hard cuts, one segment per frame.
    _, w0 = dissolve_weights(24, 8, 0)
    assert set(np.unique(w0)) == {0.0, 1.0}


def test_a_keyframe_is_the_frame_where_its_segment_stands_alone(photo):
    temp, vel = rising_blob()
    result = fire(
        photo[0], (temp, vel), FireParams.paper(interval=4, overlap=0), matte=photo[1], seed=2
    )
    np.testing.assert_array_equal(result.starts, [0, 4, 8])
    for k, s in enumerate(result.starts):
        np.testing.assert_array_equal(result.clip.frames[s], result.keyframes[k])
        tex = result.texture
        src = result.sources[k]
        np.testing.assert_array_equal(result.keyframes[k], tex[src[..., 0], src[..., 1]])


def test_between_keyframes_the_image_is_advected_by_backtracing(photo):
    temp, vel = rising_blob()
    vel[..., 1] = 0.3 * np.sin(np.arange(32) / 5.0)  # a sideways shear as well
    result = fire(
        photo[0], (temp, vel), FireParams.paper(interval=4, overlap=0), matte=photo[1], seed=2
    )
    frames = result.clip.frames
    key = result.keyframes[0]
    displacement = np.zeros((32, 32, 2), np.float32)
    stepped = key
    for t in (1, 2, 3):
        # Fig. 5's backtrace, composed: d_t(x) = -u_t(x) + d_{t-1}(x - u_t(x)) ...
        displacement = advect(displacement, vel[t]) - vel[t]
        # ... and the keyframe sampled once at x + d_t(x).
        np.testing.assert_allclose(frames[t], backward_warp(key, displacement), atol=1e-6)
        # The same motion as advecting the image itself frame after frame (which
        # differs only by the extra smoothing of repeated interpolation).
        stepped = advect(stepped, vel[t])
        assert np.abs(frames[t] - stepped).mean() < 0.1 * np.abs(frames[t] - key).mean() + 1e-3


def laplacian_variance(image):
    """Sharpness: the variance of the luminance's Laplacian (fine detail)."""
    return ndimage.laplace(image @ np.array([0.2126, 0.7152, 0.0722])).var()


def test_advection_keeps_the_keyframe_sharp_over_a_long_segment():
    # Repeated bilinear advection (the image re-interpolated every frame) blurs the
    # texture a little more each frame; composing the backtraces and sampling once
    # interpolates only once. Measured after 23 frames: 0.57 of the keyframe's
    # Laplacian variance, against 0.12 for the image advected frame by frame.
    photo, matte = sample("fire", size=96, return_alpha=True)
    n = 24
    temp, vel = rising_blob(n_frames=n, n=48, speed=0.37)
    vel[..., 1] = 0.21 * np.cos(np.arange(48) / 4.0)
    params = FireParams.paper(interval=n, overlap=0, input_size=64)
    result = fire(photo, (temp, vel), params, matte=matte, seed=3)
    stepped = result.keyframes[0]
    for t in range(1, n):
        stepped = advect(stepped, vel[t])
    first = laplacian_variance(result.clip.frames[0])
    last = laplacian_variance(result.clip.frames[-1])
    assert last > 0.4 * first
    assert laplacian_variance(stepped) < 0.25 * first  # what per-frame advection did
    assert last > 3 * laplacian_variance(stepped)


def test_frame_to_frame_change_inside_segments_is_small(photo):
    # The paper's baseline (Furukawa et al. (2013), sec. 3.3): synthesising every
    # frame independently flickers.
    temp, vel = rising_blob(n_frames=16, speed=0.5)
    # The photo at 128 px (the texture four times the 32-px grid's scale), as measured.
    params = FireParams.paper(interval=8, input_size=128)
    result = fire(photo[0], (temp, vel), params, matte=photo[1], seed=5)
    per_frame = fire(
        photo[0], (temp, vel), params.replace(interval=1, overlap=0), matte=photo[1], seed=5
    )

    def change(frames):
        return np.abs(np.diff(frames, axis=0)).mean(axis=(1, 2, 3))

    def moved_change(frames):
        # What changes beyond the motion the velocity explains.
        return np.array(
            [np.abs(frames[t + 1] - advect(frames[t], vel[t + 1])).mean() for t in range(15)]
        )

    f, g = result.clip.frames, per_frame.clip.frames
    # Measured: 0.0075 vs 0.018 (plain), <= 0.0042 vs 0.016 (motion-compensated).
    assert change(f).max() < 0.5 * change(g).mean()
    assert moved_change(f).max() < 0.35 * moved_change(g).mean()
    # Zero velocity and one segment: nothing moves at all.
    still = fire(
        photo[0],
        (np.repeat(temp[:1], 6, axis=0), np.zeros((6, 32, 32, 2))),
        FireParams.paper(interval=6, overlap=0),
        matte=photo[1],
        seed=5,
    )
    assert all(np.array_equal(f, still.clip.frames[0]) for f in still.clip.frames)


def test_same_seed_same_clip_with_its_metadata(photo):
    temp, vel = rising_blob(n_frames=8)
    params = FireParams.paper(interval=4)
    a = fire(photo[0], (temp, vel), params, matte=photo[1], seed=9)
    b = fire(photo[0], (temp, vel), params, matte=photo[1], seed=9)
    c = fire(photo[0], (temp, vel), params, matte=photo[1], seed=10)
    np.testing.assert_array_equal(a.clip.frames, b.clip.frames)
    assert not np.array_equal(a.clip.frames, c.clip.frames)
    meta = a.clip.metadata
    assert meta["method"] == "fire"
    assert meta["seed"] == 9
    assert meta["params"] == params.to_dict()
    assert meta["keyframes"] == [0, 2, 4, 6]
    assert {"synthesis", "advection", "total"} <= set(meta["timings"])
    assert a.temperature_clip.n_frames == 8
    assert a.temperature_clip.is_color
    assert a.seed == 9


def test_without_a_seed_the_seed_used_is_recorded_and_remakes_the_clip(photo):
    temp, vel = rising_blob(n_frames=6)
    params = FireParams.paper(interval=4)
    a = fire(photo[0], (temp, vel), params, matte=photo[1])
    assert isinstance(a.seed, int)
    assert a.clip.metadata["seed"] == a.seed
    b = fire(photo[0], (temp, vel), params, matte=photo[1], seed=a.clip.metadata["seed"])
    np.testing.assert_array_equal(a.clip.frames, b.clip.frames)


def test_the_photo_is_resized_to_input_size(photo):
    temp, vel = rising_blob(n_frames=2)
    result = fire(photo[0], (temp, vel), FireParams.paper(input_size=24), matte=photo[1], seed=0)
    assert max(result.texture.shape[:2]) == 24
    assert result.texture_alpha.shape == result.texture.shape[:2]


def test_a_simulation_object_gives_the_same_fire_as_its_arrays(photo):
    temp, vel = rising_blob(n_frames=4)
    sim = SimpleNamespace(temperature=temp, velocity=vel)
    a = fire(photo[0], sim, FireParams.paper(interval=2), matte=photo[1], seed=1)
    b = fire(photo[0], (temp, vel), FireParams.paper(interval=2), matte=photo[1], seed=1)
    np.testing.assert_array_equal(a.clip.frames, b.clip.frames)
    assert a.simulation is sim
    with pytest.raises(ValueError, match="simulation must have a 'velocity'"):
        fire(photo[0], SimpleNamespace(temperature=temp))
    with pytest.raises(ValueError, match="n_frames must be <= the simulation's 4 frames"):
        fire(photo[0], sim, n_frames=5)
    assert fire(photo[0], sim, matte=photo[1], n_frames=3, seed=1).clip.n_frames == 7  # 24 fps


def test_progress_reports_and_cancel_stops(photo):
    temp, vel = rising_blob(n_frames=8)
    seen = []
    fire(
        photo[0],
        (temp, vel),
        FireParams.paper(interval=4),
        seed=0,
        progress=lambda f, m: seen.append(f),
    )
    assert seen[-1] == 1.0
    assert seen == sorted(seen)
    token = CancelToken()
    token.cancel()
    with pytest.raises(Cancelled):
        fire(photo[0], (temp, vel), seed=0, progress=token)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"photo": np.zeros((8, 8), np.float32)}, "photo must be an RGB or RGBA image"),
        ({"photo": np.ones((1, 1, 3), np.float32), "matte": None}, "photo must be at least 8 x 8"),
        ({"photo": np.ones((9, 9, 3), np.float32), "matte": None}, "photo has no flame"),
        (
            {"velocity": np.full((8, 32, 32, 2), 1e9, np.float32)},
            r"velocity must be at most max\(H, W\) = 32",
        ),
        ({"matte": np.zeros((3, 3), np.float32)}, "matte must have the same height"),
        ({"temperature": np.zeros((32, 32), np.float32)}, "temperature must have 3 dim"),
        ({"velocity": np.zeros((4, 32, 32, 2), np.float32)}, r"velocity must have shape"),
        ({"velocity": np.zeros((8, 32, 32), np.float32)}, "velocity must have 4 dim"),
        ({"temperature": np.full((8, 32, 32), np.nan)}, "temperature contains"),
        ({"params": "fast"}, "params must be a FireParams"),
    ],
)
def test_bad_inputs_name_the_parameter(photo, change, match):
    temp, vel = rising_blob(n_frames=8)
    args = {"photo": photo[0], "temperature": temp, "velocity": vel, "matte": photo[1]}
    args.update(change)
    params = args.pop("params", None)
    before = temp.copy()
    with pytest.raises(ValueError, match=match):
        fire(args.pop("photo"), (args.pop("temperature"), args.pop("velocity")), params, **args)
    np.testing.assert_array_equal(temp, before)


def test_dissolve_weights_refuses_bad_overlap():
    with pytest.raises(ValueError, match="overlap must be < interval"):
        dissolve_weights(10, 4, 4)


def test_without_a_simulation_the_flame_preset_is_simulated(photo):
    pytest.importorskip("fluidnb.fluid")
    result = fire(photo[0], None, FireParams.paper(interval=2), n_frames=3, matte=photo[1], seed=4)
    assert result.clip.n_frames == 3
    assert result.clip.shape == result.simulation.shape
    meta = result.clip.metadata
    assert meta["seed"] == 4
    assert meta["fluid_params"] == result.simulation.params.to_dict()
    again = fire(photo[0], params=FireParams.paper(interval=2), n_frames=3, matte=photo[1], seed=4)
    np.testing.assert_array_equal(result.clip.frames, again.clip.frames)
    temp, vel = rising_blob(n_frames=2)
    with pytest.raises(ValueError, match="fluid_params is only used"):
        fire(photo[0], (temp, vel), fluid_params=result.simulation.params)


def test_by_default_the_clip_is_256_px_at_24_fps_and_the_paper_is_one_call_away(photo):
    temp, vel = rising_blob(n_frames=5, n=32, speed=0.5)
    default = fire(photo[0], (temp, vel), FireParams(interval=4), matte=photo[1], seed=0)
    assert default.clip.shape == (256, 256)
    assert default.clip.fps == 24
    assert default.clip.n_frames == 13  # 4 simulation intervals x 3, and the first
    assert default.keyframes.shape[1:3] == (256, 256)
    np.testing.assert_allclose(default.times, np.arange(13) / 3)
    assert default.clip.metadata["simulation_shape"] == [32, 32]
    paper = fire(photo[0], (temp, vel), FireParams.paper(interval=4), matte=photo[1], seed=0)
    assert (paper.clip.shape, paper.clip.fps, paper.clip.n_frames) == ((32, 32), 8, 5)
    # A wide grid keeps its aspect ratio.
    wide = np.repeat(temp, 2, axis=2), np.repeat(vel, 2, axis=2)
    assert fire(photo[0], wide, FireParams(), matte=photo[1], seed=0).clip.shape == (128, 256)


def test_keyframes_stay_the_simulations_frames_apart_at_any_fps():
    # The paper's N and m are simulation frames; in clip frames they scale with fps.
    for fps, interval, overlap in [(8, 10, 5), (24, 30, 15), (12, 15, 8), (60, 75, 38)]:
        times, n, m = clip_times(73, 8.0, FireParams(fps=fps, interval=10))
        assert (n, m) == (interval, overlap)
        starts, _ = dissolve_weights(len(times), n, m)
        assert times[-1] == 72.0 or times[-1] > 72.0 - 8.0 / fps
        if fps in (8, 24):  # keyframes land on simulation frames, 5 apart
            np.testing.assert_array_equal(times[starts], 5.0 * np.arange(len(starts)))


def test_in_between_frames_are_advected_not_repeated(photo):
    # A steady upward flow of 0.9 px per simulation frame on a 32 grid: on the 96-px
    # keyframes that is 2.7 px per simulation frame, 0.9 px per clip frame at 24 fps.
    temp, vel = rising_blob(n_frames=7, n=32, speed=0.9)
    params = FireParams(interval=6, overlap=0, output_size=96)
    result = fire(photo[0], (temp, vel), params, matte=photo[1], seed=2)
    frames = result.clip.frames
    assert len(frames) == 19
    assert result.starts.tolist() == [0, 18]
    key = result.keyframes[0]
    lum = frames @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    for t in range(1, 18):
        # No clip frame repeats the one before, and each is the keyframe moved up by
        # 0.9 px a frame: the shift that best explains it (in tenths of a pixel).
        assert not np.array_equal(frames[t], frames[t - 1])
        shifts = np.arange(0, 3.05, 0.1) * t / 3
        errors = [
            np.abs(
                frames[t][20:80]
                - backward_warp(
                    key, np.dstack([np.full((96, 96), d), np.zeros((96, 96))]).astype(np.float32)
                )[20:80]
            ).mean()
            for d in shifts
        ]
        assert abs(shifts[int(np.argmin(errors))] - 0.9 * t) <= 0.1 * t / 3 + 1e-9, t
    assert lum.std() > 0


def test_the_compiled_advance_is_the_numpy_composition_bit_for_bit():
    from fluidnb.fire import _advance
    from fluidnb.fire._reference import advance_reference

    gen = np.random.default_rng(0)
    keyframe = gen.random((40, 30, 3), dtype=np.float32)
    d = (3 * gen.standard_normal((40, 30, 2))).astype(np.float32)
    steps = [(2 * gen.standard_normal((40, 30, 2))).astype(np.float32) for _ in range(2)]
    frame = gen.random((40, 30, 3), dtype=np.float32)
    expected_frame = frame.copy()
    expected = advance_reference(d, steps, keyframe, 0.3, expected_frame)
    spare = np.empty_like(d)
    for u in steps:
        _advance.compose(d, u, spare)
        d, spare = spare, d
    _advance.warp_add(keyframe, d, np.float32(0.3), frame)
    np.testing.assert_array_equal(d, expected)
    np.testing.assert_array_equal(frame, expected_frame)


def test_the_compiled_velocity_upsampling_is_resize_vector_field():
    from fluidnb.fields import resize_vector_field
    from fluidnb.fire import _advance

    v = np.random.default_rng(1).standard_normal((24, 18, 2)).astype(np.float32)
    for shape in [(48, 36), (50, 41), (24, 18)]:
        out = np.empty((*shape, 2), np.float32)
        _advance.upsample_velocity(v, out)
        np.testing.assert_allclose(out, resize_vector_field(v, shape), atol=1e-5)
