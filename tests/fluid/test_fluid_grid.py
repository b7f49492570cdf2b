"""The staggered grid's operators and the exact pressure projection."""

import numpy as np
import pytest

from fluidnb.fluid import (
    BOUNDARIES,
    FluidParams,
    FluidState,
    centred_velocity,
    curl,
    divergence,
    project,
    step,
)
from fluidnb.fluid._poisson import poisson_solver


def _random_velocity(shape, seed=0):
    return np.random.default_rng(seed).normal(size=(*shape, 2))


@pytest.mark.parametrize("boundary", BOUNDARIES)
@pytest.mark.parametrize("shape", [(2, 2), (5, 7), (32, 48), (128, 128)])
def test_projection_leaves_divergence_at_round_off(boundary, shape):
    u = _random_velocity(shape)
    assert np.abs(divergence(u)).max() > 0.5
    v, p = project(u, boundary)
    assert p.shape == shape
    assert np.abs(divergence(v)).max() < 1e-11


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_projection_is_idempotent_and_orthogonal(boundary):
    u = _random_velocity((24, 20), seed=1)
    v, _ = project(u, boundary)
    w, p = project(v, boundary)
    np.testing.assert_allclose(w, v, atol=1e-11)
    assert np.abs(p - p.mean()).max() < 1e-11
    # u - Pu is a pressure gradient, orthogonal to every divergence-free field.
    u_walls = u.copy()
    u_walls[:, 0, 1] = 0
    if boundary == "closed":
        u_walls[0, :, 0] = 0
    assert abs(np.sum(v * (u_walls - v))) < 1e-9 * np.sum(u_walls**2)


def test_projection_does_not_modify_its_input():
    u = _random_velocity((8, 8))
    before = u.copy()
    project(u)
    np.testing.assert_array_equal(u, before)


@pytest.mark.parametrize("boundary", BOUNDARIES)
def test_walls_carry_no_flow(boundary):
    v, _ = project(_random_velocity((16, 12), seed=2), boundary)
    assert np.all(v[:, 0, 1] == 0)  # left wall (right and bottom are not stored)
    if boundary == "closed":
        assert np.all(v[0, :, 0] == 0)
    else:
        # What leaves through the open top must come in through it too: the other
        # walls are solid and the flow incompressible.
        assert abs(v[0, :, 0].sum()) < 1e-11


def test_divergence_of_a_single_face():
    v = np.zeros((3, 4, 2))
    v[2, 1, 0] = 2.0  # downward through the top face of cell (2, 1)
    d = divergence(v)
    expected = np.zeros((3, 4))
    expected[1, 1] = 2.0
    expected[2, 1] = -2.0
    np.testing.assert_array_equal(d, expected)


def test_curl_of_rigid_rotation_and_of_a_gradient():
    yy, xx = np.mgrid[0:16, 0:16].astype(float)
    v = np.zeros((16, 16, 2))
    omega = 0.05
    v[..., 0] = omega * (xx - 7.5)  # dy component on top faces (x unchanged)
    v[..., 1] = -omega * (yy - 7.5)
    w = curl(v)
    np.testing.assert_allclose(w[3:-3, 3:-3], 2 * omega, atol=1e-12)
    # A uniform flow has no vorticity.
    u = np.zeros((10, 10, 2))
    u[1:, :, 0] = -1.0
    assert np.abs(curl(u)[2:-2, 2:-2]).max() == 0


def test_centred_velocity_averages_faces():
    v = np.zeros((3, 3, 2))
    v[1, 1, 0] = -1.0
    v[2, 2, 1] = 4.0
    c = centred_velocity(v)
    assert c[0, 1, 0] == -0.5
    assert c[1, 1, 0] == -0.5
    assert c[2, 1, 1] == 2.0
    assert c[2, 2, 1] == 2.0
    assert np.count_nonzero(c) == 4


def test_solver_set_up_is_built_once_per_shape_and_boundary():
    poisson_solver.cache_clear()
    params = FluidParams(source_flicker=0)
    s = FluidState.zeros((20, 30), params)
    for _ in range(5):
        s = step(s, params)
    info = poisson_solver.cache_info()
    assert info.misses == 1
    assert info.hits == 4
    fast = poisson_solver((20, 30), "open_top", "fast")
    assert fast is poisson_solver((20, 30), "open_top", "fast")
    assert poisson_solver.cache_info().misses == 1
    project(np.zeros((20, 30, 2)), "closed")
    project(np.zeros((20, 30, 2)), "closed", method="lu")
    assert poisson_solver.cache_info().misses == 3


SHAPES_FAST = [(2, 2), (2, 9), (9, 2), (7, 5), (16, 16), (33, 20), (64, 96), (128, 128)]


@pytest.mark.parametrize("boundary", BOUNDARIES)
@pytest.mark.parametrize("shape", SHAPES_FAST)
def test_fast_projection_equals_the_sparse_lu(boundary, shape):
    u = _random_velocity(shape, seed=sum(shape))
    v_fast, p_fast = project(u, boundary)
    v_lu, p_lu = project(u, boundary, method="lu")
    assert np.abs(v_fast - v_lu).max() <= 1e-10 * np.abs(v_lu).max()
    # The same pressure too (a closed box's constant fixed the same way: p[0, 0] = 0).
    assert np.abs(p_fast - p_lu).max() <= 1e-10 * np.abs(p_lu).max()
    assert np.abs(divergence(v_fast)).max() < 1e-11
    if boundary == "closed":
        assert p_fast[0, 0] == 0.0


def test_fast_projection_of_a_single_row_or_column():
    for shape in [(1, 6), (6, 1)]:
        for boundary in BOUNDARIES:
            u = _random_velocity(shape, seed=3)
            v_fast, _ = project(u, boundary)
            v_lu, _ = project(u, boundary, method="lu")
            np.testing.assert_allclose(v_fast, v_lu, rtol=0, atol=1e-12)
            assert np.abs(divergence(v_fast)).max() < 1e-12


def test_bad_inputs_name_the_parameter():
    with pytest.raises(ValueError, match="velocity"):
        divergence(np.zeros((4, 4)))
    with pytest.raises(ValueError, match="velocity"):
        project(np.full((4, 4, 2), np.nan))
    with pytest.raises(ValueError, match="boundary"):
        project(np.zeros((4, 4, 2)), "periodic")
    with pytest.raises(ValueError, match="method"):
        project(np.zeros((4, 4, 2)), method="cg")
    with pytest.raises(ValueError, match="velocity"):
        curl(np.zeros((4, 4, 3)))


def test_advect_velocity_identities():
    from fluidnb.fluid import advect_velocity

    assert np.array_equal(advect_velocity(np.zeros((6, 7, 2))), np.zeros((6, 7, 2)))
    v = np.zeros((6, 7, 2))
    v[..., 1] = 0.5
    v[:, 0, 1] = 0.0  # the left wall
    out = advect_velocity(v, 1.0)
    # A uniform flow carries itself unchanged away from the wall it enters from.
    np.testing.assert_array_equal(out[:, 2:, 1], 0.5)
    np.testing.assert_array_equal(out[..., 0], 0.0)
    with pytest.raises(ValueError, match="dt"):
        advect_velocity(v, np.nan)
