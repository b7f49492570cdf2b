"""The smoothness term in bulk (Okabe et al., sec. 5, Eq. 2, 3, 6): the three tables."""

import numpy as np
import pytest

from fluidnb import Cancelled, CancelToken
from fluidnb.videodb.assignment import (
    TEXTURE_SCALE,
    grid_edges,
    pair_smoothness,
    pair_tables,
    reference_pair_tables,
)
from fluidnb.videodb.assignment import _smoothness as smoothness

# ------------------------------------------------------------------------ helpers


def random_database(seed, n_fragments=24, n_bins=3, levels=4):
    """Float16 spectra (F, NB, 2, 12, 12) and textureness (F, L, 24, 24) in RAM."""
    gen = np.random.default_rng(seed)
    spectra = (gen.random((n_fragments, n_bins, 2, 12, 12)) * 4).astype(np.float16)
    texture = (gen.random((n_fragments, levels, 24, 24)) * 2).astype(np.float16)
    return spectra, texture


def with_near_duplicates(spectra, texture, seed=0):
    """Fragments 0-4 whose overlaps (nearly) coincide, the case float32 gets wrong.

    Cut from one canvas at the stride: 1 is 0's right neighbour and 3 its lower one
    (their overlaps equal exactly); 2 and 4 are 1 and 3 moved by one float16 step
    in a few places (near-duplicate overlaps).
    """
    gen = np.random.default_rng(seed)
    spectra, texture = spectra.copy(), texture.copy()
    for arr, side in ((spectra, 12), (texture, 24)):
        h = side // 2
        canvas = (gen.random((*arr.shape[1:-2], side + h, side + h)) * 4).astype(arr.dtype)
        arr[0] = canvas[..., :side, :side]
        arr[1] = canvas[..., :side, h:]
        arr[3] = canvas[..., h:, :side]
        for near, exact in ((2, 1), (4, 3)):
            arr[near] = arr[exact]
            flat = arr[near].reshape(-1)
            flat[::37] = np.nextafter(flat[::37], np.float16(np.inf))
    return spectra, texture


# ------------------------------------------------------------------- pair tables


def tables_setup(seed=0, k=7):
    spectra, texture = with_near_duplicates(*random_database(seed))
    active = np.array([[1, 1, 1], [1, 0, 1]], bool)
    nodes, edges, horizontal = grid_edges(active)
    gen = np.random.default_rng(seed + 1)
    candidates = np.stack([gen.choice(np.arange(5, len(spectra)), k) for _ in nodes])
    # Exact and near-duplicate overlaps across every edge (labels 0 of p and 1-4 of q).
    candidates[:, :5] = [0, 1, 2, 3, 4]
    return candidates, edges, horizontal, spectra, texture


def test_bulk_tables_equal_the_pair_by_pair_definition():
    # Mutation caught: every entry scaled by the block's area squared (_finish).
    candidates, edges, horizontal, spectra, texture = tables_setup()
    assert horizontal.any()
    assert (~horizontal).any()
    fast = pair_tables(candidates, edges, horizontal, spectra, texture)
    slow = reference_pair_tables(candidates, edges, horizontal, spectra, texture)
    for name in ("dc", "rest", "tex"):
        np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-9, atol=0)
        table = getattr(slow, name)
        assert np.all(table[horizontal, 0, 1] == 0)
        assert np.all(table[~horizontal, 0, 3] == 0)
        assert np.all(table[horizontal, 0, 2] > 0)
        assert np.all(table[~horizontal, 0, 4] > 0)
    # The near-duplicates were refined directly rather than left to cancellation.
    assert fast.recomputed >= 4 * len(edges)
    assert np.array_equal(fast.edges, edges)
    assert np.array_equal(fast.horizontal, horizontal)


def test_bulk_tables_do_not_depend_on_batches_or_threads(monkeypatch):
    candidates, edges, horizontal, spectra, texture = tables_setup()
    whole = pair_tables(candidates, edges, horizontal, spectra, texture)
    # One edge per batch, two worker threads.
    monkeypatch.setattr(smoothness, "_BATCH_BYTES", 1)
    monkeypatch.setattr(smoothness, "_workers", lambda: 2)
    split = pair_tables(candidates, edges, horizontal, spectra, texture)
    for name in ("dc", "rest", "tex"):
        assert np.array_equal(getattr(whole, name), getattr(split, name))
    assert split.recomputed == whole.recomputed


