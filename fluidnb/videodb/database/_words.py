r"""Visual words and spatial-pyramid histograms of the fragments (Okabe et al., secs. 4-5).

- The codebook (:func:`fit_codebook`): the :math:`k` = 200 centres of the dense SIFT
  descriptors found by repeated cluster bisectioning (the paper's choice, after
  Steinbach et al. 2000: faster than k-means and as good), here scikit-learn's
  :class:`~sklearn.cluster.BisectingKMeans` on a seeded sample of at most ~1M
  descriptors.
- Quantisation (:func:`quantise`): each descriptor's visual word is its *nearest*
  centre in float64 (ties to the lowest index). Not ``BisectingKMeans.predict()``:
  that descends the bisection tree, comparing the descriptor with the centres of the
  clusters that were split, and disagrees with the nearest centre on ~40 % of real
  descriptors (measured; see the tests for a small case where it does).
- Histograms (:func:`pyramid_histograms`): the spatial pyramid of Lazebnik et al.
  (2006), levels 0-2, of a fragment's 9 x 9 word map, and their intersection
  (:func:`intersection`, the paper's Eq. 1):

  .. math::

      I(H_e, H_t) = \sum_{i} \min(H_e[i], H_t[i])                     \quad (1)

  Descriptor :math:`j` (per axis) sits at pixel :math:`4j + 8`; at level :math:`l` its
  cell per axis is :math:`\lfloor (4j + 8)\, 2^l / 48 \rfloor`. The 1 + 4 + 16 = 21
  cells are numbered level by level, row-major; bin ``cell * k + word`` counts the
  descriptors of that cell with that word, times 1, 1, 2 for levels 0, 1, 2
  (Lazebnik's weights 1/4, 1/4, 1/2, times 4, so that counts stay integers). Every
  histogram sums to 81 + 81 + 162 = 324, and :func:`intersection` returns
  :math:`I / 324 \in [0, 1]`, 1 for identical word maps.

References
----------
.. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
   using video database", Pacific Graphics 2011.
.. [2] S. Lazebnik, C. Schmid, J. Ponce, "Beyond bags of features: spatial pyramid
   matching for recognizing natural scene categories", CVPR 2006.
.. [3] M. Steinbach, G. Karypis, V. Kumar, "A comparison of document clustering
   techniques", KDD Workshop on Text Mining, 2000 (bisecting k-means).
.. [4] S. M. Savaresi, D. L. Boley, "A comparative analysis on the bisecting K-means
   and the PDDP clustering algorithms", Intelligent Data Analysis 8(4), 2004.
.. [5] scikit-learn, ``sklearn.cluster.BisectingKMeans``.
"""

from __future__ import annotations

import numbers
import os

import numpy as np

from ..._random import rng
from ..._threads import blas_single_threaded
from ..._validation import check_array, check_int
from .._common._geometry import FRAGMENT, GRID, LEVELS

__all__ = [
    "CELLS",
    "CODEBOOK_THREADS",
    "HISTOGRAM_TOTAL",
    "LEVEL_WEIGHTS",
    "fit_codebook",
    "intersection",
    "pyramid_cells",
    "pyramid_histograms",
    "quantise",
]

#: Cells of the pyramid: 1 + 4 + 16.
CELLS = sum(4**level for level in range(LEVELS))
#: Integer weight of a descriptor's count at levels 0, 1, 2 (Lazebnik's 1/4, 1/4, 1/2
#: times 4).
LEVEL_WEIGHTS = (1, 1, 2)
#: What every pyramid histogram sums to: 81 * (1 + 1 + 2).
HISTOGRAM_TOTAL = GRID * GRID * sum(LEVEL_WEIGHTS)

# scikit-learn's clustering runs on OpenMP threads, which spin while they wait for work
# by default; on a machine whose cores are busy (a class server, CI, a build of another
# starter database beside this one) a spinning thread that loses its core stalls every
# parallel loop: fit_codebook measured 7-12 times slower (same centres) than with
# passive waiting. Set before scikit-learn loads its OpenMP runtime (it is imported
# only when a codebook is fitted), and only when the user has not chosen;
# fluidnb.fluid sets the same for numba's.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# Rows per block in quantise: a block's float64 copy and its (rows, k) scores stay
# around 10 MB.
_BLOCK = 4096


