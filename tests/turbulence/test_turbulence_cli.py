"""``fluidnb turbulence (--target T --source S | --sample) [options] -o OUT.npz``."""

import numpy as np
import pytest

from fluidnb import Clip
from fluidnb.cli import build_parser, main
from fluidnb.turbulence import Flow

QUICK = ["--sample", "--quick", "--frames", "5"]


@pytest.fixture(autouse=True)
def cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


@pytest.fixture
def pair(tmp_path):
    """The quick sample pair written by --save-sample."""
    assert main(["turbulence", *QUICK, "--save-sample", str(tmp_path / "pair")]) == 0
    return tmp_path / "pair"


def test_the_command_is_registered(capsys):
    assert main([]) == 0
    assert "turbulence" in capsys.readouterr().out
    args = build_parser().parse_args(
        ["turbulence", "--sample", "--B", "8", "--strategy", "exact-fft"]
    )
    assert (args.B, args.strategy, args.b) == (8, "exact-fft", None)


def test_sample_writes_the_flow_a_render_and_a_summary(tmp_path, capsys):
    out, gif = tmp_path / "synth.npz", tmp_path / "synth.gif"
    code = main(["turbulence", *QUICK, "--errors", "-o", str(out), "--render", str(gif)])
    assert code == 0
    captured = capsys.readouterr()
    assert "adaptive:" in captured.out
    assert "ms of local search per frame" in captured.out
    assert "relative error 0.0000" in captured.out
    assert f"wrote {out}" in captured.out
    assert "100% done" in captured.err  # the progress line
    flow = Flow.load(out)
    assert flow.shape == (96, 64)
    assert flow.n_frames == 5
    assert np.abs(flow.velocity).max() > 0
    clip = Clip.load(gif)
    assert clip.n_frames == 5
    assert clip.shape == (96, 64)


def test_render_all_puts_the_three_flows_side_by_side(tmp_path):
    out = tmp_path / "all.npz"
    assert main(["turbulence", *QUICK, "--render", str(out), "--render-all", "--fps", "8"]) == 0
    clip = Clip.load(out)
    assert clip.shape == (96, 3 * 64 + 2 * 2)
    assert clip.fps == 8
    assert clip.metadata["flow"] == "target | source | synthesised"


def test_saved_sample_gives_the_same_flow_as_the_sample(pair, tmp_path, capsys):
    assert sorted(p.name for p in pair.iterdir()) == ["source.npz", "target.npz"]
    assert Flow.load(pair / "target.npz").shape == (12, 8)
    options = ["--strategy", "interval", "--interval", "4", "--beta", "0.5"]
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    files = ["--target", str(pair / "target.npz"), "--source", str(pair / "source.npz")]
    assert main(["turbulence", *files, *options, "-o", str(a)]) == 0
    assert "interval 4:" in capsys.readouterr().out
    assert main(["turbulence", *QUICK, *options, "-o", str(b)]) == 0
    np.testing.assert_array_equal(Flow.load(a).velocity, Flow.load(b).velocity)
    # --frames cuts given flows too.
    assert main(["turbulence", *files, "--frames", "3", "-o", str(a)]) == 0
    assert Flow.load(a).n_frames == 3


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--B", "12"], "B must divide the source grid (96, 64), got B = 12"),
        (["--b", "2"], "b must be > B dX/dx = 16/8 = 2"),
        (["--m0", "3"], "m0 must be a power of 2"),
        (["--alpha", "-1"], "alpha must be"),
        (["--frames", "9"], "--frames must be <= the flows' 5 frames, got 9"),
        (["--quick"], "--quick picks the sample's size"),
        (["--sample"], "either --target/--source or --sample"),
        (["--render-all"], "--render-all needs --render"),
    ],
)
def test_bad_options_exit_2_with_a_message(pair, tmp_path, capsys, extra, message):
    files = ["--target", str(pair / "target.npz"), "--source", str(pair / "source.npz")]
    code = main(["turbulence", *files, *extra, "-o", str(tmp_path / "x.npz")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("fluidnb turbulence: error:")
    assert message in err
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--sample", "-o", "x.gif"], "-o must end in .npz"),
        (["--sample"], "nothing to write"),
        (["-o", "x.npz"], "give --target T.npz and --source S.npz, or --sample"),
        (["--target", "t.npz", "-o", "x.npz"], "give both --target and --source"),
        (["--target", "MISSING.npz", "--source", "s.npz", "-o", "x.npz"], "--target: path"),
        (["--sample", "--frames", "0", "-o", "x.npz"], "--frames must be"),
    ],
)
def test_bad_inputs_exit_2_with_a_message(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    assert main(["turbulence", *args]) == 2
    assert message in capsys.readouterr().err


def test_a_file_that_is_not_a_flow_is_refused(pair, tmp_path, capsys):
    np.savez(tmp_path / "bad.npz", velocity=np.zeros((2, 4, 4, 2)))
    code = main(
        ["turbulence", "--target", str(tmp_path / "bad.npz"), "--source", str(pair / "source.npz")]
        + ["-o", str(tmp_path / "x.npz")]
    )
    assert code == 2
    assert "--target: path" in capsys.readouterr().err
