"""Rebuilding fragments' frames for rendering, and the database's frame cache."""

import json
import threading

import numpy as np
import pytest

from fluidnb.videodb import DatabaseParams, build_database, open_database
from fluidnb.videodb.database import FrameCache, reference_fragment_frames, sample_version
from fluidnb.videodb.database import _frames as frames_module
from fluidnb.videodb.database._frames import luminance
from tests.support.videodb_store import moving_texture

# All 18 versions (flips, 50/75/100 %, three angles): every resampling path.
PARAMS = DatabaseParams(N=8, augment="paper", words=8, codebook_samples=2000)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    clips = [
        ("right", moving_texture(1, shape=(120, 160), frames=16)),
        ("down", moving_texture(2, shape=(120, 160), frames=16, velocity=(1, 0))),
    ]
    path = tmp_path_factory.mktemp("frames") / "db"
    return build_database(clips, path, kind="water", params=PARAMS, seed=1)


@pytest.fixture
def db(built):
    """The store opened afresh: an empty cache."""
    return open_database(built.path)


def spread(db, per_version=2):
    """A few fragments of every version the database holds, of both clips."""
    ids = []
    for version in np.unique(db.source[:, 1]):
        ids += np.flatnonzero(db.source[:, 1] == version)[::7][:per_version].tolist()
    return np.array(ids)


def test_rebuilt_fragments_are_sample_version_of_the_frames_bit_for_bit(db):
    ids = spread(db)
    versions = set(np.unique(db.source[ids, 1]).tolist())
    assert len(versions) >= 12  # the 50 % ones turned by 22.5 degrees do not fit this clip
    assert versions & {1, 3, 4, 5}  # prefiltered (50, 75 %)
    assert 7 in versions  # the clip itself
    n = db.params.N
    for margin in (0, 12):
        grey = db.fragment_frames(ids, margin=margin, grey=True)
        colour = db.fragment_frames(ids, margin=margin)
        side = 48 + 2 * margin
        for i, fid in enumerate(ids):
            clip, version, start, row, col = (int(v) for v in db.source[fid])
            window = db.clip_frames(clip, start, start + n)
            where = {"origin": (row - margin, col - margin), "size": (side, side)}
            want = np.clip(sample_version(luminance(window), version, **where), 0, 1)
            assert np.array_equal(grey[i], want)
            want = sample_version(window.astype(np.float32) / 255.0, version, **where)
            assert np.array_equal(colour[i], np.clip(want, 0, 1))


def test_fragments_prefiltered_together_are_the_ones_prefiltered_alone(db, monkeypatch):
    # Fragments of one start and one prefilter are blurred together on the rectangle
    # around theirs: the same frames bit for bit, with fewer blurs.
    from fluidnb.videodb.database import _frames

    ids = spread(db, per_version=12)
    blurs = []
    real = _frames._blur
    monkeypatch.setattr(_frames, "_blur", lambda *a: blurs.append(1) or real(*a))
    grey = db.fragment_frames(ids, margin=12, grey=True)
    scaled = np.isin(db.source[ids, 1], [1, 3, 4, 5])  # prefiltered (50, 75 %)
    assert 0 < len(blurs) < scaled.sum()
    n = db.params.N
    for i, fid in enumerate(ids):
        clip, version, start, row, col = (int(v) for v in db.source[fid])
        window = db.clip_frames(clip, start, start + n)
        where = {"origin": (row - 12, col - 12), "size": (72, 72)}
        want = np.clip(sample_version(luminance(window), version, **where), 0, 1)
        assert np.array_equal(grey[i], want)


def test_rebuilt_fragments_match_the_reference_to_float32_round_off(db):
    # Mutation caught: the rebuild's luminance weighting blue as green (_to_planes).
    ids = spread(db, per_version=1)[::2]
    for grey in (True, False):
        fast = db.fragment_frames(ids, margin=12, grey=grey)
        slow = reference_fragment_frames(db, ids, margin=12, grey=grey)
        assert fast.shape == slow.shape
        np.testing.assert_allclose(fast, slow, rtol=0, atol=2e-6)


def test_luminance_is_the_rec709_weights_element_by_element():
    gen = np.random.default_rng(0)
    frames = gen.integers(0, 256, (3, 17, 23, 3), dtype=np.uint8)
    grey = luminance(frames)
    exact = frames.astype(np.float64) @ [0.2125, 0.7154, 0.0721] / 255
    np.testing.assert_allclose(grey, exact, rtol=0, atol=2e-7)
    # A pixel's value does not depend on the array it is converted with.
    assert np.array_equal(luminance(frames[:, 5:9, 2:3]), grey[:, 5:9, 2:3])
    with pytest.raises(ValueError, match="uint8 RGB"):
        luminance(frames.astype(np.float32))


