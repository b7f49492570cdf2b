r"""The assignment MRF of the video-database method and its solvers (Okabe et al., sec. 5).

Every target fragment :math:`p` (a node of a 4-connected grid, :func:`grid_edges`)
takes one of its :math:`K` candidate database fragments (its labels, ranked by
appearance, Eq. 1). The labelling minimises

.. math::

    E(l) = \sum_p V_p(l_p) + \lambda \sum_{(p, q)} W_{pq}(l_p, l_q)            \quad (4)

    V_p(l) = 1 - I(H_p, H_l)                                                    \quad (5)

with :math:`W_{pq}` the smoothness term of Eq. (6), computed in bulk by
:func:`fluidnb.videodb.pair_tables` (:mod:`fluidnb.videodb._smoothness`). This module
takes ``unary`` and ``pairwise`` as given.

Decision (spec 05, section 2): the data term is :math:`V_p = 1 - I` with the
normalised histogram intersection :math:`I \in [0, 1]`. The paper writes
:math:`V_p = I` (Eq. 5), which a minimisation would turn into a reward for
*dissimilar* fragments; the caller passes :math:`1 - I`.

The energy (:func:`energy`) and its solvers: alpha-expansion over label indices
(:func:`alpha_expansion`: each sweep of moves compiled, every move's minimum cut by our
Boykov-Kolmogorov max-flow, :mod:`fluidnb.videodb._maxflow`), iterated conditional
modes (:func:`icm`), the spec's recipe combining them (:func:`solve`), and exhaustive
search for tiny problems (:func:`brute_force`). The plain versions,
:func:`fluidnb.videodb.reference_alpha_expansion` (numpy and PyMaxflow) and
:func:`fluidnb.videodb.reference_icm`, give the same labels and energies to the bit.

Labels are per-node candidate *indices* (node :math:`p`'s label :math:`\alpha` is its
:math:`\alpha`-th candidate, a different fragment from node :math:`q`'s), so
:math:`W` is not a metric and an expansion move's binary energy is often not
submodular (measured: 20-50 % of its pairwise terms on real-sized problems). Such
terms are truncated by lowering :math:`E_{11}` to :math:`E_{01} + E_{10} - E_{00}`
(Rother et al. 2005), which makes the move energy a lower bound of the true one that
is exact at the current labelling; a move is accepted only if the true energy drops,
so no move can raise it.

References
----------
.. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Pacific Graphics 2011 (Computer Graphics Forum 30(7)).
.. [2] Y. Boykov, O. Veksler, R. Zabih, "Fast approximate energy minimization via
   graph cuts", IEEE TPAMI 23(11), 2001.
.. [3] V. Kolmogorov, R. Zabih, "What energy functions can be minimized via graph
   cuts?", IEEE TPAMI 26(2), 2004.
.. [4] C. Rother, S. Kumar, V. Kolmogorov, A. Blake, "Digital tapestry", CVPR 2005.
.. [5] J. Besag, "On the statistical analysis of dirty pictures", J. Royal
   Statistical Society B 48(3), 1986.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FuturesTimeout
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ..._progress import Cancelled, Progress
from ..._threads import usable_cores
from ..._validation import check_array, check_finite, check_int, check_range
from .._common._sums import _pairwise_sum
from . import _maxflow

__all__ = [
    "MRFSolution",
    "SolverRun",
    "alpha_expansion",
    "brute_force",
    "energy",
    "grid_edges",
    "icm",
    "solve",
]


# --------------------------------------------------------------------------- grid


def grid_edges(active):
    r"""Nodes and 4-neighbour edges of the fragments taking part in the MRF.

    Parameters
    ----------
    active : array_like of bool, shape (R, C)
        Which target fragments (on the stride grid) are nodes of the MRF.

    Returns
    -------
    nodes : ndarray of int64, shape (P, 2)
        (row, col) of each node in raster order; node ``i`` is ``nodes[i]``.
    edges : ndarray of int64, shape (E, 2)
        Node-index pairs ``(p, q)`` of neighbours with ``p`` left of or above ``q``,
        sorted by ``(p, q)``.
    horizontal : ndarray of bool, shape (E,)
        True where ``p`` is left of ``q`` (their overlap :math:`\Omega` is ``p``'s
        right half and ``q``'s left half), False where ``p`` is above ``q``.

    Examples
    --------
    >>> nodes, edges, horizontal = grid_edges([[1, 1, 0], [1, 1, 1]])
    >>> nodes.tolist()
    [[0, 0], [0, 1], [1, 0], [1, 1], [1, 2]]
    >>> edges.tolist(), horizontal.tolist()
    ([[0, 1], [0, 2], [1, 3], [2, 3], [3, 4]], [True, False, False, True, True])
    """
    arr = check_array("active", active, ndim=2, dtype_kinds="biuf")
    act = arr.astype(bool)
    nodes = np.argwhere(act).astype(np.int64)
    index = np.full(act.shape, -1, dtype=np.int64)
    index[act] = np.arange(len(nodes))
    right = act[:, :-1] & act[:, 1:]
    down = act[:-1, :] & act[1:, :]
    h = np.stack([index[:, :-1][right], index[:, 1:][right]], axis=1)
    v = np.stack([index[:-1, :][down], index[1:, :][down]], axis=1)
    edges = np.concatenate([h, v]).reshape(-1, 2)
    horizontal = np.concatenate([np.ones(len(h), bool), np.zeros(len(v), bool)])
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    return nodes, edges[order], horizontal[order]


# ----------------------------------------------------------------------- energy


def _check_edges(edges, n_nodes):
    arr = check_array("edges", edges, ndim=2, dtype_kinds="iu", min_size=0)
    if arr.shape[1:] != (2,):
        raise ValueError(f"edges must have shape (E, 2), got {arr.shape}")
    if arr.size and (arr.min() < 0 or arr.max() >= n_nodes):
        raise ValueError(
            f"edges must hold node indices in [0, {n_nodes - 1}], "
            f"got values in [{arr.min()}, {arr.max()}]"
        )
    if np.any(arr[:, 0] == arr[:, 1]):
        raise ValueError("edges must join two different nodes, got an edge (p, p)")
    return arr.astype(np.int64)


def _check_labels(name, labels, n_nodes, n_labels):
    arr = check_array(name, labels, ndim=1, dtype_kinds="iu")
    if arr.shape != (n_nodes,):
        raise ValueError(f"{name} must have shape ({n_nodes},), got {arr.shape}")
    if arr.min() < 0 or arr.max() >= n_labels:
        raise ValueError(
            f"{name} must be label indices in [0, {n_labels - 1}], "
            f"got values in [{arr.min()}, {arr.max()}]"
        )
    return arr.astype(np.int64)


@dataclass(frozen=True, eq=False)
class _Problem:
    """A validated MRF: float64 unary (P, K), flat pairwise, edges, lam."""

    unary: np.ndarray
    pairwise: np.ndarray
    p: np.ndarray
    q: np.ndarray
    lam: float
    flat: np.ndarray = field(repr=False)
    base: np.ndarray = field(repr=False)

    @property
    def n_nodes(self):
        return self.unary.shape[0]

    @property
    def n_labels(self):
        return self.unary.shape[1]

    def pair(self, lp, lq):
        """W_e(lp[e], lq[e]) for every edge e (lp, lq arrays or scalars)."""
        return self.flat[self.base + lp * self.n_labels + lq]

    def energy(self, labels):
        """Eq. (4): sum_p V_p(l_p) + lam * sum_(p, q) W_pq(l_p, l_q)."""
        data = self.unary[np.arange(self.n_nodes), labels].sum()
        return float(data + self.lam * self.pair(labels[self.p], labels[self.q]).sum())

    def argmin(self):
        return np.argmin(self.unary, axis=1).astype(np.int64)


#: The exponent bits of a float64: all set in NaN and infinities only.
_EXPONENT = np.uint64(0x7FF0000000000000)


@njit(cache=True, nogil=True)
def _all_finite(bits):
    """Whether none of the float64 values (``bits``, viewed as uint64) is NaN or infinite.

    An integer maximum over the exponent bits, which the compiler vectorises: 0.5 ms
    for the app's 25 MB table, where numpy's ``isfinite(w).all()`` took 1.2 ms.
    """
    top = np.uint64(0)
    for b in bits:
        top = max(top, b & _EXPONENT)
    return top != _EXPONENT


def _problem(unary, pairwise, edges, lam):
    v = check_array("unary", unary, ndim=2, dtype_kinds="biuf")
    w = check_array("pairwise", pairwise, ndim=3, dtype_kinds="biuf", min_size=0, finite=False)
    n_nodes, k = v.shape
    e = _check_edges(edges, n_nodes)
    if w.shape != (len(e), k, k):
        raise ValueError(
            f"pairwise must have shape (E, K, K) = ({len(e)}, {k}, {k}) for {len(e)} edges "
            f"and unary of shape {v.shape}, got {w.shape}"
        )
    lam = check_range("lam", lam, 0)
    w = np.ascontiguousarray(w, dtype=np.float64)
    if not _all_finite(w.reshape(-1).view(np.uint64)):
        check_finite("pairwise", w)  # raises, counting the values
    return _Problem(
        unary=np.asarray(v, dtype=np.float64),
        pairwise=w,
        p=e[:, 0].copy(),
        q=e[:, 1].copy(),
        lam=lam,
        flat=w.reshape(-1),
        base=np.arange(len(e), dtype=np.int64) * (k * k),
    )


def energy(labels, unary, pairwise, edges, lam):
    r"""The MRF energy of a labelling, Eq. (4).

    .. math:: E(l) = \sum_p V_p(l_p) + \lambda \sum_{(p,q)} W_{pq}(l_p, l_q)

    Parameters
    ----------
    labels : array_like of int, shape (P,)
        Each node's label index in ``[0, K)``.
    unary : array_like, shape (P, K)
        :math:`V_p(l)`, the data term. For the video-database method the caller
        passes :math:`V_p = 1 - I` (Eq. 5 with the spec's decision: the paper's
        :math:`V_p = I` would reward dissimilar candidates under minimisation).
    pairwise : array_like, shape (E, K, K)
        :math:`W_{pq}(l_p, l_q)` of each edge (:meth:`PairTables.smoothness`), indexed
        ``[e, label of p, label of q]``.
    edges : array_like of int, shape (E, 2)
        The node pairs ``(p, q)``.
    lam : float
        :math:`\lambda` of Eq. (4), >= 0.

    Returns
    -------
    float

    Examples
    --------
    >>> unary = [[0.0, 1.0], [0.5, 0.0]]
    >>> pairwise = [[[0.0, 2.0], [2.0, 0.0]]]  # Potts on one edge
    >>> energy([0, 1], unary, pairwise, [[0, 1]], lam=0.5)
    1.0
    """
    prob = _problem(unary, pairwise, edges, lam)
    return prob.energy(_check_labels("labels", labels, prob.n_nodes, prob.n_labels))


# ---------------------------------------------------------------------- solvers


@dataclass(frozen=True, eq=False)
class SolverRun:
    """One run of a move-making solver (:func:`alpha_expansion` or :func:`icm`).

    Attributes
    ----------
    labels : ndarray of int64, shape (P,)
        The final labelling (label indices).
    energies : ndarray of float64, shape (sweeps + 1,)
        Eq. (4)'s energy at the start and after every sweep; never increasing.
    sweeps : int
        Sweeps run (the last one brought no improvement unless ``max_sweeps`` stopped
        the run).
    nonsubmodular : float
        Fraction of the expansion moves' pairwise terms (over edges whose both nodes
        could move) that were not submodular and were truncated; 0 for ICM.
    seconds : float
        Wall-clock time of the run.
    """

    labels: np.ndarray
    energies: np.ndarray
    sweeps: int
    nonsubmodular: float
    seconds: float

    @property
    def energy(self):
        """The final energy, ``energies[-1]``."""
        return float(self.energies[-1])


def _finished(labels, energies, sweeps, t0, truncated=0, free_terms=0):
    """The :class:`SolverRun` of a run started at ``t0`` (``time.perf_counter()``)."""
    return SolverRun(
        labels=labels,
        energies=np.array(energies),
        sweeps=sweeps,
        nonsubmodular=truncated / free_terms if free_terms else 0.0,
        seconds=time.perf_counter() - t0,
    )


@njit(cache=True, nogil=True)
def _move_terms(unary, labels, p, q, lam, alpha, tables, cap, cost1, sp, sq):
    """One expansion move's graph terms in one pass over the edges.

    As :func:`~fluidnb.videodb.reference_alpha_expansion` builds them with numpy:
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
    n_edges, k = w.shape[0], w.shape[1]
    diag = np.empty((k, n_edges))
    for e in range(n_edges):
        for a in range(k):
            diag[a, e] = w[e, a, a]
    return diag


