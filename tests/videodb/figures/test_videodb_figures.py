"""The lesson's figures (fluidnb.videodb.figures._database) on a tiny synthetic database.

Each figure is checked for what it plots (its images, arrows and curves against the
database and the assignment they come from), not for its titles or its number of axes.
"""

import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.quiver import Quiver
from scipy import ndimage as ndi

from fluidnb.fields import resize
from fluidnb.videodb import AnimateParams, DatabaseParams, assign, build_database, render
from fluidnb.videodb.assignment import histogram_index
from fluidnb.videodb.database import sample_version, transform_vectors, valid_positions
from fluidnb.videodb.database._features import grey
from fluidnb.videodb.figures import (
    assignment_figure,
    clip_colour,
    clip_fragments_figure,
    clip_map_picture,
    fragment_figure,
    motion_arrows,
    rendering_figure,
    retrieval_figure,
    spectra_figure,
    sweep_figure,
    version_label,
    versions_figure,
)
from fluidnb.videodb.figures._pictures import CLIP_PALETTE

PARAMS = DatabaseParams(N=8, augment="flip", words=16, codebook_samples=5000)
FEW = AnimateParams(candidates=12)


def texture(seed, shape, blur=1.5):
    gen = np.random.default_rng(seed)
    t = ndi.gaussian_filter(gen.random(shape), blur, mode="wrap")
    return (t - t.min()) / (t.max() - t.min())


def moving(seed, velocity, shape=(72, 144), frames=9):
    base = texture(seed, shape)
    dy, dx = velocity
    out = np.stack([np.roll(base, (t * dy, t * dx), axis=(0, 1)) for t in range(frames)])
    out[:, :, -60:] = 0.0  # a still black band: its fragments are dropped
    return (out[..., None] * np.array([0.5, 0.7, 1.0])).astype(np.float32)


@pytest.fixture(scope="module")
def db(tmp_path_factory):
    clips = [("right", moving(1, (0, 1))), ("down", moving(2, (1, 0)))]
    path = tmp_path_factory.mktemp("figures") / "db"
    return build_database(clips, path, kind="water", params=PARAMS, seed=0)


@pytest.fixture(scope="module")
def assignment(db):
    img = np.stack([texture(9, (60, 84), blur=2.0)] * 3, axis=-1) * [0.4, 0.6, 0.9]
    matte = np.zeros((60, 84), np.float32)
    matte[6:54, 10:74] = 1.0
    return assign(img.astype(np.float32), matte, db, FEW)


def drawn(fig):
    """Render the figure (errors in drawing show only then), return its axes."""
    assert isinstance(fig, Figure)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=30)
    assert buf.getvalue()[:4] == b"\x89PNG"
    # Made with the object API, the figure is not held by pyplot (no window to close):
    # it is freed with its last reference.
    assert fig.canvas.manager is None
    return fig.get_axes()


def image(ax, i=0):
    """The data of the ``i``-th image drawn in ``ax`` (NaN where masked)."""
    data = ax.get_images()[i].get_array()
    return np.ma.filled(np.ma.asarray(data).astype(np.float64), np.nan)


def quivers(ax):
    return [c for c in ax.collections if isinstance(c, Quiver)]


def arrows(q):
    """(x, y) positions and (u, v) vectors of a quiver (data units)."""
    return np.asarray(q.get_offsets(), np.float64), np.stack([q.U, q.V], axis=1)


def spectrum_power(spectra):
    """Per bin, the power over both components averaged over the blocks (by hand)."""
    s = np.asarray(spectra, np.float64)
    dc = (s[0, 0] ** 2 + s[0, 1] ** 2).mean()  # bin 0 is stored signed: its power is its square
    rest = (s[1:, 0] + s[1:, 1]).mean(axis=(-2, -1))  # bins >= 1 are stored as power
    return np.concatenate([[dc], rest])


# ------------------------------------------------------------------ one fragment


