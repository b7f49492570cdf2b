r"""The assignment's steps as one would first write them, in numpy (Okabe et al., sec. 5; slow).

Each fast path of :mod:`fluidnb.videodb.assignment` (sparse posting lists, matrix
products in bulk, compiled sweeps over our own max-flow) has its plain version here,
in the paper's notation, one query, one pair or one node at a time. They are written
from the method, not from the fast path's code: this module imports none of the
assignment's kernels or helpers, only the grid's sizes, the retrieval's two published
thresholds, the result types, the database's spatial-pyramid histograms (Eq. 1's
:math:`H`) and PyMaxflow (the minimum cuts). So a test comparing a fast path with its
plain version fails when the fast path is broken (each test says which deliberate
breakage it catches); a reader finds the maths in its most readable form.

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

import math
import time

import maxflow
import numpy as np

from .._common._geometry import SPECTRA_BLOCK, SPECTRA_SIDE, TEXTURE_BLOCK, TEXTURE_SIDE
from ..database import pyramid_histograms
from ._mrf import SolverRun
from ._retrieval import _SLACK, MIN_MOTION, TopK
from ._smoothness import PairTables

__all__ = ["reference_alpha_expansion", "reference_icm", "reference_pair_tables", "reference_top_k"]


# -------------------------------------------------------------- retrieval (Eq. 1, Fig. 8)


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
    r""":meth:`HistogramIndex.top_k` written densely: every histogram, every score, a sort.

    For each query :math:`t`: the spatial-pyramid histograms :math:`H_e` of every
    database fragment and :math:`H_t` of the query, the histogram intersection
    :math:`I = \sum_i \min(H_e[i], H_t[i])` (Eq. 1) of every pair; the fragments whose
    mean motion :math:`m` disagrees with the query's direction :math:`u` (the angle
    between them above ``max_angle``: :math:`m \cdot u < \cos(\text{max\_angle})
    |m|`, or :math:`|m|` below 1e-6 px/frame) or speed :math:`s`
    (:math:`\max(|m|, s) > \text{max\_speed\_ratio} \min(|m|, s)`) left out, both
    within a relative 1e-12 as the index; the ``k`` best by score down, then id up,
    padded with the best when fewer are eligible (all fragments when none is).
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
        As :class:`HistogramIndex` and :meth:`HistogramIndex.top_k` (a direction row
        or speed of NaN: no filter for that query).

    Returns
    -------
    TopK
        The same ids, scores and eligible counts as the index's.
    """
    he = pyramid_histograms(words, n_words).astype(np.int64)  # (F, 21 k)
    ht = pyramid_histograms(query_words, n_words).astype(np.int64)  # (Q, 21 k)
    n_frag, n_q = len(he), len(ht)
    if not 1 <= int(k) <= n_frag:
        raise ValueError(f"k must be in [1, {n_frag}], got {k}")
    k = int(k)
    nan = np.full(n_q, np.nan)
    d = np.full((n_q, 2), np.nan) if direction is None else np.asarray(direction, float)
    s = nan if speed is None else np.asarray(speed, float)
    if mean_motion is None and not (np.isnan(d).all() and np.isnan(s).all()):
        raise ValueError("a direction or speed filter needs the fragments' mean motions")
    m = np.zeros((n_frag, 2)) if mean_motion is None else np.asarray(mean_motion, float)
    mag = np.sqrt(m[:, 0] ** 2 + m[:, 1] ** 2)
    cos_max = math.cos(math.radians(max_angle))
    ids = np.empty((n_q, k), np.int64)
    scores = np.empty((n_q, k), np.int32)
    n_eligible = np.empty(n_q, np.int64)
    for q in range(n_q):
        score = np.minimum(ht[q][None, :], he).sum(axis=1)  # Eq. (1)
        ok = np.ones(n_frag, bool)
        if not np.isnan(d[q]).all():
            u = d[q] / math.hypot(*d[q])  # the wanted direction, a unit vector
            along = m[:, 0] * u[0] + m[:, 1] * u[1]  # |m| cos(angle)
            ok &= (mag >= MIN_MOTION) & (along >= (cos_max - _SLACK) * mag)
        if not np.isnan(s[q]):
            hi, lo = np.maximum(mag, s[q]), np.minimum(mag, s[q])
            ok &= hi <= max_speed_ratio * lo * (1.0 + _SLACK)
        filtered = not (np.isnan(d[q]).all() and np.isnan(s[q]))
        n_eligible[q] = ok.sum() if filtered else n_frag
        pool = np.flatnonzero(ok) if ok.any() else np.arange(n_frag)
        order = pool[np.lexsort((pool, -score[pool]))][:k]  # score down, then id up
        order = np.concatenate([order, np.repeat(order[:1], k - len(order))])
        ids[q], scores[q] = order, score[order]
    return TopK(ids, scores, n_eligible)


# ------------------------------------------------------------ smoothness tables (Eq. 2, 3, 6)


def reference_pair_tables(candidates, edges, horizontal, spectra, texture):
    r"""The smoothness tables written out pair by pair (Eq. 2, 3 and 6), slowly.

    The literal definition that :func:`pair_tables` is tested against: for every edge,
    every label of ``p`` and every label of ``q``, the squared differences over the
    overlap :math:`\Omega` (the right half of ``p`` and the left half of ``q`` for a
    horizontal edge, the bottom and top halves for a vertical one) summed in float64,
    frequency bin by frequency bin, each block weighing its area (4 x 4 pixels for the
    spectra, 2 x 2 for the textureness). Arguments and result as :func:`pair_tables`;
    the fast path's entries are within a relative 1e-9 of these.
    """
    cand = np.asarray(candidates, np.int64)
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    hor = np.asarray(horizontal, bool)
    spectra, texture = np.asarray(spectra), np.asarray(texture)
    if len(hor) != len(edges) or cand.min() < 0 or cand.max() >= len(spectra):
        raise ValueError("horizontal must have one flag per edge, candidates valid ids")
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


# --------------------------------------------------------------- the MRF solvers (Eq. 4)


def _problem_arrays(unary, pairwise, edges, lam, init):
    """The problem as arrays, the start labelling and Eq. (4)'s energy of a labelling."""
    v = np.asarray(unary, np.float64)
    w = np.asarray(pairwise, np.float64)
    e = np.asarray(edges, np.int64).reshape(-1, 2)
    p, q = e[:, 0], e[:, 1]
    if w.shape != (len(e), *v.shape[1:] * 2) or lam < 0:
        raise ValueError("pairwise must be (E, K, K) for unary (P, K), lam >= 0")
    rows, each = np.arange(len(v)), np.arange(len(e))

    def energy(labels):
        """Eq. (4): sum_p V_p(l_p) + lam * sum_(p, q) W_pq(l_p, l_q)."""
        return float(v[rows, labels].sum() + lam * w[each, labels[p], labels[q]].sum())

    start = np.argmin(v, axis=1) if init is None else np.asarray(init, np.int64)
    return v, w, p, q, float(lam), energy, start.astype(np.int64).copy()


