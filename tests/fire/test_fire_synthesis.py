"""Texture synthesis with user control (Furukawa et al. 2013, sec. 3.2, Fig. 4; Ashikhmin 2001)."""

import numpy as np
import pytest

from fluidnb.data import sample
from fluidnb.fire import (
    FireParams,
    alpha_from_photo,
    neighbourhood_error,
    neighbourhoods,
    synthesize,
)

LUMA = np.array([0.2126, 0.7152, 0.0722])


def flame_target(n):
    """A synthetic flame-shaped temperature image in [0, 1]: hot bottom-centre."""
    yy, xx = np.mgrid[:n, :n] / n
    t = np.exp(-(((xx - 0.5) / 0.17) ** 2 + ((yy - 0.58) / 0.29) ** 2))
    return (t / t.max()).astype(np.float32)


@pytest.fixture(scope="module")
def reference():
    photo, matte = sample("fire", size=64, return_alpha=True)
    return photo, matte, flame_target(48)


@pytest.mark.parametrize("size", [3, 5, 7])
def test_the_two_ls_tile_the_square_once_and_split_at_p(size):
    upper, lower = neighbourhoods(size)
    h = size // 2
    both = {tuple(o) for o in upper} | {tuple(o) for o in lower}
    assert len(upper) + len(lower) == size * size == len(both)
    assert len(upper) == (size * size - 1) // 2
    # N_U: rows above, or p's row strictly to the left; N_L holds p itself.
    assert all(dy < 0 or (dy == 0 and dx < 0) for dy, dx in upper)
    assert [0, 0] in lower.tolist()
    assert np.abs(np.concatenate([upper, lower])).max() == h


@pytest.mark.parametrize("method", ["candidates", "exhaustive"])
@pytest.mark.parametrize("second_pass", [False, True])
def test_every_pixel_is_the_photo_at_its_recorded_source(reference, method, second_pass):
    photo, matte, target = reference
    target = target[::2, ::2]
    params = FireParams(second_pass=second_pass)
    image, sources = synthesize(photo, target, params, matte=matte, method=method, seed=4)
    assert image.shape == (*target.shape, 3)
    assert image.dtype == np.float32
    assert sources.shape == (*target.shape, 2)
    assert sources.min() >= 0
    assert sources[..., 0].max() < photo.shape[0]
    assert sources[..., 1].max() < photo.shape[1]
    matted = photo * matte[..., None]  # the colour is composited onto black
    np.testing.assert_array_equal(image, matted[sources[..., 0], sources[..., 1]])


def test_output_brightness_follows_the_target_on_the_reference_fire():
    photo, matte = sample("fire", size=128, return_alpha=True)
    target = flame_target(96)
    image, _ = synthesize(photo, target, matte=matte, seed=0)
    r = np.corrcoef(image.reshape(-1, 3) @ LUMA, target.ravel())[0, 1]
    assert r >= 0.8, r


# Stated factor: on this reference (fire photo at 64 px, 48 x 48 flame target) the
# candidate search without the coherence penalty (kappa = 0, the paper's search)
# reaches a mean neighbourhood error <= 1.5 x the exhaustive search's; with the
# default penalty (kappa = 1), which trades some of it for larger patches, 1.6 x
# (measured), and we require <= 1.8 x.
QUALITY_FACTOR = {0.0: 1.5, 1.0: 1.8}


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("coherence", [0.0, 1.0])
def test_candidate_search_error_is_within_the_stated_factor_of_exhaustive(
    reference, seed, coherence
):
    photo, matte, target = reference
    params = FireParams(coherence=coherence)
    cand = synthesize(photo, target, params, matte=matte, seed=seed)
    full = synthesize(photo, target, params, matte=matte, seed=seed, method="exhaustive")
    e_cand = neighbourhood_error(*cand, photo, target, params, matte=matte)
    e_full = neighbourhood_error(*full, photo, target, params, matte=matte)
    assert e_full <= e_cand <= QUALITY_FACTOR[coherence] * e_full, (e_cand, e_full)


def _brute_force(photo, alpha, target, size, weight):
    """The paper's search written out: every input pixel, every output pixel, in order.

    Values are compared as 8-bit levels, as fluidnb compares them.
    """
    h = size // 2

    def levels(x):
        return np.rint(np.clip(np.asarray(x, np.float32), 0, 1) * 255) / 255.0

    photo, alpha, target = levels(photo), levels(alpha), levels(target)
    ap = np.pad(photo, ((h, h), (h, h), (0, 0)), mode="edge")
    al = np.pad(alpha, h, mode="edge")
    upper, lower = neighbourhoods(size)
    hh, ww = target.shape
    out = np.zeros((hh, ww, 3))
    src = np.zeros((hh, ww, 2), int)
    err = np.zeros((hh, ww))
    for r in range(hh):
        for c in range(ww):
            nu = [(dy, dx) for dy, dx in upper if 0 <= r + dy < hh and 0 <= c + dx < ww]
            nl = [(dy, dx) for dy, dx in lower if 0 <= r + dy < hh and 0 <= c + dx < ww]
            best, arg = np.inf, None
            for sr in range(photo.shape[0]):
                for sc in range(photo.shape[1]):
                    su = sum(
                        np.sum((out[r + dy, c + dx] - ap[sr + h + dy, sc + h + dx]) ** 2)
                        for dy, dx in nu
                    )
                    sl = sum(
                        (target[r + dy, c + dx] - al[sr + h + dy, sc + h + dx]) ** 2
                        for dy, dx in nl
                    )
                    d = (1 - weight) * su / (3 * len(nu)) if nu else 0.0
                    d += weight * sl / len(nl)
                    if d < best:
                        best, arg = d, (sr, sc)
            out[r, c] = photo[arg]
            src[r, c] = arg
            err[r, c] = best
    return src, err