def test_each_fragment_is_rebuilt_once_from_the_frames_it_needs(db, monkeypatch):
    reads = []
    real = frames_module._read_frames

    def counting(db, clip, start, stop):
        reads.append((clip, start, stop))
        return real(db, clip, start, stop)

    monkeypatch.setattr(frames_module, "_read_frames", counting)
    n = db.params.N
    src = db.source
    # Fragments of one clip's first window, some asked for twice.
    ids = np.flatnonzero((src[:, 0] == 1) & (src[:, 2] == 0))[:5]
    asked = np.concatenate([ids, ids[::-1]])
    out = db.fragment_frames(asked, margin=12, grey=True)
    assert reads == [(1, 0, n)]  # that window's frames, read once
    assert db.cache.misses == 5
    np.testing.assert_array_equal(out[:5], out[5:][::-1])
    # Again: from the cache, nothing read.
    again = db.fragment_frames(asked, margin=12, grey=True)
    assert reads == [(1, 0, n)]
    assert db.cache.hits == 5
    np.testing.assert_array_equal(again, out)
    # Another fragment of the same window: its frames are cached too.
    other = np.flatnonzero((src[:, 0] == 1) & (src[:, 2] == 0))[5:6]
    db.fragment_frames(other, margin=12, grey=True)
    assert reads == [(1, 0, n)]
    # Both windows of a clip: only the frames not yet read, in one run.
    later = np.flatnonzero((src[:, 0] == 1) & (src[:, 2] == n))[:2]
    db.fragment_frames(later, margin=12, grey=True)
    assert reads == [(1, 0, n), (1, n, 2 * n)]


def test_the_returned_frames_are_the_callers_and_the_cache_is_read_only(db):
    ids = spread(db)[:3]
    first = db.fragment_frames(ids, grey=True)
    first[:] = 7.0  # the caller's copy
    np.testing.assert_array_less(db.fragment_frames(ids, grey=True), 1.0 + 1e-6)
    key = (int(ids[0]), 0, True)
    with pytest.raises(ValueError, match="read-only"):
        db.cache._fragments[key][0, 0, 0] = 1.0


def test_the_cache_keeps_to_its_bound_fragments_before_frames(db):
    ids = spread(db)
    one = 8 * 72 * 72 * 4  # a fragment of N = 8 frames with margin 12, grey
    frame = 120 * 160 * 3
    db.cache.max_bytes = 4 * one + frame + 1000
    db.fragment_frames(ids[:6], margin=12, grey=True)
    cache = db.cache
    assert cache.nbytes <= cache.max_bytes
    # The frames went first: the four most recent fragments are kept.
    assert len(cache._fragments) == 4
    assert len(cache._frames) <= 1
    assert cache.nbytes == sum(a.nbytes for a in cache._fragments.values()) + sum(
        a.nbytes for a in cache._frames.values()
    )
    kept = db.fragment_frames(ids[:6], margin=12, grey=True)
    cache.max_bytes = 0  # keeps nothing, and still rebuilds
    assert cache.nbytes == 0
    np.testing.assert_array_equal(db.fragment_frames(ids[:6], margin=12, grey=True), kept)
    assert cache.nbytes == 0
    with pytest.raises(ValueError, match="max_bytes must be an integer >= 0"):
        cache.max_bytes = -1


def test_the_cache_is_emptied_when_the_store_changes(db):
    ids = spread(db)[:4]
    before = db.fragment_frames(ids, grey=True)
    assert len(db.cache._fragments) == 4
    manifest = db.path / "manifest.json"
    text = manifest.read_text()
    # Rewritten with the same content: the same store, the cache stays.
    manifest.write_text(text)
    db.fragment_frames(ids[:1], grey=True)
    assert len(db.cache._fragments) == 4
    try:
        # Another manifest (as after adding clips or rebuilding): emptied, reopened.
        data = json.loads(text)
        data["note"] = "changed"
        manifest.write_text(json.dumps(data))
        after = db.fragment_frames(ids[:1], grey=True)
        assert len(db.cache._fragments) == 1
        assert db.cache.misses == 1
        np.testing.assert_array_equal(after, before[:1])
    finally:
        manifest.write_text(text)


def test_threads_rebuilding_at_once_get_the_same_frames(db):
    ids = spread(db)
    want = reference_fragment_frames(db, ids[:4], margin=12, grey=True)
    results, errors = {}, []

    def work(k):
        try:
            got = db.fragment_frames(np.roll(ids, 3 * k), margin=12, grey=True)
            results[k] = np.roll(got, -3 * k, axis=0)  # back in the order of ids
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for k in range(1, 4):
        np.testing.assert_array_equal(results[k], results[0])
    np.testing.assert_allclose(results[0][:4], want, atol=2e-6)


def test_the_cache_is_owned_by_the_database(built):
    a, b = open_database(built.path), open_database(built.path)
    assert isinstance(a.cache, FrameCache)
    assert a.cache is not b.cache
    assert "FrameCache(0 fragments" in repr(a.cache)
    a.fragment_frames([0], grey=True)
    assert len(a.cache._fragments) == 1
    assert len(b.cache._fragments) == 0
    a.cache.clear()
    assert a.cache.nbytes == 0
    assert a.cache.max_bytes == frames_module.CACHE_BYTES