@njit(cache=True, nogil=True)
def _label_tables(w, labels, p, q, diag):
    """The values of W a move reads, per edge, for the current labels.

    ``now[e]`` = :math:`W_e(l_p, l_q)`, ``row[a, e]`` = :math:`W_e(l_p, a)`,
    ``col[a, e]`` = :math:`W_e(a, l_q)`, and ``diag`` (:func:`_diagonal`, which does
    not depend on the labels): label-major, so a move (one ``a``) reads each in edge
    order. :func:`_relabel` keeps them up to date as labels change.
    """
    n_edges, k = w.shape[0], w.shape[1]
    now = np.empty(n_edges)
    row, col = np.empty((k, n_edges)), np.empty((k, n_edges))
    for e in range(n_edges):
        lp, lq = labels[p[e]], labels[q[e]]
        now[e] = w[e, lp, lq]
        for a in range(k):
            row[a, e] = w[e, lp, a]
            col[a, e] = w[e, a, lq]
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
    k = w.shape[1]
    for e in range(p.shape[0]):
        now[e] = pair[e]
        lp, lq = proposal[p[e]], proposal[q[e]]
        if lp != labels[p[e]]:
            for a in range(k):
                row[a, e] = w[e, lp, a]
        if lq != labels[q[e]]:
            for a in range(k):
                col[a, e] = w[e, a, lq]
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
    (:func:`~fluidnb.videodb._maxflow.maxflow`: the nodes on the sink side take alpha)
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


