"""The 18 augmented versions of a clip: geometry, sampling, flows (Okabe et al., Fig. 4-a)."""

import math

import numpy as np
import pytest

from fluidnb.videodb._common._geometry import FRAGMENT, STRIDE, VERSIONS
from fluidnb.videodb.database import reference_sample_version, reference_transform_vectors
from fluidnb.videodb.database._augment import (
    VersionSampler,
    sample_version,
    transform_flow,
    transform_vectors,
)
from fluidnb.videodb.database._flow import optical_flow
from fluidnb.videodb.database._versions import (
    IDENTITY,
    mirror_order,
    mirror_partner,
    valid_positions,
    version_coordinates,
    version_shape,
)

ALL = range(len(VERSIONS))


def clip(shape=(3, 40, 56), seed=0):
    return np.random.default_rng(seed).random(shape, dtype=np.float32)


def texture(seed=3, n=40, lmin=8.0, lmax=30.0):
    """A smooth random grey pattern f(y, x) in about [0.3, 0.7] (sum of sinusoids)."""
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0, 2 * np.pi, n)
    k = 2 * np.pi / np.exp(rng.uniform(np.log(lmin), np.log(lmax), n))
    ky, kx, ph = k * np.sin(ang), k * np.cos(ang), rng.uniform(0, 2 * np.pi, n)

    def f(y, x):
        v = np.cos(ky * np.asarray(y)[..., None] + kx * np.asarray(x)[..., None] + ph)
        return 0.5 + 0.12 * v.sum(-1) / np.sqrt(n / 2)

    return f


# --- geometry ----------------------------------------------------------------------


def test_version_shapes_for_a_paper_sized_clip():
    h, w = 180, 320
    for v, (_, s, angle) in enumerate(VERSIONS):
        hv, wv = version_shape((h, w), v)
        c, si = abs(math.cos(math.radians(angle))), abs(math.sin(math.radians(angle)))
        assert abs(hv - s * (h * c + w * si)) <= 0.5
        assert abs(wv - s * (w * c + h * si)) <= 0.5
        # The mirror image and the opposite rotation have the same canvas.
        assert version_shape((h, w), v) == version_shape((h, w), (v + 9) % 18)
        assert version_shape((h, w), v) == version_shape((h, w), v - v % 3 + 2 - v % 3)
    assert version_shape((h, w), IDENTITY) == (180, 320)
    assert [version_shape((h, w), v) for v in (1, 4, 7)] == [(90, 160), (135, 240), (180, 320)]
    assert version_shape((h, w), 8) == (289, 365)  # 180 cos + 320 sin, 320 cos + 180 sin
    assert version_shape((1, 1), 0) == (1, 1)


def test_coordinates_of_the_identity_and_the_mirror_are_pixel_centres():
    yx = version_coordinates((5, 7), IDENTITY)
    rows, cols = np.mgrid[0:5, 0:7]
    assert np.array_equal(yx[..., 0], rows)
    assert np.array_equal(yx[..., 1], cols)
    mirror = version_coordinates((5, 7), 16)
    assert np.array_equal(mirror[..., 1], 6 - cols)
    window = version_coordinates((5, 7), 16, origin=(-2, 3), size=(4, 2))
    assert np.array_equal(window[..., 0], rows[:4, :2] - 2)
    assert np.array_equal(window[..., 1], 6 - (cols[:4, :2] + 3))


def test_coordinates_rotate_counter_clockwise_on_screen():
    # +22.5 degrees: walking right in the version walks right and *down* in the source,
    # i.e. the source's rightward direction shows up pointing right and up.
    yx = version_coordinates((60, 80), 8)
    step = yx[10, 11] - yx[10, 10]
    a = math.radians(22.5)
    assert step == pytest.approx([math.sin(a), math.cos(a)])


