r"""Reiter's hexagonal automaton with the paper's random threshold (Sec. 3.2-3.3).

State: the vapour field :math:`u_t(p)` on the lattice cells. A cell with
:math:`u \ge 1` is *ice*; a cell that is not ice but has an ice neighbour is a
*frontier* cell; together they are the *receptive* set :math:`R_t`. One step:

1. split :math:`u` into :math:`a` (on :math:`R_t`, 0 elsewhere) and :math:`b` (off
   :math:`R_t`, 0 on it);
2. boundary ring: every ring point takes the mean of its region neighbours' values in
   this diffusion field (Sec. 3.3; receptive neighbours count 0);
3. diffuse :math:`b` everywhere, :math:`b \leftarrow b + \frac{\alpha}{12}(-6b +
   \sum_{q \in nn(p)} b(q))` (the paper's :math:`D_t`; receptive cells take part with
   :math:`b = 0`, so they receive inflow and lose nothing);
4. add :math:`\gamma` to :math:`a` on the ice cells and on the frontier cells whose
   fresh :math:`r_t(p) \sim U[0, 1]` exceeds :math:`r_{th}` (Eq. (1));
5. :math:`u_{t+1} = a + b`.

Two readings are decisions (recorded in the spec and here):

- A frontier cell with :math:`r_t(p) \le r_{th}` stays receptive: it keeps its
  vapour, receives inflow and only misses :math:`\gamma` for that step (the other
  reading stalls growth near :math:`r_{th} = 0.8`).
- The ring's mean is taken in the diffusion field, where Sec. 3.2 counts ice and
  frontier cells as 0.0. The ring then gives its receptive neighbours exactly what it
  takes from the others, so the total vapour changes by :math:`\gamma` times the
  number of cells that got :math:`\gamma`, nothing else. The mean of the raw
  :math:`u` (ice included) instead feeds ice from a ring point whose value follows
  that ice: near the boundary the vapour grows exponentially (measured: 5e4 after 50
  steps with :math:`\alpha = 1.3`), and frost races along the region's edge.
"""

from __future__ import annotations

import numbers
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy import sparse

from .._progress import Progress
from .._random import resolve_seed, rng
from .._validation import check_array, check_int
from ._lattice import HexLattice
from ._params import FrostParams

__all__ = ["FrostResult", "grow", "step"]

# Vapour is float64 although float32 would be faster: cells in symmetric positions sum
# their neighbours in different orders, and float32 rounding would then, now and then,
# put one of them just below 1 and its mirror image just above, breaking the exact
# six-fold symmetry of Reiter's crystals.
_DTYPE = np.float64

# How many steps between progress reports (a 1000 x 1000 lattice steps in ~30 ms, so a
# Cancel lands within about half a second).
_REPORT_EVERY = 16


@dataclass(frozen=True, eq=False)
class FrostResult:
    r"""The outcome of one frost run: when each cell froze, and how the run ended.

    Attributes
    ----------
    lattice : HexLattice
        The lattice the run used.
    freeze_frame : ndarray of int32, shape (n_cells,)
        The frame at which each cell became ice (0 for the starts), -1 if it never
        did within the run.
    end_frame : int or None
        :math:`T_{sim}`: the first frame with at least ``coverage`` of the region's
        cells frozen (Sec. 3.4), or ``None`` if the run never got there.
    n_frames : int
        The last frame simulated (frames are 0 .. n_frames).
    coverage : ndarray of float, shape (n_frames + 1,)
        Fraction of the region's cells frozen at each frame.
    gamma_cells : ndarray of int, shape (n_frames,)
        How many cells received :math:`\\gamma` in the step from frame t to t + 1.
    vapour : ndarray, shape (n_frames + 1, n_cells), or None
        :math:`u_t(p)` at every frame (``record_vapour=True`` only).
    starts : ndarray of intp
        The start cells.
    beta : float or ndarray
        The initial vapour (a scalar, or one value per cell).
    params : FrostParams
        The parameters of the run.
    seed : int
        The random seed the run used (:func:`fluidnb.resolve_seed`): pass it to
        :func:`grow` again to remake the run.
    message : str
        How the run ended, in words.
    seconds : float
        Wall time of the run.
    """

    lattice: HexLattice
    freeze_frame: np.ndarray
    end_frame: int | None
    n_frames: int
    coverage: np.ndarray
    gamma_cells: np.ndarray
    vapour: np.ndarray | None
    starts: np.ndarray
    beta: object
    params: FrostParams
    seed: int = 0
    message: str = ""
    seconds: float = field(default=0.0, repr=False)

    def ice_at(self, frame):
        """Boolean mask (n_cells,) of the cells that are ice at ``frame``."""
        frame = check_int("frame", frame, 0, self.n_frames)
        return (self.freeze_frame >= 0) & (self.freeze_frame <= frame)

    @property
    def reached(self):
        """Whether the run reached its end frame (``coverage`` of the region frozen)."""
        return self.end_frame is not None

    def __repr__(self):
        return f"FrostResult({self.message})"


