r"""The pressure Poisson solvers of the projection: a fast exact one and the sparse LU.

The projection (Eq. (2); Stam 1999) needs the pressure :math:`p` with

.. math:: A\,p = -\nabla\cdot u, \qquad A = D D^T = -\nabla^2_h,

:math:`D` the MAC grid's divergence and :math:`-D^T` its gradient, so that
:math:`u - \nabla p` has no divergence. On fluidnb's rectangle (solid walls left,
right and at the bottom; an open or a solid top) :math:`A` is a sum of two 1-D
operators, :math:`A = L_x \otimes I + I \otimes L_y`, both tridiagonal ``[-1, 2, -1]``
with the wall rows changed:

- :math:`L_x` (length W) has Neumann rows at both side walls (diagonal 1). Its
  eigenvectors are the cosines :math:`\cos(\pi k (j + 1/2) / W)`, i.e. the type-II
  discrete cosine transform (DCT), with eigenvalues
  :math:`\lambda_k = 2 - 2\cos(\pi k / W)`.
- :math:`L_y` (length H) has a Neumann row at the bottom wall (diagonal 1) and, at
  the top, a Neumann row for a solid top or a Dirichlet row (:math:`p = 0` just
  above the grid, diagonal 2) for an open top.

So a DCT along x turns :math:`A p = r` into W independent tridiagonal systems along y,
:math:`(L_y + \lambda_k I)\,\hat p_k = \hat r_k`, solved exactly by the Thomas algorithm
in O(H) each; an inverse DCT brings :math:`p` back. Exact to round-off, O(HW log W),
and the only setup per grid shape is the Thomas algorithm's elimination factors,
cached (scipy.fft caches its own DCT plans).

A closed box determines :math:`p` up to a constant: the k = 0 system is singular. Both
solvers fix the constant the same way, :math:`p = 0` in cell (0, 0) (the top-left).

The sparse LU of :math:`A` (scipy's SuperLU, factorised once per shape) stays as the
reference the tests compare with, and is what a grid with solid cells inside would
need (its matrix is no longer separable).
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np
import scipy.fft
import scipy.sparse as sp
from numba import njit, prange
from scipy.sparse.linalg import splu

__all__ = ["METHODS", "poisson_solver"]

#: The Poisson solvers :func:`fluidnb.fluid.project` offers.
METHODS = ("fast", "lu")

#: The largest grid the sparse LU is built for: its fill-in grows faster than the
#: grid (a 4096 x 4096 factorisation ended in an empty MemoryError).
LU_MAX_CELLS = 512 * 512


def _row_diagonals(n, open_start):
    """Diagonal of a 1-D ``[-1, 2, -1]`` operator of length n with wall rows.

    The last row is a Neumann wall (diagonal 1); the first is Neumann too, or
    Dirichlet (diagonal 2: the value beyond it is 0) when ``open_start``.
    """
    diag = np.full(n, 2.0)
    diag[-1] -= 1.0
    if not open_start:
        diag[0] -= 1.0
    return diag


class _FastPoisson:
    r"""DCT along x, one tridiagonal (Thomas) solve per x-mode along y.

    The Thomas factors are computed once here, for all W modes at once: for each
    mode k the forward sweep of :math:`(L_y + \lambda_k I)` is
    ``p'_i = (r_i + p'_{i-1}) * inv[i, k]`` and the back substitution
    ``p_i = p'_i - up[i, k] * p_{i+1}``.
    """

    def __init__(self, shape, boundary):
        h, w = shape
        self.shape = (h, w)
        self.boundary = boundary
        self.pin = boundary == "closed"
        lam = 2.0 - 2.0 * np.cos(np.pi * np.arange(w) / w)  # eigenvalues of L_x
        diag = _row_diagonals(h, open_start=boundary == "open_top")[:, None] + lam[None, :]
        upper = np.full((h, w), -1.0)
        upper[-1] = 0.0
        if self.pin:
            # Mode 0 of a closed box is singular: replace its first equation by
            # p_hat[0] = 0 (the constant is fixed again after the inverse DCT).
            diag[0, 0], upper[0, 0] = 1.0, 0.0
        inv = np.empty((h, w))
        up = np.empty((h, w))
        prev = np.zeros(w)  # c'_{i-1}, the previous row's eliminated super-diagonal
        for i in range(h):
            inv[i] = 1.0 / (diag[i] + prev)  # sub-diagonal is -1: b_i - a_i c'_{i-1}
            up[i] = upper[i] * inv[i]
            prev = up[i]
        self.inv = inv
        self.up = up

    def solve(self, div):
        """Pressure p with ``A p = -div``; ``p[0, 0] = 0`` for a closed box."""
        # The transforms use as many threads as the kernels (one for a small grid).
        workers = numba.get_num_threads()
        r = scipy.fft.dct(div, type=2, axis=1, norm="ortho", workers=workers)
        if self.pin:
            r[0, 0] = 0.0
        _thomas(r, self.inv, self.up)
        p = scipy.fft.idct(r, type=2, axis=1, norm="ortho", overwrite_x=True, workers=workers)
        if self.pin:
            p -= p[0, 0]
        return p


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _thomas(r, inv, up):
    """Solve every column's system for the right-hand side ``-r``, in place.

    Factors from _FastPoisson.

    The columns (x-modes) are independent: split among the threads in blocks, each
    thread runs the sweeps down and up its own columns, so the result does not depend
    on the number of threads.
    """
    h, w = r.shape
    block = 32
    for b in prange((w + block - 1) // block):
        lo = b * block
        hi = min(lo + block, w)
        # The right-hand side is -r (A p = -div): the sign is folded into the sweep.
        for k in range(lo, hi):
            r[0, k] = -r[0, k] * inv[0, k]
        for i in range(1, h):
            for k in range(lo, hi):
                r[i, k] = (r[i - 1, k] - r[i, k]) * inv[i, k]
        for i in range(h - 2, -1, -1):
            for k in range(lo, hi):
                r[i, k] -= up[i, k] * r[i + 1, k]


class _SparsePoisson:
    """The Poisson matrix of one grid shape, factorised once (sparse LU, the reference)."""

    def __init__(self, shape, boundary):
        h, w = shape
        n = h * w
        if n > LU_MAX_CELLS:
            raise ValueError(
                f"method='lu' factorises the whole Poisson matrix and is meant for grids "
                f"of at most {LU_MAX_CELLS} cells (512 x 512), got {h}x{w}: use "
                f"method='fast', exact on any size"
            )
        cells = np.arange(n).reshape(h, w)
        rows, cols, vals = [], [], []
        # Divergence operator D: cells x faces. Each active face leaves the cell
        # after it (-1) and enters the cell before it (+1).
        # Top faces of the dy component (row 0 only when the top is open).
        i0 = 0 if boundary == "open_top" else 1
        fy = np.arange((h - i0) * w).reshape(h - i0, w)
        rows += [cells[i0:].ravel(), cells[:-1].ravel()]
        cols += [fy.ravel(), fy[1 - i0 :].ravel()]
        vals += [-np.ones(fy.size), np.ones((h - 1) * w)]
        face = fy.size
        # Left faces of the dx component (column 0 is the wall).
        fx = face + np.arange(h * (w - 1)).reshape(h, w - 1)
        rows += [cells[:, 1:].ravel(), cells[:, :-1].ravel()]
        cols += [fx.ravel(), fx.ravel()]
        vals += [-np.ones(fx.size), np.ones(fx.size)]
        n_faces = face + fx.size
        d = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n, n_faces),
        )
        a = (d @ d.T).tocsc()  # = -Laplacian, symmetric positive (semi-)definite
        # A closed box determines pressure up to a constant: pin cell 0 to zero by
        # solving the reduced system (the dropped equation follows from the others,
        # because the total divergence of a closed box is zero).
        self.pin = boundary == "closed"
        if self.pin:
            a = a[1:, 1:]
        self.shape = (h, w)
        self.boundary = boundary
        self.n_unknowns = a.shape[0]
        self.lu = splu(a, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})

    def solve(self, div):
        """Pressure p with -Laplacian(p) = -div (so that div(u - grad p) = 0)."""
        rhs = -div.ravel()
        if self.pin:
            p = np.zeros(rhs.size)
            p[1:] = self.lu.solve(rhs[1:])
        else:
            p = self.lu.solve(rhs)
        return p.reshape(self.shape)


@lru_cache(maxsize=16)
def poisson_solver(shape, boundary, method="fast"):
    """The Poisson solver for a grid shape, boundary and method, built once and cached."""
    if method == "fast":
        return _FastPoisson(shape, boundary)
    return _SparsePoisson(shape, boundary)
