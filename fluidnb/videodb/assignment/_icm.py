r"""Iterated conditional modes (Besag 1986) on the assignment's MRF (Eq. 4), each sweep compiled.

In raster order each node takes the label minimising :math:`V_p(l) + \lambda \sum_q
W_{pq}` with its neighbours fixed, sweep after sweep until nothing changes.
:func:`~fluidnb.videodb.assignment.reference_icm` is the same node by node in numpy.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

from ..._progress import Progress
from ..._validation import check_int
from ._mrf import _finished, _problem, _start, _w_at, _w_shape

__all__ = ["icm"]


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
                cost[lab] += lam * _w_at(w, e, lp, lab)
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
                    col[e, a] = _w_at(w, e, a, best)
    return changed


@njit(cache=True, nogil=True)
def _columns(w, labels, q):
    """``col[e, a]`` = :math:`W_e(a, l_q)`, each edge's column for its ``q``'s label."""
    n_edges, k = _w_shape(w)
    col = np.empty((n_edges, k))
    for e in range(n_edges):
        lq = labels[q[e]]
        for a in range(k):
            col[e, a] = _w_at(w, e, a, lq)
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


def _icm(prob, labels, max_sweeps, report):
    """Iterated conditional modes in raster order, sweep after sweep until none changes.

    Each sweep (:func:`_icm_sweep`, compiled) visits every node once, in place.
    """
    t0 = time.perf_counter()
    labels = labels.copy()
    sweep = _compiled_icm_sweep(prob, labels)
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
