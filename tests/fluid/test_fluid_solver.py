"""One step of the solver: the physics invariants of the spec's checks."""

import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fluidnb.fields import advect
from fluidnb.fluid import (
    FluidParams,
    FluidState,
    buoyancy,
    cool,
    curl,
    divergence,
    project,
    source_mask,
    step,
    vorticity_confinement,
)
from fluidnb.fluid._threads import fixed

QUIET = {"kappa_b": 0.0, "C_r": 0.0, "source_radius": 0.0, "density_rate": 0.0}


def _random_state(shape, seed=0, *, divergence_free=True, t_scale=1.0):
    g = np.random.default_rng(seed)
    v = g.normal(size=(*shape, 2))
    if divergence_free:
        v, _ = project(v)
    return FluidState(v, t_scale * g.random(shape), g.random(shape))


def test_step_keeps_the_velocity_divergence_free():
    params = FluidParams()
    s = FluidState.zeros((48, 40), params)
    g = np.random.default_rng(0)
    for _ in range(30):
        s = step(s, params, rng=g)
        assert np.abs(divergence(s.velocity)).max() < 1e-10
    assert np.abs(s.velocity).max() > 0.1


def test_advection_of_a_constant_field_stays_constant():
    s = _random_state((32, 32), seed=3)
    const = np.full((32, 32), 0.7)
    out = advect(const, s.centred_velocity, 2.5)
    np.testing.assert_array_equal(out, const)
    # Through the whole step: uniform temperature and density, no forces.
    params = FluidParams(epsilon=0.0, **QUIET)
    t = FluidState(s.velocity, np.full((32, 32), 0.3), np.full((32, 32), 0.2))
    t1 = step(t, params)
    np.testing.assert_array_equal(t1.temperature, t.temperature)
    np.testing.assert_array_equal(t1.density, t.density)


@pytest.mark.parametrize("epsilon", [0.0, 0.5])
def test_zero_velocity_leaves_every_field_unchanged(epsilon):
    g = np.random.default_rng(4)
    s = FluidState(np.zeros((16, 24, 2)), g.random((16, 24)), g.random((16, 24)), frame=3)
    s1 = step(s, FluidParams(epsilon=epsilon, **QUIET))
    np.testing.assert_array_equal(s1.velocity, s.velocity)
    np.testing.assert_array_equal(s1.temperature, s.temperature)
    np.testing.assert_array_equal(s1.density, s.density)
    assert s1.frame == 4


def test_still_air_at_ambient_stays_still_with_every_force_on():
    params = FluidParams(source_radius=0.0, T_amb=0.25)
    s = FluidState.zeros((16, 16), params)
    s1 = step(s, params)
    assert s1 == FluidState(s.velocity, s.temperature, s.density, frame=1)


def _cooling_reference(t0, c_r, t_amb, duration):
    """Fine integration of dT/dt = -C_r ((T - T_amb) / (T_max - T_amb))^4."""

    def rhs(_, t):
        x = np.clip((t - t_amb) / (t.max() - t_amb), 0, None)
        return -c_r * x**4

    sol = solve_ivp(rhs, (0, duration), t0, rtol=1e-10, atol=1e-12, method="DOP853")
    return sol.y[:, -1]


@pytest.mark.parametrize("t_amb", [0.0, 0.3])
def test_with_zero_velocity_the_temperature_follows_the_cooling_ode(t_amb):
    shape = (6, 8)
    t0 = t_amb + np.random.default_rng(5).random(shape)
    duration = 40.0
    reference = _cooling_reference(t0.ravel(), 0.01, t_amb, duration).reshape(shape)
    errors = []
    for dt in (1.0, 0.25):
        params = FluidParams(dt=dt, epsilon=0.0, T_amb=t_amb, **{**QUIET, "C_r": 0.01})
        s = FluidState(np.zeros((*shape, 2)), t0, np.zeros(shape))
        for _ in range(round(duration / dt)):
            s = step(s, params)
        assert np.all(s.velocity == 0)
        errors.append(np.abs(s.temperature - reference).max())
    # The hottest cell cools at C_r per frame: 0.4 over 40 frames.
    assert np.isclose(reference.max(), t0.max() - 0.4, atol=1e-6)
    # T_max is measured once per step (as in the paper) and held over it: the
    # error is first order in dt, about 1 % of the temperature span at dt = 1.
    assert errors[0] < 0.015
    assert errors[1] < errors[0] / 3


def test_cooling_never_goes_below_ambient():
    t = np.array([[1.0, 0.999, 0.2, 0.0]])
    out = cool(t, FluidParams(C_r=50.0))
    assert np.all(out >= 0.0)
    assert np.all(np.diff(out[0]) <= 0)
    np.testing.assert_array_equal(cool(t, FluidParams(C_r=0.0)), t)