def test_fragment_figure_plots_the_fragments_features(db):
    f, frame = 3, 2
    axes = drawn(fragment_figure(db, f, frame=frame))
    # The mean image A, and its DC motion per 4 x 4 block (every other block) as arrows
    # pointing along the stored mean motion of those blocks.
    np.testing.assert_array_equal(image(axes[0]), db.mean_images([f])[0])
    (q,) = quivers(axes[0])
    xy, uv = arrows(q)
    dc = db.spectra[f, 0].astype(np.float64)  # (2, 12, 12): (dy, dx)
    np.testing.assert_allclose(xy[:, 0], np.tile((np.arange(0, 12, 2) + 0.5) * 4 - 0.5, 6))
    along = np.stack([dc[1, ::2, ::2].ravel(), dc[0, ::2, ::2].ravel()], axis=1)  # (x, y)
    gain = (uv * along).sum() / (along * along).sum()  # one length per px/frame for all
    assert gain > 0
    np.testing.assert_allclose(uv, gain * along, atol=1e-9)
    # D_i = F_i - A in grey.
    frames = db.fragment_frames([f])[0]
    np.testing.assert_allclose(
        image(axes[1]), grey(frames[frame]) - grey(frames).mean(axis=0), atol=1e-6
    )
    # The 9 x 9 word map (coloured modulo 20, labelled with the words).
    np.testing.assert_array_equal(image(axes[2]), db.words[f] % 20)
    labels = [int(t.get_text()) for t in axes[2].texts]
    assert labels == db.words[f].ravel().tolist()
    # The spectra: bins 1.. on the line, the DC bin's power as the diamond.
    line, diamond = axes[3].get_lines()
    power = spectrum_power(db.spectra[f])
    np.testing.assert_allclose(line.get_ydata(), power[1:] + 1e-12, rtol=1e-6)
    np.testing.assert_allclose(diamond.get_ydata(), power[:1] + 1e-12, rtol=1e-6)
    # The textureness's four levels, each scaled to its maximum, 2 x 2 with gaps.
    montage = image(axes[4])
    t = db.texture[f].astype(np.float32)
    for level in range(4):
        r, c = divmod(level, 2)
        tile = montage[r * 26 : r * 26 + 24, c * 26 : c * 26 + 24]
        np.testing.assert_allclose(tile, t[level] / t[level].max(), atol=1e-6)
    assert np.isnan(montage[24:26]).all()


def test_clip_fragments_figure_marks_kept_and_dropped_fragments(db):
    fig = clip_fragments_figure(db, 0)
    top = fig.get_axes()[0]
    src = db.source
    own = (src[:, 0] == 0) & (src[:, 1] == 7) & (src[:, 2] == 0)  # the clip itself, window 0
    info = db.clips[0]
    valid = valid_positions((info["height"], info["width"]), 7)
    kept = {(int(r), int(c)) for r, c in src[own, 3:5]}
    dots, crosses = top.get_lines()[-2:]
    centre = 23.5  # a fragment's centre, from its top-left corner
    got = {(int(y - centre), int(x - centre)) for x, y in dots.get_xydata()}
    assert got == kept
    dropped = {(int(y - centre), int(x - centre)) for x, y in crosses.get_xydata()}
    assert dropped == {(int(r), int(c)) for r, c in valid} - kept
    assert dropped  # the black band
    # The picture is the clip's frame (version 7 is the clip itself).
    frame0 = db.clip_frames(0, 0, 1).astype(np.float32) / 255
    np.testing.assert_allclose(image(top), sample_version(frame0, 7)[0], atol=1e-6)
    drawn(fig)


def test_clip_fragments_figure_checks_the_fragment_belongs_to_the_clip(db):
    other = int(np.flatnonzero(db.source[:, 0] == 1)[0])
    with pytest.raises(ValueError, match="belongs to clip 1, not to clip 0"):
        clip_fragments_figure(db, 0, fragment=other)
    axes = drawn(clip_fragments_figure(db, fragment=other))
    # Its own fragment's mean image in the bottom row (after the clip and its frames).
    np.testing.assert_array_equal(image(axes[2]), db.mean_images([other])[0])