@pytest.mark.parametrize("v", ALL)
def test_vectors_follow_the_coordinate_map(v):
    # A version step delta is a source step Q(p + delta) - Q(p); carrying that source
    # vector into the version must give delta back: u_v = s R F u_s inverts the map.
    yx = version_coordinates((50, 70), v)
    down = yx[6, 5] - yx[5, 5]
    right = yx[5, 6] - yx[5, 5]
    assert transform_vectors(np.stack([down, right]), v) == pytest.approx(np.eye(2), abs=1e-12)


@pytest.mark.parametrize("v", ALL)
def test_transform_vectors_equals_the_literal_formula(v):
    # Mutation caught: the sign of sin in the rotation's lower row (version_matrix).
    u = np.random.default_rng(v).normal(size=(4, 5, 2))
    assert np.allclose(transform_vectors(u, v), reference_transform_vectors(u, v), atol=1e-12)


def test_transform_vectors_flip_scale_rotation():
    u = np.array([[0.0, 1.0], [1.0, 0.0], [0.3, -0.7]])
    flipped = transform_vectors(u, 16)
    assert np.array_equal(flipped, u * [1, -1])  # flip: dx negated, exactly
    assert np.array_equal(transform_vectors(u, IDENTITY), u)
    assert np.allclose(transform_vectors(u, 1), 0.5 * u)  # 50 %: half the length
    a = math.radians(22.5)
    assert transform_vectors(u[0], 8) == pytest.approx([-math.sin(a), math.cos(a)])  # right->up
    assert transform_vectors(u[1], 8) == pytest.approx([math.cos(a), math.sin(a)])  # down->right
    assert transform_vectors(u[0], 6) == pytest.approx([math.sin(a), math.cos(a)])  # -22.5
    assert transform_vectors(u.astype(np.float32), 8).dtype == np.float32


# --- sampling ----------------------------------------------------------------------


def test_identity_is_exact():
    frames = clip()
    assert np.array_equal(sample_version(frames, IDENTITY), frames)
    # ... also through the general path, to the last row and column.
    part = sample_version(frames, IDENTITY, origin=(30, 40), size=(10, 16))
    assert np.array_equal(part, frames[:, 30:40, 40:56])
    flow = clip((2, 40, 56, 2))
    assert np.array_equal(transform_flow(flow, IDENTITY), flow)


def test_mirror_is_exact():
    frames = clip((2, 40, 56, 3))
    assert np.array_equal(sample_version(frames, 16), frames[:, :, ::-1])
    flow = clip((2, 40, 56, 2))
    mirrored = transform_flow(flow, 16)
    assert np.array_equal(mirrored[..., 0], flow[:, :, ::-1, 0])
    assert np.array_equal(mirrored[..., 1], -flow[:, :, ::-1, 1])


@pytest.mark.parametrize("v", ALL)
def test_sampling_equals_the_literal_reference(v):
    # The plain version has its own canvas, coordinates and prefilter. Mutations
    # caught: the prefilter's sigma (1/s - 1)/3 instead of /2 (prefilter_sigma); the
    # flipped versions not mirrored (_coordinates).
    frames = clip((2, 30, 44))
    fast = sample_version(frames, v)
    assert fast.dtype == np.float32
    assert np.abs(fast - reference_sample_version(frames, v)).max() < 2e-6
    window = {"origin": (-3, 5), "size": (9, 7)}  # partly outside the canvas: clamped
    ref = reference_sample_version(frames, v, **window)
    assert np.abs(sample_version(frames, v, **window) - ref).max() < 2e-6


