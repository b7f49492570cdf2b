"""A video database's files as a fault probe found them (issue 37): shared, full, hostile.

- the manifest and the build's state were written 0600 (``mkstemp``): other users of a
  shared folder could not open a database, and were told it was corrupt;
- a build on a full disk (or over ``ulimit -f``) said "No space left on device" or
  "File too large", naming nothing;
- an interrupted ``add`` could be resumed but not discarded;
- a FIFO given as a clip was "no such file", and JSON nested too deeply in a store's
  files (or a frame folder's ``clip.json``) was a RecursionError traceback.
"""

from __future__ import annotations

import os
import resource
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.cli import main
from fluidnb.videodb import (
    add_clips,
    build_database,
    discard_addition,
    open_database,
    read_video,
    starter_database,
    verify_database,
)
from tests.support.videodb_store import (
    ADD,
    BUILD,
    PARAMS,
    REPO,
    SMALL_OPTIONS,
    UP,
    killed_at,
    moving_texture,
    sources,
    store_bytes,
)

DEEP = "[" * 200_000 + "]" * 200_000


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = tmp_path_factory.mktemp("store") / "db"
    return build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=2)


@pytest.fixture(scope="module")
def clip_files(tmp_path_factory):
    """The two clips of ``sources()`` as MP4 files (what the command line takes)."""
    folder = tmp_path_factory.mktemp("clips")
    return [str(Clip(frames, fps=12).save(folder / f"{name}.mp4")) for name, frames in sources()]


def modes(root):
    """Every file's and folder's permission bits under ``root``, by relative path."""
    root = Path(root)
    return {str(p.relative_to(root)): oct(stat.S_IMODE(p.stat().st_mode)) for p in root.rglob("*")}


