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
    # Catches a change of the choice rule: "<=" for "<" among the coherent candidates
    # (the last of equals wins, not the first) fails 6 of these 7 cases.
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


@pytest.mark.parametrize(("band", "chunk"), [(1, 1), (2, 3), (3, 7), (8, 40)])
@pytest.mark.parametrize("size", [3, 5])
def test_the_parallel_tiles_give_the_raster_scans_result_bit_for_bit(band, chunk, size):
    # Catches a wavefront that lets a pixel read a neighbour too early or too late:
    # a shear of k // 2 - 1 columns a row (7 of these 8 cases fail), or a tile's
    # second pass run before the first pass has finished everywhere (all 8 fail).
    from fluidnb._random import rng
    from fluidnb.fire._synthesis import _check_photo, _check_target, _Prepared, _run

    photo, matte = sample("fire", size=40, return_alpha=True)
    texture, alpha = _check_photo(photo, matte)
    yy, xx = np.mgrid[:37, :29] / 30
    target = np.exp(-(((xx - 0.5) / 0.25) ** 2 + ((yy - 0.6) / 0.35) ** 2))
    target = _check_target(target.astype(np.float32))
    params = FireParams(size=size, n_random=5)
    prepared = _Prepared(texture, alpha, params)
    serial = _run(texture, alpha, target, params, False, rng(3), prepared, threads=1)
    tiles = _run(
        texture, alpha, target, params, False, rng(3), prepared, threads=2, tiles=(band, chunk)
    )
    np.testing.assert_array_equal(tiles[1], serial[1])
    np.testing.assert_array_equal(tiles[2], serial[2])
    _, sources = synthesize_reference(photo, target, params, matte=matte, seed=3)
    np.testing.assert_array_equal(serial[1], sources)


def test_a_keyframe_large_enough_for_threads_equals_one_thread():
    # The size synthesize() runs on several threads (>= 64 x 64), with its own tiles.
    import numba

    photo, matte = sample("fire", size=64, return_alpha=True)
    yy, xx = np.mgrid[:80, :70] / 70
    target = np.exp(-(((xx - 0.5) / 0.2) ** 2 + ((yy - 0.6) / 0.3) ** 2)).astype(np.float32)
    many = synthesize(photo, target, matte=matte, seed=9)[1]
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = synthesize(photo, target, matte=matte, seed=9)[1]
    finally:
        numba.set_num_threads(threads)
    np.testing.assert_array_equal(many, one)
