"""The method's individual steps: parameters, Eq. (1)-(4), the mapping, the noise, shading."""

import math

import numpy as np
import pytest

from fluidnb.flicker import (
    FlickerParams,
    apply_shading,
    feather_weights,
    harmonic_height,
    height_from_luminance,
    initial_phase,
    light_vector,
    noise_spectrum,
    phase_spectrum,
    shade,
    temporal_frequencies,
    temporal_signals,
)

# ---------------------------------------------------------------------- parameters


def test_defaults_are_the_papers_experiment():
    p = FlickerParams()
    assert (p.T, p.f0, p.fps) == (64, 4, 8.0)
    assert p.mapping == "convex"
    assert p.beta == 2.0
    assert np.allclose([p.A, p.C], 128 / 255)
    # The dominant frequency of the paper's clips: 0.5 Hz.
    assert p.f0 * p.fps / p.T == pytest.approx(0.5)
    assert FlickerParams.from_json(p.to_json()) == p


def test_every_field_carries_its_meaning():
    specs = FlickerParams.specs()
    for name in ("T", "f0", "kappa", "beta", "A", "C", "mapping", "branch"):
        assert specs[name].eq, name
    assert specs["kappa"].symbol == r"\kappa"
    assert specs["beta"].eq == "Eq. (10)"
    # The slider default must be on the slider's own grid (A = 128/255 in 8-bit steps).
    spec = specs["A"]
    steps = (spec.default - spec.ui_range[0]) / spec.step
    assert steps == pytest.approx(round(steps))


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"T": 1}, r"T must be an integer in \[2, 1024\], got 1"),
        ({"f0": 32}, r"f0 must be < T/2 = 32"),
        ({"T": 8, "f0": 4}, r"f0 must be < T/2 = 4"),
        ({"kappa": -0.5}, "kappa must be in"),
        ({"beta": -1.0}, "beta must be in"),
        ({"A": 0.0}, r"A must be in \(0, 1\]"),
        ({"mapping": "flat"}, "mapping must be one of 'plane', 'convex', 'concave'"),
        ({"branch": "up"}, "branch must be one of"),
        ({"elevation": 0.0}, "elevation must be in"),
        ({"fps": 0.0}, "fps must be in"),
        ({"feather": -1.0}, "feather must be in"),
    ],
)
def test_bad_parameters_are_refused_with_their_name(changes, match):
    with pytest.raises(ValueError, match=match):
        FlickerParams(**changes)


# ---------------------------------------------------------------------- Eq. (1)-(4)


def test_height_is_the_luminance():
    rgb = np.zeros((2, 3, 3), np.uint8)
    rgb[0, 0] = (255, 255, 255)
    rgb[1, 2] = (0, 255, 0)
    h = height_from_luminance(rgb)
    assert h.dtype == np.float32
    assert h.shape == (2, 3)
    assert h[0, 0] == pytest.approx(1.0)
    assert h[1, 2] == pytest.approx(0.7154)
    grey = np.random.default_rng(0).random((4, 5)).astype(np.float32)
    assert np.array_equal(height_from_luminance(grey), grey)


@pytest.mark.parametrize("branch", ["rising", "falling"])
def test_initial_phase_satisfies_eq2_on_both_branches(branch):
    A = C = 128 / 255
    h = np.linspace(0, 1, 101)
    alpha = initial_phase(h, A, C, branch)
    # Eq. (2): H(0) = A sin(alpha) + C, for every luminance.
    np.testing.assert_allclose(A * np.sin(alpha) + C, h, atol=1e-12)
    assert np.all(np.abs(alpha) <= np.pi)
    if branch == "rising":
        assert np.all(np.abs(alpha) <= np.pi / 2 + 1e-12)
        assert np.all(np.cos(alpha) >= -1e-12)  # the height grows next
    else:
        inner = np.abs(np.sin(alpha)) < 0.999  # away from the extremes, where both agree
        assert np.all(np.abs(alpha[inner]) > np.pi / 2)
        assert np.all(np.cos(alpha[inner]) < 0)  # the height falls next