@pytest.mark.parametrize(("sigma", "rho"), [(100.0, 1e4), (0.0, 0.0), (3.5, 0.0)])
def test_pair_smoothness_is_the_tables_combined_bit_for_bit(monkeypatch, sigma, rho):
    """W alone (no three tables kept: a streamed animate) is exactly
    ``pair_tables(...).smoothness(sigma, rho)``, in one batch and in one-edge batches
    on two threads; every entry within 1e-9 of the pair-by-pair definition.

    Mutation caught: a batch's W written to the rows of the batch's position (0..n)
    instead of its edges."""
    candidates, edges, horizontal, spectra, texture = tables_setup()
    want = pair_tables(candidates, edges, horizontal, spectra, texture).smoothness(sigma, rho)
    got = pair_smoothness(candidates, edges, horizontal, spectra, texture, sigma, rho)
    assert np.array_equal(got, want)
    slow = reference_pair_tables(candidates, edges, horizontal, spectra, texture)
    np.testing.assert_allclose(got, slow.smoothness(sigma, rho), rtol=1e-9, atol=0)
    monkeypatch.setattr(smoothness, "_BATCH_BYTES", 1)
    monkeypatch.setattr(smoothness, "_workers", lambda: 2)
    split = pair_smoothness(candidates, edges, horizontal, spectra, texture, sigma, rho)
    assert np.array_equal(split, want)
    with pytest.raises(ValueError, match="sigma"):
        pair_smoothness(candidates, edges, horizontal, spectra, texture, -1.0, rho)
    bad = texture.copy()
    bad[candidates[0, 0]] = np.nan
    with pytest.raises(ValueError, match="texture"):
        pair_smoothness(candidates, edges, horizontal, spectra, bad, sigma, rho)


def test_the_float32_combination_stays_within_two_roundings_of_the_float64_one():
    """``smoothness(..., dtype=np.float32)`` (a preview's re-solve): every entry within
    2 x 2^-24 relative of the float64 W (the tables rounded to float32, the sum rounded
    once more; every term is >= 0, so nothing cancels); the float64 path is unchanged.

    Mutation caught: the float32 copies made of the wrong tables (rest for dc)."""
    candidates, edges, horizontal, spectra, texture = tables_setup()
    tables = pair_tables(candidates, edges, horizontal, spectra, texture)
    for sigma, rho in ((100.0, 1e4), (0.0, 3.0), (2.5, 0.0)):
        double = tables.smoothness(sigma, rho)
        single = tables.smoothness(sigma, rho, np.float32)
        assert single.dtype == np.float32
        np.testing.assert_allclose(single, double, rtol=2 * 2.0**-24, atol=0)
        assert np.array_equal(double, tables.smoothness(sigma, rho, dtype=np.float64))
        assert np.count_nonzero(single != double) > 0  # rounded, not a float64 copy
    with pytest.raises(ValueError, match="dtype"):
        tables.smoothness(1.0, 1.0, np.float16)