def pyramid_cells():
    """The pyramid cell of every descriptor at each level.

    Returns
    -------
    ndarray, shape (3, 81), int64
        ``cells[l, 9 * jy + jx]``: the cell (numbered 0-20 over all levels, level by
        level, row-major) of descriptor ``(jy, jx)`` at level ``l``.

    Examples
    --------
    >>> c = pyramid_cells()
    >>> int(c[0].max()), sorted(set(c[1].tolist())), c[2, :9].tolist()
    (0, [1, 2, 3, 4], [5, 6, 6, 6, 7, 7, 7, 8, 8])
    """
    pos = 4 * np.arange(GRID) + 8  # a descriptor's centre, in pixels
    out = np.empty((LEVELS, GRID * GRID), np.int64)
    first = 0
    for level in range(LEVELS):
        side = 2**level
        cell = pos * side // FRAGMENT
        out[level] = first + (cell[:, None] * side + cell[None, :]).ravel()
        first += side * side
    return out


#: OpenMP threads of the clustering, fixed. scikit-learn splits each Lloyd iteration's
#: float sums between its threads, so another count gives centres that differ in the
#: last bits -- or, now and then, a bisection that goes another way: the codebook
#: depended on the machine's cores and on ``OMP_NUM_THREADS`` (which dask.distributed
#: sets to 1). Fixed, the same descriptors give the same codebook everywhere; two, the
#: count the starter databases were first built with.
CODEBOOK_THREADS = 2


def _bisecting_kmeans(k, random_state):
    """The clustering :func:`fit_codebook` runs (the tests build the same one)."""
    from sklearn.cluster import BisectingKMeans

    class _FixedThreads(BisectingKMeans):
        # fit() sets _n_threads from the environment; every bisection (its Lloyd
        # iterations and inertias) then runs on CODEBOOK_THREADS instead.
        def _bisect(self, *args, **kwargs):
            self._n_threads = CODEBOOK_THREADS
            return super()._bisect(*args, **kwargs)

    # scikit-learn's defaults otherwise: random init, one init per bisection, Lloyd,
    # split the cluster of largest inertia.
    return _FixedThreads(n_clusters=k, random_state=random_state)


def fit_codebook(descriptors, k=200, *, max_samples=1_000_000, seed=0):
    r"""The codebook: :math:`k` visual words by repeated cluster bisectioning.

    Parameters
    ----------
    descriptors : array_like, shape (..., D)
        Descriptors (uint8 dense SIFT, ``D = 128``), any leading shape.
    k : int
        :math:`k`, the number of visual words (Okabe et al., sec. 4: 200, the best of 100,
        200, 300 and 500).
    max_samples : int
        At most this many rows, drawn without replacement with ``seed``, are
        clustered (kept in their original order).
    seed : None, int or numpy.random.Generator
        Draws the sample and seeds the clustering (an int is passed on as
        ``random_state``). Same seed, same codebook.

    Returns
    -------
    ndarray, shape (k, D), float64
        The centres (words), in scikit-learn's order.

    Raises
    ------
    ValueError
        If there are fewer rows than ``k`` (or bad arguments).

    Notes
    -----
    scikit-learn's :class:`~sklearn.cluster.BisectingKMeans` with its defaults
    (``bisecting_strategy="biggest_inertia"``, one random init per split), on the
    sample as float32. Measured on this project's 2-core machine: ~7 s for 100k
    descriptors, ~25 s for 300k.

    Examples
    --------
    >>> gen = np.random.default_rng(0)
    >>> blobs = np.repeat([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]], 20, axis=0)
    >>> c = fit_codebook(blobs + gen.normal(0, 0.1, blobs.shape), 3, seed=0)
    >>> (np.round(c[np.lexsort(c.T[::-1])]) + 0.0).tolist()
    [[0.0, 0.0], [0.0, 10.0], [10.0, 0.0]]
    """
    x = check_array("descriptors", descriptors, ndim=None, dtype_kinds="iuf")
    if x.ndim < 2:
        raise ValueError(f"descriptors must have shape (..., D), got {x.shape}")
    x = x.reshape(-1, x.shape[-1])
    k = check_int("k", k, 1)
    max_samples = check_int("max_samples", max_samples, 1)
    gen = rng(seed)
    if len(x) < k:
        raise ValueError(
            f"descriptors has {len(x)} rows: a codebook of k = {k} words needs at least {k}"
        )
    if max_samples < k:
        raise ValueError(f"max_samples must be >= k ({k}), got {max_samples}")
    if len(x) > max_samples:
        x = x[np.sort(gen.choice(len(x), max_samples, replace=False))]
    # Clustered in float32: half the memory traffic of float64 and ~1.7 times as fast
    # here; the centres are returned (and words assigned, :func:`quantise`) in float64.
    sample = np.asarray(x, dtype=np.float32)
    if isinstance(seed, numbers.Integral):
        random_state = int(seed)
    else:
        random_state = int(gen.integers(2**31 - 1))
    model = _bisecting_kmeans(k, random_state).fit(sample)
    return np.ascontiguousarray(model.cluster_centers_, dtype=np.float64)


