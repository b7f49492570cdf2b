r"""The assignment's MRF (Okabe et al., sec. 5, Eq. 4-5): its grid, its energy, its exact minimum.

Every target fragment :math:`p` (a node of a 4-connected grid, :func:`grid_edges`)
takes one of its :math:`K` candidate database fragments (its labels, ranked by
appearance, Eq. 1). The labelling minimises

.. math::

    E(l) = \sum_p V_p(l_p) + \lambda \sum_{(p, q)} W_{pq}(l_p, l_q)            \quad (4)

    V_p(l) = 1 - I(H_p, H_l)                                                    \quad (5)

with :math:`W_{pq}` the smoothness term of Eq. (6), computed in bulk by
:func:`~fluidnb.videodb.assignment.pair_tables`. This module takes ``unary`` and
``pairwise`` as given.

Decision (spec 05, section 2): the data term is :math:`V_p = 1 - I` with the
normalised histogram intersection :math:`I \in [0, 1]`. The paper writes
:math:`V_p = I` (Eq. 5), which a minimisation would turn into a reward for
*dissimilar* fragments; the caller passes :math:`1 - I`.

Here: the grid (:func:`grid_edges`), the problem checked once (:class:`_Problem`), the
energy (:func:`energy`), the solvers' common result (:class:`SolverRun`) and exhaustive
search for tiny problems (:func:`brute_force`). The solvers: alpha-expansion over label
indices (:mod:`fluidnb.videodb.assignment._expansion`), iterated conditional modes
(:mod:`~fluidnb.videodb.assignment._icm`) and the spec's recipe combining them
(:mod:`~fluidnb.videodb.assignment._solve`).

Labels are per-node candidate *indices* (node :math:`p`'s label :math:`\alpha` is its
:math:`\alpha`-th candidate, a different fragment from node :math:`q`'s), so
:math:`W` is not a metric.

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

import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit, types
from numba.extending import overload

from ..._validation import check_array, check_finite, check_int, check_range

__all__ = ["SolverRun", "brute_force", "energy", "grid_edges"]


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
        # A float32 W's values summed in float64, as the compiled sweeps sum them.
        pair = self.pair(labels[self.p], labels[self.q]).astype(np.float64, copy=False)
        return float(data + self.lam * pair.sum())

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


#: The exponent bits of a float32.
_EXPONENT32 = np.uint32(0x7F800000)


@njit(cache=True, nogil=True)
def _all_finite32(bits):
    """:func:`_all_finite` of float32 values (``bits`` viewed as uint32)."""
    top = np.uint32(0)
    for b in bits:
        top = max(top, b & _EXPONENT32)
    return top != _EXPONENT32


def _finite(w):
    """Whether a contiguous float64 or float32 array holds no NaN or infinity."""
    if w.dtype == np.float32:
        return _all_finite32(w.reshape(-1).view(np.uint32))
    return _all_finite(w.reshape(-1).view(np.uint64))


def _problem(unary, pairwise, edges, lam, *, finite=False):
    """The checked problem; ``finite``: W (contiguous) is known finite.

    W is kept in float32 if given so (:meth:`PairTables.smoothness` with
    ``dtype=np.float32``: the solvers read it as exact float64 values), else float64.
    """
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
    w = np.ascontiguousarray(w, dtype=np.float32 if w.dtype == np.float32 else np.float64)
    if not finite and not _finite(w):
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


def _w_at(w, e, i, j):
    """:math:`W_e(i, j)`: ``w[e, i, j]``, or from the three tables (:class:`_TablesProblem`).

    The solvers read O(E K) entries of W per sweep (the rows and columns of the
    current labels); combining all E K^2 of them first cost more than a re-solve's
    sweeps (:meth:`~fluidnb.videodb.Assignment.resolve`).
    """
    if isinstance(w, tuple):
        dc, rest, tex, sigma, rho_scaled = w
        value = rest[e, i, j] * sigma
        value += dc[e, i, j]
        return value + rho_scaled * tex[e, i, j]
    return w[e, i, j]


@overload(_w_at, jit_options={"nogil": True})
def _w_at_compiled(w, e, i, j):
    if isinstance(w, types.BaseTuple):
        # PairTables.smoothness's _combine, entry by entry: the same operations in the
        # same order, so the same bits as reading the combined table.
        def at(w, e, i, j):
            dc, rest, tex, sigma, rho_scaled = w
            value = rest[e, i, j] * sigma
            value += dc[e, i, j]
            return value + rho_scaled * tex[e, i, j]

        return at
    return lambda w, e, i, j: w[e, i, j]


def _w_shape(w):
    """(E, K) of W, an array or a :class:`_TablesProblem`'s tables."""
    first = w[0] if isinstance(w, tuple) else w
    return first.shape[0], first.shape[1]


@overload(_w_shape, jit_options={"nogil": True})
def _w_shape_compiled(w):
    if isinstance(w, types.BaseTuple):
        return lambda w: (w[0].shape[0], w[0].shape[1])
    return lambda w: (w.shape[0], w.shape[1])


@dataclass(frozen=True, eq=False)
class _TablesProblem(_Problem):
    """A :class:`_Problem` whose W is read from the three tables where needed.

    ``pairwise`` is ``(dc, rest, tex, sigma, rho_scaled)``
    ; an entry is
    ``rest * sigma + dc + rho_scaled * tex`` in :meth:`PairTables.smoothness`'s order,
    so the same bits as the combined table.
    """

    def pair(self, lp, lq):
        dc, rest, tex, sigma, rho_scaled = self.pairwise
        e = np.arange(len(self.p))
        value = rest[e, lp, lq] * sigma
        value += dc[e, lp, lq]
        return value + rho_scaled * tex[e, lp, lq]


def _tables_problem(unary, tables, sigma, rho_scaled, edges, lam):
    """:class:`_TablesProblem` of the kept tables (finite: checked when they were made)."""
    v = check_array("unary", unary, ndim=2, dtype_kinds="biuf")
    e = _check_edges(edges, v.shape[0])
    if tables.dc.shape != (len(e), v.shape[1], v.shape[1]):
        raise ValueError(
            f"tables must have shape (E, K, K) = ({len(e)}, {v.shape[1]}, {v.shape[1]}), "
            f"got {tables.dc.shape}"
        )
    w = tuple(np.ascontiguousarray(t, np.float64) for t in (tables.dc, tables.rest, tables.tex))
    return _TablesProblem(
        unary=np.asarray(v, dtype=np.float64),
        pairwise=(*w, float(sigma), float(rho_scaled)),
        p=e[:, 0].copy(),
        q=e[:, 1].copy(),
        lam=check_range("lam", lam, 0),
        flat=None,
        base=None,
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


def _start(prob, init):
    if init is None:
        return prob.argmin()
    return _check_labels("init", init, prob.n_nodes, prob.n_labels)


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
