r"""The first video-database lesson's figures (``07a_videodb_database.ipynb``; sec. 4).

- :func:`clip_fragments_figure`: a clip, its fragment grid, and one fragment's mean
  image, difference frame, visual words, motion spectra and textureness (Okabe et al.,
  Fig. 2, 4-b, 5);
- :func:`fragment_figure`: the same panels for any fragment of a database;
- :func:`versions_figure`: the 18 augmented versions of a clip (Okabe et al., Fig. 4-a);
- :func:`retrieval_figure`: a query fragment and its best candidates by histogram
  intersection (Eq. 1);
- :func:`spectra_figure`: motion power spectra (Eq. 2, Okabe et al., Fig. 6) and
  textureness (Okabe et al., Fig. 7) of a few fragments side by side.

Library functions, so the notebook's cells stay short. Matplotlib's object API only
(no pyplot), so figures can be made in a worker thread and outside Jupyter; matplotlib
itself is imported when the first figure is drawn (half a second), so that importing
:mod:`fluidnb.videodb` and the command line stay quick.
"""

from __future__ import annotations

import numpy as np

from ..._image import LUMA
from ..._validation import check_array, check_int
from .._common._geometry import FRAGMENT, GRID, SPECTRA_BLOCK, STRIDE, TEXTURE_LEVELS, VERSIONS
from ..assignment._retrieval import MIN_MOTION, histogram_index
from ..database._augment import sample_version
from ..database._versions import IDENTITY, valid_positions, version_coordinates
from ..database._words import HISTOGRAM_TOTAL, pyramid_cells
from ._common import _check_db, _check_fragment, _clip_name, _figure, _off

__all__ = [
    "clip_fragments_figure",
    "fragment_figure",
    "retrieval_figure",
    "spectra_figure",
    "version_label",
    "versions_figure",
]

# Arrow length (pixels of a version) per px/frame in versions_figure.
_VERSION_GAIN = 30.0


def version_label(version):
    """A short label of an augmented version, e.g. ``"flip 75 % +22.5°"``.

    Examples
    --------
    >>> version_label(7), version_label(9)
    ('100 % 0°', 'flip 50 % -22.5°')
    """
    flip, scale, angle = VERSIONS[check_int("version", version, 0, len(VERSIONS) - 1)]
    turn = "0°" if angle == 0 else f"{angle:+g}°"
    return f"{'flip ' if flip else ''}{scale:.0%} {turn}".replace("%", " %")


# ------------------------------------------------------------------ fragment panels


def _grey(rgb):
    return np.asarray(rgb, np.float32) @ LUMA


def _word_map(ax, words, k):
    """The 9 x 9 word map, coloured by word, with the spatial pyramid's cell borders."""
    from matplotlib import colormaps

    cmap = colormaps["tab20"].resampled(20)
    ax.imshow(np.asarray(words) % 20, cmap=cmap, vmin=0, vmax=19, interpolation="nearest")
    size = 6 if k < 100 else 5
    for (r, c), w in np.ndenumerate(np.asarray(words)):
        ax.text(c, r, str(int(w)), ha="center", va="center", fontsize=size, color="k")
    # A border wherever two neighbouring descriptors fall in different pyramid cells.
    cells = pyramid_cells()
    for level, (width, colour) in zip((1, 2), ((2.2, "k"), (0.9, "0.3"))):
        cell = cells[level].reshape(GRID, GRID)
        for j in range(GRID - 1):
            if cell[0, j] != cell[0, j + 1]:
                ax.axvline(j + 0.5, color=colour, lw=width)
            if cell[j, 0] != cell[j + 1, 0]:
                ax.axhline(j + 0.5, color=colour, lw=width)
    _off(ax)


def _block_quiver(ax, dc, *, colour="yellow", gain=None):
    """Arrows of a (2, 12, 12) field of mean motions (dy, dx) over a 48 x 48 image."""
    side = dc.shape[-1]
    centres = (np.arange(side) + 0.5) * SPECTRA_BLOCK - 0.5
    xx, yy = np.meshgrid(centres, centres)
    dy, dx = np.asarray(dc[0], np.float64), np.asarray(dc[1], np.float64)
    step = 2  # every other block: 6 x 6 arrows stay readable on 48 pixels
    top = float(np.hypot(dy, dx).max())
    if top <= MIN_MOTION:
        return
    gain = 1.6 * step * SPECTRA_BLOCK / top if gain is None else gain
    ax.quiver(
        xx[::step, ::step],
        yy[::step, ::step],
        dx[::step, ::step] * gain,
        dy[::step, ::step] * gain,
        angles="xy",
        scale_units="xy",
        scale=1,
        color=colour,
        width=0.012,
        pivot="middle",
    )


