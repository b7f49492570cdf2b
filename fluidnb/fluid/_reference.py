r"""The whole solver step in plain numpy, in the paper's notation: read this first.

One Stable Fluids step (Stam 1999) as Furukawa et al. (2013), sec. 3.1 write it:

.. math::

    \frac{\partial u}{\partial t} = -(u \cdot \nabla) u - \nabla p + f, \quad
    \nabla \cdot u = 0, \qquad (1), (2)

    \frac{\partial T}{\partial t} = -(u \cdot \nabla) T
        - C_r \left(\frac{T - T_{amb}}{T_{max} - T_{amb}}\right)^4, \qquad (3)

    f_{buo} = \kappa_b (T - T_{amb})\,\hat y, \qquad (4) \qquad
    f_{conf} = \epsilon\,(N \times \omega), \;
    N = \frac{\nabla|\omega|}{|\nabla|\omega||}, \; \omega = \nabla \times u. \qquad (5)

Each function below is one term, written the way one first writes it: whole-array
numpy, no fused loops, no caches. :func:`fluidnb.fluid.step` runs the same arithmetic
in compiled kernels (``_kernels.py``) and a fast Poisson solver (``_poisson.py``); the
tests check that both give the same step (to round-off: a few 1e-13). Use this module
to read, change and experiment (the lesson notebooks/04_fluid_solver.ipynb does),
and :func:`fluidnb.fluid.step` for real work.

Grid (see :mod:`fluidnb.fluid._grid`): T, density and p at cell centres; the velocity
on a staggered (MAC) grid, stored as (H, W, 2) (dy, dx): ``u[i, j, 0]`` on the top
face of cell (i, j), ``u[i, j, 1]`` on its left face. Rows grow downwards, so "up" is
dy < 0. Walls: left, right and bottom solid; the top open (p = 0 above it) or solid.
"""

from __future__ import annotations

import numpy as np
import scipy.fft
from scipy.linalg import solve_banded

from ._solver import FluidState

__all__ = [
    "advect_scalar",
    "advect_velocity",
    "buoyancy",
    "centres",
    "cool",
    "curl",
    "divergence",
    "heat_source",
    "pressure",
    "project",
    "sample",
    "step",
    "to_x_faces",
    "to_y_faces",
    "vorticity_confinement",
]


# ------------------------------------------------------------------ the grid


def centres(u):
    """The staggered velocity averaged to the cell centres: (u_y, u_x), each (H, W).

    A cell's u_y is the mean of its top and bottom faces; the bottom wall's face is 0.
    """
    uy, ux = u[..., 0], u[..., 1]
    below = np.vstack([uy[1:], np.zeros((1, uy.shape[1]))])  # bottom wall: 0
    right = np.hstack([ux[:, 1:], np.zeros((ux.shape[0], 1))])  # right wall: 0
    return (uy + below) * 0.5, (ux + right) * 0.5


def to_y_faces(c):
    """A centred field on the top faces: the mean of the cells above and below.

    Row 0 (the top boundary) takes its own cell's value.
    """
    above = np.vstack([c[:1], c[:-1]])
    return (above + c) * 0.5


def to_x_faces(c):
    """A centred field on the left faces (column 0 takes its own cell's value)."""
    left = np.hstack([c[:, :1], c[:, :-1]])
    return (left + c) * 0.5


def divergence(u):
    r""":math:`\nabla \cdot u` per cell: what flows out of its four faces."""
    uy, ux = u[..., 0], u[..., 1]
    below = np.vstack([uy[1:], np.zeros((1, uy.shape[1]))])
    right = np.hstack([ux[:, 1:], np.zeros((ux.shape[0], 1))])
    return -uy - ux + below + right


def curl(cy, cx):
    r""":math:`\omega = \partial_x u_y - \partial_y u_x` at the centres (central differences)."""
    return np.gradient(cy, axis=1) - np.gradient(cx, axis=0)


# ------------------------------------------------------------ advection (Stam)


def sample(q, y, x):
    """Bilinear sample of the grid ``q`` at positions (y, x), clamped to the grid.

    Clamping a position to the grid is the same as repeating the edge samples.
    """
    h, w = q.shape
    y = np.clip(y, 0.0, h - 1.0)
    x = np.clip(x, 0.0, w - 1.0)
    i0, j0 = y.astype(int), x.astype(int)  # floor, as y, x >= 0
    fy, fx = y - i0, x - j0
    i1, j1 = np.minimum(i0 + 1, h - 1), np.minimum(j0 + 1, w - 1)
    top = q[i0, j0] + fx * (q[i0, j1] - q[i0, j0])
    bottom = q[i1, j0] + fx * (q[i1, j1] - q[i1, j0])
    return (bottom - top) * fy + top