# ------------------------------------------------------------------ versions, retrieval


def test_versions_figure_draws_each_versions_mean_motion(db):
    axes = drawn(versions_figure(db, 1))
    src = db.source
    for v, ax in enumerate(axes):
        mine = (src[:, 0] == 1) & (src[:, 1] == v)
        found = quivers(ax)
        if not mine.any():
            assert not found
            continue
        (q,) = found
        _, uv = arrows(q)
        dy, dx = db.mean_motion[mine].astype(np.float64).mean(axis=0)
        np.testing.assert_allclose(uv[0], [30 * dx, 30 * dy], rtol=1e-6)
        # Clip 1 flows down; its flow, measured once, is carried into each version:
        # the arrow points as the version turns, flips and scales "down".
        down = transform_vectors(np.array([1.0, 0.0]), v)
        assert np.dot(down / np.linalg.norm(down), [dy, dx] / np.hypot(dy, dx)) > 0.9


def test_version_labels():
    assert version_label(7) == "100 % 0°"
    assert version_label(17) == "flip 100 % +22.5°"
    with pytest.raises(ValueError, match="version"):
        version_label(18)


def test_retrieval_figure_shows_the_best_candidates_a_mean_image_first(db):
    fid = 5
    query = db.mean_images([fid])[0]
    axes = drawn(retrieval_figure(db, query, k=3))
    top = histogram_index(db).top_k(db.describe(query[None]), 3)
    assert top.ids[0, 0] == fid
    assert top.scores[0, 0] == 324  # I = 1: it finds itself
    for ax, i in zip(axes[2:], top.ids[0]):
        np.testing.assert_array_equal(image(ax), db.mean_images([i])[0])
    np.testing.assert_array_equal(image(axes[1]), db.describe(query[None])[0] % 20)
    with pytest.raises(ValueError, match="48, 48, 3"):
        retrieval_figure(db, np.zeros((40, 48, 3)))


def test_spectra_figure_plots_each_fragments_spectrum_and_textureness(db):
    ids = [0, 4]
    fig = spectra_figure(db, ids, labels=["a", "b"])
    axes = drawn(fig)
    lines = axes[0].get_lines()
    for k, f in enumerate(ids):
        power = spectrum_power(db.spectra[f])
        np.testing.assert_allclose(lines[2 * k].get_ydata(), power[1:] + 1e-12, rtol=1e-6)
    assert [t.get_text() for t in axes[0].get_legend().get_texts()] == ["a", "b"]
    # Right: per fragment its mean image and its textureness levels, on one colour
    # scale per level (so contrasts compare across fragments).
    grid = np.array(axes[1:]).reshape(len(ids), 5)
    tex = db.texture[ids].astype(np.float64)
    for row, f in enumerate(ids):
        np.testing.assert_array_equal(image(grid[row, 0]), db.mean_images([f])[0])
        for level in range(4):
            im = grid[row, level + 1].get_images()[0]
            np.testing.assert_allclose(image(grid[row, level + 1]), tex[row, level])
            assert im.get_clim() == (0, tex[:, level].max())
    with pytest.raises(ValueError, match="labels must have one entry per fragment"):
        spectra_figure(db, [0, 4], labels=["a"])
    with pytest.raises(ValueError, match="1 to 6"):
        spectra_figure(db, list(range(7)))


# ------------------------------------------------------------------------ assignment


def test_clip_map_picture_tints_each_cell_with_its_clips_colour():
    photo = np.random.default_rng(0).random((6, 8, 3)).astype(np.float32)
    clips = np.full((6, 8), -1)
    clips[1:4, 2:6] = 3
    out = clip_map_picture(photo, clips)
    colour = np.array(clip_colour(3))
    np.testing.assert_allclose(out[2, 3], 0.4 * photo[2, 3] + 0.6 * colour)
    np.testing.assert_allclose(out[0, 0], 0.35 * photo[0, 0])
    np.testing.assert_allclose(clip_map_picture(photo), 0.35 * photo)
    # On a canvas of another size: the photo resized, the cells sampled at the nearest.
    big = clip_map_picture(photo, clips, shape=(12, 16))
    shown = np.clip(resize(photo, (12, 16)), 0, 1)
    np.testing.assert_allclose(big[5, 7], 0.4 * shown[5, 7] + 0.6 * colour)
    np.testing.assert_allclose(big[0, 0], 0.35 * shown[0, 0])
    assert clip_colour(3) == tuple(CLIP_PALETTE[3] / 255)
    assert clip_colour(3 + len(CLIP_PALETTE)) == clip_colour(3)