class _Kernel:
    """Preallocated buffers and operators for stepping one lattice.

    :meth:`advance` runs the step compiled; :meth:`advance_numpy` is the same step
    vectorised in numpy, the version read against the paper (and the tests' reference).

    Works on the lattice's sheared flat storage, where the six neighbours of every
    point are at the same offsets, so each neighbour sum is four contiguous slice
    operations; never a per-cell Python loop. Only the span ``[lo, hi)`` that holds
    every cell and ring point is updated.
    """

    def __init__(self, lattice, alpha, gamma, rth):
        self.lattice = lattice
        self.alpha, self.gamma, self.rth = float(alpha), float(gamma), float(rth)
        size, s = lattice.storage_size, lattice.stride
        self.s = s
        self.lo, self.hi = s, size - s
        span = self.hi - self.lo
        self.is_cell = np.zeros(size, bool)
        self.is_cell[lattice.cells] = True
        self.is_cell_i = self.is_cell[self.lo : self.hi]
        self.ring_mean = _ring_operator(lattice)
        self.ice = np.zeros(size, bool)
        self.ice_i = self.ice[self.lo : self.hi]
        self.pair_bool = np.zeros(size - 1, bool)
        self.receptive = np.zeros(span, bool)
        self.gets_gamma = np.zeros(span, bool)
        self.b = np.zeros(size, _DTYPE)
        self.b_i = self.b[self.lo : self.hi]
        self.pair = np.zeros(size - 1, _DTYPE)
        self.a = np.zeros(span, _DTYPE)
        self.nsum = np.zeros(span, _DTYPE)
        self.random_shape = (span,)
        self._no_r = np.zeros(1, np.float32)
        self._ring_values = np.zeros(lattice.n_ring, _DTYPE)

    def classify(self, u):
        """Ice (u >= 1, region cells only: ring points never freeze); returns the count."""
        np.greater_equal(u, 1.0, out=self.ice)
        self.ice &= self.is_cell
        return int(np.count_nonzero(self.ice_i))

    def advance(self, u, r=None):
        """One step u_t -> u_{t+1} in place (after classify).

        ``r`` holds the step's random numbers on ``[lo, hi)``, or ``None`` when every
        frontier cell gets gamma (rth = 0). Returns how many cells got gamma.

        Compiled (:func:`_advance_compiled`): the same operations, element by element
        and in the same order, as :meth:`advance_numpy`, so the same bits (the tests
        check it), in one pass instead of ~25 numpy calls -- a live preview's few
        hundred steps on a small lattice were mostly their overhead (24 -> 5 us a step).
        """
        m = self.ring_mean
        use_r = r is not None
        n_gets = _advance_compiled(
            u,
            self.b,
            self.ice,
            self.is_cell,
            self.lattice.ring,
            m.indptr,
            m.indices,
            m.data,
            r if use_r else self._no_r,
            use_r,
            np.float32(self.rth),
            self.alpha / 12.0,
            1.0 - self.alpha / 2.0,
            self.gamma,
            self.lo,
            self.hi,
            self.s,
            self.receptive,
            self.gets_gamma,
            self._ring_values,
        )
        return int(n_gets)

    def advance_numpy(self, u, r=None):
        """:meth:`advance` in numpy: the step as vectorised array operations (reference)."""
        lo, hi, s = self.lo, self.hi, self.s
        rec = self.receptive
        _neighbour_op(np.logical_or, self.ice, rec, self.pair_bool, lo, hi, s)  # frontier
        rec |= self.ice_i
        rec &= self.is_cell_i  # the ring is never receptive: its b feeds the diffusion
        # b: vapour off the receptive set (receptive cells count as 0 in D_t).
        np.copyto(self.b, u)
        np.copyto(self.b_i, 0.0, where=rec)
        # Boundary (Sec. 3.3): each ring point takes the mean of its region neighbours'
        # vapour as the diffusion sees it (receptive ones count 0). What the ring then
        # gives its receptive neighbours it takes from the others: no net exchange.
        ring = self.lattice.ring
        self.b[ring] = self.ring_mean @ self.b
        u[ring] = self.b[ring]
        # Diffusion b + alpha/12 (-6 b + sum of neighbours) = (1 - alpha/2) b + alpha/12 sum.
        _neighbour_op(np.add, self.b, self.nsum, self.pair, lo, hi, s)
        self.nsum *= self.alpha / 12.0
        self.b_i *= 1.0 - self.alpha / 2.0
        self.nsum += self.b_i
        # a: vapour on the receptive set, plus gamma where Eq. (1) gives it.
        np.multiply(u[lo:hi], rec, out=self.a)
        if r is None:
            gets = rec
        else:
            gets = self.gets_gamma
            np.greater(r, self.rth, out=gets)
            gets |= self.ice_i  # ice always gets gamma; frontier cells only if r > rth
            gets &= rec
        np.add(self.a, self.gamma, out=self.a, where=gets)
        np.add(self.nsum, self.a, out=u[lo:hi])
        return int(np.count_nonzero(gets))


