r"""Alpha-expansion over label indices (Boykov, Veksler & Zabih 2001), each sweep compiled.

For each :math:`\alpha` in turn every node keeps its label or takes its own
:math:`\alpha`-th candidate, whichever the minimum cut of the move's binary energy
says (Kolmogorov & Zabih 2004), cut by our Boykov-Kolmogorov max-flow
(:mod:`fluidnb.videodb.assignment._maxflow`). Labels are per-node candidate indices, so
:math:`W` is not a metric and a move's binary energy is often not submodular
(measured: 20-50 % of its pairwise terms on real-sized problems). Such terms are
truncated by lowering :math:`E_{11}` to :math:`E_{01} + E_{10} - E_{00}` (Rother et
al. 2005), which makes the move energy a lower bound of the true one that is exact at
the current labelling; a move is accepted only if the true energy (Eq. 4) drops, so no
move can raise it. :func:`~fluidnb.videodb.assignment.reference_alpha_expansion` is the
same in plain numpy with PyMaxflow's cuts.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

from ..._progress import Progress
from ..._validation import check_int
from .._common._sums import _pairwise_sum
from . import _maxflow
from ._mrf import _finished, _problem, _start, _w_at, _w_shape

__all__ = ["alpha_expansion"]


@njit(cache=True, nogil=True)
def _move_terms(unary, labels, p, q, lam, alpha, tables, cap, cost1, sp, sq):
    """One expansion move's graph terms in one pass over the edges.

    As :func:`~fluidnb.videodb.assignment.reference_alpha_expansion` builds them with numpy:
    writes the (truncated) pairwise capacities ``cap`` and the nodes' cost of taking
    alpha ``cost1``, with the same operations in the same order (so the same bits);
    returns (truncated terms, free terms). The four values of :math:`W_{pq}` each edge
    needs come from :func:`_label_tables` (rows read in order, not four scattered
    reads of the (E, K, K) table).
    """
    now, row, col, diag = tables
    n_nodes = unary.shape[0]
    truncated = 0
    free_terms = 0
    for n in range(n_nodes):
        sp[n] = 0.0
        sq[n] = 0.0
    for e in range(p.shape[0]):
        lp = labels[p[e]]
        lq = labels[q[e]]
        e00 = lam * now[e]
        e01 = lam * row[alpha, e]
        e10 = lam * col[alpha, e]
        e11 = lam * diag[alpha, e]
        c = e01 + e10 - e00 - e11
        free = lp != alpha and lq != alpha
        if free:
            free_terms += 1
        if c < 0:
            if free:
                truncated += 1
            e11 = e01 + e10 - e00  # Rother et al.'s truncation
            c = 0.0
        cap[e] = c
        sp[p[e]] += e10 - e00
        sq[q[e]] += e11 - e10
    for n in range(n_nodes):
        cost1[n] = (unary[n, alpha] - unary[n, labels[n]]) + sp[n] + sq[n]
    return truncated, free_terms


@njit(cache=True, nogil=True)
def _diagonal(w):
    """``diag[a, e]`` = :math:`W_e(a, a)`, label-major (see :func:`_label_tables`)."""
    n_edges, k = _w_shape(w)
    diag = np.empty((k, n_edges))
    for e in range(n_edges):
        for a in range(k):
            diag[a, e] = _w_at(w, e, a, a)
    return diag


@njit(cache=True, nogil=True)
def _label_tables(w, labels, p, q, diag):
    """The values of W a move reads, per edge, for the current labels.

    ``now[e]`` = :math:`W_e(l_p, l_q)`, ``row[a, e]`` = :math:`W_e(l_p, a)`,
    ``col[a, e]`` = :math:`W_e(a, l_q)`, and ``diag`` (:func:`_diagonal`, which does
    not depend on the labels): label-major, so a move (one ``a``) reads each in edge
    order. :func:`_relabel` keeps them up to date as labels change.
    """
    n_edges, k = p.shape[0], diag.shape[0]
    now = np.empty(n_edges)
    row, col = np.empty((k, n_edges)), np.empty((k, n_edges))
    for e in range(n_edges):
        lp, lq = labels[p[e]], labels[q[e]]
        now[e] = _w_at(w, e, lp, lq)
        for a in range(k):
            row[a, e] = _w_at(w, e, lp, a)
            col[a, e] = _w_at(w, e, a, lq)
    return now, row, col, diag


def _tables(prob, labels, diag=None):
    """:func:`_label_tables` of ``labels`` (with ``diag`` if already made)."""
    diag = _diagonal(prob.pairwise) if diag is None else diag
    return _label_tables(prob.pairwise, labels, prob.p, prob.q, diag)


@njit(cache=True, nogil=True)
def _relabel(w, labels, proposal, p, q, tables, pair):
    """Take ``proposal`` (the move's labels) and bring :func:`_label_tables` up to date.

    ``pair[e]`` holds :math:`W_e` of the proposal (:func:`_energy` left it there).
    """
    now, row, col, _ = tables
    k = row.shape[0]
    for e in range(p.shape[0]):
        now[e] = pair[e]
        lp, lq = proposal[p[e]], proposal[q[e]]
        if lp != labels[p[e]]:
            for a in range(k):
                row[a, e] = _w_at(w, e, lp, a)
        if lq != labels[q[e]]:
            for a in range(k):
                col[a, e] = _w_at(w, e, a, lq)
    labels[:] = proposal


@njit(cache=True, nogil=True)
def _energy(unary, proposal, alpha, p, q, lam, tables, data, pair):
    """Eq. (4) of an expansion move's labels as :meth:`_Problem.energy` computes it.

    The same values summed in the same order (numpy's, :func:`_pairwise_sum`), so the
    same bits; each edge's :math:`W_e` is looked up in :func:`_label_tables` (a node
    either kept its label or took alpha). ``data`` and ``pair`` are scratch space of P
    and E values (``pair`` is left holding each edge's :math:`W_e`).
    """
    now, row, col, diag = tables
    for n in range(unary.shape[0]):
        data[n] = unary[n, proposal[n]]
    for e in range(p.shape[0]):
        at_p, at_q = proposal[p[e]] == alpha, proposal[q[e]] == alpha
        if at_p and at_q:
            pair[e] = diag[alpha, e]
        elif at_p:
            pair[e] = col[alpha, e]
        elif at_q:
            pair[e] = row[alpha, e]
        else:
            pair[e] = now[e]
    return _pairwise_sum(data) + lam * _pairwise_sum(pair)


@njit(cache=True, nogil=True)
def _expansion_sweep(w, unary, p, q, lam, graph, labels, current, changes, failed, scratch, work):
    """One sweep of alpha-expansion moves over every alpha, in place.

    For each alpha: the move's graph terms (:func:`_move_terms`), its minimum cut
    (:func:`~fluidnb.videodb.assignment._maxflow.maxflow`: the nodes on the sink side take alpha)
    and, if some node moves, the true energy (:func:`_energy`), the move kept only if
    it drops. ``failed[0, alpha]`` is the number of moves made (the labels' version)
    when alpha last failed, -1 if never, ``failed[1:, alpha]`` that move's truncated
    and free terms: a move that failed is not tried again on the same labels (it
    would build the same graph and fail the same way). ``scratch`` holds the
    :func:`_label_tables` of ``labels``, kept up to date. Returns (whether a move was
    made, the energy, moves made so far, and this sweep's truncated terms, free terms
    and cuts).
    """
    n_nodes, k = unary.shape
    n_edges = len(p)
    start, head, sister, slot = graph
    tables, (r_cap, cap, tr_cap, sp, sq, data, pair) = scratch
    proposal = np.empty(n_nodes, np.int64)
    improved = False
    truncated = free_terms = cuts = 0
    for alpha in range(k):
        if failed[0, alpha] == changes:
            truncated += failed[1, alpha]
            free_terms += failed[2, alpha]
            continue
        # A node on the sink side (x = 1) pays its source capacity: the node's
        # terminal residual (source minus sink capacity) is its cost of taking alpha.
        n_trunc, n_free = _move_terms(unary, labels, p, q, lam, alpha, tables, cap, tr_cap, sp, sq)
        truncated += n_trunc
        free_terms += n_free
        for e in range(n_edges):  # the edge's arcs p -> q and q -> p
            r_cap[slot[2 * e]] = cap[e]
            r_cap[slot[2 * e + 1]] = 0.0
        _maxflow.maxflow(start, head, sister, r_cap, tr_cap, work)
        cuts += 1
        moves = False
        for n in range(n_nodes):
            take = work[0, n] != -1 and work[4, n] != 0 and labels[n] != alpha
            proposal[n] = alpha if take else labels[n]
            moves |= take
        moved = False
        if moves:
            new = _energy(unary, proposal, alpha, p, q, lam, tables, data, pair)
            if new < current:
                _relabel(w, labels, proposal, p, q, tables, pair)
                current = new
                changes += 1
                moved = improved = True
        if not moved:
            failed[0, alpha] = changes
            failed[1, alpha] = n_trunc
            failed[2, alpha] = n_free
    return improved, current, changes, truncated, free_terms, cuts


def _expand(prob, labels, max_sweeps, report, counts=None, tables=None):
    """Alpha-expansion over label indices with Rother-style truncation, compiled.

    Sweeps over every alpha until one brings no improvement, each sweep one call of
    :func:`_expansion_sweep` (moves, cuts and energies in compiled code); Python only
    between sweeps, to report progress (and so to cancel). ``tables``: the
    :func:`_label_tables` of ``labels`` if already made (they are updated in place).
    ``counts``, a dict, gets the number of minimum cuts computed (``"cuts"``).
    """
    t0 = time.perf_counter()
    n_nodes, k, n_edges = prob.n_nodes, prob.n_labels, len(prob.p)
    unary = np.ascontiguousarray(prob.unary)
    graph = _maxflow.arcs(n_nodes, prob.p, prob.q)
    work = _maxflow.workspace(n_nodes)
    labels = labels.copy()
    buffers = (np.empty(2 * n_edges), np.empty(n_edges))
    buffers += tuple(np.empty(n_nodes) for _ in range(4)) + (np.empty(n_edges),)
    scratch = (_tables(prob, labels) if tables is None else tables, buffers)
    failed = np.full((3, k), -1, np.int64)
    current = prob.energy(labels)
    energies = [current]
    truncated = free_terms = changes = sweeps = cuts = 0
    for sweep in range(max_sweeps):
        improved, current, changes, n_trunc, n_free, n_cuts = _expansion_sweep(
            prob.pairwise, unary, prob.p, prob.q, prob.lam, graph, labels, current, changes,
            failed, scratch, work,
        )  # fmt: skip
        truncated += n_trunc
        free_terms += n_free
        cuts += n_cuts
        sweeps += 1
        energies.append(current)
        report((sweep + 1) / max_sweeps, f"alpha-expansion sweep {sweep + 1}")
        if not improved:
            break
    if counts is not None:
        counts["cuts"] = cuts
    return _finished(labels, energies, sweeps, t0, truncated, free_terms)


def alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20, progress=None):
    r"""Minimise Eq. (4) by alpha-expansion moves over label indices.

    Boykov, Veksler & Zabih's expansion: for each :math:`\alpha = 0 \ldots K-1` in turn,
    every node either keeps its label or takes its own :math:`\alpha`-th candidate,
    whichever a minimum cut of the move's binary energy says (Kolmogorov & Zabih's
    construction; the cut by Boykov & Kolmogorov's max-flow, the same cut PyMaxflow
    gives, :mod:`fluidnb.videodb.assignment._maxflow`; each sweep in compiled code). Because labels
    are per-node candidate indices, :math:`W` is not a metric and a move's pairwise
    term :math:`(E_{00}, E_{01}, E_{10}, E_{11})` may be non-submodular
    (:math:`E_{01} + E_{10} < E_{00} + E_{11}`); such terms are truncated by lowering
    :math:`E_{11}` to :math:`E_{01} + E_{10} - E_{00}` (Rother et al. 2005), and a
    move is accepted only if the true energy (Eq. 4) drops. Sweeps over all
    :math:`\alpha` repeat until one brings no improvement or ``max_sweeps``.

    When every move is submodular (e.g. a metric :math:`W` shared by all nodes, or two
    labels with submodular edges), this is the original algorithm, which reaches a
    local minimum within a factor :math:`2c` of the optimum for metrics [2]_ and the
    optimum itself for two labels and submodular edges.

    Parameters
    ----------
    unary : array_like, shape (P, K)
        :math:`V_p(l)` (for the video-database method :math:`1 - I`, see :func:`energy`).
    pairwise : array_like, shape (E, K, K)
        :math:`W_{pq}(l_p, l_q)`, indexed ``[e, label of p, label of q]``.
    edges : array_like of int, shape (E, 2)
        Node pairs ``(p, q)``.
    lam : float
        :math:`\lambda` of Eq. (4), >= 0.
    init : array_like of int, shape (P,), optional
        Starting labelling; default the unary argmin.
    max_sweeps : int
        Largest number of sweeps over all :math:`\alpha`.
    progress : callable, optional
        ``progress(fraction, message)``, called after every sweep; raising
        :class:`fluidnb.Cancelled` stops.

    Returns
    -------
    SolverRun
        Labels, the energy after every sweep, the fraction of truncated terms.

    References
    ----------
    .. [2] Boykov, Veksler, Zabih, "Fast approximate energy minimization via graph
       cuts", IEEE TPAMI 2001; Kolmogorov & Zabih, IEEE TPAMI 2004; Rother, Kumar,
       Kolmogorov, Blake, "Digital tapestry", CVPR 2005.

    Examples
    --------
    >>> unary = [[0.0, 0.5], [0.6, 0.0], [0.6, 0.0]]
    >>> potts = [[[0.0, 1.0], [1.0, 0.0]]] * 2
    >>> run = alpha_expansion(unary, potts, [[0, 1], [1, 2]], lam=1.0)
    >>> run.labels.tolist(), run.energies.tolist()
    ([1, 1, 1], [1.0, 0.5, 0.5])
    """
    prob = _problem(unary, pairwise, edges, lam)
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    return _expand(prob, _start(prob, init), max_sweeps, Progress(progress))