def test_motion_arrows_are_centred_on_the_fragments_along_their_motion(assignment):
    a = assignment
    segments, gain = motion_arrows(a)
    motion = a.db.mean_motion[a.fragments].astype(np.float64)
    centres = a.target.positions + 23.5
    h, w = a.target.shape
    inside = (centres[:, 0] < h) & (centres[:, 1] < w)
    np.testing.assert_allclose(segments.mean(axis=1), centres[inside])
    np.testing.assert_allclose(segments[:, 1] - segments[:, 0], gain * motion[inside])
    # The 90th percentile of the speeds spans 0.9 of a stride.
    speed = np.hypot(*motion[inside].T)
    assert gain == pytest.approx(0.9 * 24 / np.percentile(speed, 90))
    thin, same = motion_arrows(a, gain=2.0, thin=True)
    assert same == 2.0
    cell = a.target.positions[inside] // 24
    assert len(thin) == int(((cell[:, 0] % 2 == 0) & (cell[:, 1] % 2 == 0)).sum())


def test_assignment_figure_draws_the_clip_map_arrows_and_strokes(assignment):
    a = assignment
    stroke = np.array([[30.0, 5.0], [30.0, 80.0]])
    fig = assignment_figure(a, strokes=[stroke], title="mine")
    ax = fig.get_axes()[0]
    np.testing.assert_allclose(image(ax), clip_map_picture(a.target.image, a.clip_map()))
    (q,) = quivers(ax)
    xy, uv = arrows(q)
    segments, _ = motion_arrows(a)
    np.testing.assert_allclose(xy, segments.mean(axis=1)[:, ::-1])  # (x, y) = (col, row)
    np.testing.assert_allclose(uv, (segments[:, 1] - segments[:, 0])[:, ::-1], atol=1e-12)
    # The stroke, drawn along its points (white under crimson), with its arrow head.
    lines = [ln.get_xydata() for ln in ax.get_lines()]
    assert any(np.allclose(xy, stroke[:, ::-1]) for xy in lines)
    # The legend names the clips used, in their colours.
    used = np.unique(a.db.clip_of(a.fragments))
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()] == [a.db.clips[k]["name"] for k in used]
    for patch, k in zip(legend.get_patches(), used):
        np.testing.assert_allclose(patch.get_facecolor()[:3], clip_colour(k))
    drawn(fig)
    mosaic = assignment_figure(a, background="mosaic", arrows=False).get_axes()[0]
    np.testing.assert_allclose(image(mosaic), a.mean_image_mosaic())
    assert not quivers(mosaic)
    with pytest.raises(ValueError, match="background must be"):
        assignment_figure(a, background="paint")


def test_assignment_figure_into_given_axes(assignment):
    fig = Figure()
    ax = fig.subplots(1, 2)
    assert assignment_figure(assignment, ax=ax[1], legend=False) is fig
    assert not ax[0].get_images()
    assert ax[1].get_images()
    drawn(fig)


