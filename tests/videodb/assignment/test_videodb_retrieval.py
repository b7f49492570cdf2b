"""Exact top-K retrieval by histogram intersection and the motion filter (Okabe et al., sec. 5)."""

import numpy as np
import pytest

from fluidnb.videodb.assignment import HistogramIndex, reference_top_k
from fluidnb.videodb.database._words import intersection, pyramid_histograms


def database(seed, n, k, *, correlated=True):
    """Word maps with ties galore (few words), some spatially correlated."""
    gen = np.random.default_rng(seed)
    words = gen.integers(0, k, (n, 9, 9))
    if correlated:
        coarse = gen.integers(0, k, (n, 3, 3))
        blocky = np.repeat(np.repeat(coarse, 3, axis=1), 3, axis=2)
        words = np.where(gen.random((n, 9, 9)) < 0.7, blocky, words)
    motion = gen.normal(0, 1.5, (n, 2)).astype(np.float32)
    motion[gen.random(n) < 0.05] = 0  # some still fragments
    return words.astype(np.uint8), motion


def same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a, b))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_dense_reference(seed):
    # Mutations caught: a posting list's last entry dropped (_add_sparse); the sign of
    # dx in the direction filter (_filter).
    gen = np.random.default_rng(10 + seed)
    n, k = [(400, 6), (1500, 40), (60, 3)][seed]
    words, motion = database(seed, n, k)
    index = HistogramIndex(words, k, mean_motion=motion)
    queries = np.concatenate([gen.integers(0, k, (6, 9, 9)), words[:3]])
    q = len(queries)
    direction = gen.normal(0, 1, (q, 2))
    direction[::3] = np.nan
    speed = gen.exponential(1.5, q)
    speed[1::3] = np.nan
    for top in (1, 17, n):
        for kw in (
            {},
            {"direction": direction},
            {"speed": speed, "max_speed_ratio": 1.5},
            {"direction": direction, "speed": speed, "max_angle": 25.0},
        ):
            got = index.top_k(queries, top, **kw)
            ref = reference_top_k(words, k, queries, top, mean_motion=motion, **kw)
            assert same(got, ref), (top, kw)
    # Ties are common at these sizes: the id order among equal scores is what is checked.
    scores = index.top_k(queries, n).scores
    assert ((np.diff(scores, axis=1) == 0).sum(axis=1) >= 5).all()


def test_queries_split_over_threads_give_the_same_candidates(monkeypatch):
    from fluidnb.videodb.assignment import _retrieval

    gen = np.random.default_rng(7)
    words, motion = database(5, 900, 20)
    index = HistogramIndex(words, 20, mean_motion=motion)
    queries = gen.integers(0, 20, (11, 9, 9))
    direction = gen.normal(0, 1, (11, 2))
    direction[::4] = np.nan
    whole = index.top_k(queries, 30, direction=direction)
    monkeypatch.setattr(_retrieval, "_MIN_QUERIES", 1)
    monkeypatch.setattr(_retrieval, "_workers", lambda: 3)  # 3 threads, a query per run
    split = index.top_k(queries, 30, direction=direction)
    assert same(split, whole)
    ref = reference_top_k(words, 20, queries, 30, mean_motion=motion, direction=direction)
    assert same(split, ref)


def test_both_storage_paths_are_exercised():
    words, _ = database(3, 1500, 40)
    index = HistogramIndex(words, 40)
    lengths = np.diff(index.offsets)
    assert (index.dense_row >= 0).any()
    assert ((index.dense_row < 0) & (lengths > 0)).any()
    # Every list is ascending and its counts are the histograms' counts.
    h = pyramid_histograms(words, 40)
    for d in np.flatnonzero(lengths)[:50]:
        ids = index.ids[index.offsets[d] : index.offsets[d + 1]]
        assert (np.diff(ids) > 0).all()
        assert np.array_equal(index.counts[index.offsets[d] : index.offsets[d + 1]], h[ids, d])
    for d in np.flatnonzero(index.dense_row >= 0)[:20]:
        assert np.array_equal(index.dense[index.dense_row[d]], h[:, d])


def test_a_database_fragment_finds_itself_first():
    words, _ = database(4, 300, 12)
    words[[40, 41, 150]] = words[90]  # exact duplicates of fragment 90
    index = HistogramIndex(words, 12)
    got = index.top_k(words[[90, 7]], 5)
    assert got.ids[0, :4].tolist() == [40, 41, 90, 150]  # the ties, by id
    assert got.scores[0, :4].tolist() == [324] * 4
    assert got.ids[1, 0] == 7
    assert got.scores[1, 0] == 324
    assert got.scores[1, 1] < 324
    # Scores are Eq. (1) on the integer histograms.
    h = pyramid_histograms(words, 12)
    assert np.allclose(got.scores[1] / 324, intersection(h[7][None], h[got.ids[1]]))
    assert got.n_eligible.tolist() == [300, 300]


def test_motion_filter_semantics():
    # Database motions (dy, dx): angles to the right (0, 1) and speeds chosen on and
    # around the thresholds (45 degrees, speed ratio 2 about 1 px/frame).
    deg = np.radians([0, 30, 45, 60, 180, 0, 0, 0, 0])
    speeds = np.array([1, 1, 1, 1, 1, 0.5, 2, 2.1, 0.4])
    motion = np.stack([np.sin(deg), np.cos(deg)], axis=1) * speeds[:, None]
    motion = np.concatenate([motion, [[0.0, 0.0]]])  # a still fragment
    words = np.zeros((10, 9, 9), np.uint8)
    index = HistogramIndex(words, 2, mean_motion=motion)
    q = np.zeros((1, 9, 9), np.uint8)
    right = np.array([[0.0, 3.0]])  # any length
    got = index.top_k(q, 10, direction=right, max_angle=45)
    assert got.n_eligible.tolist() == [7]
    assert sorted(set(got.ids[0].tolist())) == [0, 1, 2, 5, 6, 7, 8]
    got = index.top_k(q, 10, speed=np.array([1.0]), max_speed_ratio=2)
    assert sorted(set(got.ids[0].tolist())) == [0, 1, 2, 3, 4, 5, 6]
    got = index.top_k(q, 10, direction=right, speed=np.array([1.0]), max_angle=45)
    assert sorted(set(got.ids[0].tolist())) == [0, 1, 2, 5, 6]
    # NaN switches a query's filter off.
    got = index.top_k(q, 10, direction=[[np.nan, np.nan]], speed=[np.nan])
    assert got.ids[0].tolist() == list(range(10))
    assert got.n_eligible.tolist() == [10]