def _spectra_power(spectra):
    """Per bin, the power summed over both components and averaged over the blocks.

    Bin 0 is stored as the signed mean motion; its power is its square (what the
    power spectrum would hold at DC).
    """
    s = np.asarray(spectra, np.float64)
    power = s.copy()
    power[0] = s[0] ** 2
    return power.sum(axis=1).mean(axis=(-2, -1))


def _spectrum_axes(ax, spectra_list, labels, colours):
    for spec, label, colour in zip(spectra_list, labels, colours):
        p = _spectra_power(spec)
        f = np.arange(len(p))
        ax.semilogy(f[1:], p[1:] + 1e-12, "o-", ms=3, color=colour, label=label)
        ax.semilogy([0], [p[0] + 1e-12], "D", ms=7, mfc="none", mec=colour, mew=1.6)
    ax.set_xlabel("frequency bin f (0 = DC)")
    ax.set_ylabel("power ((px/frame)$^2$)")
    ax.grid(alpha=0.3, which="both")


def _texture_montage(texture):
    """The 4 levels of a (4, 24, 24) textureness, 2 x 2, each to its max (gaps NaN)."""
    t = np.asarray(texture, np.float32)
    top = np.maximum(t.reshape(len(t), -1).max(axis=1), 1e-12)
    side, gap = t.shape[-1], 2
    out = np.full((2 * side + gap, 2 * side + gap), np.nan, np.float32)  # NaN: blank gaps
    for level in range(min(TEXTURE_LEVELS, len(t))):
        r, c = divmod(level, 2)
        out[
            r * (side + gap) : r * (side + gap) + side, c * (side + gap) : c * (side + gap) + side
        ] = np.clip(t[level] / top[level], 0, 1)
    return out


def _fragment_panels(axes, db, fragment, frame):
    """Mean image + motion, D_i, word map, spectra, textureness of one fragment."""
    n = db.params.N
    frame = check_int("frame", frame, 0, n - 1)
    mean = db.mean_images([fragment])[0]
    frames = db.fragment_frames([fragment])[0]
    diff = _grey(frames[frame]) - _grey(frames).mean(axis=0)

    axes[0].imshow(mean, interpolation="nearest")
    _block_quiver(axes[0], db.spectra[fragment, 0])
    my, mx = db.mean_motion[fragment]
    axes[0].set_title(
        f"mean image A + DC motion\n(dy, dx) = ({my:.2f}, {mx:.2f}) px/frame", fontsize=9
    )
    _off(axes[0])

    top = max(float(np.abs(diff).max()), 1e-6)
    axes[1].imshow(diff, cmap="RdBu_r", vmin=-top, vmax=top, interpolation="nearest")
    axes[1].set_title(
        f"difference $D_{{{frame}}} = F_{{{frame}}} - A$\n(grey, ±{top:.2f})", fontsize=9
    )
    _off(axes[1])

    _word_map(axes[2], db.words[fragment], db.params.words)
    axes[2].set_title(f"visual words (k = {db.params.words})\npyramid cells outlined", fontsize=9)

    _spectrum_axes(axes[3], [db.spectra[fragment]], ["power"], ["C0"])
    axes[3].set_title("motion spectra $\\hat M_f$ (Eq. 2)\n◇ DC, stored signed", fontsize=9)

    axes[4].imshow(_texture_montage(db.texture[fragment]), cmap="magma", interpolation="nearest")
    tex = np.asarray(db.texture[fragment], np.float64).mean(axis=(1, 2))
    side = db.texture.shape[-1]
    for level in range(TEXTURE_LEVELS):
        r, c = divmod(level, 2)
        axes[4].text(
            c * (side + 2) + 1,
            r * (side + 2) + 1,
            f"L{level} {tex[level]:.2g}",
            color="w",
            fontsize=7,
            va="top",
        )
    axes[4].set_title("textureness T (Fig. 7)\nlevels 0-3, each to its max", fontsize=9)
    _off(axes[4])