def test_the_gather_kernel_equals_numpys_take_cast_and_centring_bit_for_bit():
    # The compiled gather (float16 read as bit patterns through a table) must give the
    # very float64 features numpy's take, cast and centring give: the tables of a
    # real assignment stay the same to the last bit.
    candidates, edges, _, spectra, texture = tables_setup(k=6)
    spectra = spectra.copy()
    spectra[5, 1, 0, 0, 7] = np.float16(6e-8)  # a subnormal
    spectra[6, 1, 1, 3, 8] = -np.float16(0.0)
    for arr, lead in ((spectra, (2, 6)), (texture, (0, 4))):
        conversions = [
            (np.float16, smoothness._as_maps(arr.astype(np.float16))[0], None),  # hardware
            (np.float16, smoothness._as_maps(arr.astype(np.float16))[0], "table"),
            (np.float32, *smoothness._as_maps(arr.astype(np.float32))),
            (np.float64, *smoothness._as_maps(arr.astype(np.float64))),
        ]
        for dtype, maps, table in conversions:
            if table == "table":
                table = smoothness._half_to_double()
            elif dtype == np.float16 and not smoothness._hardware_half():
                continue  # no hardware float16 here: the table above covers it
            side = maps.shape[-1]
            for orientation in (True, False):
                box_p, box_q = smoothness._boxes(orientation, side)
                ids_p, ids_q = candidates[edges[:, 0]], candidates[edges[:, 1]]
                dim = (lead[1] - lead[0]) * side * (side // 2)
                out = [np.empty((len(edges), 6, dim)) for _ in range(2)]
                norms = [np.empty((len(edges), 6)) for _ in range(2)]
                smoothness._gather_centred(
                    maps, table, ids_p, ids_q, *lead, box_p, box_q, *out, *norms
                )
                flat = arr.astype(dtype).reshape(len(arr), -1, side, side)
                sides = []
                for ids, (r0, r1, c0, c1) in ((ids_p, box_p), (ids_q, box_q)):
                    part = np.take(flat, ids.ravel(), axis=0)[:, lead[0] : lead[1], r0:r1, c0:c1]
                    sides.append(part.astype(np.float64).reshape(len(edges), 6, dim))
                a, b = sides
                centre = (a.sum(axis=1, keepdims=True) + b.sum(axis=1, keepdims=True)) / 12
                assert np.array_equal(out[0], a - centre)
                assert np.array_equal(out[1], b - centre)
                # The squared norms, summed in another order than einsum's.
                for x, norm in zip(out, norms):
                    want = np.einsum("ekd,ekd->ek", x, x)
                    np.testing.assert_allclose(norm, want, rtol=1e-13, atol=0)


def test_the_distance_kernel_is_norms_minus_products_with_near_duplicates_summed():
    # _finish against the numpy statements it fuses: |a|^2 + |b|^2 - 2 a.b, except
    # where that cancels (rows 0 of a and b nearly equal), which is the direct sum.
    gen = np.random.default_rng(4)
    a = gen.standard_normal((3, 5, 40))
    b = gen.standard_normal((3, 6, 40))
    b[:, 0] = a[:, 0] + 1e-9 * gen.standard_normal((3, 40))  # near-duplicates
    prod = np.matmul(a, b.transpose(0, 2, 1))
    na, nb = np.einsum("ekd,ekd->ek", a, a), np.einsum("ekd,ekd->ek", b, b)
    threshold = (2 * 40 + 3) * np.finfo(np.float64).eps / smoothness._TABLE_RTOL
    out = np.full((5, 5, 6), -1.0)
    rows = np.array([4, 0, 2])
    fixed = smoothness._finish(prod, na, nb, a, b, 16.0, threshold, out, rows)
    exact = np.sum((a[:, :, None] - b[:, None]) ** 2, axis=-1)
    np.testing.assert_allclose(out[rows], 16.0 * exact, rtol=1e-12, atol=0)
    assert np.all(out[[1, 3]] == -1.0)  # other rows untouched
    assert fixed == 3  # exactly the three near-duplicate pairs
    assert np.all(out[rows, 0, 0] > 0)
    # The same pairs from norms minus products alone: relative errors far above 1e-9.
    naive = na[:, 0] + nb[:, 0] - 2 * prod[:, 0, 0]
    assert np.max(np.abs(naive - exact[:, 0, 0]) / exact[:, 0, 0]) > 1e-6


def test_bulk_tables_of_float32_and_float64_features_equal_the_definition():
    candidates, edges, horizontal, spectra, texture = tables_setup(k=5)
    for dtype in (np.float32, np.float64):
        s, t = spectra.astype(dtype), texture.astype(dtype)
        fast = pair_tables(candidates, edges, horizontal, s, t)
        slow = reference_pair_tables(candidates, edges, horizontal, s, t)
        for name in ("dc", "rest", "tex"):
            np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-9)


