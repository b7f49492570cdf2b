"""``fluidnb frost`` on the command line."""

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, data
from fluidnb.cli import build_parser, main


@pytest.fixture
def files(tmp_path):
    image = data.sample("window", size=96)  # 72 x 96
    Image.fromarray((image * 255).astype(np.uint8)).save(tmp_path / "window.png")
    mask = np.zeros(image.shape[:2], np.uint8)
    mask[16:56, 20:76] = 255
    Image.fromarray(mask).save(tmp_path / "mask.png")
    return tmp_path


def test_frost_writes_a_clip_with_start_points_as_x_y(files, capsys):
    out = files / "frost.npz"
    argv = [
        "frost",
        str(files / "window.png"),
        "--region",
        str(files / "mask.png"),
        "--start",
        "48,36",
        "--start",
        "30,20",
        "--beta",
        "0.6",
        "--spacing",
        "3",
        "--every",
        "5",
        "--seed",
        "2",
        "-o",
        str(out),
        "--freeze-times",
        str(files / "freeze.npz"),
    ]
    assert main(argv) == 0
    clip = Clip.load(out)
    meta = clip.metadata
    assert meta["method"] == "frost"
    assert meta["seed"] == 2
    assert meta["params"]["beta"] == 0.6
    assert meta["params"]["spacing"] == 3.0
    assert clip.shape == (72, 96)
    assert clip.fps == pytest.approx(24 / 5)
    printed = capsys.readouterr().out
    assert "lattice:" in printed
    assert "ends at frame" in printed
    saved = np.load(files / "freeze.npz")
    assert saved["end_frame"] == meta["end_frame"]
    # X,Y = column,row: the start point at column 48, row 36 froze at frame 0.
    points = saved["points_rc"]
    first = points[saved["freeze_frame"] == 0]
    assert np.hypot(*(first - [36, 48]).T).min() < 3
    assert np.hypot(*(first - [20, 30]).T).min() < 3


def test_frost_target_optimises_beta_and_prints_the_table(files, capsys):
    out = files / "fit.npz"
    argv = [
        "frost",
        str(files / "window.png"),
        "--region",
        str(files / "mask.png"),
        "--start",
        "48,36",
        "--spacing",
        "4",
        "--target",
        "120",
        "--seed",
        "0",
        "-o",
        str(out),
    ]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "optimising beta for end frame 120 (secant)" in printed
    assert "step      beta  end frame" in printed
    meta = Clip.load(out).metadata
    assert meta["optimise"]["target"] == 120
    assert meta["params"]["beta"] == meta["optimise"]["beta"]
    assert meta["optimise"]["converged"]
    assert abs(meta["end_frame"] - 120) <= 4


def test_frost_says_how_long_the_papers_gamma_takes_and_fit_gamma_fixes_it(files, capsys):
    base = ["frost", str(files / "window.png"), "--region", str(files / "mask.png")]
    argv = [*base, "--start", "20,36", "--spacing", "2", "--every", "40", "--seed", "0"]
    assert main([*argv, "--max-frames", "400", "-o", str(files / "slow.npz")]) == 0
    printed = capsys.readouterr().out
    assert "at gamma = 0.005 the frost ends near frame" in printed
    assert "beyond --max-frames 400" in printed
    assert Clip.load(files / "slow.npz").metadata["end_frame"] is None  # it never got there
    out = files / "fast.npz"
    assert main([*argv, "--target", "100", "--fit-gamma", "-o", str(out)]) == 0
    assert "gamma = " in capsys.readouterr().out
    meta = Clip.load(out).metadata
    assert meta["params"]["gamma"] > 0.005
    assert abs(meta["end_frame"] - 100) <= 4


def test_frost_bad_input_is_a_clear_error(files, capsys):
    base = ["frost", str(files / "window.png"), "--region", str(files / "mask.png")]
    out = ["-o", str(files / "x.npz")]
    assert main([*base, "--start", "2,2", *out]) == 2
    err = capsys.readouterr().err
    assert "--start 2,2 (X,Y = column,row) is outside the region" in err
    assert main([*base, "--start", "48,36", "--rth", "1.5", *out]) == 2
    assert "rth must be in [0, 1], got 1.5" in capsys.readouterr().err
    assert main([*base, "--start", "48,36", "--spacing", "90", *out]) == 2
    assert "leaves no lattice point inside" in capsys.readouterr().err
    # Too fine a lattice is refused before anything is allocated, naming what fits.
    assert main([*base, "--start", "48,36", "--spacing", "0.001", *out]) == 2
    err = capsys.readouterr().err
    assert "spacing=0.001 px would lay" in err
    assert "spacing must be >= 0.05 px" in err
    assert main([*base, "--start", "48,36", "--fit-gamma", *out]) == 2
    assert "--fit-gamma needs --target" in capsys.readouterr().err
    # A target sooner than the ice can travel is refused with the reason.
    assert main([*base, "--start", "48,36", "--target", "1", *out]) == 2
    assert "ice spreads at most one cell a frame" in capsys.readouterr().err
    blank = files / "blank.png"
    Image.fromarray(np.zeros((72, 96), np.uint8)).save(blank)
    assert (
        main(
            [
                "frost",
                str(files / "window.png"),
                "--region",
                str(blank),
                "--start",
                "48,36",
                *out,
            ]
        )
        == 2
    )
    assert "--region is empty" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        build_parser().parse_args(["frost", "img.png", "--start", "3;4", "-o", "x.npz"])
    assert "start point must be X,Y" in capsys.readouterr().err


def test_frost_help_lists_every_parameter():
    parser = build_parser()
    sub = parser._subparsers._group_actions[0].choices["frost"]
    text = sub.format_help()
    for flag in (
        "--beta",
        "--gamma",
        "--alpha",
        "--rth",
        "--spacing",
        "--coverage",
        "--max-frames",
        "--target",
        "--fps",
        "--solver",
        "--start",
        "--eta",
    ):
        assert flag in text
