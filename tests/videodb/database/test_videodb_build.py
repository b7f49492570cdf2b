"""Building, resuming, growing and opening video databases (Okabe et al., sec. 4)."""

import json

import numpy as np
import pytest

from fluidnb import Cancelled, Clip
from fluidnb.videodb import add_clips, build_database, open_database, read_video
from fluidnb.videodb.database import _pipeline as build_module
from tests.support.videodb_store import PARAMS, moving_texture, sources, store_bytes


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = tmp_path_factory.mktemp("db") / "store"
    db = build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=2)
    return db


def test_build_records_what_went_in(built):
    db = built
    assert db.kind == "water"
    assert [c["name"] for c in db.clips] == ["right", "down"]
    # 2 clips x 2 versions (clip, mirror) x 2 windows x (2 x 3) fragments, all moving.
    assert db.n_fragments == 2 * 2 * 2 * 6
    assert db.codebook.shape == (8, 128)
    assert db.words.shape == (db.n_fragments, 9, 9)
    assert db.spectra.shape == (db.n_fragments, PARAMS.n_bins, 2, 12, 12)
    assert db.texture.shape == (db.n_fragments, 4, 24, 24)
    assert db.motion.shape == (db.n_fragments, PARAMS.N - 1, 2)
    manifest = json.loads((db.path / "manifest.json").read_text())
    assert manifest["format"] == "fluidnb.videodb"
    assert manifest["params"] == PARAMS.to_dict()
    assert all(c["sha256"].startswith("sha256:") for c in manifest["clips"])
    assert not (db.path / "build").exists()


def test_the_built_database_is_the_one_that_opens(built):
    # build_database makes the database it returns of the arrays it read back for the
    # manifest's checksums, not by opening the folder: the same database.
    opened = open_database(built.path)
    for name in ("words", "mean_motion", "motion", "spectra", "texture", "source"):
        a, b = getattr(built, name), getattr(opened, name)
        assert a.dtype == b.dtype, name
        assert a.shape == b.shape, name
        assert np.array_equal(a, b), name
        assert not a.flags.writeable, name
    assert built.manifest == opened.manifest
    assert built.clips == opened.clips
    assert np.array_equal(built.codebook, opened.codebook)
    assert built.params == opened.params
    assert built.kind == opened.kind


def test_mean_motion_follows_the_clip_and_its_mirror(built):
    db = built
    right = db.source[:, 0] == 0
    mirrored = db.source[:, 1] == 16
    # The texture moves 1 px/frame to the right; its mirror image to the left.
    np.testing.assert_allclose(db.mean_motion[right & ~mirrored], [[0, 1]] * 12, atol=0.15)
    np.testing.assert_allclose(db.mean_motion[right & mirrored], [[0, -1]] * 12, atol=0.15)
    down = db.source[:, 0] == 1
    np.testing.assert_allclose(db.mean_motion[down], [[1, 0]] * 24, atol=0.15)
    # Spectra: the DC bin is the signed mean motion (mirrored: to the left), and a
    # steady motion has no power at the other frequencies.
    dc = db.spectra[right][:, 0].astype(np.float64).mean(axis=(2, 3))
    np.testing.assert_allclose(dc[~mirrored[right]], [[0, 1]] * 12, atol=0.15)
    np.testing.assert_allclose(dc[mirrored[right]], [[0, -1]] * 12, atol=0.15)
    assert np.abs(db.spectra[right][:, 1:].astype(np.float64)).mean() < 0.02


def test_fragments_rebuild_from_their_source(built):
    db = built
    ids = np.array([0, 7, db.n_fragments - 1])
    frames = db.fragment_frames(ids)
    assert frames.shape == (3, PARAMS.N, 48, 48, 3)
    stored = db.mean_images(ids)
    # The stored mean image is the rounded mean of the same frames.
    assert np.abs(frames.mean(axis=1) - stored).max() <= 1 / 255 + 1e-6
    # With a margin, the fragment is the centre of the larger crop.
    wide = db.fragment_frames(ids, margin=6)
    np.testing.assert_array_equal(wide[:, :, 6:-6, 6:-6], frames)


def test_a_stored_mean_image_describes_itself(built):
    db = built
    ids = np.arange(0, db.n_fragments, 5)
    np.testing.assert_array_equal(db.describe(db.mean_images(ids)), db.words[ids])


def test_building_twice_gives_the_same_store(built, tmp_path):
    again = build_database(sources(), tmp_path / "again", kind="water", params=PARAMS, seed=3)
    assert store_bytes(again.path) == store_bytes(built.path)


def test_an_interrupted_build_resumes_to_the_same_store(built, tmp_path, monkeypatch):
    real = build_module._process_clip

    def failing(root, index, *args):
        if index == 1:
            raise RuntimeError("worker died")
        return real(root, index, *args)

    monkeypatch.setattr(build_module, "_process_clip", failing)
    path = tmp_path / "resumed"
    with pytest.raises(RuntimeError, match="worker died"):
        build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=1)
    # Half-built: it does not open, and a plain build refuses the folder.
    with pytest.raises(ValueError, match="unfinished build"):
        open_database(path)
    with pytest.raises(ValueError, match="resume=True"):
        build_database(sources(), path, kind="water", params=PARAMS, seed=3)
    monkeypatch.setattr(build_module, "_process_clip", real)
    db = build_database(sources(), path, kind="water", params=PARAMS, seed=3, resume=True)
    assert store_bytes(db.path) == store_bytes(built.path)


