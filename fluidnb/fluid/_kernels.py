r"""The solver's per-cell loops, compiled with numba.

One Stable Fluids step touches every cell a dozen times (three advections, buoyancy,
confinement, divergence, pressure gradient, cooling, source). Written with numpy each
of these passes allocates whole-grid temporaries, and at 128 x 128 that bookkeeping
cost several times the arithmetic. These kernels do the same arithmetic cell by cell
in a few fused passes, with no temporaries beyond small scratch grids.

The public teaching functions (:func:`fluidnb.fluid.advect_velocity`,
:func:`~fluidnb.fluid.buoyancy`, :func:`~fluidnb.fluid.vorticity_confinement`,
:func:`~fluidnb.fluid.cool`, :func:`~fluidnb.fluid.divergence`,
:func:`~fluidnb.fluid.curl`, :func:`~fluidnb.fluid.project`) call them too. The
readable version of each, in plain numpy and the paper's notation, is
:mod:`fluidnb.fluid._reference`: each kernel does its arithmetic operation for
operation (same operands, same order), so results agree to the last bit, with two
exceptions at round-off level (a few 1e-16): the confinement's
:math:`|\nabla|\omega||` is ``sqrt(a*a + b*b)``, not ``hypot``, and the cooling's cube
is ``x*x*x``, not numpy's ``x**3`` (tests/fluid/test_fluid_kernels.py).

Both cores: the kernels split the grid by rows among numba's threads (``prange``);
each row is computed by one thread and written only by it, and the one reduction
(the temperature maximum) is taken per row and then over rows, so the result is the
same bit for bit whatever the number of threads (``numba.set_num_threads``). On a
machine whose cores are busy with other work, one thread can be faster.

Every array is float64 and C-contiguous; the callers guarantee it. Compiled on first
use and cached on disk (``cache=True``), like the fire synthesis kernel.
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager

import numba
import numpy as np
from numba import njit, prange

# numba's OpenMP threads spin while they wait for work by default. On a machine whose
# cores are busy with other programs (a classroom server, a notebook beside a
# browser, CI) a spinning thread that loses its core stalls every parallel loop: a
# step measured 5-10x slower with two threads than with one. Passive waiting costs a
# few microseconds a loop instead. Set before numba loads its OpenMP runtime, and only
# when the user has not chosen.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

#: Grids smaller than this many cells run the kernels on one thread: below it,
#: waking the second thread costs more than the half of the work it takes over.
PARALLEL_MIN_CELLS = 64 * 64


@contextmanager
def threads_for(shape):
    """Run the kernels inside on numba's threads, or on one for a small grid."""
    n = numba.get_num_threads()
    if n == 1 or shape[0] * shape[1] >= PARALLEL_MIN_CELLS:
        yield
        return
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(n)


# ------------------------------------------------------------------ small helpers


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def centres(v, out):
    """Average the staggered faces to cell centres (bottom and right walls are zero)."""
    h, w = v.shape[0], v.shape[1]
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            if i + 1 < h:
                out[i, j, 0] = (v[i, j, 0] + v[i + 1, j, 0]) * 0.5
            else:
                out[i, j, 0] = v[i, j, 0] * 0.5
            if j + 1 < w:
                out[i, j, 1] = (v[i, j, 1] + v[i, j + 1, 1]) * 0.5
            else:
                out[i, j, 1] = v[i, j, 1] * 0.5


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _split(t, hi):
    """Clamp ``t`` to [0, hi]; return its integer part and the fraction.

    Clamping the coordinate is the same as repeating the edge sample, and it keeps
    every index in range. Truncation is floor for t >= 0.
    """
    t = min(max(t, 0.0), hi)
    lo = int(t)
    return lo, t - lo


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _bilinear(q, k, ox, oy, fx, fy):
    """Sample the flat grid ``q`` between ``k``, ``k + ox``, ``k + oy``, ``k + oy + ox``.

    ``top + fy * (bottom - top)``: a fraction of exactly 0 returns the sample bit for
    bit and a constant field stays exactly constant, which a four-weight sum would not
    guarantee (the same form as fluidnb.fields.advect).
    """
    a = q[k]
    top = a + fx * (q[k + ox] - a)
    a = q[k + oy]
    bottom = a + fx * (q[k + oy + ox] - a)
    return (bottom - top) * fy + top