@njit(cache=True, nogil=True)
def _advance_compiled(
    u, b, ice, is_cell, ring, indptr, indices, data, r, use_r, rth, alpha12, keep, gamma,
    lo, hi, s, receptive, gets_gamma, ring_values,
):  # fmt: skip
    """:meth:`_Kernel.advance_numpy`, element by element in its order; returns the gamma count.

    Fills ``receptive`` (and ``gets_gamma`` when ``use_r``) as it does; ``b`` ends as
    the diffusion field with the ring's means (before the diffusion's own scaling).
    """
    # The receptive set: a neighbour is ice (the frontier) or the cell itself, cells only.
    for k in range(lo, hi):
        near = (ice[k - 1] or ice[k + 1]) or (ice[k - s] or ice[k - s + 1])
        near = near or (ice[k + s - 1] or ice[k + s])
        receptive[k - lo] = (near or ice[k]) and is_cell[k]
    # b: the vapour off the receptive set.
    for k in range(b.size):
        b[k] = u[k]
    for k in range(lo, hi):
        if receptive[k - lo]:
            b[k] = 0.0
    # The ring's means of their region neighbours in b (scipy's CSR product's order).
    for i in range(ring.size):
        total = 0.0
        for j in range(indptr[i], indptr[i + 1]):
            total += data[j] * b[indices[j]]
        ring_values[i] = total
    for i in range(ring.size):
        b[ring[i]] = ring_values[i]
        u[ring[i]] = ring_values[i]
    # Diffusion of b, and a: the receptive vapour plus gamma; u = diffused b + a.
    n_gets = 0
    for k in range(lo, hi):
        near_sum = ((b[k - 1] + b[k + 1]) + (b[k - s] + b[k - s + 1])) + (b[k + s - 1] + b[k + s])
        diffused = near_sum * alpha12 + b[k] * keep
        rec = receptive[k - lo]
        a = u[k] * (1.0 if rec else 0.0)
        gets = rec
        if use_r:
            gets = ((r[k - lo] > rth) or ice[k]) and rec
            gets_gamma[k - lo] = gets
        if gets:
            a = a + gamma
            n_gets += 1
        u[k] = diffused + a
    return n_gets