def test_a_cancelled_build_resumes(built, tmp_path):
    def cancel_after_first_clip(fraction, message):
        if "1/2 clips done" in message:
            raise Cancelled("stop")

    path = tmp_path / "cancelled"
    with pytest.raises(Cancelled):
        build_database(
            sources(),
            path,
            kind="water",
            params=PARAMS,
            seed=3,
            workers=1,
            progress=cancel_after_first_clip,
        )
    db = build_database(sources(), path, kind="water", params=PARAMS, seed=3, resume=True)
    assert store_bytes(db.path) == store_bytes(built.path)


def test_resume_refuses_other_sources(tmp_path, monkeypatch):
    real = build_module._process_clip
    monkeypatch.setattr(
        build_module, "_process_clip", lambda *a: (_ for _ in ()).throw(RuntimeError("x"))
    )
    path = tmp_path / "db"
    with pytest.raises(RuntimeError):
        build_database(sources(), path, kind="water", params=PARAMS, workers=1)
    monkeypatch.setattr(build_module, "_process_clip", real)
    other = [("other", moving_texture(9)), sources()[1]]
    with pytest.raises(ValueError, match="not the clip the interrupted build had"):
        build_database(other, path, kind="water", params=PARAMS, resume=True)
    with pytest.raises(ValueError, match="other settings"):
        build_database(sources(), path, kind="smoke", params=PARAMS, resume=True)


@pytest.mark.slow
def test_a_dask_distributed_cluster_builds_the_same_store(built, tmp_path):
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        db = build_database(
            sources(), tmp_path / "cluster", kind="water", params=PARAMS, seed=3, client=client
        )
    assert store_bytes(db.path) == store_bytes(built.path)


def test_adding_a_clip_keeps_the_codebook(built, tmp_path):
    import shutil

    path = tmp_path / "grow"
    shutil.copytree(built.path, path)
    grown = add_clips(path, [("up", moving_texture(5, velocity=(-1, 0)))])
    assert [c["name"] for c in grown.clips] == ["right", "down", "up"]
    np.testing.assert_array_equal(grown.codebook, built.codebook)
    n = built.n_fragments
    assert grown.n_fragments == n + 24
    np.testing.assert_array_equal(grown.words[:n], built.words)
    np.testing.assert_allclose(
        grown.mean_motion[n:][grown.source[n:, 1] == 7], [[-1, 0]] * 12, atol=0.15
    )
    with pytest.raises(ValueError, match="same clip as 'up'"):
        add_clips(path, [("again", moving_texture(5, velocity=(-1, 0)))])


def test_the_same_clip_twice_is_refused(tmp_path):
    clip = moving_texture(1)
    with pytest.raises(ValueError, match="same clip"):
        build_database([clip, clip], tmp_path / "db", kind="water", params=PARAMS)


@pytest.mark.parametrize(
    ("name", "frames", "reason"),
    [
        ("still", np.repeat(moving_texture(1)[:1], 20, axis=0), "no moving"),
        ("grey", np.full((20, 72, 96, 3), 0.5, np.float32), "no moving"),
        ("tiny", moving_texture(1, shape=(10, 10)), "smaller than a fragment"),
        ("short", moving_texture(1, frames=3), "no moving"),
    ],
)
def test_clips_that_give_no_fragment_are_reported_and_leave_nothing(tmp_path, name, frames, reason):
    path = tmp_path / name
    with pytest.raises(ValueError, match=f"no fragment.*{reason}"):
        build_database([(name, frames)], path, kind="water", params=PARAMS)
    assert not path.exists()  # nothing half-written is left to open


def test_a_clip_without_fragments_is_kept_with_a_note(tmp_path):
    still = ("still", np.repeat(moving_texture(3)[:1], 20, axis=0))
    db = build_database([still, sources()[0]], tmp_path / "db", kind="water", params=PARAMS)
    assert [c["fragments"] for c in db.clips] == [0, 24]
    assert "no fragment" in db.clips[0]["note"]
    assert (db.source[:, 0] == 1).all()


def test_unreadable_sources_give_clear_errors(tmp_path):
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(b"not a video")
    with pytest.raises(ValueError, match=r"broken\.mp4"):
        build_database([bad], tmp_path / "db1", kind="water", params=PARAMS)
    with pytest.raises(ValueError, match="no such file"):
        build_database([tmp_path / "missing.mp4"], tmp_path / "db2", kind="water")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="holds no image frames"):
        build_database([tmp_path / "empty"], tmp_path / "db3", kind="water")
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match=r"unknown video extension '\.txt'"):
        build_database([tmp_path / "notes.txt"], tmp_path / "db5", kind="water")
    with pytest.raises(ValueError, match="kind"):
        build_database(sources(), tmp_path / "db4", kind="")


