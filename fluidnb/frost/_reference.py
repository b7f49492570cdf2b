"""A plain per-cell Python version of the automaton: the rule as one would first write it.

Slow on purpose (one Python loop over the cells per step). It exists so that the
tests can check the vectorised kernel against the rule written out literally, the
benchmark can show what vectorising buys, and the notebook can show the rule in its
most readable form. Use :func:`fluidnb.frost.grow` for real work.
"""

from __future__ import annotations

import numpy as np

from .._random import rng
from ._params import FrostParams

__all__ = ["grow_reference", "reference_setup"]


def grow_reference(lattice, starts, params=None, *, frames, seed=None):
    """Run ``frames`` steps cell by cell; returns (freeze_frame, vapour per frame).

    The random numbers are drawn exactly as :func:`fluidnb.frost.grow` draws them
    (one float32 uniform per point of the kernel's storage span, per step), so both
    see the same :math:`r_t(p)`.
    """
    params = FrostParams() if params is None else params
    alpha, gamma, rth = params.alpha, params.gamma, params.rth
    n, n_ring = lattice.n_cells, lattice.n_ring
    nbrs = lattice.neighbours.tolist()
    gen = rng(seed)
    lo = lattice.stride  # the kernel's span [lo, hi), see _reiter._Kernel
    span = lattice.storage_size - 2 * lattice.stride
    where = (np.asarray(lattice.cells) - lo).tolist()

    u = [params.beta] * n + [0.0] * n_ring
    for s in np.asarray(starts).tolist():
        u[s] = 1.0
    freeze = [-1] * n
    history = []
    for t in range(frames + 1):
        ice = [u[p] >= 1.0 for p in range(n)]
        for p in range(n):
            if ice[p] and freeze[p] < 0:
                freeze[p] = t
        history.append(u[:n])
        if t == frames:
            break
        r = gen.random(span, dtype=np.float32) if rth > 0 else None
        receptive = [ice[p] or any(q < n and ice[q] for q in nbrs[p]) for p in range(n)]
        # b: the vapour that diffuses (0 on receptive cells).
        b = [0.0 if receptive[p] else u[p] for p in range(n)] + [0.0] * n_ring
        # Boundary (Sec. 3.3): each ring point takes the mean of its region neighbours
        # in the diffusion field.
        for k in range(n, n + n_ring):
            inner = [b[q] for q in nbrs[k] if 0 <= q < n]
            b[k] = sum(inner) / len(inner)
        new = list(u)
        for p in range(n):
            total = sum(b[q] for q in nbrs[p])  # a cell's six neighbours always exist
            diffused = b[p] + alpha / 12.0 * (-6.0 * b[p] + total)
            a = u[p] if receptive[p] else 0.0
            if receptive[p] and (ice[p] or r is None or r[where[p]] > rth):
                a += gamma
            new[p] = a + diffused
        u = new
    return np.array(freeze), np.array(history)


def reference_setup(rth=0.0):
    """A region, start point and parameters on which beta = 0.25 ends near 160 frames (Tables 1-2).

    The paper gives neither its region nor the gamma of its Tables 1-2 (only of its
    Fig. 3). Mass balance shows why a region must be small to end near 160 frames at
    beta = 0.25 with gamma = 0.005: freezing 90 % of N cells needs at least 0.9 N of
    vapour, the region starts with beta N, and each step adds gamma to at most N cells
    (the boundary ring exchanges none), so T_sim >= (0.9 - beta) / gamma = 130 frames;
    in practice much more, because gamma given to cells already frozen is locked in
    them. The smallest region (a start point and its six neighbours) ends exactly at
    (1 - beta) / gamma = 150 frames; a 37-cell hexagon needs 351.

    We keep a region of a useful size -- a hexagon of radius 10 (331 cells), start point at
    the centre -- and choose gamma so that beta = 0.25 ends near 160 frames:
    gamma = 0.036 for rth = 0 (frame 158) and gamma = 0.19 for rth = 0.8 (frame 158
    with seed 0). rth = 0.8 needs about five times the gamma because only one frontier
    cell in five receives it each step. The end frame then falls by about 350-400
    frames per unit of beta, so the steepest descent converges in one or two steps with
    eta = 3e-6 (near 1 / (2 slope^2)) and in about ten with the paper's 1e-6.

    Parameters
    ----------
    rth : {0.0, 0.8}
        The random threshold of Table 1 (0.0) or Table 2 (0.8).

    Returns
    -------
    lattice : HexLattice
    starts : ndarray of intp
        The centre cell.
    params : FrostParams
        The paper's defaults with this rth and the calibrated gamma.

    Examples
    --------
    >>> lattice, starts, params = reference_setup(0.0)
    >>> lattice.n_cells, params.gamma
    (331, 0.036)
    """
    from ._lattice import HexLattice

    gammas = {0.0: 0.036, 0.8: 0.19}
    if rth not in gammas:
        raise ValueError(f"rth must be 0.0 or 0.8 (the paper's Tables 1 and 2), got {rth!r}")
    lattice = HexLattice.hexagon(10)
    params = FrostParams(rth=float(rth), gamma=gammas[rth])
    return lattice, np.array([lattice.center_cell()]), params
