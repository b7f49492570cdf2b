"""Two writers at one video database: one waits or is refused, the database stays valid.

Our decision: a build or an addition that finds the database locked fails at once with
an error naming the holder (pid, host, what it does, since when) -- the command line
prints it as one line and exits with status 2 -- while the starter-database cache
waits for the other process and then opens what it built.
"""

import os
import queue
import shutil
import subprocess
import sys
import threading

import pytest

from fluidnb import Clip
from fluidnb.cli import main
from fluidnb.videodb import (
    DatabaseBusy,
    add_clips,
    build_database,
    open_database,
    starter_database,
    starter_path,
    verify_database,
)
from tests.support.videodb_store import (
    ADD,
    BUILD,
    PARAMS,
    REPO,
    SMALL_OPTIONS,
    Paused,
    moving_texture,
    sources,
    store_bytes,
)

STARTER = """
from fluidnb.videodb import starter_database
db = starter_database("water", quick=True, progress=lambda f, m: print(m, flush=True))
print("opened", db.n_fragments)
"""


def child(code, *args):
    return [sys.executable, "-c", code, *map(str, args)]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    path = tmp_path_factory.mktemp("lock") / "db"
    return build_database(sources(), path, kind="water", params=PARAMS, seed=3, workers=2)


@pytest.fixture(scope="module")
def clip_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("clips")
    for name, frames in sources():
        Clip(frames, fps=12).save(folder / f"{name}.mp4")
    return [folder / "right.mp4", folder / "down.mp4"]


def paused(code, point, tmp_path, *args, env=None):
    p = Paused(
        f"import sys; sys.argv[1:] = {[str(a) for a in args]!r}\n{code}",
        point,
        until=tmp_path / "go-on",
        env=env,
    )
    p.wait_paused()
    return p


def test_a_second_build_is_refused_at_once_naming_the_holder(clip_files, tmp_path, capsys):
    # The undisturbed build to compare with runs as the holder does, in a fresh child
    # process: the codebook's k-means sums depend on the process's thread pools (which
    # earlier tests in this process may have changed), and bit-equality is only ours to
    # promise between two runs of our code under the same threading.
    undisturbed = tmp_path / "undisturbed"
    done = subprocess.run(
        child(BUILD, undisturbed), cwd=REPO, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    path = tmp_path / "db"
    holder = paused(BUILD, "ingested", tmp_path, path)
    try:
        with pytest.raises(DatabaseBusy, match=rf"locked by pid {holder.pid} on host .*building"):
            build_database(sources(), path, kind="water", params=PARAMS, seed=3)
        with pytest.raises(DatabaseBusy, match=rf"pid {holder.pid}"):
            build_database(sources(), path, kind="water", params=PARAMS, seed=3, resume=True)
        # The command line: one line, status 2.
        argv = ["videodb", "build", str(path), *map(str, clip_files), "--kind", "water"]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1
        assert f"is locked by pid {holder.pid}" in err
        assert "wait for that process to finish" in err
        # A reader is told the truth too: being built, not "unfinished".
        with pytest.raises(ValueError, match=rf"being built right now by pid {holder.pid}"):
            open_database(path)
    finally:
        status, out, err = holder.go_on()
    assert status == 0, err
    assert "built" in out
    # The refused writers changed nothing: the same bytes as an undisturbed build.
    assert store_bytes(path) == store_bytes(undisturbed)
    assert verify_database(path) == []


def test_an_addition_is_locked_and_readers_see_the_database_as_it_was(built, tmp_path):
    path = tmp_path / "db"
    shutil.copytree(built.path, path)
    holder = paused(ADD, "fragments", tmp_path, path)
    try:
        with pytest.raises(DatabaseBusy, match=rf"pid {holder.pid} .*adding clips to it"):
            add_clips(path, [("left", moving_texture(6, velocity=(0, -1)))])
        # Not blocked, and not shown the half-added clip.
        during = open_database(path)
        assert [c["name"] for c in during.clips] == ["right", "down"]
        assert during.n_fragments == built.n_fragments
        assert verify_database(path) == []
    finally:
        status, _, err = holder.go_on()
    assert status == 0, err
    assert [c["name"] for c in open_database(path).clips] == ["right", "down", "up"]


def test_two_command_line_builds_racing_leave_one_valid_database(clip_files, tmp_path):
    """The issue's case: `fluidnb videodb build db clip1 clip2` twice at once."""
    path = tmp_path / "db"
    argv = [sys.executable, "-m", "fluidnb", "videodb", "build", str(path), *map(str, clip_files)]
    argv += ["--kind", "water", "--workers", "1", *SMALL_OPTIONS]
    procs = [
        subprocess.Popen(argv, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    results = [(p.wait(timeout=600), *p.communicate()) for p in procs]
    assert sorted(r[0] for r in results) == [0, 2], results
    _, _, loser_err = next(r for r in results if r[0] == 2)
    # Refused while the other held the lock or, had it already finished, because the
    # folder holds its database: either way one clear line.
    lines = [ln for ln in loser_err.splitlines() if "error" in ln]
    assert len(lines) == 1, loser_err
    assert "is locked by pid" in lines[0] or "already holds a video database" in lines[0]
    assert "Traceback" not in loser_err
    db = open_database(path)
    assert [c["name"] for c in db.clips] == ["right", "down"]
    assert verify_database(path) == []


class Lines:
    """The lines of a child's stdout, read by a thread (so waiting for one can time out)."""

    def __init__(self, stream):
        self.lines = queue.Queue()
        self.seen = []
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream):
        for line in stream:
            self.lines.put(line)
        self.lines.put(None)

    def wait_for(self, text, timeout=300):
        while True:
            line = self.lines.get(timeout=timeout)
            if line is None:
                raise AssertionError(f"never said {text!r}: {''.join(self.seen)}")
            self.seen.append(line)
            if text in line:
                return line

    def rest(self):
        while (line := self.lines.get(timeout=300)) is not None:
            self.seen.append(line)
        return "".join(self.seen)


def test_two_notebooks_asking_for_one_starter_database(tmp_path, monkeypatch):
    """The second waits for the first to build it, then opens it: no error in either."""
    env = {"FLUIDNB_CACHE_DIR": str(tmp_path / "cache")}
    first = paused(STARTER, "ingested", tmp_path, env=env)
    with subprocess.Popen(
        child(STARTER),
        cwd=REPO,
        env=dict(os.environ, **env),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as second:
        try:
            out = Lines(second.stdout)
            assert f"waiting for pid {first.pid}" in out.wait_for("waiting for")
        finally:
            status, first_out, first_err = first.go_on()
        assert status == 0, first_err
        second_out = out.rest()
        assert second.wait(timeout=600) == 0, second.stderr.read()
    assert "built by another process" in second_out
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", env["FLUIDNB_CACHE_DIR"])
    path = starter_path("water", quick=True)
    assert f"opened {open_database(path).n_fragments}" in first_out
    assert f"opened {open_database(path).n_fragments}" in second_out
    assert verify_database(path) == []
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name, f"{path.name}.lock"]
    assert starter_database("water", quick=True).n_fragments > 0  # and now from the cache
