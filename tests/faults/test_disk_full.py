"""A full disk during an export: one line that names the file and says the disk is full.

An MP4 export onto a full disk said "ffmpeg could not encode 'prev.mp4': no message"
(issue 37): ffmpeg's words went to a temporary file on the same full disk. And what
was there before -- a video and its sidecar -- must survive a failed export intact.
The real thing needs a tiny tmpfs (root may mount one: ``tiny_disk`` in conftest.py);
the sidecar's case is also simulated at the writer's boundary.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.cli import main


def _noise(path, frames=10, side=128):
    clip = Clip(np.random.default_rng(0).random((frames, side, side), dtype=np.float32), fps=10)
    return clip.save(path)


@pytest.mark.parametrize("tmpdir_on_the_full_disk", [False, True])
def test_an_mp4_export_onto_a_full_disk_says_so_and_keeps_the_old_video(
    tiny_disk, tmp_path, tmpdir_on_the_full_disk, capsys, monkeypatch
):
    source = _noise(tmp_path / "noise.npz")
    old = Clip(np.full((2, 8, 8), 0.5, np.float32), fps=5).save(tiny_disk / "prev.mp4")
    before = {p.name: p.read_bytes() for p in tiny_disk.iterdir()}
    assert sorted(before) == ["prev.mp4", "prev.mp4.json"]
    if tmpdir_on_the_full_disk:  # where the old code kept ffmpeg's messages
        monkeypatch.setenv("TMPDIR", str(tiny_disk))
        monkeypatch.setattr("tempfile.tempdir", None)
    assert main(["convert", str(source), "-o", str(old)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"fluidnb convert: error: cannot write {str(old)!r}: No space left on device "
        "(the disk is full)\n"
    )
    assert {p.name: p.read_bytes() for p in tiny_disk.iterdir()} == before
    assert Clip.load(old).n_frames == 2


def test_a_png_sequence_or_gif_onto_a_full_disk_names_the_output(tiny_disk, tmp_path, capsys):
    source = _noise(tmp_path / "noise.npz")
    for out in (tiny_disk / "x.gif", tiny_disk / "frames"):
        assert main(["convert", str(source), "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"fluidnb convert: error: cannot write {str(out)!r}: No space"), err
        assert err.count("\n") == 1
    assert not [p for p in tiny_disk.rglob("*") if "partial" in p.name]


def test_a_sidecar_that_cannot_be_written_leaves_the_old_video_and_sidecar(tmp_path, monkeypatch):
    from pathlib import Path

    old = Clip(np.full((2, 8, 8), 0.5, np.float32), fps=5).save(tmp_path / "prev.mp4")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real = Path.write_text

    def full(self, *args, **kwargs):
        if self.name.endswith(".json"):
            raise OSError(28, os.strerror(28))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError, match=r"cannot write '.*prev.mp4.json': No space left on device"):
        Clip(np.zeros((3, 16, 16), np.float32), fps=9).save(old)
    monkeypatch.undo()
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
