"""Preparation (sec. 2.1), the two-level search and synthesis (2.2), errors (Table 1)."""

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.fields import advect
from fluidnb.turbulence import (
    Flow,
    TurbulenceParams,
    check_settings,
    compare,
    global_search,
    local_features,
    local_search,
    prepare,
    render,
    sample_flows,
    synthesize,
    table1,
    vorticity_clip,
)
from fluidnb.turbulence._prepare import _coarsen


@pytest.fixture(scope="module")
def pair():
    return sample_flows(24, scale=2)


@pytest.fixture(scope="module")
def prep(pair):
    return prepare(*pair)


def test_the_source_high_frequencies_hold_no_low_frequencies(prep):
    # Seed 2.1: U_sh = U_s - U_sl. Averaged back to the coarse grid it is ~0 ...
    lo = _coarsen(prep.U_sh, prep.factor, vector=True)
    assert np.sqrt(np.mean(lo**2)) < 1e-6 * np.sqrt(np.mean(prep.u_s**2))
    # ... while it is a real part of the source, not a rounding error.
    assert np.sqrt(np.mean(prep.U_sh**2)) > 0.2 * np.sqrt(np.mean(prep.U_s**2))
    # The upsampled target averages back to the user's design.
    back = _coarsen(prep.U_t, prep.factor, vector=True)
    np.testing.assert_allclose(back, prep.u_t, atol=1e-5)


def test_preparation_follows_the_papers_layout(prep):
    assert prep.factor == 8
    assert prep.window == 32
    assert prep.tiles == (6, 4)
    assert prep.n_patches == 24
    # Local patch centres sit on the B-grid; global patches are b x b around them.
    np.testing.assert_array_equal(prep.centres[:2], [[8, 8], [8, 24]])
    np.testing.assert_array_equal(prep.target_corners[:2], [[-1, -1], [-1, 1]])
    assert set(np.unique(prep.d_t)) <= {0.0, 1.0}


def test_the_global_search_is_the_brute_force_minimum_of_eq_1(prep):
    i, b, alpha = 15, prep.params.b, prep.params.alpha
    q_l, E_l = global_search(prep, i)
    tgt = np.concatenate([prep.u_t[i], np.sqrt(alpha) * prep.d_t[i][..., None]], -1)
    src = np.concatenate([prep.u_s[i], np.sqrt(alpha) * prep.d_s[i][..., None]], -1)
    pad = np.pad(tgt, ((b, b), (b, b), (0, 0)), mode="edge")
    h, w = src.shape[:2]
    for p in range(prep.n_patches):
        y, x = prep.target_corners[p] + b
        x_p = pad[y : y + b, x : x + b]
        E = np.array(
            [
                [((x_p - src[a : a + b, c : c + b]) ** 2).sum() for c in range(w - b + 1)]
                for a in range(h - b + 1)
            ]
        )
        assert tuple(q_l[p]) == np.unravel_index(E.argmin(), E.shape)
        assert E_l[p] == pytest.approx(E.min(), rel=1e-9, abs=1e-12)


def test_windows_are_centred_on_the_global_match_and_stay_inside(prep):
    starts = prep.window_starts(np.array([[0, 0], [3, 2], [9, 4]]))
    B, n = prep.params.B, prep.window
    H, W = prep.U_s.shape[1:3]
    # Match (3, 2): centre 8 * (3 + 2, 2 + 2) = (40, 32); patch centres 40 +- 16.
    np.testing.assert_array_equal(starts[1], [40 - 8 - 16, 32 - 8 - 16])
    assert (starts >= 0).all()
    assert (starts + n - 1 + B <= [H, W]).all()


def test_pasted_detail_is_the_source_detail_at_the_chosen_positions(pair):
    out = synthesize(*pair, TurbulenceParams(strategy="adaptive"))
    prep, B = out.prepared, 16
    _ty, tx = prep.tiles
    for i in (0, 11, 23):
        for p, (y, x) in enumerate(out.local_positions[i]):
            r, c = divmod(p, tx)
            np.testing.assert_array_equal(
                out.detail[i, r * B : (r + 1) * B, c * B : (c + 1) * B],
                prep.U_sh[i, y : y + B, x : x + B],
            )
        np.testing.assert_allclose(out.velocity[i], prep.U_t[i] + out.detail[i], atol=1e-6)


