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
cached (scipy.fft caches its own FFT plans). Each DCT is a real FFT of the row read
in another order (Makhoul 1980), the reordering and the FFT's turns done by the
kernels on either side; see :class:`_FastPoisson`. (The readable version,
:func:`fluidnb.fluid._reference.pressure`, calls scipy's DCT.)

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

from . import _kernels

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
    r"""A cosine transform along x, one tridiagonal (Thomas) solve per x-mode along y.

    The cosine transform (DCT-II) of a row is done with one real FFT of the same
    length (Makhoul 1980): the row is read in the order ``x[0], x[2], x[4], ...,
    x[5], x[3], x[1]`` (``pos`` maps column j to its place), and bin k of its FFT,
    turned by :math:`e^{-i\pi k / 2W}`, holds the coefficients of modes k (real part)
    and W - k (minus the imaginary part). The inverse runs the same way back. The
    reordering is done by the kernels on either side (the divergence writes in that
    order, the gradient reads it), and the turns by the tridiagonal solve, which
    takes each FFT bin's two modes together: no pass over the grid of its own.

    The Thomas factors are computed once here, for all W modes at once: for each
    mode k the forward sweep of :math:`(L_y + \lambda_k I)` is
    ``p'_i = (r_i + p'_{i-1}) * inv[i, k]`` and the back substitution
    ``p_i = p'_i - up[i, k] * p_{i+1}``; ``inv_a``, ``up_a`` are bin k's first mode
    (k), ``inv_b``, ``up_b`` its second (W - k).
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
            # p_hat[0] = 0 (the constant is fixed again after the inverse transform).
            diag[0, 0], upper[0, 0] = 1.0, 0.0
        inv = np.empty((h, w))
        up = np.empty((h, w))
        prev = np.zeros(w)  # c'_{i-1}, the previous row's eliminated super-diagonal
        for i in range(h):
            inv[i] = 1.0 / (diag[i] + prev)  # sub-diagonal is -1: b_i - a_i c'_{i-1}
            up[i] = upper[i] * inv[i]
            prev = up[i]
        bins = np.arange(w // 2 + 1)
        partner = (w - bins) % w  # bin 0 has no second mode: its own, fed zeros
        self.inv_a, self.up_a = inv[:, bins].copy(), up[:, bins].copy()
        self.inv_b, self.up_b = inv[:, partner].copy(), up[:, partner].copy()
        angle = np.pi * bins / (2 * w)
        self.cos, self.sin = np.cos(angle), np.sin(angle)
        if w % 2 == 0:
            # The Nyquist bin's two modes are one: equal weights keep them equal.
            self.sin[-1] = self.cos[-1]
        pos = np.empty(w, dtype=np.uint64)
        pos[0::2] = np.arange((w + 1) // 2)
        pos[1::2] = w - 1 - np.arange(w // 2)
        self.pos = pos

    def _solve_ordered(self, r, parts=None):
        """The pressure (in ``pos`` order) for a right-hand side in ``pos`` order.

        ``parts``: runs of FFT bins for the tridiagonal solves, one per thread.
        """
        w = self.shape[1]
        # The FFTs run on one thread: a second worker measured slower at 128 x 128
        # on a busy machine (its thread pool wakes for 30 microseconds of work), and
        # how the rows are shared out then cannot change a bit on any CPU.
        z = scipy.fft.rfft(r, axis=1)
        _thomas(z.view(np.float64), self.cos, self.sin, self.inv_a, self.up_a,
                self.inv_b, self.up_b, self.pin,
                numba.get_num_threads() if parts is None else parts)  # fmt: skip
        return scipy.fft.irfft(z, n=w, axis=1, overwrite_x=True)

    def solve(self, div):
        """Pressure p with ``A p = -div``; ``p[0, 0] = 0`` for a closed box."""
        r = np.empty(self.shape)
        r[:, self.pos] = div
        p = self._solve_ordered(r)[:, self.pos]
        if self.pin:
            p -= p[0, 0]
        return p

    def pressure(self, r, parts=None):
        """The pressure (``pos`` order) for a divergence in ``pos`` order, and ``p0``.

        ``p0`` is the constant to take from it (a closed box's ``p[0, 0]``, else 0).
        """
        p = self._solve_ordered(r, parts)
        return p, (float(p[0, 0]) if self.pin else 0.0)  # cell (0, 0) is in place 0

    def project(self, vy, vx, out):
        """``out`` = the velocity (planes ``vy``, ``vx``, walls zero) minus grad p.

        Returns the pressure in ``pos`` order and the constant ``p0`` to take from it.
        """
        r = np.empty(self.shape)
        _kernels.divergence(vy, vx, self.pos, r)
        p, p0 = self.pressure(r)
        _kernels.subtract_gradient(vy, vx, p, self.pos, self.boundary == "open_top", p0, out)
        return p, p0


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _thomas(z, cos, sin, inv_a, up_a, inv_b, up_b, pin, parts):
    """Every x-mode's tridiagonal solve, in place on the row FFTs ``z`` (re, im pairs).

    Factors and turns from _FastPoisson. Bin k is read as modes k and W - k
    (``a = Re(e^{-i pi k/2W} z)``, ``b = -Im(...)``), both solved for the right-hand
    side ``-a``, ``-b`` (A p = -div: the sign is folded into the sweep), and written
    back as ``e^{i pi k/2W} (p_a - i p_b)``, what the inverse FFT needs -- one row
    behind the back substitution, which still reads the row below untouched.

    The bins are independent: split into ``parts`` runs (one per thread), each thread
    runs the sweeps down and up its own bins (the inner loops run across bins, so they
    vectorise); no bin's arithmetic depends on how they are split, so the result does
    not depend on the number of threads.
    """
    h = z.shape[0]
    n_bins = z.shape[1] // 2
    parts = max(min(parts, n_bins), 1)
    two = np.uint64(2)
    one = np.uint64(1)
    for part in prange(parts):
        lo = part * n_bins // parts
        hi = (part + 1) * n_bins // parts
        # Unsigned indices into row views: no wrap-around guards, so the loops across
        # bins vectorise.
        row, ia, ib = z[0], inv_a[0], inv_b[0]
        for kk in range(lo, hi):
            k = np.uint64(kk)
            c, s = cos[k], sin[k]
            re, im = row[two * k], row[two * k + one]
            row[two * k] = -(c * re + s * im) * ia[k]
            row[two * k + one] = -(s * re - c * im) * ib[k]
        if pin and lo == 0:
            row[0] = 0.0  # p_hat = 0 for the closed box's constant mode
        for i in range(1, h):
            row, prev, ia, ib = z[i], z[i - 1], inv_a[i], inv_b[i]
            for kk in range(lo, hi):
                k = np.uint64(kk)
                c, s = cos[k], sin[k]
                re, im = row[two * k], row[two * k + one]
                row[two * k] = (prev[two * k] - (c * re + s * im)) * ia[k]
                row[two * k + one] = (prev[two * k + one] - (s * re - c * im)) * ib[k]
        for i in range(h - 2, -1, -1):
            row, nxt, ua, ub = z[i], z[i + 1], up_a[i], up_b[i]
            for kk in range(lo, hi):
                k = np.uint64(kk)
                c, s = cos[k], sin[k]
                pa, pb = nxt[two * k], nxt[two * k + one]
                row[two * k] -= ua[k] * pa
                row[two * k + one] -= ub[k] * pb
                nxt[two * k], nxt[two * k + one] = c * pa + s * pb, s * pa - c * pb
        row = z[0]
        for kk in range(lo, hi):
            k = np.uint64(kk)
            c, s = cos[k], sin[k]
            pa, pb = row[two * k], row[two * k + one]
            row[two * k], row[two * k + one] = c * pa + s * pb, s * pa - c * pb


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
