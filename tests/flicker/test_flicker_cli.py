"""``fluidnb flicker IMAGE [--mask MASK] [options] -o OUT``."""

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, as_image, data, to_uint8
from fluidnb.cli import main
from fluidnb.flicker import FlickerParams


@pytest.fixture
def files(tmp_path):
    photo = data.sample("ripples", size=40)
    Image.fromarray(to_uint8(photo)).save(tmp_path / "photo.png")
    mask = np.zeros(photo.shape[:2], np.uint8)
    mask[8:28, 10:30] = 255
    Image.fromarray(mask).save(tmp_path / "mask.png")
    return tmp_path


def test_flicker_writes_a_clip_with_the_given_parameters(files, capsys):
    out = files / "out.npz"
    code = main(
        [
            "flicker",
            str(files / "photo.png"),
            "--mask",
            str(files / "mask.png"),
            "--T",
            "12",
            "--f0",
            "2",
            "--mapping",
            "plane",
            "--beta",
            "1.5",
            "--seed",
            "3",
            "-o",
            str(out),
        ]
    )
    assert code == 0
    captured = capsys.readouterr()
    assert "wrote" in captured.out
    assert "100%" in captured.err  # the text progress bar
    clip = Clip.load(out)
    assert clip.n_frames == 12
    assert clip.metadata["method"] == "flicker"
    assert clip.metadata["seed"] == 3
    p = FlickerParams.from_dict(clip.metadata["params"])
    assert (p.T, p.f0, p.mapping, p.beta) == (12, 2, "plane", 1.5)
    # Outside the mask the photo is untouched (as read back from the PNG).
    photo = as_image(files / "photo.png")
    outside = as_image(files / "mask.png") < 0.5
    assert np.array_equal(
        clip.frames[:, outside], np.broadcast_to(photo[outside], (12,) + photo[outside].shape)
    )


def test_flicker_writes_a_gif_with_default_parameters(files):
    out = files / "out.gif"
    assert (
        main(["flicker", str(files / "photo.png"), "--T", "10", "--seed", "0", "-o", str(out)]) == 0
    )
    clip = Clip.load(out)
    assert clip.n_frames == 10
    assert clip.fps == pytest.approx(8)


def test_bad_mask_is_a_clear_error_with_status_2(files, capsys):
    small = np.zeros((10, 10), np.uint8)
    Image.fromarray(small).save(files / "small.png")
    out = files / "x.npz"
    code = main(
        ["flicker", str(files / "photo.png"), "--mask", str(files / "small.png"), "-o", str(out)]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("fluidnb flicker: error: --mask must have the same height and width")
    Image.fromarray(np.zeros((40, 40), np.uint8)).save(files / "empty.png")
    assert (
        main(
            [
                "flicker",
                str(files / "photo.png"),
                "--mask",
                str(files / "empty.png"),
                "-o",
                str(out),
            ]
        )
        == 2
    )
    assert "--mask is empty" in capsys.readouterr().err
    assert not out.exists()


def test_bad_parameters_and_missing_image_exit_2(files, capsys):
    out = str(files / "x.npz")
    assert main(["flicker", str(files / "photo.png"), "--T", "8", "--f0", "4", "-o", out]) == 2
    assert "f0 must be < T/2" in capsys.readouterr().err
    assert main(["flicker", str(files / "nope.png"), "-o", out]) == 2
    assert "no such file" in capsys.readouterr().err


def test_help_lists_every_parameter(capsys):
    with pytest.raises(SystemExit):
        main(["flicker", "--help"])
    text = capsys.readouterr().out
    for name in FlickerParams.specs():
        assert "--" + name.replace("_", "-") in text
    assert "--flow" in text


def test_flow_from_a_velocity_or_a_strokes_file(files, capsys):
    from fluidnb.sketch import save_strokes

    out = files / "flow.npz"
    args = ["flicker", str(files / "photo.png"), "--T", "16", "--f0", "2", "--seed", "0"]
    assert main([*args, "--flow", "0,0.5", "-o", str(out)]) == 0
    clip = Clip.load(out)
    assert clip.metadata["params"]["mapping"] == "flow"  # --flow alone picks the mapping
    assert clip.metadata["velocity"] == [0.0, 0.5]
    save_strokes(files / "s.json", [np.array([[20.0, 30.0], [20.0, 22.0]])], (40, 40))
    assert main([*args, "--mapping", "flow", "--flow", str(files / "s.json"), "-o", str(out)]) == 0
    assert Clip.load(out).metadata["velocity"] == [0.0, -0.5]
    assert main([*args, "--flow", "left", "-o", str(out)]) == 2
    assert "--flow must be DY,DX" in capsys.readouterr().err
    assert main([*args, "--mapping", "flow", "-o", str(out)]) == 2
    assert "needs flow=" in capsys.readouterr().err
