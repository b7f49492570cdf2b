"""Moving a texture along a flow without stretching it: flow maps (Neyret 2003)."""

import numpy as np
import pytest

from fluidnb.videodb.starter import flow_map_texture


def test_flow_map_texture_is_exact_where_both_phases_agree():
    # Zero flow, no jitter: both phases are the texture itself, every frame too.
    tex = np.random.default_rng(0).random((12, 20, 3)).astype(np.float32)
    still = flow_map_texture(tex, np.zeros((12, 20, 2)), 10, jitter=False, preserve_contrast=False)
    assert all(np.array_equal(f, tex) for f in still)
    # Texture constant along a whole-pixel flow: nothing changes either.
    rows = np.repeat(np.random.default_rng(1).random((12, 1)), 20, axis=1).astype(np.float32)
    v = np.zeros((12, 20, 2))
    v[..., 1] = 2.0
    frames = flow_map_texture(rows, v, 9, period=4, jitter=False, preserve_contrast=False)
    assert all(np.array_equal(f, rows) for f in frames)


def test_flow_map_texture_shifts_by_the_flow():
    # A texture of period P v / 2 along a uniform whole-pixel flow v: the two phases
    # agree and frame t is the texture shifted by t v, exactly.
    tile = np.random.default_rng(2).random((6, 4)).astype(np.float32)
    tex = np.tile(tile, (1, 6))  # period 4 = P v / 2 with P = 8, v = 1
    v = np.zeros((12, 6, 24, 2))
    v[..., 1] = 1.0
    frames = flow_map_texture(tex, v, period=8, jitter=False, preserve_contrast=False)
    assert frames.shape == (13, 6, 24)
    for t, frame in enumerate(frames):
        assert np.array_equal(frame, np.roll(tex, t, axis=1))


def test_flow_map_texture_cross_fades_two_phases():
    # Each phase is the texture moved since its last restart: phase a restarts at
    # multiples of P, phase b half a period later; w_a = 1 - |2 (t mod P) / P - 1|.
    tex = np.random.default_rng(3).random((5, 32)).astype(np.float32)
    v = np.zeros((5, 32, 2))
    v[..., 1] = 1.0
    period = 8
    frames = flow_map_texture(tex, v, 20, period=period, jitter=False, preserve_contrast=False)
    for t, frame in enumerate(frames):
        age_a, age_b = t % period, (t - period // 2) % period
        wa = 1 - abs(2 * age_a / period - 1)
        expected = wa * np.roll(tex, age_a, axis=1) + (1 - wa) * np.roll(tex, age_b, axis=1)
        np.testing.assert_allclose(frame, expected, atol=1e-6)


def test_flow_map_texture_contrast_stays_constant():
    # Jittered phases are uncorrelated: a plain cross-fade dims the contrast by up to
    # 1/sqrt(2) at mid-fade, the variance-preserving blend keeps it.
    tex = (0.5 + 0.25 * (np.random.default_rng(4).random((64, 64)) - 0.5)).astype(np.float32)
    still = np.zeros((64, 64, 2))
    kept = flow_map_texture(tex, still, 17, period=16, seed=0).std(axis=(1, 2))
    plain = flow_map_texture(tex, still, 17, period=16, seed=0, preserve_contrast=False)
    plain = plain.std(axis=(1, 2))
    assert kept.min() > 0.95 * kept.max()
    assert plain.min() < 0.75 * plain.max()
    np.testing.assert_allclose(plain[4] / tex.std(), 1 / np.sqrt(2), atol=0.03)  # w_a = 1/2


def test_flow_map_texture_leaves_its_inputs_alone():
    tex = np.random.default_rng(5).random((8, 8, 3)).astype(np.float32)
    v = np.full((3, 8, 8, 2), 0.7)
    tex0, v0 = tex.copy(), v.copy()
    flow_map_texture(tex, v, seed=0)
    assert np.array_equal(tex, tex0)
    assert np.array_equal(v, v0)


def test_flow_map_texture_refuses_bad_arguments():
    tex = np.zeros((4, 6), np.float32)
    v = np.zeros((4, 6, 2))
    with pytest.raises(ValueError, match=r"texture must hold floats in \[0, 1\]"):
        flow_map_texture(tex + 2, v, 3)
    with pytest.raises(ValueError, match="texture must hold floats"):
        flow_map_texture(np.zeros((4, 6), np.uint8), v, 3)
    with pytest.raises(ValueError, match="velocity must have shape"):
        flow_map_texture(tex, np.zeros((4, 5, 2)), 3)
    with pytest.raises(ValueError, match="n_frames is required"):
        flow_map_texture(tex, v)
    with pytest.raises(ValueError, match="n_frames must be len"):
        flow_map_texture(tex, np.zeros((2, 4, 6, 2)), 5)
    with pytest.raises(ValueError, match="period must be an even integer"):
        flow_map_texture(tex, v, 3, period=7)
    with pytest.raises(ValueError, match="velocity contains"):
        flow_map_texture(tex, np.full((4, 6, 2), np.nan), 3)


@pytest.mark.parametrize("preserve", [True, False])
@pytest.mark.parametrize("channels", [None, 1, 3])
def test_the_compiled_flow_map_equals_the_plain_one_bit_for_bit(preserve, channels):
    # The kernels against _flow_map(compiled=False): backward_warp and numpy blending,
    # with an unsteady flow fast enough to wrap around and reach the clamped border.
    from fluidnb.videodb.starter._flow_map import _flow_map

    gen = np.random.default_rng(6)
    h, w = 23, 37
    tex = gen.random((h, w) if channels is None else (h, w, channels)).astype(np.float32)
    v = (gen.standard_normal((14, h, w, 2)) * 3).astype(np.float32)
    args = (tex, v, 15, 6, True, preserve)
    fast = _flow_map(*args, np.random.default_rng(1))
    plain = _flow_map(*args, np.random.default_rng(1), compiled=False)
    assert fast.shape == (15, *tex.shape)
    assert np.array_equal(fast.view(np.uint32), plain.view(np.uint32))


def test_the_kernels_wrap_is_pythons_modulo():
    # The kernels' wrap skips the division for -n <= i < 2n (where nearly all the
    # coordinates are); everywhere else it must still be Python's i % n.
    from fluidnb.videodb.starter._flow_map import _wrap

    for n in (1, 2, 7, 23):
        for i in range(-5 * n - 3, 5 * n + 4):
            assert _wrap(i, n) == i % n, (i, n)