def test_a_source_without_detail_leaves_the_target_unchanged(pair):
    target, source = pair
    calm = Flow(np.full_like(source.velocity, 0.3), source.density, source.dx)
    out = synthesize(target, calm)
    np.testing.assert_allclose(out.detail, 0, atol=1e-6)
    np.testing.assert_allclose(out.velocity, out.prepared.U_t, atol=1e-6)


def test_feathered_seams_keep_a_constant_detail_constant(pair):
    target, source = pair
    v = source.velocity.copy()
    v[..., 1] += 0.5  # a uniform drift has no detail either: any blend gives U_t
    out = synthesize(target, Flow(v, source.density, source.dx), TurbulenceParams(blend=4))
    np.testing.assert_allclose(out.velocity - out.prepared.U_t, out.detail, atol=1e-5)
    assert np.isfinite(out.velocity).all()


def frame_change(out):
    """Mean squared change of U_h between frames, after following the target flow."""
    U, Ut = out.detail, out.prepared.U_t
    return np.mean([np.mean((U[i] - advect(U[i - 1], Ut[i - 1])) ** 2) for i in range(1, len(U))])


def test_the_temporal_term_makes_the_detail_change_less_between_frames(pair):
    still = synthesize(*pair, TurbulenceParams(beta=0.0, strategy="exact-bounds"))
    coherent = synthesize(*pair, TurbulenceParams(beta=2.0, strategy="exact-bounds"))
    assert frame_change(coherent) < 0.8 * frame_change(still)


def test_errors_are_zero_for_exact_searches_and_positive_for_sampling(pair):
    results = compare(
        *pair,
        strategies=[
            {"strategy": "exhaustive"},
            {"strategy": "interval", "interval": 8},
            {"strategy": "adaptive"},
            {"strategy": "exact-fft"},
            {"strategy": "exact-bounds"},
        ],
    )
    rows = {r["strategy"]: r for r in table1(results)}
    assert table1({k: v.summary() for k, v in results.items()}) == list(rows.values())
    for name in ("exhaustive", "exact-fft", "exact-bounds"):
        assert rows[name]["relative_error"] == 0
        assert rows[name]["absolute_error"] == 0
    assert rows["interval 8"]["relative_error"] > rows["adaptive"]["relative_error"] >= 0
    assert rows["adaptive"]["relative_error"] < 0.05  # the paper: about 0.01
    assert rows["adaptive"]["paper_relative_error"] == 0.0103
    assert rows["exhaustive"]["speedup"] == 1.0
    smoke = results["adaptive"].errors(smoke_only=True)
    assert np.nanmin(smoke["absolute"]) >= 0


def test_compare_can_keep_only_the_runs_asked_for(pair):
    short = [f.frames(0, 6) for f in pair]
    strategies = [{"strategy": "exhaustive"}, {"strategy": "adaptive"}]
    whole = compare(*short, strategies)
    lean = compare(*short, strategies, keep=lambda p: p.strategy == "adaptive")
    assert isinstance(lean["adaptive"], type(whole["adaptive"]))
    np.testing.assert_array_equal(lean["adaptive"].velocity, whole["adaptive"].velocity)
    assert isinstance(lean["exhaustive"], dict)  # its row, not its flows

    def untimed(rows):
        return [
            {k: v for k, v in r.items() if k not in ("seconds_per_frame", "speedup")} for r in rows
        ]

    assert untimed([lean["exhaustive"]]) == untimed([whole["exhaustive"].summary()])
    assert untimed(table1(lean)) == untimed(table1(whole))


def test_synthesis_is_deterministic(pair):
    a = synthesize(*pair, TurbulenceParams(strategy="adaptive"))
    b = synthesize(*pair, TurbulenceParams(strategy="adaptive"))
    np.testing.assert_array_equal(a.velocity, b.velocity)
    np.testing.assert_array_equal(a.local_positions, b.local_positions)


