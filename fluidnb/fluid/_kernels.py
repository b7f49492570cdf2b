r"""The solver's per-cell loops, compiled with numba.

A Stable Fluids step touches every cell many times: three advections (both velocity
components, then temperature and density), buoyancy, vorticity confinement, the
projection's divergence and gradient, cooling and the source. Written with numpy each
term is a pass over the grid with whole-grid temporaries, and at 128 x 128 that
bookkeeping costs several times the arithmetic. :func:`fluidnb.fluid.step` runs them as
a few fused passes, in the order of the readable step (:mod:`fluidnb.fluid._reference`):

1. :func:`advect_velocity` -- the velocity copied into two wall-padded planes (what the
   gathers read without a branch), then advected through itself;
2. :func:`confinement` -- the vorticity of that and the push epsilon (N x omega) at
   the centres;
3. :func:`forces_and_divergence` -- buoyancy and the push added on the faces, the walls
   set, and the divergence of the result, written in the order the pressure solve's
   cosine transform reads (``_poisson.py``: a real FFT, the tridiagonal solves with the
   transform's turns folded in, the inverse FFT);
4. :func:`gradient_and_scalars` -- the pressure gradient subtracted, and temperature and
   density advected along the divergence-free velocity (the per-row maximum taken);
5. :func:`cool` -- the cooling with that maximum, in place;
6. :func:`heat` -- the source, over its own few cells.

Each term is a small inline function (:func:`_advected_faces`, :func:`_face_forces`,
:func:`_push`, :func:`_projected`, :func:`_cooled`, ...) that the fused kernels and the
per-term kernels behind the public teaching functions
(:func:`fluidnb.fluid.advect_velocity`, :func:`~fluidnb.fluid.buoyancy`,
:func:`~fluidnb.fluid.vorticity_confinement`, :func:`~fluidnb.fluid.divergence`,
:func:`~fluidnb.fluid.project`, :func:`~fluidnb.fluid.cool`, ...) share. Each does its
arithmetic operation for operation as :mod:`fluidnb.fluid._reference` does (same
operands, same order), so the results agree to the last bit, except the cooling's cube
root (about one unit in the last place; see :func:`_inv_cbrt`) and the Poisson solve
(round-off: another route to the same cosine transform).

Index arithmetic is unsigned and the velocity is kept as two planes between the
passes: numba then adds no wrap-around guard to an access, no loop of gathers stores
into the interleaved (H, W, 2) array, and LLVM turns every pass into vector code.

Both cores: the kernels split the grid by rows among numba's threads (``prange``);
each row is computed by one thread and written only by it, and the one reduction
(the temperature maximum) is taken per row and then over rows, so the result is the
same bit for bit whatever the number of threads. Every parallel loop is a rendezvous
of the threads (tens of microseconds on a busy machine), so a step has seven: the
kernels that need a neighbouring row's result split the rows into one chunk per
thread and recompute the one row beyond a chunk's edge rather than wait for it. How
many threads a step uses is measured, not assumed (:mod:`fluidnb.fluid._threads`).

Every array is float64 and C-contiguous; the callers guarantee it. Compiled on first
use and cached on disk (``cache=True``), like the fire synthesis kernel.
"""

from __future__ import annotations

import math
import os

import numpy as np
from numba import njit, prange

# numba's OpenMP threads spin while they wait for work by default. On a machine whose
# cores are busy with other programs (a classroom server, a notebook beside a
# browser, CI) a spinning thread that loses its core stalls every parallel loop: a
# step measured 5-10x slower with two threads than with one. Passive waiting avoids
# that, at a price: waking the second thread costs about 40 microseconds a parallel
# loop on the 2-core VMs we measured on, even idle, so there two threads do not pay
# for a 128 x 128 step and fluidnb.fluid._threads keeps one. On a machine of your
# own, GOMP_SPINCOUNT=10000 (a short spin, then sleep) made two threads 1.5x faster
# than one when idle. Set before numba loads its OpenMP runtime, and only when the
# user has chosen neither.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"

