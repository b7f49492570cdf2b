"""The lesson's figures (fluidnb.videodb._figures) on a tiny synthetic database."""

import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from scipy import ndimage as ndi

from fluidnb.videodb import AnimateParams, DatabaseParams, assign, build_database, render
from fluidnb.videodb._figures import (
    assignment_figure,
    clip_fragments_figure,
    fragment_figure,
    mean_image_mosaic,
    motion_coherence,
    rendering_figure,
    retrieval_figure,
    spectra_figure,
    sweep_figure,
    version_label,
    versions_figure,
)

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
    """Render the figure (errors in drawing show only then), return its image axes."""
    assert isinstance(fig, Figure)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=30)
    assert buf.getvalue()[:4] == b"\x89PNG"
    # Made with the object API, the figure is not held by pyplot (no window to close):
    # it is freed with its last reference.
    assert fig.canvas.manager is None
    return fig.get_axes()


def titles(axes):
    return [a.get_title() for a in axes]


def test_fragment_figure_has_the_five_panels(db):
    axes = drawn(fragment_figure(db, 3, frame=2))
    assert len(axes) == 5
    t = titles(axes)
    assert "mean image A" in t[0]
    assert "D_{2}" in t[1]
    assert "visual words (k = 16)" in t[2]
    assert "Eq. 2" in t[3]
    assert axes[3].get_yscale() == "log"
    assert "textureness" in t[4]
    assert fragment_figure.__name__ == "fragment_figure"


def test_clip_fragments_figure_marks_kept_and_dropped_fragments(db):
    fig = clip_fragments_figure(db, 0)
    top = fig.get_axes()[0]
    # The dots are the kept fragments of the clip itself (version 7, first window).
    src = db.source
    own = (src[:, 0] == 0) & (src[:, 1] == 7) & (src[:, 2] == 0)
    dots, crosses = top.lines[-2:] if len(top.lines) >= 2 else (None, None)
    assert len(dots.get_xdata()) == int(own.sum())
    assert len(crosses.get_xdata()) > 0  # the black band is dropped
    axes = drawn(fig)
    assert len(axes) == 7  # the clip, four frames, five fragment panels
    assert "clip 0 'right'" in axes[0].get_title()
    assert "of its N = 8 frames" in axes[1].get_title()


def test_clip_fragments_figure_checks_the_fragment_belongs_to_the_clip(db):
    other = int(np.flatnonzero(db.source[:, 0] == 1)[0])
    with pytest.raises(ValueError, match="belongs to clip 1, not to clip 0"):
        clip_fragments_figure(db, 0, fragment=other)
    axes = drawn(clip_fragments_figure(db, fragment=other))
    assert "clip 1 'down'" in axes[0].get_title()


def test_versions_figure_shows_the_18_versions_with_their_counts(db):
    axes = drawn(versions_figure(db, 1))
    assert len(axes) == 18
    counts = np.bincount(db.source[db.source[:, 0] == 1, 1], minlength=18)
    for v, ax in enumerate(axes):
        assert ax.get_title() == f"{version_label(v)}\n{counts[v]} fragments"


def test_version_labels():
    assert version_label(7) == "100 % 0°"
    assert version_label(17) == "flip 100 % +22.5°"
    with pytest.raises(ValueError, match="version"):
        version_label(18)


def test_retrieval_figure_a_mean_image_finds_itself(db):
    fid = 5
    axes = drawn(retrieval_figure(db, db.mean_images([fid])[0], k=3))
    assert len(axes) == 5  # query, its words, three candidates
    assert axes[2].get_title().startswith(f"#{fid} I = 1.00")
    with pytest.raises(ValueError, match="48, 48, 3"):
        retrieval_figure(db, np.zeros((40, 48, 3)))


def test_spectra_figure_one_row_per_fragment(db):
    axes = drawn(spectra_figure(db, [0, 4], labels=["a", "b"]))
    assert len(axes) == 1 + 2 * 5  # the spectra, then mean image + 4 levels a row
    assert [t.get_text() for t in axes[0].get_legend().get_texts()] == ["a", "b"]
    with pytest.raises(ValueError, match="labels must have one entry per fragment"):
        spectra_figure(db, [0, 4], labels=["a"])
    with pytest.raises(ValueError, match="1 to 6"):
        spectra_figure(db, list(range(7)))


def test_mean_image_mosaic_is_the_assigned_mean_images(assignment):
    a = assignment
    mosaic = mean_image_mosaic(a)
    h, w = a.target.shape
    assert mosaic.shape == (h, w, 3)
    # Where only one fragment covers a pixel (the canvas's top-left corner is the first
    # fragment's alone), the mosaic is that fragment's mean image.
    first = a.db.mean_images(a.fragments[:1])[0]
    r, c = a.target.positions[0]
    assert (r, c) == (0, 0)
    np.testing.assert_allclose(mosaic[:8, :8], first[:8, :8], atol=1e-5)


def test_motion_coherence_counts_agreeing_neighbours(assignment):
    a = assignment
    coh = motion_coherence(a)
    m = a.db.mean_motion[a.fragments].astype(np.float64)
    p, q = a.edges.T
    cos = (m[p] * m[q]).sum(1) / (np.linalg.norm(m[p], axis=1) * np.linalg.norm(m[q], axis=1))
    assert coh == pytest.approx(cos.mean())
    assert -1.0 <= coh <= 1.0
    # A drawn direction makes every fragment flow right: full agreement.
    stroke = np.array([[30.0, 5.0], [30.0, 80.0]])
    img, matte = a.target.image, a.target.matte
    right = assign(img, matte, a.db, FEW, direction=[stroke])
    assert motion_coherence(right) == pytest.approx(1.0, abs=0.02)


def test_assignment_figure_draws_clips_arrows_and_strokes(assignment):
    stroke = np.array([[30.0, 5.0], [30.0, 80.0]])
    fig = assignment_figure(assignment, strokes=[stroke], title="mine")
    ax = fig.get_axes()[0]
    assert ax.get_title() == "mine"
    names = {t.get_text() for t in ax.get_legend().get_texts()}
    used = set(assignment.db.clip_of(assignment.fragments).tolist())
    assert names == {assignment.db.clips[k]["name"] for k in used}
    drawn(fig)
    axes = drawn(assignment_figure(assignment, background="mosaic", arrows=False))
    assert "σ = 100" in axes[0].get_title()
    with pytest.raises(ValueError, match="background must be"):
        assignment_figure(assignment, background="paint")


def test_assignment_figure_into_given_axes(assignment):
    fig = Figure()
    ax = fig.subplots(1, 2)
    assert assignment_figure(assignment, ax=ax[1], legend=False) is fig
    assert ax[0].get_title() == ""
    assert ax[1].get_title() != ""
    drawn(fig)


def test_sweep_figure_reports_what_changed(assignment):
    other = assignment.resolve(lam=0.0)
    changed = np.mean(other.fragments != assignment.fragments)
    axes = drawn(sweep_figure({"base": assignment, "λ = 0": other}))
    assert len(axes) == 2
    assert axes[0].get_title().startswith("base\nchanged 0%")
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


def test_rendering_figure_has_the_six_stages(assignment):
    anim = render(assignment, AnimateParams(candidates=12, loop=2))
    axes = drawn(rendering_figure(anim, frame=1))
    assert len(axes) == 6
    t = titles(axes)
    assert "D_{1}" in t[1]
    assert "frame 1" in t[4]
    assert "τ = 0" in t[5]
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