@pytest.mark.parametrize("weight", [0.0, 0.4, 1.0])
def test_exhaustive_search_is_the_brute_force_search(weight):
    gen = np.random.default_rng(7)
    photo = gen.random((8, 9, 3), dtype=np.float32)
    target = gen.random((5, 4), dtype=np.float32)
    params = FireParams(weight=weight, size=3, second_pass=False)
    _image, sources, error = synthesize(
        photo, target, params, method="exhaustive", seed=0, return_error=True
    )
    src, err = _brute_force(photo, alpha_from_photo(photo), target, 3, weight)
    if weight == 1.0:
        # Colour does not count: only the (unique) errors must agree.
        np.testing.assert_allclose(error, err, rtol=1e-5, atol=1e-7)
    else:
        np.testing.assert_array_equal(sources, src)
        np.testing.assert_allclose(error, err, rtol=1e-5, atol=1e-7)


def test_same_seed_same_image_and_another_seed_another(reference):
    photo, matte, target = reference
    a = synthesize(photo, target, matte=matte, seed=11)
    b = synthesize(photo, target, matte=matte, seed=11)
    c = synthesize(photo, target, matte=matte, seed=12)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])


def test_weight_one_matches_the_shape_and_weight_zero_ignores_it(reference):
    photo, matte, target = reference
    alpha = alpha_from_photo(photo, matte)

    def alpha_error(weight):
        _, src = synthesize(photo, target, FireParams(weight=weight), matte=matte, seed=3)
        return np.mean((alpha[src[..., 0], src[..., 1]] - target) ** 2)

    assert alpha_error(1.0) < 0.25 * alpha_error(0.0)


def test_alpha_is_the_normalised_luminance_of_the_matted_photo():
    photo = np.zeros((2, 3, 3), np.float32)
    photo[0, 0] = 0.2
    photo[1, 2] = 0.6
    np.testing.assert_allclose(alpha_from_photo(photo), [[1 / 3, 0, 0], [0, 0, 1]], atol=1e-6)
    # A matte composites the photo onto black first: what it hides is not flame.
    matte = np.array([[1, 1, 1], [1, 1, 0.25]], np.float32)
    np.testing.assert_allclose(alpha_from_photo(photo, matte), [[1, 0, 0], [0, 0, 0.75]], atol=1e-6)
    # The brightest flame pixel has alpha 1, so the hottest target finds it.
    flame, m = sample("fire", size=48, return_alpha=True)
    a = alpha_from_photo(flame, m)
    assert a.max() == 1.0
    lum = (flame * m[..., None]) @ LUMA
    assert np.unravel_index(a.argmax(), a.shape) == np.unravel_index(lum.argmax(), lum.shape)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"photo": np.zeros((8, 8), np.float32)}, "photo must be an RGB or RGBA image"),
        ({"photo": np.ones((1, 1, 3), np.float32), "matte": None}, "photo must be at least 8 x 8"),
        ({"matte": "empty"}, "matte has no flame region"),  # the matte, not the photo
        ({"photo": np.zeros((16, 16, 3), np.float32), "matte": None}, "photo has no flame"),
        ({"matte": np.zeros((5, 5), np.float32)}, "matte must have the same height"),
        ({"target": np.full((6, 6), np.nan, np.float32)}, "target contains"),
        ({"target": np.full((6, 6), 2.0, np.float32)}, r"target must be in \[0, 1\]"),
        ({"target": np.zeros((6, 6, 2), np.float32)}, "target must have 2 dimensions"),
        ({"method": "fast"}, "method must be one of"),
        ({"params": {"weight": 0.5}}, "params must be a FireParams"),
    ],
)
def test_bad_inputs_name_the_parameter(change, match):
    photo, matte = sample("flame", size=16, return_alpha=True)
    args = {"photo": photo, "target": np.zeros((6, 6), np.float32), "matte": matte}
    args.update(change)
    if isinstance(args["matte"], str):
        args["matte"] = np.zeros_like(matte)
    params = args.pop("params", None)
    with pytest.raises(ValueError, match=match):
        synthesize(args.pop("photo"), args.pop("target"), params, **args, seed=0)


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"size": 4}, "size must be an odd integer"),
        ({"weight": 1.5}, r"weight must be in \[0, 1\]"),
        ({"interval": 6, "overlap": 6}, "overlap must be < interval"),
        ({"input_size": 4}, "input_size must be -1, 0 or >= 8"),
        ({"input_size": -2}, r"input_size must be an integer in \[-1, 4096\], got -2"),
        ({"output_size": 8}, r"output_size must be 0 \(the simulation's grid\) or >= 16 pixels"),
        ({"output_size": 5000}, r"output_size must be an integer in \[0, 4096\], got 5000"),
        ({"fps": 0}, r"fps must be in \[1, 120\], got 0"),
        ({"fps": float("nan")}, "fps must be"),
    ],
)
def test_bad_params_are_refused(fields, match):
    with pytest.raises(ValueError, match=match):
        FireParams(**fields)


def test_overlap_defaults_to_half_the_interval():
    assert FireParams(interval=10).m == 5
    assert FireParams(interval=7).m == 3
    assert FireParams(interval=10, overlap=0).m == 0


def test_without_random_candidates_the_first_pixel_still_gets_a_source(reference):
    photo, matte, target = reference
    params = FireParams(n_random=0)
    image, sources = synthesize(photo, target[:12, :12], params, matte=matte, seed=0)
    assert sources.min() >= 0
    matted = photo * matte[..., None]  # the colour is composited onto black
    np.testing.assert_array_equal(image, matted[sources[..., 0], sources[..., 1]])