# ---------------------------------------------------------------------- advection
#
# The gathers index flat (raveled) arrays with the neighbours as offsets, zero at a
# clamped edge: measured, a third faster than numba's 2-D indexing of computed
# indices.


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def advect_velocity(v, dt, c, out):
    """Semi-Lagrangian self-advection of a staggered velocity; ``c`` is (H, W, 2) scratch.

    Each component is backtraced from its own face with the full velocity vector
    there (the other component averaged from the centres) and read bilinearly,
    clamped. The bottom (for dy) and right (for dx) walls' faces are not stored;
    they are read as zero (from zero-padded copies), as the stored top and left
    walls are, so a backtrace towards those walls sees the wall. Clamping at the last
    stored face instead would make the grid lopsided (a symmetric flame would drift).
    """
    h, w = v.shape[0], v.shape[1]
    centres(v, c)
    qy = np.zeros((h + 1) * w)  # dy on rows 0..h of faces, row h the bottom wall
    qx = np.zeros(h * (w + 1))  # dx on columns 0..w of faces, column w the right wall
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            qy[i * w + j] = v[i, j, 0]
            qx[i * (w + 1) + j] = v[i, j, 1]
    s = -dt
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            # dy on the top face of (i, j); row 0 takes the top cell's dx, as
            # (x + x) * 0.5 == x exactly.
            vx = (c[max(i - 1, 0), j, 1] + c[i, j, 1]) * 0.5
            y0, fy = _split(v[i, j, 0] * s + i, float(h))
            x0, fx = _split(vx * s + j, w - 1.0)
            oy = w if y0 < h else 0
            ox = 1 if x0 < w - 1 else 0
            out[i, j, 0] = _bilinear(qy, y0 * w + x0, ox, oy, fx, fy)
            # dx on the left face of (i, j); column 0 takes the left cell's dy.
            vy = (c[i, max(j - 1, 0), 0] + c[i, j, 0]) * 0.5
            y0, fy = _split(vy * s + i, h - 1.0)
            x0, fx = _split(v[i, j, 1] * s + j, float(w))
            oy = w + 1 if y0 < h - 1 else 0
            ox = 1 if x0 < w else 0
            out[i, j, 1] = _bilinear(qx, y0 * (w + 1) + x0, ox, oy, fx, fy)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def advect_scalars(t, d, v, dt, c, t_out, d_out):
    """Carry two centred scalars along a staggered velocity; return ``max(t_out)``.

    Both are read at the same backtraced position (bilinear, clamped at the border);
    ``c`` is (H, W, 2) scratch for the centred velocity. The maximum is what the
    cooling law needs next (its T_max), taken here to save a pass.
    """
    h, w = t.shape
    centres(v, c)
    tf, df, cf = t.ravel(), d.ravel(), c.ravel()
    t_of, d_of = t_out.ravel(), d_out.ravel()
    s = -dt
    row_max = np.empty(h)  # per row, so the threads share nothing (max is exact anyway)
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        m = -np.inf
        for j in range(w):
            k = i * w + j
            y0, fy = _split(cf[2 * k] * s + i, h - 1.0)
            x0, fx = _split(cf[2 * k + 1] * s + j, w - 1.0)
            oy = w if y0 < h - 1 else 0
            ox = 1 if x0 < w - 1 else 0
            k0 = y0 * w + x0
            x = _bilinear(tf, k0, ox, oy, fx, fy)
            t_of[k] = x
            m = max(m, x)
            d_of[k] = _bilinear(df, k0, ox, oy, fx, fy)
        row_max[i] = m
    return row_max.max() if h > 0 else -np.inf


