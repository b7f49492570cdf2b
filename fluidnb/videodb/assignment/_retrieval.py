r"""Candidate retrieval: the database fragments most similar in appearance (Okabe et al., sec. 5).

For every target fragment the assignment keeps the :math:`K` = 100 database fragments
whose spatial-pyramid histograms of visual words (:mod:`~fluidnb.videodb.database._words`)
have the largest intersection with its own (Eq. 1),

.. math::

    I(H_e, H_t) = \sum_i \min(H_e[i], H_t[i]),                            \quad (1)

over the whole database (the paper's ~240,000 fragments), exactly. Scores are
integers 0..324 (324 for identical word maps), so ties are common: they are broken by
fragment id, lower first, so the result never depends on a sort's stability.

:class:`HistogramIndex` keeps the database's histograms as sparse posting lists, one
per histogram bin (``cell * k + word``, 21 k of them), each listing the fragments with
a nonzero count there, ids ascending, with their counts (a fragment has at most 243
nonzero bins of 4200, ~220 for uniformly used words). A query walks only the lists of
its own nonzero bins, adding :math:`\min(H_e[i], H_t[i])` to each listed fragment's
score (a compiled kernel, one query at a time, the score buffer reused; the queries
are split over the cores); then, scores being small integers, one counting pass finds
the threshold score of the top :math:`K` and a second collects the ids in ascending
order: :math:`O(F)` per query, no sort.
The bins of frequent words at the coarse levels are held by a large share of the
fragments (a third of them at level 0 for uniformly used words); those (held by at
least 1/12 of the fragments) are kept as dense rows of counts instead of lists,
which a vectorised loop adds faster than a long list can be walked.

User motion (Okabe et al., sec. 5, Fig. 8): with a direction and/or speed over a target
fragment, database fragments whose mean motion differs markedly are discarded *before*
the top :math:`K` is taken. A fragment is eligible when

- the angle between its mean motion :math:`m` and the direction is at most
  ``max_angle`` degrees (a fragment with :math:`|m| <` 1e-6 px/frame has no direction
  and is not eligible), and
- :math:`\max(|m|, s) / \min(|m|, s) \le` ``max_speed_ratio`` for the speed :math:`s`.

(Both within a relative 1e-12, so that motions exactly on a boundary count as inside.)
When fewer than :math:`K` fragments are eligible, the row is padded by repeating the
best of them (a repeated label is harmless to the MRF); when none is, the query falls
back to the unfiltered top :math:`K`.
:func:`~fluidnb.videodb.assignment.reference_top_k` is the same search written densely
in numpy, for the tests.

References
----------
.. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Pacific Graphics 2011.
.. [2] S. Lazebnik, C. Schmid, J. Ponce, "Beyond bags of features: spatial pyramid
   matching for recognizing natural scene categories", CVPR 2006.
"""

from __future__ import annotations

import math
import threading
import weakref
from typing import NamedTuple

import numpy as np
from numba import njit

from ..._threads import spread_pool
from ..._validation import check_array, check_int, check_range
from .._common._geometry import GRID
from ..database._words import CELLS, HISTOGRAM_TOTAL, _check_words, pyramid_cells
from ._smoothness import _workers

__all__ = [
    "MIN_MOTION",
    "STILL",
    "HistogramIndex",
    "TopK",
    "fragment_speeds",
    "histogram_index",
    "moving_fragments",
]

#: Below this speed (px/frame) a fragment's mean motion has no direction.
MIN_MOTION = 1e-6
# Bins held by at least this fraction of the fragments are kept as a dense row of
# counts (F bytes, against 5 bytes an entry in a list): adding a dense row (vectorised,
# ~0.14 ns a fragment) beats walking a list of more than ~1/13 of the fragments
# (~1.8 ns an entry). Measured on 240k fragments: 1/8 -> 9.0 ms a query, 237 MB;
# 1/12 -> 7.2 ms, 306 MB; 1/20 -> 6.9 ms, 336 MB.
_DENSE_FRACTION = 1 / 12
# Relative slack on the angle and speed-ratio tests (motions exactly on a boundary).
_SLACK = 1e-12
# Queries per thread at least: below, one thread (its start costs ~0.1 ms, a query
# over the paper's 240,000 fragments ~2.5 ms).
_MIN_QUERIES = 8


