"""The answers the lessons' checks accept are what the library measures (issue 40).

A choice question's right option is fixed in its lesson module; where the option states
something measurable ("taller", "the enstrophy grows", "the box warms from the top"),
these tests measure it the way the notebook's code route does, at the notebook's quick
sizes, so an option cannot stay "right" after the library changes underneath it.
"""

import numpy as np
import pytest

from fluidnb.fluid import FluidParams, curl, divergence, flame_preset, simulate, source_mask
from fluidnb.fluid import _reference as ref
from fluidnb.lessons import fluid as lesson

N, FRAMES = 48, 40  # 04_fluid_solver.ipynb's quick sizes (test_lesson_numbers reads them)
BASE = flame_preset().params


def flame_height(sim, p):
    """The notebook's measure: where gas above 20 % of the source's excess reaches."""
    hot = sim.temperature[len(sim.temperature) // 2 :] > p.T_amb + 0.2 * (p.source_T - p.T_amb)
    reach = [(hot.shape[1] - np.argmax(m.any(axis=1))) / hot.shape[1] for m in hot if m.any()]
    return float(np.mean(reach)) if reach else 0.0


def height(**changes):
    p = BASE.replace(**changes)
    return flame_height(simulate(p, FRAMES, shape=(N, N), seed=1), p)


def right(q, part):
    return next(iter(q.checker.checkers[part].answer))


def test_ex1_more_buoyancy_is_taller_and_c_r_hardly_brings_it_back():
    assert right(lesson.ex1, "double") == "taller"
    assert right(lesson.ex1, "keep") == "hardly"
    k = BASE.kappa_b
    half, one, double = height(kappa_b=k / 2), height(), height(kappa_b=2 * k)
    assert half < one < double
    # Eight times C_r closes less than half of the gap doubling kappa_b opened.
    assert double - height(kappa_b=2 * k, C_r=8 * BASE.C_r) < 0.5 * (double - one)


def test_ex2_the_enstrophy_grows_with_epsilon():
    assert right(lesson.ex2, "trend") == "grows"
    ens = [
        np.mean([np.sum(curl(v) ** 2) for v in sim.velocity[FRAMES // 2 :]])
        for sim in (
            simulate(BASE.replace(epsilon=e), FRAMES, shape=(N, N), seed=1)
            for e in (0.0, 0.2, 0.8, 1.5)
        )
    ]
    assert np.all(np.diff(ens) > 0), ens


def test_ex3_without_the_projection_the_divergence_jumps_to_order_one_and_stays():
    assert right(lesson.ex3, "divergence") == "grows"
    p = FluidParams(source_flicker=0.0)
    state = simulate(p, 25, shape=(N, N), seed=0)
    u, T = (np.asarray(a[-1], dtype=float) for a in (state.velocity, state.temperature))
    assert np.abs(divergence(u)).max() < 1e-5  # stored as float32: round-off of float32
    for _ in range(10):
        u = ref.advect_velocity(u, p.dt)
        u = u + p.dt * (
            ref.buoyancy(T, p.kappa_b, p.T_amb) + ref.vorticity_confinement(u, p.epsilon)
        )
        T = ref.cool(ref.advect_scalar(T, u, p.dt), p.C_r, p.T_amb, p.dt, T.max())
        T, _ = ref.heat_source(T, np.zeros_like(T), source_mask(T.shape, p), p)
        assert np.abs(divergence(u)).max() > 0.3


def test_ex4_a_closed_box_warms_from_the_top():
    assert right(lesson.ex4, "where") == "a"
    n = 3 * FRAMES
    top = slice(0, N // 4)
    opened = simulate(BASE, n, shape=(N, N), seed=1).temperature[-1][top].mean()
    closed = simulate(BASE.replace(boundary="closed"), n, shape=(N, N), seed=1)
    assert closed.temperature[-1][top].mean() > 1.05 * opened
    # Warmer at the top than in the middle band: it fills from the lid down.
    T = closed.temperature[-1]
    assert T[top].mean() > T[N // 4 : N // 2].mean()


def test_ex5_the_hottest_cell_drops_0_0192_not_c_r():
    assert lesson.ex5.checker.checkers["drop"].expected == pytest.approx(1 - 1.06 ** (-1 / 3))
    assert not lesson.ex5.check(drop=0.02, why="a")


@pytest.mark.parametrize("flicker", [BASE.source_flicker, 0.0])
def test_ex6_four_substeps_make_a_taller_hotter_flame_through_the_source(flicker):
    assert right(lesson.ex6, "why") == "source"
    p = BASE.replace(source_flicker=flicker)
    disc = source_mask((N, N), p) >= 1
    one = simulate(p, FRAMES, shape=(N, N), seed=1)
    four = simulate(p, FRAMES, shape=(N, N), seed=1, substeps=4)
    assert flame_height(four, p) > flame_height(one, p)
    heat = [s.temperature[FRAMES // 2 :].sum(axis=(1, 2)).mean() for s in (one, four)]
    assert heat[1] > 1.1 * heat[0]  # more heat a frame: the source refills each substep
    if flicker:  # and keeps the hottest of four random targets
        src = [np.mean([t[disc].mean() for t in s.temperature[FRAMES // 2 :]]) for s in (one, four)]
        assert src[1] > src[0] + 0.05


def test_q9_the_same_seed_gives_the_same_clip():
    a = simulate(BASE, 10, shape=(24, 24), seed=5)
    b = simulate(BASE, 10, shape=(24, 24), seed=a.seed)
    assert np.array_equal(a.temperature, b.temperature)
    assert lesson.q9.check(equal=True, why="a")


# ------------------------------------------------------------------ 03_frost


def test_frost_ex1_an_off_centre_start_keeps_its_mirror_and_loses_the_turn():
    from fluidnb.frost import FrostParams, HexLattice, grow
    from fluidnb.lessons import frost

    hexa = HexLattice.hexagon(11, spacing=1.0)
    ax = hexa.axial[: hexa.n_cells] - hexa.axial[hexa.center_cell()]
    index = {tuple(a): i for i, a in enumerate(ax.tolist())}
    ff = grow(hexa, [index[(5, 0)]], FrostParams(), frames=66).freeze_frame
    turn = np.array([index[(-r, q + r)] for q, r in ax.tolist()])
    mirror = np.array([index[(q + r, -r)] for q, r in ax.tolist()])
    assert not np.array_equal(ff, ff[turn])
    assert np.array_equal(ff, ff[mirror])
    assert frost.ex1.check(rotation=False, mirror=True)


def test_frost_ex2_the_smallest_h_that_converges_lies_in_the_accepted_range():
    from fluidnb.frost import optimise_beta, reference_setup
    from fluidnb.lessons import frost

    lat, starts, p = reference_setup(0.0)

    def converges(h):
        return optimise_beta(
            lat, starts, 130, p, beta0=0.25, seed=0, method="steepest", eta=1e-6, h=h
        ).converged

    lo, hi = frost.ex2.checker.range
    assert not converges(0.002)
    assert converges(0.003)
    assert lo <= 0.003 <= hi
    assert not lo <= 0.002


def test_frost_ex3_the_predicted_eta_converges_in_one_step():
    from fluidnb.frost import grow, optimise_beta, reference_setup
    from fluidnb.lessons import frost

    lat, starts, p = reference_setup(0.0)
    e = [grow(lat, starts, p.replace(beta=b), seed=0).end_frame for b in (0.28, 0.32)]
    eta = 1 / (2 * ((e[1] - e[0]) / 0.04) ** 2)
    assert frost.ex3.check(eta)
    res = optimise_beta(lat, starts, 130, p, beta0=0.25, seed=0, method="steepest", eta=eta, h=0.02)
    assert res.converged
    assert len(res.steps) <= 3  # step 0 plus one or two updates


def test_frost_q11_a_blob_without_a_start_never_ends_and_gamma_cannot_help():
    from fluidnb.frost import FrostParams, HexLattice, estimate_end_frame, gamma_for_target

    yy, xx = np.mgrid[0:120, 0:160]
    region = ((yy - 58) / 36) ** 2 + ((xx - 83) / 58) ** 2 <= 1
    blob = ((yy - 110) / 8.4) ** 2 + ((xx - 80) / 64) ** 2 <= 1
    two = HexLattice.from_mask(region | blob, 6.0)
    starts = [[58, 64], [48, 112]]
    assert "never ends" in str(estimate_end_frame(two, starts, FrostParams()))
    with pytest.raises(ValueError, match="add a start point in every piece"):
        gamma_for_target(two, starts, 72, FrostParams(), seed=0)


# ------------------------------------------------------------------ 05_fire


@pytest.fixture(scope="module")
def fire_setup():
    from fluidnb import data
    from fluidnb.fire import alpha_from_photo, temperature_target

    rgb, matte = data.sample("fire", size=64, return_alpha=True)
    photo = rgb * matte[..., None]
    sim = simulate(flame_preset().params, 24, shape=(64, 64), seed=0)
    target = temperature_target(sim.temperature, alpha_from_photo(photo), cutoff=0.2)[-1]
    return photo, sim, target


def continuity(src, target):
    return (np.abs(np.diff(src, axis=1) - [0, 1]).sum(-1) == 0)[target[:, 1:] > 0.1].mean()


def test_fire_q2_the_plain_temperature_seldom_reaches_the_bright_photo(fire_setup):
    from fluidnb.fire import alpha_from_photo

    photo, sim, _ = fire_setup
    T = sim.temperature[-1]
    plain = (T - T.min()) / (T.max() - T.min())
    a_a = alpha_from_photo(photo)
    share = [(x > 0.7).sum() / (x > 0.01).sum() for x in (plain, a_a)]
    assert share[0] < 0.5 * share[1]


def test_fire_ex1_a_middle_weight_follows_as_well_and_keeps_more_patches(fire_setup):
    from fluidnb.fire import FireParams, synthesize

    photo, _, target = fire_setup
    luma = np.array([0.2126, 0.7152, 0.0722])
    r, c = {}, {}
    for w in (0.2, 0.6, 0.9):
        img, src = synthesize(photo, target, FireParams(weight=w), seed=1)
        r[w] = np.corrcoef(img.reshape(-1, 3) @ luma, target.ravel())[0, 1]
        c[w] = continuity(src, target)
    assert r[0.9] > r[0.2] + 0.05
    assert r[0.9] - r[0.6] < 0.03
    assert c[0.2] > c[0.6] > c[0.9]


def test_fire_ex2_no_overlap_cuts_at_the_keyframes(fire_setup):
    from fluidnb.fire import FireParams, fire

    photo, sim, _ = fire_setup
    p = FireParams(interval=8, output_size=64, overlap=0)
    hard = fire(photo, sim, p, seed=0)
    change = np.abs(np.diff(np.asarray(hard.clip.frames, float), axis=0)).mean(axis=(1, 2, 3))
    at_key = np.diff(np.floor(np.asarray(hard.times) / p.interval)) > 0
    assert change[at_key].mean() > 3 * change[~at_key].mean()


def test_fire_ex4_ex5_random_winners_break_the_patches(fire_setup):
    from fluidnb.fire import FireParams, neighbourhood_error, synthesize

    photo, _, target = fire_setup
    c, err = {}, {}
    for label, p in [
        ("default", FireParams()),
        ("kappa0", FireParams(coherence=0.0)),
        ("n64", FireParams(n_random=64)),
    ]:
        img, src = synthesize(photo, target, p, seed=0)
        c[label], err[label] = (
            continuity(src, target),
            neighbourhood_error(img, src, photo, target, p),
        )
    assert c["kappa0"] < c["default"]
    assert c["n64"] < c["default"]
    assert err["n64"] < err["default"]


# ------------------------------------------------------------------ 07b_videodb_animation


@pytest.fixture(scope="module")
def stream_and_clouds():
    from fluidnb import data
    from fluidnb.videodb import AnimateParams, assign, starter_database

    water = starter_database("water", quick=True)
    smoke = starter_database("smoke", quick=True)
    stream = assign(
        data.sample("stream", size=240),
        data.region("stream", size=240),
        water,
        AnimateParams(candidates=40),
    )
    clouds = assign(
        data.sample("clouds", size=240),
        data.region("clouds", size=240),
        smoke,
        AnimateParams.for_kind("smoke", candidates=40),
    )
    return stream, clouds


def changed(asg, **values):
    return np.mean(asg.resolve(**values).fragments != asg.fragments)


def test_videodb_lambda_matters_little_on_the_clouds_not_on_the_stream(stream_and_clouds):
    from fluidnb.lessons import videodb_animation as lesson

    stream, clouds = stream_and_clouds
    # Quick databases, as CI runs the lesson. With the full ones (measured 2026-11-28)
    # lambda 0.1-10 changed 4 % of the stream's fragments and 9 % of the clouds': the
    # lesson's text and q7's option say both.
    for x in (10, 100, 1000):
        assert changed(clouds, lam=clouds.params.lam * x) < 0.1
        assert changed(stream, lam=stream.params.lam * x) > 0.25
    assert right_part(lesson.q7, "paper") == "b"


def right_part(q, part):
    return next(iter(q.checker.checkers[part].answer))


def test_videodb_q7_sigma_moves_the_map_more_than_lambda(stream_and_clouds):
    stream, _ = stream_and_clouds
    lam = [changed(stream.resolve(lam=0.001), lam=v) for v in (0.01, 0.1, 1, 10)]
    sig = [changed(stream.resolve(sigma=1), sigma=v) for v in (10, 100, 1000)]
    assert max(sig) > max(lam)


def test_videodb_ex1_looks_alone_lose_the_coherence(stream_and_clouds):
    stream, _ = stream_and_clouds
    assert stream.resolve(lam=0).motion_coherence() < stream.motion_coherence() - 0.3


def test_videodb_ex3_the_coherence_falls_within_the_accepted_decades(stream_and_clouds):
    from fluidnb.lessons import videodb_animation as lesson

    stream, _ = stream_and_clouds
    crossover = np.median(stream.tables.dc) / np.median(stream.tables.rest)
    falls = [
        np.log10(s / crossover)
        for s in 10.0 ** np.arange(0, 7)
        if stream.resolve(sigma=s).motion_coherence() < 0.6
    ]
    assert lesson.ex3.check(falls[0])


def test_videodb_ex5_solve_is_never_worse_than_alpha_expansion():
    from fluidnb.lessons.videodb_animation import _problem
    from fluidnb.videodb.assignment import alpha_expansion, energy, solve

    for seed in range(20):
        u, w, edges, lam = _problem(seed, rows=2, cols=2, k=8)
        both = energy(solve(u, w, edges, lam).labels, u, w, edges, lam)
        assert both <= alpha_expansion(u, w, edges, lam).energy + 1e-9


def test_videodb_ex6_a_leaf_looks_as_close_as_water_and_flat_blocks_share_candidates(
    stream_and_clouds,
):
    """ex6's cell at quick size: the leaf's best V_p is no worse than the stream's, and
    most fragments of the flat-block painting share their candidate list (the stream's
    none); the painting's motion stays coherent (the solution says so)."""
    from fluidnb import data
    from fluidnb.lessons import videodb_animation as lesson
    from fluidnb.videodb import assign

    stream, _ = stream_and_clouds
    photo = data.sample("stream", size=240)
    side = int(96 * photo.shape[1] / 480)  # the cell's blocks
    painting = photo.copy()
    for r in range(0, photo.shape[0], side):
        for c in range(0, photo.shape[1], side):
            painting[r : r + side, c : c + side] = photo[r : r + side, c : c + side].mean((0, 1))
    leaf = assign(data.sample("leaf", size=240), None, stream.db, stream.params)
    flat = assign(painting, data.region("stream", size=240), stream.db, stream.params)

    def shared(asg):
        return 1 - len({tuple(row) for row in asg.candidates}) / len(asg.candidates)

    def best(asg):
        return asg.unary[:, 0].mean()

    assert best(leaf) <= best(stream) + 0.01  # not "clearly worse" (b)
    assert shared(stream) == 0
    assert shared(leaf) == 0
    assert shared(flat) > 0.5  # most of the painting's fragments (a; not c)
    assert best(flat) > best(stream)  # "rises too on the small quick database"
    assert flat.motion_coherence() > stream.motion_coherence()  # coherent, not random
    assert lesson.ex6.check("a")
    assert not lesson.ex6.check("b")
    assert not lesson.ex6.check("c")


# ------------------------------------------------------------------ 08_scene.ipynb


def test_scene_moving_a_layer_re_renders_none_and_changes_the_overlap():
    """08's ex1 (0 layers re-rendered after a move) and ex2 (a: the order changes the
    overlap, the fire's light on top of the ice), on a small scene of the lesson's kinds."""
    from fluidnb.data import sample
    from fluidnb.fire import FireParams
    from fluidnb.frost import FrostParams
    from fluidnb.lessons import scene as lesson08
    from fluidnb.scene import Layer, Scene, render

    photo = sample("lake", size=64)
    h, w = photo.shape[:2]
    fire, frost = np.zeros((h, w), bool), np.zeros((h, w), bool)
    fire[h // 4 :, w // 3 : 2 * w // 3] = True
    frost[: h // 2, : w // 2 + 4] = True  # overlaps the fire's left part
    scene = Scene(
        photo,
        [
            Layer("fire", fire, FireParams(output_size=48, interval=4), seed=1),
            Layer("frost", frost, FrostParams(spacing=3.0, gamma=0.3, target=20, max_frames=30)),
        ],
        size=None,
    )
    top = render(scene)
    before = scene.renders
    scene.move("frost", 0)
    under = render(scene)
    assert scene.renders - before == lesson08.ex1.checker.expected == 0
    both = fire & frost
    assert top.frames[:, both].max() > 0  # the flame reaches the overlap
    differ = np.abs(under.frames[:, both] - top.frames[:, both]).max()
    assert differ > 0.05  # the order matters where they overlap (ex2's "a", not "b")
    # With the frost under the fire the flame's light is added over the ice, not covered
    # by it: the overlap is brighter.
    assert under.frames[:, both].mean() > top.frames[:, both].mean()
    elsewhere = ~frost  # only one layer acts there: the order cannot matter
    assert np.array_equal(under.frames[:, elsewhere], top.frames[:, elsewhere])
    assert lesson08.ex2.check("a")
    assert not lesson08.ex2.check("b")


# ------------------------------------------------------------------ 06_turbulence, 06b


@pytest.fixture(scope="module")
def turbulence_quick():
    """06's quick sizes (30 frames, both grids halved): the flows, and the adaptive run."""
    from fluidnb.turbulence import TurbulenceParams, prepare, sample_flows, synthesize

    target, source = sample_flows(30, scale=2)
    params = TurbulenceParams()
    prep = prepare(target, source, params)
    return target, source, params, prep, synthesize(target, source, params, prepared=prep)


def test_turbulence_ex1_interval_16_is_further_along_the_uniform_curve(turbulence_quick):
    from fluidnb.lessons import turbulence as lesson06
    from fluidnb.turbulence import compare, table1

    assert lesson06.ex1.check("a")
    target, source, params, _, _ = turbulence_quick
    rows = table1(
        compare(
            target,
            source,
            [{"strategy": "interval", "interval": m} for m in (8, 16)] + [{"strategy": "adaptive"}],
            params=params,
        )
    )
    i8, i16, ad = ({k: r[k] for k in ("evaluations_per_patch", "relative_error")} for r in rows)
    assert i16["evaluations_per_patch"] == 4 < i8["evaluations_per_patch"] == 16
    assert i16["relative_error"] > 2 * i8["relative_error"] > 0
    assert ad["relative_error"] < 0.1 * i16["relative_error"]


def test_turbulence_ex3_two_starts_measure_at_most_160(turbulence_quick):
    from fluidnb.lessons import turbulence as lesson06
    from fluidnb.turbulence import window_positions

    assert lesson06.ex3.checker.checkers["at_most"].expected == 160
    # The bound holds for every start pair on a random landscape (the cell's function).
    rng = np.random.default_rng(0)
    for _ in range(20):
        E = rng.random((32, 32))

        def run(k, E=E):
            first = []

            def pick(points):
                ranked = sorted(map(tuple, points), key=lambda q: E[q])
                first.append(ranked[k] if not first else ranked[0])
                return first[-1]

            return window_positions("adaptive", 32, m0=8, best=pick)

        one, second = run(0), run(1)
        cost = sum(map(len, one + second[1:]))  # as the cell counts: round 0 shared
        assert sum(map(len, one)) < cost <= 160
        ends = [min(map(tuple, np.vstack(r)), key=lambda q: E[q]) for r in (one, second)]
        assert E[min(ends, key=lambda q: E[q])] <= E[ends[0]]


def test_turbulence_ex4_blend_removes_the_seams_and_changes_picks_after_frame_0(
    turbulence_quick,
):
    from fluidnb.lessons import turbulence as lesson06
    from fluidnb.turbulence import synthesize, vorticity

    assert right(lesson06.ex4, "seams") == "gone"
    assert right(lesson06.ex4, "picks") == "a"
    target, source, params, prep, pasted = turbulence_quick
    blended = synthesize(target, source, params.replace(blend=4), prepared=prep)

    def seam_ratio(syn):
        w = np.stack([vorticity(u) for u in syn.velocity[10:]])
        jump = np.abs(np.diff(w, axis=2))
        edge = np.arange(jump.shape[2]) % params.B == params.B - 1
        return jump[..., edge].mean() / jump[..., ~edge].mean()

    assert seam_ratio(pasted) > 1.4
    assert seam_ratio(blended) < 1.1
    picked = np.any(blended.local_positions != pasted.local_positions, axis=-1)
    assert not picked[0].any()  # frame 0: no temporal term, the same search
    assert 0 < picked.mean() < 0.25  # later: a few, through the temporal term


def test_turbulence_ex5_without_the_mask_the_smoke_patches_change(turbulence_quick):
    from fluidnb.lessons import turbulence as lesson06
    from fluidnb.turbulence import synthesize

    assert lesson06.ex5.check("a")
    target, source, params, prep, base = turbulence_quick
    no_mask = synthesize(target, source, params.replace(alpha=0.0))
    moved = np.any(no_mask.local_positions != base.local_positions, axis=-1)
    smoke = np.stack([prep.smoke_patches(i) for i in range(len(moved))])
    assert moved[smoke].mean() > 0.5
    assert moved[~smoke].mean() < 0.2 * moved[smoke].mean()


def test_turbulence_exact_ex2_bounds_measure_few_and_the_fft_gains_with_the_window(
    turbulence_quick,
):
    """06b's ex2, without timing (tests never time): exact-bounds measures a handful of
    positions in full for most patches at b = 8, and the FFT's work per patch grows more
    slowly with the window than the direct sums' (the times the notebook prints: full mode 0.6 x the
    exhaustive speed at b = 4, 1.3 x at b = 8)."""
    import scipy.fft

    from fluidnb.lessons import turbulence_exact as lesson06b
    from fluidnb.turbulence import global_search, local_features, local_search, prepare

    assert right(lesson06b.ex2, "fastest") == "bounds"
    assert right(lesson06b.ex2, "fft") == "a"
    target, source, params, _, _ = turbulence_quick
    p8 = params.replace(b=8)
    prep8 = prepare(target, source, p8)
    S, X = local_features(prep8, 18, None, p8)
    starts = prep8.window_starts(global_search(prep8, 18)[0])
    bounds = local_search(S, X, starts, prep8.window, "exact-bounds")
    assert np.median(bounds.evaluations) < 0.01 * prep8.window**2  # a handful, mostly
    assert bounds.evaluations.mean() < 0.1 * prep8.window**2
    B = params.B

    def direct_over_fft(n):
        L = scipy.fft.next_fast_len(n + B - 1)
        return n**2 * B**2 / (L**2 * np.log2(L))

    assert direct_over_fft(64) > direct_over_fft(32)


def test_videodb_ex2_the_power_of_the_mean_calls_opposite_flows_alike():
    from fluidnb.lessons import videodb_animation as lesson
    from fluidnb.videodb import starter_database

    assert lesson.ex2.check("a")
    water = starter_database("water", quick=True)
    mm = water.mean_motion
    east = int(np.argmax(mm[:, 1] - 3 * np.abs(mm[:, 0])))
    west = int(np.argmax(-mm[:, 1] - 3 * np.abs(mm[:, 0])))
    assert mm[east, 1] > 0 > mm[west, 1]
    dc = water.spectra[[east, west], 0].astype(float)
    signed, power = ((dc[0] - dc[1]) ** 2).sum(), ((dc[0] ** 2 - dc[1] ** 2) ** 2).sum()
    assert power < 0.5 * signed


def test_videodb_ex4_more_candidates_lower_the_energy(stream_and_clouds):
    from fluidnb import data
    from fluidnb.lessons import videodb_animation as lesson
    from fluidnb.videodb import assign, starter_database

    assert lesson.ex4.check("a")
    stream, _ = stream_and_clouds  # K = 40
    water = starter_database("water", quick=True)
    photo, matte = data.sample("stream", size=240), data.region("stream", size=240)
    e = [
        assign(photo, matte, water, stream.params.replace(candidates=k)).solution.energy
        for k in (10, 100)
    ]
    assert e[0] > stream.solution.energy > e[1]


# ------------------------------------------------------------------ 02_flicker


def test_flicker_ex2_kappa_above_1_maps_detail_above_half_the_loop():
    from fluidnb.flicker import FlickerParams, temporal_frequencies
    from fluidnb.lessons import flicker as lesson02

    assert lesson02.ex2.check("b")
    p = FlickerParams(T=64, mapping="convex")
    below = temporal_frequencies((96, 72), p.replace(kappa=1.0))
    above = temporal_frequencies((96, 72), p.replace(kappa=1.5))
    assert np.abs(below).max() <= p.T / 2 < np.abs(above).max()


def test_flicker_ex3_small_beta_jitters_more_and_zero_is_calmer_than_0_1():
    """The cell's measure at the cell's T = 64, on a photo of quick mode's size."""
    from fluidnb import data
    from fluidnb.flicker import FlickerParams, flicker
    from fluidnb.lessons import flicker as lesson02

    assert lesson02.ex3.check(smaller="a", zero="b")
    photo = data.sample("stream", size=96)
    jitter = {}
    for beta in (4.0, 0.5, 0.1, 0.0):
        frames = np.asarray(flicker(photo, params=FlickerParams(T=64, beta=beta), seed=0).frames)
        jitter[beta] = np.abs(np.diff(frames, axis=0)).mean()
    assert jitter[0.5] > 1.3 * jitter[4.0]
    assert jitter[0.1] > 1.3 * jitter[0.0]


def test_flicker_ex4_on_the_clouds_the_convex_difference_is_smaller_but_not_relatively():
    from fluidnb import data
    from fluidnb.flicker import FlickerParams, flicker
    from fluidnb.lessons import flicker as lesson02

    assert lesson02.ex4.check("a")
    p = FlickerParams(T=64, beta=0.0)
    diff, ratio = {}, {}
    for name in ("stream", "clouds"):
        img = data.sample(name, size=96)
        conv, plane = (
            np.asarray(flicker(img, params=p.replace(mapping=m), seed=0).frames)
            for m in ("convex", "plane")
        )
        diff[name] = np.abs(conv - plane).mean()
        ratio[name] = diff[name] / np.abs(plane - plane[0]).mean()
    assert diff["clouds"] < 0.6 * diff["stream"]
    assert 0.8 < ratio["clouds"] / ratio["stream"] < 1.25