def _hot_blob(shape, centre, radius, t_amb=0.0):
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    r = np.hypot(yy - centre[0], xx - centre[1])
    return t_amb + np.clip(radius - r, 0, 1)


@pytest.mark.parametrize("boundary", ["closed", "open_top"])
def test_a_hot_blob_rises(boundary):
    shape = (64, 48)
    t0 = _hot_blob(shape, (40, 23.5), 6)
    params = FluidParams(kappa_b=0.1, epsilon=0.0, C_r=0.0, source_radius=0.0, boundary=boundary)
    s = FluidState(np.zeros((*shape, 2)), t0, np.zeros(shape))
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]

    def centre(t):
        return (t * yy).sum() / t.sum(), (t * xx).sum() / t.sum()

    y0, x0 = centre(s.temperature)
    for _ in range(20):
        s = step(s, params)
    y1, x1 = centre(s.temperature)
    assert y1 < y0 - 3  # up is dy < 0
    assert abs(x1 - x0) < 1e-6  # the set-up is mirror-symmetric
    assert s.velocity[..., 0].min() < -0.5


def test_buoyancy_points_up_and_scales_with_excess_temperature():
    t = np.full((4, 4), 0.5)
    f = buoyancy(t, FluidParams(kappa_b=0.2, T_amb=0.25))
    np.testing.assert_allclose(f[..., 0], -0.05)
    assert np.all(f[..., 1] == 0)
    g = buoyancy(t, FluidParams(kappa_b=0.2, T_amb=0.25, wind=0.1))
    np.testing.assert_allclose(g[..., 1], 0.025)


def _enstrophy(s):
    return float(np.sum(curl(s.velocity) ** 2))


def test_vorticity_confinement_adds_enstrophy():
    base = FluidParams(epsilon=0.0)
    shape = (64, 64)
    runs = {}
    for eps in (0.0, 0.4):
        params = base.replace(epsilon=eps)
        s = FluidState.zeros(shape, params)
        g = np.random.default_rng(6)
        for _ in range(40):
            s = step(s, params, rng=g)
        runs[eps] = _enstrophy(s)
    assert runs[0.4] > 1.2 * runs[0.0] > 0


def test_vorticity_confinement_force_spins_a_vortex_up():
    yy, xx = np.mgrid[0:32, 0:32] - 15.5
    swirl = np.exp(-(yy**2 + xx**2) / 20)
    v = np.zeros((32, 32, 2))
    v[..., 0] = 0.3 * xx * swirl
    v[..., 1] = -0.3 * yy * swirl
    v, _ = project(v, "closed")
    f = vorticity_confinement(v, 0.5)
    # The force turns with the vortex: it does positive work on it.
    assert np.sum(f * v) > 0
    # and it is zero where the flow has no vorticity gradient to follow.
    far = np.hypot(yy, xx) > 14
    assert np.abs(f[far]).max() < 1e-3 * np.abs(f).max()
    assert not vorticity_confinement(v, 0.0).any()


def test_source_heats_its_disc_only():
    params = FluidParams(source_flicker=0.0, kappa_b=0.0, epsilon=0.0, density_rate=0.5)
    s = step(FluidState.zeros((32, 32), params), params)
    m = source_mask((32, 32), params)
    np.testing.assert_array_equal(s.temperature, m * params.source_T)
    np.testing.assert_allclose(s.density, 0.5 * m)
    assert m[29, 16] == 1
    assert m[:20].sum() == 0


def test_same_seed_same_state_and_inputs_untouched():
    params = FluidParams()
    s0 = _random_state((24, 24), seed=7)
    before = [a.copy() for a in (s0.velocity, s0.temperature, s0.density)]

    def two(seed):
        g = np.random.default_rng(seed)
        return step(step(s0, params, rng=g), params, rng=g)

    a, b = two(11), two(11)
    assert a == b
    c = two(12)
    assert not np.array_equal(a.temperature, c.temperature)
    for x, y in zip(before, (s0.velocity, s0.temperature, s0.density)):
        np.testing.assert_array_equal(x, y)


def test_state_is_immutable_and_copies_its_inputs():
    v = np.zeros((4, 5, 2))
    s = FluidState(v, np.zeros((4, 5)), np.zeros((4, 5)))
    v[0, 0, 0] = 1.0
    assert s.velocity[0, 0, 0] == 0
    with pytest.raises(ValueError, match="read-only"):
        s.velocity[0, 0, 0] = 1.0
    with pytest.raises(AttributeError):
        s.frame = 2
    assert s.shape == (4, 5)


