r"""The assignment's steps as one would first write them, in numpy (Okabe et al., sec. 5; slow).

Each fast path of :mod:`fluidnb.videodb.assignment` (sparse posting lists, matrix
products in bulk, compiled sweeps over our own max-flow) has its plain version here,
in the paper's notation, one query, one pair or one node at a time; the tests check the
fast path against it, and a reader finds the maths in its most readable form.

=================================  ================================================
plain version                      fast path (tested against it)
=================================  ================================================
:func:`reference_top_k`            :meth:`~fluidnb.videodb.assignment.HistogramIndex.top_k`
:func:`reference_pair_tables`      :func:`~fluidnb.videodb.assignment.pair_tables`
:func:`reference_alpha_expansion`  :func:`~fluidnb.videodb.assignment.alpha_expansion`
:func:`reference_icm`              :func:`~fluidnb.videodb.assignment.icm`
=================================  ================================================

How closely each pair agrees is said in each function's docstring.
"""

from __future__ import annotations

import time

import maxflow
import numpy as np

from ..._progress import Progress
from ..._validation import check_int
from .._common._geometry import SPECTRA_BLOCK, SPECTRA_SIDE, TEXTURE_BLOCK, TEXTURE_SIDE
from ..database._words import pyramid_histograms
from ._icm import _icm
from ._mrf import _finished, _problem, _start
from ._retrieval import _SLACK, MIN_MOTION, TopK, _check_filter
from ._smoothness import PairTables, _check_tables_input

__all__ = ["reference_alpha_expansion", "reference_icm", "reference_pair_tables", "reference_top_k"]


def reference_top_k(
    words,
    n_words,
    query_words,
    k,
    *,
    mean_motion=None,
    direction=None,
    speed=None,
    max_angle=45.0,
    max_speed_ratio=2.0,
):
    """:meth:`HistogramIndex.top_k` written densely: every histogram, every score, a sort.

    Memory (Q, F, 21 k): for the tests' small databases only.

    Parameters
    ----------
    words : array_like of int, shape (F, 9, 9)
    n_words : int
        The codebook's size :math:`k`.
    query_words : array_like of int, shape (Q, 9, 9)
    k : int
        Candidates per query.
    mean_motion, direction, speed, max_angle, max_speed_ratio
        As :class:`HistogramIndex` and :meth:`HistogramIndex.top_k`.

    Returns
    -------
    TopK
    """
    he = pyramid_histograms(words, n_words).astype(np.int64)  # (F, 21 k)
    k = check_int("k", k, 1, len(he))
    ht = pyramid_histograms(query_words, n_words).astype(np.int64)  # (Q, 21 k)
    n_frag, n_q = len(he), len(ht)
    has_motion = mean_motion is not None
    unit, s, cos_max, ratio = _check_filter(
        n_q, direction, speed, max_angle, max_speed_ratio, has_motion
    )
    if has_motion:
        m = np.asarray(mean_motion, dtype=np.float64)
        mag = np.sqrt(m[:, 0] * m[:, 0] + m[:, 1] * m[:, 1])
    ids = np.empty((n_q, k), np.int64)
    scores = np.empty((n_q, k), np.int32)
    n_eligible = np.empty(n_q, np.int64)
    for q in range(n_q):
        score = np.minimum(ht[q][None, :], he).sum(axis=1)  # Eq. (1)
        ok = np.ones(n_frag, bool)
        if not np.isnan(unit[q, 0]):
            dot = m[:, 0] * unit[q, 0] + m[:, 1] * unit[q, 1]  # |m| cos(angle)
            ok &= (mag >= MIN_MOTION) & (dot >= (cos_max - _SLACK) * mag)
        if not np.isnan(s[q]):
            hi, lo = np.maximum(mag, s[q]), np.minimum(mag, s[q])
            ok &= hi <= ratio * lo * (1.0 + _SLACK)
        filtered = not (np.isnan(unit[q, 0]) and np.isnan(s[q]))
        n_eligible[q] = ok.sum() if filtered else n_frag
        pool = np.flatnonzero(ok) if ok.any() else np.arange(n_frag)
        order = pool[np.lexsort((pool, -score[pool]))][:k]  # score down, then id up
        order = np.concatenate([order, np.repeat(order[:1], k - len(order))])
        ids[q], scores[q] = order, score[order]
    return TopK(ids, scores, n_eligible)