def _neighbour_op(op, x, out, pair, lo, hi, s):
    """Combine the six neighbours of every point in [lo, hi) with ``op`` (add or or).

    Neighbours sit at offsets +-1, -s and -s + 1 (the pair above), s - 1 and s (the
    pair below): ``out = (x[k-1] op x[k+1]) op pair[k-s] op pair[k+s-1]`` with
    ``pair[m] = x[m] op x[m+1]``.
    """
    op(x[:-1], x[1:], out=pair)
    op(x[lo - 1 : hi - 1], x[lo + 1 : hi + 1], out=out)
    op(out, pair[lo - s : hi - s], out=out)
    op(out, pair[lo + s - 1 : hi + s - 1], out=out)
    return out


def _ring_operator(lattice):
    """Sparse (n_ring, storage size) matrix averaging each ring point's region neighbours."""
    n_cells, n_ring = lattice.n_cells, lattice.n_ring
    nbrs = lattice.neighbours[n_cells:]
    is_cell = (nbrs >= 0) & (nbrs < n_cells)
    counts = is_cell.sum(axis=1)  # >= 1 by construction of the ring
    rows = np.repeat(np.arange(n_ring), 6)[is_cell.ravel()]
    cols = lattice.cells[nbrs[is_cell]]
    vals = (1.0 / counts)[rows]
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n_ring, lattice.storage_size))


def _check_lattice(lattice):
    if not isinstance(lattice, HexLattice):
        raise ValueError(
            "lattice must be a HexLattice (HexLattice.from_mask(region, spacing)), "
            f"got {type(lattice).__name__}"
        )
    return lattice


def _check_params(params):
    if params is None:
        return FrostParams()
    if not isinstance(params, FrostParams):
        raise ValueError(f"params must be a FrostParams, got {type(params).__name__}")
    return params


def _start_cells(lattice, starts):
    """Start points as cell indices: a 1-D integer array of cells, or (n, 2) pixel points."""
    if starts is None:
        raise ValueError("starts is empty: place at least one start point in the region")
    arr = np.asarray(starts)
    if arr.size == 0:
        raise ValueError("starts is empty: place at least one start point in the region")
    if arr.ndim == 1 and arr.dtype.kind in "iu":
        if arr.min() < 0 or arr.max() >= lattice.n_cells:
            raise ValueError(
                f"start cells must be indices in [0, {lattice.n_cells - 1}], "
                f"got {arr.min()}..{arr.max()}"
            )
        return np.unique(arr).astype(np.intp)
    return lattice.snap(arr)


def _initial_beta(lattice, params, beta):
    if beta is None:
        return params.beta
    if isinstance(beta, numbers.Real) and not isinstance(beta, bool):
        return params.replace(beta=float(beta)).beta
    arr = check_array("beta", beta, ndim=1, dtype_kinds="iuf")
    if arr.shape != (lattice.n_cells,):
        raise ValueError(
            f"beta must be a number or one value per cell ({lattice.n_cells},), "
            f"got shape {arr.shape}"
        )
    if arr.min() < 0 or arr.max() > 1:
        raise ValueError(f"beta must be in [0, 1], got values {arr.min():g}..{arr.max():g}")
    out = arr.astype(_DTYPE)  # a copy: the caller's array is never kept or changed
    out.setflags(write=False)
    return out


def _initial_state(lattice, beta, starts):
    u = np.zeros(lattice.storage_size, _DTYPE)
    u[lattice.cells] = beta
    u[lattice.cells[starts]] = 1.0
    return u