def test_initial_phase_clips_heights_outside_the_range():
    alpha = initial_phase(np.array([0.0, 1.0]), A=0.25, C=0.5)
    np.testing.assert_allclose(alpha, [-np.pi / 2, np.pi / 2])
    with pytest.raises(ValueError, match="A must be"):
        initial_phase(np.zeros(3), A=0.0, C=0.5)


def test_harmonic_height_is_eq1_with_period_T_over_f0():
    alpha = np.array([[0.3, -1.0]])
    t = np.arange(12)
    H = harmonic_height(alpha, t, A=0.4, C=0.5, f0=3, T=12)
    assert H.shape == (12, 1, 2)
    expected = 0.4 * np.sin(2 * np.pi * 3 / 12 * t[:, None, None] + alpha) + 0.5
    np.testing.assert_allclose(H, expected, atol=1e-12)
    # P = T / f0 = 4 frames per oscillation.
    np.testing.assert_allclose(H[4:], H[:-4], atol=1e-12)


def test_phase_spectrum_is_the_dft_of_exp_j_alpha():
    alpha = np.random.default_rng(1).uniform(-np.pi, np.pi, (6, 10))
    F = phase_spectrum(alpha)
    direct = np.fft.fft2(np.cos(alpha) + 1j * np.sin(alpha))
    np.testing.assert_allclose(F, direct, atol=1e-10)
    # Eq. (4) written out for one coefficient.
    y, x = np.mgrid[0:6, 0:10]
    f = np.sum(np.exp(1j * alpha) * np.exp(-2j * np.pi * (2 * x / 10 + 1 * y / 6)))
    assert F[1, 2] == pytest.approx(f)


# ---------------------------------------------------------------------- the mapping


def test_plane_maps_everything_to_f0():
    fc = temporal_frequencies((7, 9), FlickerParams(mapping="plane", f0=5))
    assert fc.dtype == np.int64
    assert np.all(fc == 5)


@pytest.mark.parametrize("T", [16, 64, 65])
def test_convex_kappa_one_sends_the_finest_detail_just_below_nyquist(T):
    p = FlickerParams(T=T, f0=4, mapping="convex", kappa=1.0)
    fc = temporal_frequencies((32, 32), p)
    top = math.ceil(T / 2) - 1
    assert fc[0, 0] == 4  # the mean keeps f0
    assert fc.max() == top == fc[16, 16]  # the Nyquist corner
    assert fc.min() == 4
    assert 2 * fc.max() < T


def test_surfaces_are_symmetric_about_the_ft_axis():
    for mapping in ("convex", "concave"):
        p = FlickerParams(mapping=mapping)
        fc = temporal_frequencies((12, 20), p, rounded=False)
        # f_c(-nu) = f_c(nu): the mapping adds no direction (Sec. 3.2, first condition).
        flipped = np.roll(fc[::-1, ::-1], (1, 1), axis=(0, 1))
        np.testing.assert_array_equal(fc, flipped)
    convex = temporal_frequencies((12, 20), FlickerParams(mapping="convex"), rounded=False)
    concave = temporal_frequencies((12, 20), FlickerParams(mapping="concave"), rounded=False)
    np.testing.assert_allclose(convex + concave, 2 * 4)
    flat = temporal_frequencies((12, 20), FlickerParams(mapping="convex", kappa=0.0))
    assert np.all(flat == 4)


def test_pixel_size_keeps_the_mapping_of_a_structure():
    p = FlickerParams(mapping="convex")
    full = temporal_frequencies((64, 64), p, rounded=False)
    quarter = temporal_frequencies((16, 16), p, pixel_size=4, rounded=False)
    # Frequency index k of the 16-grid at pixel size 4 is the same physical frequency
    # as index k of the 64-grid.
    np.testing.assert_allclose(quarter[:8, :8], full[:8, :8])


