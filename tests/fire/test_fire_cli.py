"""``fluidnb fire PHOTO [--matte M] [--sim SIM.npz] [options] -o OUT``."""

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, data, to_uint8
from fluidnb.cli import main
from fluidnb.fire import FireParams


@pytest.fixture
def files(tmp_path):
    photo, matte = data.sample("fire", size=40, return_alpha=True)
    Image.fromarray(to_uint8(photo)).save(tmp_path / "photo.png")
    Image.fromarray(to_uint8(matte)).save(tmp_path / "matte.png")
    n, t = 24, 6
    yy, xx = np.mgrid[:n, :n].astype(np.float32)
    temp = np.stack([np.exp(-((xx - 12) ** 2 + (yy - 15 + k) ** 2) / 30) for k in range(t)])
    vel = np.zeros((t, n, n, 2), np.float32)
    vel[..., 0] = -1.0
    np.savez(tmp_path / "sim.npz", temperature=temp, velocity=vel)
    return tmp_path


def test_fire_writes_a_clip_with_the_given_parameters(files, capsys):
    out = files / "out.npz"
    code = main(
        [
            "fire",
            str(files / "photo.png"),
            "--matte",
            str(files / "matte.png"),
            "--sim",
            str(files / "sim.npz"),
            "--frames",
            "5",
            "--interval",
            "4",
            "--overlap",
            "2",
            "--weight",
            "0.7",
            "--no-second-pass",
            "--seed",
            "3",
            "-o",
            str(out),
            "--temperature-output",
            str(files / "temp.npz"),
        ]
    )
    assert code == 0
    assert "wrote" in capsys.readouterr().out
    clip = Clip.load(out)
    # The defaults: 256 px and 24 fps, 3 clip frames a simulation frame (4 intervals).
    assert clip.n_frames == 13
    assert clip.shape == (256, 256)
    assert clip.fps == 24
    meta = clip.metadata
    assert meta["method"] == "fire"
    assert meta["seed"] == 3
    expected = FireParams(interval=4, overlap=2, weight=0.7, second_pass=False)
    assert meta["params"] == expected.to_dict()
    assert Clip.load(files / "temp.npz").n_frames == 5


def test_paper_gives_the_papers_set_up_and_options_change_it(files):
    args = ["fire", str(files / "photo.png"), "--sim", str(files / "sim.npz"), "--seed", "1"]
    assert main([*args, "--paper", "-o", str(files / "p.npz")]) == 0
    clip = Clip.load(files / "p.npz")
    assert (clip.n_frames, clip.shape, clip.fps) == (6, (24, 24), 8)
    assert clip.metadata["params"] == FireParams.paper().to_dict()
    assert main([*args, "--paper", "--fps", "16", "-o", str(files / "q.npz")]) == 0
    clip = Clip.load(files / "q.npz")
    assert (clip.n_frames, clip.shape, clip.fps) == (11, (24, 24), 16)


def test_same_seed_same_file(files):
    args = ["fire", str(files / "photo.png"), "--sim", str(files / "sim.npz"), "--seed", "1"]
    assert main([*args, "-o", str(files / "a.npz")]) == 0
    assert main([*args, "-o", str(files / "b.npz")]) == 0
    np.testing.assert_array_equal(
        Clip.load(files / "a.npz").frames, Clip.load(files / "b.npz").frames
    )


def test_a_saved_simulation_is_read_with_its_velocity_at_the_pixels(files):
    fluid = pytest.importorskip("fluidnb.fluid")
    sim = fluid.simulate(fluid.FluidParams(), 3, shape=(24, 24), seed=0)
    sim.save(files / "saved.npz")
    code = main(
        ["fire", str(files / "photo.png"), "--sim", str(files / "saved.npz"), "--seed", "0"]
        + ["-o", str(files / "c.npz")]
    )
    assert code == 0
    assert Clip.load(files / "c.npz").n_frames == 7  # 3 simulation frames at 24 fps


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--interval", "4", "--overlap", "4"], "overlap must be < interval"),
        (["--size", "4"], "size must be an odd integer"),
        (["--frames", "99"], "--frames must be <= the simulation's 6 frames"),
        (["--matte", "MISSING"], "--matte"),
        (["--fps", "0"], "fps must be in [1, 120], got 0"),
        (["--fps", "500"], "fps must be in [1, 120], got 500"),
        (["--output-size", "8"], "output_size must be 0 (the simulation's grid) or >= 16"),
        (["--output-size", "-3"], "output_size must be an integer in [0, 4096], got -3"),
    ],
)
def test_bad_options_exit_2_with_a_message(files, capsys, extra, message):
    code = main(
        ["fire", str(files / "photo.png"), "--sim", str(files / "sim.npz"), *extra]
        + ["-o", str(files / "x.npz")]
    )
    assert code == 2
    assert message in capsys.readouterr().err


def test_a_sim_file_without_the_arrays_is_refused(files, capsys):
    np.savez(files / "bad.npz", temperature=np.zeros((2, 4, 4)))
    code = main(["fire", str(files / "photo.png"), "--sim", str(files / "bad.npz"), "-o", "x.npz"])
    assert code == 2
    assert "missing velocity" in capsys.readouterr().err


def test_without_sim_the_flame_preset_is_simulated(files):
    pytest.importorskip("fluidnb.fluid")
    out = files / "flame.npz"
    code = main(["fire", str(files / "photo.png"), "--frames", "2", "--seed", "0", "-o", str(out)])
    assert code == 0
    clip = Clip.load(out)
    assert clip.n_frames == 4  # 2 simulation frames, 1/8 s apart, at 24 fps
    assert clip.shape == (256, 256)  # the preset's 128 x 128 grid, synthesised at 256
    assert "fluid_params" in clip.metadata


def test_an_rgba_cutout_is_read_with_its_alpha_as_the_matte(files):
    # `fluidnb fire flame.png` on a cut-out whose clear pixels hold random colour:
    # before, every frame was a solid rectangle of that colour.
    rgb, alpha = data.sample("fire", size=40, return_alpha=True)
    straight = np.clip(rgb / np.maximum(alpha[..., None], 1e-6), 0, 1)
    junk = np.random.default_rng(0).random(rgb.shape)
    straight = np.where(alpha[..., None] > 0, straight, junk)
    Image.fromarray(to_uint8(np.dstack([straight, alpha])), mode="RGBA").save(files / "cut.png")
    out = files / "cut.npz"
    code = main(
        ["fire", str(files / "cut.png"), "--sim", str(files / "sim.npz"), "--paper", "-o", str(out)]
    )
    assert code == 0
    frames = Clip.load(out).frames
    temp = np.load(files / "sim.npz")["temperature"]
    cold = temp < 0.01 * temp.max()
    lum = frames @ np.array([0.2126, 0.7152, 0.0722])
    assert lum[cold].mean() < 0.01
    assert np.corrcoef(lum.ravel(), temp.ravel())[0, 1] > 0.8