class TopK(NamedTuple):
    r"""The candidates of each query, best first.

    Attributes
    ----------
    ids : ndarray of int64, shape (Q, K)
        Database fragment ids by decreasing score, ties by increasing id (a row is
        padded with its first id when fewer than ``K`` fragments were eligible).
    scores : ndarray of int32, shape (Q, K)
        :math:`I(H_e, H_t)` of Eq. (1), 0..324 (divide by 324 for :math:`I \in [0, 1]`).
    n_eligible : ndarray of int64, shape (Q,)
        Fragments that passed the query's motion filter (all ``F`` without one; 0
        means none did and the row is the unfiltered top ``K``).
    """

    ids: np.ndarray
    scores: np.ndarray
    n_eligible: np.ndarray


class HistogramIndex:
    r"""The database's spatial-pyramid histograms as posting lists, for exact top-K search.

    Parameters
    ----------
    words : array_like of int, shape (F, 9, 9)
        Every database fragment's visual-word map (fragment id = row).
    k : int
        :math:`k`, the codebook's size (words are in ``[0, k)``).
    mean_motion : array_like, shape (F, 2), optional
        Every fragment's mean motion (dy, dx) in px/frame; needed for the motion
        filter of :meth:`top_k`.
    ids : array_like of int, shape (F,), optional
        The database id of each row, increasing (an index over some of the
        database's fragments: :func:`histogram_index`); default the row.

    Attributes
    ----------
    n_fragments : int
        :math:`F`.
    n_words : int
        :math:`k`.
    offsets : ndarray of int64, shape (21 k + 1,)
        Posting list of bin ``d``: entries ``offsets[d]:offsets[d + 1]`` of ``ids``
        and ``counts`` (empty for a dense bin).
    ids : ndarray of int32, shape (nnz,)
        Fragment ids, ascending within each list.
    counts : ndarray of uint8, shape (nnz,)
        :math:`H_e[d]` of those fragments (1..81).
    dense_row : ndarray of int64, shape (21 k,)
        Row of ``dense`` holding bin ``d``, or -1 for a bin kept as a list.
    dense : ndarray of uint8, shape (n_dense, F)
        :math:`H_e[d]` of every fragment for the dense bins.

    Notes
    -----
    Measured on 240,000 synthetic word maps (k = 200; one core of a 2-core AMD EPYC
    VM whose timings drift up to 2x with load): built in 1.7-3 s, 180-310 MB;
    top-100 in 4-5 ms a query for spatially correlated maps, ~7 ms for independent
    uniform words (more, and denser, bins per query); the motion filter adds ~2 ms.

    Examples
    --------
    >>> gen = np.random.default_rng(0)
    >>> words = gen.integers(0, 16, (50, 9, 9))
    >>> index = HistogramIndex(words, 16)
    >>> best = index.top_k(words[[7]], 3)
    >>> int(best.ids[0, 0]), int(best.scores[0, 0])
    (7, 324)
    """

    def __init__(self, words, k, *, mean_motion=None, ids=None):
        k = check_int("k", k, 1, 65536)
        w = _check_words(words, k)
        if w.ndim != 3 or len(w) == 0:
            raise ValueError(f"words must have shape (F, 9, 9) with F >= 1, got {w.shape}")
        if len(w) >= 2**31:
            raise ValueError(f"words has {len(w)} fragments; at most 2**31 - 1 are supported")
        self.n_fragments = len(w)
        self.n_words = k
        flat = w.reshape(len(w), GRID * GRID)
        if flat.dtype != np.uint8 or not flat.flags.c_contiguous:
            flat = np.ascontiguousarray(flat, dtype=np.uint8 if k <= 256 else np.int64)
        dense_from = max(1, math.ceil(self.n_fragments * _DENSE_FRACTION))
        self.offsets, self.ids, self.counts, self.dense_row, self.dense = _build_postings(
            flat, pyramid_cells(), k, dense_from
        )
        if mean_motion is None:
            self._motion = None
        else:
            self._motion = _check_motion(mean_motion, self.n_fragments)
        self._ids = None
        if ids is not None:
            self._ids = np.asarray(ids, np.int64)
            if self._ids.shape != (self.n_fragments,) or np.any(np.diff(self._ids) <= 0):
                raise ValueError(
                    f"ids must be {self.n_fragments} increasing fragment ids, got shape "
                    f"{self._ids.shape}"
                )

    @property
    def nbytes(self):
        """Memory held by the posting lists, in bytes."""
        parts = (self.offsets, self.ids, self.counts, self.dense_row, self.dense)
        return sum(a.nbytes for a in parts)

    def __repr__(self):
        return (
            f"HistogramIndex(n_fragments={self.n_fragments}, n_words={self.n_words}, "
            f"nnz={len(self.ids)}, motion={self._motion is not None})"
        )

    def top_k(
        self,
        query_words,
        k,
        *,
        direction=None,
        speed=None,
        max_angle=45.0,
        max_speed_ratio=2.0,
    ):
        r"""The ``k`` database fragments with the largest intersection (Eq. 1), exactly.

        Parameters
        ----------
        query_words : array_like of int, shape (Q, 9, 9)
            The target fragments' visual-word maps.
        k : int
            :math:`K`, candidates per query (the paper: 100), ``1 <= k <= F``.
        direction : array_like, shape (Q, 2), optional
            Per query the user's flow direction (dy, dx) (any length, normalised
            here), or a row of NaN for none (Okabe et al., Fig. 8).
        speed : array_like, shape (Q,), optional
            Per query the user's speed in px/frame (>= 0), or NaN for none.
        max_angle : float
            Largest angle in degrees between a fragment's mean motion and the
            direction (``AnimateParams.max_angle``).
        max_speed_ratio : float
            Largest factor between a fragment's mean speed and the speed
            (``AnimateParams.max_speed_ratio``), >= 1.

        Returns
        -------
        TopK
            ``(ids, scores, n_eligible)``; see :class:`TopK`.
        """
        q = _check_words(query_words, self.n_words, name="query_words")
        if q.ndim != 3:
            raise ValueError(f"query_words must have shape (Q, 9, 9), got {q.shape}")
        n_top = check_int("k", k, 1, self.n_fragments)
        filt = _check_filter(
            len(q), direction, speed, max_angle, max_speed_ratio, self._motion is not None
        )
        motion, mag = (np.zeros((1, 2)), np.zeros(1)) if self._motion is None else self._motion
        ids = np.empty((len(q), n_top), np.int64)
        scores = np.empty((len(q), n_top), np.int32)
        n_eligible = np.empty(len(q), np.int64)
        flat = np.ascontiguousarray(q.reshape(len(q), GRID * GRID), dtype=np.int64)
        unit, speed, cos_max, ratio = filt

        def search(rows):
            _search(
                self.offsets,
                self.ids,
                self.counts,
                self.dense_row,
                self.dense,
                flat[rows],
                pyramid_cells(),
                self.n_words,
                self.n_fragments,
                motion,
                mag,
                unit[rows],
                speed[rows],
                cos_max,
                ratio,
                ids[rows],
                scores[rows],
                n_eligible[rows],
            )

        # Queries are independent: spread over the cores (the kernel releases the GIL,
        # each call has its own score buffer), in runs of _MIN_QUERIES or more rows
        # handed out as threads free up -- never one fixed share per thread, which
        # would wait for a thread whose core another process is using.
        workers = min(_workers(), max(1, len(q) // _MIN_QUERIES))
        if workers == 1:
            search(slice(0, len(q)))
        else:
            step = max(_MIN_QUERIES, -(-len(q) // (8 * workers)))
            runs = [slice(a, min(a + step, len(q))) for a in range(0, len(q), step)]
            with spread_pool(workers, "fluidnb-retrieval") as pool:
                list(pool.map(search, runs))
        if self._ids is not None:
            ids = self._ids[ids]
        return TopK(ids, scores, n_eligible)


# Each database's index, built on first use and kept while the database lives.
_INDEXES = weakref.WeakKeyDictionary()
_INDEXES_LOCK = threading.Lock()


def histogram_index(db):
    """The :class:`HistogramIndex` of a database's moving fragments, built on first use and kept.

    Parameters
    ----------
    db : VideoDatabase

    Returns
    -------
    HistogramIndex
        Over the word maps of ``db``'s :func:`moving_fragments` with their mean motion
        (the motion filter), its ids the database's, the same object for every call
        with the same opened database.
    """
    with _INDEXES_LOCK:
        index = _INDEXES.get(db)
    if index is None:
        moving = moving_fragments(db)
        if moving.all():
            index = HistogramIndex(db.words, db.params.words, mean_motion=db.mean_motion)
        else:
            index = HistogramIndex(
                np.asarray(db.words)[moving],
                db.params.words,
                mean_motion=np.asarray(db.mean_motion)[moving],
                ids=np.flatnonzero(moving),
            )
        with _INDEXES_LOCK:
            index = _INDEXES.setdefault(db, index)
    return index


#: A fragment whose median speed over its frames is below this share of the
#: database's median is still (:func:`moving_fragments`).
STILL = 0.1


def fragment_speeds(db):
    """Each fragment's median speed over its frames, px/frame: the median of ``|db.motion|``.

    Parameters
    ----------
    db : VideoDatabase

    Returns
    -------
    ndarray, shape (F,), float32
    """
    motion = np.asarray(db.motion, np.float32)
    return np.median(np.hypot(motion[..., 0], motion[..., 1]), axis=1).astype(np.float32)


def moving_fragments(db):
    r"""Which of the database's fragments move: the ones the assignment may choose.

    In the paper every database fragment is fluid, and moves. Footage of real scenes
    also holds still ones (the launch pad beside a rocket's plume, rocks in a
    stream: a fragment is kept when any of its pixels moves), and a photo's water
    looks like them: on a database built from two real clips the chosen fragments'
    median speed was 0.04 px/frame against the database's 6, and the photo barely
    moved (issue 35). A fragment whose :func:`fragment_speeds` is below
    :data:`STILL` times the database's median is left out (a slow database keeps
    its fragments: the bar is relative; at most half are left out).

    Parameters
    ----------
    db : VideoDatabase

    Returns
    -------
    ndarray of bool, shape (F,)

    Examples
    --------
    >>> from fluidnb.videodb import starter_database
    >>> bool(moving_fragments(starter_database("water", quick=True)).mean() > 0.95)
    True
    """
    speeds = fragment_speeds(db)
    return speeds >= np.float32(STILL) * np.median(speeds)


def _check_motion(mean_motion, n):
    m = check_array("mean_motion", mean_motion, ndim=2, dtype_kinds="iuf")
    if m.shape != (n, 2):
        raise ValueError(f"mean_motion must have shape ({n}, 2) as (dy, dx), got {m.shape}")
    m = np.ascontiguousarray(m, dtype=np.float64)
    return m, _speeds(m)


def _speeds(m):
    return np.sqrt(m[:, 0] * m[:, 0] + m[:, 1] * m[:, 1])


def _check_filter(n_queries, direction, speed, max_angle, max_speed_ratio, has_motion):
    """Per query: unit direction (NaN: none), speed (NaN: none); cos(max_angle), ratio."""
    max_angle = check_range("max_angle", max_angle, 0, 180)
    ratio = check_range("max_speed_ratio", max_speed_ratio, 1)
    if direction is None:
        unit = np.full((n_queries, 2), np.nan)
    else:
        d = check_array("direction", direction, ndim=2, dtype_kinds="iuf", finite=False)
        if d.shape != (n_queries, 2):
            raise ValueError(
                f"direction must have shape ({n_queries}, 2) as (dy, dx), got {d.shape}"
            )
        d = d.astype(np.float64)
        none = np.isnan(d).all(axis=1)
        given = ~none
        bad = given & ~(np.isfinite(d).all(axis=1) & (np.abs(d).max(axis=1) > 0))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"direction rows must be a nonzero finite (dy, dx) or all NaN (none), got "
                f"{d[i].tolist()} in row {i}"
            )
        unit = np.full((n_queries, 2), np.nan)
        unit[given] = d[given] / np.sqrt((d[given] ** 2).sum(axis=1))[:, None]
    if speed is None:
        s = np.full(n_queries, np.nan)
    else:
        s = check_array("speed", speed, ndim=1, dtype_kinds="iuf", finite=False)
        if s.shape != (n_queries,):
            raise ValueError(f"speed must have shape ({n_queries},), got {s.shape}")
        s = s.astype(np.float64)
        if np.isinf(s).any() or (s < 0).any():
            raise ValueError("speed must hold speeds >= 0 in px/frame, or NaN for none")
    wanted = (~np.isnan(unit[:, 0])).any() or (~np.isnan(s)).any()
    if wanted and not has_motion:
        raise ValueError(
            "a direction or speed filter needs the fragments' mean motions: build the "
            "HistogramIndex with mean_motion=..."
        )
    cos_max = math.cos(math.radians(max_angle))
    return np.ascontiguousarray(unit), np.ascontiguousarray(s), cos_max, ratio


@njit(cache=True, nogil=True)
def _fragment_bins(word_row, cells, k, hist, touched):
    """Fill ``hist`` with one fragment's nonzero bins; return how many (in ``touched``)."""
    n = 0
    for level in range(cells.shape[0]):
        weight = 2 if level == 2 else 1
        for j in range(word_row.shape[0]):
            d = cells[level, j] * k + word_row[j]
            # Branch-free (whether a bin is new is a coin toss: mispredicted branches
            # cost more than the rest of the loop).
            touched[n] = d
            n += 1 if hist[d] == 0 else 0
            hist[d] += weight
    return n


@njit(cache=True, nogil=True)
def _build_postings(words, cells, k, dense_from):
    """Posting lists of the pyramid histograms of (F, 81) word maps (two passes).

    Bins held by at least ``dense_from`` fragments get a dense row of counts instead.
    """
    n_frag = words.shape[0]
    dims = CELLS * k
    hist = np.zeros(dims, np.int64)
    touched = np.empty(3 * words.shape[1], np.int64)
    length = np.zeros(dims, np.int64)
    for f in range(n_frag):
        n = _fragment_bins(words[f], cells, k, hist, touched)
        for i in range(n):
            length[touched[i]] += 1
            hist[touched[i]] = 0
    dense_row = np.full(dims, -1, np.int64)
    n_dense = 0
    offsets = np.zeros(dims + 1, np.int64)
    for d in range(dims):
        if length[d] >= dense_from:
            dense_row[d] = n_dense
            n_dense += 1
            offsets[d + 1] = offsets[d]
        else:
            offsets[d + 1] = offsets[d] + length[d]
    ids = np.empty(offsets[dims], np.int32)
    counts = np.empty(offsets[dims], np.uint8)
    dense = np.zeros((n_dense, n_frag), np.uint8)
    cursor = offsets[:dims].copy()
    for f in range(n_frag):
        n = _fragment_bins(words[f], cells, k, hist, touched)
        for i in range(n):
            d = touched[i]
            if dense_row[d] >= 0:
                dense[dense_row[d], f] = hist[d]
            else:
                ids[cursor[d]] = f
                counts[cursor[d]] = hist[d]
                cursor[d] += 1
            hist[d] = 0
    return offsets, ids, counts, dense_row, dense


@njit(cache=True, nogil=True)
def _filter(motion, mag, uy, ux, s, cos_max, ratio, ok):
    """The motion filter (module notes) of every fragment into ``ok``; returns the count.

    The angle test is ``m . u >= (cos(max_angle) - slack) |m|`` (no division), the
    speed test ``max(|m|, s) <= ratio min(|m|, s) (1 + slack)``, exactly as
    :func:`fluidnb.videodb.assignment.reference_top_k` writes them.
    """
    use_dir = not math.isnan(uy)
    use_speed = not math.isnan(s)
    lim = cos_max - _SLACK
    n_ok = 0
    for f in range(mag.shape[0]):
        m = mag[f]
        good = True
        if use_dir:
            # & rather than and: no branches, the loop vectorises.
            good = (m >= MIN_MOTION) & (motion[f, 0] * uy + motion[f, 1] * ux >= lim * m)
        if use_speed:
            hi = m if m > s else s
            lo = m if m < s else s
            good = good & (hi <= ratio * lo * (1.0 + _SLACK))
        ok[f] = good
        n_ok += 1 if good else 0
    return n_ok


@njit(cache=True, nogil=True)
def _add_dense(score, row, c):
    """``score[f] += min(c, row[f])`` over all fragments (vectorises)."""
    for f in range(row.shape[0]):
        v = np.int16(row[f])
        score[f] += v if v < c else c


@njit(cache=True, nogil=True)
def _add_sparse(score, ids, counts, lo, hi, c):
    """``score[ids[j]] += min(c, counts[j])`` over one posting list.

    Four at a time, all loads before the stores: one at a time, each load waited on the
    previous store (the ids differ, but the processor cannot know it early), ~2x slower.
    Unsigned ids spare numba's negative-index check.
    """
    j = lo
    while j + 4 <= hi:
        f0, f1 = np.uint32(ids[j]), np.uint32(ids[j + 1])
        f2, f3 = np.uint32(ids[j + 2]), np.uint32(ids[j + 3])
        v0, v1 = np.int16(counts[j]), np.int16(counts[j + 1])
        v2, v3 = np.int16(counts[j + 2]), np.int16(counts[j + 3])
        s0 = score[f0] + (v0 if v0 < c else c)
        s1 = score[f1] + (v1 if v1 < c else c)
        s2 = score[f2] + (v2 if v2 < c else c)
        s3 = score[f3] + (v3 if v3 < c else c)
        score[f0], score[f1], score[f2], score[f3] = s0, s1, s2, s3
        j += 4
    while j < hi:
        f = np.uint32(ids[j])
        v = np.int16(counts[j])
        score[f] += v if v < c else c
        j += 1


@njit(cache=True, nogil=True)
def _search(
    offsets,
    post_ids,
    post_counts,
    dense_row,
    dense,
    queries,
    cells,
    k,
    n_frag,
    motion,
    mag,
    unit,
    speed,
    cos_max,
    ratio,
    out_ids,
    out_scores,
    n_eligible,
):
    """Exact top-K of every query by histogram intersection; see the module notes."""
    n_top = out_ids.shape[1]
    score = np.zeros(n_frag, np.int16)  # -1..324; 16 bits keep more of it in cache
    hist = np.zeros(CELLS * k, np.int64)
    touched = np.empty(3 * queries.shape[1], np.int64)
    per_score = np.zeros(HISTOGRAM_TOTAL + 1, np.int64)
    slot = np.zeros(HISTOGRAM_TOTAL + 1, np.int64)
    ok = np.ones(mag.shape[0], np.bool_)
    for q in range(queries.shape[0]):
        score[:] = 0
        n = _fragment_bins(queries[q], cells, k, hist, touched)
        for i in range(n):
            d = touched[i]
            c = np.int16(hist[d])
            hist[d] = 0
            if dense_row[d] >= 0:
                _add_dense(score, dense[dense_row[d]], c)
            else:
                _add_sparse(score, post_ids, post_counts, offsets[d], offsets[d + 1], c)
        # Motion filter: ineligible fragments' scores become -1 (none eligible: keep all).
        uy, ux, s = unit[q, 0], unit[q, 1], speed[q]
        n_ok = n_frag
        if not (math.isnan(uy) and math.isnan(s)):
            n_ok = _filter(motion, mag, uy, ux, s, cos_max, ratio, ok)
            if n_ok > 0:
                for f in range(n_frag):
                    if not ok[f]:
                        score[f] = -1
        n_eligible[q] = n_ok
        # Counting selection: the threshold score t of the top m, then ids in ascending
        # order (all above t, and the first ``need`` at t), placed by score.
        per_score[:] = 0
        for f in range(n_frag):
            if score[f] >= 0:
                per_score[score[f]] += 1
        m = min(n_top, n_ok if n_ok > 0 else n_frag)
        above = 0
        t = HISTOGRAM_TOTAL
        while above + per_score[t] < m:
            above += per_score[t]
            t -= 1
        need = m - above
        pos = 0
        for v in range(HISTOGRAM_TOTAL, t, -1):
            slot[v] = pos
            pos += per_score[v]
        slot[t] = pos
        for f in range(n_frag):
            v = score[f]
            if v > t or (v == t and need > 0):
                if v == t:
                    need -= 1
                out_ids[q, slot[v]] = f
                out_scores[q, slot[v]] = v
                slot[v] += 1
        for i in range(m, n_top):
            out_ids[q, i] = out_ids[q, 0]
            out_scores[q, i] = out_scores[q, 0]