def test_renders_and_result_flow(pair):
    out = synthesize(*[f.frames(0, 6) for f in pair])
    clips = render(out)
    assert set(clips) == {"target", "source", "synthesised"}
    assert {c.frames.shape for c in clips.values()} == {(6, 96, 64)}
    assert clips["synthesised"].frames.max() > 0.5
    meta = clips["synthesised"].metadata  # what the command line's --render saves
    assert meta["flow"] == "synthesised"
    assert TurbulenceParams.from_dict(meta["params"]) == out.params
    assert meta["seed"] is None
    assert meta["timings"]["total"] == out.timings["total"]
    assert vorticity_clip(out.velocity).frames.shape == (6, 96, 64, 3)
    flow = out.to_flow()
    assert flow.shape == (96, 64)
    assert flow.dx == pair[1].dx
    with pytest.raises(ValueError, match="reference=True"):
        out.errors()


# -- bad input -------------------------------------------------------------------------


def test_bad_pairs_get_clear_errors(pair):
    target, source = pair
    with pytest.raises(ValueError, match="same number of frames"):
        prepare(target.frames(0, 5), source.frames(0, 6))
    with pytest.raises(ValueError, match="whole number"):
        prepare(Flow(target.velocity, target.density, 0.3), source)
    with pytest.raises(ValueError, match="source shape must be 8 x"):
        prepare(target, Flow(source.velocity[:, :88], source.density[:, :88], source.dx))
    with pytest.raises(ValueError, match="B must divide"):
        prepare(target, source, TurbulenceParams(B=12))
    with pytest.raises(ValueError, match=r"b must be > B dX/dx = 16/8 = 2"):
        prepare(target, source, TurbulenceParams(b=2))
    with pytest.raises(ValueError, match=r"mask .* is empty in every frame.*lower D_th"):
        prepare(target, source, TurbulenceParams(D_th=1e3))
    with pytest.raises(ValueError, match=r"must be a fluidnb\.turbulence\.Flow"):
        prepare(target.velocity, source)


def test_bad_parameters_and_flows_are_refused():
    with pytest.raises(ValueError, match="m0 must be a power of 2"):
        TurbulenceParams(m0=6)
    with pytest.raises(ValueError, match="strategy"):
        TurbulenceParams(strategy="fast")
    with pytest.raises(ValueError, match="alpha"):
        TurbulenceParams(alpha=-1)
    v = np.zeros((3, 8, 8, 2))
    with pytest.raises(ValueError, match="NaN"):
        Flow(np.full_like(v, np.nan), np.zeros((3, 8, 8)), 1.0)
    with pytest.raises(ValueError, match=r"\(I, H, W, 2\)"):
        Flow(np.zeros((3, 8, 8, 3)), np.zeros((3, 8, 8)), 1.0)
    with pytest.raises(ValueError, match="density must have shape"):
        Flow(v, np.zeros((3, 8, 9)), 1.0)
    with pytest.raises(ValueError, match="dx"):
        Flow(v, np.zeros((3, 8, 8)), 0.0)


def test_local_features_rebuild_the_synthesis_search(pair):
    out = synthesize(*pair, TurbulenceParams(strategy="exhaustive", beta=2.0))
    prep = out.prepared
    for i in (0, 9):
        previous = None if i == 0 else advect(out.detail[i - 1], prep.U_t[i - 1])
        S, X = local_features(prep, i, previous, out.params)
        assert X.shape == (prep.n_patches, 16, 16, 3 if i == 0 else 5)
        starts = prep.window_starts(out.global_positions[i])
        found = local_search(S, X, starts, prep.window, "exhaustive")
        np.testing.assert_array_equal(found.positions, out.local_positions[i])
        np.testing.assert_array_equal(found.energies, out.energies[i])


# -- settings against grids, plain table rows, the clip ---------------------------------


