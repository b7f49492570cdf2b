r"""The assignment MRF of the video-database method (Okabe et al., sec. 5, Eq. 2-6).

Every target fragment :math:`p` (a node of a 4-connected grid) takes one of its
:math:`K` candidate database fragments (its labels, ranked by appearance, Eq. 1). The
labelling minimises

.. math::

    E(l) = \sum_p V_p(l_p) + \lambda \sum_{(p, q)} W_{pq}(l_p, l_q)            \quad (4)

    V_p(l) = 1 - I(H_p, H_l)                                                    \quad (5)

    W_{pq}(l_i, l_j) = \mathrm{smooth}(\hat M^{l_i}, \hat M^{l_j})
                       + \rho\, \mathrm{texture}(T^{l_i}, T^{l_j})              \quad (6)

    \mathrm{smooth} = d(\hat M_1, \hat M_1) + \sigma \sum_{f \ge 2} d(\hat M_f, \hat M_f)
                                                                                \quad (2)

    d(F, G) = \sum_{x \in \Omega} (F(x) - G(x))^2                               \quad (3)

where :math:`\Omega` is the overlap of the two neighbouring fragments and
:math:`\hat M_f` the motion power spectrum at frequency bin :math:`f` (:math:`f = 1`,
our bin 0, is DC, which the database stores as the signed mean motion: its power would
not tell opposite flows apart; see :mod:`fluidnb.videodb._features`).

Decision (spec 05, section 2): the data term is :math:`V_p = 1 - I` with the
normalised histogram intersection :math:`I \in [0, 1]`. The paper writes
:math:`V_p = I` (Eq. 5), which a minimisation would turn into a reward for
*dissimilar* fragments. This module takes ``unary`` as given; the caller passes
:math:`1 - I`.

The module has three parts:

- the smoothness tables in bulk (:func:`pair_tables`): for every edge and every
  label pair, the DC term, the other frequencies and the textureness are kept as
  three float64 tables, so a change of :math:`\sigma` or :math:`\rho` only recombines
  them (:meth:`PairTables.smoothness`). The squared distances are computed as norms
  minus a matrix product, batched over edges; entries where that formula cancels
  badly (near-duplicate candidates, where float32 gave 300 % errors) are recomputed
  directly, so every entry is exact to 1e-9 relative (a worst-case bound).
  :func:`fluidnb.videodb.reference_pair_tables` is the literal pair-by-pair definition;
- the energy (:func:`energy`) and its solvers: alpha-expansion over label indices on
  PyMaxflow (:func:`alpha_expansion`), iterated conditional modes (:func:`icm`), the
  spec's recipe combining them (:func:`solve`), and exhaustive search for tiny
  problems (:func:`brute_force`);
- :func:`grid_edges`, the 4-neighbourhood of the target's fragment grid.

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

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field

import maxflow
import numpy as np
from threadpoolctl import threadpool_limits

from .._progress import Progress
from .._validation import check_array, check_int, check_range
from ._geometry import SPECTRA_BLOCK, SPECTRA_SIDE, TEXTURE_BLOCK, TEXTURE_SIDE

__all__ = [
    "MRFSolution",
    "PairTables",
    "SolverRun",
    "alpha_expansion",
    "brute_force",
    "energy",
    "grid_edges",
    "icm",
    "pair_tables",
    "solve",
]

#: Relative accuracy every entry of the bulk tables is guaranteed to (see _sqdist).
#: Measured on a synthetic swirling clip (984 fragments, 100 random candidates): 0.14 %
#: of the entries are recomputed at 1e-9, 7 % at 1e-10.
_TABLE_RTOL = 1e-9
#: Bytes of float64 features gathered per batch of edges (bounds memory).
_BATCH_BYTES = 1 << 25


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


# ------------------------------------------------------------------ pair tables


@dataclass(frozen=True, eq=False)
class PairTables:
    r"""The three smoothness tables of every edge (Eq. 2, 3, 6), float64.

    ``W = dc + sigma * rest + rho * tex`` (:meth:`smoothness`); keeping the three
    parts lets a change of :math:`\sigma` or :math:`\rho` recombine them without
    touching the database again. The arrays are read-only.

    Attributes
    ----------
    dc : ndarray, shape (E, K, K)
        :math:`d(\hat M_1^{l_i}, \hat M_1^{l_j})` over :math:`\Omega` (Eq. 3 on the DC
        bin of both flow components), for label ``i`` of ``p`` and ``j`` of ``q``.
    rest : ndarray, shape (E, K, K)
        :math:`\sum_{f \ge 2} d(\hat M_f^{l_i}, \hat M_f^{l_j})` (Eq. 2's sum).
    tex : ndarray, shape (E, K, K)
        :math:`\mathrm{texture}(T^{l_i}, T^{l_j})`: Eq. 3 on the textureness, all levels.
    edges : ndarray of int64, shape (E, 2)
        The edges ``(p, q)`` the tables belong to.
    horizontal : ndarray of bool, shape (E,)
        Orientation of each edge (see :func:`grid_edges`).
    recomputed : int
        Entries (over the three tables) whose norms-minus-product value cancelled
        too much and were recomputed directly (near-duplicate candidates).
    """

    dc: np.ndarray
    rest: np.ndarray
    tex: np.ndarray
    edges: np.ndarray
    horizontal: np.ndarray
    recomputed: int = 0

    def __post_init__(self):
        for name in ("dc", "rest", "tex", "edges", "horizontal"):
            getattr(self, name).setflags(write=False)

    def smoothness(self, sigma, rho):
        r"""The pairwise term :math:`W_{pq}` of Eq. (6) for every edge and label pair.

        Parameters
        ----------
        sigma : float
            :math:`\sigma` of Eq. (2), >= 0: weight of the non-DC frequencies.
        rho : float
            :math:`\rho` of Eq. (6), >= 0: weight of the textureness.

        Returns
        -------
        ndarray of float64, shape (E, K, K)
            ``dc + sigma * rest + rho * tex``.
        """
        sigma = check_range("sigma", sigma, 0)
        rho = check_range("rho", rho, 0)
        out = self.rest * sigma
        out += self.dc
        out += rho * self.tex
        return out


def _check_tables_input(candidates, edges, horizontal, spectra, texture):
    spectra = check_array("spectra", spectra, ndim=5, dtype_kinds="f", finite=False)
    texture = check_array("texture", texture, ndim=4, dtype_kinds="f", finite=False)
    if spectra.shape[2:] != (2, SPECTRA_SIDE, SPECTRA_SIDE):
        raise ValueError(
            f"spectra must have shape (F, NB, 2, {SPECTRA_SIDE}, {SPECTRA_SIDE}), "
            f"got {spectra.shape}"
        )
    if texture.shape[2:] != (TEXTURE_SIDE, TEXTURE_SIDE):
        raise ValueError(
            f"texture must have shape (F, levels, {TEXTURE_SIDE}, {TEXTURE_SIDE}), "
            f"got {texture.shape}"
        )
    if texture.shape[0] != spectra.shape[0]:
        raise ValueError(
            f"spectra and texture must describe the same fragments, got {spectra.shape[0]} "
            f"and {texture.shape[0]}"
        )
    cand = check_array("candidates", candidates, ndim=2, dtype_kinds="iu")
    n_frag = spectra.shape[0]
    if cand.min() < 0 or cand.max() >= n_frag:
        raise ValueError(
            f"candidates must be fragment ids in [0, {n_frag - 1}], "
            f"got values in [{cand.min()}, {cand.max()}]"
        )
    edges = _check_edges(edges, len(cand))
    hor = check_array("horizontal", horizontal, ndim=1, dtype_kinds="biu", min_size=0)
    if hor.shape != (len(edges),):
        raise ValueError(f"horizontal must have shape ({len(edges)},), got {hor.shape}")
    return cand.astype(np.int64), edges, hor.astype(bool), spectra, texture


def _sqdist(a, b):
    """Squared distances between all rows of a[e] and b[e]: (B, K, D) x2 -> (B, K, K).

    ``|a|^2 + |b|^2 - 2 a.b`` has an absolute error of at most about
    ``(2 D + 3) eps (|a|^2 + |b|^2)``; wherever the result is not at least
    ``(2 D + 3) eps / _TABLE_RTOL`` times ``|a|^2 + |b|^2`` (near-duplicates) it is
    recomputed as the plain sum of squared differences, so every entry is within
    ``_TABLE_RTOL`` of the exact value. Returns (distances, recomputed count).
    """
    n_b, k_a, dim = a.shape
    k_b = b.shape[1]
    if dim == 0:
        return np.zeros((n_b, k_a, k_b)), 0
    # Centred on the edge's mean candidate (distances do not change): the norms then
    # measure the candidates' spread, not their distance from 0, and far fewer
    # entries cancel (candidates of one edge are alike: 7 % of entries needed the
    # direct sum on a real target, 0.1 % after centring). ``a`` and ``b`` are the
    # caller's scratch buffers.
    centre = (a.sum(axis=1, keepdims=True) + b.sum(axis=1, keepdims=True)) / (k_a + k_b)
    a -= centre
    b -= centre
    na = np.einsum("bkd,bkd->bk", a, a)
    nb = np.einsum("bkd,bkd->bk", b, b)
    scale = na[:, :, None] + nb[:, None, :]
    d = scale - 2.0 * np.matmul(a, b.transpose(0, 2, 1))
    threshold = (2 * dim + 3) * np.finfo(np.float64).eps / _TABLE_RTOL
    eb, ei, ej = np.nonzero(d <= threshold * scale)
    step = max(1, _BATCH_BYTES // (8 * dim))
    for s in range(0, len(eb), step):
        sl = slice(s, s + step)
        diff = a[eb[sl], ei[sl]] - b[eb[sl], ej[sl]]
        d[eb[sl], ei[sl], ej[sl]] = np.einsum("nd,nd->n", diff, diff)
    return d, len(eb)


def _halves(horizontal, side):
    """Index slices of Omega on p's and q's side for a (..., side, side) array."""
    h = side // 2
    full, lo, hi = slice(None), slice(0, h), slice(h, None)
    if horizontal:  # p left of q: p's right half meets q's left half
        return (full, hi), (full, lo)
    return (hi, full), (lo, full)  # p above q: p's bottom half meets q's top half


def _workers():
    try:
        return max(1, min(4, len(os.sched_getaffinity(0))))
    except AttributeError:  # not on Linux
        return max(1, min(4, os.cpu_count() or 1))


class _TableBatches:
    """Fills the three tables for one batch of edges of one orientation per call.

    Thread-safe: each worker thread keeps its own gather and float64 buffers (fresh
    large arrays per batch cost as much in page faults as the conversion itself);
    batches write disjoint rows of the tables.
    """

    def __init__(self, cand, edges, spectra, texture, tables):
        self.cand, self.edges, self.tables = cand, edges, tables
        self.arrays = {"spectra": spectra, "texture": texture}
        n_bins, k = spectra.shape[1], cand.shape[1]
        # (table, array, leading index, block area, side): which part of the
        # database each table measures; the leading index picks frequency bins.
        self.terms = (
            ("dc", "spectra", slice(0, 1), SPECTRA_BLOCK**2, SPECTRA_SIDE),
            ("rest", "spectra", slice(1, n_bins), SPECTRA_BLOCK**2, SPECTRA_SIDE),
            ("tex", "texture", slice(None), TEXTURE_BLOCK**2, TEXTURE_SIDE),
        )
        # Features per fragment on one side of an overlap (half a fragment), at most.
        self.width = max(spectra[0].size, texture[0].size) // 2
        # Edges per batch: the float64 features of one side fill about _BATCH_BYTES.
        self.batch = max(1, min(len(edges), _BATCH_BYTES // (8 * k * self.width)))
        self.rows = self.batch * k
        self.local = threading.local()
        self.lock = threading.Lock()
        self.recomputed = 0

    def _buffers(self):
        buf = getattr(self.local, "buffers", None)
        if buf is None:
            raw = {
                name: tuple(np.empty((self.rows, *a.shape[1:]), a.dtype) for _ in range(2))
                for name, a in self.arrays.items()
            }
            work = tuple(np.empty(self.rows * self.width) for _ in range(2))
            buf = self.local.buffers = (raw, work)
        return buf

    def __call__(self, es, orientation):
        raw, work = self._buffers()
        k = self.cand.shape[1]
        n = len(es) * k
        ids = (self.cand[self.edges[es, 0]].ravel(), self.cand[self.edges[es, 1]].ravel())
        for name, array in self.arrays.items():
            for side in (0, 1):
                np.take(array, ids[side], axis=0, out=raw[name][side][:n], mode="clip")
        fixed = 0
        for table, name, lead, area, block_side in self.terms:
            feats = []
            for side, (r, c) in enumerate(_halves(orientation, block_side)):
                src = raw[name][side][:n][:, lead, ..., r, c]
                dst = work[side][: src.size].reshape(src.shape)
                np.copyto(dst, src)
                feats.append(dst.reshape(len(es), k, -1))
            d, n_fix = _sqdist(*feats)
            self.tables[table][es] = area * d
            fixed += n_fix
        with self.lock:
            self.recomputed += fixed
        return len(es)


def pair_tables(candidates, edges, horizontal, spectra, texture, *, progress=None):
    r"""The smoothness tables of Eq. (2), (3) and (6) for every edge, in bulk.

    For edge ``e = (p, q)``, label ``i`` of ``p`` (fragment ``a = candidates[p, i]``)
    and label ``j`` of ``q`` (``b = candidates[q, j]``), over the overlap
    :math:`\Omega` of the two neighbours (``p``'s right / bottom half against ``q``'s
    left / top half):

    - ``dc[e, i, j] = 16 * sum_Omega (spectra[a, 0] - spectra[b, 0])**2``, both flow
      components: :math:`d(\hat M_1, \hat M_1)` (Eq. 3);
    - ``rest[e, i, j] = 16 * sum_{f >= 1} sum_Omega (spectra[a, f] - spectra[b, f])**2``:
      Eq. (2)'s sum over :math:`f = 2 \ldots N/2`;
    - ``tex[e, i, j] = 4 * sum_Omega (texture[a] - texture[b])**2`` over all levels:
      Eq. (6)'s :math:`\mathrm{texture}(T^{l_i}, T^{l_j})`;

    the factors 16 and 4 being the areas of the 4 x 4 and 2 x 2 pixel blocks the stored
    arrays are averaged over, so the sums approximate Eq. (3)'s full-resolution ones.

    Each table is computed as squared norms minus a matrix product, batched over edges
    of one orientation (in a grid each node is the ``p`` of at most one horizontal and
    one vertical edge, so every node's candidates are gathered once per side), in
    float64; entries where that formula cancels (near-duplicate candidates) are
    recomputed directly, so every entry is within 1e-9 relative of
    :func:`fluidnb.videodb.reference_pair_tables`. Batches run on up to 4 threads (one per core),
    each with a single-threaded BLAS.

    Parameters
    ----------
    candidates : array_like of int, shape (P, K)
        Database fragment ids of each node's ``K`` labels.
    edges : array_like of int, shape (E, 2)
        Neighbour pairs ``(p, q)``, ``p`` left of or above ``q`` (:func:`grid_edges`).
    horizontal : array_like of bool, shape (E,)
        True for left-right neighbours, False for top-bottom ones.
    spectra : ndarray, shape (F, NB, 2, 12, 12), float16 (any float)
        The database's motion spectra :math:`\hat M` (bin 0: the mean motion), in RAM.
    texture : ndarray, shape (F, L, 24, 24), float16 (any float)
        The database's textureness :math:`T` (L = 4 Laplacian levels), in RAM.
    progress : callable, optional
        ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops.

    Returns
    -------
    PairTables
        ``dc``, ``rest``, ``tex`` of shape (E, K, K) and the edges;
        ``tables.smoothness(sigma, rho)`` is :math:`W_{pq}` (Eq. 6).

    Raises
    ------
    ValueError
        On shapes that do not fit, ids out of range, or candidates whose spectra or
        textureness are not finite.
    """
    cand, edges, hor, spectra, texture = _check_tables_input(
        candidates, edges, horizontal, spectra, texture
    )
    report = Progress(progress)
    n_edges, k = len(edges), cand.shape[1]
    tables = {name: np.empty((n_edges, k, k)) for name in ("dc", "rest", "tex")}
    builder = _TableBatches(cand, edges, spectra, texture, tables)
    # Batches of edges of one orientation (their overlap slices differ).
    batches = []
    for orientation in (True, False):
        sel = np.flatnonzero(hor == orientation)
        step = builder.batch
        batches += [(sel[s : s + step], orientation) for s in range(0, len(sel), step)]
    workers = min(_workers(), len(batches)) or 1
    # One BLAS thread per worker, workers over batches: a multithreaded BLAS inside
    # many mid-sized products stalls badly when other processes share the cores
    # (measured on 2 busy cores: 5-55 s instead of 5-10 s).
    done = 0
    with threadpool_limits(1, user_api="blas"), ThreadPoolExecutor(workers) as pool:
        futures = [pool.submit(builder, es, o) for es, o in batches]
        try:
            for future in as_completed(futures):
                done += future.result()
                report(done / max(n_edges, 1), f"smoothness tables: {done}/{n_edges} edges")
        finally:
            for future in futures:
                future.cancel()
    for name, table in tables.items():
        if not np.all(np.isfinite(table)):
            raise ValueError(
                f"the candidates' {'texture' if name == 'tex' else 'spectra'} contain NaN "
                "or infinite values; all must be finite"
            )
    report(1.0, "smoothness tables done")
    return PairTables(
        edges=edges.copy(), horizontal=hor.copy(), recomputed=builder.recomputed, **tables
    )


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


def _problem(unary, pairwise, edges, lam):
    v = check_array("unary", unary, ndim=2, dtype_kinds="biuf")
    w = check_array("pairwise", pairwise, ndim=3, dtype_kinds="biuf", min_size=0)
    n_nodes, k = v.shape
    e = _check_edges(edges, n_nodes)
    if w.shape != (len(e), k, k):
        raise ValueError(
            f"pairwise must have shape (E, K, K) = ({len(e)}, {k}, {k}) for {len(e)} edges "
            f"and unary of shape {v.shape}, got {w.shape}"
        )
    lam = check_range("lam", lam, 0)
    w = np.ascontiguousarray(w, dtype=np.float64)
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


def _expand(prob, labels, max_sweeps, report):
    """Alpha-expansion over label indices with Rother-style truncation."""
    t0 = time.perf_counter()
    n_nodes, k = prob.n_nodes, prob.n_labels
    p, q, lam = prob.p, prob.q, prob.lam
    n_edges = len(p)
    rows = np.arange(n_nodes)
    zeros = np.zeros(n_edges)
    labels = labels.copy()
    current = prob.energy(labels)
    energies = [current]
    truncated = free_terms = 0
    sweeps = 0
    for sweep in range(max_sweeps):
        improved = False
        for alpha in range(k):
            lp, lq = labels[p], labels[q]
            # The move's binary energy per edge: x = 0 keeps the label, x = 1 takes alpha.
            e00 = lam * prob.pair(lp, lq)
            e01 = lam * prob.pair(lp, alpha)
            e10 = lam * prob.pair(alpha, lq)
            e11 = lam * prob.pair(alpha, alpha)
            cap = e01 + e10 - e00 - e11
            bad = cap < 0
            free = (lp != alpha) & (lq != alpha)
            truncated += np.count_nonzero(bad & free)
            free_terms += np.count_nonzero(free)
            # Rother et al. 2005: lower E11 to E01 + E10 - E00 (a lower bound of the
            # true move energy, exact at x = 0), then check the true energy below.
            e11 = np.where(bad, e01 + e10 - e00, e11)
            cap = np.where(bad, 0.0, cap)
            # Kolmogorov & Zabih 2004: E = E00 + (E10 - E00) x_p + (E11 - E10) x_q
            #                              + cap (1 - x_p) x_q.
            cost1 = prob.unary[:, alpha] - prob.unary[rows, labels]
            cost1 = cost1 + np.bincount(p, e10 - e00, minlength=n_nodes)
            cost1 += np.bincount(q, e11 - e10, minlength=n_nodes)
            g = maxflow.Graph[float](n_nodes, n_edges)
            nodes = g.add_nodes(n_nodes)
            g.add_edges(nodes[p], nodes[q], cap, zeros)
            # A node in the sink segment (x = 1) pays its source capacity.
            g.add_grid_tedges(nodes, np.maximum(cost1, 0.0), np.maximum(-cost1, 0.0))
            g.maxflow()
            take = g.get_grid_segments(nodes) & (labels != alpha)
            if take.any():
                proposal = np.where(take, alpha, labels)
                new = prob.energy(proposal)
                if new < current:
                    labels, current, improved = proposal, new, True
            report((sweep + (alpha + 1) / k) / max_sweeps, f"alpha-expansion sweep {sweep + 1}")
        sweeps += 1
        energies.append(current)
        if not improved:
            break
    return SolverRun(
        labels=labels,
        energies=np.array(energies),
        sweeps=sweeps,
        nonsubmodular=truncated / free_terms if free_terms else 0.0,
        seconds=time.perf_counter() - t0,
    )


def _icm(prob, labels, max_sweeps, report):
    """Iterated conditional modes in raster (node index) order."""
    t0 = time.perf_counter()
    n_nodes, lam, w = prob.n_nodes, prob.lam, prob.pairwise
    labels = labels.copy()
    # For node n: (edge, other node) pairs where n is p (a column of W[e]) or q (a row).
    as_p = [[] for _ in range(n_nodes)]
    as_q = [[] for _ in range(n_nodes)]
    for e, (a, b) in enumerate(zip(prob.p.tolist(), prob.q.tolist())):
        as_p[a].append((e, b))
        as_q[b].append((e, a))
    energies = [prob.energy(labels)]
    sweeps = 0
    for sweep in range(max_sweeps):
        changed = False
        for n in range(n_nodes):
            cost = prob.unary[n].copy()
            for e, m in as_p[n]:
                cost += lam * w[e, :, labels[m]]
            for e, m in as_q[n]:
                cost += lam * w[e, labels[m], :]
            best = int(np.argmin(cost))
            if cost[best] < cost[labels[n]]:
                labels[n] = best
                changed = True
        sweeps += 1
        energies.append(prob.energy(labels))
        report((sweep + 1) / max_sweeps, f"ICM sweep {sweep + 1}")
        if not changed:
            break
    return SolverRun(
        labels=labels,
        energies=np.array(energies),
        sweeps=sweeps,
        nonsubmodular=0.0,
        seconds=time.perf_counter() - t0,
    )


def _start(prob, init):
    if init is None:
        return prob.argmin()
    return _check_labels("init", init, prob.n_nodes, prob.n_labels)


def alpha_expansion(unary, pairwise, edges, lam, *, init=None, max_sweeps=20, progress=None):
    r"""Minimise Eq. (4) by alpha-expansion moves over label indices.

    Boykov, Veksler & Zabih's expansion: for each :math:`\alpha = 0 \ldots K-1` in turn,
    every node either keeps its label or takes its own :math:`\alpha`-th candidate,
    whichever a minimum cut of the move's binary energy says (Kolmogorov & Zabih's
    construction, built vectorised on PyMaxflow's ``Graph[float]``). Because labels
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
        ``progress(fraction, message)``, called after every move; raising
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
    never worse than ICM.

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
    stage_icm, stage_a, stage_b = Progress(progress).split(0.1, 0.55)
    start = prob.argmin()
    base = _icm(prob, start, max_sweeps, stage_icm)
    from_argmin = _expand(prob, start, max_sweeps, stage_a)
    from_icm = _expand(prob, base.labels, max_sweeps, stage_b)
    best, name = (from_argmin, "argmin")
    if from_icm.energy < from_argmin.energy:
        best, name = (from_icm, "icm")
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
