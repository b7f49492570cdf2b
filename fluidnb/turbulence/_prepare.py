"""Preparation (Watanabe et al., sec. 2.1) and the global search on the coarse grid (Eq. 1)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..fields import downsample, upsample
from ._flows import Flow
from ._params import TurbulenceParams

__all__ = ["Prepared", "check_settings", "global_search", "prepare"]


@dataclass(frozen=True, eq=False)
class Prepared:
    r"""The fields and patch layout both searches work on (Watanabe et al., sec. 2.1, Fig. 1).

    Lower case: the target's low-resolution grid (:math:`n_x \times n_y`, spacing
    :math:`\Delta x`); upper case: the source's high-resolution grid
    (:math:`N_x \times N_y`, :math:`\Delta X`). Velocities are (dy, dx) in cells of
    their own grid per frame, so an upsampled velocity is multiplied by ``factor``.

    Attributes
    ----------
    params : TurbulenceParams
    factor : int
        :math:`r = \Delta x / \Delta X`, the resolution ratio.
    window : int
        :math:`n = b\,r`, the local search's positions per axis (clipped to what
        the source holds).
    u_t, d_t : ndarray, (I, h, w, 2) and (I, h, w)
        Target velocity and mask :math:`d_t` (0/1).
    u_s, d_s : ndarray
        The source downsampled to the target grid (block means): :math:`u_s`,
        :math:`d_s`.
    U_t, D_t, U_sl : ndarray, (I, H, W, 2) / (I, H, W)
        :math:`u_t`, :math:`d_t`, :math:`u_s` bilinearly upsampled.
    U_s, D_s : ndarray
        The source velocity and mask.
    U_sh : ndarray, (I, H, W, 2)
        The source's high frequencies :math:`U_s - U_{sl}`.
    rho_t, rho_s : ndarray, (I, h, w) and (I, H, W)
        The target's and source's smoke densities (for pictures).
    centres : ndarray, (P, 2)
        Centre of each local patch :math:`X(p)` in source cells (edges at integers).
    dx_source : float
        :math:`\Delta X`, the source's grid spacing.
    target_corners : ndarray of int, (P, 2)
        Top-left cell of each global patch :math:`x(p)` on the target grid (may lie
        outside it: the target is edge-padded).
    """

    params: TurbulenceParams
    factor: int
    window: int
    u_t: np.ndarray
    d_t: np.ndarray
    u_s: np.ndarray
    d_s: np.ndarray
    U_t: np.ndarray
    D_t: np.ndarray
    U_sl: np.ndarray
    U_s: np.ndarray
    D_s: np.ndarray
    U_sh: np.ndarray
    rho_t: np.ndarray
    rho_s: np.ndarray
    centres: np.ndarray
    target_corners: np.ndarray
    dx_source: float = 1.0

    @property
    def n_frames(self):
        """Frames ``I``."""
        return self.u_t.shape[0]

    @property
    def tiles(self):
        """(rows, cols) of local patches tiling the high-resolution grid."""
        B = self.params.B
        return self.U_t.shape[1] // B, self.U_t.shape[2] // B

    @property
    def n_patches(self):
        """Number of local patches ``P``."""
        ty, tx = self.tiles
        return ty * tx

    def smoke_patches(self, i):
        """Which local patches hold target smoke at frame ``i`` (Fig. 3-4; bool (P,))."""
        ty, tx = self.tiles
        B = self.params.B
        tiles = self.D_t[i].reshape(ty, B, tx, B)
        return (tiles >= 0.5).any(axis=(1, 3)).reshape(-1)

    def window_starts(self, q_l):
        """Top-left source cell of each local window, centred on the global matches.

        ``q_l`` holds each global match's top-left target-grid cell on the source's
        low-resolution grid; the window's ``n x n`` patch positions are centred on
        the match's centre and shifted, if need be, to stay inside the source.
        """
        B, b, n, r = self.params.B, self.params.b, self.window, self.factor
        H, W = self.U_s.shape[1:3]
        centre = r * (np.asarray(q_l, float) + b / 2)
        start = np.floor(centre - B / 2 - n / 2 + 0.5).astype(np.int64)
        hi = np.array([H - B - n + 1, W - B - n + 1])
        return np.clip(start, 0, np.maximum(hi, 0))


def prepare(target, source, params=None):
    """Check a target/source pair and compute every field the searches need.

    Parameters
    ----------
    target : Flow
        The low-resolution flow the user designed (:math:`u_t`, density for
        :math:`d_t`).
    source : Flow
        The high-resolution flow with the wanted detail (:math:`U_s`, :math:`D_s`);
        same number of frames, same domain: ``target.dx / source.dx`` must be an
        integer ``r`` and ``source.shape == r * target.shape``.
    params : TurbulenceParams, optional

    Returns
    -------
    Prepared

    Raises
    ------
    ValueError
        For mismatched frame counts, spacings or shapes; a ``B`` that does not tile
        the source; ``b <= B dX / dx``; a global patch larger than the target; a
        mask empty in every frame (with the density range, to pick ``D_th``).
    """
    params = TurbulenceParams() if params is None else params
    if not isinstance(params, TurbulenceParams):
        raise ValueError(f"params must be a TurbulenceParams, got {type(params).__name__}")
    for name, flow in (("target", target), ("source", source)):
        if not isinstance(flow, Flow):
            raise ValueError(f"{name} must be a fluidnb.turbulence.Flow, got {type(flow).__name__}")
    if target.n_frames != source.n_frames:
        raise ValueError(
            f"target and source must have the same number of frames, "
            f"got {target.n_frames} and {source.n_frames}"
        )
    r = check_settings(params, target.shape, source.shape, ratio=target.dx / source.dx)
    H, W = source.shape
    B, b = params.B, params.b
    d_t, D_s = target.mask(params.D_th), source.mask(params.D_th)
    for name, flow, m in (("target", target, d_t), ("source", source, D_s)):
        if not m.any():
            raise ValueError(
                f"the {name} mask (density > D_th = {params.D_th:g}) is empty in every "
                f"frame; its density peaks at {float(flow.density.max()):g}: lower D_th"
            )
    u_t = target.velocity
    U_s = source.velocity
    u_s = _coarsen(U_s, r, vector=True)
    d_s = _coarsen(D_s, r)
    U_t = _lift(u_t, r)
    D_t = _bilinear(d_t.astype(np.float32), r)
    U_sl = _lift(u_s, r)
    U_sh = U_s - U_sl
    ty, tx = H // B, W // B
    cy, cx = np.meshgrid(B * np.arange(ty) + B / 2, B * np.arange(tx) + B / 2, indexing="ij")
    centres = np.stack([cy.ravel(), cx.ravel()], -1)
    corners = np.floor(centres / r - b / 2 + 0.5).astype(np.int64)
    n = min(b * r, H - B + 1, W - B + 1)
    arrays = {
        "u_t": u_t, "d_t": d_t.astype(np.float32), "u_s": u_s, "d_s": d_s,
        "U_t": U_t, "D_t": D_t, "U_sl": U_sl, "U_s": U_s,
        "D_s": D_s.astype(np.float32), "U_sh": U_sh,
        "rho_t": target.density, "rho_s": source.density,
    }  # fmt: skip
    for a in arrays.values():
        if a.flags.writeable:
            a.flags.writeable = False
    return Prepared(
        params, r, n, **arrays, centres=centres, target_corners=corners, dx_source=source.dx
    )


def check_settings(params, target_shape, source_shape, *, ratio=None):
    r"""Check settings against the grids they will run on, before any flow exists.

    The rules :func:`prepare` enforces that depend only on the grids (not on the
    flows' values): the source grid is a whole multiple ``r`` of the target's,
    ``B`` tiles the source grid, the global patch is larger than a local one
    (:math:`b > B\,\Delta X / \Delta x`, Watanabe et al., sec. 2.1) and fits the
    target grid. An app can call it on every slider move; :func:`prepare` calls it
    too, so both say the same.

    Parameters
    ----------
    params : TurbulenceParams
    target_shape, source_shape : tuple of int
        (H, W) of the target (coarse) and source (fine) grids.
    ratio : float, optional
        :math:`\Delta x / \Delta X`, the flows' grid-spacing ratio; must then be a
        whole number ``r`` with ``source_shape == r * target_shape``. Default: the
        ratio of the shapes.

    Returns
    -------
    int
        ``r``, the resolution ratio.

    Raises
    ------
    ValueError
        Naming the setting or grid at fault and what is allowed.

    Examples
    --------
    >>> check_settings(TurbulenceParams(), (24, 16), (192, 128))
    8
    >>> check_settings(TurbulenceParams(b=2), (24, 16), (192, 128))
    Traceback (most recent call last):
    ...
    ValueError: b must be > B dX/dx = 16/8 = 2 (Watanabe et al., sec. 2.1), got b = 2
    """
    if not isinstance(params, TurbulenceParams):
        raise ValueError(f"params must be a TurbulenceParams, got {type(params).__name__}")
    shapes = {}
    for name, given in (("target_shape", target_shape), ("source_shape", source_shape)):
        try:
            shape = tuple(int(k) for k in given)
        except (TypeError, ValueError):
            shape = ()
        if len(shape) != 2 or min(shape) < 1:
            raise ValueError(f"{name} must be (H, W) with H, W >= 1, got {given!r}")
        shapes[name] = shape
    (h, w), (H, W) = shapes["target_shape"], shapes["source_shape"]
    if ratio is None:
        ratio = H / h
        if H % h or W % w or H // h != W // w:
            raise ValueError(
                f"source_shape must be a whole multiple r of target_shape {(h, w)} "
                f"(the same r along both axes), got {(H, W)}"
            )
    r = round(ratio)
    if r < 1 or not math.isclose(ratio, r, rel_tol=1e-6):
        raise ValueError(f"target.dx / source.dx must be a whole number >= 1, got {ratio:g}")
    if (r * h, r * w) != (H, W):
        raise ValueError(
            f"source shape must be {r} x the target's {(h, w)} = {(r * h, r * w)} "
            f"(dx ratio {r}), got {(H, W)}"
        )
    B, b = params.B, params.b
    if H % B or W % B:
        raise ValueError(f"B must divide the source grid {(H, W)}, got B = {B}")
    if b * r <= B:
        raise ValueError(
            f"b must be > B dX/dx = {B}/{r} = {B / r:g} (Watanabe et al., sec. 2.1), got b = {b}"
        )
    if b > min(h, w):
        raise ValueError(f"b must be <= the target grid's shorter side {min(h, w)}, got {b}")
    return r


def _coarsen(seq, factor, vector=False):
    """Block-mean :func:`fluidnb.fields.downsample` of a whole (I, H, W[, 2]) sequence."""
    seq = np.asarray(seq, dtype=np.float32)
    i = seq.shape[0]
    # Frames (and components) become channels: one call for all.
    stacked = np.moveaxis(seq.reshape(i, *seq.shape[1:3], -1), 0, 2)  # (H, W, I, k)
    h, w = stacked.shape[:2]
    out = downsample(stacked.reshape(h, w, -1), factor)
    if vector:
        out = out / factor  # velocities in cells of the coarser grid
    out = np.moveaxis(out.reshape(*out.shape[:2], i, -1), 2, 0)
    return np.ascontiguousarray(out.reshape(i, *out.shape[1:3], *seq.shape[3:]), np.float32)


def _lift(u, r):
    """Bilinear upsampling whose block means give ``u`` back exactly.

    Plain bilinear interpolation followed by the block-mean downsampling is a
    slight blur, so ``U_s - bilinear(u_s)`` would still hold some of the coarse
    grid's content. Interpolating corrected samples ``v`` with
    ``downsample(bilinear(v)) = u`` instead makes the source's high frequencies
    :math:`U_{sh}` average to zero over every coarse cell (they add nothing the
    low-resolution grid can see) and makes :math:`U_t` average back to the
    user's :math:`u_t`. Both operators are separable, so ``v`` comes from two
    small matrices, :math:`v = M_y^{-1} u M_x^{-T}`, and the whole lift is one
    matrix per axis applied to every frame at once.

    The price: undoing the blur boosts the coarse grid's finest scales (the
    matrices' condition number is about 2), so where ``u`` changes from cell to
    cell the result differs from plain bilinear interpolation by up to a few tens
    of percent (about 10 % RMS on the sample flows at the paper's sizes) and its
    vorticity shows faint cell-sized stripes.
    """
    h, w = u.shape[1:3]
    ay = _upsampling(h, r) @ np.linalg.inv(_round_trip(h, r))
    ax = _upsampling(w, r) @ np.linalg.inv(_round_trip(w, r))
    return _separable(ay, u, ax) * r  # velocities scale with the grid


def _bilinear(d, r):
    """Plain bilinear upsampling of a (I, h, w) sequence (the masks)."""
    h, w = d.shape[1:3]
    return _separable(_upsampling(h, r), d[..., None], _upsampling(w, r))[..., 0]


def _separable(ay, u, ax):
    """``ay @ u[f, :, :, c] @ ax.T`` for every frame and channel, float32."""
    out = np.tensordot(ay, u.astype(np.float64), axes=(1, 1))  # (A, f, j, c), by BLAS
    out = np.tensordot(out, ax, axes=(2, 1))  # (A, f, c, B)
    return np.ascontiguousarray(out.transpose(1, 0, 3, 2), dtype=np.float32)


def _upsampling(n, r):
    """The matrix of :func:`fluidnb.fields.upsample` (bilinear) along one axis."""
    # The n unit vectors as channels of an (n, 1) image: the other axis is trivial.
    eye = np.eye(n, dtype=np.float32)[:, None, :]
    return upsample(eye, r)[:, 0, :].astype(np.float64)


def _round_trip(n, r):
    """The matrix of ``downsample(upsample(., r), r)`` along one axis of length n."""
    eye = np.eye(n, dtype=np.float32)[:, None, :]
    return downsample(upsample(eye, r), r)[:, 0, :].astype(np.float64)


def global_search(prep, i):
    r"""The global search of Eq. (1) at frame ``i``, over every source position.

    For each local patch ``p``, the ``b x b`` global patch :math:`x(p)` of the
    (edge-padded) target, centred on ``p``, is compared with every ``b x b`` patch
    :math:`z(q_l)` of the downsampled source:
    :math:`E_l = \|x_u - z_u\|^2 + \alpha \|x_d - z_d\|^2`.

    Returns
    -------
    q_l : ndarray of int, (P, 2)
        Top-left target-grid cell of the best source patch.
    E_l : ndarray, (P,)
        Its energy.
    """
    b, alpha = prep.params.b, prep.params.alpha
    tgt = _features(prep.u_t[i], prep.d_t[i], alpha)
    src = _features(prep.u_s[i], prep.d_s[i], alpha)
    pad = np.pad(tgt, ((b, b), (b, b), (0, 0)), mode="edge")
    rows = prep.target_corners[:, :1] + b + np.arange(b)
    cols = prep.target_corners[:, 1:] + b + np.arange(b)
    x = pad[rows[:, :, None], cols[:, None, :]].reshape(len(rows), -1)  # (P, b*b*3)
    z = np.lib.stride_tricks.sliding_window_view(src, (b, b), axis=(0, 1))
    qh, qw = z.shape[:2]
    z = np.ascontiguousarray(np.moveaxis(z, 2, -1)).reshape(qh * qw, -1)  # (Q, b*b*3)
    best, energy = _nearest(np.ascontiguousarray(x), z)
    return np.stack([best // qw, best % qw], -1), energy


@njit(cache=True, fastmath=True)
def _nearest(x, z):
    # For each row of x, the first row of z at the least squared distance (direct
    # differences, not the expanded form: exact), and that distance. A compiled
    # loop: the (P, Q, F) array of differences numpy would build took 7 ms a frame.
    P, Q, F = x.shape[0], z.shape[0], x.shape[1]
    best = np.zeros(P, np.int64)
    energy = np.empty(P)
    for p in range(P):
        xp = x[p]
        e_min = np.inf
        for q in range(Q):
            zq = z[q]
            e = 0.0
            for f in range(F):
                d = xp[f] - zq[f]
                e += d * d
            if e < e_min:
                e_min, best[p] = e, q
        energy[p] = e_min
    return best, energy


def _features(u, d, alpha):
    """Velocity and sqrt(alpha)-weighted mask as channels of one float64 image."""
    return np.concatenate([u, np.sqrt(alpha) * d[..., None]], axis=-1).astype(np.float64)
