"""Pictures of flows: a dye carried through them, and vorticity maps."""

from __future__ import annotations

import numpy as np

from .._clip import Clip
from .._validation import check_array, check_range
from ..fields import advect, upsample

__all__ = ["dye_clip", "injection", "render", "side_by_side", "vorticity", "vorticity_clip"]


def vorticity(velocity):
    r"""Vorticity :math:`\omega = \partial_x v_y - \partial_y v_x` of cell-centred flows.

    Parameters
    ----------
    velocity : ndarray, shape (..., H, W, 2)
        (dy, dx) per cell (one frame or a sequence).

    Returns
    -------
    ndarray, shape (..., H, W)
        In 1 / frame; positive is clockwise on screen (y points down).

    Examples
    --------
    >>> y, x = np.mgrid[0:5, 0:5].astype(float)
    >>> v = np.stack([x - 2, -(y - 2)], -1)  # dy = x, dx = -y: a rigid rotation
    >>> float(vorticity(v)[2, 2])
    2.0
    """
    v = check_array("velocity", velocity, dtype_kinds="iuf")
    if v.ndim < 3 or v.shape[-1] != 2:
        raise ValueError(f"velocity must have shape (..., H, W, 2), got {v.shape}")
    v = v.astype(np.float64)
    return np.gradient(v[..., 0], axis=-1) - np.gradient(v[..., 1], axis=-2)


def injection(flow, factor=1):
    """Where and how much smoke a flow's scene adds each frame, from its density.

    The part of each frame's density that advection of the previous frame does not
    explain, ``max(rho(i+1) - advect(rho(i), u(i)), 0)``: the scene's smoke source.
    Frame 0 gets the whole first density. Upsampled by ``factor`` (bilinear).

    Returns
    -------
    ndarray, shape (I, factor H, factor W), float32
    """
    rho, u = flow.density, flow.velocity
    out = np.empty_like(rho)
    out[0] = rho[0]
    for i in range(1, len(rho)):
        out[i] = np.maximum(rho[i] - advect(rho[i - 1], u[i - 1]), 0.0)
    if factor == 1:
        return out
    return np.moveaxis(upsample(np.moveaxis(out, 0, -1), factor), -1, 0)


def dye_clip(velocity, inject, *, fps=24.0, vmax=None, metadata=None):
    """Carry a dye through a flow: ``dye(i) = advect(dye(i-1), U(i-1)) + inject(i)``.

    Parameters
    ----------
    velocity : ndarray, shape (I, H, W, 2)
        (dy, dx) in cells per frame.
    inject : ndarray, shape (I, H, W)
        Dye added at each frame (see :func:`injection`).
    fps : float
    vmax : float, optional
        Dye shown as white; default: the 99.5th percentile.
    metadata : dict, optional

    Returns
    -------
    Clip
        Grey frames in [0, 1].
    """
    v = check_array("velocity", velocity, ndim=4, dtype_kinds="iuf")
    q = check_array("inject", inject, ndim=3, dtype_kinds="iuf")
    if q.shape != v.shape[:3]:
        raise ValueError(f"inject must have shape {v.shape[:3]} like the velocity, got {q.shape}")
    return _grey(_carry(v, q), vmax, fps, metadata)


def _carry(v, q):
    dye = np.empty(q.shape, np.float32)
    dye[0] = q[0]
    for i in range(1, len(q)):
        dye[i] = advect(dye[i - 1], v[i - 1]) + q[i]
    return dye


def _grey(dye, vmax, fps, metadata=None):
    top = float(np.percentile(dye, 99.5)) if vmax is None else vmax
    top = check_range("vmax", top if top > 0 else 1.0, 0, lo_open=True)
    return Clip(np.clip(dye / top, 0, 1), fps=fps, metadata=metadata or {})


def vorticity_clip(velocity, *, fps=24.0, vmax=None, metadata=None):
    """Vorticity maps as a colour clip: red clockwise, blue anticlockwise, white 0."""
    import matplotlib

    w = vorticity(velocity)
    top = float(np.percentile(np.abs(w), 99)) if vmax is None else vmax
    top = check_range("vmax", top if top > 0 else 1.0, 0, lo_open=True)
    cmap = matplotlib.colormaps["RdBu_r"]
    rgb = cmap(np.clip(0.5 + 0.5 * w / top, 0, 1))[..., :3].astype(np.float32)
    return Clip(rgb, fps=fps, metadata=metadata or {})


def render(synthesis, *, fps=24.0):
    """Dye renders of a :class:`Synthesis`: target (upsampled), source, synthesised.

    The same dye, injected where the target's scene adds smoke (:func:`injection`),
    is carried by the upsampled target flow and by the synthesised one; the source
    carries its own smoke, injected likewise. All three share one brightness scale.

    Returns
    -------
    dict
        ``"target"``, ``"source"``, ``"synthesised"`` -> Clip, each with the run's
        metadata (``method``, ``params``, ``seed``, ``timings``) and ``flow``, its key.
    """
    from ._flows import Flow

    prep = synthesis.prepared
    inj = injection(Flow(prep.u_t, prep.rho_t, 1.0), prep.factor)
    dyes = {
        "target": _carry(prep.U_t, inj),
        "source": _carry(prep.U_s, injection(Flow(prep.U_s, prep.rho_s, 1.0))),
        "synthesised": _carry(synthesis.velocity, inj),
    }
    top = max(float(np.percentile(d, 99.5)) for d in dyes.values())
    meta = {
        "method": "turbulence",
        "params": synthesis.params.to_dict(),
        "seed": None,  # the synthesis draws no random numbers
        "timings": dict(synthesis.timings),
    }
    return {k: _grey(d, top if top > 0 else 1.0, fps, {**meta, "flow": k}) for k, d in dyes.items()}


def side_by_side(clips, metadata=None):
    """Clips of one size placed left to right, a thin grey line between them, as one clip.

    Parameters
    ----------
    clips : list of Clip
        Same frame count and frame shape (grey or colour, not mixed).
    metadata : dict, optional
        Default: the first clip's.

    Examples
    --------
    >>> a = Clip(np.zeros((2, 4, 64), np.float32))
    >>> side_by_side([a, a, a]).frames.shape
    (2, 4, 196)
    """
    frames = [c.frames for c in clips]
    if len({f.shape for f in frames}) != 1:
        raise ValueError(f"clips must all have one shape, got {[f.shape for f in frames]}")
    gap = max(1, frames[0].shape[2] // 32)
    sep = np.full((*frames[0].shape[:2], gap, *frames[0].shape[3:]), 0.5, np.float32)
    parts = [frames[0]]
    for f in frames[1:]:
        parts += [sep, f]
    meta = clips[0].metadata if metadata is None else metadata
    return Clip(np.concatenate(parts, axis=2), fps=clips[0].fps, metadata=meta)
