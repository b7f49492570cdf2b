"""Dense SIFT on the 9 x 9 grid of a 48 x 48 fragment (Okabe et al., sec. 4; Lowe 2004, VLFeat)."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.videodb.database import dense_sift, reference_dense_sift
from fluidnb.videodb.database._sift import _orientation_units


def smooth_images(n, seed, shape=(48, 48), sigmas=(0.7, 1.5, 3.0)):
    """Random textures of a few scales, stretched to [0, 1], float32."""
    gen = np.random.default_rng(seed)
    out = []
    for i in range(n):
        img = ndi.gaussian_filter(gen.random(shape), sigmas[i % len(sigmas)])
        out.append((img - img.min()) / (img.max() - img.min()))
    return np.stack(out).astype(np.float32)


def test_fast_path_equals_the_literal_reference():
    # The kernel sums in another order (separable passes, reciprocals), so a value may
    # differ by one count where 512 v lands within round-off of an integer; on these
    # images every value agrees exactly.
    # Mutation caught: the Gaussian window's sigma one bin width too wide (_axis_table).
    images = smooth_images(3, seed=1)
    fast = dense_sift(images)
    for img, got in zip(images, fast):
        ref = reference_dense_sift(img)
        diff = np.abs(got.astype(int) - ref.astype(int))
        assert diff.max() <= 1
        assert np.mean(diff == 0) >= 0.999
        assert ref.any()


@pytest.mark.parametrize("value", [0.0, 0.5, 1.0])
def test_constant_image_gives_zero_descriptors(value):
    d = dense_sift(np.full((48, 48), value, np.float32))
    assert d.shape == (9, 9, 128)
    assert not d.any()


@pytest.mark.parametrize(
    ("ramp", "orientation"),
    [
        (lambda y, x: x / 64, 0),  # brighter to the right: gradient along +x
        (lambda y, x: (x + y) / 128, 1),  # 45 degrees, towards +x and +y (down)
        (lambda y, x: y / 64, 2),  # brighter downwards: +y
        (lambda y, x: (47 - x) / 64, 4),  # brighter to the left: -x
        (lambda y, x: (47 - y) / 64, 6),  # brighter upwards: -y
    ],
)
def test_ramp_puts_all_energy_in_its_gradient_orientation(ramp, orientation):
    # Multiples of 1/64 and 1/128 are exact in float32: every pixel, border included,
    # has the same gradient, so all 81 descriptors are the same.
    y, x = np.mgrid[:48, :48]
    d = dense_sift(ramp(y, x).astype(np.float32)).reshape(9, 9, 4, 4, 8)
    others = np.delete(d, orientation, axis=-1)
    assert not others.any()
    energy = d[..., orientation]
    assert energy.all()
    assert (d == d[0, 0]).all()
    # The Gaussian window is centred: bins mirror about the descriptor's centre.
    assert np.array_equal(energy[0, 0], energy[0, 0][::-1, :])
    assert np.array_equal(energy[0, 0], energy[0, 0][:, ::-1])


def test_ramp_values_match_the_closed_form():
    # A constant gradient: bin (by, bx) holds |g| W[by] W[bx], with W[b] the sum over
    # the window's 16 pixels of the triangular weight of bin b (centre 4 b + 1.5) times
    # the Gaussian window (sigma 8, centre 7.5). Then normalise, clip at 0.2,
    # renormalise, 512 v truncated.
    d = np.arange(16)
    window = np.exp(-((d - 7.5) ** 2) / (2 * 8.0**2))
    tri = np.maximum(0, 1 - np.abs(d[None, :] - (4 * np.arange(4)[:, None] + 1.5)) / 4)
    w = tri @ window
    v = np.outer(w, w).ravel()
    v = np.minimum(v / np.linalg.norm(v), 0.2)
    expected = np.floor(512 * v / np.linalg.norm(v))
    x = np.mgrid[:48, :48][1]
    got = dense_sift((x / 64).astype(np.float32))[..., ::8].astype(float)
    assert np.abs(got - expected).max() <= 1
    assert len(np.unique(expected)) >= 2  # the window does shape the descriptor


def test_shifted_pattern_moves_descriptors_by_one_grid_step():
    big = smooth_images(1, seed=2, shape=(56, 56))[0]
    base = big[4:52, 4:52]
    right = big[4:52, :48]  # the pattern moved 4 px to the right
    down = big[:48, 4:52]  # ... and 4 px down
    d_base, d_right, d_down = dense_sift(np.stack([base, right, down]))
    # Descriptors whose windows keep away from the image border (where gradients are
    # one-sided) see the very same pixels in the very same order: equal bit for bit.
    assert np.array_equal(d_right[:, 2:8], d_base[:, 1:7])
    assert np.array_equal(d_down[2:8, :], d_base[1:7, :])
    assert not np.array_equal(d_right[:, 1:7], d_base[:, 1:7])


def test_transposed_image_swaps_axes_and_mirrors_orientations():
    # Transposing swaps (gy, gx): theta -> pi/2 - theta, orientation bin t -> 2 - t
    # (mod 8), spatial bin (by, bx) -> (bx, by), descriptor (ky, kx) -> (kx, ky).
    # Sums run in another order, so values may differ by one count.
    img = smooth_images(1, seed=3)[0]
    d = dense_sift(img).reshape(9, 9, 4, 4, 8).astype(int)
    t = dense_sift(np.ascontiguousarray(img.T)).reshape(9, 9, 4, 4, 8).astype(int)
    expected = d.transpose(1, 0, 3, 2, 4)[..., (2 - np.arange(8)) % 8]
    assert np.abs(t - expected).max() <= 1
    assert np.mean(t == expected) > 0.999


def test_batches_give_the_same_descriptors_as_single_images():
    images = smooth_images(5, seed=4)
    batch = dense_sift(images)
    assert batch.shape == (5, 9, 9, 128)
    assert batch.dtype == np.uint8
    for i in (0, 3):
        assert np.array_equal(dense_sift(images[i]), batch[i])
    assert np.array_equal(dense_sift(images[2:4]), batch[2:4])
    assert dense_sift(images[:0]).shape == (0, 9, 9, 128)


def test_descriptors_are_normalised_and_clipped():
    d = dense_sift(smooth_images(2, seed=5)).reshape(-1, 128).astype(float) / 512
    norms = np.linalg.norm(d, axis=1)
    # Truncation to integers removes up to 1/512 per value.
    assert np.all(norms <= 1.0 + 1e-6)
    assert np.all(norms > 0.85)
    # After clipping at 0.2 and renormalising no value exceeds 0.2 / (0.2 * sqrt(25)).
    assert d.max() < 0.5


def test_inputs_are_not_modified():
    images = smooth_images(2, seed=6)
    before = images.copy()
    dense_sift(images)
    assert np.array_equal(images, before)


def test_orientation_units_match_atan2():
    gen = np.random.default_rng(7)
    gx = np.concatenate([gen.standard_normal(4000), [1, 0, -1, 0, 1, -1, -1, 1, 1e-300, 0]])
    gy = np.concatenate([gen.standard_normal(4000), [0, 1, 0, -1, 1, 1, -1, -1, 0, 1e-300]])
    u = np.empty_like(gx)
    _orientation_units(gy, gx, u)
    expected = np.mod(np.arctan2(gy, gx), 2 * np.pi) / (2 * np.pi) * 8
    expected[expected == 8] = 0
    wrap = np.abs(u - 8) < 1e-12
    assert np.all(np.abs(np.where(wrap, u - 8, u) - expected) <= 4 * np.spacing(8.0))
    # Axes and diagonals land exactly on the bins.
    assert u[-10:-2].tolist() == [0, 2, 4, 6, 1, 3, 5, 7]


@pytest.mark.parametrize(
    ("images", "match"),
    [
        (np.zeros((2, 48, 47), np.float32), "shape"),
        (np.zeros((48, 48), np.uint8), "numeric"),
        (np.full((48, 48), 1.5, np.float32), r"\[0, 1\]"),
        (np.full((48, 48), np.nan, np.float32), "NaN"),
        (np.zeros((1, 1, 48, 48), np.float32), "dimensions"),
    ],
)
def test_bad_images_are_refused(images, match):
    with pytest.raises(ValueError, match=match):
        dense_sift(images)