U0 = np.uint64(0)
U1 = np.uint64(1)


# ------------------------------------------------------------------ small helpers


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def centres(v, out):
    """Average the staggered faces to cell centres (bottom and right walls are zero)."""
    h, w = v.shape[0], v.shape[1]
    for r in prange(h):
        i = np.int64(r)
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
def _pad_row(v, i, qy, qx):
    """Copy row ``i`` of the staggered velocity into the wall-padded planes.

    ``qy`` (H + 1, W) holds dy on rows 0..H of faces (row H, the bottom wall, zero),
    ``qx`` (H, W + 1) dx on columns 0..W (column W, the right wall, zero).
    """
    h, w = v.shape[0], v.shape[1]
    for jj in range(w):
        j = np.uint64(jj)
        qy[i, j] = v[i, j, 0]
        qx[i, j] = v[i, j, 1]
    qx[i, np.uint64(w)] = 0.0
    if i + U1 == np.uint64(h):
        for jj in range(w):
            qy[i + U1, np.uint64(jj)] = 0.0


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _before(k):
    """The index before ``k``, or 0 at 0: row / column 0's faces take their own cell's."""
    return k - U1 if k > U0 else U0


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _split(t, hi):
    """Clamp ``t`` to [0, hi]; return its integer part (unsigned) and the fraction.

    Clamping the coordinate is the same as repeating the edge sample, and it keeps
    every index in range -- a NaN too lands on 0, never outside the grid. Truncation
    is floor for t >= 0.
    """
    t = t if t > 0.0 else 0.0
    t = t if t < hi else hi
    lo = np.uint64(t)
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


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _sample(q, stride, y, x, y_hi, x_hi):
    """Bilinear sample of the flat grid ``q`` (rows of ``stride``) at (y, x), clamped.

    ``y_hi``, ``x_hi``: the last row and column (floats).
    """
    y0, fy = _split(y, y_hi)
    x0, fx = _split(x, x_hi)
    oy = stride if y0 < y_hi else U0
    ox = U1 if x0 < x_hi else U0
    return _bilinear(q, y0 * stride + x0, ox, oy, fx, fy)


# ---------------------------------------------------------------------- advection
#
# The gathers index flat (raveled) arrays with the neighbours as offsets, zero at a
# clamped edge: measured, a third faster than numba's 2-D indexing of computed
# indices. Everything read or written in order is indexed in 2-D: LLVM then sees
# consecutive addresses (flat unsigned sums it turned into gathers and scatters).


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _centred_y(qy, i, j):
    """The dy component at the centre of cell (i, j), from its padded plane."""
    return (qy[i, j] + qy[i + U1, j]) * 0.5


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _centred_x(qx, i, j):
    """The dx component at the centre of cell (i, j), from its padded plane."""
    return (qx[i, j] + qx[i, j + U1]) * 0.5


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _advected_faces(qy, qx, qy_flat, qx_flat, i, im, j, jm, s):
    """The semi-Lagrangian step for the two faces of cell (i, j); ``s = -dt``.

    Each component is backtraced from its own face with the full velocity vector
    there (the other component averaged from the two neighbouring centres; row or
    column 0 takes its own cell's, as ``(x + x) * 0.5 == x``) and read bilinearly
    from its padded plane (``qy_flat``, ``qx_flat``: the same, flat), clamped. The
    bottom (for dy) and right (for dx) walls' faces are read as zero, as the stored
    top and left walls are, so a backtrace towards those walls sees the wall;
    clamping at the last stored face instead would make the grid lopsided (a
    symmetric flame would drift).
    """
    h, w = qx.shape[0], qy.shape[1]
    fi, fj = float(i), float(j)
    vx = (_centred_x(qx, im, j) + _centred_x(qx, i, j)) * 0.5
    dy = _sample(qy_flat, np.uint64(w), qy[i, j] * s + fi, vx * s + fj, float(h), w - 1.0)
    vy = (_centred_y(qy, i, jm) + _centred_y(qy, i, j)) * 0.5
    dx = _sample(qx_flat, np.uint64(w + 1), vy * s + fi, qx[i, j] * s + fj, h - 1.0, float(w))
    return dy, dx


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def pad(v, qy, qx):
    """Copy a staggered (H, W, 2) velocity into its wall-padded planes (see _pad_row)."""
    for r in prange(v.shape[0]):
        _pad_row(v, np.uint64(r), qy, qx)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def advect_velocity(v, dt, qy, qx, ay, ax):
    """Semi-Lagrangian self-advection of a staggered velocity (no forces, no walls).

    ``qy``, ``qx`` are scratch for the padded planes of ``v``; the result goes to the
    padded planes ``ay``, ``ax`` (their wall row and column set to zero).
    """
    h, w = v.shape[0], v.shape[1]
    for r in prange(h):
        _pad_row(v, np.uint64(r), qy, qx)
    qy_flat, qx_flat = qy.ravel(), qx.ravel()
    for r in prange(h):
        i = np.uint64(r)
        for jj in range(w):
            j = np.uint64(jj)
            ay[i, j], ax[i, j] = _advected_faces(
                qy, qx, qy_flat, qx_flat, i, _before(i), j, _before(j), -dt
            )
        ax[i, np.uint64(w)] = 0.0
        if i + U1 == np.uint64(h):
            for jj in range(w):
                ay[i + U1, np.uint64(jj)] = 0.0