def test_settings_are_checked_against_grid_shapes_without_flows():
    paper, quick = ((24, 16), (192, 128)), ((12, 8), (96, 64))
    assert check_settings(TurbulenceParams(), *paper) == 8
    assert check_settings(TurbulenceParams(), *quick, ratio=8.0) == 8
    bad = {
        "B must divide the source grid": (TurbulenceParams(B=12), paper, None),
        r"b must be > B dX/dx = 16/8 = 2": (TurbulenceParams(b=2), paper, None),
        r"b must be <= the target grid's shorter side 8": (TurbulenceParams(b=9), quick, None),
        "source_shape must be a whole multiple": (TurbulenceParams(), ((24, 16), (192, 100)), None),
        "source shape must be 4 x": (TurbulenceParams(), paper, 4.0),
        "whole number": (TurbulenceParams(), paper, 7.5),
        r"target_shape must be \(H, W\)": (TurbulenceParams(), ((24,), (192, 128)), None),
        "params must be a TurbulenceParams": ({"B": 16}, paper, None),
    }
    for message, (params, shapes, ratio) in bad.items():
        with pytest.raises(ValueError, match=message):
            check_settings(params, *shapes, ratio=ratio)


def test_prepare_and_check_settings_refuse_the_same_settings(pair):
    target, source = pair
    for params in (TurbulenceParams(B=12), TurbulenceParams(b=2), TurbulenceParams(b=9)):
        with pytest.raises(ValueError, match=" must ") as direct:
            check_settings(params, target.shape, source.shape)
        with pytest.raises(ValueError, match=" must ") as via_prepare:
            prepare(target, source, params)
        assert str(direct.value) == str(via_prepare.value)


def test_table1_takes_plain_rows_as_well_as_syntheses():
    from types import MappingProxyType

    as_tuples = table1({"exhaustive": (0.0, 0.0, 0.12), "adaptive": (0.01, 0.2, 0.012)})
    as_mappings = table1(
        {
            "exhaustive": MappingProxyType({"seconds_per_frame": 0.12, "relative_error": 0.0,
                                            "absolute_error": 0.0}),
            "adaptive": {"seconds_per_frame": 0.012, "relative_error": 0.01,
                         "absolute_error": 0.2},
        }
    )  # fmt: skip
    as_list = table1(
        [
            {"strategy": "exhaustive", "seconds_per_frame": 0.12, "relative_error": 0.0,
             "absolute_error": 0.0},
            {"strategy": "adaptive", "seconds_per_frame": 0.012, "relative_error": 0.01,
             "absolute_error": 0.2},
        ]
    )  # fmt: skip
    for rows in (as_tuples, as_mappings, as_list):
        by = {r["strategy"]: r for r in rows}
        assert by["adaptive"]["speedup"] == pytest.approx(10.0)
        assert by["adaptive"]["relative_error"] == 0.01
        assert by["adaptive"]["paper_relative_error"] == 0.0103
    row = {"seconds_per_frame": 0.5}
    table1({"exhaustive": row})
    assert row == {"seconds_per_frame": 0.5}  # the caller's row is not changed
    with pytest.raises(ValueError, match="a table1 row must be"):
        table1({"adaptive": [0.01, 0.2, 0.012]})
    with pytest.raises(ValueError, match="needs a strategy"):
        table1([{"seconds_per_frame": 0.1}])
    with pytest.raises(ValueError, match="needs a number 'seconds_per_frame'"):
        table1({"adaptive": {"relative_error": 0.0}})


def test_a_synthesis_carries_its_clip_with_the_conventions_metadata(pair):
    params = TurbulenceParams(strategy="exhaustive")
    out = synthesize(*[f.frames(0, 5) for f in pair], params)
    clip = out.clip
    assert isinstance(clip, Clip)
    assert clip is out.clip  # made once
    assert clip.frames.shape == (5, 96, 64)
    meta = clip.metadata
    assert meta["method"] == "turbulence"
    assert TurbulenceParams.from_dict(meta["params"]) == params
    assert meta["seed"] is None  # nothing in the synthesis is random
    assert set(meta["timings"]) >= {"prepare", "local_search", "total"}
    # The same dye as render()'s synthesised panel, up to its brightness scale.
    panel = render(out)["synthesised"].frames
    lit = (panel > 0.05) & (panel < 0.95)
    assert lit.sum() > 100
    ratio = clip.frames[lit] / panel[lit]
    assert np.ptp(ratio[(clip.frames[lit] < 0.95)]) < 0.05
