"""The compiled keyframe scan equals the plain-numpy one written in the paper's notation."""

import numpy as np
import pytest

from fluidnb.data import sample
from fluidnb.fire import FireParams, synthesize, synthesize_reference


@pytest.mark.parametrize(
    "fields",
    [
        {},
        {"second_pass": False},
        {"coherence": 0.0},
        {"coherence": 4.0, "n_random": 3},
        {"n_random": 0},
        {"weight": 0.0, "size": 3},
        {"weight": 1.0, "size": 7},
    ],
)
def test_the_fast_scan_chooses_the_same_source_for_every_pixel(fields):
    photo, matte = sample("fire", size=20, return_alpha=True)
    yy, xx = np.mgrid[:11, :9] / 10
    target = np.exp(-(((xx - 0.5) / 0.25) ** 2 + ((yy - 0.6) / 0.35) ** 2)).astype(np.float32)
    params = FireParams(**fields)
    fast_image, fast_sources = synthesize(photo, target, params, matte=matte, seed=5)
    image, sources = synthesize_reference(photo, target, params, matte=matte, seed=5)
    np.testing.assert_array_equal(fast_sources, sources)
    np.testing.assert_array_equal(fast_image, image)


def test_on_random_pictures_too():
    gen = np.random.default_rng(2)
    for _ in range(3):
        photo = gen.random((9, 10, 3), dtype=np.float32)
        target = gen.random((6, 7), dtype=np.float32)
        params = FireParams(size=3, n_random=4)
        fast = synthesize(photo, target, params, seed=1)
        ref = synthesize_reference(photo, target, params, seed=1)
        np.testing.assert_array_equal(fast[1], ref[1])