def test_a_render_from_the_reference_frames_differs_only_by_round_off(built, monkeypatch):
    """The render's rebuild against the plain version: the same animation to round-off.

    The rebuilt frames differ from the reference's by float32 round-off (2e-6); the
    blended differences by as little; histogram matching counts pixels into bins, so a
    value moving across a bin edge shifts a cell's map a little: the frames stay within
    1e-3 (a quarter of an 8-bit level).
    """
    from fluidnb.videodb import AnimateParams, assign, render
    from fluidnb.videodb.rendering import _render as render_module

    db = open_database(built.path)
    gen = np.random.default_rng(5)
    photo = moving_texture(7, shape=(96, 120), frames=1)[0]
    photo = np.clip(photo + 0.05 * gen.random(photo.shape), 0, 1).astype(np.float32)
    a = assign(photo, None, db, AnimateParams(candidates=10, loop=2, rendering="paper"))
    fast = render(a)

    def plain(db, ids, *, margin, grey, differences=None, progress=None):
        from fluidnb.videodb.database._differences import difference_frames

        frames = reference_fragment_frames(db, np.unique(ids), margin=margin, grey=grey)
        if differences is not None:
            frames = [difference_frames(f, differences) for f in frames]
        return dict(zip(np.unique(ids).tolist(), frames))

    monkeypatch.setattr(render_module, "rebuild_fragments", plain)
    slow = render(a)
    d_fast, d_slow = fast.stages["differences"], slow.stages["differences"]
    assert np.abs(d_slow).max() > 0.01  # it moves
    np.testing.assert_allclose(d_fast, d_slow, rtol=0, atol=2e-6)
    np.testing.assert_allclose(fast.clip.frames, slow.clip.frames, rtol=0, atol=1e-3)


def test_frames_decoded_directly_equal_zarrs_and_bad_chunks_go_to_zarr(db, tmp_path):
    n = db.params.N
    arr = db._array(db._group(), 0, "frames")
    assert frames_module._direct_codecs(arr) is True  # bytes, blosc, crc32c
    direct = frames_module._read_frames(db, 0, 3, 3 + n)
    np.testing.assert_array_equal(direct, arr[3 : 3 + n])
    # A chunk that fails its checksum, or is not one frame, is not decoded here.
    file = sorted((db.path / "clips/00000/frames/c").rglob("*"))
    file = next(p for p in file if p.is_file())
    data = bytearray(file.read_bytes())
    frame = np.empty(arr.shape[1:], np.uint8)
    assert frames_module._decode(file, frame, True)
    bad = tmp_path / "bad"
    bad.write_bytes(bytes(data[:-5]) + bytes(data[-4:]))  # truncated, checksum kept
    assert not frames_module._decode(bad, frame, True)
    data[100] ^= 0xFF
    bad.write_bytes(bytes(data))
    assert not frames_module._decode(bad, frame, True)
    assert not frames_module._decode(tmp_path / "missing", frame, True)
    assert not frames_module._decode(file, np.empty(7, np.uint8), True)  # another size


@pytest.mark.parametrize("rendering", ["paper", "flow"])
def test_the_renders_differences_are_staggers_blended(built, rendering):
    """The compiled loops (difference_frames, play_loops) against stagger and the blend."""
    from fluidnb.videodb import AnimateParams, assign, render
    from fluidnb.videodb.rendering import blend_differences, stagger

    db = open_database(built.path)
    photo = moving_texture(8, shape=(96, 120), frames=1)[0]
    params = AnimateParams(candidates=10, loop=3, rendering=rendering)
    a = assign(photo, None, db, params)
    anim = render(a)
    frames = db.fragment_frames(a.fragments, margin=12, grey=True)
    diffs = frames - frames.mean(axis=1, keepdims=True)
    st = anim.stages
    timing = {}
    if rendering == "flow":
        from fluidnb.videodb.rendering._render import _flow_plan

        plan = _flow_plan(a, a.params, db.params.N)
        if not np.all(plan["rates"] == 1):  # the detail plays at the painted speed
            timing = {"rates": plan["rates"], "n_frames": plan["n_frames"]}
    looped = stagger(diffs, st["offsets"], overlap=3, mirrors=st["mirrors"], **timing)
    canvas = a.target.canvas.shape[:2]
    blended = blend_differences(looped, a.target.positions, canvas, margin=12)
    h, w = a.target.shape
    got = st["differences"][: len(blended)]
    np.testing.assert_allclose(got, blended[:, :h, :w], rtol=0, atol=1e-6)


def test_a_render_keeps_the_fragments_differences_for_the_next(built):
    from fluidnb.videodb import AnimateParams, assign, render

    db = open_database(built.path)
    photo = moving_texture(9, shape=(96, 120), frames=1)[0]
    a = assign(photo, None, db, AnimateParams(candidates=10, loop=2, rendering="paper"))
    first = render(a)
    n = len(np.unique(a.fragments))
    assert db.cache.misses == n
    keys = list(db.cache._fragments)
    assert all(k[2:] == (True, "differences", 2) for k in keys)  # what the blend reads
    again = render(a)
    assert db.cache.hits == n  # nothing rebuilt
    assert np.array_equal(again.clip.frames, first.clip.frames)
    with pytest.raises(ValueError, match="grey"):
        frames_module.rebuild_fragments(db, a.fragments, margin=12, grey=False, differences=2)
