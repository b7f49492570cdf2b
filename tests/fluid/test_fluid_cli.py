"""``fluidnb simulate`` on the command line."""

import numpy as np

from fluidnb import Clip
from fluidnb.cli import main
from fluidnb.fluid import Simulation


def test_simulate_writes_an_npz(tmp_path, capsys):
    out = tmp_path / "flame.npz"
    argv = ["simulate", "--shape", "24,20", "--frames", "4", "--seed", "2"]
    assert main([*argv, "--epsilon", "0.1", "-o", str(out)]) == 0
    sim = Simulation.load(out)
    assert sim.velocity.shape == (4, 24, 20, 2)
    assert sim.temperature.shape == sim.density.shape == (4, 24, 20)
    assert sim.params.epsilon == 0.1
    assert sim.seed == 2
    assert "wrote" in capsys.readouterr().out
    # Same seed, same arrays.
    again = tmp_path / "again.npz"
    assert main([*argv, "--epsilon", "0.1", "-o", str(again)]) == 0
    np.testing.assert_array_equal(Simulation.load(again).temperature, sim.temperature)


def test_simulate_smoke_to_gif(tmp_path):
    out = tmp_path / "smoke.gif"
    argv = ["simulate", "--preset", "smoke", "--shape", "16,24", "--frames", "3", "-o", str(out)]
    assert main(argv) == 0
    clip = Clip.load(out)
    assert clip.n_frames == 3
    assert clip.shape == (16, 24)


def test_simulate_reports_bad_values(tmp_path, capsys):
    out = str(tmp_path / "x.npz")
    assert main(["simulate", "--frames", "2", "--C-r", "-1", "-o", out]) == 2
    assert "C_r" in capsys.readouterr().err
    assert main(["simulate", "--frames", "0", "--shape", "8,8", "-o", out]) == 2
    assert "n_frames" in capsys.readouterr().err
    assert main(["simulate", "--frames", "1", "--shape", "1,8", "-o", out]) == 2
    assert "shape" in capsys.readouterr().err