# ------------------------------------------------------------------------- forces


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _rows(i, h):
    """Rows of np.gradient's difference at row ``i`` and its divisor (2, or 1 at edges)."""
    if i == 0:
        return 1, 0, 1.0
    if i == h - 1:
        return i, i - 1, 1.0
    return i + 1, i - 1, 2.0


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def curl(cy, cx, out):
    """Vorticity at the centres from the centred velocity (dy, dx), as ``np.gradient``.

    ``d(cy)/dx - d(cx)/dy``, central differences inside, one-sided at the border
    (needs H, W >= 2). The border columns are done apart so the inner loop has no
    branch (and vectorises).
    """
    h, w = out.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        ip, im, dv = _rows(i, h)
        out[i, 0] = (cy[i, 1] - cy[i, 0]) - (cx[ip, 0] - cx[im, 0]) / dv
        for j in range(1, w - 1):
            out[i, j] = (cy[i, j + 1] - cy[i, j - 1]) / 2.0 - (cx[ip, j] - cx[im, j]) / dv
        j = w - 1
        out[i, j] = (cy[i, j] - cy[i, j - 1]) - (cx[ip, j] - cx[im, j]) / dv


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _planar_centres(v, cy, cx):
    """The centred velocity as two planes, what the stencils below read fastest."""
    h, w = cy.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            if i + 1 < h:
                cy[i, j] = (v[i, j, 0] + v[i + 1, j, 0]) * 0.5
            else:
                cy[i, j] = v[i, j, 0] * 0.5
            if j + 1 < w:
                cx[i, j] = (v[i, j, 1] + v[i, j + 1, 1]) * 0.5
            else:
                cx[i, j] = v[i, j, 1] * 0.5


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _push(ny, nx, om, epsilon):
    """The push epsilon (N x omega) at one centre, given grad|omega| = (ny, nx)."""
    # Not math.hypot: the C library's is an order of magnitude slower, and its
    # overflow guard is moot for velocities in px/frame.
    norm = math.sqrt(ny * ny + nx * nx)
    if norm < 1e-12:
        # Where |omega| is flat there is no direction to push: N = 0 there.
        norm = np.inf
    scale = epsilon * om / norm
    # N x omega with N = (nx, ny, 0) and omega = (0, 0, w) is (ny w, -nx w, 0).
    return -nx * scale, ny * scale


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _confinement_at_centres(v, epsilon, fy, fx):
    """The push epsilon (N x omega) at the centres into the planes ``fy``, ``fx``."""
    h, w = fy.shape
    cy, cx = np.empty((h, w)), np.empty((h, w))
    _planar_centres(v, cy, cx)
    om = np.empty((h, w))
    curl(cy, cx, om)
    a = np.abs(om)
    # N = grad|omega| / |grad|omega||, central differences, one-sided at the border
    # (np.gradient of |omega|).
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        ip, im, dv = _rows(i, h)
        fy[i, 0], fx[i, 0] = _push((a[ip, 0] - a[im, 0]) / dv, a[i, 1] - a[i, 0], om[i, 0], epsilon)
        for j in range(1, w - 1):
            ny = (a[ip, j] - a[im, j]) / dv
            nx = (a[i, j + 1] - a[i, j - 1]) / 2.0
            fy[i, j], fx[i, j] = _push(ny, nx, om[i, j], epsilon)
        j = w - 1
        ny = (a[ip, j] - a[im, j]) / dv
        fy[i, j], fx[i, j] = _push(ny, a[i, j] - a[i, j - 1], om[i, j], epsilon)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def forces(v, t, kappa_b, t_amb, wind, epsilon, dt, buoyant, out, accumulate):
    """Buoyancy (Eq. 4) and vorticity confinement (Eq. 5) on the faces.

    Buoyancy ``-kappa_b (T - T_amb)`` on the dy faces and ``wind (T - T_amb)`` on the
    dx faces, the temperature averaged across each face (row / column 0 takes its
    cell's value), when ``buoyant``; plus confinement from the staggered velocity
    ``v`` when ``epsilon != 0``, computed at the centres and averaged to the faces
    the same way. With ``accumulate`` the force times ``dt`` is added to ``out`` (the
    solver's update); otherwise the force itself is stored (``dt`` unused).
    """
    h, w = out.shape[0], out.shape[1]
    confine = epsilon != 0.0 and h >= 2 and w >= 2
    if confine:
        cfy, cfx = np.empty((h, w)), np.empty((h, w))
        _confinement_at_centres(v, epsilon, cfy, cfx)
    else:
        cfy, cfx = np.empty((1, 1)), np.empty((1, 1))
    # Row and column 0 take their cell's value where the others average two cells:
    # (x + x) * 0.5 == x exactly, so one formula serves both without a branch.
    nk = -kappa_b
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        im = max(i - 1, 0)
        for j in range(w):
            jm = max(j - 1, 0)
            fy = 0.0
            fx = 0.0
            if buoyant:
                e = t[i, j] - t_amb
                fy = ((t[im, j] - t_amb) + e) * 0.5 * nk
                if wind != 0.0:
                    fx = ((t[i, jm] - t_amb) + e) * 0.5 * wind
            if confine:
                fy += (cfy[im, j] + cfy[i, j]) * 0.5
                fx += (cfx[i, jm] + cfx[i, j]) * 0.5
            if accumulate:
                out[i, j, 0] += fy * dt
                out[i, j, 1] += fx * dt
            else:
                out[i, j, 0] = fy
                out[i, j, 1] = fx