@pytest.mark.parametrize("v", ALL)
def test_a_window_sampled_alone_equals_the_whole_version_bit_for_bit(v):
    grey, colour, flow = clip((3, 40, 56)), clip((1, 40, 56, 3), 1), clip((2, 40, 56, 2), 2)
    hv, wv = version_shape((40, 56), v)
    for data, sample in ((grey, sample_version), (colour, sample_version), (flow, transform_flow)):
        whole = sample(data, v)
        assert whole.shape[1:3] == (hv, wv)
        for r0, c0, h, w in [(0, 0, 5, 6), (hv - 7, wv - 4, 7, 4), (hv // 3, wv // 2, 11, 13)]:
            part = sample(data, v, origin=(r0, c0), size=(h, w))
            assert np.array_equal(part, whole[:, r0 : r0 + h, c0 : c0 + w])
        # Windows reaching outside the canvas agree with any window that holds them.
        big = sample(data, v, origin=(-6, -5), size=(hv + 12, wv + 10))
        assert np.array_equal(big[:, 6 : 6 + hv, 5 : 5 + wv], whole)
        small = sample(data, v, origin=(-4, wv - 3), size=(8, 7))
        assert np.array_equal(small, big[:, 2:10, wv + 2 : wv + 9])


def bits(a):
    """The float32 values' bit patterns (so that -0.0 and 0.0 differ)."""
    return np.ascontiguousarray(a, np.float32).view(np.uint32)


@pytest.mark.parametrize("shape", [(4, 40, 56), (3, 61, 48), (2, 37, 53)])
def test_the_version_sampler_gives_sample_version_bit_for_bit(shape):
    # The build's path: the source prepared once, blurred once per scale, each flipped
    # version the mirror image of its partner: the same bits as one call per version,
    # in any order of the versions.
    grey, colour, flow = clip(shape), clip((1, *shape[1:], 3), 1), clip((*shape, 2), 2) - 0.5
    samplers = VersionSampler(grey), VersionSampler(colour), VersionSampler(flow, vectors=True)
    for order in (mirror_order(ALL), list(ALL)[::-1]):
        for v in order:
            g, c, f = (sample(v) for sample in samplers)
            hv, wv = version_shape(shape[1:], v)
            assert g.shape == (hv, wv, shape[0])
            assert c.shape == (hv, wv, 3)
            assert f.shape == (hv, wv, 2 * shape[0])
            assert np.array_equal(bits(g), bits(np.moveaxis(sample_version(grey, v), 0, -1)))
            assert np.array_equal(bits(c), bits(sample_version(colour, v)[0]))
            carried = np.moveaxis(transform_flow(flow, v), 0, 2).reshape(hv, wv, -1)
            assert np.array_equal(bits(f), bits(carried))
    # The three samplers (and later windows and clips of this size) share each
    # version's sampling plan, made once and read-only: nothing can change it under them.
    from fluidnb.videodb.database._augment import _whole_plan

    plan = _whole_plan(*shape[1:], 0)
    assert plan is _whole_plan(*shape[1:], 0)
    assert not any(a.flags.writeable for a in plan.indices)


def test_mirror_partners_are_mirror_images():
    assert [mirror_partner(v) for v in ALL] == [11, 10, 9, 14, 13, 12, 17, 16, 15] + [
        2,
        1,
        0,
        5,
        4,
        3,
        8,
        7,
        6,
    ]
    assert sorted(mirror_order(ALL)) == list(ALL)
    order = mirror_order(ALL)
    assert all(order[i + 1] == mirror_partner(order[i]) for i in range(0, 18, 2))
    frames = clip((2, 31, 45))
    for v in ALL:
        flip, s, angle = VERSIONS[v]
        assert VERSIONS[mirror_partner(v)] == (not flip, s, -angle)
        assert np.array_equal(
            sample_version(frames, v), sample_version(frames, mirror_partner(v))[:, :, ::-1]
        )


def test_sampling_keeps_range_and_constants():
    frames = clip()
    const = np.full((2, 30, 40), 0.3, np.float32)
    for v, (_, s, _) in enumerate(VERSIONS):
        out = sample_version(frames, v)
        assert out.min() >= frames.min() - 1e-7
        assert out.max() <= frames.max() + 1e-7
        # Interpolation alone keeps a constant exactly; the prefilter's float32 weights
        # need not sum to exactly 1 (measured: 1 ulp off at 75 %).
        assert np.abs(sample_version(const, v) - np.float32(0.3)).max() <= (0 if s == 1 else 6e-8)


def test_inputs_are_not_modified():
    frames, flow = clip(), clip((2, 40, 56, 2))
    copies = frames.copy(), flow.copy()
    sample_version(frames, 0)
    transform_flow(flow, 11)
    assert np.array_equal(frames, copies[0])
    assert np.array_equal(flow, copies[1])


def test_scaled_flow_of_a_uniform_motion_is_scaled():
    flow = np.zeros((1, 40, 56, 2), np.float32)
    flow[..., 0], flow[..., 1] = 0.4, -1.2
    half = transform_flow(flow, 1)
    assert np.allclose(half, [0.2, -0.6], atol=1e-6)
    turned = transform_flow(flow, 5)  # 75 %, +22.5 degrees
    assert np.allclose(turned, transform_vectors(np.array([0.4, -1.2]), 5), atol=1e-6)


# --- flows of versions: carried versus measured ------------------------------------


@pytest.fixture(scope="module")
def moving():
    """A pattern moving by (0.6, 1.1) px a frame (exact), and its DIS flow."""
    f = texture()
    yy, xx = np.mgrid[0:96, 0:128].astype(float)
    frames = np.stack([f(yy - 0.6 * t, xx - 1.1 * t) for t in range(3)]).astype(np.float32)
    return frames, optical_flow(frames)


@pytest.mark.parametrize(
    ("v", "bound"),
    [
        (8, 0.08),  # +22.5 degrees: measured mean EPE 0.031
        (6, 0.08),  # -22.5 degrees: 0.027
        (4, 0.08),  # 75 %: 0.033
        (1, 0.15),  # 50 %: 0.089
        (16, 0.05),  # mirror image: 0.005
        (11, 0.15),  # mirror, 50 %, +22.5 degrees: 0.095
    ],
)
def test_carried_flow_matches_flow_measured_on_the_version(moving, v, bound):
    frames, flow = moving
    measured = optical_flow(sample_version(frames, v))
    carried = transform_flow(flow, v)
    # Compare away from the source's border, where the flows see content come and go.
    yx = version_coordinates(frames.shape[1:], v)
    inside = (yx[..., 0] >= 8) & (yx[..., 0] <= 87) & (yx[..., 1] >= 8) & (yx[..., 1] <= 119)
    error = np.hypot(*(measured - carried)[:, inside].transpose(2, 0, 1))
    assert error.mean() < bound
    # Both agree with the true motion carried by u_v = s R F u_s.
    truth = transform_vectors(np.array([0.6, 1.1]), v)
    assert np.abs(np.median(measured[:, inside], axis=(0, 1)) - truth).max() < 0.1
    assert np.abs(np.median(carried[:, inside], axis=(0, 1)) - truth).max() < 0.1


# --- fragments ---------------------------------------------------------------------


def grid_positions(shape, v):
    hv, wv = version_shape(shape, v)
    return [
        (r, c)
        for r in range(0, hv - FRAGMENT + 1, STRIDE)
        for c in range(0, wv - FRAGMENT + 1, STRIDE)
    ]


def maps_inside(shape, v, r, c):
    yx = version_coordinates(shape, v, origin=(r, c), size=(FRAGMENT, FRAGMENT))
    h, w = shape
    return bool(np.all((yx >= 0) & (yx <= [h - 1, w - 1])))


@pytest.mark.parametrize("v", ALL)
def test_valid_positions_are_exactly_the_fragments_inside_the_source(v):
    shape = (180, 240)
    listed = valid_positions(shape, v)
    assert listed.dtype == np.int64
    assert listed.shape[1] == 2
    expected = [p for p in grid_positions(shape, v) if maps_inside(shape, v, *p)]
    assert [tuple(p) for p in listed.tolist()] == expected
    assert len(expected) > 0


def test_fragments_just_outside_are_excluded():
    shape = (180, 240)
    for v in (0, 2, 8, 17):  # rotated: the canvas's corners lie outside the source
        listed = {tuple(p) for p in valid_positions(shape, v).tolist()}
        left_out = [p for p in grid_positions(shape, v) if p not in listed]
        assert left_out  # the corners of a rotated canvas
        for r, c in left_out:
            assert not maps_inside(shape, v, r, c)
        # Each excluded fragment touching a kept one has a pixel outside the source.
        assert any(
            (r + STRIDE, c) in listed or (r, c + STRIDE) in listed or (r, c - STRIDE) in listed
            for r, c in left_out
        )


def test_valid_positions_of_the_identity_and_small_sources():
    rows, cols = (180 - FRAGMENT) // STRIDE + 1, (320 - FRAGMENT) // STRIDE + 1
    assert len(valid_positions((180, 320), IDENTITY)) == rows * cols
    assert valid_positions((180, 320), IDENTITY)[-1].tolist() == [120, 264]
    assert valid_positions((48, 48), IDENTITY).tolist() == [[0, 0]]
    assert valid_positions((47, 100), IDENTITY).shape == (0, 2)
    assert valid_positions((60, 90), 1).shape == (0, 2)  # 50 %: 30 x 45 pixels


# --- errors ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: sample_version(clip(), 18), "version must be an integer"),
        (lambda: sample_version(clip(), -1), "version must be an integer"),
        (lambda: sample_version(clip(), 1.5), "version must be an integer"),
        (lambda: sample_version(clip()[0], 1), "3 or 4 dimensions"),
        (lambda: sample_version(clip().astype(np.uint8), 1), "numeric array"),
        (lambda: sample_version(np.full((1, 4, 4), np.nan, np.float32), 1), "NaN"),
        (lambda: sample_version(clip(), 1, size=(0, 4)), r"size\[0\] must be"),
        (lambda: sample_version(clip(), 1, origin=(5,)), "origin must be a"),
        (lambda: sample_version(clip(), 1, origin=(400, 0)), "inside the version's canvas"),
        (lambda: transform_flow(clip(), 1), r"flow must have shape \(T, H, W, 2\)"),
        (lambda: VersionSampler(clip(), vectors=True), r"frames must have shape \(T, H, W, 2\)"),
        (lambda: VersionSampler(clip())(18), "version must be an integer"),
        (lambda: transform_vectors(np.zeros(3), 1), r"vectors must have shape \(\.\.\., 2\)"),
        (lambda: version_shape((0, 5), 1), r"shape\[0\] must be"),
        (lambda: valid_positions(7, 1), "shape must be a"),
    ],
)
def test_bad_input_is_refused(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("shape", [(40, 50, 24), (7, 3, 2), (2, 9, 1), (30, 1, 3)])
@pytest.mark.parametrize("sigma", [0.5, 1.5])
def test_prefilter_blur_is_the_clamped_gaussian(shape, sigma):
    """The prefilter's row-at-a-time blur is scipy's Gaussian with clamped edges (the
    reference sampler's), on a window of a larger array and on rows shorter than the
    kernel; and a window's interior is the whole's bit for bit."""
    from scipy import ndimage as ndi

    from fluidnb.videodb.database._augment import _blur, _gaussian_kernel
    from fluidnb.videodb.database._versions import _TRUNCATE

    rng = np.random.default_rng(12)
    whole = rng.random((shape[0] + 8, shape[1] + 8, shape[2])).astype(np.float32)
    window = whole[4:-4, 4:-4]  # not contiguous
    kernel = _gaussian_kernel(sigma)
    out = _blur(window, kernel)
    ref = ndi.gaussian_filter(
        window.astype(np.float64), (sigma, sigma, 0), mode="nearest", truncate=_TRUNCATE
    )
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-6)
    r = len(kernel) - 1
    inner = _blur(whole, kernel)[4 + r : -4 - r, 4 + r : -4 - r]  # the window's, context r
    assert np.array_equal(out[r:-r, r:-r], inner)