@njit(cache=True, nogil=True)
def _icm_sweep(unary, w, lam, labels, p, ptr_p, edge_p, ptr_q, edge_q, col, cost):
    r"""One ICM sweep in node order: the sums of ``reference_icm`` in the same order.

    Node ``n``'s costs add :math:`W_e(\cdot, l_q)` where ``n`` is edge ``e``'s ``p``,
    read from ``col[e]`` (a copy of that column, updated when ``q`` changes, so that
    the sums run over contiguous values), and :math:`W_e(l_p, \cdot)` where it is its
    ``q``, a row of ``w``.
    """
    n_nodes, k = unary.shape
    changed = False
    for n in range(n_nodes):
        for lab in range(k):
            cost[lab] = unary[n, lab]
        for i in range(ptr_p[n], ptr_p[n + 1]):
            e = edge_p[i]
            for lab in range(k):
                cost[lab] += lam * col[e, lab]
        for i in range(ptr_q[n], ptr_q[n + 1]):
            e = edge_q[i]
            lp = labels[p[e]]
            for lab in range(k):
                cost[lab] += lam * w[e, lp, lab]
        best = 0
        for lab in range(1, k):
            if cost[lab] < cost[best]:  # the first minimum, as np.argmin
                best = lab
        if cost[best] < cost[labels[n]]:
            labels[n] = best
            changed = True
            for i in range(ptr_q[n], ptr_q[n + 1]):
                e = edge_q[i]
                for a in range(k):
                    col[e, a] = w[e, a, best]
    return changed


