"""The flow mapping (spec 01-flicker, "Beyond the paper: directional flow").

A stroke drawn along a stream sets a velocity v; every spatial frequency then travels
along v, so ripples are carried one way instead of running both ways.
"""

import numpy as np
import pytest

from fluidnb.flicker import (
    FlickerModel,
    FlickerParams,
    as_velocity,
    flicker,
    flow_velocity,
    temporal_frequencies,
)
from tests.flicker.test_flicker_invariants import heights, photo

# f0 = 8 of T = 64: one oscillation every P = 8 frames, after which the height of a
# moving pattern is the same pattern moved by 8 v (Eq. (1)'s carrier is back in phase).
T, F0, P = 64, 8, 8


def drift(a, b):
    """The shift (pixels along x) that best carries ``a`` onto ``b``: cross-correlation."""
    a = a - a.mean(axis=-1, keepdims=True)
    b = b - b.mean(axis=-1, keepdims=True)
    cc = np.fft.ifft(np.conj(np.fft.fft(a, axis=-1)) * np.fft.fft(b, axis=-1), axis=-1)
    cc = cc.real.reshape(-1, a.shape[-1]).sum(axis=0)
    s = int(np.argmax(cc))
    return s if s <= a.shape[-1] // 2 else s - a.shape[-1]


def xt_slope(slice_):
    """Pixels per frame of the streaks in an x-t slice (T, W): the peak of its 2-D spectrum.

    A pattern moving at v with the carrier f0 puts the slice's energy on the lines
    f_t = +-f0 - T v nu. Shearing the spectrum by each candidate v and summing the energy
    on those lines finds the one that fits.
    """
    n_t, w = slice_.shape
    power = np.abs(np.fft.fft2(slice_ - slice_.mean())) ** 2
    nu = np.fft.fftfreq(w)
    best, best_v = -1.0, None
    for v in np.linspace(-1.5, 1.5, 121):
        on = 0.0
        for sign in (1, -1):
            ft = np.mod(np.rint(sign * F0 - n_t * v * nu), n_t).astype(int)
            on += power[ft, np.arange(w)].sum()
        if on > best:
            best, best_v = on, v
    return best_v


@pytest.mark.parametrize("v", [0.5, -0.5, 0.25, 1.0])
def test_heights_move_along_the_velocity_and_the_reverse_reverses(v):
    img = photo((40, 96, 3))
    p = FlickerParams(mapping="flow", beta=0, T=T, f0=F0)
    H = heights(FlickerModel(img, params=p, flow=(0.0, v)))
    for t in (0, 5, 30, 60):
        assert drift(H[t], H[(t + P) % T]) == round(v * P), t
    # Nothing moves across the flow: once moved back along x, no shift along y.
    back = np.roll(H[3 + P], -round(v * P), axis=1)
    assert drift(H[3].T, back.T) == 0


@pytest.mark.parametrize("v", [0.5, -0.5])
def test_an_xt_slice_of_the_frames_shows_streaks_of_slope_v(v):
    img = photo((40, 96, 3))
    p = FlickerParams(mapping="flow", beta=0, T=T, f0=F0, k=2.0)
    frames = flicker(img, params=p, flow=(0.0, v)).frames.mean(axis=-1)
    change = frames - frames.mean(axis=0)  # what moves, without the still photo
    slopes = [xt_slope(change[:, r, :]) for r in (10, 20, 30)]
    assert np.median(slopes) == pytest.approx(v, abs=0.1)
    # and the frames drift the same way
    assert drift(change[4], change[4 + P]) == round(v * P)


def test_the_plane_mapping_carries_nothing():
    img = photo((40, 96, 3))
    p = FlickerParams(mapping="plane", beta=0, T=T, f0=F0, k=2.0)
    frames = flicker(img, params=p).frames.mean(axis=-1)
    change = frames - frames.mean(axis=0)
    assert [xt_slope(change[:, r, :]) for r in (10, 20, 30)] == [0.0, 0.0, 0.0]


