"""Damaged chunks of a video database: found, named, never read as zeros or garbage."""

import json
import re
import shutil

import numpy as np
import pytest
import zarr
from PIL import Image
from scipy import ndimage as ndi

from fluidnb import to_uint8
from fluidnb.cli import main
from fluidnb.videodb import (
    AnimateParams,
    add_clips,
    animate,
    build_database,
    open_database,
    starter_path,
    verify_database,
)
from fluidnb.videodb.database._format import CHUNK, RAM_ARRAYS
from tests.support.videodb_store import PARAMS, chunk_files, moving_texture, sources

FEW = AnimateParams(candidates=10, loop=2)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = tmp_path_factory.mktemp("chunks") / "db"
    return build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=2)


@pytest.fixture(scope="module")
def photo():
    gen = np.random.default_rng(4)
    img = ndi.gaussian_filter(gen.random((60, 80)), 2.0)
    img = (img - img.min()) / (img.max() - img.min())
    matte = np.zeros((60, 80), np.float32)
    matte[8:52, 10:70] = 1.0
    return np.stack([img] * 3, axis=-1).astype(np.float32), matte


def copy(built, tmp_path, name="db"):
    return shutil.copytree(built.path, tmp_path / name)


def damage(file, how):
    """Flip a byte in the middle, cut the file in half, or delete it."""
    data = file.read_bytes()
    if how == "flip":
        b = bytearray(data)
        b[len(b) // 2] ^= 0x5A
        file.write_bytes(bytes(b))
    elif how == "truncate":
        file.write_bytes(data[: len(data) // 2])
    else:
        file.unlink()


WHAT = {"flip": "cannot be read: its checksum does not match", "truncate": "cannot be read"}
WHAT["delete"] = "is missing"


@pytest.mark.parametrize("how", ["flip", "truncate", "delete"])
@pytest.mark.parametrize("array", RAM_ARRAYS)
def test_a_damaged_in_memory_array_is_refused_at_open_naming_the_chunk(built, tmp_path, array, how):
    path = copy(built, tmp_path)
    file = chunk_files(path, f"clips/00001/{array}")[0]
    damage(file, how)
    message = rf"chunk 0 of clips/00001/{array} {WHAT[how]}.*{file.relative_to(path)}"
    with pytest.raises(ValueError, match=message):
        open_database(path)
    assert len(verify_database(path)) == 1


@pytest.mark.parametrize("how", ["flip", "truncate", "delete"])
def test_a_damaged_frame_is_refused_when_it_is_needed(built, tmp_path, how):
    path = copy(built, tmp_path)
    frame = 3
    file = chunk_files(path, "clips/00000/frames")[frame]
    damage(file, how)
    db = open_database(path)  # the frames are read on demand
    src = db.source
    window = (src[:, 2] <= frame) & (frame < src[:, 2] + db.params.N)
    uses = np.flatnonzero((src[:, 0] == 0) & window)
    others = np.flatnonzero(src[:, 0] == 1)
    db.fragment_frames(others[:3])  # the other clip's frames are intact
    with pytest.raises(ValueError, match=rf"chunk {frame} of clips/00000/frames {WHAT[how]}"):
        db.fragment_frames(uses[:1])
    with pytest.raises(ValueError, match=rf"{path}.* is damaged.*rebuild"):
        db.clip_frames(0)
    problems = verify_database(path)
    assert len(problems) == 1
    assert f"chunk {frame} of clips/00000/frames" in problems[0]


@pytest.mark.parametrize("how", ["flip", "truncate", "delete"])
def test_a_damaged_mean_image_is_refused_when_it_is_needed(built, tmp_path, how):
    path = copy(built, tmp_path)
    damage(chunk_files(path, "clips/00001/mean")[0], how)
    db = open_database(path)
    first = db.clips[1]["first"]
    db.mean_images([0, first - 1])  # clip 0's are intact
    with pytest.raises(ValueError, match=rf"chunk 0 of clips/00001/mean {WHAT[how]}"):
        db.mean_images([0, first])


def animate_cli(path, tmp_path, photo, capsys, out="o.npz"):
    """`fluidnb animate` of the photo on the database ``path``: (status, its error lines)."""
    img, matte = photo
    Image.fromarray(to_uint8(img)).save(tmp_path / "photo.png")
    Image.fromarray(to_uint8(matte)).save(tmp_path / "matte.png")
    argv = ["animate", str(tmp_path / "photo.png"), "--matte", str(tmp_path / "matte.png")]
    argv += ["--db", str(path), "--candidates", "10", "--loop", "2", "-o", str(tmp_path / out)]
    status = main(argv)
    err = capsys.readouterr().err  # the progress bar, then one line
    assert "Traceback" not in err
    return status, [line for line in err.splitlines() if "error:" in line]


def test_deleted_frames_stop_animate_with_one_line(built, tmp_path, photo, capsys):
    """The issue's case: every frames chunk deleted, animate exited 0 with other frames."""
    path = copy(built, tmp_path)
    for clip in ("00000", "00001"):
        for file in chunk_files(path, f"clips/{clip}/frames"):
            file.unlink()
    status, errors = animate_cli(path, tmp_path, photo, capsys)
    assert status == 2
    assert len(errors) == 1
    assert "frames is missing" in errors[0]
    assert not (tmp_path / "o.npz").exists()


def swap(a, b):
    """Exchange two files' bytes (two chunks, each intact, each in the other's place)."""
    a_bytes, b_bytes = a.read_bytes(), b.read_bytes()
    a.write_bytes(b_bytes)
    b.write_bytes(a_bytes)


@pytest.mark.parametrize("array", ["frames", "mean", "words", "spectra"])
def test_a_chunk_swapped_between_clips_is_refused_naming_both_places(built, tmp_path, array):
    """Issue 37: each chunk's checksum covered only its bytes, so a swap passed --verify."""
    path = copy(built, tmp_path)
    i = 3 if array == "frames" else 0
    here, there = (chunk_files(path, f"clips/{c}/{array}")[i] for c in ("00000", "00001"))
    assert here.read_bytes() != there.read_bytes()
    swap(here, there)
    problems = verify_database(path)
    assert len(problems) == 2, problems
    for line, (a, b) in zip(problems, [("00000", "00001"), ("00001", "00000")]):
        assert f"chunk {i} of clips/{a}/{array} is not the chunk written there" in line
        assert f"it holds chunk {i} of clips/{b}/{array}" in line
        assert "rebuild" in line
    if array in RAM_ARRAYS:
        with pytest.raises(ValueError, match=rf"chunk 0 of clips/00000/{array} is not the chunk"):
            open_database(path)
        return
    db = open_database(path)
    read = db.clip_frames if array == "frames" else db.mean_images
    rows = 0 if array == "frames" else [0, db.clips[1]["first"]]
    with pytest.raises(ValueError, match=rf"chunk {i} of clips/00000/{array} is not the chunk"):
        read(rows)


@pytest.mark.parametrize("array", ["frames", "mean"])
def test_chunks_swapped_between_clips_stop_animate_and_verify(
    built, tmp_path, photo, capsys, array
):
    """The issue's case: every frames (or mean) chunk of two clips swapped."""
    path = copy(built, tmp_path)
    for here, there in zip(*(chunk_files(path, f"clips/{c}/{array}") for c in ("00000", "00001"))):
        swap(here, there)
    assert main(["videodb", "info", str(path), "--verify"]) == 2
    out = capsys.readouterr()
    assert "is not the chunk written there" in out.out
    assert "Traceback" not in out.err
    status, errors = animate_cli(path, tmp_path, photo, capsys)
    if array == "frames":
        assert status == 2
        assert len(errors) == 1
        assert "of clips/0000" in errors[0]
        assert "is not the chunk written there" in errors[0]
        assert not (tmp_path / "o.npz").exists()
    else:
        # animate does not read the mean images: the clip is the intact database's.
        assert status == 0
        animate_cli(built.path, tmp_path, photo, capsys, out="intact.npz")
        with np.load(tmp_path / "o.npz") as a, np.load(tmp_path / "intact.npz") as b:
            np.testing.assert_array_equal(a["frames"], b["frames"])


def test_info_verify_lists_every_damaged_chunk(built, tmp_path, capsys):
    path = copy(built, tmp_path)
    assert main(["videodb", "info", str(path), "--verify"]) == 0
    assert "verified: every chunk is present and its checksum matches" in capsys.readouterr().out
    damage(chunk_files(path, "clips/00000/frames")[5], "flip")
    damage(chunk_files(path, "clips/00001/frames")[0], "delete")
    damage(chunk_files(path, "clips/00001/spectra")[0], "truncate")
    assert main(["videodb", "info", str(path), "--verify"]) == 2
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    assert len(lines) == 3
    assert "chunk 5 of clips/00000/frames cannot be read" in lines[0]
    assert "chunk 0 of clips/00001/frames is missing" in lines[1]
    assert "chunk 0 of clips/00001/spectra cannot be read" in lines[2]
    assert "3 damaged or missing parts" in captured.err
    # Without --verify, info opens what it must and says the rest when it is read.
    assert main(["videodb", "info", str(path)]) == 2
    assert "clips/00001/spectra" in capsys.readouterr().err


def test_all_black_chunks_are_written_and_read_back(tmp_path):
    """zarr skips chunks equal to the fill value; ours are all written, so missing = damaged."""
    clip = moving_texture(7, frames=2 * PARAMS.N)
    clip[:2] = 0.0  # two black frames: all-zero chunks
    db = build_database([("dark", clip)], tmp_path / "db", kind="water", params=PARAMS)
    files = chunk_files(db.path, "clips/00000/frames")
    assert len(files) == 2 * PARAMS.N
    assert not db.clip_frames(0, 0, 2).any()
    assert verify_database(db.path) == []
    for name in ("words", "spectra", "mean"):
        rows = len(getattr(db, name, db.words))
        assert len(chunk_files(db.path, f"clips/00000/{name}")) == -(-rows // CHUNK)


def edit_manifest(path, **changes):
    """Rewrite a store's manifest with ``changes`` (a value of None drops the key)."""
    manifest = json.loads((path / "manifest.json").read_text())
    for key, value in changes.items():
        if value is None:
            manifest.pop(key, None)
        else:
            manifest[key] = value
    (path / "manifest.json").write_text(json.dumps(manifest))
    return manifest


def drop_root_version(path):
    """The store's root group as versions 1 and 2 wrote it: no ``version`` attribute."""
    meta = json.loads((path / "zarr.json").read_text())
    meta["attributes"].pop("version", None)
    (path / "zarr.json").write_text(json.dumps(meta))


def as_version_2(path):
    """Rewrite a store as format version 2 wrote it: no tables, no digest, no root version."""
    manifest = json.loads((path / "manifest.json").read_text())
    for clip in manifest["clips"]:
        del clip["chunks"]
    del manifest["digest"]
    manifest["version"] = 2
    (path / "manifest.json").write_text(json.dumps(manifest))
    drop_root_version(path)


def as_version_1(path):
    """Rewrite a store as format version 1 wrote it: no checksums, empty chunks skipped."""
    from zarr.codecs import BloscCodec

    as_version_2(path)
    group = zarr.open_group(str(path), mode="a", zarr_format=3)
    for clip in group["clips"].group_values():
        for name, arr in list(clip.arrays()):
            data, chunks = arr[...], arr.chunks
            shuffle = "bitshuffle" if name == "frames" else "shuffle"
            new = clip.create_array(
                name,
                shape=data.shape,
                chunks=chunks,
                dtype=data.dtype,
                compressors=BloscCodec(cname="lz4", clevel=5, shuffle=shuffle),
                fill_value=0,
                overwrite=True,
            )
            new[...] = data
    edit_manifest(path, version=1)


def test_a_version_1_store_still_opens_and_animates_identically(built, tmp_path, photo):
    path = copy(built, tmp_path, "v1")
    as_version_1(path)
    meta = json.loads((path / "clips/00000/frames/zarr.json").read_text())
    assert [c["name"] for c in meta["codecs"]] == ["bytes", "blosc"]
    old = open_database(path)
    assert not old.checked
    assert built.checked
    for name in RAM_ARRAYS:
        np.testing.assert_array_equal(getattr(old, name), getattr(built, name))
    assert "format version 1: its chunks carry no checksums" in old.summary()
    ids = np.arange(0, built.n_fragments, 7)
    np.testing.assert_array_equal(old.fragment_frames(ids), built.fragment_frames(ids))
    np.testing.assert_array_equal(old.mean_images(ids), built.mean_images(ids))
    # The checksums change nothing that is read: the same animation, bit for bit.
    a = animate(*photo, old, FEW, seed=1).clip.frames
    b = animate(*photo, built, FEW, seed=1).clip.frames
    np.testing.assert_array_equal(a, b)
    assert verify_database(path) == []
    with pytest.raises(ValueError, match=r"format version 1.*rebuild"):
        add_clips(path, [("up", moving_texture(5, velocity=(-1, 0)))])
    # Version 1 cannot tell a missing chunk from zeros; the manifest's SHA-256 of the
    # in-memory arrays still catches one of theirs.
    chunk_files(path, "clips/00000/words")[0].unlink()
    with pytest.raises(ValueError, match="checksum"):
        open_database(path)


def test_a_version_2_store_still_opens_and_says_what_it_lacks(built, tmp_path, photo):
    path = copy(built, tmp_path, "v2")
    as_version_2(path)
    old = open_database(path)
    assert old.checked
    assert old.tables is None
    assert "format version 2: a chunk moved or swapped" in old.summary()
    for name in RAM_ARRAYS:
        np.testing.assert_array_equal(getattr(old, name), getattr(built, name))
    a = animate(*photo, old, FEW, seed=1).clip.frames
    b = animate(*photo, built, FEW, seed=1).clip.frames
    np.testing.assert_array_equal(a, b)
    assert verify_database(path) == []
    with pytest.raises(ValueError, match=r"format version 2 \(no tables of its chunks\).*rebuild"):
        add_clips(path, [("up", moving_texture(5, velocity=(-1, 0)))])
    # Version 2's checks hold: a missing chunk is refused, not read as zeros.
    chunk_files(path, "clips/00000/frames")[0].unlink()
    with pytest.raises(ValueError, match="chunk 0 of clips/00000/frames is missing"):
        open_database(path).clip_frames(0)


def delete_every_frame(path):
    for clip in ("00000", "00001"):
        for file in chunk_files(path, f"clips/{clip}/frames"):
            file.unlink()


# How far an edit of the manifest's version goes: the version alone (the issue's
# case), the digest dropped too, and the root group's version dropped as well.
EDITS = {
    "version": ({"version": 1}, False, "was changed after it was written"),
    "digest": ({"version": 1, "digest": None}, False, "was written as version 3"),
    "root": ({"version": 1, "digest": None}, True, "was written with chunk checksums"),
    # Down to version 2 (whose checks remain), root and all: the missing chunks named.
    "to-2": ({"version": 2, "digest": None}, True, "frames is missing"),
}


@pytest.mark.parametrize("edit", list(EDITS))
def test_a_manifest_cannot_switch_its_own_checks_off(built, tmp_path, photo, capsys, edit):
    """Issue 37: "version": 1 in the manifest and every frames chunk deleted passed."""
    changes, root_too, message = EDITS[edit]
    path = copy(built, tmp_path)
    delete_every_frame(path)
    edit_manifest(path, **changes)
    if root_too:
        drop_root_version(path)
    assert main(["videodb", "info", str(path), "--verify"]) == 2
    out = capsys.readouterr()
    assert "Traceback" not in out.err
    assert re.search(message, out.out + out.err), out.out + out.err
    assert "verified" not in out.out
    status, errors = animate_cli(path, tmp_path, photo, capsys)
    assert status == 2
    assert len(errors) == 1
    assert re.search(message, errors[0]), errors[0]
    assert not (tmp_path / "o.npz").exists()


def test_a_version_2_manifest_edited_to_1_is_refused(built, tmp_path):
    path = copy(built, tmp_path)
    as_version_2(path)
    delete_every_frame(path)
    edit_manifest(path, version=1)
    with pytest.raises(ValueError, match=r"says format version 1, but .* was written with chunk"):
        open_database(path).clip_frames(0)
    problems = verify_database(path)
    assert problems
    assert all("says format version 1" in line for line in problems)


def test_a_version_3_manifest_edited_to_2_still_checks_every_place(built, tmp_path):
    """Its tables dropped too and the root group's version: then the digest is missing."""
    path = copy(built, tmp_path)
    swap(*(chunk_files(path, f"clips/{c}/frames")[3] for c in ("00000", "00001")))
    edit_manifest(path, version=2)
    with pytest.raises(ValueError, match="was changed after it was written"):
        open_database(path)
    edit_manifest(path, digest=None)
    with pytest.raises(
        ValueError, match="says format version 2, but the store was written as version 3"
    ):
        open_database(path)


def test_a_damaged_starter_database_says_how_to_rebuild_it(built, tmp_path, monkeypatch):
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path / "cache"))
    path = starter_path("fire", quick=True)
    shutil.copytree(built.path, path)
    damage(chunk_files(path, "clips/00000/frames")[0], "delete")
    with pytest.raises(ValueError, match="videodb build --starter fire --quick --rebuild`"):
        open_database(path).clip_frames(0)