def test_float32_state_steps():
    s = _random_state((16, 16), seed=8)
    s32 = FluidState(*(a.astype(np.float32) for a in (s.velocity, s.temperature, s.density)))
    out = step(s32, FluidParams(source_flicker=0))
    assert np.abs(divergence(out.velocity)).max() < 1e-10


def test_bad_inputs_name_the_parameter():
    s = FluidState.zeros((8, 8))
    with pytest.raises(ValueError, match="state"):
        step(np.zeros((8, 8, 2)), FluidParams())
    with pytest.raises(ValueError, match="params"):
        step(s, {"dt": 1})
    with pytest.raises(ValueError, match="temperature"):
        FluidState(np.zeros((8, 8, 2)), np.zeros((8, 9)), np.zeros((8, 8)))
    with pytest.raises(ValueError, match="density"):
        FluidState(np.zeros((8, 8, 2)), np.zeros((8, 8)), np.full((8, 8), np.inf))
    with pytest.raises(ValueError, match="shape"):
        FluidState.zeros((8,))
    with pytest.raises(ValueError, match=r"shape\[0\]"):
        FluidState.zeros((1, 8))
    with pytest.raises(ValueError, match="dt"):
        FluidParams(dt=0)
    with pytest.raises(ValueError, match="source_T"):
        FluidParams(source_T=-1.0)
    with pytest.raises(ValueError, match="boundary"):
        FluidParams(boundary="periodic")
    with pytest.raises(ValueError, match="epsilon"):
        vorticity_confinement(np.zeros((4, 4, 2)), -1)


@pytest.mark.parametrize("epsilon", [0.0, 0.4])
def test_a_symmetric_set_up_stays_mirror_symmetric(epsilon):
    params = FluidParams(epsilon=epsilon, source_flicker=0.0, density_rate=0.2)
    s = FluidState.zeros((40, 32), params)
    for _ in range(15):
        s = step(s, params)
    c = s.centred_velocity
    np.testing.assert_allclose(s.temperature, s.temperature[:, ::-1], atol=1e-9)
    np.testing.assert_allclose(s.density, s.density[:, ::-1], atol=1e-9)
    np.testing.assert_allclose(c[..., 0], c[:, ::-1, 0], atol=1e-9)
    np.testing.assert_allclose(c[..., 1], -c[:, ::-1, 1], atol=1e-9)
    assert s.temperature.max() > 0.5


@pytest.mark.parametrize("boundary", ["closed", "open_top"])
def test_no_flow_through_the_walls_during_a_run(boundary):
    params = FluidParams(boundary=boundary, wind=0.05, density_rate=0.1)
    s = FluidState.zeros((24, 20), params)
    g = np.random.default_rng(9)
    for _ in range(20):
        s = step(s, params, rng=g)
        assert np.all(s.velocity[:, 0, 1] == 0)  # left wall; right and bottom not stored
        if boundary == "closed":
            assert np.all(s.velocity[0, :, 0] == 0)
        else:
            assert abs(s.velocity[0, :, 0].sum()) < 1e-10  # in = out through the top
    assert np.abs(s.velocity).max() > 0.1


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
@pytest.mark.parametrize("boundary", ["open_top", "closed"])
@pytest.mark.parametrize("shape", [(37, 29), (70, 66)])
def test_one_and_two_threads_give_the_same_run_bit_for_bit(boundary, shape):
    # The parallel kernels split the grid by rows (the Poisson solve by FFT bins) and
    # each thread writes only its own (the maximum of the temperature is taken per
    # row, then over rows); the transforms run on as many workers: nothing depends on
    # how the work is shared out. fixed() overrides the thread choice (and the rule
    # that a small grid runs on one thread).
    params = FluidParams(boundary=boundary, density_rate=0.1, wind=0.02)
    runs = []
    for threads in (1, 2):
        with fixed(threads):
            s, g = FluidState.zeros(shape, params), np.random.default_rng(5)
            for _ in range(25):
                s = step(s, params, rng=g)
        runs.append(s)
    assert np.abs(runs[0].velocity).max() > 0.1
    assert runs[0] == runs[1]


def test_step_refuses_an_int_rng_which_would_replay_the_same_noise():
    params = FluidParams(source_flicker=0.5)
    s = FluidState.zeros((16, 16), params)
    with pytest.raises(ValueError, match="rng must be a numpy Generator"):
        step(s, params, rng=3)
    # One generator carried through the steps: the source differs from step to step.
    g = np.random.default_rng(3)
    a = step(s, params, rng=g)
    b = step(s, params, rng=g)
    assert not np.array_equal(a.temperature, b.temperature)
