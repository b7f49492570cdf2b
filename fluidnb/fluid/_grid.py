"""The staggered (MAC) grid, its difference operators and the exact pressure projection.

Grid layout
-----------
Temperature, density and pressure live at cell centres, ``(H, W)``. The velocity is
staggered (a MAC grid, Harlow & Welch 1965, as in Fedkiw, Stam & Jensen 2001) but
packed into the usual ``(H, W, 2)`` array of fluidnb's (dy, dx) convention:

- ``velocity[i, j, 0]`` (dy, > 0 down) sits on the **top face** of cell (i, j),
  at position (i - 1/2, j); row 0 is the top boundary of the domain;
- ``velocity[i, j, 1]`` (dx, > 0 right) sits on the **left face** of cell (i, j),
  at position (i, j - 1/2); column 0 is the left wall.

The bottom and right walls carry no stored value: their normal velocity is zero.
On this layout the divergence of a cell is a compact difference of its four faces and
the pressure Poisson matrix is the 5-point Laplacian, so an exact solve leaves a
divergence at round-off and no checkerboard modes (which the collocated central
differences of Stam's original code allow). :func:`centred_velocity` averages the
faces to cell centres for anyone who wants the velocity at the pixels.

Boundary conditions
-------------------
Solid walls (zero normal velocity) on the left, right and bottom. The top is either
open (``"open_top"``: pressure 0 just above the grid, gas leaves freely) or solid
(``"closed"``). Tangential velocity at walls is free (slip).
"""

from __future__ import annotations

import numpy as np

from .._validation import check_choice, check_vector_field
from . import _kernels
from ._params import BOUNDARIES
from ._poisson import METHODS, poisson_solver

__all__ = [
    "centred_velocity",
    "curl",
    "divergence",
    "enforce_walls",
    "project",
]


def enforce_walls(velocity, boundary="open_top", *, out=None):
    """Zero the normal velocity on the solid walls (in place when ``out`` is given)."""
    v = np.array(velocity, dtype=np.float64) if out is None else out
    v[:, 0, 1] = 0.0  # left wall
    if boundary == "closed":
        v[0, :, 0] = 0.0  # top wall
    return v


def centred_velocity(velocity):
    """Average the staggered face velocities to the cell centres.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity in the layout of :mod:`fluidnb.fluid` (dy on top
        faces, dx on left faces; bottom and right walls zero).

    Returns
    -------
    ndarray, shape (H, W, 2)
        (dy, dx) at the cell centres, px/frame: the layout every other fluidnb
        function (``fluidnb.fields.advect``, ``resize_vector_field``) expects.

    Examples
    --------
    >>> v = np.zeros((2, 2, 2))
    >>> v[1, :, 0] = -1.0  # upward flow through the face between the rows
    >>> centred_velocity(v)[..., 0]
    array([[-0.5, -0.5],
           [-0.5, -0.5]])
    """
    v = check_vector_field("velocity", velocity)
    return _centres(np.asarray(v, dtype=np.float64))


def _f64(a):
    """float64, C-contiguous (what the compiled kernels take); no copy when already so."""
    return np.ascontiguousarray(a, dtype=np.float64)


def _centres(v):
    out = np.empty(v.shape)
    _kernels.centres(_f64(v), out)
    return out


def divergence(velocity):
    r"""Discrete divergence :math:`\nabla \cdot u` of a staggered velocity, per cell.

    ``div[i, j] = (dy below - dy above) + (dx right - dx left)``, the faces of cell
    (i, j), with the bottom and right walls' faces zero. This is the operator the
    projection makes vanish (Eq. (2)).

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity (see :mod:`fluidnb.fluid`), px/frame.

    Returns
    -------
    ndarray, shape (H, W)
        Net outflow of each cell, px^2/frame per px^2 (1/frame).

    Examples
    --------
    >>> v = np.zeros((3, 3, 2))
    >>> v[1, 1, 0] = -1.0  # flow up through the top face of cell (1, 1)
    >>> divergence(v) + 0.0  # out of cell (1, 1), into cell (0, 1)
    array([[ 0., -1.,  0.],
           [ 0.,  1.,  0.],
           [ 0.,  0.,  0.]])
    """
    v = check_vector_field("velocity", velocity)
    return _divergence(np.asarray(v, dtype=np.float64))


def _divergence(v):
    vy, vx = _planes(v)
    div = np.empty(v.shape[:2])
    _kernels.divergence(vy, vx, _in_order(v.shape[1]), div)
    return div


def _planes(v):
    """The two components of an (H, W, 2) field as C-contiguous float64 planes."""
    return _f64(v[..., 0]), _f64(v[..., 1])


