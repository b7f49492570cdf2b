"""The compiled kernels of fluidnb.fluid against the numpy formulas they replaced.

The references below are the solver's earlier pure-numpy implementation, kept here
verbatim (in substance) as the specification of each kernel: same arithmetic, same
order, so the results must agree to the last bit -- except the confinement (sqrt
instead of hypot) and the cooling (x*x*x instead of numpy's x**3, and our own inverse
cube root instead of the C library's), which may differ by round-off, bounded here in
units in the last place (the C library's last bit differs between CPUs). The readable
version a student reads is fluidnb.fluid._reference, checked against the kernels in
test_fluid_reference.py.
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
from fluidnb.fluid._forces import _cooling_rate, _push
from fluidnb.fluid._poisson import poisson_solver
from fluidnb.fluid._solver import _advected

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


def _orders(w):
    """The column orders the divergence and gradient kernels are run with."""
    return {"natural": np.arange(w, dtype=np.uint64), "fft": poisson_solver((2, w), "closed").pos}


def _unpadded(ay, ax, shape):
    h, w = shape
    return np.stack([ay[:h], ax[:, :w]], axis=-1)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize(("order", "parts"), [("natural", 1), ("fft", 1), ("fft", 3)])
def test_forces_and_divergence_add_dt_times_the_force_and_divide(shape, closed, order, parts):
    g = np.random.default_rng(6)
    v, t = _velocity(shape, 7), g.uniform(size=shape)
    dt, params = 0.7, FluidParams(kappa_b=0.05, epsilon=0.3, wind=0.2)
    ay, ax = _advected(v, dt)
    fy, fx = _push(ay, ax, shape, params.epsilon)
    by, bx, div = np.empty(shape), np.empty(shape), np.zeros(shape)
    pos = _orders(shape[1])[order]
    K.forces_and_divergence(ay, ax, t, fy, fx, dt, 0.05, 0.0, 0.2, closed, pos, parts, by, bx, div)
    a = _advect_velocity(v, dt)
    np.testing.assert_array_equal(a, _unpadded(ay, ax, shape))
    ref = a + dt * (buoyancy(t, params) + vorticity_confinement(a, params.epsilon))
    ref[:, 0, 1] = 0.0  # the walls, as the projection sets them
    if closed:
        ref[0, :, 0] = 0.0
    np.testing.assert_array_equal(np.stack([by, bx], axis=-1), ref)
    np.testing.assert_array_equal(div[:, pos], _divergence(ref))
    # The push is the confinement's, at the centres; against the numpy formula.
    f = np.empty((*shape, 2))
    K.face_forces(np.zeros(shape), fy, fx, 0.0, 0.0, 0.0, f)
    if min(shape) >= 2:
        np.testing.assert_allclose(f, _confinement(_centres(a), 0.3), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("open_top", [True, False])
@pytest.mark.parametrize(("order", "parts"), [("natural", 1), ("fft", 1), ("fft", 3)])
def test_gradient_and_scalars_project_then_carry_both_fields(shape, open_top, order, parts):
    g = np.random.default_rng(2)
    b = _velocity(shape, 3)
    b[:, 0, 1] = 0.0
    if not open_top:
        b[0, :, 0] = 0.0
    p, p0 = g.normal(size=shape), 0.3
    pos = _orders(shape[1])[order]
    stored = np.empty(shape)
    stored[:, pos] = p  # as the pressure solve leaves it
    t, d = g.uniform(size=shape), g.uniform(size=shape)
    out = [np.empty(shape) for _ in range(4)]
    v = np.empty((*shape, 2))
    by, bx = np.ascontiguousarray(b[..., 0]), np.ascontiguousarray(b[..., 1])
    t_max = K.gradient_and_scalars(
        by, bx, stored, pos, open_top, p0, t, d, 0.8, parts, *out[:2], v, *out[2:]
    )
    # The gradient of p - p0, as the projection subtracts it (p = 0 above an open top).
    q = p - p0
    ref = b.copy()
    ref[1:, :, 0] -= q[1:] - q[:-1]
    if open_top:
        ref[0, :, 0] -= q[0]
    ref[:, 1:, 1] -= q[:, 1:] - q[:, :-1]
    np.testing.assert_array_equal(np.stack(out[:2], axis=-1), ref)
    np.testing.assert_array_equal(v, ref)
    carried = advect(np.stack([t, d], axis=-1), _centres(ref), 0.8)
    np.testing.assert_array_equal(out[2], carried[..., 0])
    np.testing.assert_array_equal(out[3], carried[..., 1])
    assert t_max == out[2].max()
    # The plain subtraction kernel (of project()) does the same.
    K.subtract_gradient(by, bx, stored, pos, open_top, p0, v)
    np.testing.assert_array_equal(v, ref)


@pytest.mark.parametrize("shape", SHAPES)
def test_cooling_equals_the_numpy_formula_to_round_off(shape):
    t = np.random.default_rng(8).uniform(-0.2, 1.5, size=shape)
    got = cool(t, FluidParams(C_r=0.3, T_amb=0.1), 0.9)
    assert _ulps(got, _cool(t, 0.3, 0.1, 0.9)).max() <= 4
    np.testing.assert_array_equal(got[t <= 0.1], t[t <= 0.1])
    # The step cools in place, the same way.
    out_t = t.copy()
    span = t.max() - 0.1
    K.cool(out_t, 0.1, span, *_cooling_rate(0.3, 0.9, span), out_t)
    np.testing.assert_array_equal(out_t, got)


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


def _ulps(got, ref):
    """|got - ref| in units in the last place of ref."""
    got, ref = np.asarray(got, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    return np.abs(got - ref) / np.spacing(np.abs(ref))


def test_the_inverse_cube_root_of_the_cooling_is_correct_to_a_few_units_in_the_last_place():
    from numba import njit

    inv_cbrt = njit(lambda y: K._inv_cbrt(y))
    y = np.concatenate([np.linspace(1.0, 2.0, 20001), [1.0 + 1e-17, np.nextafter(2.0, 1.0)]])
    got = np.array([inv_cbrt(v) for v in y])
    assert got[0] == 1.0
    # Against the C library's cube root: a bound, not bit equality. The reference
    # 1 / cbrt(y) is itself rounded twice (cbrt within about one unit of the truth,
    # differently on every CPU, then the division's half unit), so it may stand up
    # to ~2 units from the truth on the other side of ours: 4 units apart at most
    # (measured: 3 on one CPU, 4 on another).
    assert _ulps(got, 1.0 / np.cbrt(y)).max() <= 4
    if np.finfo(np.longdouble).nmant >= 63:  # x86's 80-bit long double: near the truth
        exact = np.array([np.longdouble(v) ** (-np.longdouble(1) / 3) for v in y])
        assert _ulps(got, exact).max() <= 1.5  # measured: 1.04


@pytest.mark.parametrize("k", [0.15, 1.0, 7.5, 3e4])
def test_the_cooled_value_follows_the_closed_form_within_a_few_ulps(k):
    # Beyond k e^3 = 1 the kernel takes the cube root of 1 + 1/(k e^3) instead.
    from numba import njit

    cooled = njit(lambda x, span, k, root: K._cooled(x, 0.2, span, k, root))
    span = 1.3
    x = 0.2 + span * np.linspace(-0.1, 1.0, 2001)
    got = np.array([cooled(v, span, *_cooling_rate(k * span / 3.0, 1.0, span)) for v in x])
    e = (x - 0.2) / span
    ref = np.where(e > 0, 0.2 + span * (e / np.cbrt(1.0 + k * e**3)), x)
    assert _ulps(got, ref).max() <= 4
    np.testing.assert_array_equal(got[e <= 0], x[e <= 0])  # at or below ambient: as is