@njit(cache=True, nogil=True)
def _columns(w, labels, q):
    """``col[e, a]`` = :math:`W_e(a, l_q)`, each edge's column for its ``q``'s label."""
    n_edges, k = w.shape[0], w.shape[1]
    col = np.empty((n_edges, k))
    for e in range(n_edges):
        lq = labels[q[e]]
        for a in range(k):
            col[e, a] = w[e, a, lq]
    return col


def _compiled_icm_sweep(prob, labels):
    """``sweep(labels) -> changed``: one ICM sweep by :func:`_icm_sweep` (in place)."""
    n_nodes = prob.n_nodes
    # For node n, its edges where it is p and where it is q, each in edge order (a
    # stable sort), as compressed rows.
    incident = []
    for me in (prob.p, prob.q):
        ptr = np.zeros(n_nodes + 1, np.int64)
        np.cumsum(np.bincount(me, minlength=n_nodes), out=ptr[1:])
        incident += [ptr, np.argsort(me, kind="stable").astype(np.int64)]
    w = prob.pairwise
    unary = np.ascontiguousarray(prob.unary)
    col = _columns(w, labels, prob.q)
    cost = np.empty(prob.n_labels)
    return lambda labels: _icm_sweep(unary, w, prob.lam, labels, prob.p, *incident, col, cost)


