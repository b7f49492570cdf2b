r"""Minimum s-t cuts by Boykov and Kolmogorov's augmenting-path algorithm, compiled.

Each alpha-expansion move of the assignment MRF (:mod:`fluidnb.videodb.assignment._mrf`) is the
minimum cut of a small graph: one node per target fragment, one edge per pair of
neighbours, and each node joined to the source :math:`s` and the sink :math:`t`. The
algorithm of Boykov & Kolmogorov [1]_ keeps two search trees of non-saturated
(residual) arcs, :math:`S` rooted at the source and :math:`T` at the sink, and
repeats three stages:

- *growth*: active nodes (the trees' frontier) take free neighbours they reach through
  residual arcs into their tree, until an arc joins :math:`S` to :math:`T`: a path
  :math:`s \to t`;
- *augmentation*: the path's bottleneck capacity is pushed along it; the arcs it
  saturates cut nodes off their trees (*orphans*);
- *adoption*: each orphan looks for a new parent in its tree (a neighbour that still
  reaches the tree's root, the nearest one preferred) or becomes free, its children
  orphans in turn.

It stops when no active node is left: no path remains, the flow is maximal, and the
nodes in :math:`T` are exactly those that can still reach the sink in the residual
graph. They form the sink side of the minimum cut (:math:`x = 1`); the others,
:math:`S` and the free nodes, the source side.

The cut must be the very one of Kolmogorov's maxflow library (v3.0x, as PyMaxflow wraps
it), which :func:`fluidnb.videodb.assignment.reference_alpha_expansion` uses, so the conventions
are that library's:

- edge ``e`` (``p -> q``) is the arcs ``2 e`` (``p -> q``, capacity ``cap``) and
  ``2 e + 1`` (``q -> p``, ``rev_cap``), and a node's arcs are visited in the reverse
  of the order they were added (:func:`arcs`);
- a node's two terminal arcs are kept as one signed residual ``tr = source - sink``
  (``tr > 0``: residual from :math:`s`; ``tr < 0``: residual to :math:`t`);
- active nodes are served first in, first out (nodes activated while a queue is
  served wait for the next); a node that found a path stays the growing node until
  its arcs are exhausted;
- adoption takes the orphans of an augmentation from the root's end of the path
  first (each then with the orphans it makes, first in, first out); an orphan's new
  parent is the neighbour with the shortest distance to the root (the first such in
  arc order); distances are cached with a time stamp, and growth re-parents a node
  to a strictly nearer parent [1]_ (sec. 3.3, the library's heuristic).

Why the order matters: in exact arithmetic the nodes that can reach the sink after
*any* maximum flow are the same (the smallest sink side among the minimum cuts), so
the cut depends on the graph alone. In floating point the residuals depend on which
paths the flow took: on an exact tie another order can leave 1e-17 where the library
leaves 0, and a node changes side. Following the same paths in the same order gives
the same bits, hence the same cut (the tests check this against PyMaxflow).

(For whoever edits this module: numba caches a compiled caller with its callees built
in and does not notice when a callee's module changes, so after an edit here clear
``fluidnb/videodb/__pycache__``, or the cached :mod:`fluidnb.videodb.assignment._mrf` sweeps keep
running the old max-flow.)

References
----------
.. [1] Y. Boykov, V. Kolmogorov, "An experimental comparison of min-cut/max-flow
   algorithms for energy minimization in vision", IEEE TPAMI 26(9), 1124-1137, 2004.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["arcs", "maxflow", "min_cut", "sink_side", "workspace"]

# A node's parent: an arc (the arc from the node to its parent), or one of these.
_FREE = -1  # in no tree
_TERMINAL = -2  # joined to its tree's terminal directly
_ORPHAN = -3  # cut off its tree by the last augmentation, waiting for adoption

# Rows of the (8, P) int64 workspace.
_PARENT, _NEXT, _TS, _DIST, _SINK, _ORPHANS, _FIFO = range(7)
# Its last row's first entries: the two active queues' ends and the FIFO's.
_Q0_FIRST, _Q0_LAST, _Q1_FIRST, _Q1_LAST, _FIFO_HEAD, _FIFO_TAIL, _CHAIN = range(7)
_ROWS = 8
_HEADS = 7  # the row of queue ends (needs P >= 7 columns: see workspace)
_INFINITE = 1 << 40  # a distance no path reaches


def arcs(n_nodes, tails, heads):
    """The graph's arcs grouped by node, each node's in the library's order.

    Edge ``e`` is two arcs, ``p -> q`` then ``q -> p``; the library keeps each node's
    arcs as a list with the newest first, so a node's arcs are visited from its last
    edge back. Here they are stored in that order, node after node (compressed rows:
    the same visits, without following a chain of pointers).

    Parameters
    ----------
    n_nodes : int
        Number of nodes ``P``.
    tails, heads : ndarray of int, shape (E,)
        Edge ``e`` joins ``tails[e]`` to ``heads[e]`` (added in this order).

    Returns
    -------
    start : ndarray of int64, shape (P + 1,)
        Node ``i``'s arcs are ``start[i]`` to ``start[i + 1] - 1``.
    head : ndarray of int64, shape (2 E,)
        Where each arc goes.
    sister : ndarray of int64, shape (2 E,)
        Each arc's reverse.
    slot : ndarray of int64, shape (2 E,)
        Edge ``e``'s arcs: ``slot[2 e]`` is ``p -> q``, ``slot[2 e + 1]`` is ``q -> p``
        (where to write their capacities).
    """
    tails = np.asarray(tails, np.int64)
    heads = np.asarray(heads, np.int64)
    return _arcs(n_nodes, tails, heads)


@njit(cache=True, nogil=True)
def _arcs(n_nodes, tails, heads):
    n_edges = len(tails)
    start = np.zeros(n_nodes + 1, np.int64)
    for e in range(n_edges):
        start[tails[e] + 1] += 1
        start[heads[e] + 1] += 1
    for i in range(n_nodes):
        start[i + 1] += start[i]
    fill = start[1:].copy()  # each node's arcs are filled from its end back
    head = np.empty(2 * n_edges, np.int64)
    slot = np.empty(2 * n_edges, np.int64)
    for e in range(n_edges):
        p, q = tails[e], heads[e]
        fill[p] -= 1
        fill[q] -= 1
        slot[2 * e], slot[2 * e + 1] = fill[p], fill[q]
        head[fill[p]], head[fill[q]] = q, p
    sister = np.empty(2 * n_edges, np.int64)
    for e in range(n_edges):
        sister[slot[2 * e]], sister[slot[2 * e + 1]] = slot[2 * e + 1], slot[2 * e]
    return start, head, sister, slot


def workspace(n_nodes):
    """Scratch space for :func:`maxflow` on graphs of ``n_nodes`` nodes (reusable)."""
    return np.zeros((_ROWS, max(n_nodes, _HEADS)), np.int64)


@njit(cache=True, nogil=True, inline="always")
def _set_active(work, i):
    """Append ``i`` to the second active queue unless it is queued (or growing)."""
    nxt, ends = work[_NEXT], work[_HEADS]
    if nxt[i] == _FREE:
        if ends[_Q1_LAST] != _FREE:
            nxt[ends[_Q1_LAST]] = i
        else:
            ends[_Q1_FIRST] = i
        ends[_Q1_LAST] = i
        nxt[i] = i  # the last of its queue points to itself


@njit(cache=True, nogil=True)
def _next_active(work):
    """The next active node still in a tree (-1: none); served nodes leave the queue."""
    nxt, ends, parent = work[_NEXT], work[_HEADS], work[_PARENT]
    while True:
        i = ends[_Q0_FIRST]
        if i == _FREE:  # the first queue is done: serve the second
            i = ends[_Q0_FIRST] = ends[_Q1_FIRST]
            ends[_Q0_LAST] = ends[_Q1_LAST]
            ends[_Q1_FIRST] = ends[_Q1_LAST] = _FREE
            if i == _FREE:
                return _FREE
        if nxt[i] == i:
            ends[_Q0_FIRST] = ends[_Q0_LAST] = _FREE
        else:
            ends[_Q0_FIRST] = nxt[i]
        nxt[i] = _FREE
        if parent[i] != _FREE:  # a node freed by adoption is no longer active
            return i


@njit(cache=True, nogil=True, inline="always")
def _orphan(work, i):
    """Cut ``i`` off its tree by an augmentation: to the front of the chain."""
    work[_PARENT, i] = _ORPHAN
    work[_ORPHANS, i] = work[_HEADS, _CHAIN]
    work[_HEADS, _CHAIN] = i


@njit(cache=True, nogil=True, inline="always")
def _orphan_later(work, i):
    """Cut ``i`` off its tree during adoption: to the back of the FIFO."""
    n = work.shape[1]
    work[_PARENT, i] = _ORPHAN
    work[_FIFO, work[_HEADS, _FIFO_TAIL] % n] = i
    work[_HEADS, _FIFO_TAIL] += 1


@njit(cache=True, nogil=True)
def _augment(middle, head, sister, r_cap, tr_cap, work):
    """Push the bottleneck along the path through ``middle`` (an arc from S to T)."""
    parent = work[_PARENT]
    # The bottleneck: the middle arc, S's arcs towards the node, T's away from it.
    bottleneck = r_cap[middle]
    i = head[sister[middle]]
    while parent[i] != _TERMINAL:
        a = parent[i]
        if bottleneck > r_cap[sister[a]]:
            bottleneck = r_cap[sister[a]]
        i = head[a]
    if bottleneck > tr_cap[i]:
        bottleneck = tr_cap[i]
    i = head[middle]
    while parent[i] != _TERMINAL:
        a = parent[i]
        if bottleneck > r_cap[a]:
            bottleneck = r_cap[a]
        i = head[a]
    if bottleneck > -tr_cap[i]:
        bottleneck = -tr_cap[i]
    # Push it; a saturated arc (or terminal arc) makes its child an orphan.
    r_cap[sister[middle]] += bottleneck
    r_cap[middle] -= bottleneck
    i = head[sister[middle]]
    while parent[i] != _TERMINAL:
        a = parent[i]
        r_cap[a] += bottleneck
        r_cap[sister[a]] -= bottleneck
        if r_cap[sister[a]] == 0:
            _orphan(work, i)
        i = head[a]
    tr_cap[i] -= bottleneck
    if tr_cap[i] == 0:
        _orphan(work, i)
    i = head[middle]
    while parent[i] != _TERMINAL:
        a = parent[i]
        r_cap[sister[a]] += bottleneck
        r_cap[a] -= bottleneck
        if r_cap[a] == 0:
            _orphan(work, i)
        i = head[a]
    tr_cap[i] += bottleneck
    if tr_cap[i] == 0:
        _orphan(work, i)
    return bottleneck


@njit(cache=True, nogil=True)
def _adopt(i, start, head, sister, r_cap, work, time):
    """Find orphan ``i`` a parent in its tree, or free it (and orphan its children)."""
    parent, ts, dist, sink = work[_PARENT], work[_TS], work[_DIST], work[_SINK]
    in_t = sink[i]
    best, best_d = _FREE, _INFINITE
    for a0 in range(start[i], start[i + 1]):
        # An arc from the neighbour towards i (S) or from i towards it (T) with room.
        room = r_cap[a0] if in_t else r_cap[sister[a0]]
        j = head[a0]
        if room != 0 and sink[j] == in_t and parent[j] != _FREE:
            # Does j still reach the root? Walk up until a node stamped this round.
            d = 0
            while True:
                if ts[j] == time:
                    d += dist[j]
                    break
                a = parent[j]
                d += 1
                if a == _TERMINAL:
                    ts[j] = time
                    dist[j] = 1
                    break
                if a == _ORPHAN:
                    d = _INFINITE
                    break
                j = head[a]
            if d < _INFINITE:
                if d < best_d:
                    best, best_d = a0, d
                # Stamp the distances along the path walked, for the next walks.
                j = head[a0]
                while ts[j] != time:
                    ts[j] = time
                    dist[j] = d
                    d -= 1
                    j = head[parent[j]]
    parent[i] = best
    if best != _FREE:
        ts[i] = time
        dist[i] = best_d + 1
        return
    # Free: neighbours of the same tree that could reach i become active, its
    # children orphans.
    for a0 in range(start[i], start[i + 1]):
        j = head[a0]
        a = parent[j]
        if sink[j] == in_t and a != _FREE:
            room = r_cap[a0] if in_t else r_cap[sister[a0]]
            if room != 0:
                _set_active(work, j)
            if a != _TERMINAL and a != _ORPHAN and head[a] == i:
                _orphan_later(work, j)


@njit(cache=True, nogil=True)
def maxflow(start, head, sister, r_cap, tr_cap, work, flow=0.0):
    """The maximum flow from source to sink; the trees it leaves in ``work``.

    Parameters
    ----------
    start, head, sister : ndarray of int64
        The graph's arcs (:func:`arcs`).
    r_cap : ndarray of float64, shape (2 E,)
        Each arc's capacity (>= 0), in the order of ``head`` (edge ``e``'s at
        ``slot[2 e]`` and ``slot[2 e + 1]``); left holding the residuals.
    tr_cap : ndarray of float64, shape (P,)
        Each node's source capacity minus its sink capacity; left holding the
        residuals.
    work : ndarray of int64
        :func:`workspace` of at least ``P`` nodes; afterwards node ``i`` is on the
        sink side where ``work[_PARENT, i] != -1 and work[_SINK, i]`` (:func:`sink_side`).
    flow : float
        The flow so far, to add the augmenting paths' to (as the library does: the
        flow ``min(source, sink)`` through each node straight to the sink).

    Returns
    -------
    float
        ``flow`` plus the flow pushed along augmenting paths, path by path.
    """
    n = len(start) - 1
    if len(tr_cap) != n or len(r_cap) != len(head) or work.shape[0] != _ROWS:
        raise ValueError("maxflow: r_cap, tr_cap or work do not fit the graph")
    if work.shape[1] < n:
        raise ValueError("maxflow: work is too small for the graph (see workspace)")
    parent, nxt, ts, dist, sink = work[_PARENT], work[_NEXT], work[_TS], work[_DIST], work[_SINK]
    ends = work[_HEADS]
    ends[:] = _FREE
    ends[_FIFO_HEAD] = ends[_FIFO_TAIL] = 0
    # Nodes joined to a terminal start its tree, all active in node order (written
    # without branching on the sign, which is as good as random).
    last = _FREE
    for i in range(n):
        joined = tr_cap[i] != 0
        sink[i] = tr_cap[i] < 0
        parent[i] = _TERMINAL if joined else _FREE
        ts[i] = 0
        dist[i] = 1
        nxt[i] = _FREE
        if joined:
            if last == _FREE:
                ends[_Q1_FIRST] = i
            else:
                nxt[last] = i
            last = i
    if last != _FREE:
        nxt[last] = last
        ends[_Q1_LAST] = last
    time = 0
    current = _FREE
    while True:
        i = current
        if i != _FREE:
            nxt[i] = _FREE
            if parent[i] == _FREE:
                i = _FREE
        if i == _FREE:
            i = _next_active(work)
            if i == _FREE:
                break
        # Growth: from i over arcs with room (out of S, into T) until the trees meet.
        middle = _FREE
        in_t = sink[i]
        for a in range(start[i], start[i + 1]):
            room = r_cap[sister[a]] if in_t else r_cap[a]
            if room != 0:
                j = head[a]
                if parent[j] == _FREE:
                    sink[j] = in_t
                    parent[j] = sister[a]
                    ts[j] = ts[i]
                    dist[j] = dist[i] + 1
                    _set_active(work, j)
                elif sink[j] != in_t:
                    middle = sister[a] if in_t else a  # the arc from S's node to T's
                    break
                elif ts[j] <= ts[i] and dist[j] > dist[i]:
                    # j is nearer its root through i (the library's heuristic)
                    parent[j] = sister[a]
                    ts[j] = ts[i]
                    dist[j] = dist[i] + 1
        time += 1
        if middle == _FREE:
            current = _FREE
            continue
        nxt[i] = i  # i keeps growing after this path: not queued meanwhile
        current = i
        flow += _augment(middle, head, sister, r_cap, tr_cap, work)
        # Adoption: the augmentation's orphans in turn, each with those it makes.
        ends, fifo = work[_HEADS], work[_FIFO]
        while ends[_CHAIN] != _FREE:
            o = ends[_CHAIN]
            ends[_CHAIN] = work[_ORPHANS, o]
            _adopt(o, start, head, sister, r_cap, work, time)
            while ends[_FIFO_HEAD] != ends[_FIFO_TAIL]:
                o = fifo[ends[_FIFO_HEAD] % len(fifo)]
                ends[_FIFO_HEAD] += 1
                _adopt(o, start, head, sister, r_cap, work, time)
    return flow


@njit(cache=True, nogil=True)
def sink_side(work, out):
    """``out[i]``: node ``i`` ends in T (can reach the sink) after :func:`maxflow`."""
    for i in range(len(out)):
        out[i] = work[_PARENT, i] != _FREE and work[_SINK, i] != 0
    return out


def min_cut(n_nodes, edges, cap, rev_cap, source, sink):
    """A minimum s-t cut, as PyMaxflow's ``Graph[float]`` computes it.

    Parameters
    ----------
    n_nodes : int
        Number of nodes ``P``.
    edges : array_like of int, shape (E, 2)
        Node pairs ``(p, q)``, added in this order.
    cap, rev_cap : array_like of float, shape (E,)
        Capacities ``p -> q`` and ``q -> p`` (>= 0).
    source, sink : array_like of float, shape (P,)
        Each node's capacity from the source and to the sink.

    Returns
    -------
    flow : float
        The maximum flow (the minimum cut's capacity).
    sink_side : ndarray of bool, shape (P,)
        Nodes that can reach the sink in the residual graph (``x = 1``).

    Examples
    --------
    >>> flow, side = min_cut(2, [[0, 1]], [1.0], [0.0], [3.0, 0.0], [0.0, 2.0])
    >>> flow, side.tolist()
    (1.0, [False, True])
    """
    edges = np.asarray(edges, np.int64).reshape(-1, 2)
    cap, rev_cap = (np.asarray(c, np.float64) for c in (cap, rev_cap))
    source, sink = (np.asarray(c, np.float64) for c in (source, sink))
    shapes = (cap.shape, rev_cap.shape, source.shape, sink.shape)
    if shapes != ((len(edges),),) * 2 + ((n_nodes,),) * 2:
        raise ValueError(f"cap, rev_cap need one value per edge, source, sink per node: {shapes}")
    if edges.size and (edges.min() < 0 or edges.max() >= n_nodes):
        raise ValueError(f"edges must join nodes in [0, {n_nodes - 1}]")
    if not all(np.all(np.isfinite(c)) for c in (cap, rev_cap, source, sink)):
        raise ValueError("capacities must be finite")
    if np.any(cap < 0) or np.any(rev_cap < 0):
        raise ValueError("edge capacities must be >= 0 (terminal ones may be anything)")
    start, head, sister, slot = arcs(n_nodes, edges[:, 0], edges[:, 1])
    r_cap = np.empty(2 * len(edges))
    r_cap[slot[0::2]] = cap
    r_cap[slot[1::2]] = rev_cap
    tr_cap = source - sink
    flow = 0.0
    for s, t in zip(source.tolist(), sink.tolist()):  # summed in the library's order
        flow += min(s, t)
    work = workspace(n_nodes)
    flow = maxflow(start, head, sister, r_cap, tr_cap, work, flow)
    return flow, sink_side(work, np.empty(n_nodes, bool))
