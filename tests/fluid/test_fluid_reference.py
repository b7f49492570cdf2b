"""The readable numpy solver (fluidnb.fluid._reference) against the fast one."""

import numpy as np
import pytest

from fluidnb.fields import advect
from fluidnb.fluid import (
    BOUNDARIES,
    FluidParams,
    FluidState,
    advect_velocity,
    buoyancy,
    cool,
    curl,
    divergence,
    project,
    step,
    vorticity_confinement,
)
from fluidnb.fluid import _reference as ref

SHAPES = [(2, 2), (3, 7), (9, 4), (17, 12), (24, 32)]


def _velocity(shape, seed):
    return np.random.default_rng(seed).normal(scale=1.5, size=(*shape, 2))


@pytest.mark.parametrize("shape", SHAPES)
def test_the_readable_terms_equal_the_kernels(shape):
    g = np.random.default_rng(1)
    u = _velocity(shape, 0)
    T = g.uniform(-0.2, 1.2, size=shape)
    cy, cx = ref.centres(u)
    np.testing.assert_array_equal(np.stack([cy, cx], axis=-1), _centres(u))
    np.testing.assert_array_equal(ref.divergence(u), divergence(u))
    for dt in (0.5, 1.0, 3.0):
        np.testing.assert_array_equal(ref.advect_velocity(u, dt), advect_velocity(u, dt))
        np.testing.assert_array_equal(ref.advect_scalar(T, u, dt), advect(T, _centres(u), dt))
    params = FluidParams(kappa_b=0.07, T_amb=0.1, wind=0.3)
    np.testing.assert_array_equal(ref.buoyancy(T, 0.07, 0.1, 0.3), buoyancy(T, params))
    np.testing.assert_array_equal(ref.vorticity_confinement(u, 0.4), vorticity_confinement(u, 0.4))
    np.testing.assert_array_equal(ref.curl(*ref.centres(u)), curl(u))
    # The cooling: our cube root against numpy's, a few units in the last place.
    got, want = cool(T, params, 0.9), ref.cool(T, params.C_r, params.T_amb, 0.9, T.max())
    assert np.all(np.abs(got - want) <= 4 * np.spacing(np.abs(want)))


@pytest.mark.parametrize("noisy", [False, True])
def test_the_readable_source_equals_the_kernel(noisy):
    from fluidnb.fluid import source_mask
    from fluidnb.fluid._solver import _heat

    params = FluidParams(source_radius=0.2, density_rate=0.3, dt=0.7, source_flicker=0.5 * noisy)
    g = np.random.default_rng(4)
    T, d = g.uniform(0, 1.2, size=(17, 12)), g.uniform(size=(17, 12))
    mask = source_mask(T.shape, params)
    noise = None
    if noisy:
        noise = np.zeros(T.shape)
        noise[mask > 0] = np.random.default_rng(5).uniform(-1, 1, size=np.count_nonzero(mask))
    T_ref, d_ref = ref.heat_source(T, d, mask, params, noise)
    assert np.any(T_ref != T)
    assert np.any(d_ref != d)
    _heat(T, d, params, np.random.default_rng(5))  # in place, the same numbers drawn
    np.testing.assert_array_equal(T, T_ref)
    np.testing.assert_array_equal(d, d_ref)


def _centres(u):
    from fluidnb.fluid import centred_velocity

    return centred_velocity(u)


@pytest.mark.parametrize("boundary", BOUNDARIES)
@pytest.mark.parametrize("shape", SHAPES)
def test_the_readable_projection_equals_the_sparse_lu(boundary, shape):
    u = _velocity(shape, 2)
    v, p = ref.project(u, boundary)
    v_lu, p_lu = project(u, boundary, method="lu")
    np.testing.assert_allclose(v, v_lu, rtol=0, atol=1e-11 * np.abs(v_lu).max())
    np.testing.assert_allclose(p, p_lu, rtol=0, atol=1e-11 * np.abs(p_lu).max())
    assert np.abs(ref.divergence(v)).max() < 1e-11


@pytest.mark.parametrize("boundary", BOUNDARIES)
@pytest.mark.parametrize("shape", [(3, 7), (17, 12), (24, 32)])
def test_the_readable_step_equals_the_fast_step(boundary, shape):
    params = FluidParams(boundary=boundary, density_rate=0.2, wind=0.02, source_radius=0.2)
    g = np.random.default_rng(3)
    u, _ = project(_velocity(shape, 4), boundary)
    s = FluidState(u, g.uniform(0, 1, size=shape), g.uniform(0, 1, size=shape))
    fast, slow = s, s
    g_fast, g_slow = np.random.default_rng(9), np.random.default_rng(9)
    for _ in range(5):
        fast = step(fast, params, rng=g_fast)
        slow = ref.step(slow, params, rng=g_slow)
        # The Poisson solves differ by round-off (Thomas vs LAPACK): a few 1e-13.
        for name in ("velocity", "temperature", "density"):
            a, b = getattr(fast, name), getattr(slow, name)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * max(np.abs(b).max(), 1))
    assert fast.frame == slow.frame == 5
    assert np.abs(fast.velocity - s.velocity).max() > 0.1  # the flow did change


def test_the_readable_cooling_follows_the_closed_form():
    T = np.array([[1.0, 0.5, 0.0, -0.2]])
    out = ref.cool(T, 0.01, 0.0, 1.0, T.max())
    assert out[0, 0] == pytest.approx(1.0 / np.cbrt(1.03))
    np.testing.assert_array_equal(out[0, 2:], T[0, 2:])  # at or below ambient: unchanged