def test_sweep_figure_draws_each_assignment_at_one_scale(assignment):
    other = assignment.resolve(lam=0.0)
    changed = np.mean(other.fragments != assignment.fragments)
    axes = drawn(sweep_figure({"base": assignment, "λ = 0": other}))
    gains = []
    for ax, a in zip(axes, (assignment, other)):
        np.testing.assert_allclose(image(ax), clip_map_picture(a.target.image, a.clip_map()))
        (q,) = quivers(ax)
        xy, uv = arrows(q)
        segments, _ = motion_arrows(a, gain=1.0, thin=True)
        np.testing.assert_allclose(xy, segments.mean(axis=1)[:, ::-1])
        unit = (segments[:, 1] - segments[:, 0])[:, ::-1]
        moving = np.abs(unit).sum(axis=1) > 0
        gains.append(np.unique(np.round(uv[moving] / unit[moving], 9)))
    assert len(gains[0]) == 1
    np.testing.assert_array_equal(gains[0], gains[1])  # one arrow scale for all panels
    assert axes[1].get_title().startswith(f"λ = 0\nchanged {changed:.0%}")
    with pytest.raises(ValueError, match="non-empty dict"):
        sweep_figure({})


def test_sweep_figure_zooms_on_the_fragments_and_refuses_another_target(assignment):
    fig = sweep_figure({"a": assignment}, zoom=True)
    ax = fig.get_axes()[0]
    pos = assignment.target.positions
    h, w = assignment.target.shape
    assert ax.get_xlim() == (pos[:, 1].min() - 0.5, min(w, pos[:, 1].max() + 48) - 0.5)
    assert ax.get_ylim() == (min(h, pos[:, 0].max() + 48) - 0.5, pos[:, 0].min() - 0.5)
    drawn(fig)
    img, matte = assignment.target.image, assignment.target.matte.copy()
    matte[:, 30:] = 0.0  # fewer fragments: another target
    other = assign(img, matte, assignment.db, FEW)
    with pytest.raises(ValueError, match="another target"):
        sweep_figure({"a": assignment, "b": other})


# ------------------------------------------------------------------------- rendering


def test_rendering_figure_shows_the_flow_renderings_stages(assignment):
    anim = render(assignment, AnimateParams(candidates=12, loop=2))
    t = 3
    axes = drawn(rendering_figure(anim, frame=t))
    st = anim.stages
    np.testing.assert_array_equal(image(axes[0]), assignment.target.image)
    m = assignment.target.matte[..., None]
    dim = (1 - m) * 0.4 * assignment.target.image
    np.testing.assert_allclose(image(axes[1]), m * np.clip(st["phase_a"][t], 0, 1) + dim)
    np.testing.assert_allclose(image(axes[2]), m * np.clip(st["phase_b"][t], 0, 1) + dim)
    np.testing.assert_array_equal(image(axes[3]), st["differences"][t])
    np.testing.assert_allclose(image(axes[4]), m * st["unmatched"][t] + dim)
    np.testing.assert_array_equal(image(axes[5]), anim.clip.frames[t])


def test_rendering_figure_shows_the_stages_of_one_frame(assignment):
    anim = render(assignment, AnimateParams(candidates=12, loop=2, rendering="paper"))
    t = 1
    axes = drawn(rendering_figure(anim, frame=t))
    st = anim.stages
    np.testing.assert_array_equal(image(axes[0]), assignment.target.image)
    np.testing.assert_array_equal(image(axes[1]), st["differences"][t])
    np.testing.assert_array_equal(image(axes[2]), st["mean"])
    np.testing.assert_array_equal(image(axes[3]), st["unmatched"][t])
    np.testing.assert_array_equal(image(axes[4]), anim.clip.frames[t])
    np.testing.assert_array_equal(image(axes[5]), st["matte"][t])
    with pytest.raises(ValueError, match="animation must be an Animation"):
        rendering_figure(assignment)


def test_bad_inputs_name_the_parameter(db):
    with pytest.raises(ValueError, match="db must be a VideoDatabase"):
        fragment_figure("water", 0)
    with pytest.raises(ValueError, match="fragment must be"):
        fragment_figure(db, db.n_fragments)
    with pytest.raises(ValueError, match="frame must be"):
        fragment_figure(db, 0, frame=PARAMS.N)
    with pytest.raises(ValueError, match="assignment must be an Assignment"):
        assignment_figure(db)
    with pytest.raises(ValueError, match="assignment must be an Assignment"):
        motion_arrows(db)