# ------------------------------------------------------------------------- forces


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _rows(i, h):
    """Rows of np.gradient's difference at row ``i``, and 1 / its divisor (2, or 1 at edges).

    Dividing by 2 or 1 is exactly multiplying by 0.5 or 1 (a power of two), and a
    multiplication vectorises far better than a division.
    """
    if i == U0:
        return U1, U0, 1.0
    if i == np.uint64(h - 1):
        return i, i - U1, 1.0
    return i + U1, i - U1, 0.5


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _omega_row(qy, qx, i, out):
    """Vorticity ``d(cy)/dx - d(cx)/dy`` of row ``i`` into the row ``out``, as ``np.gradient``.

    From the centred velocity (averaged from the padded planes; needs H, W >= 2):
    central differences inside, one-sided at the border. The border columns are done
    apart so the inner loop has no branch (and vectorises).
    """
    h, w = qx.shape[0], qy.shape[1]
    ip, im, half = _rows(i, h)
    j = U0
    out[j] = (_centred_y(qy, i, U1) - _centred_y(qy, i, j)) - (
        _centred_x(qx, ip, j) - _centred_x(qx, im, j)
    ) * half
    for jj in range(1, w - 1):
        j = np.uint64(jj)
        out[j] = (_centred_y(qy, i, j + U1) - _centred_y(qy, i, j - U1)) * 0.5 - (
            _centred_x(qx, ip, j) - _centred_x(qx, im, j)
        ) * half
    j = np.uint64(w - 1)
    out[j] = (_centred_y(qy, i, j) - _centred_y(qy, i, j - U1)) - (
        _centred_x(qx, ip, j) - _centred_x(qx, im, j)
    ) * half


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _push(ny, nx, om, epsilon):
    """The push epsilon (N x omega) at one centre, given grad|omega| = (ny, nx)."""
    # Not math.hypot: the C library's is an order of magnitude slower, and its
    # overflow guard is moot for velocities in px/frame.
    norm = math.sqrt(ny * ny + nx * nx)
    # Where |omega| is flat there is no direction to push: N = 0 there.
    norm = norm if norm >= 1e-12 else np.inf
    scale = epsilon * om / norm
    # N x omega with N = (nx, ny, 0) and omega = (0, 0, w) is (ny w, -nx w, 0).
    return -nx * scale, ny * scale


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _push_row(after, om, before, half, epsilon, fy, fx):
    """The push at the centres of one row into the rows ``fy``, ``fx``.

    ``om`` is the row's vorticity, ``after`` and ``before`` the rows np.gradient's
    difference along y takes, ``half`` 1 / its divisor (see :func:`_rows`):
    N = grad|omega| / |grad|omega||.
    """
    w = om.shape[0]
    j = U0
    fy[j], fx[j] = _push(
        (abs(after[j]) - abs(before[j])) * half, abs(om[U1]) - abs(om[j]), om[j], epsilon
    )
    for jj in range(1, w - 1):
        j = np.uint64(jj)
        ny = (abs(after[j]) - abs(before[j])) * half
        nx = (abs(om[j + U1]) - abs(om[j - U1])) * 0.5
        fy[j], fx[j] = _push(ny, nx, om[j], epsilon)
    j = np.uint64(w - 1)
    ny = (abs(after[j]) - abs(before[j])) * half
    fy[j], fx[j] = _push(ny, abs(om[j]) - abs(om[j - U1]), om[j], epsilon)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def confinement(qy, qx, epsilon, parts, fy, fx):
    """The push epsilon (N x omega) at the centres ``fy``, ``fx`` (needs H, W >= 2).

    The velocity as its padded planes (see :func:`_pad_row`). One parallel loop over
    ``parts`` chunks of rows: each computes the vorticity of its rows and of one row
    beyond either end into a buffer of its own, then the push.
    """
    h, w = fy.shape
    for c in prange(parts):
        lo, hi = _chunk(c, parts, h)
        first, last = max(lo - 1, 0), min(hi + 1, h)
        om = np.empty((last - first, w))
        for r in range(first, last):
            _omega_row(qy, qx, np.uint64(r), om[r - first])
        for r in range(lo, hi):
            ip, im, half = _rows(np.uint64(r), h)
            _push_row(om[ip - first], om[r - first], om[im - first], half, epsilon, fy[r], fx[r])


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def curl(v, out):
    """Vorticity at the centres of a staggered velocity (needs H, W >= 2)."""
    h, w = out.shape
    qy, qx = np.empty((h + 1, w)), np.empty((h, w + 1))
    for r in prange(h):
        _pad_row(v, np.uint64(r), qy, qx)
    for r in prange(h):
        _omega_row(qy, qx, np.uint64(r), out[r])


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _face_forces(t, fy, fx, i, im, j, jm, t_amb, nk, wind):
    """Buoyancy (Eq. 4) and the confinement push on the two faces of cell (i, j).

    Buoyancy ``-kappa_b (T - T_amb)`` (``nk = -kappa_b``) on the dy face and ``wind
    (T - T_amb)`` on the dx face, plus the push ``fy``, ``fx``: each a centred field
    averaged across the face (row / column 0 takes its cell's value, as
    ``(x + x) * 0.5 == x``).
    """
    e = t[i, j] - t_amb
    f_y = ((t[im, j] - t_amb) + e) * 0.5 * nk + (fy[im, j] + fy[i, j]) * 0.5
    f_x = ((t[i, jm] - t_amb) + e) * 0.5 * wind + (fx[i, jm] + fx[i, j]) * 0.5
    return f_y, f_x


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def face_forces(t, fy, fx, kappa_b, t_amb, wind, out):
    """The force on every face (buoyancy + the centred push ``fy``, ``fx``)."""
    h, w = t.shape
    nk = -kappa_b
    for r in prange(h):
        i = np.uint64(r)
        for jj in range(w):
            j = np.uint64(jj)
            f = _face_forces(t, fy, fx, i, _before(i), j, _before(j), t_amb, nk, wind)
            out[i, j, 0], out[i, j, 1] = f


