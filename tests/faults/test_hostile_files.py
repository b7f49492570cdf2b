"""Files a fault probe made to break the readers (issue 37): one clear ValueError each.

JSON nested 200,000 arrays deep ran Python's parser out of recursion (a RecursionError
traceback); a truncated MP4 converted without a word into 2 of its 24 frames; a full
disk during an MP4 export said only "no message".
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from fluidnb import Clip

DEEP = "[" * 200_000 + "]" * 200_000


def test_a_clip_json_nested_too_deeply_is_not_ours(tmp_path):
    folder = Clip(np.zeros((2, 4, 5), np.float32), fps=5).save(tmp_path / "seq")
    (folder / "clip.json").write_text(DEEP)
    with pytest.raises(ValueError, match=r"clip.json.*expected JSON written by Clip.save"):
        Clip.load(folder)
    # Saving into it is refused too: nothing says those frames are ours.
    with pytest.raises(ValueError, match="folder of files fluidnb did not write"):
        Clip(np.zeros((2, 4, 5), np.float32), fps=5).save(folder)


def test_parameters_nested_too_deeply_are_a_value_error():
    from fluidnb.flicker import FlickerParams

    with pytest.raises(ValueError, match="parameters are not valid JSON: nested too deeply"):
        FlickerParams.from_json(DEEP)


@pytest.mark.parametrize("metadata", [DEEP, "[1, 2]"], ids=["deep", "not-an-object"])
def test_saved_simulations_and_flows_with_broken_metadata_are_refused(tmp_path, metadata):
    from fluidnb.fluid import Simulation
    from fluidnb.turbulence import Flow

    path = tmp_path / "broken.npz"
    velocity = np.zeros((1, 4, 4, 2), np.float32)
    np.savez(path, metadata=np.array(metadata), velocity=velocity, density=velocity[..., 0])
    with pytest.raises(ValueError, match=r"is not a saved Simulation: .*its metadata"):
        Simulation.load(path)
    with pytest.raises(ValueError, match=r"is not a saved Flow or Simulation: .*its metadata"):
        Flow.load(path)


def test_the_strokes_reader_refuses_deep_json_with_one_line(tmp_path, capsys):
    from PIL import Image

    from fluidnb.cli import main

    Image.new("L", (64, 48), 128).save(tmp_path / "photo.png")
    head = {"format": "fluidnb.strokes", "version": 1, "shape": [48, 64]}
    text = json.dumps(head)[:-1] + ', "strokes": ' + DEEP + "}"
    (tmp_path / "deep.json").write_text(text)
    argv = ["flicker", str(tmp_path / "photo.png"), "--flow", str(tmp_path / "deep.json")]
    assert main([*argv, "-o", str(tmp_path / "o.gif")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "nested too deeply" in err


def _moving_mp4(path, frames=24):
    gen = np.random.default_rng(7)
    base = gen.random((96, 120)).astype(np.float32)
    clip = Clip(np.stack([np.roll(base, t, axis=1) for t in range(frames)]), fps=12)
    return clip.save(path)


@pytest.mark.parametrize("keep", [0.6, 0.8, 0.9, 0.97])
def test_a_truncated_mp4_is_refused_not_converted_into_fewer_frames(tmp_path, keep, capsys):
    from fluidnb.cli import main

    whole = _moving_mp4(tmp_path / "whole.mp4")
    cut = tmp_path / "cut.mp4"  # a video from elsewhere: no sidecar says how long it was
    cut.write_bytes(whole.read_bytes()[: int(whole.stat().st_size * keep)])
    assert main(["convert", str(cut), "-o", str(tmp_path / "out.gif")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"fluidnb convert: error: cannot read {str(cut)!r}"), err
    assert "truncated or damaged" in err or "expected a video" in err, err
    assert not (tmp_path / "out.gif").exists()
    # With its sidecar, Clip.load says the same.
    (tmp_path / "cut.mp4.json").write_text((tmp_path / "whole.mp4.json").read_text())
    with pytest.raises(ValueError, match=r"cut\.mp4.*(truncated|expected a video)"):
        Clip.load(cut)


def test_a_video_shorter_than_its_audio_is_read_whole(tmp_path):
    import subprocess

    import imageio_ffmpeg

    from fluidnb import _media

    video = _moving_mp4(tmp_path / "video.mp4")
    both = tmp_path / "with-audio.mp4"  # the container lasts 4 s, the video 2 s
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-nostdin", "-i", str(video)]
    cmd += ["-f", "lavfi", "-t", "4", "-i", "anullsrc=r=8000:cl=mono"]
    cmd += ["-map", "0:v", "-map", "1:a", "-c:v", "copy", "-c:a", "aac", str(both)]
    subprocess.run(cmd, check=True, capture_output=True)
    frames, fps, _ = _media.read_video(both)
    assert (len(frames), fps) == (24, 12.0)
    assert Clip.load(both).n_frames == 24
