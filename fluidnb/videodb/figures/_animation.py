r"""The second video-database lesson's figures (``07b_videodb_animation.ipynb``; secs. 5-6).

- :func:`assignment_figure`, :func:`sweep_figure`: which source clip animates each
  target fragment and its mean motion, for one or several assignments (Eq. 4-6);
- :func:`rendering_figure`: the rendering's stages (Okabe et al., sec. 6).

Drawn by the same rule as the app's assignment map
(:mod:`fluidnb.videodb.figures._pictures`); matplotlib's object API only, imported
when the first figure is drawn.
"""

from __future__ import annotations

import numpy as np

from ..._validation import check_array, check_int
from ...sketch import arrow_heads
from .._common._geometry import FRAGMENT, STRIDE
from ..assignment._retrieval import MIN_MOTION
from ..rendering._render import Animation
from ._common import _check_assignment, _clip_name, _figure, _off
from ._pictures import clip_colour, clip_map_picture, motion_arrows

__all__ = ["assignment_figure", "rendering_figure", "sweep_figure"]


def _draw_strokes(ax, strokes, side):
    for s in strokes:
        pts = check_array("strokes", s, ndim=2).astype(np.float64)
        ax.plot(pts[:, 1], pts[:, 0], "-", color="w", lw=4, solid_capstyle="round")
        ax.plot(pts[:, 1], pts[:, 0], "-", color="crimson", lw=2, solid_capstyle="round")
        for seg in arrow_heads(pts, size=max(6.0, 0.03 * side)):
            ax.plot(seg[:, 1], seg[:, 0], "-", color="crimson", lw=2.5)