def test_bad_shape_and_params_for_the_mapping():
    with pytest.raises(ValueError, match="params must be a FlickerParams"):
        temporal_frequencies((4, 4), {"mapping": "plane"})
    with pytest.raises(ValueError, match="pixel_size"):
        temporal_frequencies((4, 4), FlickerParams(), pixel_size=0)


# ---------------------------------------------------------------------- Eq. (10)


def test_noise_weights_fall_as_one_over_distance_to_the_power_beta_over_two():
    T = 32
    for beta in (1.0, 2.0, 3.0):
        N = noise_spectrum(T, beta, seed=3)
        c = np.arange(T)
        for row in (0, 5, 31):
            d = np.minimum(np.abs(c - row), T - np.abs(c - row))
            expected = np.where(d == 0, 1.0, np.maximum(d, 1) ** (-beta / 2))
            np.testing.assert_allclose(np.abs(N[row]), expected)


def test_noise_phase_depends_on_ft_only_and_on_the_seed():
    N = noise_spectrum(16, 2.0, seed=7)
    phase = np.angle(N)
    np.testing.assert_allclose(np.exp(1j * (phase - phase[0])), 1.0, atol=1e-12)
    assert np.array_equal(N, noise_spectrum(16, 2.0, seed=7))
    assert not np.allclose(N, noise_spectrum(16, 2.0, seed=8))
    assert np.array_equal(noise_spectrum(16, 0.0, seed=7), np.eye(16))


def test_temporal_signals_without_noise_are_pure_rotations():
    T = 12
    g = temporal_signals(np.eye(T))
    t = np.arange(T)
    for c in range(T):
        np.testing.assert_allclose(g[c], np.exp(2j * np.pi * c * t / T), atol=1e-12)


def test_temporal_signals_have_period_T_at_every_time():
    U = noise_spectrum(16, 2.0, seed=0)
    t = np.array([0.0, 0.5, 3.25, 15.75])
    np.testing.assert_allclose(temporal_signals(U, t + 16), temporal_signals(U, t), atol=1e-9)
    np.testing.assert_allclose(temporal_signals(U, t - 32), temporal_signals(U, t), atol=1e-9)
    # Half a frame before the loop closes lies between the last and the first frame.
    g = temporal_signals(U, np.array([15.0, 15.5, 16.0]))
    step = np.abs(np.diff(temporal_signals(U), axis=1)).max()
    assert np.all(np.abs(g[:, 1] - g[:, 0]) <= step)
    assert np.all(np.abs(g[:, 2] - g[:, 1]) <= step)


# ---------------------------------------------------------------------- shading


