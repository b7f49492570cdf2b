"""Builds and additions that fail: a valid database or a resumable state, never a stuck folder.

``info`` (open_database), ``build``, ``build --resume`` and ``add`` must agree on what a
folder holds after each failure, and resuming must give the uninterrupted result.
"""

import shutil
import sys

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.cli import main
from fluidnb.videodb import add_clips, build_database, open_database, verify_database
from fluidnb.videodb.database._folder import folder_state
from tests.support.videodb_store import (
    ADD,
    BUILD,
    PARAMS,
    UP,
    killed_at,
    moving_texture,
    sources,
    store_bytes,
)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = tmp_path_factory.mktemp("uninterrupted") / "db"
    return build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=2)


@pytest.fixture(scope="module")
def grown(built, tmp_path_factory):
    path = tmp_path_factory.mktemp("uninterrupted") / "grown"
    shutil.copytree(built.path, path)
    return add_clips(path, [UP])


def build(path, **kw):
    return build_database(sources(), path, kind="water", params=PARAMS, seed=3, **kw)


def info(path, capsys):
    """`fluidnb videodb info PATH`: (status, what it printed)."""
    status = main(["videodb", "info", str(path)])
    out = capsys.readouterr()
    return status, out.out + out.err


# What a build killed at each point leaves, and what info says of it.
KILLED = {
    # right after the folder appeared: nothing in it but the lock
    "locked": ("empty", "it is empty; build one into it"),
    "ingested": ("unfinished", "holds an unfinished build"),
    "fragments": ("unfinished", "holds an unfinished build"),
    "codebook": ("unfinished", "holds an unfinished build"),
    # the manifest written, the build's state not yet removed: a database
    "manifest": ("database", "kind 'water': 2 clips"),
}


@pytest.mark.parametrize("point", list(KILLED))
def test_a_killed_build_resumes_to_the_uninterrupted_store(built, tmp_path, point, capsys):
    path = tmp_path / "db"
    killed_at(BUILD, point, path)
    state, said = KILLED[point]
    assert folder_state(path) == state
    status, printed = info(path, capsys)
    assert said in printed
    assert status == (0 if state == "database" else 2)
    if state == "unfinished":
        # info's advice and build's refusal are the same.
        assert "--resume" in printed
        with pytest.raises(ValueError, match="unfinished build: continue it with --resume"):
            build(path)
        assert folder_state(path) == "unfinished"
    if state == "database":
        with pytest.raises(ValueError, match="already holds a video database"):
            build(path, resume=True)
        assert open_database(path).n_fragments == built.n_fragments
        assert verify_database(path) == []
        # What the killed build left (its state) goes with the next writer.
        add_clips(path, [UP])
        assert not (path / "build").exists()
        return
    db = build(path, resume=True)
    assert store_bytes(db.path) == store_bytes(built.path)


def test_a_build_killed_before_its_state_is_rebuilt_by_a_plain_build(built, tmp_path, capsys):
    path = tmp_path / "db"
    killed_at(BUILD, "locked", path)
    db = build(path)  # no --resume needed: nothing was done
    assert store_bytes(db.path) == store_bytes(built.path)


def test_remains_without_a_state_are_cleared_by_the_next_build(built, tmp_path, capsys):
    """A build rolled back (or killed) after its zarr group but before its state."""
    path = tmp_path / "db"
    killed_at(BUILD, "ingested", path)
    (path / "build" / "state.json").unlink()
    assert folder_state(path) == "debris"
    status, printed = info(path, capsys)
    assert status == 2
    assert "building into it again starts afresh" in printed
    db = build(path)
    assert store_bytes(db.path) == store_bytes(built.path)


@pytest.mark.parametrize(
    ("second", "message"),
    [
        ("missing", r"sources\[1\]: .*no such file"),
        ("nan", r"sources\[1\]: source contains NaN"),
        ("duplicate", r"sources\[1\] \('again'\) is the same clip as 'right'"),
    ],
)
def test_a_build_failing_for_its_input_leaves_nothing(built, tmp_path, second, message):
    """The first clip is stored when the second fails: all of it goes, a retry works."""
    bad = {
        "missing": tmp_path / "missing.mp4",
        "nan": ("nan", np.full((20, 72, 96, 3), np.nan, np.float32)),
        "duplicate": ("again", sources()[0][1]),
    }[second]
    path = tmp_path / "db"
    with pytest.raises(ValueError, match=message):
        build_database([sources()[0], bad], path, kind="water", params=PARAMS, seed=3)
    assert not path.exists()
    # Into a folder the user made: it is left as it was, empty.
    path.mkdir()
    with pytest.raises(ValueError, match=message):
        build_database([sources()[0], bad], path, kind="water", params=PARAMS, seed=3)
    assert folder_state(path) == "empty"
    with pytest.raises(ValueError, match="it is empty"):
        open_database(path)
    db = build(path)
    assert store_bytes(db.path) == store_bytes(built.path)


