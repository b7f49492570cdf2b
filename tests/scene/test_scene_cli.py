"""``fluidnb scene`` on the command line: a photo and regions, or a scene folder."""

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, data
from fluidnb.cli import main
from fluidnb.scene import load_scene


@pytest.fixture
def files(tmp_path):
    photo = data.sample("lake", size=80)  # 45 x 80
    Image.fromarray((photo * 255).round().astype(np.uint8)).save(tmp_path / "lake.png")
    h, w = photo.shape[:2]
    for name, (r0, r1, c0, c1) in {
        "water": (0.45, 0.65, 0.0, 1.0),
        "fire": (0.5, 0.7, 0.7, 0.8),
        "frost": (0.0, 0.4, 0.0, 0.3),
    }.items():
        m = np.zeros((h, w), np.uint8)
        m[int(r0 * h) : int(r1 * h), int(c0 * w) : int(c1 * w)] = 255
        Image.fromarray(m).save(tmp_path / f"{name}.png")
    return tmp_path


def test_regions_then_the_saved_folder_give_the_same_clip(files, capsys):
    out, again, folder = files / "a.npz", files / "b.npz", files / "scene"
    argv = ["scene", str(files / "lake.png"), "--flicker", str(files / "water.png")]
    argv += ["--frost", str(files / "frost.png"), "--size", "0", "--save-scene", str(folder)]
    assert main([*argv, "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "flicker" in printed
    assert "frost" in printed
    assert f"wrote {out}" in printed
    clip = Clip.load(out)
    assert clip.metadata["method"] == "scene"
    assert [x["kind"] for x in clip.metadata["layers"]] == ["flicker", "frost"]
    scene = load_scene(folder)
    assert [layer.kind for layer in scene.layers] == ["flicker", "frost"]
    assert main(["scene", str(folder), "-o", str(again)]) == 0
    np.testing.assert_allclose(Clip.load(again).frames, clip.frames, atol=1e-6)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "give at least one region"),
        (["--strokes", "s.json", "--fire", "fire.png"], "--strokes draws the water's flow"),
        (["--fire", "small.png"], "--fire"),
        (["--fire", "fire.png", "--size", "-3"], "--size must be >= 0"),
        (["--fire", "fire.png", "--fps", "0"], "--fps must be > 0"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(files, capsys, extra, message):
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(files / "small.png")
    (files / "s.json").write_text(
        '{"format": "fluidnb.strokes", "version": 1, "shape": [45, 80], '
        '"strokes": [[[30, 2], [30, 70]]]}'
    )
    argv = ["scene", str(files / "lake.png")]
    argv += [str(files / x) if x.endswith((".png", ".json")) else x for x in extra]
    assert main([*argv, "-o", str(files / "x.npz")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err
    assert "\n" not in err
    assert "Traceback" not in err
    assert not (files / "x.npz").exists()


def test_a_folder_with_regions_is_refused(files, capsys, tmp_path):
    folder = files / "scene"
    folder.mkdir()
    (folder / "scene.json").write_text("{}")
    code = main(
        ["scene", str(folder), "--fire", str(files / "fire.png"), "-o", str(files / "x.npz")]
    )
    assert code == 2
    assert "a scene folder holds its own regions" in capsys.readouterr().err