def _fragment_title(db, fragment):
    clip, version, first, row, col = (int(v) for v in db.source[fragment])
    return (
        f"fragment {fragment}: clip {clip} '{_clip_name(db, clip)}', version {version} "
        f"({version_label(version)}), frames {first}-{first + db.params.N - 1}, "
        f"top-left ({row}, {col})"
    )


def fragment_figure(db, fragment, *, frame=0, figsize=(13, 3.1)):
    r"""One database fragment as the method sees it (Okabe et al., secs. 4-5, Fig. 2, 5, 6, 7).

    Parameters
    ----------
    db : VideoDatabase
        The database.
    fragment : int
        The fragment's id (row of ``db.words``).
    frame : int
        Which difference frame :math:`D_i = F_i - A` to show, ``0 <= frame < N``.
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Five panels: the mean image :math:`A` with the DC term of its motion spectra
        (the mean motion of each 4 x 4-pixel block, every other block) as arrows; one
        difference frame (grey, red brighter than :math:`A`, blue darker); the 9 x 9
        visual-word map with the spatial pyramid's level-1 (thick) and level-2 (thin)
        cells; the motion power spectrum per frequency bin (both components, averaged
        over the fragment; the diamond is the DC bin's power, the square of the mean
        motion the database stores signed); the textureness's four Laplacian levels.
    """
    db = _check_db(db)
    fragment = _check_fragment(db, fragment)
    fig = _figure(figsize)
    axes = fig.subplots(1, 5, width_ratios=[1, 1, 1, 1.5, 1])
    _fragment_panels(axes, db, fragment, frame)
    fig.suptitle(_fragment_title(db, fragment), fontsize=10)
    return fig


def _version_canvas(db, clip, version, first, frame, *, shade=False):
    """The version's canvas at frame ``first + frame`` of the clip, float32 RGB.

    With ``shade``, pixels that map outside the source (the sampler clamps them, so
    they smear the border) are darkened: no fragment is cut there.
    """
    frames = db.clip_frames(clip, first + frame, first + frame + 1).astype(np.float32) / 255
    canvas = sample_version(frames, version)[0].clip(0, 1)
    if shade:
        h, w = frames.shape[1:3]
        yx = version_coordinates((h, w), version)
        outside = (yx[..., 0] < 0) | (yx[..., 0] > h - 1) | (yx[..., 1] < 0) | (yx[..., 1] > w - 1)
        canvas[outside] *= 0.25
    return canvas


def _default_fragment(db, clip):
    """The fragment of the clip itself (version 7, first window) nearest its centre."""
    src = db.source
    own = np.flatnonzero((src[:, 0] == clip) & (src[:, 1] == IDENTITY) & (src[:, 2] == 0))
    if len(own) == 0:
        own = np.flatnonzero(src[:, 0] == clip)
    if len(own) == 0:
        raise ValueError(f"clip {clip} has no fragment in the database (nothing moved)")
    info = db.clips[clip]
    centre = np.array([info["height"], info["width"]]) / 2 - FRAGMENT / 2
    d = ((src[own, 3:5] - centre) ** 2).sum(axis=1)
    return int(own[np.argmin(d)])