def test_light_vector_points_at_the_light():
    np.testing.assert_allclose(light_vector(0, 90), [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(light_vector(180, 60), [-0.5, 0, math.sqrt(3) / 2], atol=1e-12)
    with pytest.raises(ValueError, match="elevation"):
        light_vector(0, 0)


def test_lambert_shading_of_planes():
    flat = shade(np.zeros((5, 6)), elevation=30)
    np.testing.assert_allclose(flat, 0.5, atol=1e-7)
    # A plane rising to the right with slope 1 (bump 1, height 1 per pixel) has
    # normal (-1, 0, 1)/sqrt(2): a light from the left (azimuth 180) at elevation 45
    # hits it head on, a light from the right grazes it at 90 degrees.
    ramp = np.tile(np.arange(6, dtype=np.float32), (5, 1))
    np.testing.assert_allclose(shade(ramp, azimuth=180, elevation=45, bump=1), 1, atol=1e-6)
    np.testing.assert_allclose(shade(ramp, azimuth=0, elevation=45, bump=1), 0, atol=1e-6)
    # y points up the image: a height rising towards the top faces the bottom.
    up = np.tile(np.arange(5, dtype=np.float32)[::-1, None], (1, 6))
    assert shade(up, azimuth=270, bump=1).min() > shade(up, azimuth=90, bump=1).max()
    # A preview at pixel size 2 sees half the slope per full-resolution pixel.
    np.testing.assert_allclose(
        shade(2 * ramp, azimuth=180, bump=1, pixel_size=2), shade(ramp, azimuth=180, bump=1)
    )


def test_shading_a_stack_equals_shading_each_frame():
    h = np.random.default_rng(0).random((3, 9, 7)).astype(np.float32)
    stack = shade(h, azimuth=30, elevation=50, bump=3)
    for i in range(3):
        np.testing.assert_array_equal(stack[i], shade(h[i], azimuth=30, elevation=50, bump=3))


def test_apply_shading_is_identity_where_nothing_changes_and_keeps_hue():
    rng = np.random.default_rng(0)
    img = rng.random((6, 7, 3)).astype(np.float32)
    S0 = rng.random((6, 7)).astype(np.float32)
    assert np.array_equal(apply_shading(img, S0, S0, k=2.0), img)
    S = S0 + 0.5
    w = np.zeros((6, 7), np.float32)
    w[2:4, 2:5] = 1
    out = apply_shading(img, S, S0, k=3.0, weight=w)
    assert np.array_equal(out[w == 0], img[w == 0])
    assert out.max() <= 1.0
    inside = out[w == 1]
    ratio = inside / inside.max(axis=-1, keepdims=True)
    src = img[w == 1] / img[w == 1].max(axis=-1, keepdims=True)
    np.testing.assert_allclose(ratio, src, rtol=1e-5)  # brightened, same hue
    np.testing.assert_allclose(inside.max(axis=-1), 1.0, rtol=1e-6)  # saturated
    dark = apply_shading(img, S0 - 1.0, S0, k=5.0)
    assert dark.min() == 0.0


def test_feather_weights():
    m = np.zeros((20, 20), bool)
    m[4:16, 4:16] = True
    w = feather_weights(m, 3)
    assert np.all(w[~m] == 0)
    assert np.all(w[8:12, 8:12] == 1)
    assert 0 < w[4, 10] < w[5, 10] < w[6, 10] < 1
    assert np.array_equal(feather_weights(m, 0), m.astype(np.float32))
    assert np.all(feather_weights(np.ones((5, 5), bool), 10) == 1)


def test_near_distance_is_scipys_euclidean_distance_up_to_its_reach():
    # feather_weights measures the few pixels a feather needs itself (issue 39: no
    # scipy.ndimage import); up to its reach it is the exact Euclidean distance, and
    # beyond it only says "farther".
    from scipy import ndimage

    from fluidnb.flicker._shading import _near_squared_distance

    rng = np.random.default_rng(3)
    checked = 0
    for trial in range(120):
        h, w = (int(n) for n in rng.integers(1, 40, 2))
        if trial % 2:
            m = rng.random((h, w)) < rng.uniform(0.5, 1.0)
        else:  # blobs: long distances, concave edges
            m = ndimage.gaussian_filter(rng.random((h, w)), 3) > 0.45
        if m.all() or not m.any():
            continue
        exact = ndimage.distance_transform_edt(m)
        for reach in (1, 2, 5, 12):
            d = np.sqrt(_near_squared_distance(m, reach))
            near = exact <= reach
            assert np.array_equal(d[near], exact[near])
            assert np.all(d[~near] > reach)
            checked += 1
    assert checked > 200


@pytest.mark.parametrize("feather", [0.5, 4.0, 11.0, 30.0])
def test_feather_weights_follow_the_distance_transform(feather):
    # The smoothstep of scipy's distance transform, bit for bit, for short feathers
    # (our own distance) and long ones (scipy's).
    from scipy import ndimage

    rng = np.random.default_rng(4)
    m = ndimage.gaussian_filter(rng.random((90, 120)), 6) > 0.48
    d = ndimage.distance_transform_edt(m)
    x = np.clip((d - 0.5) / feather, 0.0, 1.0)
    expected = (x * x * (3 - 2 * x)).astype(np.float32)
    assert np.array_equal(feather_weights(m, feather), expected)
    assert np.array_equal(
        feather_weights(m, 2 * feather, pixel_size=2.0), feather_weights(m, feather)
    )