def _icm(prob, labels, max_sweeps, report, sweep=None):
    """Iterated conditional modes in raster order, sweep after sweep until none changes.

    ``sweep(labels) -> changed`` visits every node once, in place (default
    :func:`_icm_sweep`, compiled; :func:`~fluidnb.videodb.reference_icm` passes it
    written with numpy).
    """
    t0 = time.perf_counter()
    labels = labels.copy()
    sweep = _compiled_icm_sweep(prob, labels) if sweep is None else sweep
    energies = [prob.energy(labels)]
    sweeps = 0
    for i in range(max_sweeps):
        changed = sweep(labels)
        sweeps += 1
        energies.append(prob.energy(labels))
        report((i + 1) / max_sweeps, f"ICM sweep {i + 1}")
        if not changed:
            break
    return _finished(labels, energies, sweeps, t0)


def _start(prob, init):
    if init is None:
        return prob.argmin()
    return _check_labels("init", init, prob.n_nodes, prob.n_labels)


def alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20, progress=None):
    r"""Minimise Eq. (4) by alpha-expansion moves over label indices.

    Boykov, Veksler & Zabih's expansion: for each :math:`\alpha = 0 \ldots K-1` in turn,
    every node either keeps its label or takes its own :math:`\alpha`-th candidate,
    whichever a minimum cut of the move's binary energy says (Kolmogorov & Zabih's
    construction; the cut by Boykov & Kolmogorov's max-flow, the same cut PyMaxflow
    gives, :mod:`fluidnb.videodb._maxflow`; each sweep in compiled code). Because labels
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


def icm(unary, pairwise, edges, lam, *, init=None, max_sweeps=20, progress=None):
    r"""Minimise Eq. (4) by iterated conditional modes (Besag 1986), the baseline.

    Visits the nodes in raster order and gives each the label minimising its part of
    Eq. (4) with its neighbours fixed (changing only on a strict decrease, so the
    energy never rises); sweeps until nothing changes or ``max_sweeps``.

    Parameters
    ----------
    unary, pairwise, edges, lam
        As :func:`alpha_expansion`.
    init : array_like of int, shape (P,), optional
        Starting labelling; default the unary argmin.
    max_sweeps : int
        Largest number of sweeps.
    progress : callable, optional
        ``progress(fraction, message)``, called after every sweep.

    Returns
    -------
    SolverRun
        ``nonsubmodular`` is 0.

    References
    ----------
    .. [5] J. Besag, "On the statistical analysis of dirty pictures", J. Royal
       Statistical Society B 48(3), 1986.
    """
    prob = _problem(unary, pairwise, edges, lam)
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    return _icm(prob, _start(prob, init), max_sweeps, Progress(progress))


@dataclass(frozen=True, eq=False)
class MRFSolution:
    """The result of :func:`solve`.

    Attributes
    ----------
    labels : ndarray of int64, shape (P,)
        The labelling of lower energy (label indices into each node's candidates).
    energy : float
        Its energy, Eq. (4).
    energies : ndarray of float64
        The winning expansion run's energy at its start and after every sweep.
    icm_energy : float
        The energy ICM reached from the unary argmin (``energy <= icm_energy``).
    start : str
        ``"argmin"`` or ``"icm"``: which start the winning expansion ran from.
    nonsubmodular : float
        Fraction of truncated move terms in the winning run.
    sweeps : int
        Sweeps of the winning run.
    timings : dict
        Seconds spent in ``"icm"``, ``"expansion_argmin"`` and ``"expansion_icm"``.
    """

    labels: np.ndarray
    energy: float
    energies: np.ndarray
    icm_energy: float
    start: str
    nonsubmodular: float
    sweeps: int
    timings: dict


def solve(unary, pairwise, edges, lam, *, max_sweeps=20, progress=None):
    r"""Minimise Eq. (4) the spec's way: alpha-expansion from two starts, keep the lower.

    Runs ICM from the unary argmin, then :func:`alpha_expansion` once from the unary
    argmin and once from ICM's result, and keeps the labelling of lower energy (the
    argmin start on a tie). Since expansion never raises the energy, the result is
    never worse than ICM. The run from the argmin does not wait for ICM: on two or
    more cores it runs on a thread of its own beside the other two (the same result,
    ~30 % sooner at the app's size).

    Parameters
    ----------
    unary, pairwise, edges, lam
        As :func:`alpha_expansion`.
    max_sweeps : int
        Largest number of sweeps of each run.
    progress : callable, optional
        ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops.

    Returns
    -------
    MRFSolution

    Examples
    --------
    >>> unary = [[0.0, 0.5], [0.6, 0.0], [0.6, 0.0]]
    >>> potts = [[[0.0, 1.0], [1.0, 0.0]]] * 2
    >>> result = solve(unary, potts, [[0, 1], [1, 2]], lam=1.0)
    >>> result.labels.tolist(), result.energy, result.icm_energy
    ([1, 1, 1], 0.5, 0.5)
    """
    prob = _problem(unary, pairwise, edges, lam)
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    report = Progress(progress)
    stage_icm, stage_b, stage_a = report.split(0.1, 0.55)
    start = prob.argmin()
    diag = _diagonal(prob.pairwise)  # the same for both runs

    def from_start(report):
        return _expand(prob, start, max_sweeps, report, tables=_tables(prob, start, diag))

    def from_icm_result():
        base = _icm(prob, start, max_sweeps, stage_icm)
        tables = _tables(prob, base.labels, diag)
        return base, _expand(prob, base.labels, max_sweeps, stage_b, tables=tables)

    if _side_by_side(prob):
        base, from_icm, from_argmin = _beside(from_start, from_icm_result, stage_a)
    else:
        base, from_icm = from_icm_result()
        from_argmin = from_start(stage_a)
    best, name = (from_argmin, "argmin")
    if from_icm.energy < from_argmin.energy:
        best, name = (from_icm, "icm")
    report(1.0, "MRF solved")
    return MRFSolution(
        labels=best.labels,
        energy=best.energy,
        energies=best.energies,
        icm_energy=base.energy,
        start=name,
        nonsubmodular=best.nonsubmodular,
        sweeps=best.sweeps,
        timings={
            "icm": base.seconds,
            "expansion_argmin": from_argmin.seconds,
            "expansion_icm": from_icm.seconds,
        },
    )


#: Problems with fewer node labels (P K) than this are solved on one thread (a thread
#: costs ~0.1 ms; at the app's 171 x 100 the second one saves ~3 of 10 ms).
_SIDE_BY_SIDE = 4096


def _side_by_side(prob):
    """Whether :func:`solve` runs its two expansions on two threads."""
    return len(usable_cores()) > 1 and prob.n_nodes * prob.n_labels >= _SIDE_BY_SIDE


def _beside(aside, main, report):
    """``aside(report)`` on a thread of its own while ``main()`` runs here.

    The expansions release the GIL, so the two run at once on two cores. The caller's
    ``report`` is only called from this thread: while waiting for ``aside``, with its
    progress (so raising :class:`Cancelled` stops both; ``aside`` stops at its next
    report). Returns ``(*main(), aside(...))``.
    """
    stop = threading.Event()
    done = [0.0]

    def relay(fraction, message):  # aside's reports, on its thread
        if stop.is_set():
            raise Cancelled("stopped with the other run")
        done[0] = fraction

    with ThreadPoolExecutor(1, thread_name_prefix="fluidnb-mrf") as pool:
        future = pool.submit(aside, relay)
        try:
            result = main()
            while True:
                try:
                    return (*result, future.result(timeout=0.05))
                except FuturesTimeout:
                    report(done[0], "alpha-expansion from the unary argmin")
        except BaseException:
            stop.set()
            raise


def brute_force(unary, pairwise, edges, lam, *, max_labelings=1 << 20):
    r"""The exact minimum of Eq. (4) by trying every labelling (tiny problems only).

    Parameters
    ----------
    unary, pairwise, edges, lam
        As :func:`alpha_expansion`.
    max_labelings : int
        Refuse problems with more than this many labellings (:math:`K^P`).

    Returns
    -------
    labels : ndarray of int64, shape (P,)
        A minimiser (the first in lexicographic order, node 0 most significant).
    energy : float
        Its energy (computed as :func:`energy` does).

    Raises
    ------
    ValueError
        If :math:`K^P` exceeds ``max_labelings``.

    Examples
    --------
    >>> unary = [[0.0, 0.5], [0.6, 0.0], [0.6, 0.0]]
    >>> potts = [[[0.0, 1.0], [1.0, 0.0]]] * 2
    >>> labels, value = brute_force(unary, potts, [[0, 1], [1, 2]], lam=1.0)
    >>> labels.tolist(), value
    ([1, 1, 1], 0.5)
    """
    prob = _problem(unary, pairwise, edges, lam)
    max_labelings = check_int("max_labelings", max_labelings, 1)
    n_nodes, k = prob.n_nodes, prob.n_labels
    total = k**n_nodes
    if total > max_labelings:
        raise ValueError(
            f"brute_force needs K**P = {k}**{n_nodes} = {total} labellings, more than "
            f"max_labelings = {max_labelings}; use solve() for problems of this size"
        )
    rows = np.arange(n_nodes)
    best_value, best_index = np.inf, 0
    chunk = 1 << 16
    for start in range(0, total, chunk):
        index = np.arange(start, min(start + chunk, total))
        lab = np.stack(np.unravel_index(index, (k,) * n_nodes), axis=1)
        values = prob.unary[rows, lab].sum(axis=1)
        values = values + prob.lam * prob.pair(lab[:, prob.p], lab[:, prob.q]).sum(axis=1)
        i = int(np.argmin(values))
        if values[i] < best_value:
            best_value, best_index = values[i], int(index[i])
    labels = np.array(np.unravel_index(best_index, (k,) * n_nodes), dtype=np.int64)
    return labels, prob.energy(labels)