def advect_scalar(q, u, dt):
    r"""The semi-Lagrangian step :math:`q(x) \leftarrow q(x - \Delta t\,u(x))` for a centred q."""
    cy, cx = centres(u)
    i, j = np.indices(q.shape)
    return sample(q, i - dt * cy, j - dt * cx)


def advect_velocity(u, dt):
    r"""The first term of Eq. (1): :math:`u \leftarrow u(x - \Delta t\,u(x))`, per component.

    Each component is carried from its own faces: u_y on the top faces (plus the
    bottom wall's row of zeros), backtraced with the velocity at each face (u_y
    itself, u_x averaged from the centres); u_x likewise on the left faces.
    """
    h, w = u.shape[:2]
    uy, ux = u[..., 0], u[..., 1]
    cy, cx = centres(u)
    i, j = np.indices((h, w))
    new = np.empty_like(u)
    q = np.vstack([uy, np.zeros((1, w))])  # u_y on rows 0..H of faces
    new[..., 0] = sample(q, i - dt * uy, j - dt * to_y_faces(cx))
    q = np.hstack([ux, np.zeros((h, 1))])  # u_x on columns 0..W of faces
    new[..., 1] = sample(q, i - dt * to_x_faces(cy), j - dt * ux)
    return new


# --------------------------------------------------------------- forces (4), (5)


def buoyancy(T, kappa_b, T_amb, wind=0.0):
    r"""Eq. (4): :math:`f_{buo} = \kappa_b (T - T_{amb})\,\hat y` on the faces (up is dy < 0).

    ``wind`` adds a sideways push ``wind * (T - T_amb)`` (not in the paper).
    """
    excess = T - T_amb
    f = np.empty((*T.shape, 2))
    f[..., 0] = to_y_faces(excess) * -kappa_b
    f[..., 1] = to_x_faces(excess) * wind
    return f


def vorticity_confinement(u, epsilon):
    r"""Eq. (5): :math:`f_{conf} = \epsilon (N \times \omega)` on the faces (Fedkiw et al. 2001)."""
    cy, cx = centres(u)
    omega = curl(cy, cx)
    Ny, Nx = np.gradient(np.abs(omega), axis=0), np.gradient(np.abs(omega), axis=1)
    norm = np.sqrt(Ny * Ny + Nx * Nx)
    norm[norm < 1e-12] = np.inf  # |omega| flat: no direction to push, N = 0
    scale = epsilon * omega / norm
    # N x omega with N = (Nx, Ny, 0) and omega = (0, 0, w) is (Ny w, -Nx w, 0).
    f = np.empty(u.shape)
    f[..., 0] = to_y_faces(-Nx * scale)
    f[..., 1] = to_x_faces(Ny * scale)
    return f


# ------------------------------------------------------------- projection (2)


def pressure(div, boundary="open_top"):
    r"""Solve :math:`-\nabla^2 p = -\nabla \cdot u` exactly (see fluidnb.fluid._poisson).

    The 5-point Laplacian with walls is :math:`L_x \otimes I + I \otimes L_y`. A cosine
    transform (DCT-II) along x diagonalises :math:`L_x` (eigenvalues
    :math:`\lambda_k = 2 - 2\cos(\pi k / W)`), leaving for each x-mode k one
    tridiagonal system along y, :math:`(L_y + \lambda_k)\,\hat p_k = \hat r_k`.
    A closed box fixes p only up to a constant: we set p = 0 in cell (0, 0).
    """
    h, w = div.shape
    r_hat = scipy.fft.dct(-div, type=2, axis=1, norm="ortho")
    lam = 2.0 - 2.0 * np.cos(np.pi * np.arange(w) / w)
    # L_y: [-1, 2, -1]; a Neumann wall row has 1 on the diagonal, the open top's
    # first row keeps 2 (p = 0 just above the grid).
    diag_y = np.full(h, 2.0)
    diag_y[-1] = 1.0
    if boundary == "closed":
        diag_y[0] = 1.0
    p_hat = np.zeros((h, w))
    for k in range(w):
        bands = np.zeros((3, h))  # solve_banded's layout: upper, diagonal, lower
        bands[0, 1:] = -1.0
        bands[1] = diag_y + lam[k]
        bands[2, :-1] = -1.0
        if boundary == "closed" and k == 0:
            # Singular (constants solve it with zero right-hand side): fix p_hat[0] = 0
            # and solve for the rest.
            if h > 1:
                p_hat[1:, 0] = solve_banded((1, 1), bands[:, 1:], r_hat[1:, 0])
            continue
        p_hat[:, k] = solve_banded((1, 1), bands, r_hat[:, k])
    p = scipy.fft.idct(p_hat, type=2, axis=1, norm="ortho")
    if boundary == "closed":
        p -= p[0, 0]
    return p