def _in_order(w):
    """The column map of a field stored in its natural order (see _kernels.divergence)."""
    return np.arange(w, dtype=np.uint64)


def curl(velocity):
    r"""Vorticity :math:`\omega = \partial_x u_y - \partial_y u_x` at the cell centres.

    Central differences of :func:`centred_velocity` (one-sided at the border). With
    rows growing downwards, a positive value turns clockwise on screen.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity, px/frame.

    Returns
    -------
    ndarray, shape (H, W)
        The scalar vorticity (1/frame).

    Examples
    --------
    A rigid rotation has uniform vorticity, twice its angular velocity:

    >>> yy, xx = np.mgrid[0:8, 0:8] - 3.5
    >>> c = np.stack([0.1 * xx, -0.1 * yy], axis=-1)  # centred field
    >>> v = np.zeros_like(c)
    >>> v[1:, :, 0] = 0.1 * xx[1:]  # sample it on the faces
    >>> v[:, 1:, 1] = -0.1 * (yy[:, 1:])
    >>> np.round(curl(v)[2:6, 2:6], 6)
    array([[0.2, 0.2, 0.2, 0.2],
           [0.2, 0.2, 0.2, 0.2],
           [0.2, 0.2, 0.2, 0.2],
           [0.2, 0.2, 0.2, 0.2]])
    """
    v = check_vector_field("velocity", velocity)
    v = _f64(v)
    out = np.zeros(v.shape[:2])
    if min(out.shape) >= 2:  # np.gradient's rule: one-sided needs two samples
        _kernels.curl(v, out)
    return out


def _project(v, boundary, method="fast"):
    """Project a staggered velocity (float64, C order; modified in place); return p."""
    enforce_walls(v, boundary, out=v)
    h, w = v.shape[:2]
    if h * w == 1 and boundary == "closed":
        return np.zeros((h, w))
    solver = poisson_solver((h, w), boundary, method)
    vy, vx = _planes(v)
    if method == "fast":
        p, p0 = solver.project(vy, vx, v)
        return p[:, solver.pos] - p0
    p = solver.solve(_divergence(v))
    _kernels.subtract_gradient(vy, vx, p, _in_order(w), boundary == "open_top", 0.0, v)
    return p


def project(velocity, boundary="open_top", *, method="fast"):
    r"""Make a staggered velocity field divergence-free (Eq. (2)).

    Solves the pressure Poisson equation :math:`\nabla^2 p = \nabla \cdot u` on the
    MAC grid (5-point Laplacian) exactly, then subtracts :math:`\nabla p` (Stam's
    projection step, with :math:`\Delta t / \rho` absorbed into p). The wall faces
    are set to zero first. Afterwards :func:`divergence` is zero to round-off.

    The default solver (``method="fast"``) diagonalises the Laplacian along x with a
    discrete cosine transform (the side walls are Neumann) and solves one tridiagonal
    system along y per x-mode (Neumann at a solid wall, p = 0 above an open top):
    O(HW log W), exact to round-off. ``method="lu"`` is the sparse LU factorisation of
    the whole matrix, the reference it is tested against. Both cache their set-up
    per grid shape and boundary. See :mod:`fluidnb.fluid._poisson`.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        Staggered (dy, dx) velocity, px/frame. Not modified.
    boundary : {"open_top", "closed"}
        Solid walls left, right and at the bottom, and an open (p = 0) or solid top.
    method : {"fast", "lu"}
        The Poisson solver: DCT + tridiagonal (default) or sparse LU (reference).

    Returns
    -------
    velocity : ndarray, shape (H, W, 2)
        The divergence-free part, float64.
    pressure : ndarray, shape (H, W)
        The pressure at cell centres (px^2/frame); in a closed box, where it is
        defined up to a constant, 0 in the top-left cell.

    References
    ----------
    .. [1] J. Stam, "Stable Fluids", Proceedings of SIGGRAPH 99, pp. 121-128, 1999.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u0 = rng.normal(size=(16, 16, 2))
    >>> bool(np.allclose(project(u0)[0], project(u0, method="lu")[0], atol=1e-12))
    True
    >>> u, p = project(rng.normal(size=(16, 16, 2)))
    >>> bool(np.abs(divergence(u)).max() < 1e-12)
    True
    """
    check_choice("boundary", boundary, BOUNDARIES)
    check_choice("method", method, METHODS)
    v = np.array(check_vector_field("velocity", velocity), dtype=np.float64)
    p = _project(v, boundary, method)
    return v, p