def grow(
    lattice,
    starts,
    params=None,
    *,
    beta=None,
    seed=None,
    frames=None,
    record_vapour=False,
    progress=None,
):
    r"""Grow frost from start cells with Reiter's automaton and a random threshold.

    :math:`u_0(p) = \beta` everywhere and 1 at the starts; each step applies the
    boundary rule (Sec. 3.3) and Eq. (1) of [1]_ on the region's cells, vectorised
    over the lattice (see the module docstring for the step).

    Parameters
    ----------
    lattice : HexLattice
        The region's lattice (:meth:`HexLattice.from_mask`).
    starts : array_like
        Start points: an (n, 2) array of pixel (row, col) coordinates (snapped with
        :meth:`HexLattice.snap`) or a 1-D integer array of cell indices.
    params : FrostParams, optional
        :math:`\beta, \gamma, \alpha, r_{th}`, the end-frame ``coverage`` and the
        frame limit ``max_frames`` (default: the paper's values).
    beta : float or ndarray, shape (n_cells,), optional
        Overrides ``params.beta``; an array gives every cell its own initial vapour
        (e.g. from :func:`direction_beta`).
    seed : None, int or numpy.random.Generator
        Random seed of :math:`r_t(p)`. The stream is drawn for the whole lattice every step,
        so runs with different :math:`\beta` and the same seed see the same
        :math:`r_t(p)` for every (step, cell): common random numbers. With
        :math:`r_{th} = 0` no numbers are drawn (every frontier cell gets
        :math:`\gamma`), which is Reiter's model exactly.
    frames : int, optional
        Run exactly this many steps (frames 0 .. frames). By default the run stops
        at the end frame, or at ``params.max_frames``.
    record_vapour : bool
        Keep :math:`u_t(p)` of every frame in :attr:`FrostResult.vapour`.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` in it to stop.

    Returns
    -------
    FrostResult
        Freeze frame of every cell, the end frame :math:`T_{sim}` (or ``None`` with
        a plain message if the run did not get there), coverage per frame.

    Raises
    ------
    ValueError
        For starts outside the region, an invalid ``beta`` or ``frames``.

    References
    ----------
    .. [1] M. Amano, S. Sato, T. Itoh, "スケッチ入力を用いた氷・霜アニメーション生成の
       ための初期値最適化による成長速度制御" (Growth speed control by initial value
       optimisation for sketch-based ice and frost animation).
    .. [2] C. A. Reiter, "A local cellular model for snow crystal growth", Chaos,
       Solitons & Fractals 23 (2005) 1111-1119.

    Examples
    --------
    >>> lat = HexLattice.hexagon(12)
    >>> res = grow(lat, [lat.center_cell()], FrostParams(beta=0.4))
    >>> res
    FrostResult(ends at frame 693: 92% of 469 cells frozen (>= 90%))
    >>> res.freeze_frame[lat.center_cell()], res.coverage[res.end_frame] >= 0.9
    (np.int32(0), np.True_)
    """
    lattice = _check_lattice(lattice)
    params = _check_params(params)
    starts = _start_cells(lattice, starts)
    beta0 = _initial_beta(lattice, params, beta)
    if frames is not None:
        frames = check_int("frames", frames, 0)
    limit = params.max_frames if frames is None else frames
    report = Progress(progress)
    seed = resolve_seed(seed)  # recorded in the result, so the run can be remade
    gen = rng(seed)
    started = time.perf_counter()

    kernel = _Kernel(lattice, params.alpha, params.gamma, params.rth)
    u = _initial_state(lattice, beta0, starts)
    n = lattice.n_cells
    need = params.coverage * n
    # Frames at which each point was ice, summed on the storage (ice never melts, so a
    # cell that froze at frame f has been ice for t + 1 - f of the frames 0 .. t).
    ice_frames = np.zeros(lattice.storage_size, np.int32)
    coverage = np.zeros(limit + 1)
    gamma_cells = np.zeros(limit, np.int64)
    vapour = np.zeros((limit + 1, n)) if record_vapour else None
    cells = lattice.cells
    end = None
    t = 0
    while True:
        n_ice = kernel.classify(u)
        ice_frames += kernel.ice
        coverage[t] = n_ice / n
        if vapour is not None:
            vapour[t] = u[cells]
        if end is None and n_ice >= need - 1e-9:
            end = t
            if frames is None:
                break
        if t == limit:
            break
        if t % _REPORT_EVERY == 0:
            frac = (
                t / limit if frames is not None else max(t / limit, coverage[t] / params.coverage)
            )
            report(frac, f"frame {t}: {coverage[t]:.0%} frozen")
        r = None
        if params.rth > 0:
            r = gen.random(kernel.random_shape, dtype=np.float32)
        gamma_cells[t] = kernel.advance(u, r)
        t += 1

    ice_frames = ice_frames[cells]
    freeze = np.where(ice_frames > 0, t + 1 - ice_frames, -1).astype(np.int32)
    if end is not None:
        message = (
            f"ends at frame {end}: {coverage[end]:.0%} of {n} cells frozen "
            f"(>= {params.coverage:.0%})"
        )
    else:
        message = (
            f"never within {t} frames: {coverage[t]:.0%} of {n} cells frozen, "
            f"{params.coverage:.0%} needed"
        )
    report(1.0, message)
    for arr in (freeze, coverage, gamma_cells):
        arr.setflags(write=False)
    return FrostResult(
        lattice=lattice,
        freeze_frame=freeze,
        end_frame=end,
        n_frames=t,
        coverage=coverage[: t + 1],
        gamma_cells=gamma_cells[:t],
        vapour=None if vapour is None else vapour[: t + 1],
        starts=starts,
        beta=beta0,
        params=params,
        seed=seed,
        message=message,
        seconds=time.perf_counter() - started,
    )


