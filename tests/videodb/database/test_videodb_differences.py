"""A fragment's difference frames D_i = F_i - A, made where the database rebuilds it (sec. 6)."""

import numpy as np
import pytest


def test_difference_frames_are_the_frames_minus_their_mean_cross_faded():
    from fluidnb.videodb.database._differences import difference_frames
    from fluidnb.videodb.rendering import loop_crossfade

    gen = np.random.default_rng(3)
    frames = gen.random((12, 9, 11)).astype(np.float32)
    d = frames - frames.mean(axis=0)
    # D_i = F_i - A as numpy computes it, frame-major (as play_loops reads them).
    assert np.array_equal(difference_frames(frames), d)
    for loop in (1, 3, 6):
        got = difference_frames(frames, loop)
        assert got.shape == (12 - loop, 9, 11)
        np.testing.assert_allclose(got, loop_crossfade(d, overlap=loop), rtol=0, atol=1e-7)
        assert np.array_equal(got[loop:], d[loop : 12 - loop])
    with pytest.raises(ValueError, match="loop must be"):
        difference_frames(frames, 7)


def test_difference_frames_are_their_numpy_steps_bit_for_bit():
    # The compiled pass (a row of pixels at a time) against the same float32 and
    # float64 steps written over whole frames in numpy, sums in frame order.
    from fluidnb.videodb.database._differences import difference_frames

    gen = np.random.default_rng(5)
    frames = gen.random((15, 13, 21)).astype(np.float32)  # 15: no power of two
    a = frames[0].copy()
    for f in frames[1:]:
        a += f
    a /= np.float32(len(frames))
    d = frames - a
    for loop in (0, 1, 5):
        length = len(frames) - loop
        want = d[:length].copy()
        m = np.zeros(d.shape[1:])
        for f in d:
            m += f.astype(np.float64)
        m /= len(frames)
        theta = 0.5 * np.pi * np.arange(1, loop + 1) / (loop + 1)  # as the function's
        for j, (s, c) in enumerate(zip(np.sin(theta), np.cos(theta))):
            head, tail = d[j].astype(np.float64) - m, d[length + j].astype(np.float64) - m
            want[j] = (m + s * head + c * tail).astype(np.float32)
        got = difference_frames(frames, loop)
        assert got.flags.c_contiguous
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