# ------------------------------------------------------------------------ cooling


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _inv_cbrt(y):
    """``y ** (-1/3)`` for ``y`` in [1, 2], within about one unit in the last place.

    The C library's ``cbrt`` (and numpy's, which calls it) costs about 25 ns a value
    and, being a call, keeps the loop around it from vectorising: over a 128 x 128
    grid it cost more than the advection. Instead: a cubic fitted to ``y ** (-1/3)``
    on [1, 2] (error < 4e-4), then three Newton steps
    ``r <- r + r (1 - y r^3) / 3``, each squaring the error (to 1e-26): multiplications
    only, which vectorise.
    """
    d = y - 1.0
    r = 0.99973891 + d * (-0.32411571 + d * (0.16757398 + d * -0.04969008))
    for _ in range(3):
        r = r + r * (1.0 - y * (r * r * r)) * (1.0 / 3.0)
    return r


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _cooled(x, t_amb, span, k, k_root):
    """One cell of the exact cooling step: ``e / (1 + k e^3)^(1/3)`` in relative units.

    ``e = (x - T_amb) / span``, ``k = 3 C_r dt / span`` and ``k_root = k ** (-1/3)``;
    cells at or below ambient are returned as they are (see
    :func:`fluidnb.fluid.cool`). The cube root is only ever taken on [1, 2]: where
    ``c = k e^3 > 1``, ``e / (1 + c)^(1/3) = k^(-1/3) / (1 + 1/c)^(1/3)``. Both forms
    are computed and one is selected, so the loop has no branch and vectorises.
    """
    e = (x - t_amb) / span
    c = k * (e * e * e)
    small = c <= 1.0
    r = _inv_cbrt(1.0 + (c if small else 1.0 / c))
    cooled = t_amb + span * (e * r if small else k_root * r)
    return cooled if x > t_amb else x


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def cool(t, t_amb, span, k, k_root, out):
    """Radiative cooling of every cell above ambient (``k = 3 C_r dt / span``)."""
    h, w = t.shape
    for r in prange(h):
        i = np.uint64(r)
        for jj in range(w):
            j = np.uint64(jj)
            out[i, j] = _cooled(t[i, j], t_amb, span, k, k_root)