def reference_alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Alpha-expansion (Eq. 4), each move built in plain numpy and cut by PyMaxflow.

    What :func:`~fluidnb.videodb.assignment.alpha_expansion` computes, bit for bit (the
    tests check labels, energies, sweeps and the truncated share). For each
    :math:`\alpha` in turn, every node either keeps its label (:math:`x = 0`) or takes
    its :math:`\alpha`-th candidate (:math:`x = 1`); the move's binary energy per edge
    is :math:`(E_{00}, E_{01}, E_{10}, E_{11})`, truncated where it is non-submodular
    (Rother et al. 2005), and written as a graph (Kolmogorov & Zabih 2004) whose
    minimum cut (PyMaxflow's Boykov-Kolmogorov max-flow) is the move, kept only if the
    true energy falls. Sweeps repeat until one brings no improvement.

    The fast path does the same in compiled code, its own Boykov-Kolmogorov max-flow
    (:mod:`fluidnb.videodb.assignment._maxflow`) following the library's steps so that
    the residuals, hence the cuts, are the same to the bit; it also skips a move that
    failed on the same labels (it would fail again). Arguments and result as
    :func:`~fluidnb.videodb.assignment.alpha_expansion` (without ``progress``).
    """
    t0 = time.perf_counter()
    v, w, p, q, lam, energy, labels = _problem_arrays(unary, pairwise, edges, lam, init)
    n_nodes, n_labels = v.shape
    rows, each = np.arange(n_nodes), np.arange(len(p))

    def move_terms(labels, alpha):
        lp, lq = labels[p], labels[q]
        # The move's binary energy per edge: x = 0 keeps the label, x = 1 takes alpha.
        e00 = lam * w[each, lp, lq]
        e01 = lam * w[each, lp, alpha]
        e10 = lam * w[each, alpha, lq]
        e11 = lam * w[each, alpha, alpha]
        cap = e01 + e10 - e00 - e11
        bad = cap < 0
        free = (lp != alpha) & (lq != alpha)
        # Rother et al. 2005: lower E11 to E01 + E10 - E00 (a lower bound of the true
        # move energy, exact at x = 0); the true energy is checked after the cut.
        e11 = np.where(bad, e01 + e10 - e00, e11)
        cap = np.where(bad, 0.0, cap)
        # Kolmogorov & Zabih 2004: E = E00 + (E10 - E00) x_p + (E11 - E10) x_q
        #                              + cap (1 - x_p) x_q.
        cost1 = v[:, alpha] - v[rows, labels]
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

    current = energy(labels)
    energies = [current]
    truncated = free_terms = sweeps = 0
    for _ in range(int(max_sweeps)):
        improved = False
        for alpha in range(n_labels):
            cap, cost1, n_trunc, n_free = move_terms(labels, alpha)
            truncated += n_trunc
            free_terms += n_free
            take = min_cut(cap, cost1) & (labels != alpha)
            if take.any():
                proposal = np.where(take, alpha, labels)
                new = energy(proposal)
                if new < current:
                    labels, current, improved = proposal, new, True
        sweeps += 1
        energies.append(current)
        if not improved:
            break
    share = truncated / free_terms if free_terms else 0.0
    return SolverRun(labels, np.array(energies), sweeps, share, time.perf_counter() - t0)


def reference_icm(unary, pairwise, edges, lam, *, init=None, max_sweeps=20):
    r"""Iterated conditional modes (Eq. 4) node by node, in plain numpy (Besag 1986).

    What :func:`~fluidnb.videodb.assignment.icm` computes, bit for bit: in raster order,
    each node takes the label minimising :math:`V_p(l) + \lambda \sum_q W_{pq}` with its
    neighbours fixed (a strict decrease only), sweep after sweep until one changes
    nothing; the energy after every sweep (the sweeps counted as the fast path counts
    them; its sweep is compiled). Arguments and result as
    :func:`~fluidnb.videodb.assignment.icm` (without ``progress``).
    """
    t0 = time.perf_counter()
    v, w, p, q, lam, energy, labels = _problem_arrays(unary, pairwise, edges, lam, init)
    n_nodes = len(v)
    # For node n: (edge, other node) pairs where n is p (a column of W[e]) or q (a row).
    as_p = [[] for _ in range(n_nodes)]
    as_q = [[] for _ in range(n_nodes)]
    for e, (a, b) in enumerate(zip(p.tolist(), q.tolist())):
        as_p[a].append((e, b))
        as_q[b].append((e, a))

    energies = [energy(labels)]
    sweeps = 0
    for _ in range(int(max_sweeps)):
        changed = False
        for n in range(n_nodes):
            cost = v[n].copy()
            for e, m in as_p[n]:
                cost += lam * w[e, :, labels[m]]
            for e, m in as_q[n]:
                cost += lam * w[e, labels[m], :]
            best = int(np.argmin(cost))
            if cost[best] < cost[labels[n]]:
                labels[n] = best
                changed = True
        sweeps += 1
        energies.append(energy(labels))
        if not changed:
            break
    return SolverRun(labels, np.array(energies), sweeps, 0.0, time.perf_counter() - t0)
