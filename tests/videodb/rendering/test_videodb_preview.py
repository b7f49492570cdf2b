"""A live preview frame of an assignment: one frame of what render makes, at low resolution."""

from dataclasses import dataclass

import numpy as np
import pytest

from fluidnb import Cancelled, data, param
from fluidnb.fields import downsample
from fluidnb.videodb import (
    AnimateParams,
    assign,
    prefetch_preview,
    preview_frame,
    render,
    starter_database,
)

SIZE = 160  # the stream photo at 160 px: 125 x 160
# The paper's rendering (where the library also offers the flow rendering).
PAPER = {"rendering": "paper"} if "rendering" in AnimateParams.specs() else {}


@dataclass(frozen=True)
class FlowParams(AnimateParams):
    """The flow rendering's two fields, for a library that does not have them yet."""

    rendering: str = param("flow", choices=("flow", "paper"), doc="the rendering")
    detail: float = param(0.5, lo=0, hi=4, doc="weight of the differences")


@pytest.fixture(scope="module")
def scene():
    db = starter_database("water", quick=True)
    photo = data.sample("stream", size=SIZE)
    matte = data.region("stream", size=SIZE)
    a = assign(photo, matte, db, AnimateParams(candidates=20, loop=0, **PAPER))
    return a, render(a).clip.frames