def _word_dtype(k):
    return np.uint8 if k <= 256 else (np.uint16 if k <= 65536 else np.int64)


def _check_pair(descriptors, centres):
    x = check_array("descriptors", descriptors, ndim=None, dtype_kinds="iuf", min_size=0)
    c = check_array("centres", centres, ndim=2, dtype_kinds="iuf")
    if x.ndim < 1 or x.shape[-1] != c.shape[1]:
        raise ValueError(
            f"descriptors must have shape (..., {c.shape[1]}) like the centres "
            f"{c.shape}, got {x.shape}"
        )
    return x, np.ascontiguousarray(c, dtype=np.float64)


def _squared_distances(x, c):
    """``sum_i (x_i - c_i)^2`` in float64: x (m, D), c (m, j, D) or (j, D) -> (m, j).

    The one place :func:`quantise` computes them directly (its near-ties), as numpy
    sums the plain expression: :func:`~fluidnb.videodb.database.reference_quantise`
    writes the same, so the two sum every value in the same order.
    """
    diff = x[:, None, :] - c
    return (diff * diff).sum(axis=-1)


def quantise(descriptors, centres):
    r"""The visual word of every descriptor: the index of its nearest centre.

    Parameters
    ----------
    descriptors : array_like, shape (..., D)
        Descriptors (uint8 dense SIFT), any leading shape, e.g. (B, 9, 9, 128).
    centres : array_like, shape (k, D)
        The codebook (:func:`fit_codebook`).

    Returns
    -------
    ndarray, shape (...)
        ``argmin_c sum_i (x_i - c_i)^2`` in float64, ties to the lowest index (exactly
        :func:`~fluidnb.videodb.database.reference_quantise`). uint8 when ``k <= 256``,
        uint16 up to 65536, else int64.

    Notes
    -----
    Not ``BisectingKMeans.predict()``, which descends the bisection tree and
    disagrees with the nearest centre on ~40 % of real descriptors.

    Blocks of 4096 rows are screened in float32 (twice as fast as float64; the
    matrix product is nearly all the time: ~5 s for 1M descriptors here): scores
    :math:`\|c\|^2 - 2\, x \cdot c` (the :math:`\|x\|^2` they share does not change
    the order), whose round-off, casts included, is at most
    :math:`(D + 6)\, u\, (\|x\| + \max\|c\|)^2` with :math:`u = 2^{-24}` (~8 for
    SIFT descriptors, whose squared distances to their words are ~1e4-1e5). Every
    centre scoring within 4 times that of the best is a candidate; where a row has
    several, their distances are computed directly in float64, as the reference
    does. A centre outside that margin cannot be the nearest, so the answer is
    exact, and it does not depend on how the rows are split into blocks.

    The products run on one BLAS thread: a block's product is a few milliseconds,
    and OpenBLAS's threads, once woken, spin on the cores for a while after it --
    through the smoothness tables that follow in :func:`~fluidnb.videodb.assign`
    (~0.08 s of CPU each time, measured), or beside a build's other clips.

    Examples
    --------
    >>> centres = np.array([[0.0, 0.0], [4.0, 0.0]])
    >>> quantise(np.array([[1, 0], [3, 0], [2, 0]], np.uint8), centres).tolist()
    [0, 1, 0]
    """
    x, c = _check_pair(descriptors, centres)
    lead, d = x.shape[:-1], x.shape[-1]
    k = c.shape[0]
    rows = x.reshape(-1, d)
    out = np.empty(len(rows), _word_dtype(k))
    c2 = (c * c).sum(axis=1)
    cmax = float(np.sqrt(c2.max()))
    c32, c2_32 = c.astype(np.float32), c2.astype(np.float32)
    margin = 4.0 * (d + 6) * 2.0**-24
    with blas_single_threaded():  # see Notes
        for lo in range(0, len(rows), _BLOCK):
            xb = np.asarray(rows[lo : lo + _BLOCK], dtype=np.float64)
            scores = c2_32[None, :] - np.float32(2) * (xb.astype(np.float32) @ c32.T)
            best = scores.min(axis=1).astype(np.float64)
            tol = margin * (np.sqrt((xb * xb).sum(axis=1)) + cmax) ** 2
            near = scores <= (best + tol)[:, None]
            words = scores.argmin(axis=1)
            many = np.flatnonzero(near.sum(axis=1) > 1)
            if len(many):
                # Near-ties: decide them on the directly computed distances, over the
                # candidates only (in index order, so argmin keeps the lowest index).
                j = int(near[many].sum(axis=1).max())
                cand = np.argsort(~near[many], axis=1, kind="stable")[:, :j]
                valid = np.take_along_axis(near[many], cand, axis=1)
                dist = _squared_distances(xb[many], c[cand])
                dist[~valid] = np.inf
                words[many] = cand[np.arange(len(many)), dist.argmin(axis=1)]
            out[lo : lo + len(xb)] = words
    return out.reshape(lead)