# ---------------------------------------------------------------------- projection


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def divergence(v, out):
    """Net outflow of each cell: (dy below - dy above) + (dx right - dx left)."""
    h, w = out.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            s = -v[i, j, 0] - v[i, j, 1]
            if i + 1 < h:
                s += v[i + 1, j, 0]
            if j + 1 < w:
                s += v[i, j + 1, 1]
            out[i, j] = s


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def subtract_gradient(v, p, open_top):
    """``v -= grad p`` on every active face; above an open top the pressure is 0."""
    h, w = p.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            if i > 0:
                v[i, j, 0] -= p[i, j] - p[i - 1, j]
            elif open_top:
                v[0, j, 0] -= p[0, j]
            if j > 0:
                v[i, j, 1] -= p[i, j] - p[i, j - 1]


# ------------------------------------------------------------------ cooling, source


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _cbrt(y):
    """The cube root of ``y >= 1`` (the cooling's divisor), to 3 units in the last place.

    The C library's ``cbrt`` (and numpy's, which calls it) costs about 25 ns a value:
    over a 128 x 128 grid more than the advection. The cooling only ever needs it on
    [1, 2] when ``3 C_r dt / span <= 1`` (x <= 1): there, start from the Taylor series
    ``1 + d/3 - d^2/9`` (d = y - 1, error < 0.04) and take three Halley steps
    ``r <- r (r^3 + 2y) / (2r^3 + y)``, each cubing the error: a handful of flops.
    """
    if y > 2.0:
        return np.cbrt(y)
    d = y - 1.0
    r = 1.0 + d * (1.0 / 3.0 - d * (1.0 / 9.0))
    for _ in range(3):
        r3 = r * r * r
        r = r * (r3 + 2.0 * y) / (2.0 * r3 + y)
    return r


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _cooled(x, t_amb, span, k):
    """One cell of the exact cooling step: ``x / (1 + k x^3)^(1/3)`` in relative units.

    ``k = 3 C_r dt / span``; see :func:`fluidnb.fluid.cool`.
    """
    if x > t_amb:
        e = (x - t_amb) / span
        return t_amb + span * (e / _cbrt(1.0 + k * (e * e * e)))
    return x


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def cool(t, t_amb, span, k, out):
    """Radiative cooling of every cell above ambient (``k = 3 C_r dt / span``)."""
    h, w = t.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            out[i, j] = _cooled(t[i, j], t_amb, span, k)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def cool_and_heat(
    t, d, cooling, t_amb, span, k, mask, heat, source_t, noisy, hot, flicker, noise, smoke
):
    """Cooling (when ``cooling``), then the source, in place on ``t`` and ``d``.

    Inside the source's soft disc ``mask`` the temperature is raised towards
    ``source_t`` -- or, when ``noisy``, towards
    ``t_amb + hot * (1 + flicker * noise)`` -- never lowered; the density gains
    ``smoke * mask`` (``smoke = density_rate * dt``, skipped when 0). Nothing of the
    source when not ``heat``.
    """
    h, w = t.shape
    for r in prange(h):
        i = np.int64(r)  # signed: prange's index is unsigned, and i - 1 must not wrap
        for j in range(w):
            x = t[i, j]
            if cooling:
                x = _cooled(x, t_amb, span, k)
            if heat:
                m = mask[i, j]
                target = t_amb + hot * (1.0 + flicker * noise[i, j]) if noisy else source_t
                target -= x
                if target < 0.0:
                    target = 0.0
                x += target * m
                if smoke > 0.0:
                    d[i, j] += smoke * m
            t[i, j] = x
