"""Saving clips never loses the user's files, and a failed save names what was asked for.

- A PNG sequence goes into a new or empty folder, or one fluidnb wrote (its clip.json
  says which frames are ours); a file fluidnb did not write is never replaced.
- A write that fails leaves no ``.partial`` file and its error names the output.
- The frame rate is bounded in the library (``Clip``, ``save``, files read back) and on
  the command line alike.
"""

from __future__ import annotations

import errno
import json

import numpy as np
import pytest

from fluidnb import Clip, _media
from fluidnb.cli import main


def clip(n=3, seed=0):
    return Clip(np.random.default_rng(seed).random((n, 6, 8)), fps=5)


def listing(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# ---------------------------------------------------------------------- frame folders


def test_a_folder_of_the_users_files_is_refused(tmp_path):
    folder = tmp_path / "userdir"
    folder.mkdir()
    (folder / "frame_00000.png").write_bytes(b"the user's own picture")
    (folder / "notes.txt").write_text("mine")
    before = listing(folder)
    with pytest.raises(ValueError, match=r"userdir.*fluidnb did not write.*new or empty folder"):
        clip().save(folder)
    assert listing(folder) == before


def test_a_folder_with_only_unrelated_files_is_refused_too(tmp_path):
    """Frames never go in among someone else's files, even where no name clashes."""
    (tmp_path / "holiday.jpg").write_bytes(b"jpeg")
    with pytest.raises(ValueError, match="did not write"):
        clip().save(tmp_path)
    assert listing(tmp_path) == {"holiday.jpg": b"jpeg"}


def test_saving_again_into_our_own_folder_replaces_only_our_frames(tmp_path):
    folder = clip(3).save(tmp_path / "frames")
    (folder / "frame_00003.png").write_bytes(b"added by the user")  # beyond our 3 frames
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match=r"'frame_00003\.png' there was not written by fluidnb"):
        clip(5, seed=1).save(folder)  # would replace frame_00003.png
    assert (folder / "frame_00003.png").read_bytes() == b"added by the user"
    shorter = clip(2, seed=2)
    shorter.save(folder)  # ours: frames 0-2 may be replaced, 2 removed
    assert sorted(p.name for p in folder.iterdir()) == [
        "clip.json",
        "frame_00000.png",
        "frame_00001.png",
        "frame_00003.png",
        "notes.txt",
    ]
    assert (folder / "frame_00003.png").read_bytes() == b"added by the user"
    assert (folder / "notes.txt").read_text() == "mine"
    np.testing.assert_array_equal(Clip.load(folder).to_uint8(), shorter.to_uint8())


def test_a_folder_whose_clip_json_is_not_ours_is_refused(tmp_path):
    (tmp_path / "clip.json").write_text(json.dumps({"format": "something else", "n_frames": 9}))
    with pytest.raises(ValueError, match="did not write"):
        clip().save(tmp_path)


def test_an_interrupted_save_can_be_saved_again(tmp_path, monkeypatch):
    folder = clip(2).save(tmp_path / "frames")
    from PIL import Image

    real_save = Image.Image.save
    calls = []

    def failing(self, fp, *args, **kwargs):
        calls.append(fp)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_save(self, fp, *args, **kwargs)

    monkeypatch.setattr(Image.Image, "save", failing)
    with pytest.raises(OSError, match=r"cannot write '.*frames': No space left"):
        clip(4, seed=1).save(folder)  # frames 0, 1 written, then the disk is full
    monkeypatch.undo()
    with pytest.raises(ValueError, match="interrupted"):
        Clip.load(folder)
    again = clip(4, seed=1)
    again.save(folder)  # frames 0-3 are all claimed by the interrupted save
    np.testing.assert_array_equal(Clip.load(folder).to_uint8(), again.to_uint8())


def test_a_file_where_the_folder_should_be_is_refused(tmp_path):
    (tmp_path / "frames").write_bytes(b"a file without extension")
    with pytest.raises(ValueError, match="is a file: a PNG sequence needs a folder"):
        clip().save(tmp_path / "frames")
    assert (tmp_path / "frames").read_bytes() == b"a file without extension"


