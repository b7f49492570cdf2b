"""What a database keeps of each fragment, checked against known answers (Fig. 5-7, Eq. 2).

The motion spectra and the textureness feed the smoothness term of Eq. (2) and (6);
here each is computed on inputs whose answer is known in closed form.
"""

import numpy as np
import pytest

from fluidnb.videodb.database import motion_spectra, textureness, window_features
from fluidnb.videodb.database._features import _flow_blocks, _moving_blocks, pixel_features

N = 32  # frames per fragment: n = N - 1 flows
H, W = 48, 72


def flow_of(dx_series, dy_series=None, shape=(H, W)):
    """A flow (n, H, W, 2) uniform in space, (dy, dx) per frame pair from the series."""
    n = len(dx_series)
    dy_series = np.zeros(n) if dy_series is None else dy_series
    flow = np.empty((n, *shape, 2), np.float32)
    flow[..., 0] = np.asarray(dy_series, np.float32)[:, None, None]
    flow[..., 1] = np.asarray(dx_series, np.float32)[:, None, None]
    return flow


# ------------------------------------------------------------------ motion spectra


@pytest.mark.parametrize(("k", "amplitude", "mean"), [(3, 1.5, 0.0), (1, 0.4, 0.7), (7, 2.0, -1.2)])
def test_a_sinusoidal_motion_puts_its_power_in_its_bin(k, amplitude, mean):
    """M_t = m + A cos(2 pi k t / n): bin 0 holds m, bin k the power (A / 2)^2, others 0.

    The one-sided spectrum |sum_t M_t e^(-2 pi i f t / n)|^2 / n^2 of a cosine of k
    cycles over the n flows is (A n / 2)^2 / n^2 = A^2 / 4 at f = k, in (px/frame)^2
    whatever n; the other component, which does not move, has none.
    """
    n = N - 1
    t = np.arange(n)
    dx = mean + amplitude * np.cos(2 * np.pi * k * t / n + 0.3)
    spec = motion_spectra(flow_of(dx), n_bins=N // 2)
    assert spec.shape == (N // 2, 2, H // 4, W // 4)
    np.testing.assert_allclose(spec[0, 1], mean, atol=1e-5)  # DC: the signed mean motion
    np.testing.assert_allclose(spec[k, 1], amplitude**2 / 4, rtol=1e-4)
    others = np.delete(spec[1:, 1], k - 1, axis=0)
    assert np.abs(others).max() < 1e-8
    assert np.abs(spec[:, 0]).max() < 1e-8  # dy never moves


def test_a_pure_translation_has_only_dc():
    """A steady flow (dy, dx): bin 0 is (dy, dx), signed; every other bin is 0."""
    n = N - 1
    spec = motion_spectra(flow_of(np.full(n, -1.25), np.full(n, 0.5)), n_bins=N // 2)
    np.testing.assert_allclose(spec[0, 0], 0.5, rtol=1e-6)
    np.testing.assert_allclose(spec[0, 1], -1.25, rtol=1e-6)  # to the left: negative
    assert np.abs(spec[1:]).max() < 1e-10


def test_opposite_flows_differ_at_dc_and_agree_elsewhere():
    """Our decision for bin 0: the mean itself, so opposite flows do not look alike."""
    n = N - 1
    wobble = 0.3 * np.sin(2 * np.pi * 2 * np.arange(n) / n)
    right = motion_spectra(flow_of(1.0 + wobble), n_bins=4)
    left = motion_spectra(flow_of(-1.0 - wobble), n_bins=4)
    np.testing.assert_allclose(right[0], -left[0], atol=1e-6)
    np.testing.assert_allclose(right[1:], left[1:], rtol=1e-5, atol=1e-9)


def test_spectra_are_per_block_of_the_motion():
    """Each stored value is the spectrum of the mean motion over its 4 x 4 pixels."""
    n = N - 1
    k, amplitude = 2, 1.0
    dx = amplitude * np.cos(2 * np.pi * k * np.arange(n) / n)
    flow = flow_of(dx)
    flow[:, :, :34] = 0.0  # still up to column 34: block 8 (columns 32-35) half moves
    spec = motion_spectra(flow, n_bins=4)
    np.testing.assert_allclose(spec[k, 1, :, 9:], amplitude**2 / 4, rtol=1e-4)
    assert np.abs(spec[k, 1, :, :8]).max() < 1e-12
    # Block 8 moves at half the speed on average: a quarter of the power.
    np.testing.assert_allclose(spec[k, 1, :, 8], (amplitude / 2) ** 2 / 4, rtol=1e-4)


# ---------------------------------------------------------------------- textureness


def test_a_constant_image_has_zero_textureness():
    """Every band of a constant's Laplacian pyramid is 0; the residual is the constant,
    summed over the frames (level 3 is the brightness, as the paper's Fig. 7)."""
    c = 0.6
    frames = np.full((N, H, W), c, np.float32)
    t = textureness(frames)
    assert t.shape == (4, H // 2, W // 2)
    assert np.abs(t[:3]).max() < 1e-4 * N * c  # float32 round-off of the blurs
    np.testing.assert_allclose(t[3], N * c, rtol=1e-5)


def test_a_fine_checkerboard_is_all_level_zero():
    """(-1)^(x + y) is the finest detail there is: a Gaussian of sigma 1 removes it
    (by exp(-pi^2) per axis), so it lies in band 0 alone, |L0| = a; the rest is the
    mean c, in the residual."""
    c, a = 0.5, 0.2
    y, x = np.mgrid[:H, :W]
    frame = (c + a * (-1.0) ** (x + y)).astype(np.float32)
    t = textureness(np.repeat(frame[None], N, axis=0))
    inner = (slice(4, -4), slice(4, -4))  # away from the border's reflection
    np.testing.assert_allclose(t[0][inner], N * a, rtol=2e-3)
    assert t[1][inner].max() < 2e-3 * N * a
    assert t[2][inner].max() < 2e-3 * N * a
    np.testing.assert_allclose(t[3][inner], N * c, rtol=2e-3)


def test_textureness_sums_over_frames():
    """Magnitudes summed over the window's frames: a frame and its negative about the
    mean (a flickering texture) count twice the magnitude of one."""
    gen = np.random.default_rng(0)
    frame = (0.5 + 0.2 * gen.standard_normal((H, W))).astype(np.float32)
    flicker = np.stack([frame, 1.0 - frame] * (N // 2))
    one = textureness(frame[None])
    np.testing.assert_allclose(textureness(flicker)[:3], N * one[:3], rtol=1e-4, atol=1e-4)


def test_stored_textureness_keeps_opencvs_pyramid_steps_bit_for_bit():
    """Databases store the textureness: it stays on the OpenCV blur-and-resample steps it
    was built with (not the renderer's fused float32 steps, equal only to round-off), so
    the same sources keep giving the same database."""
    import cv2

    from fluidnb.fields._pyramid import _kernel, _laplacian32
    from fluidnb.videodb.database._features import _textureness

    gen = np.random.default_rng(5)
    stack = gen.random((H, W, 6)).astype(np.float32)  # even sides: the fused path applies
    k = _kernel(1.0)

    def blur(a):
        return cv2.sepFilter2D(a, -1, k, k, borderType=cv2.BORDER_REFLECT)

    def resize(a, shape):
        return cv2.resize(a, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)

    gauss = [stack]
    for _ in range(3):
        g = gauss[-1]
        gauss.append(resize(blur(g), ((g.shape[0] + 1) // 2, (g.shape[1] + 1) // 2)))
    want = [g - blur(resize(nxt, g.shape[:2])) for g, nxt in zip(gauss[:-1], gauss[1:])]
    got = _laplacian32(stack, 4, fused=False)
    for band, ref in zip(got, want + [gauss[-1]]):
        assert np.array_equal(band, ref)
    # The fused steps differ in the last bits here: the choice is not a no-op.
    fused = _laplacian32(stack, 4)
    assert any(not np.array_equal(a, b) for a, b in zip(fused, got))
    # And the stored textureness is made from the OpenCV steps.
    levels = [np.abs(band).sum(axis=-1, dtype=np.float32) for band in got]
    assert np.array_equal(_textureness(stack)[0], _block_mean_2(levels[0]))


def _block_mean_2(a):
    """The 2 x 2 block means of ``a`` (TEXTURE_BLOCK = 2), in float32 as the library."""
    from fluidnb.videodb.database._features import block_mean

    return block_mean(a[None], 2)[0].astype(np.float32)


# ------------------------------------------------------------------- window features


def test_window_features_of_a_translation_keep_its_motion_and_drop_the_still_part():
    """A window whose right part translates at (0.5, -1.25) px/frame and whose left
    fragment is still: the still fragment is dropped, the moving one keeps the motion
    as its mean motion, per frame pair, and as its DC spectrum, with nothing else."""
    n = N - 1
    flow = flow_of(np.full(n, -1.25), np.full(n, 0.5))
    flow[:, :, :24] = 0.0  # the first fragment's left half is still
    gen = np.random.default_rng(1)
    frames = gen.random((N, H, W)).astype(np.float32)
    colour = np.stack([frames.mean(axis=0)] * 3, axis=-1)
    positions = np.array([[0, 0], [0, 24]])
    keep, feats = window_features(frames, colour, flow, positions, threshold=0.2, n_bins=N // 2)
    assert keep.tolist() == [True, True]
    np.testing.assert_allclose(feats["mean_motion"][1], [0.5, -1.25], rtol=1e-6)
    np.testing.assert_allclose(feats["motion"][1], np.tile([0.5, -1.25], (n, 1)), rtol=1e-6)
    spectra = feats["spectra"].astype(np.float32)
    np.testing.assert_allclose(spectra[1, 0, 0], 0.5, rtol=1e-3)  # float16
    np.testing.assert_allclose(spectra[1, 0, 1], -1.25, rtol=1e-3)
    assert np.abs(spectra[1, 1:]).max() == 0
    # Fragment 0: its moving half counts, its still half does not (Fig. 5-d).
    np.testing.assert_allclose(feats["moving"], [0.5, 1.0])
    np.testing.assert_allclose(feats["mean_motion"][0], [0.5, -1.25], rtol=1e-6)
    # Nothing moves at all: no fragment is kept.
    keep, feats = window_features(
        frames, colour, np.zeros_like(flow), positions, threshold=0.2, n_bins=N // 2
    )
    assert not keep.any()
    assert feats is None
    # The mean image is the colour mean rounded to 8 bits.
    keep, feats = window_features(frames, colour, flow, positions, threshold=0.2, n_bins=4)
    expected = (np.clip(colour[:48, 24:72], 0, 1) * 255 + 0.5).astype(np.uint8)
    np.testing.assert_array_equal(feats["mean"][1], expected)


@pytest.mark.parametrize("seed", range(6))
def test_the_fused_moving_mask_and_block_means_equal_numpy_and_opencv(seed):
    # The build's kernel against the plain computation it replaces: the mask of
    # np.sqrt(dy ** 2 + dx ** 2).mean(axis=0) > threshold, and OpenCV's area resize of
    # the masked flow frame by frame (_flow_blocks): the same bits, ragged edges too.
    gen = np.random.default_rng(seed)
    n, h, w = int(gen.integers(2, 34)), int(gen.integers(4, 90)), int(gen.integers(4, 90))
    flow = (gen.standard_normal((n, h, w, 2)) * gen.uniform(0.1, 2.0)).astype(np.float32)
    flow[:, : h // 3] *= np.float32(0.05)  # a slow part: some pixels below the threshold
    threshold = float(gen.uniform(0.1, 1.0))
    moving = np.sqrt(flow[..., 0] ** 2 + flow[..., 1] ** 2).mean(axis=0) > threshold
    assert 0 < moving.mean() < 1
    expected = np.moveaxis(_flow_blocks(flow, moving), 1, -1)  # (n, Hb, Wb, 2)
    got_moving = np.empty((h, w), bool)
    got = np.empty((n, h // 4, w // 4, 2), np.float32)
    pixel_major = np.ascontiguousarray(np.moveaxis(flow, 0, 2)).reshape(h, w, 2 * n)
    _moving_blocks(pixel_major, np.float32(threshold), got_moving, got)
    assert np.array_equal(got_moving, moving)
    assert np.array_equal(got.view(np.uint32), np.ascontiguousarray(expected).view(np.uint32))


def test_pixel_features_are_window_features_of_the_same_pixels():
    gen = np.random.default_rng(2)
    n, h, w = 9, 72, 96
    frames = gen.random((n + 1, h, w)).astype(np.float32)
    colour = gen.random((h, w, 3)).astype(np.float32)
    flow = gen.standard_normal((n, h, w, 2)).astype(np.float32)
    positions = np.array([[0, 0], [0, 24], [24, 48]])
    keep, feats = window_features(frames, colour, flow, positions, threshold=0.5, n_bins=5)
    keep2, feats2 = pixel_features(
        np.ascontiguousarray(np.moveaxis(frames, 0, -1)),
        colour,
        np.ascontiguousarray(np.moveaxis(flow, 0, 2)).reshape(h, w, 2 * n),
        positions,
        threshold=0.5,
        n_bins=5,
    )
    assert np.array_equal(keep, keep2)
    for name, value in feats.items():
        assert np.array_equal(value, feats2[name]), name
    assert feats["spectra"].shape == (3, 5, 2, 12, 12)


# ------------------------------------------------- the build's kernels against numpy


def _same_bits(a, b):
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _wide_range(gen, shape):
    """float32 values over many magnitudes, both signs, with exact zeros and -0.0."""
    x = gen.standard_normal(shape) * np.exp(gen.uniform(-12, 12, shape))
    x = x.astype(np.float32)
    x.flat[::7] = 0.0
    x.flat[3::11] = -0.0
    return x


@pytest.mark.parametrize("c", [*range(1, 34), 64, 100, 127, 128, 129, 300])
def test_band_magnitudes_are_numpys_sum_bit_for_bit(c):
    # The kernel replicates numpy's pairwise summation order for up to 128 channels
    # (numpy's own sum beyond): the stored textureness must not change by one bit.
    from fluidnb.videodb.database._features import _band_magnitudes

    gen = np.random.default_rng(c)
    g, e = _wide_range(gen, (5, 7, c)), _wide_range(gen, (5, 7, c))
    for base in (e, None):
        out = np.empty((5, 7), np.float32)
        _band_magnitudes(g, base, out)
        band = g if base is None else g + np.float32(-1.0) * base  # _laplacian32's sign
        assert _same_bits(out, np.abs(band).sum(axis=-1, dtype=np.float32))


@pytest.mark.parametrize(("n", "h", "w"), [(1, 4, 4), (2, 9, 13), (5, 33, 31), (32, 48, 72)])
def test_textureness_equals_its_plain_version(n, h, w):
    # OpenCV's float32 pyramid and the fused band-magnitude kernel against float64
    # Laplacian pyramids summed in numpy: float32 round-off apart.
    # Mutation caught: the band's magnitude without its absolute value
    # (_band_magnitudes summing g - e).
    from fluidnb.videodb.database._features import _textureness
    from fluidnb.videodb.database._reference import reference_textureness

    stack = np.random.default_rng(n + h).random((h, w, n)).astype(np.float32)
    fast, plain = _textureness(stack), reference_textureness(stack)
    assert fast.shape == plain.shape == (4, h // 2, w // 2)
    np.testing.assert_allclose(fast, plain, rtol=1e-5, atol=1e-6 * n)


@pytest.mark.parametrize("seed", range(4))
def test_window_sums_equal_the_numpy_integral_image_bit_for_bit(seed):
    # Mutation caught: each window one block row short (_window_sums).
    from fluidnb.videodb.database._features import _window_sums
    from fluidnb.videodb.database._reference import reference_window_sums

    gen = np.random.default_rng(seed)
    p, q = int(gen.integers(1, 6)), int(gen.integers(1, 3))
    hb, wb = int(gen.integers(12, 40)), int(gen.integers(12, 40))
    blocks = _wide_range(gen, (p, hb, wb, q)) * np.float32(1e-6)
    blocks[:, :2] = -0.0  # whole windows of -0.0: the sign of zero is kept too
    # A huge block that every later corner of the integral image carries and the
    # four lookups cancel: their float64 round-off shows in the float32 sums, so
    # they must be the same operations in the same order.
    blocks[:, 2, 3] = np.float32(1e12)
    # Every corner on the stride-24 grid (6 blocks) whose window fits, edges included.
    rows, cols = np.arange(0, hb - 11, 6), np.arange(0, wb - 11, 6)
    positions = 4 * np.stack(np.meshgrid(rows, cols, indexing="ij"), -1).reshape(-1, 2)
    want = reference_window_sums(np.moveaxis(blocks, -1, 1), positions)  # (p, q, k)
    assert _same_bits(_window_sums(blocks, positions), np.moveaxis(want, -1, 0))


@pytest.mark.parametrize(
    ("n", "h", "w", "threshold"),
    [(1, 48, 48, 0.5), (5, 50, 75, 0.8), (9, 72, 96, 0.5), (31, 99, 121, 1.0), (9, 72, 96, 9.0)],
)
def test_pixel_features_equal_their_plain_version(n, h, w, threshold):
    # The build's features (kernels: the moving mask and block means, the window sums,
    # the textureness's magnitudes, the cut into fragments) against the features
    # written per fragment in float64: the same fragments kept, the same mean images
    # and moving shares, motions to float32 round-off, spectra and textureness to one
    # float16 rounding; ragged edges, fragments at the canvas's edges and windows with
    # nothing moving included. (That a build gives the same bits every time is
    # test_videodb_build's.)
    # Mutations caught: a still pixel's motion counted in the block means
    # (_moving_blocks); the window sums reading one block row too low (_window_sums);
    # the spectra's power divided by n instead of n^2 (_power).
    from fluidnb.videodb.database._reference import reference_pixel_features

    gen = np.random.default_rng(n * h)
    stack = gen.random((h, w, n + 1)).astype(np.float32)
    colour = (gen.random((h, w, 3)) * 1.2 - 0.1).astype(np.float32)  # clipped too
    flow = (gen.standard_normal((h, w, 2 * n)) * 0.7).astype(np.float32)
    flow[: 2 * h // 3, : 2 * w // 3] *= np.float32(0.1)  # a still corner: fragments dropped
    rows, cols = np.arange(0, h - 47, 24), np.arange(0, w - 47, 24)
    positions = np.stack(np.meshgrid(rows, cols, indexing="ij"), -1).reshape(-1, 2)
    args = stack, colour, flow, positions
    keep, feats = pixel_features(*args, threshold=threshold, n_bins=n // 2 + 1)
    keep_ref, ref = reference_pixel_features(*args, threshold=threshold, n_bins=n // 2 + 1)
    assert np.array_equal(keep, keep_ref)
    if threshold > 5:  # nothing moves that fast
        assert feats is None
        assert ref is None
        return
    assert keep.sum() > 0
    assert sorted(feats) == sorted(ref)
    for name in ref:
        assert feats[name].dtype == ref[name].dtype
        assert feats[name].shape == ref[name].shape
    for name in ("mean", "moving"):
        np.testing.assert_array_equal(feats[name], ref[name])
    for name in ("motion", "mean_motion"):
        np.testing.assert_allclose(feats[name], ref[name], rtol=1e-5, atol=1e-6)
    for name in ("spectra", "texture"):  # float16: one rounding step
        np.testing.assert_allclose(
            feats[name].astype(np.float32), ref[name], rtol=2**-10, atol=1e-7, err_msg=name
        )


def test_half_rounding_is_numpys_cast_bit_for_bit():
    # The stored spectra and textureness are cast to float16 by the build's integer
    # port of numpy's cast (numpy's own slows down on values that underflow). Checked
    # once over all 2^32 float32 patterns; here every half, the midpoints between
    # neighbouring halves (the ties) and a float32 step either side of them, the
    # underflow and overflow boundaries, and random bit patterns, both signs.
    from fluidnb.videodb.database._features import _to_half

    halves = np.arange(1 << 16, dtype=np.uint32).astype(np.uint16).view(np.float16)
    finite = np.sort(halves[np.isfinite(halves)].astype(np.float32))
    mids = (finite[:-1].astype(np.float64) + finite[1:]) / 2  # exact in float64
    mids = mids.astype(np.float32)
    near = np.concatenate([np.nextafter(mids, -np.inf), mids, np.nextafter(mids, np.inf)])
    gen = np.random.default_rng(0)
    random_bits = gen.integers(0, 1 << 32, 1 << 20, dtype=np.uint64).astype(np.uint32)
    edges = np.array([2.0**-25, 2.0**-24, 2.0**-14, 65504, 65519.996, 65520, 1e30, np.inf])
    edges = edges.astype(np.float32)
    x = np.concatenate([finite, near, random_bits.view(np.float32), edges, -edges])
    x = x[~np.isnan(x)]
    with np.errstate(over="ignore"):
        want = x.astype(np.float16)
    assert _same_bits(_to_half(x), want)
    assert np.isnan(_to_half(np.array([np.nan, -np.nan], np.float32))).all()
    # Any layout: a strided (transposed) 4-d view casts as the contiguous array.
    arr = gen.standard_normal((3, 4, 5, 6)).astype(np.float32) * np.float32(1e-5)
    view = arr.transpose(0, 3, 1, 2)
    assert _same_bits(_to_half(view), view.astype(np.float16))