def step(lattice, vapour, params=None, *, r=None):
    r"""One step of the automaton on a per-cell vapour vector (state in, state out).

    The same update :func:`grow` applies, exposed for teaching and checking:
    boundary rule, receptive set, diffusion of the non-receptive part, :math:`\gamma`
    by Eq. (1).

    Parameters
    ----------
    lattice : HexLattice
        The lattice.
    vapour : array_like, shape (n_cells,)
        :math:`u_t(p)` of the region's cells (not modified).
    params : FrostParams, optional
        :math:`\alpha, \gamma, r_{th}`.
    r : array_like, shape (n_cells,), optional
        The step's random numbers :math:`r_t(p)`; required when ``params.rth > 0``.

    Returns
    -------
    next_vapour : ndarray, shape (n_cells,)
        :math:`u_{t+1}(p)`.
    gamma_mask : ndarray of bool, shape (n_cells,)
        The cells that received :math:`\gamma` in this step.

    Examples
    --------
    >>> lat = HexLattice.hexagon(2)
    >>> u = np.full(lat.n_cells, 0.35)
    >>> u[lat.center_cell()] = 1.0
    >>> u1, got = step(lat, u)
    >>> int(got.sum())  # the ice start cell and its six frontier cells
    7
    """
    lattice = _check_lattice(lattice)
    params = _check_params(params)
    vapour = check_array("vapour", vapour, ndim=1, dtype_kinds="iuf")
    if vapour.shape != (lattice.n_cells,):
        raise ValueError(
            f"vapour must have one value per cell ({lattice.n_cells},), got {vapour.shape}"
        )
    kernel = _Kernel(lattice, params.alpha, params.gamma, params.rth)
    u = np.zeros(lattice.storage_size, _DTYPE)
    u[lattice.cells] = vapour
    r_span = None
    if params.rth > 0:
        if r is None:
            raise ValueError("r is required when rth > 0: one random number per cell")
        r = check_array("r", r, ndim=1, dtype_kinds="f")
        if r.shape != (lattice.n_cells,):
            raise ValueError(f"r must have one value per cell ({lattice.n_cells},), got {r.shape}")
        r_full = np.zeros(lattice.storage_size, np.float32)
        r_full[lattice.cells] = r
        r_span = r_full[kernel.lo : kernel.hi]
    kernel.classify(u)
    kernel.advance(u, r_span)
    got = np.zeros(lattice.storage_size, bool)
    got[kernel.lo : kernel.hi] = kernel.receptive if r_span is None else kernel.gets_gamma
    return u[lattice.cells], got[lattice.cells]