def one_error(capsys, prog="fluidnb videodb"):
    """The one line a command printed on stderr as its error (and no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    # A progress bar redraws its line with carriage returns: the error is after the last.
    lines = [line.split("\r")[-1].strip() for line in err.splitlines()]
    errors = [line for line in lines if line.startswith(f"{prog} ") and "error:" in line]
    assert len(errors) == 1, err
    return errors[0]


# ------------------------------------------------------------------ shared folders


def test_every_file_of_a_database_respects_the_umask(tmp_path, umask_002):
    """Issue 37: manifest.json was 0600 (mkstemp), the chunks 0664, under umask 002."""
    db = build_database(sources(), tmp_path / "db", kind="water", params=PARAMS, seed=3)
    found = modes(db.path)
    assert found["manifest.json"] == oct(0o664)
    files = {k: v for k, v in found.items() if (db.path / k).is_file()}
    folders = {k: v for k, v in found.items() if (db.path / k).is_dir()}
    assert files == dict.fromkeys(files, oct(0o664))
    assert folders == dict.fromkeys(folders, oct(0o775))
    # An addition's new manifest too.
    add_clips(db.path, [UP])
    assert modes(db.path)["manifest.json"] == oct(0o664)


def test_an_unfinished_builds_state_respects_the_umask(tmp_path, umask_002):
    path = tmp_path / "db"
    killed_at(BUILD, "ingested", path)  # the child inherits the umask
    found = modes(path / "build")
    assert found["state.json"] == oct(0o664)
    assert set(found.values()) <= {oct(0o664), oct(0o775)}


def test_a_starter_databases_manifest_respects_the_umask(tmp_path, umask_002, monkeypatch):
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path / "cache"))
    db = starter_database("smoke", quick=True)
    assert modes(db.path)["manifest.json"] == oct(0o664)
    assert set(modes(db.path).values()) <= {oct(0o664), oct(0o775)}


NOBODY = 65534
AS_ANOTHER_USER = """
import sys
from fluidnb.cli import main
sys.exit(main(["videodb", "info", sys.argv[1]]))
"""


def as_another_user(folder, db):
    """`fluidnb videodb info DB` run by user ``nobody``: (status, stdout, stderr)."""
    env = dict(os.environ, HOME=str(folder), NUMBA_CACHE_DIR=str(folder / "numba"))
    env.pop("FLUIDNB_CACHE_DIR", None)
    proc = subprocess.run(
        [sys.executable, "-c", AS_ANOTHER_USER, str(db)],
        cwd=REPO,
        env=env,
        user=NOBODY,
        group=NOBODY,
        extra_groups=[],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    return proc.returncode, proc.stdout, proc.stderr


@pytest.mark.skipif(os.name != "posix" or os.geteuid() != 0, reason="needs root to be nobody")
def test_another_user_opens_a_database_and_is_told_why_when_not(built):
    """Issue 37: with manifest.json 0600 another user was told the database was corrupt."""
    folder = Path(tempfile.mkdtemp(prefix="fluidnb-shared-"))
    try:
        folder.chmod(0o777)
        old = os.umask(0o022)
        try:
            db = build_database(sources(), folder / "db", kind="water", params=PARAMS, seed=3)
        finally:
            os.umask(old)
        status, out, err = as_another_user(folder, db.path)
        assert status == 0, err
        assert "kind 'water': 2 clips" in out
        # A manifest made unreadable (as the old mkstemp did): said as it is.
        (db.path / "manifest.json").chmod(0o600)
        status, out, err = as_another_user(folder, db.path)
        assert status == 2
        assert "Traceback" not in err
        assert err.strip().splitlines()[-1] == (
            f"fluidnb videodb info: error: db: cannot read {str(db.path / 'manifest.json')!r}: "
            f"Permission denied (its owner can let others read the database: chmod -R a+rX "
            f"{str(db.path)!r})"
        )
        assert "corrupt" not in err
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# ------------------------------------------------------------------ no room


def test_a_build_on_a_full_disk_names_what_it_wrote_and_resumes(
    small_disk, clip_files, tmp_path, capsys
):
    """Issue 37: "No space left on device", naming nothing; then the build must go on."""
    disk = small_disk("160k")
    out = disk / "db"
    argv = ["videodb", "build", str(out), *clip_files, "--kind", "water", *SMALL_OPTIONS]
    assert main(argv) == 2
    line = one_error(capsys)
    assert line.startswith(f"fluidnb videodb build: error: cannot write '{out}")
    assert "No space left on device (the disk is full); " in line
    resumable = (out / "build" / "state.json").is_file()
    if resumable:
        assert line.endswith(
            "continue it with `fluidnb videodb build OUT CLIPS --resume` "
            "(build_database(..., resume=True))"
        )
    else:
        assert line.endswith(
            "nothing was kept that a build could continue: make room and build again"
        )
    # Room made: the build goes on (or starts again, as it said) to the database a
    # build with room makes.
    subprocess.run(["mount", "-o", "remount,size=8m", str(disk)], check=True)
    assert main(argv + (["--resume"] if resumable else [])) == 0
    capsys.readouterr()
    reference = tmp_path / "reference"
    assert main([*argv[:2], str(reference), *argv[3:]]) == 0
    capsys.readouterr()
    assert store_bytes(out) == store_bytes(reference)


# 30 kB a file: the frames' chunks fit (20 kB), the features' do not (35-110 kB).
LIMITED_BUILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_FSIZE, (30_000, 30_000))
from fluidnb.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_build_over_a_file_size_limit_names_the_file(clip_files, tmp_path):
    """`ulimit -f`: "File too large", naming nothing (issue 37); the state survives it."""
    out = tmp_path / "db"
    argv = ["videodb", "build", str(out), *clip_files, "--kind", "water", *SMALL_OPTIONS]
    proc = subprocess.run(
        [sys.executable, "-c", LIMITED_BUILD, *argv],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    line = proc.stderr.strip().splitlines()[-1].split("\r")[-1].strip()
    assert line.startswith(f"fluidnb videodb build: error: cannot write '{out}/"), line
    assert "File too large (a file size limit, ulimit -f); the unfinished build is kept" in line
    assert resource.getrlimit(resource.RLIMIT_FSIZE)[0] == resource.RLIM_INFINITY
    db = build_database(
        [(Path(f).stem, f) for f in clip_files], out, kind="water", params=PARAMS, resume=True
    )
    assert db.n_fragments > 0
    assert verify_database(out) == []


# ------------------------------------------------------------------ discarding


def test_an_interrupted_addition_is_discarded_and_the_database_is_as_it_was(
    built, tmp_path, capsys
):
    path = shutil.copytree(built.path, tmp_path / "db")
    before = store_bytes(path)
    killed_at(ADD, "fragments", path)
    assert (path / "clips" / "00002").is_dir()
    assert main(["videodb", "info", str(path)]) == 0
    assert "or discard it with `fluidnb videodb add DB --discard`" in capsys.readouterr().out
    with pytest.raises(ValueError, match="or discard it with --discard"):
        add_clips(path, [UP])
    assert discard_addition(path) == ["up"]
    assert store_bytes(path) == before
    with pytest.raises(ValueError, match="has no interrupted addition of clips to discard"):
        discard_addition(path)
    # ... and the next addition is an ordinary one.
    assert [c["name"] for c in add_clips(path, [UP]).clips] == ["right", "down", "up"]


def test_the_command_line_discards_an_interrupted_addition(built, tmp_path, capsys):
    path = shutil.copytree(built.path, tmp_path / "db")
    before = store_bytes(path)
    killed_at(ADD, "ingested", path)
    assert main(["videodb", "add", str(path), "x.mp4", "--discard"]) == 2
    assert "--discard takes no SOURCES" in one_error(capsys)
    assert main(["videodb", "add", str(path)]) == 2
    assert "give at least one clip in SOURCES (or --discard)" in one_error(capsys)
    assert main(["videodb", "add", str(path), "--discard"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("discarded the interrupted addition of 'up'\n")
    assert "kind 'water': 2 clips" in out
    assert "interrupted" not in out.split("\n", 1)[1]
    assert store_bytes(path) == before
    assert main(["videodb", "add", str(path), "--discard"]) == 2
    assert "no interrupted addition" in one_error(capsys)


# ------------------------------------------------------------------ hostile files


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_fifo_given_as_a_clip_is_named_as_what_it_is(tmp_path, capsys):
    fifo = tmp_path / "clip.mp4"
    os.mkfifo(fifo)
    message = "is a named pipe (FIFO), not a video file or a folder of frames"
    with pytest.raises(
        ValueError,
        match=r"source: '.*clip\.mp4' " + message.replace("(", r"\(").replace(")", r"\)"),
    ):
        read_video(fifo)
    out = tmp_path / "db"
    assert main(["videodb", "build", str(out), str(fifo), "--kind", "water"]) == 2
    assert message in one_error(capsys)
    assert not out.exists()


def test_a_frame_folders_clip_json_nested_too_deeply_is_ignored(tmp_path):
    """Its fps is informational: damaged, it is not read (as invalid JSON was not)."""
    folder = Clip(moving_texture(3, frames=4), fps=12).save(tmp_path / "frames")
    assert read_video(folder).fps == 12
    (folder / "clip.json").write_text(DEEP)
    video = read_video(folder)
    assert video.fps == 24
    assert video.frames.shape == (4, 72, 96, 3)


@pytest.mark.parametrize(
    ("file", "message"),
    [
        (
            "manifest.json",
            r"manifest\.json' is corrupt: cannot read .* \(it is nested too deeply\)",
        ),
        ("zarr.json", r"zarr\.json' is damaged \(cannot read .* \(it is nested too deeply\)\)"),
        ("clips/00001/words/zarr.json", r"clips/00001/words/zarr\.json' is damaged"),
    ],
)
def test_a_store_file_nested_too_deeply_is_one_line(built, tmp_path, capsys, file, message):
    path = shutil.copytree(built.path, tmp_path / "db")
    (path / file).write_text(DEEP)
    with pytest.raises(ValueError, match=message):
        open_database(path)
    assert main(["videodb", "info", str(path)]) == 2
    one_error(capsys)
    assert main(["videodb", "info", str(path), "--verify"]) == 2
    capsys.readouterr()


def test_a_builds_state_or_holder_nested_too_deeply_is_no_traceback(built, tmp_path, capsys):
    path = tmp_path / "db"
    killed_at(BUILD, "ingested", path)
    (path / "build" / "state.json").write_text(DEEP)
    # A state that cannot be read is none: what is left is a build's remains.
    assert main(["videodb", "info", str(path)]) == 2
    assert "holds the remains of a build that stopped" in one_error(capsys)
    (path / ".fluidnb-lock.holder.json").write_text(DEEP)
    db = build_database(sources(), path, kind="water", params=PARAMS, seed=3)
    np.testing.assert_array_equal(db.words, built.words)
