r"""The smoothness term of the assignment MRF in bulk (Okabe et al., sec. 5, Eq. 2, 3, 6).

Two neighbouring target fragments :math:`p, q` (left-right or up-down) that take
database fragments :math:`l_i, l_j` pay

.. math::

    W_{pq}(l_i, l_j) = \mathrm{smooth}(\hat M^{l_i}, \hat M^{l_j})
                       + \rho\, \mathrm{texture}(T^{l_i}, T^{l_j})              \quad (6)

    \mathrm{smooth} = d(\hat M_1, \hat M_1) + \sigma \sum_{f \ge 2} d(\hat M_f, \hat M_f)
                                                                                \quad (2)

    d(F, G) = \sum_{x \in \Omega} (F(x) - G(x))^2                               \quad (3)

where :math:`\Omega` is the overlap of the two fragments (half of each),
:math:`\hat M_f` the motion power spectrum at frequency bin :math:`f` (:math:`f = 1`,
our bin 0, is DC, which the database stores as the signed mean motion: its power would
not tell opposite flows apart; see :mod:`fluidnb.videodb.database._features`) and :math:`T`
the textureness, and

.. math::

    \mathrm{texture}(T^{l_i}, T^{l_j}) = s_T\, d(T^{l_i}, T^{l_j})

with :math:`s_T` = :data:`TEXTURE_SCALE` = 1e-5 the unit of the textureness term, which
the paper does not give (our decision, see there): so :math:`\rho` is the paper's
:math:`\rho`, and its values (:math:`\rho = 100\,\sigma`) mean what they say.

The paper's bottleneck (half an hour for 100 x 100 label pairs per edge): computed
here in bulk (:func:`pair_tables`), as squared norms minus a matrix product, batched
over edges, in float64; entries where that formula cancels badly (near-duplicate
candidates, where float32 gave 300 % errors) are recomputed directly, so every entry
is exact to 1e-9 relative (a worst-case bound). Three tables per edge are kept -- the
DC term, the other frequencies and the textureness -- so that a change of
:math:`\sigma` or :math:`\rho` only recombines them (:meth:`PairTables.smoothness`).
:func:`fluidnb.videodb.assignment.reference_pair_tables` is the literal pair-by-pair definition.

References
----------
.. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Pacific Graphics 2011 (Computer Graphics Forum 30(7)).
"""

from __future__ import annotations

import functools
import threading
from concurrent.futures import as_completed
from dataclasses import dataclass, field

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from ..._progress import Progress
from ..._threads import blas_single_threaded, spread_pool, usable_cores
from ..._validation import check_array, check_range
from .._common._geometry import SPECTRA_BLOCK, SPECTRA_SIDE, TEXTURE_BLOCK, TEXTURE_SIDE
from ._mrf import _all_finite, _check_edges

__all__ = ["TEXTURE_SCALE", "PairTables", "pair_smoothness", "pair_tables"]

#: :math:`s_T`, the unit of the textureness term of Eq. (6):
#: :math:`\mathrm{texture}(T^{l_i}, T^{l_j}) = s_T\, d(T^{l_i}, T^{l_j})`, applied in
#: :meth:`PairTables.smoothness` (the ``tex`` table holds :math:`d` alone). The paper's
#: units are unknown (our decision); ours are (px/frame)^2 for the motion terms and
#: luminance in [0, 1] summed over the N frames for the textureness, whose :math:`d`
#: is ~10^5 times larger. With this unit the paper's rho = 100 sigma = 10^4 weighs the
#: textureness about as much as the mean motion: medians over candidate pairs on the
#: starter databases, DC term / rho-weighted textureness, water 1290 / 1180, smoke
#: 3980 / 4590, fire 8580 / 1160.
TEXTURE_SCALE = 1e-5

#: Relative accuracy every entry of the bulk tables is guaranteed to (see _finish).
#: Measured on a synthetic swirling clip (984 fragments, 100 random candidates): 0.14 %
#: of the entries are recomputed at 1e-9, 7 % at 1e-10.
_TABLE_RTOL = 1e-9
#: Bytes of float64 features gathered per batch of edges, per side: small enough that
#: both workers' features stay in the L3 cache between the gather and the product
#: (measured at K = 100, 2 cores: 32 MB batches 178-180 ms for 112 edges, 4 MB
#: 164-166 ms).
_BATCH_BYTES = 1 << 22