def test_near_duplicates_defeat_float32_so_the_check_is_real():
    # Norms minus product in float32 misses the near-duplicate entries badly (the
    # notes measured 300 %); the float64 tables above match to 1e-9.
    _, _, _, spectra, _ = tables_setup()
    a = spectra[0, 1:, :, :, 6:].astype(np.float32).ravel()  # right half of 0
    b = spectra[2, 1:, :, :, :6].astype(np.float32).ravel()  # left half of 2
    exact = np.sum((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    approx32 = np.float32(a @ a) + np.float32(b @ b) - np.float32(2) * np.float32(a @ b)
    assert exact > 0
    assert abs(float(approx32) - exact) / exact > 0.5


def test_fragments_cut_from_one_canvas_join_at_zero_cost():
    # Fragments cut at the stride from one canvas share their overlap exactly, so
    # every table is 0 for that pair (and not for the wrong orientation).
    gen = np.random.default_rng(3)
    canvas_m = gen.random((3, 2, 18, 18)).astype(np.float16)  # spectra blocks, 1.5 fragments
    canvas_t = gen.random((4, 36, 36)).astype(np.float16)  # textureness blocks
    spectra = np.stack([canvas_m[..., :12, :12], canvas_m[..., :12, 6:], canvas_m[..., 6:, :12]])
    texture = np.stack([canvas_t[..., :24, :24], canvas_t[..., :24, 12:], canvas_t[..., 12:, :24]])
    candidates = np.array([[0], [1], [2]])
    edges = np.array([[0, 1], [0, 2], [0, 2]])
    horizontal = np.array([True, False, True])
    tables = pair_tables(candidates, edges, horizontal, spectra, texture)
    for table in (tables.dc, tables.rest, tables.tex):
        assert table[0, 0, 0] == 0.0
        assert table[1, 0, 0] == 0.0
        assert table[2, 0, 0] > 0.0


def test_smoothness_recombines_the_three_tables():
    candidates, edges, horizontal, spectra, texture = tables_setup(k=5)
    tables = pair_tables(candidates, edges, horizontal, spectra, texture)
    # Eq. (6) as it reads, with rho the paper's and the textureness in its unit.
    w = tables.smoothness(100.0, 1e4)
    texture = TEXTURE_SCALE * tables.tex
    np.testing.assert_allclose(w, tables.dc + 100.0 * tables.rest + 1e4 * texture, rtol=1e-15)
    assert np.array_equal(tables.smoothness(0, 0), tables.dc)
    assert tables.dc.shape == (len(edges), 5, 5)
    for table in (tables.dc, tables.rest, tables.tex):
        assert np.all(table >= 0)
    with pytest.raises(ValueError, match="sigma must be >= 0"):
        tables.smoothness(-1.0, 1.0)
    with pytest.raises(ValueError, match="read-only"):
        tables.dc[0, 0, 0] = 1.0


def test_smoothness_is_the_three_numpy_statements_to_the_bit():
    # One compiled pass with the numpy version's operations in its order: the same
    # bits, so a re-solve's W (and its labels) do not depend on the path. A fused
    # multiply-add would round once where numpy rounds twice; the data below has
    # entries where that shows, so the test would see one.
    from fractions import Fraction

    gen = np.random.default_rng(12)
    shape = (40, 9, 9)
    dc, rest, tex = (gen.random(shape) * 10.0 ** gen.integers(-3, 6, shape) for _ in range(3))
    tables = smoothness.PairTables(dc, rest, tex, np.zeros((40, 2), int), np.ones(40, bool))
    for sigma, rho in [(100.0, 1e4), (0.37, 3.3), (7.0, 0.0), (0.0, 12.5)]:
        want = tables.rest * sigma
        want += tables.dc
        want += rho * TEXTURE_SCALE * tables.tex
        got = tables.smoothness(sigma, rho)
        assert got.dtype == np.float64
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))

    def fma(a, b, c):
        return float(Fraction(a) * Fraction(b) + Fraction(c))

    sigma, c = 0.37, 3.3 * TEXTURE_SCALE
    first = second = 0
    for r, d, t in zip(rest.flat, dc.flat, tex.flat):
        first += fma(r, sigma, d) != r * sigma + d
        second += fma(c, t, r * sigma + d) != (r * sigma + d) + c * t
    assert first > 30
    assert second > 30


def test_smoothness_refuses_tables_of_different_shapes():
    tables = smoothness.PairTables(
        np.zeros((2, 3, 3)), np.zeros((2, 3, 3)), np.zeros((1, 3, 3)), np.zeros((2, 2)), np.ones(2)
    )
    with pytest.raises(ValueError, match="dc, rest and tex must have the same shape"):
        tables.smoothness(1.0, 1.0)


def test_pair_tables_without_edges_and_with_dc_only():
    spectra, texture = random_database(0, n_bins=1)
    empty = pair_tables([[0, 1]], np.zeros((0, 2), int), np.zeros(0, bool), spectra, texture)
    assert empty.dc.shape == (0, 2, 2)
    tables = pair_tables([[0, 1], [2, 3]], [[0, 1]], [True], spectra, texture)
    assert np.array_equal(tables.rest, np.zeros((1, 2, 2)))  # one bin: DC only
    assert tables.recomputed == 0  # nothing cancelled: the empty terms are not counted
    assert np.all(tables.dc > 0)


def test_pair_tables_reports_progress_and_can_be_cancelled():
    candidates, edges, horizontal, spectra, texture = tables_setup(k=5)
    seen = []
    pair_tables(
        candidates, edges, horizontal, spectra, texture, progress=lambda f, m: seen.append(f)
    )
    assert seen[-1] == 1.0
    assert seen == sorted(seen)
    token = CancelToken()
    token.cancel()
    with pytest.raises(Cancelled):
        pair_tables(candidates, edges, horizontal, spectra, texture, progress=token)


def test_pair_tables_bad_inputs():
    candidates, edges, horizontal, spectra, texture = tables_setup(k=5)
    with pytest.raises(ValueError, match="candidates must be fragment ids"):
        pair_tables(candidates + 100, edges, horizontal, spectra, texture)
    with pytest.raises(ValueError, match="spectra must have shape"):
        pair_tables(candidates, edges, horizontal, spectra[..., :6], texture)
    with pytest.raises(ValueError, match="horizontal must have shape"):
        pair_tables(candidates, edges, horizontal[:-1], spectra, texture)
    with pytest.raises(ValueError, match="edges must hold node indices"):
        pair_tables(candidates, edges + 10, horizontal, spectra, texture)
    bad = spectra.copy()
    bad[candidates[0, 0], 1, 0, 0, -1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        pair_tables(candidates, edges, horizontal, bad, texture)
    assert np.isnan(bad[candidates[0, 0], 1, 0, 0, -1])  # input untouched
