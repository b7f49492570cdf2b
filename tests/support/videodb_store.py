"""Small video databases for the tests of building, locking and damage."""

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage as ndi

from fluidnb.videodb import DatabaseParams

#: The repository: child processes run here, so that they import ``tests.support`` too.
REPO = Path(__file__).resolve().parents[2]

# Small and quick: N = 8 frames a fragment, the clip and its mirror image, 8 words.
PARAMS = DatabaseParams(N=8, augment="flip", words=8, codebook_samples=2000)

# The same, as `fluidnb videodb build` options.
SMALL_OPTIONS = ["--N", "8", "--augment", "flip", "--words", "8", "--codebook-samples", "2000"]


def moving_texture(seed, shape=(72, 96), frames=20, velocity=(0, 1), colour=(1.0, 0.9, 0.7)):
    """A smooth random texture translating by whole pixels each frame (wraps around)."""
    gen = np.random.default_rng(seed)
    h, w = shape
    base = ndi.gaussian_filter(gen.random((h, w)), 2.0, mode="wrap")
    base = (base - base.min()) / (base.max() - base.min())
    dy, dx = velocity
    out = np.stack([np.roll(base, (t * dy, t * dx), axis=(0, 1)) for t in range(frames)])
    return (out[..., None] * np.array(colour)).astype(np.float32)


def sources():
    """Two named clips: a texture moving right, another moving down."""
    return [
        ("right", moving_texture(1)),
        ("down", moving_texture(2, velocity=(1, 0), colour=(0.6, 0.8, 1.0))),
    ]


def store_bytes(path):
    """Every file of a store, relative path -> bytes."""
    root = Path(path)
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def chunk_files(path, array):
    """The chunk files of ``array`` (e.g. ``clips/00000/frames``) in a store, in order."""
    folder = Path(path) / array / "c"
    files = [p for p in folder.rglob("*") if p.is_file()]
    return sorted(files, key=lambda p: tuple(int(i) for i in p.relative_to(folder).parts))


class Paused:
    """A Python child process run until it reaches a pause point of a build (see _build._pause).

    ``code`` runs with ``FLUIDNB_TEST_PAUSE_AT=point``; :meth:`wait_paused` returns once
    the child says it stopped there. Then :meth:`kill` it (SIGKILL), or create
    ``until`` to let it go on (:meth:`go_on`).
    """

    def __init__(self, code, point, *, until=None, env=None):
        full = dict(os.environ, **(env or {}))
        full["FLUIDNB_TEST_PAUSE_AT"] = point
        if until is not None:
            full["FLUIDNB_TEST_PAUSE_UNTIL"] = str(until)
        self.until = until
        self.point = point
        self.proc = subprocess.Popen(
            [sys.executable, "-c", code],
            cwd=REPO,
            env=full,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.pid = self.proc.pid

    def wait_paused(self, timeout=300):
        """Read the child's stderr until it says it paused; fail with its output if it ends."""
        seen = []
        for line in self.proc.stderr:
            seen.append(line)
            if f"paused at {self.point}" in line:
                return
        self.proc.wait(timeout=timeout)
        raise AssertionError(
            f"the child ended (status {self.proc.returncode}) before pausing at "
            f"{self.point!r}:\n{''.join(seen)}{self.proc.stdout.read()}"
        )

    def kill(self):
        """SIGKILL the child (nothing of it runs afterwards) and reap it."""
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=60)
        self.proc.stdout.close()
        self.proc.stderr.close()

    def go_on(self, timeout=300):
        """Let the child go on; returns (status, stdout, stderr after the pause)."""
        Path(self.until).touch()
        out, err = self.proc.communicate(timeout=timeout)
        return self.proc.returncode, out, err


#: A third clip, moving up: what the tests add to the two of :func:`sources`.
UP = ("up", moving_texture(5, velocity=(-1, 0)))

#: A child's build of :func:`sources` into ``sys.argv[1]`` (for :class:`Paused`).
BUILD = """
import sys
from fluidnb.videodb import build_database
from tests.support.videodb_store import PARAMS, sources
build_database(sources(), sys.argv[1], kind="water", params=PARAMS, seed=3, workers=1)
print("built")
"""

#: A child's addition of :data:`UP` to the database ``sys.argv[1]``.
ADD = """
import sys
from fluidnb.videodb import add_clips
from tests.support.videodb_store import UP
add_clips(sys.argv[1], [UP], workers=1)
print("added")
"""


def killed_at(code, point, path):
    """Run ``code`` on ``path`` in a child process and SIGKILL it at ``point``."""
    child = Paused(f"import sys; sys.argv[1:] = [{str(path)!r}]\n{code}", point)
    child.wait_paused()
    child.kill()