@dataclass(frozen=True, eq=False)
class PairTables:
    r"""The three smoothness tables of every edge (Eq. 2, 3, 6), float64.

    ``W = dc + sigma * rest + rho * TEXTURE_SCALE * tex`` (:meth:`smoothness`); keeping
    the three parts lets a change of :math:`\sigma` or :math:`\rho` recombine them
    without touching the database again. The arrays are read-only.

    Attributes
    ----------
    dc : ndarray, shape (E, K, K)
        :math:`d(\hat M_1^{l_i}, \hat M_1^{l_j})` over :math:`\Omega` (Eq. 3 on the DC
        bin of both flow components), for label ``i`` of ``p`` and ``j`` of ``q``.
    rest : ndarray, shape (E, K, K)
        :math:`\sum_{f \ge 2} d(\hat M_f^{l_i}, \hat M_f^{l_j})` (Eq. 2's sum).
    tex : ndarray, shape (E, K, K)
        :math:`d(T^{l_i}, T^{l_j})`: Eq. 3 on the textureness, all levels (Eq. 6's
        :math:`\mathrm{texture}` is this times :data:`TEXTURE_SCALE`).
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
    #: float32 copies of dc, rest, tex, made by the first float32 smoothness().
    _single: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self):
        for name in ("dc", "rest", "tex", "edges", "horizontal"):
            getattr(self, name).setflags(write=False)

    def smoothness(self, sigma, rho, dtype=np.float64):
        r"""The pairwise term :math:`W_{pq}` of Eq. (6) for every edge and label pair.

        Parameters
        ----------
        sigma : float
            :math:`\sigma` of Eq. (2), >= 0: weight of the non-DC frequencies.
        rho : float
            :math:`\rho` of Eq. (6), >= 0: weight of the textureness (the paper's, e.g.
            :math:`100\,\sigma`; the textureness's unit :data:`TEXTURE_SCALE` is
            applied here).
        dtype : {numpy.float64, numpy.float32}
            float32: combined from float32 copies of the three tables (made once,
            half the memory they take again) into a float32 W, half the memory
            traffic of float64 (a live preview's re-solve); every entry within 2e-7
            relative of the float64 one (two roundings to float32), the labels a
            solve gives from it the same or nearly (measured in the tests).

        Returns
        -------
        ndarray of dtype, shape (E, K, K)
            ``dc + sigma * rest + rho * TEXTURE_SCALE * tex``.
        """
        sigma = check_range("sigma", sigma, 0)
        rho = check_range("rho", rho, 0)
        dtype = np.dtype(dtype)
        if dtype not in (np.float64, np.float32):
            raise ValueError(f"dtype must be float64 or float32, got {dtype}")
        if dtype == np.float32:
            if not self._single:  # the float32 copies, once; all three at once (threads)
                names = ("dc", "rest", "tex")
                self._single.update({n: getattr(self, n).astype(np.float32) for n in names})
            tables = [self._single[name] for name in ("dc", "rest", "tex")]
        else:
            tables = [np.ascontiguousarray(t, np.float64) for t in (self.dc, self.rest, self.tex)]
        if not tables[0].shape == tables[1].shape == tables[2].shape:
            raise ValueError(
                "dc, rest and tex must have the same shape (E, K, K), got "
                + ", ".join(str(t.shape) for t in tables)
            )
        # texture(T, T) = TEXTURE_SCALE * d(T, T)
        out = np.empty(tables[0].shape, dtype)
        return _combine(*tables, sigma, rho * TEXTURE_SCALE, out)


@njit(cache=True, nogil=True)
def _combine(dc, rest, tex, sigma, rho_scaled, out):
    """``out = rest * sigma; out += dc; out += rho_scaled * tex`` in one pass.

    float32 tables are read as float64 (exact) and the float64 result rounded into a
    float32 ``out`` once.

    The same operations in the same order, element by element, as those three numpy
    statements (so the same bits: no fused multiply-add), reading each table once
    instead of writing and reading two temporaries (measured at 171 nodes, K = 100:
    3.6 ms instead of 7-11 ms).
    """
    d, r, t, o = dc.reshape(-1), rest.reshape(-1), tex.reshape(-1), out.reshape(-1)
    for i in range(o.size):
        value = r[i] * sigma
        value += d[i]
        o[i] = value + rho_scaled * t[i]
    return out


@njit(cache=True, nogil=True)
def _combine_rows(dc, rest, tex, sigma, rho_scaled, out, rows):
    """``out[rows[e]]`` = :func:`_combine` of ``dc[e]``, ``rest[e]``, ``tex[e]`` (the same bits)."""
    for e in range(rows.shape[0]):
        _combine(dc[e], rest[e], tex[e], sigma, rho_scaled, out[rows[e]])


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


@njit(cache=True, nogil=True)
def _finish(prod, norm_p, norm_q, a, b, area, threshold, out, rows):
    """Squared distances from the products, into ``out[rows[e]]``; returns recomputed.

    ``out[rows[e], i, j] = area * (|a_i|^2 + |b_j|^2 - 2 a_i.b_j)`` with ``prod`` the
    products ``a_i.b_j`` of edge ``e`` (from BLAS) and ``norm_p``, ``norm_q`` the
    squared norms (:func:`_gather_centred`). ``a`` and ``b`` come centred on the edge's
    mean candidate: distances do not change, but the norms then measure the
    candidates' spread, not their distance from 0, and far fewer entries cancel
    (candidates of one edge are alike: 7 % of entries needed the direct sum on a real
    target, 0.1 % after centring).

    The formula has an absolute error of at most about ``(2 D + 3) eps (|a|^2 +
    |b|^2)``; wherever the result is not at least ``threshold = (2 D + 3) eps /
    _TABLE_RTOL`` times ``|a|^2 + |b|^2`` (near-duplicates) it is recomputed as the
    plain sum of squared differences, so every entry is within ``_TABLE_RTOL`` of the
    exact value. One pass over the products instead of numpy's five temporaries (the
    norms' sum, the difference, the test, the scaling, the store).
    """
    n_e, k_p, k_q = prod.shape
    dim = a.shape[2]
    fixed = 0
    for e in range(n_e):
        table = out[rows[e]]
        for i in range(k_p):
            for j in range(k_q):
                scale = norm_p[e, i] + norm_q[e, j]
                d = scale - 2.0 * prod[e, i, j]
                if d <= threshold * scale:  # cancelled: the direct sum
                    d = 0.0
                    for t in range(dim):
                        diff = a[e, i, t] - b[e, j, t]
                        d += diff * diff
                    fixed += 1
                table[i, j] = area * d
    return fixed


def _boxes(horizontal, side):
    """Omega on p's and q's side of a (side x side) map: [row0, row1, col0, col1] each."""
    h = side // 2
    if horizontal:  # p left of q: p's right half meets q's left half
        return np.array([0, side, h, side]), np.array([0, side, 0, h])
    return np.array([h, side, 0, side]), np.array([0, h, 0, side])  # p above, q below


@functools.cache
def _half_to_double():
    """float64 of every float16 bit pattern (65,536 entries): an exact conversion table."""
    table = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float64)
    table.setflags(write=False)
    return table


@functools.cache
def _hardware_half():
    """Whether this processor converts float16 in hardware (x86's F16C; every AArch64).

    Then :func:`_as_double` compiles to that instruction (twice as fast as the table:
    measured 0.08 s against 0.15 s per 18-edge batch under load); elsewhere LLVM would
    call a runtime helper that numba may not provide, so the table is used.
    """
    try:
        import llvmlite.binding as llvm

        triple = llvm.get_process_triple()
        if triple.startswith(("aarch64", "arm64")):
            return True
        return triple.startswith(("x86_64", "amd64")) and bool(
            llvm.get_host_cpu_features().get("f16c", False)
        )
    except Exception:  # pragma: no cover - a platform llvmlite does not describe
        return False


@intrinsic
def _as_double(typingctx, value):
    """float64 of a float32 / float64, or of float16 bits held in a uint16 (exact)."""
    if value == types.uint16:

        def codegen(context, builder, signature, args):
            return builder.fpext(builder.bitcast(args[0], ir.HalfType()), ir.DoubleType())

    elif isinstance(value, types.Float):

        def codegen(context, builder, signature, args):
            return context.cast(builder, args[0], signature.args[0], types.float64)

    else:
        return None
    return types.float64(value), codegen


def _as_maps(array):
    """A database array as (F, A, S, S) maps to gather from, and its conversion table.

    float16 (the database's) is read as its bit patterns (numba has no float16),
    converted by the processor (:func:`_hardware_half`) or through
    :func:`_half_to_double`; float32 / float64 are read as they are (table None);
    other floats are converted to float64 first.
    """
    arr = np.ascontiguousarray(array)
    arr = arr.reshape(arr.shape[0], -1, *arr.shape[-2:])
    if arr.dtype == np.float16:
        return arr.view(np.uint16), None if _hardware_half() else _half_to_double()
    if arr.dtype not in (np.float32, np.float64):
        arr = arr.astype(np.float64)
    return arr, None


@njit(cache=True, nogil=True)
def _read(maps, table, f, a0, a1, box, row):
    """``row`` = maps[f, a0:a1, box rows, box cols] flattened, in float64 (exact)."""
    r0, r1, c0, c1 = box[0], box[1], box[2], box[3]
    width = c1 - c0
    j = 0
    for a in range(a0, a1):
        for r in range(r0, r1):
            # Slices, not indices: no negative-index wrap-around in the inner loop.
            src = maps[f, a, r, c0:c1]
            dst = row[j : j + width]
            for c in range(width):
                if table is None:
                    dst[c] = _as_double(src[c])
                else:
                    dst[c] = table[src[c]]
            j += width


@njit(cache=True, nogil=True)
def _gather_centred(maps, table, ids_p, ids_q, a0, a1, box_p, box_q, out_p, out_q, norm_p, norm_q):
    """Gather both sides' overlap features in float64, centre them, and their norms.

    ``out_p[e, i]`` = maps[ids_p[e, i], a0:a1, box_p rows, box_p cols] flattened
    (float16 bit patterns through ``table``, or :func:`_as_double`), likewise
    ``out_q``, both moved by the edge's mean candidate ``(sum_i out_p[e, i] + sum_j
    out_q[e, j]) / (Kp + Kq)``, summed in candidate order; ``norm_p[e, i]`` =
    ``|out_p[e, i]|^2`` (likewise ``norm_q``). The features are the same values, bit
    for bit, as numpy's ``np.take``, a cast to float64, ``a.sum(axis=1)`` (sequential
    over that axis) and the subtraction, in two passes instead of numpy's four over large
    temporaries and einsum's norms (the cast from float16 alone was once half of the
    tables' time).
    """
    n_e = ids_p.shape[0]
    dim = out_p.shape[2]
    n_p, n_q = ids_p.shape[1], ids_q.shape[1]
    sums = np.empty((2, dim))
    centre = np.zeros(dim)
    for e in range(n_e):
        # 1. The features, and each side's sum in candidate order.
        for side in range(2):
            ids = ids_p if side == 0 else ids_q
            box = box_p if side == 0 else box_q
            out = out_p if side == 0 else out_q
            total = sums[side]
            for i in range(ids.shape[1]):
                x = out[e, i]
                _read(maps, table, ids[e, i], a0, a1, box, x)
                if i == 0:
                    total[:] = x
                else:
                    total += x
        if dim > 0 and n_p > 0 and n_q > 0:
            for t in range(dim):
                centre[t] = (sums[0, t] + sums[1, t]) / (n_p + n_q)
        # 2. The centred features and their squared norms.
        for side in range(2):
            ids = ids_p if side == 0 else ids_q
            out = out_p if side == 0 else out_q
            norm = norm_p if side == 0 else norm_q
            for i in range(ids.shape[1]):
                norm[e, i] = _centre(out[e, i], centre)


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def _centre(x, centre):
    """``x -= centre`` and return ``|x|^2``.

    The subtraction is exact IEEE (the features' bits are tested); only the sum of
    squares may be reassociated, so that it runs in vector registers (the norms are
    used to 1e-13, not to the bit; measured: 4x faster than a strict left-to-right
    sum, which had made this pass as slow as the gather itself).
    """
    s = 0.0
    for t in range(x.size):
        v = x[t] - centre[t]
        x[t] = v
        s += v * v
    return s


def _workers():
    return max(1, min(4, len(usable_cores())))


class _TableBatches:
    """Fills the three tables for one batch of edges of one orientation per call.

    Thread-safe: each worker thread keeps its own float64 buffers (fresh large arrays
    per batch cost as much in page faults as filling them); batches write disjoint rows
    of the tables.
    """

    def __init__(self, cand, edges, spectra, texture, tables, weights=None):
        self.cand, self.edges, self.tables = cand, edges, tables
        # (sigma, rho * TEXTURE_SCALE): fill tables["w"] = W (Eq. 6) only, each batch's
        # three tables made in a small buffer of its own and combined there.
        self.weights = weights
        n_bins, k = spectra.shape[1], cand.shape[1]
        spec, spec_table = _as_maps(spectra)  # (F, NB * 2, 12, 12): bin-major
        tex, tex_table = _as_maps(texture)  # (F, L, 24, 24)
        # (table, maps, conversion, leading range, block area): which part of the
        # database each table measures; the leading range picks frequency bins
        # (two flow components per bin).
        self.terms = (
            ("dc", spec, spec_table, (0, 2), SPECTRA_BLOCK**2),
            ("rest", spec, spec_table, (2, 2 * n_bins), SPECTRA_BLOCK**2),
            ("tex", tex, tex_table, (0, tex.shape[1]), TEXTURE_BLOCK**2),
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
            k = self.cand.shape[1]
            buf = self.local.buffers = (
                tuple(np.empty(self.rows * self.width) for _ in range(2)),
                tuple(np.empty(self.rows) for _ in range(2)),
                np.empty(self.rows * k),
                None if self.weights is None else np.empty((3, self.batch, k, k)),
            )
        return buf

    def __call__(self, es, orientation):
        work, norms, prod, parts = self._buffers()
        k = self.cand.shape[1]
        n = len(es)
        ids_p = self.cand[self.edges[es, 0]]
        ids_q = self.cand[self.edges[es, 1]]
        fixed = 0
        if parts is None:
            tables, rows = self.tables, es
        else:  # this batch's three tables, then W from them (pair_smoothness)
            tables = {name: parts[i, :n] for i, name in enumerate(("dc", "rest", "tex"))}
            rows = np.arange(n)
        for table, maps, conversion, (a0, a1), area in self.terms:
            side = maps.shape[-1]
            box_p, box_q = _boxes(orientation, side)
            dim = (a1 - a0) * side * (side // 2)
            a, b = (w[: n * k * dim].reshape(n, k, dim) for w in work)
            na, nb = (w[: n * k].reshape(n, k) for w in norms)
            _gather_centred(maps, conversion, ids_p, ids_q, a0, a1, box_p, box_q, a, b, na, nb)
            if dim == 0:  # no such terms (a database of one frequency bin): d = 0
                tables[table][rows] = 0.0
                continue
            products = prod[: n * k * k].reshape(n, k, k)
            np.matmul(a, b.transpose(0, 2, 1), out=products)
            # Below this fraction of |a|^2 + |b|^2 a distance may have lost more than
            # _TABLE_RTOL to cancellation: _finish sums it directly.
            threshold = (2 * dim + 3) * np.finfo(np.float64).eps / _TABLE_RTOL
            fixed += _finish(products, na, nb, a, b, area, threshold, tables[table], rows)
        if parts is not None:
            _combine_rows(*parts[:, :n], *self.weights, self.tables["w"], es)
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
      :math:`d(T^{l_i}, T^{l_j})`, Eq. (6)'s :math:`\mathrm{texture}` without its unit
      :data:`TEXTURE_SCALE`;

    the factors 16 and 4 being the areas of the 4 x 4 and 2 x 2 pixel blocks the stored
    arrays are averaged over, so the sums approximate Eq. (3)'s full-resolution ones.

    Each table is computed as squared norms minus a matrix product, batched over edges
    of one orientation (in a grid each node is the ``p`` of at most one horizontal and
    one vertical edge, so every node's candidates are gathered once per side), in
    float64; entries where that formula cancels (near-duplicate candidates) are
    recomputed directly, so every entry is within 1e-9 relative of
    :func:`fluidnb.videodb.assignment.reference_pair_tables`. The overlap halves are gathered from
    the float16 arrays, converted, centred and their norms taken by one compiled
    kernel (:func:`_gather_centred`; numpy's take, cast and centring cost twice the
    matrix products), and the products become distances in another (:func:`_finish`),
    so only the products themselves are left to BLAS (about two thirds of the time).
    Batches of one or two edges (their features stay in the cache) run on up to 4
    threads (one per core), each with a single-threaded BLAS.

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
        ``tables.smoothness(sigma, rho)`` is :math:`W_{pq}` (Eq. 6) for the paper's
        :math:`\sigma` and :math:`\rho`.

    Raises
    ------
    ValueError
        On shapes that do not fit, ids out of range, or candidates whose spectra or
        textureness are not finite.
    """
    cand, edges, hor, spectra, texture = _check_tables_input(
        candidates, edges, horizontal, spectra, texture
    )
    n_edges, k = len(edges), cand.shape[1]
    tables = {name: np.empty((n_edges, k, k)) for name in ("dc", "rest", "tex")}
    recomputed = _fill(cand, edges, hor, spectra, texture, tables, None, progress)
    return PairTables(edges=edges.copy(), horizontal=hor.copy(), recomputed=recomputed, **tables)


def pair_smoothness(candidates, edges, horizontal, spectra, texture, sigma, rho, *, progress=None):
    r"""The pairwise term :math:`W_{pq}` of Eq. (6) alone, without keeping its three tables.

    ``pair_tables(...).smoothness(sigma, rho)``, bit for bit, made batch by batch: each
    batch's three tables are filled in a small buffer (as :func:`pair_tables` fills its
    rows) and combined there (:meth:`PairTables.smoothness`'s operations), so the three
    (E, K, K) tables are never held and never read back. For a result that needs no
    re-solve (:func:`fluidnb.videodb.animate` with ``stream=True``): at 1920 px (3779
    edges, K = 100) it holds 0.3 GB instead of 1.2 GB (three tables and W) and skips a
    pass over them.

    Parameters
    ----------
    candidates, edges, horizontal, spectra, texture, progress
        As :func:`pair_tables`.
    sigma, rho : float
        As :meth:`PairTables.smoothness`.

    Returns
    -------
    ndarray of float64, shape (E, K, K)
    """
    sigma = check_range("sigma", sigma, 0)
    rho = check_range("rho", rho, 0)
    cand, edges, hor, spectra, texture = _check_tables_input(
        candidates, edges, horizontal, spectra, texture
    )
    out = {"w": np.empty((len(edges), cand.shape[1], cand.shape[1]))}
    _fill(cand, edges, hor, spectra, texture, out, (sigma, rho * TEXTURE_SCALE), progress)
    return out["w"]


def _fill(cand, edges, hor, spectra, texture, tables, weights, progress):
    """Fill ``tables`` (three, or ``"w"`` with ``weights``) batch by batch; the recomputed count."""
    report = Progress(progress)
    n_edges = len(edges)
    builder = _TableBatches(cand, edges, spectra, texture, tables, weights)
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
    with blas_single_threaded(), spread_pool(workers, "fluidnb-tables") as pool:
        futures = [pool.submit(builder, es, o) for es, o in batches]
        try:
            for future in as_completed(futures):
                done += future.result()
                report(done / max(n_edges, 1), f"smoothness tables: {done}/{n_edges} edges")
        finally:
            for future in futures:
                future.cancel()
    for name, table in tables.items():
        if not _all_finite(table.reshape(-1).view(np.uint64)):
            what = {"tex": "texture", "w": "spectra or texture"}.get(name, "spectra")
            raise ValueError(
                f"the candidates' {what} contain NaN or infinite values; all must be finite"
            )
    report(1.0, "smoothness tables done")
    return builder.recomputed