def _check_words(words, k, *, name="words"):
    """Word maps (..., 9, 9) of integers in [0, k)."""
    arr = check_array(name, words, ndim=None, dtype_kinds="iu", min_size=0)
    if arr.ndim < 2 or arr.shape[-2:] != (GRID, GRID):
        raise ValueError(f"{name} must have shape (..., 9, 9) (a 9 x 9 word map), got {arr.shape}")
    if arr.size and (int(arr.min()) < 0 or int(arr.max()) >= k):
        raise ValueError(
            f"{name} must hold visual words in [0, {k - 1}] for k = {k}, got values in "
            f"[{int(arr.min())}, {int(arr.max())}]"
        )
    return arr


def pyramid_histograms(words, k):
    r"""Spatial-pyramid histograms (levels 0-2) of 9 x 9 visual-word maps.

    Parameters
    ----------
    words : array_like of int, shape (B, 9, 9) or (9, 9)
        Visual words in ``[0, k)`` (:func:`quantise` of :func:`dense_sift`).
    k : int
        :math:`k`, the codebook's size.

    Returns
    -------
    ndarray, shape (B, 21 * k) or (21 * k,), uint8
        :math:`H[\mathrm{cell} \cdot k + w]`: the descriptors of word :math:`w` in the
        cell, times 1, 1, 2 at levels 0, 1, 2 (see the module notes). Each row sums
        to 324; the largest count, 81, fits 8 bits.

    References
    ----------
    .. [1] S. Lazebnik, C. Schmid, J. Ponce, "Beyond bags of features", CVPR 2006.

    Examples
    --------
    >>> h = pyramid_histograms(np.zeros((9, 9), np.uint8), 2)
    >>> int(h.sum()), h[:2].tolist(), h[2:10].tolist()
    (324, [81, 0], [16, 0, 20, 0, 20, 0, 25, 0])
    """
    k = check_int("k", k, 1)
    w = _check_words(words, k)
    single = w.ndim == 2
    flat = w.reshape(-1, GRID * GRID)
    cells = pyramid_cells()
    # Level 2's weight 2 as its indices listed twice: integer counts, one bincount.
    offset = np.concatenate([cells[0], cells[1], cells[2], cells[2]]) * k
    n, dims = len(flat), CELLS * k
    hist = np.empty((n, dims), np.uint8)
    step = max(1, _BLOCK * 64 // dims)  # bounded scratch: ~2 MB of int64 counts
    for lo in range(0, n, step):
        part = flat[lo : lo + step].astype(np.int64)
        cols = np.tile(part, 4) + offset
        cols += np.arange(len(part), dtype=np.int64)[:, None] * dims
        counts = np.bincount(cols.ravel(), minlength=len(part) * dims)
        hist[lo : lo + len(part)] = counts.reshape(len(part), dims)
    return hist[0] if single else hist


def intersection(h_a, h_b):
    r"""Normalised histogram intersection :math:`I(H_e, H_t) / 324` (Eq. 1).

    Parameters
    ----------
    h_a, h_b : array_like, shape (..., 21 * k)
        Pyramid histograms (:func:`pyramid_histograms`); leading axes broadcast.

    Returns
    -------
    ndarray or float, shape (...)
        :math:`\sum_i \min(H_e[i], H_t[i]) / 324` in [0, 1]: 1 for identical word
        maps.

    Examples
    --------
    >>> a = pyramid_histograms(np.zeros((9, 9), np.uint8), 2)
    >>> b = pyramid_histograms(np.ones((9, 9), np.uint8), 2)
    >>> float(intersection(a, a)), float(intersection(a, b))
    (1.0, 0.0)
    """
    a = check_array("h_a", h_a, ndim=None, dtype_kinds="iuf")
    b = check_array("h_b", h_b, ndim=None, dtype_kinds="iuf")
    if a.ndim < 1 or b.ndim < 1 or a.shape[-1] != b.shape[-1] or a.shape[-1] % CELLS:
        raise ValueError(
            f"h_a and h_b must be pyramid histograms of the same length 21 * k, got "
            f"shapes {a.shape} and {b.shape}"
        )
    if (a.dtype.kind in "if" and a.min() < 0) or (b.dtype.kind in "if" and b.min() < 0):
        raise ValueError("h_a and h_b must be histograms (counts >= 0)")
    exact = a.dtype.kind in "iu" and b.dtype.kind in "iu"
    total = np.minimum(a, b).sum(axis=-1, dtype=np.int64 if exact else np.float64)
    return total / HISTOGRAM_TOTAL
