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