def test_a_resume_with_a_bad_source_keeps_the_state(built, tmp_path):
    path = tmp_path / "db"
    killed_at(BUILD, "ingested", path)  # the first clip is in
    with pytest.raises(ValueError, match=r"no such file.*unfinished build .* is kept"):
        build_database(
            [sources()[0], tmp_path / "typo.mp4"],
            path,
            kind="water",
            params=PARAMS,
            seed=3,
            resume=True,
        )
    with pytest.raises(ValueError, match="not the clip the interrupted build had"):
        build_database(sources()[::-1], path, kind="water", params=PARAMS, seed=3, resume=True)
    assert folder_state(path) == "unfinished"
    db = build(path, resume=True)
    assert store_bytes(db.path) == store_bytes(built.path)


@pytest.mark.parametrize(
    ("clips", "message"),
    [
        ([UP, UP], r"sources\[1\] \('up'\) is the same clip as 'up'"),
        ([("right-again", sources()[0][1])], "same clip as 'right'"),
        ([UP, ("nan", np.full((20, 72, 96, 3), np.nan, np.float32))], "contains NaN"),
        ([("still", np.repeat(moving_texture(8)[:1], 20, axis=0))], "no fragment"),
    ],
)
def test_an_addition_failing_for_its_input_leaves_the_database_as_it_was(
    built, tmp_path, clips, message, capsys
):
    """The issue's case: `videodb add db clip3.mp4 clip3.mp4` left clips/00002 behind."""
    path = shutil.copytree(built.path, tmp_path / "db")
    before = store_bytes(path)
    with pytest.raises(ValueError, match=message):
        add_clips(path, clips)
    assert store_bytes(path) == before
    # ... and the next plain addition is not refused.
    assert [c["name"] for c in add_clips(path, [UP]).clips] == ["right", "down", "up"]


def test_the_command_line_refuses_a_doubled_clip_and_adds_it_next(built, tmp_path, capsys):
    path = shutil.copytree(built.path, tmp_path / "db")
    Clip(UP[1], fps=12).save(tmp_path / "clip3.mp4")
    clip3 = str(tmp_path / "clip3.mp4")
    assert main(["videodb", "add", str(path), clip3, clip3]) == 2
    assert "is the same clip as 'clip3'" in capsys.readouterr().err
    assert not (path / "clips" / "00002").exists()
    assert not (path / "build").exists()
    assert main(["videodb", "add", str(path), clip3]) == 0
    assert "3 clips" in capsys.readouterr().out


@pytest.mark.parametrize("point", ["ingested", "fragments"])
def test_a_killed_addition_resumes_and_the_database_stays_usable(
    built, grown, tmp_path, point, capsys
):
    path = shutil.copytree(built.path, tmp_path / "db")
    before = open_database(path)
    killed_at(ADD, point, path)
    # info: the database as it was, and the interrupted addition with what to do.
    status, printed = info(path, capsys)
    assert status == 0
    assert "2 clips" in printed
    assert "an addition of 'up' was interrupted: continue it with" in printed
    assert "--resume" in printed
    during = open_database(path)
    assert during.n_fragments == before.n_fragments
    np.testing.assert_array_equal(during.words, before.words)
    # add agrees: a plain addition is refused with the same advice.
    with pytest.raises(ValueError, match="unfinished addition of clips: continue it with --resume"):
        add_clips(path, [UP])
    db = add_clips(path, [UP], resume=True)
    assert store_bytes(db.path) == store_bytes(grown.path)


def test_an_addition_killed_after_its_manifest_is_done(built, grown, tmp_path, capsys):
    path = shutil.copytree(built.path, tmp_path / "db")
    killed_at(ADD, "manifest", path)
    status, printed = info(path, capsys)
    assert status == 0
    assert "3 clips" in printed
    assert "interrupted" not in printed
    db = open_database(path)
    np.testing.assert_array_equal(db.words, grown.words)
    # Another clip goes in, and the leftovers with it.
    add_clips(path, [("left", moving_texture(6, velocity=(0, -1)))])
    assert not (path / "build").exists()


def test_an_unreachable_scheduler_is_one_line_and_builds_nothing(tmp_path, capsys):
    path = tmp_path / "db"
    Clip(UP[1], fps=12).save(tmp_path / "a.mp4")
    argv = ["videodb", "build", str(path), str(tmp_path / "a.mp4"), "--kind", "water"]
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "cannot reach a dask scheduler at 'tcp://127.0.0.1:1' within 5 s" in err
    assert not path.exists()


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_a_killed_holder_does_not_keep_its_database_locked(built, tmp_path):
    path = tmp_path / "db"
    killed_at(BUILD, "codebook", path)
    # Its sidecar is still there, but its process is gone: nobody is building.
    assert (path / ".fluidnb-lock.holder.json").exists()
    with pytest.raises(ValueError, match="holds an unfinished build"):
        open_database(path)
    db = build(path, resume=True)
    assert store_bytes(db.path) == store_bytes(built.path)
