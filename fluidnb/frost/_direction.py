r"""A :math:`\beta` that depends on the direction from the start point (the paper's future work).

Amano et al. (sec. 5) propose to let the initial value :math:`\beta` vary with the
direction from the start point, chosen with the distance to the boundary in mind, so
that the frost reaches every part of the region's boundary at the same time. This
module does that by a few rounds of per-direction Newton steps:

1. split the region into ``n_directions`` angular sectors around each start point;
2. run with a uniform :math:`\beta` and at :math:`\beta + \delta`, and measure in each
   sector :math:`k` the arrival frame :math:`A_k` at the boundary (median freeze frame
   of the region's edge cells in the sector) and the slope
   :math:`S = d \log A / d\beta` (median over the sectors); far boundaries arrive late,
   so their sectors need a larger :math:`\beta`;
3. set :math:`\beta_k \leftarrow \beta_k + (\log A^* - \log A_k) / S_k` (damped and
   bounded) towards the common arrival :math:`A^*` (the median of the first run's
   arrivals, so the overall pace stays the same), interpolate :math:`\beta_k` smoothly
   in angle to every cell, rerun, refine :math:`S_k` by secants, and repeat; the round
   with the smallest spread of arrivals wins.

Runs share one random seed (common random numbers), as in the optimiser.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .._progress import Progress
from .._random import resolve_seed
from .._validation import check_int, check_range
from ._reiter import _check_lattice, _check_params, _start_cells, grow

__all__ = ["DirectionBeta", "direction_beta"]

# Newton steps are damped and bounded: sectors interact (a fast sector's ice spreads
# sideways into its neighbours), so a full step overshoots.
_DAMPING = 0.8
_MAX_STEP = 0.15
_BETA_MIN, _BETA_MAX = 0.02, 0.98


@dataclass(frozen=True, eq=False)
class DirectionBeta:
    r"""A per-cell :math:`\beta` that evens out the arrival at the boundary.

    Attributes
    ----------
    beta : ndarray, shape (n_cells,)
        :math:`\beta(p)` of the best round, to pass as ``grow(..., beta=...)``.
    sector_beta : ndarray, shape (n_starts, n_directions)
        :math:`\beta_k` per start point and sector of the last round (sector 0 points east,
        then counter-clockwise as seen on the image).
    distance : ndarray, shape (n_starts, n_directions)
        Median distance (pixels) from the start point to the region's edge in each sector.
    arrival : ndarray, shape (rounds + 1, n_starts, n_directions)
        :math:`A_k` (frames) of every run, the uniform one first (NaN: empty sector).
    spread : ndarray, shape (rounds + 1,)
        Max - min of :math:`A_k` over the sectors, per run (the uniform one first):
        what the rounds reduce; :attr:`beta` is the round with the smallest.
    sector : ndarray of int, shape (n_cells,)
        The (start * n_directions + direction) sector of each cell.
    seed : int
        The random seed of every run.
    message : str
        The outcome in words.
    seconds : float
        Wall time.
    """

    beta: np.ndarray
    sector_beta: np.ndarray
    distance: np.ndarray
    arrival: np.ndarray
    spread: np.ndarray
    sector: np.ndarray
    seed: int
    message: str
    seconds: float = field(default=0.0, repr=False)


def _sectors(lattice, starts, n_dir):
    """Nearest start point, angle from it and sector of every cell."""
    pts = lattice.points
    origin = pts[starts]
    d2 = ((pts[:, None, :] - origin[None, :, :]) ** 2).sum(axis=2)
    owner = np.argmin(d2, axis=1)
    rel = pts - origin[owner]
    # Angle counter-clockwise from east as seen on the image (rows point down).
    theta = np.arctan2(-rel[:, 0], rel[:, 1]) % (2 * np.pi)
    width = 2 * np.pi / n_dir
    k = np.minimum((theta / width).astype(int), n_dir - 1)
    dist = np.sqrt(d2[np.arange(len(pts)), owner])
    return owner, theta, owner * n_dir + k, dist


def _edge_cells(lattice):
    n = lattice.n_cells
    nb = lattice.neighbours[:n]
    return ((nb >= n) | (nb < 0)).any(axis=1)


def _per_sector(values, sector, mask, n_sectors):
    out = np.full(n_sectors, np.nan)
    for s in np.unique(sector[mask]):
        out[s] = np.median(values[mask & (sector == s)])
    return out


def _spread(arrival):
    return float(np.nanmax(arrival) - np.nanmin(arrival))


def _interpolate(sector_beta, owner, theta, n_dir):
    """Periodic linear interpolation of beta_k between sector centres."""
    width = 2 * np.pi / n_dir
    pos = theta / width - 0.5  # sector centres at integer positions
    k0 = np.floor(pos).astype(int)
    f = pos - k0
    b0 = sector_beta[owner, k0 % n_dir]
    b1 = sector_beta[owner, (k0 + 1) % n_dir]
    return (1 - f) * b0 + f * b1


def direction_beta(
    lattice,
    starts,
    params=None,
    *,
    n_directions=12,
    rounds=3,
    delta=0.02,
    seed=0,
    progress=None,
):
    r"""Find a direction-dependent :math:`\beta(\theta)` so frost reaches the boundary evenly.

    Parameters
    ----------
    lattice : HexLattice
        The region's lattice.
    starts : array_like
        Start cells or (n, 2) pixel points, as for :func:`grow`.
    params : FrostParams, optional
        The run's parameters; ``params.beta`` is the starting (uniform) value.
    n_directions : int
        Angular sectors around each start point (>= 2).
    rounds : int
        Newton rounds after the two uniform runs (>= 1).
    delta : float
        :math:`\beta` step of the second uniform run, for the slopes :math:`S_k`.
    seed : int or numpy.random.Generator
        One random seed for all runs (common random numbers).
    progress : callable, optional
        ``progress(fraction, message)``.

    Returns
    -------
    DirectionBeta
        The per-cell :math:`\beta` and the arrival frames before and after.

    Examples
    --------
    >>> from fluidnb.frost import FrostParams, HexLattice
    >>> lat = HexLattice.hexagon(8)
    >>> off = lat.snap([lat.points[lat.center_cell()] + [0, 4]])  # east of centre
    >>> res = direction_beta(lat, off, FrostParams(beta=0.4), n_directions=6, rounds=2)
    >>> bool(res.spread.min() < res.spread[0])
    True
    """
    lattice = _check_lattice(lattice)
    params = _check_params(params)
    starts = _start_cells(lattice, starts)
    n_dir = check_int("n_directions", n_directions, 2, 360)
    rounds = check_int("rounds", rounds, 1, 50)
    delta = check_range("delta", delta, 0, 0.5, lo_open=True)
    seed = resolve_seed(seed)  # one int for every run (common random numbers)
    report = Progress(progress)
    started = time.perf_counter()
    n_starts = len(starts)
    n_sec = n_starts * n_dir
    owner, theta, sector, dist = _sectors(lattice, starts, n_dir)
    edge = _edge_cells(lattice)
    distance = _per_sector(dist, sector, edge, n_sec).reshape(n_starts, n_dir)
    total = rounds + 2

    def arrivals(beta, i):
        sub = report.sub(i / total, (i + 1) / total)
        res = grow(lattice, starts, params, beta=beta, seed=seed, progress=sub)
        # A cell that never froze arrives "at the end of the run" (a lower bound).
        f = np.where(res.freeze_frame < 0, res.n_frames + 1, res.freeze_frame)
        return _per_sector(f.astype(float), sector, edge, n_sec)

    b0 = params.beta
    first = arrivals(b0, 0)
    b1 = min(b0 + delta, 1.0)
    second = arrivals(b1, 1)
    present = np.isfinite(first) & np.isfinite(second)
    # Arrival times scale with distance over speed, so work with log A: one shared
    # slope d(log A)/d(beta) (the median over the sectors, robust to a sector whose
    # arrival did not move) starts every sector; per-sector secants refine it.
    log_slope = (np.log(second) - np.log(first)) / (b1 - b0)
    usable = present & (log_slope < 0)
    shared = np.median(log_slope[usable]) if usable.any() else -5.0
    slope = np.full(n_sec, shared)
    goal = np.log(np.nanmedian(first))
    sector_beta = np.full(n_sec, b0)
    history = [first]
    beta = np.full(lattice.n_cells, b0)
    best_beta, best_spread = beta, _spread(first)
    current, previous_beta = first, None
    for i in range(rounds):
        step = np.where(present, _DAMPING * (goal - np.log(current)) / slope, 0.0)
        new = np.clip(sector_beta + np.clip(step, -_MAX_STEP, _MAX_STEP), _BETA_MIN, _BETA_MAX)
        # Empty sectors (no edge cells) take the mean of the others.
        new[~present] = new[present].mean() if present.any() else b0
        previous_beta, sector_beta = sector_beta, new
        beta = _interpolate(sector_beta.reshape(n_starts, n_dir), owner, theta, n_dir)
        before, current = current, arrivals(beta, i + 2)
        history.append(current)
        if _spread(current) < best_spread:
            best_beta, best_spread = beta, _spread(current)
        # Per-sector secant slopes, kept within a factor 3 of the shared one.
        moved = np.abs(sector_beta - previous_beta) > 1e-3
        with np.errstate(divide="ignore", invalid="ignore"):
            secant = (np.log(current) - np.log(before)) / (sector_beta - previous_beta)
        ok = moved & np.isfinite(secant) & (secant < 0)
        slope = np.where(ok, np.clip(secant, 3 * shared, shared / 3), slope)
    arrival = np.stack(history).reshape(len(history), n_starts, n_dir)
    spread = np.array([_spread(a) for a in history])
    beta = np.clip(best_beta, 0.0, 1.0)
    beta.setflags(write=False)
    best = int(np.argmin(spread))
    message = (
        f"boundary arrival spread {spread[0]:.0f} -> {spread[best]:.0f} frames (round "
        f"{best} of {rounds}) over {n_dir} directions; common arrival ~{np.exp(goal):.0f}"
    )
    report(1.0, message)
    return DirectionBeta(
        beta=beta,
        sector_beta=sector_beta.reshape(n_starts, n_dir),
        distance=distance,
        arrival=arrival,
        spread=spread,
        sector=sector,
        seed=seed,
        message=message,
        seconds=time.perf_counter() - started,
    )