def clip_fragments_figure(db, clip=None, *, fragment=None, frame=0, figsize=(13, 7.2)):
    r"""A clip cut into fragments, and one fragment's features (Okabe et al., sec. 4, Fig. 4-b, 5).

    Parameters
    ----------
    db : VideoDatabase
        The database.
    clip : int, optional
        The source clip (index into ``db.clips``); default the clip of ``fragment``,
        else clip 0.
    fragment : int, optional
        The fragment to show; default the clip's own (unaugmented, first window)
        fragment nearest the clip's centre.
    frame : int
        The frame of the fragment's window drawn (``0 <= frame < N``).
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Top: the frame of the fragment's augmented version with the stride-24 grid,
        a dot at the centre of every fragment kept in the database (something moved
        in it) and a cross where a fragment was dropped (nothing moved), the fragment
        outlined in yellow and its right-hand neighbour dashed (they overlap by half);
        beside it four of the fragment's frames. Bottom: :func:`fragment_figure`'s
        five panels.

    Raises
    ------
    ValueError
        If ``fragment`` does not belong to ``clip``, or the clip has no fragment.
    """
    from matplotlib.patches import Rectangle

    db = _check_db(db)
    if fragment is not None:
        fragment = _check_fragment(db, fragment)
        own = int(db.source[fragment, 0])
        if clip is not None and check_int("clip", clip, 0, len(db.clips) - 1) != own:
            raise ValueError(f"fragment {fragment} belongs to clip {own}, not to clip {clip}")
        clip = own
    else:
        clip = 0 if clip is None else check_int("clip", clip, 0, len(db.clips) - 1)
        fragment = _default_fragment(db, clip)
    n = db.params.N
    frame = check_int("frame", frame, 0, n - 1)
    _, version, first, row, col = (int(v) for v in db.source[fragment])
    canvas = _version_canvas(db, clip, version, first, frame, shade=True)
    info = db.clips[clip]

    fig = _figure(figsize)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.45, 1])
    ax_clip, ax_frames = top.subplots(1, 2, width_ratios=[2.3, 1])
    ax_clip.imshow(canvas, interpolation="nearest")
    hv, wv = canvas.shape[:2]
    for y in range(0, hv + 1, STRIDE):
        ax_clip.axhline(y - 0.5, color="w", lw=0.4, alpha=0.5)
    for x in range(0, wv + 1, STRIDE):
        ax_clip.axvline(x - 0.5, color="w", lw=0.4, alpha=0.5)
    valid = valid_positions((info["height"], info["width"]), version)
    src = db.source
    here = (src[:, 0] == clip) & (src[:, 1] == version) & (src[:, 2] == first)
    kept = {(int(r), int(c)) for r, c in src[here, 3:5]}
    half = FRAGMENT / 2 - 0.5
    is_kept = np.array([(int(r), int(c)) in kept for r, c in valid], bool)
    if len(valid):
        ax_clip.plot(
            valid[is_kept, 1] + half, valid[is_kept, 0] + half, "o", ms=4, color="lime", ls=""
        )
        ax_clip.plot(
            valid[~is_kept, 1] + half, valid[~is_kept, 0] + half, "x", ms=4, color="0.6", ls=""
        )
    ax_clip.add_patch(
        Rectangle((col - 0.5, row - 0.5), FRAGMENT, FRAGMENT, fc="none", ec="yellow", lw=2.5)
    )
    if (row, col + STRIDE) in {(int(r), int(c)) for r, c in valid}:
        ax_clip.add_patch(
            Rectangle(
                (col + STRIDE - 0.5, row - 0.5),
                FRAGMENT,
                FRAGMENT,
                fc="none",
                ec="yellow",
                lw=1.5,
                ls="--",
            )
        )
    ax_clip.set_xlim(-0.5, wv - 0.5)
    ax_clip.set_ylim(hv - 0.5, -0.5)
    ax_clip.set_title(
        f"clip {clip} '{info['name']}' ({info['height']} x {info['width']}), version "
        f"{version} ({version_label(version)}), frame {first + frame}\n"
        f"{int(is_kept.sum())} of {len(valid)} fragments kept (dots: something moves; "
        f"crosses: dropped), stride {STRIDE} px",
        fontsize=9,
    )
    _off(ax_clip)

    frames = db.fragment_frames([fragment])[0]
    picks = np.linspace(0, n - 1, 4).round().astype(int)
    gap = 2
    strip = np.ones((2 * FRAGMENT + gap, 2 * FRAGMENT + gap, 3), np.float32)
    for k, t in enumerate(picks):
        r, c = divmod(k, 2)
        strip[
            r * (FRAGMENT + gap) : r * (FRAGMENT + gap) + FRAGMENT,
            c * (FRAGMENT + gap) : c * (FRAGMENT + gap) + FRAGMENT,
        ] = frames[t]
    ax_frames.imshow(strip, interpolation="nearest")
    for k, t in enumerate(picks):
        r, c = divmod(k, 2)
        ax_frames.text(
            c * (FRAGMENT + gap) + 2,
            r * (FRAGMENT + gap) + 2,
            f"$F_{{{t}}}$",
            color="w",
            fontsize=9,
            va="top",
        )
    ax_frames.set_title(f"fragment {fragment}: 4 of its N = {n} frames", fontsize=9)
    _off(ax_frames)

    axes = bottom.subplots(1, 5, width_ratios=[1, 1, 1, 1.5, 1])
    _fragment_panels(axes, db, fragment, frame)
    return fig