def reference_pair_tables(candidates, edges, horizontal, spectra, texture):
    r"""The smoothness tables written out pair by pair (Eq. 2, 3 and 6), slowly.

    The literal definition that :func:`pair_tables` is tested against: for every edge,
    every label of ``p`` and every label of ``q``, the squared differences over the
    overlap :math:`\Omega` summed in float64, frequency bin by frequency bin.
    Arguments and result as :func:`pair_tables`.
    """
    cand, edges, hor, spectra, texture = _check_tables_input(
        candidates, edges, horizontal, spectra, texture
    )
    n_edges, k = len(edges), cand.shape[1]
    n_bins = spectra.shape[1]
    dc = np.zeros((n_edges, k, k))
    rest = np.zeros((n_edges, k, k))
    tex = np.zeros((n_edges, k, k))
    hs, ht = SPECTRA_SIDE // 2, TEXTURE_SIDE // 2
    for e in range(n_edges):
        p, q = edges[e]
        for i in range(k):
            m_i = spectra[cand[p, i]].astype(np.float64)  # M^ of label i: (NB, 2, 12, 12)
            t_i = texture[cand[p, i]].astype(np.float64)  # T of label i: (L, 24, 24)
            for j in range(k):
                m_j = spectra[cand[q, j]].astype(np.float64)
                t_j = texture[cand[q, j]].astype(np.float64)
                if hor[e]:  # Omega: right half of p, left half of q
                    mp, mq = m_i[:, :, :, hs:], m_j[:, :, :, :hs]
                    tp, tq = t_i[:, :, ht:], t_j[:, :, :ht]
                else:  # Omega: bottom half of p, top half of q
                    mp, mq = m_i[:, :, hs:, :], m_j[:, :, :hs, :]
                    tp, tq = t_i[:, ht:, :], t_j[:, :ht, :]
                # Eq. (3), with the block areas 4 x 4 (spectra) and 2 x 2 (texture).
                dc[e, i, j] = SPECTRA_BLOCK**2 * np.sum((mp[0] - mq[0]) ** 2)
                for f in range(1, n_bins):
                    rest[e, i, j] += SPECTRA_BLOCK**2 * np.sum((mp[f] - mq[f]) ** 2)
                tex[e, i, j] = TEXTURE_BLOCK**2 * np.sum((tp - tq) ** 2)
    return PairTables(dc=dc, rest=rest, tex=tex, edges=edges.copy(), horizontal=hor.copy())


