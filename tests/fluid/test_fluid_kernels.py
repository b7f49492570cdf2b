"""The compiled kernels of fluidnb.fluid against the numpy formulas they replaced.

The references below are the solver's earlier pure-numpy implementation, kept here
verbatim (in substance) as the specification of each kernel: same arithmetic, same
order, so the results must agree to the last bit -- except the confinement (sqrt
instead of hypot) and the cooling (x*x*x instead of numpy's x**3, and a Halley cube
root), which may differ by round-off. The readable version a student reads is
fluidnb.fluid._reference, checked against the kernels in test_fluid_reference.py.
"""

import numpy as np
import pytest

from fluidnb.fields import advect
from fluidnb.fluid import (
    FluidParams,
    advect_velocity,
    buoyancy,
    centred_velocity,
    cool,
    curl,
    divergence,
    project,
    vorticity_confinement,
)
from fluidnb.fluid import _kernels as K

SHAPES = [(2, 2), (3, 7), (17, 12), (32, 48)]

# ------------------------------------------------------------- numpy references


def _centres(v):
    out = np.empty_like(v)
    uy, ux = v[..., 0], v[..., 1]
    np.add(uy[:-1], uy[1:], out=out[:-1, :, 0])
    out[-1, :, 0] = uy[-1]
    np.add(ux[:, :-1], ux[:, 1:], out=out[:, :-1, 1])
    out[:, -1, 1] = ux[:, -1]
    out *= 0.5
    return out


def _to_y_faces(c):
    f = np.empty_like(c)
    np.add(c[:-1], c[1:], out=f[1:])
    f[1:] *= 0.5
    f[0] = c[0]
    return f


def _to_x_faces(c):
    f = np.empty_like(c)
    np.add(c[:, :-1], c[:, 1:], out=f[:, 1:])
    f[:, 1:] *= 0.5
    f[:, 0] = c[:, 0]
    return f


def _divergence(v):
    uy, ux = v[..., 0], v[..., 1]
    div = -uy - ux
    div[:-1] += uy[1:]
    div[:, :-1] += ux[:, 1:]
    return div


def _curl(c):
    return np.gradient(c[..., 0], axis=1) - np.gradient(c[..., 1], axis=0)


def _advect_velocity(v, dt):
    h, w = v.shape[:2]
    c = _centres(v)
    new = np.empty_like(v)
    q = np.zeros((h + 1, w))
    q[:h] = v[..., 0]
    vel = np.empty((h + 1, w, 2))
    vel[:h, :, 0] = v[..., 0]
    vel[h, :, 0] = 0.0
    vel[:h, :, 1] = _to_y_faces(c[..., 1])
    vel[h, :, 1] = c[-1, :, 1]
    new[..., 0] = advect(q, vel, dt)[:h]
    q = np.zeros((h, w + 1))
    q[:, :w] = v[..., 1]
    vel = np.empty((h, w + 1, 2))
    vel[:, :w, 0] = _to_x_faces(c[..., 0])
    vel[:, w, 0] = c[:, -1, 0]
    vel[:, :w, 1] = v[..., 1]
    vel[:, w, 1] = 0.0
    new[..., 1] = advect(q, vel, dt)[:, :w]
    return new


def _buoyancy(t, kappa_b, t_amb, wind):
    excess = t - t_amb
    f = np.empty((*t.shape, 2))
    f[..., 0] = _to_y_faces(excess)
    f[..., 0] *= -kappa_b
    f[..., 1] = _to_x_faces(excess) * wind if wind else 0.0
    return f


def _confinement(c, epsilon):
    w = _curl(c)
    a = np.abs(w)
    ny = np.gradient(a, axis=0)
    nx = np.gradient(a, axis=1)
    norm = np.hypot(ny, nx)
    norm[norm < 1e-12] = np.inf
    scale = epsilon * w / norm
    f = np.empty(c.shape)
    f[..., 0] = _to_y_faces(-nx * scale)
    f[..., 1] = _to_x_faces(ny * scale)
    return f


def _cool(t, c_r, t_amb, dt):
    span = t.max() - t_amb
    hot = t > t_amb
    x = (t[hot] - t_amb) / span
    x /= np.cbrt(1.0 + (3.0 * c_r * dt / span) * x**3)
    out = t.copy()
    out[hot] = t_amb + span * x
    return out


def _velocity(shape, seed):
    return np.random.default_rng(seed).normal(scale=1.5, size=(*shape, 2))


# ------------------------------------------------------------------------ tests