# ------------------------------------------------------------------------ versions


def versions_figure(db, clip=0, *, frame=0, figsize=(14, 4.4)):
    r"""The 18 augmented versions of a clip (Okabe et al., sec. 4, Fig. 4-a).

    Parameters
    ----------
    db : VideoDatabase
        The database (its clips' frames are stored with it).
    clip : int
        The source clip (index into ``db.clips``).
    frame : int
        The clip's frame to show.
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        2 x 9 panels at one pixel scale (so the 50 % versions look half as large):
        top without, bottom with the horizontal flip; scales 50, 75, 100 % and
        rotations -22.5, 0, +22.5 degrees. Each panel's arrow is the mean motion of
        the version's fragments in the database (flow estimated once on the clip and
        carried into each version: a flip negates dx, a rotation turns the arrow with
        the picture, a scale shortens it), and its title says how many fragments the
        version gave.
    """
    db = _check_db(db)
    clip = check_int("clip", clip, 0, len(db.clips) - 1)
    info = db.clips[clip]
    frame = check_int("frame", frame, 0, int(info["frames"]) - 1)
    canvases = [_version_canvas(db, clip, v, frame, 0, shade=True) for v in range(len(VERSIONS))]
    hmax = max(c.shape[0] for c in canvases)
    wmax = max(c.shape[1] for c in canvases)
    src = db.source
    fig = _figure(figsize)
    axes = fig.subplots(2, 9)
    for v, (ax, canvas) in enumerate(zip(axes.ravel(), canvases)):
        hv, wv = canvas.shape[:2]
        ax.imshow(canvas, extent=(-0.5, wv - 0.5, hv - 0.5, -0.5), interpolation="nearest")
        ax.set_xlim(-0.5, wmax - 0.5)
        ax.set_ylim(hmax - 0.5, -0.5)
        mine = (src[:, 0] == clip) & (src[:, 1] == v)
        count = int(mine.sum())
        if count:
            dy, dx = db.mean_motion[mine].astype(np.float64).mean(axis=0)
            speed = float(np.hypot(dy, dx))
            if speed > MIN_MOTION:
                # One px/frame is drawn GAIN px long at every scale: the arrows compare.
                ax.quiver(
                    [wv / 2],
                    [hv / 2],
                    [_VERSION_GAIN * dx],
                    [_VERSION_GAIN * dy],
                    angles="xy",
                    scale_units="xy",
                    scale=1,
                    color="yellow",
                    width=0.03,
                    pivot="middle",
                    edgecolor="k",
                    linewidth=0.5,
                )
        ax.set_title(f"{version_label(v)}\n{count} fragments", fontsize=8)
        _off(ax)
    fig.suptitle(
        f"clip {clip} '{info['name']}': the 18 versions (arrow: mean motion of the version's "
        f"fragments, {_VERSION_GAIN:g} px per px/frame; dark: outside the source, no fragment)",
        fontsize=10,
    )
    return fig


# ----------------------------------------------------------------------- retrieval