def test_a_vertical_stroke_moves_the_pattern_down():
    img = photo((96, 40))
    p = FlickerParams(mapping="flow", beta=0, T=T, f0=F0)
    stroke = np.array([[10.0, 20.0], [30.0, 21.0], [42.0, 20.0]])  # down 32 px in one loop
    model = FlickerModel(img, params=p, flow=stroke)
    np.testing.assert_allclose(model.velocity, [0.5, 0.0])
    H = heights(model)
    assert drift(H[2].T, H[2 + P].T) == 4
    reverse = heights(FlickerModel(img, params=p, flow=stroke[::-1]))
    assert drift(reverse[2].T, reverse[2 + P].T) == -4


@pytest.mark.parametrize("beta", [0.0, 2.0])
def test_the_flow_clip_still_loops(beta):
    img = photo((30, 50, 3))
    p = FlickerParams(mapping="flow", beta=beta, T=32, f0=2)
    model = FlickerModel(img, params=p, flow=(0.3, -0.4), seed=3)
    # Integer bins: each component turns a whole number of times per loop, so the
    # field at t = T (evaluated, not wrapped) is the field at t = 0.
    from fluidnb.flicker import noise_spectrum, temporal_signals

    g = temporal_signals(noise_spectrum(32, beta, seed=3)[model.bins], times=[0.0, 32.0])
    np.testing.assert_allclose(g[:, 1], g[:, 0], rtol=0, atol=1e-9)
    H = heights(model)
    steps = np.abs(np.diff(H, axis=0)).mean(axis=(1, 2))
    assert np.abs(H[0] - H[-1]).mean() <= steps.max()
    assert np.array_equal(model.frame(32), model.frame(0))


def test_zero_velocity_is_the_plane_mapping_exactly():
    img = photo()
    plane = FlickerModel(img, params=FlickerParams(mapping="plane", T=16), seed=2)
    still = FlickerModel(img, params=FlickerParams(mapping="flow", T=16), flow=(0, 0), seed=2)
    np.testing.assert_allclose(heights(still), heights(plane), rtol=0, atol=2e-6)


@pytest.mark.parametrize("beta", [0.0, 2.0])
def test_flow_frame0_and_the_region(beta):
    img = photo((30, 44, 3))
    mask = np.zeros(img.shape[:2], bool)
    mask[6:20, 10:31] = True
    p = FlickerParams(mapping="flow", beta=beta, T=16, f0=2, bump=6.0, k=2.0)
    clip = flicker(img, mask, p, flow=(0.2, 0.6), seed=0)
    for frame in clip.frames:
        assert np.array_equal(frame[~mask], img[~mask])
    if beta == 0:
        np.testing.assert_allclose(clip.frames[0], img, rtol=0, atol=1e-5)
    assert clip.metadata["velocity"] == [0.2, 0.6]
    model = FlickerModel(img, mask, p, flow=(0.2, 0.6), seed=0)
    for t in (0, 7, 15):
        assert np.array_equal(model.frame(t), clip.frames[t])


def test_the_frequency_map_is_the_tilted_plane():
    p = FlickerParams(mapping="flow", T=64, f0=4)
    fc = temporal_frequencies((8, 8), p, velocity=(0.0, 0.5), rounded=False)
    nu = np.fft.fftfreq(8)
    np.testing.assert_allclose(fc, 4 - 64 * 0.5 * nu[None, :] + 0 * nu[:, None])


def test_stroke_helpers():
    assert flow_velocity([[0, 0], [0, 16]], T=32).tolist() == [0.0, 0.5]
    two = [np.array([[0, 0], [16, 0]]), np.array([[5, 5], [5, 21]])]
    np.testing.assert_allclose(flow_velocity(two, T=32), [0.25, 0.25])
    assert as_velocity(np.array([0.1, 0.2]), 8).tolist() == [0.1, 0.2]
    assert as_velocity(None, 8) is None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"params": FlickerParams(mapping="flow", T=16)}, "mapping='flow' needs flow="),
        ({"params": FlickerParams(T=16), "flow": (0, 1)}, "only used by mapping='flow'"),
        ({"params": FlickerParams(mapping="flow", T=16), "flow": (0, 9)}, "at most 4 pixels"),
        ({"params": FlickerParams(mapping="flow", T=16), "flow": [[1, 2]]}, "two or more"),
        ({"params": FlickerParams(mapping="flow", T=16), "flow": (0, np.nan)}, "flow"),
    ],
)
def test_bad_flow_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        flicker(photo(), seed=0, **kwargs)