def test_build_refuses_an_existing_database_or_a_full_folder(built, tmp_path):
    with pytest.raises(ValueError, match="already holds a video database"):
        build_database(sources(), built.path, kind="water", params=PARAMS)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty"):
        build_database(sources(), tmp_path / "full", kind="water", params=PARAMS)
    assert (tmp_path / "full" / "notes.txt").read_text() == "mine"


def test_damaged_stores_give_errors_naming_the_file(built, tmp_path):
    import shutil

    def copy(name):
        dst = tmp_path / name
        shutil.copytree(built.path, dst)
        return dst

    p = copy("version")
    m = json.loads((p / "manifest.json").read_text())
    m["version"] = 99
    (p / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match="format version 99"):
        open_database(p)

    p = copy("garbled")
    (p / "manifest.json").write_text("{ not json")
    with pytest.raises(ValueError, match=r"manifest\.json.*corrupt"):
        open_database(p)

    p = copy("truncated")
    chunk = p / "clips/00000/spectra/c/0/0/0/0/0"
    chunk.write_bytes(chunk.read_bytes()[:100])
    with pytest.raises(ValueError, match=r"clips/00000/spectra/c/0/0/0/0/0"):
        open_database(p)

    p = copy("missing")
    shutil.rmtree(p / "clips/00001/texture")
    with pytest.raises(ValueError, match=r"clips/00001/texture.*missing"):
        open_database(p)

    p = copy("changed")
    m = json.loads((p / "manifest.json").read_text())
    m["clips"][0]["checksum"] = "sha256:0"
    (p / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match="checksum"):
        open_database(p)


def test_read_video_reads_files_folders_and_clips(tmp_path):
    frames = moving_texture(4, shape=(50, 60), frames=6)
    clip = Clip(frames, fps=12)
    clip.save(tmp_path / "c.mp4")
    clip.save(tmp_path / "c.gif")
    clip.save(tmp_path / "folder")
    for source in (tmp_path / "c.mp4", tmp_path / "c.gif", tmp_path / "folder", clip, frames):
        v = read_video(source)
        assert v.frames.shape == (6, 50, 60, 3)
        assert v.frames.dtype == np.uint8
    assert read_video(tmp_path / "c.gif").fps == pytest.approx(12, rel=0.1)
    webm = _encode_webm(tmp_path / "c.webm", clip)
    v = read_video(webm)
    assert v.frames.shape == (6, 50, 60, 3)
    assert v.sha256.startswith("sha256:")
    # A large video is scaled by ffmpeg on the way in.
    assert read_video(webm, max_side=30).frames.shape == (6, 25, 30, 3)
    big = read_video(moving_texture(4, shape=(100, 200), frames=2), max_side=100)
    assert big.frames.shape == (2, 50, 100, 3)
    assert big.scaled == 0.5


def test_a_clips_frames_are_converted_to_8_bits_as_to_uint8_does():
    # read_video converts a Clip's float32 frames with a one-pass kernel: it must give
    # to_uint8's bytes (the stored frames and the clips' SHA-256), rounding ties and
    # values outside [0, 1] included.
    from fluidnb import to_uint8
    from fluidnb.videodb.database._video import _clip_uint8

    gen = np.random.default_rng(4)
    ties = (np.arange(256, dtype=np.float32) - np.float32(0.5)) / np.float32(255)
    near = np.concatenate([np.nextafter(ties, -1), ties, np.nextafter(ties, 2)])
    values = np.concatenate(
        [near, gen.uniform(-0.3, 1.3, 30_000), [0.0, -0.0, 1.0, np.inf, -np.inf, 1e30, -1e-30]]
    ).astype(np.float32)
    assert np.array_equal(_clip_uint8(values), to_uint8(values))
    frames = gen.random((3, 5, 7, 3)).astype(np.float32)
    for arr in (frames, frames[..., 0], frames[:, ::2, ::-1]):  # RGB, grey, strided
        assert np.array_equal(_clip_uint8(arr), to_uint8(arr))
    clip = Clip(frames)
    assert np.array_equal(read_video(clip).frames, to_uint8(frames))


def _encode_webm(path, clip):
    """A WebM (VP9) file, as a user's browser recording would be."""
    import subprocess

    import imageio_ffmpeg

    frames = clip.to_uint8()
    h, w = frames.shape[1:3]
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-y"]
    cmd += ["-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", "12", "-i", "pipe:0"]
    cmd += ["-c:v", "libvpx-vp9", "-pix_fmt", "yuv420p", str(path)]
    subprocess.run(cmd, input=frames.tobytes(), check=True, capture_output=True)
    return path


def test_background_import_thread_is_joined_at_shutdown():
    # A daemon thread still inside an import of a compiled extension when the
    # interpreter shuts down (a build stopped with Ctrl-C) can crash the process; the
    # codebook's early import runs on a thread the interpreter waits for.
    thread = build_module._import_in_background("json", "no_such_module_fluidnb")
    assert thread.name == "fluidnb-import"
    assert not thread.daemon
    thread.join(timeout=30)
    assert not thread.is_alive()  # a module that fails to import is skipped, not fatal