@pytest.mark.parametrize("shape", SHAPES)
def test_grid_operators_equal_the_numpy_formulas(shape):
    v = _velocity(shape, 0)
    np.testing.assert_array_equal(centred_velocity(v), _centres(v))
    np.testing.assert_array_equal(divergence(v), _divergence(v))
    np.testing.assert_array_equal(curl(v), _curl(_centres(v)))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("dt", [0.5, 1.0, 3.0])
def test_velocity_advection_equals_the_numpy_formula(shape, dt):
    v = _velocity(shape, 1)
    np.testing.assert_array_equal(advect_velocity(v, dt), _advect_velocity(v, dt))


@pytest.mark.parametrize("shape", SHAPES)
def test_scalar_advection_equals_fields_advect_and_measures_the_maximum(shape):
    g = np.random.default_rng(2)
    v = _velocity(shape, 3)
    t, d = g.uniform(size=shape), g.uniform(size=shape)
    t_out, d_out = np.empty(shape), np.empty(shape)
    t_max = K.advect_scalars(t, d, v, 0.8, np.empty(v.shape), t_out, d_out)
    ref = advect(np.stack([t, d], axis=-1), _centres(v), 0.8)
    np.testing.assert_array_equal(t_out, ref[..., 0])
    np.testing.assert_array_equal(d_out, ref[..., 1])
    assert t_max == t_out.max()


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("wind", [0.0, 0.3])
def test_buoyancy_equals_the_numpy_formula(shape, wind):
    t = np.random.default_rng(4).uniform(-0.5, 1.5, size=shape)
    params = FluidParams(kappa_b=0.07, T_amb=0.1, wind=wind)
    np.testing.assert_array_equal(buoyancy(t, params), _buoyancy(t, 0.07, 0.1, wind))


@pytest.mark.parametrize("shape", SHAPES)
def test_confinement_equals_the_numpy_formula_to_round_off(shape):
    v = _velocity(shape, 5)
    ref = _confinement(_centres(v), 0.4)
    np.testing.assert_allclose(vorticity_confinement(v, 0.4), ref, rtol=1e-13, atol=1e-15)


def test_forces_accumulate_dt_times_the_force():
    g = np.random.default_rng(6)
    v, t = _velocity((20, 24), 7), g.uniform(size=(20, 24))
    params = FluidParams(kappa_b=0.05, epsilon=0.3, wind=0.2)
    f = np.empty(v.shape)
    K.forces(v, t, 0.05, 0.0, 0.2, 0.3, 1.0, True, f, False)
    ref = _buoyancy(t, 0.05, 0.0, 0.2) + _confinement(_centres(v), 0.3)
    np.testing.assert_allclose(f, ref, rtol=1e-13, atol=1e-15)
    out = v.copy()
    K.forces(v, t, params.kappa_b, params.T_amb, params.wind, params.epsilon, 0.7, True, out, True)
    np.testing.assert_allclose(out, v + 0.7 * ref, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("shape", SHAPES)
def test_cooling_equals_the_numpy_formula_to_round_off(shape):
    t = np.random.default_rng(8).uniform(-0.2, 1.5, size=shape)
    got = cool(t, FluidParams(C_r=0.3, T_amb=0.1), 0.9)
    np.testing.assert_allclose(got, _cool(t, 0.3, 0.1, 0.9), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(got[t <= 0.1], t[t <= 0.1])


@pytest.mark.parametrize("boundary", ["open_top", "closed"])
def test_projection_subtracts_the_pressure_gradient_as_before(boundary):
    v = _velocity((12, 9), 9)
    u, p = project(v, boundary)
    ref = v.copy()
    ref[:, 0, 1] = 0.0
    if boundary == "closed":
        ref[0, :, 0] = 0.0
    ref[1:, :, 0] -= p[1:] - p[:-1]
    if boundary == "open_top":
        ref[0, :, 0] -= p[0]
    ref[:, 1:, 1] -= p[:, 1:] - p[:, :-1]
    np.testing.assert_array_equal(u, ref)


def test_the_cube_root_of_the_cooling_is_correct_to_a_few_units_in_the_last_place():
    from numba import njit

    cbrt = njit(lambda y: K._cbrt(y))
    y = np.concatenate([np.linspace(1.0, 2.0, 20001), [1.0 + 1e-17, np.nextafter(2.0, 3.0), 7.5]])
    got = np.array([cbrt(v) for v in y])
    ref = np.cbrt(y)
    assert np.all(np.abs(got - ref) <= 4 * np.spacing(ref))  # measured: at most 3
    assert got[0] == 1.0
    np.testing.assert_array_equal(got[y > 2.0], ref[y > 2.0])