def test_the_command_line_refuses_a_users_folder_before_any_work(tmp_path, capsys):
    folder = tmp_path / "userdir"
    folder.mkdir()
    (folder / "frame_00000.png").write_bytes(b"mine")
    clip().save(tmp_path / "c.npz")
    assert main(["convert", str(tmp_path / "c.npz"), "-o", str(folder)]) == 2
    err = capsys.readouterr().err
    assert "--output" in err
    assert "fluidnb did not write" in err
    assert listing(folder) == {"frame_00000.png": b"mine"}


# ---------------------------------------------------------------------- failed writes


@pytest.mark.parametrize("ext", [".gif", ".npz", ".mp4"])
def test_a_failed_write_names_the_output_and_leaves_no_partial_file(tmp_path, monkeypatch, ext):
    """The temporary file is written, then the disk fills up: it must not survive."""

    def full_disk(target, *args, **kwargs):
        if hasattr(target, "write"):  # _write_gif gets a file open on the temporary name
            target.write(b"half a file")
        else:
            with open(target, "wb") as f:
                f.write(b"half a file")
        raise OSError(errno.ENOSPC, "No space left on device")

    writer = {".gif": "_write_gif", ".npz": "_write_npz", ".mp4": "_encode_mp4"}[ext]
    monkeypatch.setattr(_media, writer, full_disk)
    out = tmp_path / f"wanted{ext}"
    with pytest.raises(OSError, match="No space left") as info:
        clip().save(out)
    assert info.value.errno == errno.ENOSPC
    assert str(out) in str(info.value)
    assert "partial" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_a_failed_flow_save_keeps_the_file_that_was_there(tmp_path, monkeypatch):
    from fluidnb.turbulence import Flow

    flow = Flow(np.zeros((1, 4, 4, 2)), np.zeros((1, 4, 4)), 1.0)
    path = tmp_path / "flow.npz"
    flow.save(path)
    before = path.read_bytes()

    def full_disk(f, **arrays):
        f.write(b"half a file")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez_compressed", full_disk)
    with pytest.raises(OSError, match=r"cannot write '.*flow\.npz': No space left"):
        flow.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["flow.npz"]


def test_a_file_where_a_parent_folder_should_be_is_a_clear_oserror(tmp_path):
    blocker = tmp_path / "photo.png"
    blocker.write_bytes(b"png")
    with pytest.raises(NotADirectoryError, match=r"photo\.png' is a file, not a folder"):
        clip().save(blocker / "x.npz")
    assert blocker.read_bytes() == b"png"


# ---------------------------------------------------------------------- frame rates


@pytest.mark.parametrize("fps", [1e30, 1e-30, 0.001, 2000.0, 0.0, -1.0, float("inf")])
def test_absurd_frame_rates_are_refused_everywhere(fps, tmp_path):
    with pytest.raises(ValueError, match="fps must be"):
        Clip(np.zeros((2, 4, 4)), fps=fps)
    with pytest.raises(ValueError, match="fps must be"):
        clip().save(tmp_path / "x.mp4", fps=fps)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("fps", [0.01, 1000.0])
def test_the_bounds_themselves_are_accepted_and_written(fps, tmp_path):
    for ext in (".gif", ".mp4", ".npz"):
        back = Clip.load(clip().save(tmp_path / f"x{ext}", fps=fps))
        assert back.fps == fps


def test_a_file_claiming_an_absurd_frame_rate_is_refused_on_reading(tmp_path):
    folder = clip().save(tmp_path / "frames")
    info = json.loads((folder / "clip.json").read_text())
    (folder / "clip.json").write_text(json.dumps({**info, "fps": 1e30}))
    with pytest.raises(ValueError, match=r"clip\.json.*fps must be in \[0\.01, 1000\]"):
        Clip.load(folder)


def test_the_command_lines_fps_is_checked_like_the_librarys(tmp_path, capsys):
    clip().save(tmp_path / "c.npz")
    with pytest.raises(SystemExit) as exc:
        main(["convert", str(tmp_path / "c.npz"), "--fps", "1e30", "-o", str(tmp_path / "x.mp4")])
    assert exc.value.code == 2
    assert "fps must be in [0.01, 1000] frames per second, got 1e+30" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.npz"]
