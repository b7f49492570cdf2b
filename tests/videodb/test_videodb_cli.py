"""``fluidnb videodb build|add|info`` and ``fluidnb animate``, as a user types them."""

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage as ndi

from fluidnb import Clip, load_clip, to_uint8
from fluidnb.cli import main
from fluidnb.sketch import save_strokes

SMALL = ["--N", "8", "--augment", "flip", "--words", "16", "--codebook-samples", "5000"]


def moving(seed, velocity, shape=(96, 120), frames=16):
    gen = np.random.default_rng(seed)
    base = ndi.gaussian_filter(gen.random(shape), 1.5, mode="wrap")
    base = (base - base.min()) / (base.max() - base.min())
    dy, dx = velocity
    out = np.stack([np.roll(base, (t * dy, t * dx), axis=(0, 1)) for t in range(frames)])
    return np.repeat(out[..., None], 3, axis=3).astype(np.float32)


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    d = tmp_path_factory.mktemp("videos")
    for name, v in (("right", (0, 1)), ("down", (1, 0)), ("left", (0, -2))):
        Clip(moving(len(name), v), fps=12).save(d / f"{name}.mp4")
    return d


@pytest.fixture(scope="module")
def store(videos, tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "db"
    argv = ["videodb", "build", str(path), str(videos / "right.mp4"), str(videos / "down.mp4")]
    assert main([*argv, "--kind", "river", "--workers", "2", *SMALL]) == 0
    return path


def test_build_then_info_lists_the_clips(store, capsys):
    assert main(["videodb", "info", str(store)]) == 0
    out = capsys.readouterr().out
    assert "kind 'river': 2 clips" in out
    assert "'right'" in out
    assert "'down'" in out


def test_add_a_users_mp4(store, videos, tmp_path, capsys):
    import shutil

    copy = tmp_path / "db"
    shutil.copytree(store, copy)
    assert main(["videodb", "add", str(copy), str(videos / "left.mp4")]) == 0
    assert "3 clips" in capsys.readouterr().out
    assert main(["videodb", "add", str(copy), str(videos / "left.mp4")]) == 2
    assert "same clip" in capsys.readouterr().err


def test_build_errors_are_one_clear_line(tmp_path, capsys):
    assert (
        main(["videodb", "build", str(tmp_path / "db"), str(tmp_path / "none.mp4"), "--kind", "x"])
        == 2
    )
    assert "no such file" in capsys.readouterr().err
    assert main(["videodb", "build", str(tmp_path / "db2"), str(tmp_path / "a.mp4")]) == 2
    assert "--kind is required" in capsys.readouterr().err
    assert main(["videodb", "info", str(tmp_path)]) == 2
    assert "not a fluidnb video database" in capsys.readouterr().err


@pytest.mark.parametrize("rendering", ["paper", "flow", None])
def test_animate_a_photo_with_strokes_and_speed(store, tmp_path, capsys, rendering, monkeypatch):
    import fluidnb.cli._animate as command

    tuned = []  # the allocator's settings for the command's process (issue 39)
    monkeypatch.setattr(command, "reuse_freed_memory", lambda: tuned.append(True))
    gen = np.random.default_rng(3)
    photo = ndi.gaussian_filter(gen.random((80, 110)), 2.0)
    photo = (photo - photo.min()) / (photo.max() - photo.min())
    Image.fromarray(to_uint8(np.stack([photo] * 3, axis=-1))).save(tmp_path / "photo.png")
    matte = np.zeros((80, 110), np.float32)
    matte[10:70, 20:90] = 1
    Image.fromarray(to_uint8(matte)).save(tmp_path / "matte.png")
    save_strokes(tmp_path / "s.json", [[[40, 100], [40, 10]]], (80, 110))  # to the left
    Image.fromarray(to_uint8(matte * 0.25)).save(tmp_path / "speed.png")  # 1 px/frame
    out = tmp_path / "out.npz"
    argv = [
        "animate",
        str(tmp_path / "photo.png"),
        "--matte",
        str(tmp_path / "matte.png"),
        "--db",
        str(store),
        "--strokes",
        str(tmp_path / "s.json"),
        "--speed",
        str(tmp_path / "speed.png"),
        "--candidates",
        "20",
        "--lambda",
        "0.02",
        "--loop",
        "2",
        "--seed",
        "1",
        "-o",
        str(out),
    ]
    if rendering is not None:
        argv += ["--rendering", rendering]
    assert main(argv) == 0
    assert tuned == [True]
    assert "wrote" in capsys.readouterr().out
    clip = load_clip(out)
    # --rendering round-trips into the clip's parameters; flow is the default.
    assert clip.metadata["params"]["rendering"] == (rendering or "flow")
    if rendering == "paper":
        assert clip.frames.shape == (6, 80, 110, 3)  # N - loop
    else:  # whole repeats of the N - loop frames of the differences
        assert clip.frames.shape[1:] == (80, 110, 3)
        assert len(clip.frames) % 6 == 0
    assert clip.metadata["params"]["lam"] == 0.02
    assert clip.metadata["params"]["candidates"] == 20
    assert clip.metadata["seed"] == 1
    still = np.abs(clip.frames - clip.frames[:1]).max(axis=(0, 3))
    assert (still[matte == 0] == 0).all()
    assert still[matte == 1].mean() > 0


def test_animate_refuses_strokes_drawn_on_another_image(store, tmp_path, capsys):
    Image.fromarray(np.zeros((60, 60, 3), np.uint8)).save(tmp_path / "p.png")
    save_strokes(tmp_path / "s.json", [[[1, 1], [5, 5]]], (80, 110))
    code = main(
        [
            "animate",
            str(tmp_path / "p.png"),
            "--db",
            str(store),
            "--strokes",
            str(tmp_path / "s.json"),
            "-o",
            str(tmp_path / "o.gif"),
        ]
    )
    assert code == 2
    assert "drawn on a 80 x 110 image" in capsys.readouterr().err
