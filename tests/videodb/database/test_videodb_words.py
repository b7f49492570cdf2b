"""Codebook, visual words and spatial-pyramid histograms (Okabe et al., secs. 4-5, Eq. 1)."""

import numpy as np
import pytest

from fluidnb.videodb.database._reference import reference_quantise
from fluidnb.videodb.database._words import (
    HISTOGRAM_TOTAL,
    _bisecting_kmeans,
    fit_codebook,
    intersection,
    pyramid_cells,
    pyramid_histograms,
    quantise,
)


def blobs(seed, n=600, d=16, centres=12):
    gen = np.random.default_rng(seed)
    means = gen.uniform(0, 100, (centres, d))
    return np.rint(means[gen.integers(0, centres, n)] + gen.normal(0, 4, (n, d)))


# -- codebook ---------------------------------------------------------------------------


def test_codebook_is_sklearn_bisecting_kmeans_and_repeatable():
    x = blobs(0).astype(np.uint8)
    c = fit_codebook(x, 8, seed=3)
    assert c.shape == (8, 16)
    assert c.dtype == np.float64
    assert np.array_equal(c, fit_codebook(x, 8, seed=3))
    model = _bisecting_kmeans(8, 3).fit(x.astype(np.float32))  # clustered in float32
    assert np.array_equal(c, model.cluster_centers_)
    assert not np.array_equal(c, fit_codebook(x, 8, seed=4))


def test_codebook_subsample_is_seeded_and_bounded():
    x = blobs(1, n=900).reshape(30, 30, 16)  # any leading shape
    c = fit_codebook(x, 5, max_samples=200, seed=0)
    assert np.array_equal(c, fit_codebook(x, 5, max_samples=200, seed=0))
    # The same rows, drawn as fit_codebook draws them, give the same centres.
    rows = x.reshape(-1, 16)
    pick = np.sort(np.random.default_rng(0).choice(len(rows), 200, replace=False))
    model = _bisecting_kmeans(5, 0).fit(rows[pick].astype(np.float32))
    assert np.array_equal(c, model.cluster_centers_)


def test_codebook_needs_k_rows():
    with pytest.raises(ValueError, match="at least 10"):
        fit_codebook(np.zeros((9, 4)), 10)
    with pytest.raises(ValueError, match="max_samples"):
        fit_codebook(np.zeros((50, 4)), 10, max_samples=5)
    with pytest.raises(ValueError, match="k must be"):
        fit_codebook(np.zeros((50, 4)), 0)
    with pytest.raises(ValueError, match="NaN"):
        fit_codebook(np.full((50, 4), np.nan), 3)


# -- quantisation -----------------------------------------------------------------------


def test_predict_descends_the_tree_quantise_takes_the_nearest_centre():
    # Three groups on a line: 100 points at 0, 10 at 6, 100 at 10. The first bisection
    # splits {0} from {6, 10} (whose centre is ~9.6), the second {6} from {10}. A point
    # at 4 is nearer 0 than 9.6, so predict() goes down the {0} branch, but its nearest
    # word is the one at 6.
    gen = np.random.default_rng(1)
    line = np.concatenate([np.zeros(100), np.full(10, 6.0), np.full(100, 10.0)])
    x = np.zeros((210, 128))
    x[:, 0] = line + gen.normal(0, 0.05, 210)
    centres = fit_codebook(x, 3, seed=0)
    model = _bisecting_kmeans(3, 0).fit(x)
    query = np.zeros((1, 128))
    query[0, 0] = 4.0
    by_tree = model.predict(query)[0]
    nearest = quantise(query, centres)[0]
    assert centres[by_tree, 0] == pytest.approx(0.0, abs=0.1)
    assert centres[nearest, 0] == pytest.approx(6.0, abs=0.1)
    dist = ((query - centres) ** 2).sum(axis=1)
    assert nearest == np.argmin(dist) != by_tree


def test_quantise_equals_brute_force_with_ties():
    # (The near-tie margin's mutation: the test below.)
    gen = np.random.default_rng(2)
    centres = gen.integers(0, 8, (20, 6)).astype(np.float64)
    centres[7] = centres[3]  # duplicate word: ties go to 3
    x = gen.integers(0, 8, (3000, 6)).astype(np.uint8)  # many exact ties
    got = quantise(x, centres)
    assert got.dtype == np.uint8
    assert np.array_equal(got, reference_quantise(x, centres))
    assert 7 not in got
    assert np.array_equal(quantise(x.reshape(30, 100, 6), centres), got.reshape(30, 100))


def test_quantise_resolves_what_the_matrix_product_cannot():
    # Centres 1e-6 apart around a point of norm ~3400: "norms minus a product" loses
    # ~1e-9 to round-off, far more than the 1e-12 between the squared distances.
    gen = np.random.default_rng(3)
    base = np.full(128, 300.0)
    n = 200
    centres = np.repeat(base[None], 6, axis=0)
    centres[:, 0] += np.arange(6) * 1e-6 - 2.5e-6
    centres[:, 1] += gen.normal(0, 1e-6, 6)
    x = np.repeat(base[None], n, axis=0).astype(np.uint16)
    x[:, 0] += gen.integers(0, 2, n).astype(np.uint16)
    ref = reference_quantise(x, centres)
    assert np.array_equal(quantise(x, centres), ref)
    xf = x.astype(np.float64)
    naive = ((centres**2).sum(1)[None] - 2 * xf @ centres.T).argmin(axis=1)
    assert not np.array_equal(naive, ref)  # the plain product alone gets some wrong
    # Descriptors near pairs of centres 1e-4 apart: the float32 scores of a pair often
    # differ by a rounding step in the wrong order (not only tie), so the margin that
    # sends near-ties to the direct distances is needed.
    # Mutation caught: that margin set to 0 (exact float32 ties only).
    base = gen.uniform(0, 255, (8, 128))
    centres = np.repeat(base, 2, axis=0)
    centres[1::2, gen.integers(0, 128, 8)] += 1e-4
    x = (base[gen.integers(0, 8, 400)] + gen.normal(0, 3, (400, 128))).clip(0, 255)
    x = x.astype(np.uint8)
    assert np.array_equal(quantise(x, centres), reference_quantise(x, centres))