def test_at_full_size_it_is_the_renders_frame(scene):
    a, frames = scene
    n = a.db.params.N
    moved = np.abs(frames - a.target.image).mean(axis=(1, 2, 3))  # how much each frame moves
    for t in (0, n // 2, n - 1):
        out = preview_frame(a, frame=t, factor=1)
        assert out.shape == frames[t].shape
        assert out.dtype == np.float32
        error = np.abs(out - frames[t]).mean()
        # Close to its own frame (no context, 8-bit mean images), far from the others.
        assert error < 0.05 * moved[t], (t, error, moved[t])
        other = frames[(t + n // 2) % n]
        assert np.abs(out - other).mean() > 10 * error


def test_outside_the_matte_it_is_the_photo_exactly(scene):
    a, _ = scene
    # Shrunk by block means of the padded target (the canvas, in float32), then cut
    # to size.
    inside = downsample(a.target.canvas_matte, 2)[:63, :80] > 0
    out = preview_frame(a, factor=2)
    assert out.shape == (63, 80, 3)
    photo = np.clip(downsample(a.target.canvas, 2, precision="float32")[:63, :80], 0, 1)
    np.testing.assert_array_equal(out[~inside], photo[~inside])
    assert np.abs(out[inside] - photo[inside]).mean() > 1e-3  # the fluid is animated


def test_its_half_size_is_the_full_size_frame_shrunk(scene):
    a, frames = scene
    half = downsample(frames[a.db.params.N // 2][:124], 2)
    out = preview_frame(a, factor=2)[:62]
    photo = downsample(a.target.image[:124], 2)
    assert np.abs(out - half).mean() < 0.25 * np.abs(half - photo).mean()


def test_the_flow_rendering_keeps_the_photo_sharp_under_the_differences(scene):
    a, _ = scene
    params = FlowParams(**{**a.params.to_dict(), "rendering": "flow", "detail": 0.0})
    photo = np.clip(downsample(a.target.canvas, 2)[:63, :80], 0, 1)
    # No differences: the photo itself (histograms matched to themselves).
    np.testing.assert_allclose(preview_frame(a, params), photo, atol=2e-3)
    flow = preview_frame(a, params.replace(detail=1.0))
    inside = downsample(a.target.canvas_matte, 2)[:63, :80] > 0.5
    assert np.abs(flow[inside] - photo[inside]).mean() > 5e-3  # the differences show
    # The paper's blurs the photo along the motion: farther from it than the flow's.
    paper = preview_frame(a)
    assert (
        np.abs(paper[inside] - photo[inside]).mean() > np.abs(flow[inside] - photo[inside]).mean()
    )


def test_a_cache_rebuilds_only_new_fragments(scene, monkeypatch):
    a, _ = scene
    cache = {}
    first = preview_frame(a, cache=cache)
    assert fragments(cache) == set(a.fragments.tolist())
    reads = []
    real = type(a.db).clip_frames
    monkeypatch.setattr(
        type(a.db), "clip_frames", lambda *args, **kw: reads.append(1) or real(*args, **kw)
    )
    np.testing.assert_array_equal(preview_frame(a, cache=cache), first)
    assert reads == []
    other = a.resolve(lam=1e-4)  # looks alone: other fragments
    new = set(other.fragments.tolist()) - set(cache)
    assert new
    preview_frame(other, cache=cache)
    assert 0 < len(reads) <= len(new)
    assert set(other.fragments.tolist()) <= fragments(cache)


def test_prefetched_mean_images_give_the_same_previews_without_reading_them(scene, monkeypatch):
    a, _ = scene
    other = a.resolve(lam=1e-4)  # looks alone: other fragments, among the same candidates
    plain = preview_frame(other, cache={})
    cache = {}
    read = prefetch_preview(a, cache)
    assert read == len(np.unique(a.candidates))
    assert prefetch_preview(other, cache) == 0  # the same candidates: nothing more to read
    means = []
    real = type(a.db).mean_images
    monkeypatch.setattr(
        type(a.db), "mean_images", lambda *args, **kw: means.append(1) or real(*args, **kw)
    )
    np.testing.assert_allclose(preview_frame(other, cache=cache), plain, rtol=0, atol=1e-6)
    assert means == []  # one frame per fragment read, no mean image
    assert set(other.fragments.tolist()) <= fragments(cache)


def test_prefetch_preview_stops_when_asked_and_keeps_what_it_read(scene):
    a, _ = scene
    cache, seen = {}, []

    def stop(fraction, message):
        seen.append(fraction)
        raise Cancelled

    with pytest.raises(Cancelled):
        prefetch_preview(a, cache, progress=stop)
    assert len(seen) == 1
    kept = len(next(v for k, v in cache.items() if isinstance(k, tuple)))
    assert 0 < kept < len(np.unique(a.candidates))  # one clip's candidates
    assert prefetch_preview(a, cache) == len(np.unique(a.candidates)) - kept
    with pytest.raises(ValueError, match="assignment must be an Assignment"):
        prefetch_preview("a", {})
    with pytest.raises(ValueError, match="cache must be a dict"):
        prefetch_preview(a, None)


def fragments(cache):
    """The fragment ids a preview cache holds difference frames of."""
    return {k for k in cache if not isinstance(k, tuple)}


def test_a_cache_keeps_the_targets_own_pictures_for_its_target_only(scene, monkeypatch):
    import fluidnb.videodb.rendering._preview as module

    a, _ = scene
    cache = {}
    first = preview_frame(a, cache=cache)
    calls = []
    real = module.colour_axes
    monkeypatch.setattr(module, "colour_axes", lambda *x: calls.append(1) or real(*x))
    again = preview_frame(a.resolve(lam=a.params.lam), cache=cache)  # the same target
    np.testing.assert_array_equal(again, first)
    assert calls == []
    # Another target (the same photo, another matte) is not shown with this one's.
    h, w = a.target.shape
    matte = np.zeros((h, w), np.float32)
    matte[: h // 2] = 1
    b = assign(a.target.image, matte, a.db, a.params)
    np.testing.assert_array_equal(preview_frame(b, cache=cache), preview_frame(b))
    assert len(calls) == 2  # made once for b with the cache, once without


def test_bad_arguments_are_named(scene):
    a, _ = scene
    with pytest.raises(ValueError, match="assignment must be an Assignment"):
        preview_frame("a")
    with pytest.raises(ValueError, match="frame"):
        preview_frame(a, frame=a.db.params.N)
    with pytest.raises(ValueError, match="factor"):
        preview_frame(a, factor=0)


def test_its_one_level_blend_is_blend_differences_with_one_level(scene):
    # preview_frame adds the fragments with the blend's weights itself when levels=1.
    import fluidnb.videodb.rendering._preview as module
    from fluidnb.videodb.rendering import blend_differences

    a, _ = scene
    hc, wc = a.target.canvas.shape[:2]
    diffs = module._difference_frames(a.db, a.fragments, 4, {})
    still = module._target_constants(a.target, 1, {})
    d = module._weighted_sum(diffs, a.target.positions, still.weights, (hc, wc))
    blended = blend_differences(diffs[:, None], a.target.positions, (hc, wc), margin=0, levels=1)
    np.testing.assert_allclose(d, blended[0], rtol=0, atol=1e-6)
    assert np.abs(d).max() > 0.05


@pytest.mark.parametrize("factor", [2, 3, 4, 6, 8])
def test_its_small_blend_is_the_full_size_blend_in_block_means(scene, factor):
    # The one-level blend made at the preview's size at once (block means of each
    # weighted fragment, added on the small grid) is the full-size blend shrunk.
    import fluidnb.videodb.rendering._preview as module

    a, _ = scene
    hc, wc = a.target.canvas.shape[:2]
    diffs = module._difference_frames(a.db, a.fragments, 4, {})
    still = module._target_constants(a.target, 1, {})
    full = module._weighted_sum(diffs, a.target.positions, still.weights, (hc, wc))
    small = module._weighted_sum_shrunk(diffs, a.target.positions, still.weights, (hc, wc), factor)
    blocks = full.reshape(hc // factor, factor, wc // factor, factor).mean(axis=(1, 3))
    np.testing.assert_allclose(small, blocks, rtol=0, atol=1e-6)
    np.testing.assert_allclose(small, downsample(full, factor, precision="float32"), atol=1e-6)
    assert np.abs(small).max() > 0.02


def test_the_matching_to_the_photo_is_made_once_and_is_match_histograms_cells(scene):
    import fluidnb.videodb.rendering._preview as module
    from fluidnb.videodb.rendering import match_histograms_cells

    a, _ = scene
    still = module._target_constants(a.target, 2, {})
    rng = np.random.default_rng(3)
    frame = (still.in_axes + 0.05 * rng.standard_normal(still.in_axes.shape)).astype(np.float32)
    matching = still.matching(24)
    assert still.matching(24) is matching
    assert still.matching(12) is not matching
    got = matching.match(frame, np.empty_like(frame))
    want = match_histograms_cells(frame[None], still.in_axes, still.matte, cell=24)[0]
    np.testing.assert_array_equal(got, want)
    # The preview with its kept matching: the same with a cache and without one.
    cache = {}
    first = preview_frame(a, cache=cache)
    np.testing.assert_array_equal(preview_frame(a, cache=cache), first)
    np.testing.assert_array_equal(preview_frame(a), first)