def test_short_rows_are_padded_and_empty_ones_fall_back():
    words, motion = database(5, 200, 8)
    motion[:] = (0.0, 1.0)
    motion[[17, 3, 120]] = (1.0, 0.0)  # only these move down
    index = HistogramIndex(words, 8, mean_motion=motion)
    queries = words[[0, 1]]
    down_or_up = np.array([[1.0, 0.0], [-1.0, 0.0]])
    got = index.top_k(queries, 10, direction=down_or_up, max_angle=10)
    assert got.n_eligible.tolist() == [3, 0]
    assert sorted(got.ids[0, :3].tolist()) == [3, 17, 120]
    assert (got.ids[0, 3:] == got.ids[0, 0]).all()
    assert (got.scores[0, 3:] == got.scores[0, 0]).all()
    assert (np.diff(got.scores[0, :3]) <= 0).all()
    unfiltered = index.top_k(queries[1:], 10)
    assert np.array_equal(got.ids[1], unfiltered.ids[0])
    assert np.array_equal(got.scores[1], unfiltered.scores[0])
    ref = reference_top_k(
        words, 8, queries, 10, mean_motion=motion, direction=down_or_up, max_angle=10
    )
    assert same(got, ref)


def test_inputs_are_not_modified():
    words, motion = database(6, 50, 5)
    w0, m0 = words.copy(), motion.copy()
    index = HistogramIndex(words, 5, mean_motion=motion)
    d = np.array([[0.0, 2.0]])
    index.top_k(words[:1], 3, direction=d)
    assert np.array_equal(words, w0)
    assert np.array_equal(motion, m0)
    assert d.tolist() == [[0.0, 2.0]]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda ix, w: ix.top_k(w[:2], 0), "k must be"),
        (lambda ix, w: ix.top_k(w[:2], 51), "k must be"),
        (lambda ix, w: ix.top_k(w[0], 3), r"\(Q, 9, 9\)"),
        (lambda ix, w: ix.top_k(w[:2] + 5, 3), r"\[0, 4\]"),
        (lambda ix, w: ix.top_k(w[:2], 3, direction=[[1.0, np.nan], [0, 1]]), "direction"),
        (lambda ix, w: ix.top_k(w[:2], 3, direction=[[0, 0], [0, 1]]), "nonzero"),
        (lambda ix, w: ix.top_k(w[:2], 3, direction=[[0, 1]]), r"\(2, 2\)"),
        (lambda ix, w: ix.top_k(w[:2], 3, speed=[-1.0, 1.0]), "speed"),
        (lambda ix, w: ix.top_k(w[:2], 3, speed=[1.0, 1.0], max_speed_ratio=0.5), "ratio"),
        (lambda ix, w: ix.top_k(w[:2], 3, direction=[[0, 1], [0, 1]], max_angle=200), "angle"),
    ],
)
def test_bad_queries_are_refused(call, match):
    words, motion = database(7, 50, 5)
    index = HistogramIndex(words, 5, mean_motion=motion)
    with pytest.raises(ValueError, match=match):
        call(index, words)


def test_bad_databases_are_refused():
    words, motion = database(8, 20, 5)
    with pytest.raises(ValueError, match="mean_motion"):
        HistogramIndex(words, 5).top_k(words[:1], 2, speed=[1.0])
    with pytest.raises(ValueError, match=r"\(20, 2\)"):
        HistogramIndex(words, 5, mean_motion=motion[:5])
    with pytest.raises(ValueError, match="NaN"):
        HistogramIndex(words, 5, mean_motion=np.full((20, 2), np.nan))
    with pytest.raises(ValueError, match="F >= 1"):
        HistogramIndex(words[:0], 5)
    with pytest.raises(ValueError, match=r"\[0, 3\]"):
        HistogramIndex(words, 4)


def test_an_index_over_some_fragments_answers_in_the_database_ids():
    gen = np.random.default_rng(3)
    words, motion = database(1, 300, 12)
    keep = np.sort(gen.choice(300, 180, replace=False))
    queries = np.concatenate([gen.integers(0, 12, (5, 9, 9)), words[keep[:3]]])
    direction = gen.normal(0, 1, (8, 2))
    index = HistogramIndex(words[keep], 12, mean_motion=motion[keep], ids=keep)
    got = index.top_k(queries, 20, direction=direction)
    rows = HistogramIndex(words[keep], 12, mean_motion=motion[keep])
    plain = rows.top_k(queries, 20, direction=direction)
    np.testing.assert_array_equal(got.ids, keep[plain.ids])  # the rows' ids, mapped
    np.testing.assert_array_equal(got.scores, plain.scores)
    own = index.top_k(words[keep[:3]], 1).ids[:, 0]
    np.testing.assert_array_equal(own, keep[:3])  # a fragment finds itself, by its own id
    with pytest.raises(ValueError, match="ids must be 180 increasing"):
        HistogramIndex(words[keep], 12, ids=keep[::-1])