def reference_alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Alpha-expansion (Eq. 4), each move built in plain numpy and cut by PyMaxflow.

    What :func:`~fluidnb.videodb.assignment.alpha_expansion` computes, bit for bit (the tests
    check labels, energies, sweeps and the truncated share). For each :math:`\alpha`
    in turn, every node either keeps its label (:math:`x = 0`) or takes its
    :math:`\alpha`-th candidate (:math:`x = 1`); the move's binary energy per edge is
    :math:`(E_{00}, E_{01}, E_{10}, E_{11})`, truncated where it is non-submodular
    (Rother et al. 2005), and written as a graph (Kolmogorov & Zabih 2004) whose
    minimum cut (PyMaxflow's Boykov-Kolmogorov max-flow) is the move, kept only if the
    true energy falls. Sweeps repeat until one brings no improvement.

    The fast path does the same in compiled code, its own Boykov-Kolmogorov max-flow
    (:mod:`fluidnb.videodb.assignment._maxflow`) following the library's steps so that the
    residuals, hence the cuts, are the same to the bit; it also skips a move that
    failed on the same labels (it would fail again). Arguments and result as
    :func:`~fluidnb.videodb.assignment.alpha_expansion` (without ``progress``).
    """
    t0 = time.perf_counter()
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    prob = _problem(unary, pairwise, edges, lam)
    p, q, lam, n_nodes = prob.p, prob.q, prob.lam, prob.n_nodes
    rows = np.arange(n_nodes)

    def move_terms(labels, alpha):
        lp, lq = labels[p], labels[q]
        # The move's binary energy per edge: x = 0 keeps the label, x = 1 takes alpha.
        e00 = lam * prob.pair(lp, lq)
        e01 = lam * prob.pair(lp, alpha)
        e10 = lam * prob.pair(alpha, lq)
        e11 = lam * prob.pair(alpha, alpha)
        cap = e01 + e10 - e00 - e11
        bad = cap < 0
        free = (lp != alpha) & (lq != alpha)
        # Rother et al. 2005: lower E11 to E01 + E10 - E00 (a lower bound of the true
        # move energy, exact at x = 0); the true energy is checked after the cut.
        e11 = np.where(bad, e01 + e10 - e00, e11)
        cap = np.where(bad, 0.0, cap)
        # Kolmogorov & Zabih 2004: E = E00 + (E10 - E00) x_p + (E11 - E10) x_q
        #                              + cap (1 - x_p) x_q.
        cost1 = prob.unary[:, alpha] - prob.unary[rows, labels]
        cost1 = cost1 + np.bincount(p, e10 - e00, minlength=n_nodes)
        cost1 += np.bincount(q, e11 - e10, minlength=n_nodes)
        return cap, cost1, np.count_nonzero(bad & free), np.count_nonzero(free)

    def min_cut(cap, cost1):
        """Which nodes take alpha (x = 1, the sink side) by the move's minimum cut."""
        g = maxflow.Graph[float](n_nodes, len(p))
        nodes = g.add_nodes(n_nodes)
        g.add_edges(nodes[p], nodes[q], cap, np.zeros(len(p)))
        # A node in the sink segment (x = 1) pays its source capacity.
        g.add_grid_tedges(nodes, np.maximum(cost1, 0.0), np.maximum(-cost1, 0.0))
        g.maxflow()
        return g.get_grid_segments(nodes)

    labels = _start(prob, init).copy()
    current = prob.energy(labels)
    energies = [current]
    truncated = free_terms = sweeps = 0
    for _ in range(max_sweeps):
        improved = False
        for alpha in range(prob.n_labels):
            cap, cost1, n_trunc, n_free = move_terms(labels, alpha)
            truncated += n_trunc
            free_terms += n_free
            take = min_cut(cap, cost1) & (labels != alpha)
            if take.any():
                proposal = np.where(take, alpha, labels)
                new = prob.energy(proposal)
                if new < current:
                    labels, current, improved = proposal, new, True
        sweeps += 1
        energies.append(current)
        if not improved:
            break
    return _finished(labels, energies, sweeps, t0, truncated, free_terms)


def reference_icm(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Iterated conditional modes (Eq. 4) node by node, in plain numpy.

    What :func:`~fluidnb.videodb.assignment.icm` computes, bit for bit: in raster order, each
    node takes the label minimising :math:`V_p(l) + \lambda \sum_q W_{pq}` with its
    neighbours fixed (a strict decrease only), sweep after sweep until nothing
    changes (the sweeps are counted as the fast path does; its sweep is compiled).
    Arguments and result as :func:`~fluidnb.videodb.assignment.icm` (without ``progress``).
    """
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    prob = _problem(unary, pairwise, edges, lam)
    lam, w = prob.lam, prob.pairwise
    # For node n: (edge, other node) pairs where n is p (a column of W[e]) or q (a row).
    as_p = [[] for _ in range(prob.n_nodes)]
    as_q = [[] for _ in range(prob.n_nodes)]
    for e, (a, b) in enumerate(zip(prob.p.tolist(), prob.q.tolist())):
        as_p[a].append((e, b))
        as_q[b].append((e, a))

    def sweep(labels):
        changed = False
        for n in range(prob.n_nodes):
            cost = prob.unary[n].copy()
            for e, m in as_p[n]:
                cost += lam * w[e, :, labels[m]]
            for e, m in as_q[n]:
                cost += lam * w[e, labels[m], :]
            best = int(np.argmin(cost))
            if cost[best] < cost[labels[n]]:
                labels[n] = best
                changed = True
        return changed

    return _icm(prob, _start(prob, init), max_sweeps, Progress(None), sweep=sweep)