def project(u, boundary="open_top"):
    r"""Eq. (2): :math:`u \leftarrow u - \nabla p` with :math:`\nabla^2 p = \nabla \cdot u`.

    Returns the divergence-free velocity and p.
    """
    u = u.copy()
    u[:, 0, 1] = 0.0  # the left wall carries no flow
    if boundary == "closed":
        u[0, :, 0] = 0.0  # nor does a solid top
    p = pressure(divergence(u), boundary)
    above = np.vstack([np.zeros((1, p.shape[1])), p[:-1]])  # p = 0 above an open top
    u[..., 0] -= p - above
    if boundary == "closed":
        u[0, :, 0] = 0.0
    u[:, 1:, 1] -= p[:, 1:] - p[:, :-1]
    return u, p


# ----------------------------------------------------- cooling (3) and the source


def cool(T, C_r, T_amb, dt, T_max):
    r"""The second term of Eq. (3) integrated exactly over dt, :math:`T_{max}` held.

    With :math:`x = (T - T_{amb}) / (T_{max} - T_{amb})`,
    :math:`dx/dt = -c\,x^4` (:math:`c = C_r / (T_{max} - T_{amb})`) has the solution
    :math:`x / (1 + 3 c\,\Delta t\,x^3)^{1/3}`. Cells at or below ambient do not cool.
    """
    span = T_max - T_amb
    if C_r == 0 or dt == 0 or span <= 0:
        return T.copy()
    x = (T - T_amb) / span
    hot = x > 0
    x[hot] = x[hot] / np.cbrt(1.0 + 3.0 * C_r * dt / span * x[hot] ** 3)
    return np.where(hot, T_amb + span * x, T)


def heat_source(T, density, mask, params, noise=None):
    """Raise T inside the source disc towards ``source_T`` and add smoke there.

    ``noise`` (uniform in [-1, 1], per cell) makes the target flicker by
    ``source_flicker`` times the source's excess over ambient.
    """
    p = params
    target = p.source_T
    if noise is not None:
        target = p.T_amb + (p.source_T - p.T_amb) * (1.0 + p.source_flicker * noise)
    T = T + np.maximum(target - T, 0.0) * mask  # heat, never cool
    density = density + p.density_rate * p.dt * mask
    return T, density


# ------------------------------------------------------------------ one step


def step(state, params, rng=None):
    """One step of :func:`fluidnb.fluid.step`, term by term (same order, same noise).

    Parameters
    ----------
    state : FluidState
    params : FluidParams
    rng : numpy.random.Generator, optional
        Drawn from exactly as :func:`fluidnb.fluid.step` draws (the same generator
        state gives the same flicker).

    Returns
    -------
    FluidState
    """
    from ._forces import source_mask

    p, dt = params, params.dt
    u = np.array(state.velocity, dtype=np.float64)
    T = np.array(state.temperature, dtype=np.float64)
    density = np.array(state.density, dtype=np.float64)

    u = advect_velocity(u, dt)  # 1. -(u . grad) u
    f = buoyancy(T, p.kappa_b, p.T_amb, p.wind)  # 2. + f
    if p.epsilon != 0:
        f = f + vorticity_confinement(u, p.epsilon)
    u = u + dt * f
    u, _ = project(u, p.boundary)  # 3. - grad p, div u = 0
    T = advect_scalar(T, u, dt)  # 4. -(u . grad) T, and the smoke
    density = advect_scalar(density, u, dt)
    T = cool(T, p.C_r, p.T_amb, dt, T.max())  # 5. the cooling of Eq. (3)
    if p.source_radius > 0:  # 6. the source
        mask = source_mask(T.shape, p)
        noise = None
        if p.source_flicker > 0 and p.source_T > p.T_amb:
            # One uniform number per cell of the source, in row-major order.
            gen = np.random.default_rng() if rng is None else rng
            noise = np.zeros(T.shape)
            noise[mask > 0] = gen.uniform(-1.0, 1.0, size=np.count_nonzero(mask))
        T, density = heat_source(T, density, mask, p, noise)
    return FluidState(u, T, density, frame=state.frame + 1)