def retrieval_figure(db, image, *, k=6, figsize=None):
    r"""A query fragment and its ``k`` best database fragments by Eq. (1).

    Parameters
    ----------
    db : VideoDatabase
        The database to search.
    image : array_like, shape (48, 48, 3)
        The query: a target fragment, or a database fragment's mean image (which then
        finds itself first, with :math:`I = 1`).
    k : int
        Candidates shown, ``1 <= k <= db.n_fragments``.
    figsize : (float, float), optional
        Figure size in inches (default: by ``k``).

    Returns
    -------
    matplotlib.figure.Figure
        The query, its visual-word map, then the candidates' mean images, each titled
        with its id, its clip and :math:`I(H_e, H_t)` (Eq. 1, normalised to [0, 1]).
    """
    db = _check_db(db)
    img = check_array("image", image, ndim=3)
    if img.shape != (FRAGMENT, FRAGMENT, 3):
        raise ValueError(f"image must have shape (48, 48, 3), got {img.shape}")
    k = check_int("k", k, 1, db.n_fragments)
    words = db.describe(img[None])
    top = histogram_index(db).top_k(words, k)
    ids, scores = top.ids[0], top.scores[0]
    means = db.mean_images(ids)
    fig = _figure(figsize or (1.75 * (k + 2), 2.6))
    axes = fig.subplots(1, k + 2)
    axes[0].imshow(np.clip(img, 0, 1), interpolation="nearest")
    axes[0].set_title("query", fontsize=9)
    _off(axes[0])
    _word_map(axes[1], words[0], db.params.words)
    axes[1].set_title("its words", fontsize=9)
    for ax, i, s, m in zip(axes[2:], ids, scores, means):
        ax.imshow(m, interpolation="nearest")
        clip = int(db.source[i, 0])
        ax.set_title(f"#{int(i)} I = {s / HISTOGRAM_TOTAL:.2f}\n{_clip_name(db, clip)}", fontsize=8)
        _off(ax)
    return fig


# ------------------------------------------------------------------ spectra, texture


def spectra_figure(db, fragments, *, labels=None, figsize=None):
    r"""Motion spectra (Eq. 2, Fig. 6) and textureness (Fig. 7) side by side (Okabe et al.).

    Parameters
    ----------
    db : VideoDatabase
        The database.
    fragments : sequence of int
        Fragment ids to compare (1-6 of them).
    labels : sequence of str, optional
        A name for each (default ``"#id"``).
    figsize : (float, float), optional
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Left: each fragment's motion power per frequency bin (summed over dy and dx,
        averaged over the fragment; diamonds: the DC bin's power, i.e. the squared
        mean motion), on one log axis, so a calm fragment (DC only) and a turbulent one
        (power at every frequency) tell apart at a glance, as in the paper's Fig. 6.
        Right: per fragment its mean image and the four textureness levels, each level
        on one colour scale for all fragments, so contrast differences show (Fig. 7).
    """
    db = _check_db(db)
    ids = [_check_fragment(db, f, "fragments") for f in np.atleast_1d(fragments).tolist()]
    if not 1 <= len(ids) <= 6:
        raise ValueError(f"fragments must hold 1 to 6 fragment ids, got {len(ids)}")
    if labels is None:
        labels = [f"#{i}" for i in ids]
    labels = [str(s) for s in labels]
    if len(labels) != len(ids):
        raise ValueError(f"labels must have one entry per fragment ({len(ids)}), got {len(labels)}")
    colours = [f"C{i}" for i in range(len(ids))]
    fig = _figure(figsize or (13, 1.0 + 1.75 * max(2, len(ids))))
    left, right = fig.subfigures(1, 2, width_ratios=[1, 1.5])
    ax = left.subplots()
    _spectrum_axes(ax, [db.spectra[i] for i in ids], labels, colours)
    ax.legend(fontsize=8)
    ax.set_title("motion power spectra (Eq. 2; ◇ DC = mean motion squared)", fontsize=9)

    tex = np.asarray(db.texture[ids], np.float64)
    scale = np.maximum(tex.max(axis=(0, 2, 3)), 1e-12)
    means = db.mean_images(ids)
    grid = right.subplots(len(ids), 1 + TEXTURE_LEVELS, squeeze=False)
    for row, (label, colour) in enumerate(zip(labels, colours)):
        grid[row, 0].imshow(means[row], interpolation="nearest")
        grid[row, 0].set_ylabel(label, color=colour, fontsize=9)
        for level in range(TEXTURE_LEVELS):
            a = grid[row, level + 1]
            a.imshow(tex[row, level], cmap="magma", vmin=0, vmax=scale[level])
            a.set_xlabel(f"mean {tex[row, level].mean():.3g}", fontsize=7, labelpad=1)
            if row == 0:
                a.set_title(f"T, level {level}", fontsize=9)
        for a in grid[row]:
            _off(a)
    grid[0, 0].set_title("mean image A", fontsize=9)
    right.suptitle("textureness (Fig. 7): one colour scale per level", fontsize=9)
    return fig