def test_quantise_works_block_by_block(monkeypatch):
    from fluidnb.videodb.database import _words

    gen = np.random.default_rng(4)
    centres = gen.uniform(0, 50, (30, 8))
    x = gen.integers(0, 50, (1000, 8)).astype(np.uint8)
    whole = quantise(x, centres)
    monkeypatch.setattr(_words, "_BLOCK", 37)
    assert np.array_equal(quantise(x, centres), whole)
    assert np.array_equal(whole, reference_quantise(x, centres))


def test_quantise_dtype_and_validation():
    assert quantise(np.zeros((2, 3)), np.zeros((300, 3))).dtype == np.uint16
    assert quantise(np.zeros((0, 9, 9, 3)), np.zeros((4, 3))).shape == (0, 9, 9)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        quantise(np.zeros((2, 4)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="NaN"):
        quantise(np.full((2, 3), np.nan), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="centres"):
        quantise(np.zeros((2, 3)), np.zeros(3))


# -- spatial pyramid ----------------------------------------------------------------------


def literal_histogram(word_map, k):
    """The DESIGN's definition, one descriptor at a time."""
    h = np.zeros(21 * k, int)
    for jy in range(9):
        for jx in range(9):
            first = 0
            for level, weight in zip(range(3), (1, 1, 2)):
                side = 2**level
                cy = (4 * jy + 8) * side // 48
                cx = (4 * jx + 8) * side // 48
                cell = first + cy * side + cx
                h[cell * k + word_map[jy, jx]] += weight
                first += side * side
    return h


def test_pyramid_cells():
    c = pyramid_cells()
    assert c.shape == (3, 81)
    assert set(c[0]) == {0}
    # Level 1 cells hold 4 or 5 descriptors per axis (positions 8..20 | 24..40).
    assert np.bincount(c[1] - 1).tolist() == [16, 20, 20, 25]
    assert np.bincount(c[2] - 5).reshape(4, 4).tolist() == [
        [1, 3, 3, 2],
        [3, 9, 9, 6],
        [3, 9, 9, 6],
        [2, 6, 6, 4],
    ]


def test_pyramid_histograms_follow_the_definition():
    gen = np.random.default_rng(5)
    words = gen.integers(0, 7, (20, 9, 9)).astype(np.uint8)
    h = pyramid_histograms(words, 7)
    assert h.shape == (20, 21 * 7)
    assert h.dtype == np.uint8
    assert (h.sum(axis=1) == HISTOGRAM_TOTAL).all()
    for i in (0, 13):
        assert np.array_equal(h[i], literal_histogram(words[i], 7))
    assert np.array_equal(pyramid_histograms(words[4], 7), h[4])


def test_intersection_known_answers():
    gen = np.random.default_rng(6)
    a = gen.integers(0, 10, (9, 9))
    b = a.copy()
    b[4, 6] = (a[4, 6] + 1) % 10  # one descriptor changes word: 1 + 1 + 2 counts lost
    ha, hb = pyramid_histograms(np.stack([a, b]), 10)
    assert intersection(ha, ha) == 1.0
    assert intersection(ha, hb) == (324 - 4) / 324
    assert intersection(hb, ha) == intersection(ha, hb)
    disjoint = pyramid_histograms(np.full((9, 9), 9), 10)
    same = pyramid_histograms(np.zeros((9, 9), int), 10)
    assert intersection(same, disjoint) == 0.0
    # Broadcasting: one target against several database fragments.
    many = intersection(ha[None], np.stack([ha, hb, same]))
    assert many.shape == (3,)
    assert many[0] == 1.0
    assert 0.0 <= many.min() <= many.max() <= 1.0


def test_pyramid_validation():
    with pytest.raises(ValueError, match=r"\[0, 4\]"):
        pyramid_histograms(np.full((9, 9), 5), 5)
    with pytest.raises(ValueError, match="9 x 9"):
        pyramid_histograms(np.zeros((8, 9), int), 5)
    with pytest.raises(ValueError, match="numeric"):
        pyramid_histograms(np.zeros((9, 9)), 5)
    with pytest.raises(ValueError, match="same length"):
        intersection(np.zeros(21 * 3, int), np.zeros(21 * 4, int))


def test_the_codebook_does_not_depend_on_the_threads_openmp_may_use():
    # scikit-learn splits its sums between its OpenMP threads; the fit fixes their
    # number, so a process limited to one (dask.distributed sets OMP_NUM_THREADS=1)
    # or a machine with more cores gets the same codebook, to the last bit.
    from threadpoolctl import threadpool_limits

    gen = np.random.default_rng(7)
    centres = gen.integers(0, 256, (24, 32))
    x = np.clip(centres[gen.integers(0, 24, 6000)] + gen.normal(0, 40, (6000, 32)), 0, 255)
    x = x.astype(np.uint8)
    default = fit_codebook(x, 16, seed=1)
    for limit in (1, 3):
        with threadpool_limits(limits=limit, user_api="openmp"):
            assert np.array_equal(fit_codebook(x, 16, seed=1), default), limit