def _draw_assignment(
    ax,
    a,
    *,
    background,
    arrows,
    strokes,
    field,
    speed,
    legend,
    gain,
    legend_loc,
    thin=False,
    zoom=False,
):
    from matplotlib.patches import Patch

    target = a.target
    h, w = target.shape
    names = []
    if background == "mosaic":
        ax.imshow(a.mean_image_mosaic(), interpolation="nearest")
    elif background == "clips":
        clips = a.clip_map()
        ax.imshow(clip_map_picture(target.image, clips), interpolation="nearest")
        names = [(int(k), clip_colour(k)) for k in np.unique(clips[clips >= 0])]
    else:
        ax.imshow(target.image)
    if speed is not None:
        s = np.asarray(speed, np.float64)
        ax.imshow(np.ma.masked_less_equal(s, 0), cmap="viridis", alpha=0.6, vmin=0)
    if field and a.field is not None:
        step = max(12, max(h, w) // 24)
        rr, cc = np.mgrid[step // 2 : h : step, step // 2 : w : step]
        keep = target.matte[rr, cc] > 0.5  # the field where it is used: the fluid
        f = a.field[rr, cc][keep]
        ax.quiver(
            cc[keep],
            rr[keep],
            f[:, 1],
            f[:, 0],
            angles="xy",
            scale_units="xy",
            scale=1 / (0.6 * step),
            color="cyan",
            width=0.0035,
            pivot="middle",
        )
    if strokes is not None:
        _draw_strokes(ax, strokes, max(h, w))
    if arrows:
        segments, gain = motion_arrows(a, gain=gain, thin=thin)
        c = segments.mean(axis=1)  # the arrows' middles: the fragments' centres
        v = segments[:, 1] - segments[:, 0]
        ax.quiver(
            c[:, 1],
            c[:, 0],
            v[:, 1],
            v[:, 0],
            angles="xy",
            scale_units="xy",
            scale=1,
            color="w",
            edgecolor="k",
            linewidth=0.6,
            width=0.004 if not thin else 0.008,
            pivot="middle",
            headwidth=4,
        )
    if legend and names:
        handles = [Patch(color=col, label=_clip_name(a.db, k)) for k, col in names]
        ax.legend(handles=handles, fontsize=7, loc=legend_loc, framealpha=0.8)
    (r0, r1), (c0, c1) = _view(a) if zoom else ((0, h), (0, w))
    ax.set_xlim(c0 - 0.5, c1 - 0.5)
    ax.set_ylim(r1 - 0.5, r0 - 0.5)
    _off(ax)
    return gain


def _view(a):
    """Rows and columns (start, stop) of the image the taking-part fragments cover."""
    h, w = a.target.shape
    pos = a.target.positions
    r0, c0 = (int(v) for v in pos.min(axis=0))
    r1, c1 = (int(v) + FRAGMENT for v in pos.max(axis=0))
    return (r0, min(r1, h)), (c0, min(c1, w))


def assignment_figure(
    assignment,
    *,
    background="clips",
    arrows=True,
    strokes=None,
    field=False,
    speed=None,
    legend=True,
    title=None,
    ax=None,
    gain=None,
    zoom=False,
    figsize=(7.5, 6),
):
    r"""Which database fragment animates each part of the target (Okabe et al., sec. 5).

    Parameters
    ----------
    assignment : Assignment
        The result of :func:`assign` (or :meth:`Assignment.resolve`).
    background : {"clips", "mosaic", "photo"}
        ``"clips"``: the photo, each fragment's cell coloured by the source clip its
        fragment came from (:meth:`Assignment.clip_map`), with a legend;
        ``"mosaic"``: the assigned fragments' mean images
        (:meth:`Assignment.mean_image_mosaic`);
        ``"photo"``: the photo alone.
    arrows : bool
        Draw each assigned fragment's mean motion (dy, dx) at its fragment's centre
        (:func:`motion_arrows`).
    strokes : sequence of array_like (n, 2), optional
        Flow strokes (row, col) to draw, with arrow heads.
    field : bool
        Draw the assignment's direction field (from the user's strokes), if any, as a
        faint quiver.
    speed : ndarray, shape (H, W), optional
        A speed map (px/frame, 0 = none) drawn translucent.
    legend : bool
        The clips' legend (``background="clips"``).
    title : str, optional
        The axes' title (default: the parameters and the energy).
    ax : matplotlib.axes.Axes, optional
        Draw into this axes (of an existing figure) instead of a new figure.
    gain : float, optional
        Arrow length in pixels per px/frame (default: the 90th percentile speed
        spans most of a stride); give one value to compare several figures.
    zoom : bool
        Show only the part of the image the taking-part fragments cover.
    figsize : (float, float)
        Size of a new figure in inches.

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on (``ax``'s own when given).
    """
    a = _check_assignment(assignment)
    if background not in ("clips", "mosaic", "photo"):
        raise ValueError(f"background must be 'clips', 'mosaic' or 'photo', got {background!r}")
    if ax is None:
        fig = _figure(figsize)
        ax = fig.subplots()
    else:
        fig = ax.figure
    _draw_assignment(
        ax,
        a,
        background=background,
        arrows=arrows,
        strokes=strokes,
        field=field,
        speed=speed,
        legend=legend,
        gain=gain,
        legend_loc="lower right",
        zoom=zoom,
    )
    if title is None:
        p = a.params
        title = (
            f"σ = {p.sigma:g}, λ = {p.lam:g}, ρ = {p.rho:g}: E = {a.solution.energy:.4g}, "
            f"coherence {a.motion_coherence():.2f}"
        )
    ax.set_title(title, fontsize=9)
    return fig


def sweep_figure(assignments, *, reference=None, background="clips", zoom=True, figsize=None):
    r"""Several assignments side by side, with what changed (Okabe et al., sec. 7, parameters).

    Parameters
    ----------
    assignments : dict of str to Assignment
        Label (e.g. ``"σ = 1000"``) to assignment, drawn left to right. Usually the
        same :class:`Assignment` re-solved for other :math:`\sigma`, :math:`\lambda`,
        :math:`\rho` (:meth:`Assignment.resolve`).
    reference : Assignment, optional
        What "changed" is measured against (default the first).
    background : {"clips", "mosaic", "photo"}
        As :func:`assignment_figure`.
    zoom : bool
        Show only the part of the image the fragments cover.
    figsize : (float, float), optional
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per assignment titled with its label, the fraction of target
        fragments whose database fragment differs from ``reference``'s, and the
        :meth:`Assignment.motion_coherence`; arrows drawn at one scale in all panels.
    """
    if not isinstance(assignments, dict) or not assignments:
        raise ValueError("assignments must be a non-empty dict of label -> Assignment")
    items = [(str(k), _check_assignment(v, f"assignments[{k!r}]")) for k, v in assignments.items()]
    ref = items[0][1] if reference is None else _check_assignment(reference, "reference")
    for label, a in items:
        same = a.target is ref.target or (
            a.target.shape == ref.target.shape
            and np.array_equal(a.target.positions, ref.target.positions)
        )
        if not same:
            raise ValueError(f"assignments[{label!r}] is of another target than the reference")
    motion = np.concatenate([a.db.mean_motion[a.fragments] for _, a in items]).astype(np.float64)
    top = float(np.percentile(np.hypot(motion[:, 0], motion[:, 1]), 90))
    gain = 1.8 * STRIDE / top if top > MIN_MOTION else 1.0
    (r0, r1), (c0, c1) = (
        _view(ref) if zoom else ((0, ref.target.shape[0]), (0, ref.target.shape[1]))
    )
    n = len(items)
    fig = _figure(figsize or (3.4 * n, 3.4 * (r1 - r0) / (c1 - c0) + 0.8))
    axes = np.atleast_1d(fig.subplots(1, n))
    for i, (ax, (label, a)) in enumerate(zip(axes, items)):
        _draw_assignment(
            ax,
            a,
            background=background,
            arrows=True,
            strokes=None,
            field=False,
            speed=None,
            legend=i == n - 1,
            gain=gain,
            legend_loc="lower right",
            thin=True,
            zoom=zoom,
        )
        changed = float(np.mean(a.fragments != ref.fragments))
        ax.set_title(
            f"{label}\nchanged {changed:.0%}, coherence {a.motion_coherence():.2f}", fontsize=9
        )
    return fig


def rendering_figure(animation, *, frame=None, figsize=(13, 7.6)):
    r"""The rendering's steps for one frame (Okabe et al., sec. 6).

    Parameters
    ----------
    animation : Animation
        The result of :func:`render` or :func:`animate` (its ``stages``).
    frame : int, optional
        The frame shown (default the middle one).
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        2 x 3 panels. The paper's rendering: the target with its matte's outline; the
        blended difference frame :math:`D_i` (Laplacian-pyramid blend of the assigned
        fragments', grey: red brighter, blue darker); the approximate mean image (the
        target blurred along the assigned motion); mean + :math:`D_i` before the
        histogram matching; the final frame (matched cell by cell, composited through
        the matte); the matte :math:`B_i` used for it (static, or dynamic for
        ``tau > 0``). The flow rendering (beyond the paper): the target with the
        motion field's arrows; the two advected phases with their ages and weights;
        :math:`D_i`; their cross-fade + :math:`D_i` before matching; the final frame.
    """
    if not isinstance(animation, Animation):
        raise ValueError(f"animation must be an Animation, got {type(animation).__name__}")
    st = animation.stages
    clip = animation.clip
    t_count = clip.n_frames
    frame = t_count // 2 if frame is None else check_int("frame", frame, 0, t_count - 1)
    target = animation.assignment.target
    matte = target.matte
    d = st["differences"][frame]
    top = max(float(np.percentile(np.abs(d), 99.5)), 1e-6)
    fig = _figure(figsize)
    ax = fig.subplots(2, 3)
    ax[0, 0].imshow(target.image)
    ax[0, 0].contour(matte, levels=[0.5], colors="yellow", linewidths=1)
    ax[0, 0].set_title("target and its matte α", fontsize=9)
    if "velocity" in st:
        _flow_panels(ax, animation, frame, d, top)
        return fig
    ax[0, 1].imshow(d, cmap="RdBu_r", vmin=-top, vmax=top)
    ax[0, 1].set_title(
        f"blended differences $D_{{{frame}}}$ (pyramid blend, ±{top:.2f})", fontsize=9
    )
    ax[0, 2].imshow(st["mean"])
    ax[0, 2].set_title("approximate mean image (motion blur)", fontsize=9)
    ax[1, 0].imshow(st["unmatched"][frame])
    ax[1, 0].set_title(f"mean + $D_{{{frame}}}$, before matching", fontsize=9)
    ax[1, 1].imshow(clip.frames[frame])
    ax[1, 1].set_title(f"frame {frame}: histograms matched, composited", fontsize=9)
    ax[1, 2].imshow(st["matte"][frame], cmap="gray", vmin=0, vmax=1)
    ax[1, 2].contour(matte, levels=[0.5], colors="yellow", linewidths=1)
    tau = animation.assignment.params.tau
    ax[1, 2].set_title(f"matte $B_{{{frame}}}$ (τ = {tau:g}; yellow: α = 0.5)", fontsize=9)
    for a in ax.ravel():
        _off(a)
    return fig


def _flow_panels(ax, animation, frame, d, top):
    """The flow rendering's panels of :func:`rendering_figure`."""
    st = animation.stages
    v = st["velocity"]
    h, w = v.shape[:2]
    step = max(8, min(h, w) // 12)
    yy, xx = np.mgrid[step // 2 : h : step, step // 2 : w : step]
    matte = animation.assignment.target.matte
    speed = np.hypot(v[..., 0], v[..., 1])
    typical = float(np.median(speed[matte > 0.5])) if (matte > 0.5).any() else 0.0
    fastest = float(speed.max())
    ax[0, 0].quiver(
        xx,
        yy,
        v[yy, xx, 1],
        v[yy, xx, 0],
        angles="xy",
        scale_units="xy",
        scale=fastest / (0.9 * step) if fastest > 0 else 1.0,
        color="cyan",
        width=0.004,
        pivot="middle",
    )
    ax[0, 0].set_title(
        f"target, matte and motion field v (median {typical:.2f} px/frame)", fontsize=9
    )
    ages, weights = st["ages"][frame], st["weights"][frame]
    photo = animation.assignment.target.image
    m = matte[..., None]
    for k, (name, key) in enumerate((("a", "phase_a"), ("b", "phase_b"))):
        # Inside the matte: the advected phase; outside, the photo dimmed (the layer
        # there is only what may flow in).
        shown = m * np.clip(st[key][frame], 0, 1) + (1 - m) * 0.4 * photo
        ax[0, 1 + k].imshow(shown)
        ax[0, 1 + k].set_title(
            f"phase {name}: photo advected {ages[k]:+.1f} frames, weight {weights[k]:.2f}",
            fontsize=9,
        )
    ax[1, 0].imshow(d, cmap="RdBu_r", vmin=-top, vmax=top)
    ax[1, 0].set_title(f"blended differences $D_{{{frame}}}$ (±{top:.2f})", fontsize=9)
    ax[1, 1].imshow(m * st["unmatched"][frame] + (1 - m) * 0.4 * photo)
    ax[1, 1].set_title(f"cross-fade + $D_{{{frame}}}$, before matching", fontsize=9)
    ax[1, 2].imshow(animation.clip.frames[frame])
    ax[1, 2].set_title(f"frame {frame}: histograms matched, composited", fontsize=9)
    for a in ax.ravel():
        _off(a)