# ------------------------------------------------------------------------- source


@njit(cache=True, nogil=True, error_model="numpy")
def heat(t, d, cells, weights, source_t, noisy, t_amb, hot, flicker, noise, smoke):
    """The source, in place on ``t`` and ``d``, over its cells only.

    ``cells`` are the flat indices of the source's soft disc and ``weights`` its
    mask there. The temperature is raised towards ``source_t`` -- or, when ``noisy``,
    towards ``t_amb + hot * (1 + flicker * noise)`` -- never lowered; the density gains
    ``smoke * weight`` (``smoke = density_rate * dt``).
    """
    tf, df = t.ravel(), d.ravel()
    for n in range(cells.size):
        c = cells[n]
        m = weights[n]
        target = t_amb + hot * (1.0 + flicker * noise[n]) if noisy else source_t
        x = tf[c]
        tf[c] = x + max(target - x, 0.0) * m
        df[c] = df[c] + smoke * m


# ---------------------------------------------------------------------- projection


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _outflow(top, left, below, right, i, j, h, w):
    """Cell (i, j)'s divergence from its faces, in the reference's order of sums.

    ``-top - left + below + right``; the bottom (i = H - 1) and right (j = W - 1)
    walls' faces are zero and not added.
    """
    s = -top - left
    if i + U1 < np.uint64(h):
        s += below
    if j + U1 < np.uint64(w):
        s += right
    return s


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def divergence(vy, vx, pos, out):
    """Net outflow of each cell, (dy below - dy above) + (dx right - dx left).

    The velocity as its two planes of faces. Cell (i, j)'s goes to ``out[i, pos[j]]``:
    ``pos`` is ``arange(W)`` for the plain field, or the order the projection's cosine
    transform reads (see ``_poisson.py``).
    """
    h, w = vy.shape
    for r in prange(h):
        i = np.uint64(r)
        ib = i + U1 if i + U1 < np.uint64(h) else i
        for jj in range(w):
            j = np.uint64(jj)
            jr = j + U1 if j + U1 < np.uint64(w) else j
            out[i, pos[j]] = _outflow(vy[i, j], vx[i, j], vy[ib, j], vx[i, jr], i, j, h, w)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _forced(ay, ax, t, fy, fx, i, j, dt, t_amb, nk, wind, closed):
    """The faces of cell (i, j) after the forces: ``a + dt f``, the walls zero.

    ``ay``, ``ax``: the advected velocity's padded planes; the force as
    :func:`_face_forces`. The left wall's dx, and a closed top's dy, are zero.
    """
    f_y, f_x = _face_forces(t, fy, fx, i, _before(i), j, _before(j), t_amb, nk, wind)
    b_y = ay[i, j] + dt * f_y
    b_x = ax[i, j] + dt * f_x
    if closed and i == U0:
        b_y = 0.0
    if j == U0:
        b_x = 0.0
    return b_y, b_x


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _chunk(c, parts, h):
    """Rows [lo, hi) of chunk ``c`` of ``parts``, for the kernels that run bottom-up."""
    return c * h // parts, (c + 1) * h // parts


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def forces_and_divergence(
    ay, ax, t, fy, fx, dt, kappa_b, t_amb, wind, closed, pos, parts, by, bx, div
):  # fmt: skip
    """Add ``dt`` times the forces to the advected faces, zero the walls, and divide.

    ``ay``, ``ax``: the advected velocity's padded planes; ``fy``, ``fx``: the centred
    push (zeros for none). The result goes to the planes ``by``, ``bx`` and its
    divergence to ``div[i, pos[j]]`` (see :func:`divergence`).

    One parallel loop over ``parts`` chunks of rows (one per thread; every parallel
    loop is a rendezvous of the threads), each run bottom-up so that a row's
    divergence finds the row below done; the first row below a chunk is recomputed
    (the same arithmetic, so the same bits whatever the chunks).
    """
    h, w = t.shape
    nk = -kappa_b
    for c in prange(parts):
        lo, hi = _chunk(c, parts, h)
        below = np.empty(w)
        for r in range(hi - 1, lo - 1, -1):
            i = np.uint64(r)
            for jj in range(w):
                j = np.uint64(jj)
                by[i, j], bx[i, j] = _forced(ay, ax, t, fy, fx, i, j, dt, t_amb, nk, wind, closed)
            # The dy faces of the row below, in a buffer of its own (so the loop below
            # reads one array whatever their origin, and vectorises).
            if r + 1 == hi and hi < h:
                for jj in range(w):
                    below[jj] = _forced(
                        ay, ax, t, fy, fx, i + U1, np.uint64(jj), dt, t_amb, nk, wind, closed
                    )[0]
            elif r + 1 < hi:
                for jj in range(w):
                    below[np.uint64(jj)] = by[i + U1, np.uint64(jj)]
            for jj in range(w):
                j = np.uint64(jj)
                jr = j + U1 if j + U1 < np.uint64(w) else j
                div[i, pos[j]] = _outflow(by[i, j], bx[i, j], below[j], bx[i, jr], i, j, h, w)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _pressure_row(p, pos, p0, i, out):
    """Row ``i`` of the pressure in its natural order, ``p0`` taken off.

    ``out[j] = p[i, pos[j]] - p0`` (see :func:`divergence` for ``pos``), so the
    gradient reads each value in order, once.
    """
    for jj in range(out.shape[0]):
        j = np.uint64(jj)
        out[j] = p[i, pos[j]] - p0


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _projected(vy, vx, here, above, open_top, i, j):
    """The faces of cell (i, j) minus the pressure gradient.

    ``here`` and ``above``: the pressure of rows i and i - 1 (:func:`_pressure_row`).
    Above an open top the pressure is 0, and a wall face (the left column's dx, a
    closed top's dy) is left as it is (zero).
    """
    a = vy[i, j]
    if i > U0:
        a -= here[j] - above[j]
    elif open_top:
        a -= here[j]
    b = vx[i, j]
    if j > U0:
        b -= here[j] - here[j - U1]
    return a, b


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def subtract_gradient(vy, vx, p, pos, open_top, p0, out):
    """``out = v - grad (p - p0)``: the velocity's planes in, an (H, W, 2) array out."""
    h, w = p.shape
    for r in prange(h):
        i = np.uint64(r)
        here, above = np.empty(w), np.empty(w)
        _pressure_row(p, pos, p0, i, here)
        if i > U0:
            _pressure_row(p, pos, p0, i - U1, above)
        for jj in range(w):
            j = np.uint64(jj)
            out[i, j, 0], out[i, j, 1] = _projected(vy, vx, here, above, open_top, i, j)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def gradient_and_scalars(
    by, bx, p, pos, open_top, p0, t, d, dt, parts, vy, vx, v, t_out, d_out
):  # fmt: skip
    """Subtract the pressure gradient, then advect temperature and density; ``max(t_out)``.

    ``by``, ``bx``: the velocity before the projection; the divergence-free faces go to
    the planes ``vy``, ``vx`` (see :func:`_projected`) and, row by row in a loop of its
    own, to the state's (H, W, 2) array ``v``. Temperature and density are
    both read at the same position backtraced from the centre along that velocity
    (bilinear, clamped). Chunks of rows bottom-up, as :func:`forces_and_divergence`:
    a row's centres find the row below done. The maximum, which the cooling law needs
    next, is taken per row, in a loop of its own (a running maximum would keep the
    loop of gathers from vectorising).
    """
    h, w = t.shape
    uw = np.uint64(w)
    tf, df = t.ravel(), d.ravel()
    s = -dt
    row_max = np.empty(h)  # per row, so the threads share nothing (max is exact anyway)
    for c in prange(parts):
        lo, hi = _chunk(c, parts, h)
        below = np.zeros(w)  # the bottom wall's faces, or the first row below the chunk
        here, above, beyond = np.empty(w), np.empty(w), np.empty(w)
        for r in range(hi - 1, lo - 1, -1):
            i = np.uint64(r)
            fi = float(i)
            _pressure_row(p, pos, p0, i, here)
            if r > 0:
                _pressure_row(p, pos, p0, i - U1, above)
            for jj in range(w):
                j = np.uint64(jj)
                vy[i, j], vx[i, j] = _projected(by, bx, here, above, open_top, i, j)
            for jj in range(w):
                j = np.uint64(jj)
                v[i, j, 0] = vy[i, j]
                v[i, j, 1] = vx[i, j]
            # The dy faces of the row below, in a buffer of its own (see
            # forces_and_divergence).
            if r + 1 == hi and hi < h:
                _pressure_row(p, pos, p0, i + U1, beyond)
                for jj in range(w):
                    j = np.uint64(jj)
                    below[j] = _projected(by, bx, beyond, here, open_top, i + U1, j)[0]
            elif r + 1 < hi:
                for jj in range(w):
                    below[np.uint64(jj)] = vy[i + U1, np.uint64(jj)]
            last = r + 1 == h
            for jj in range(w):
                j = np.uint64(jj)
                jr = j + U1 if j + U1 < uw else j
                # The centred velocity, as fluidnb.fluid._kernels.centres.
                cy = vy[i, j] * 0.5 if last else (vy[i, j] + below[j]) * 0.5
                cx = (vx[i, j] + vx[i, jr]) * 0.5 if jr > j else vx[i, j] * 0.5
                y0, ty = _split(cy * s + fi, h - 1.0)
                x0, tx = _split(cx * s + float(j), w - 1.0)
                oy = uw if y0 < np.uint64(h - 1) else U0
                ox = U1 if x0 < uw - U1 else U0
                k0 = y0 * uw + x0
                t_out[i, j] = _bilinear(tf, k0, ox, oy, tx, ty)
                d_out[i, j] = _bilinear(df, k0, ox, oy, tx, ty)
            row_max[i] = _row_max(t_out, i)
    return row_max.max()


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _row_max(a, i):
    """``max(a[i])``, in four interleaved runs (a single running maximum is a chain)."""
    w = a.shape[1]
    m0 = m1 = m2 = m3 = -np.inf
    j = 0
    while j + 4 <= w:
        m0 = max(m0, a[i, np.uint64(j)])
        m1 = max(m1, a[i, np.uint64(j + 1)])
        m2 = max(m2, a[i, np.uint64(j + 2)])
        m3 = max(m3, a[i, np.uint64(j + 3)])
        j += 4
    while j < w:
        m0 = max(m0, a[i, np.uint64(j)])
        j += 1
    return max(max(m0, m1), max(m2, m3))
