"""``fire(..., stream=True)``: the frames made in order, a block at a time, are the clip's.

The command line streams (issue 39: at ``--output-size 1920`` the clip alone would be
gigabytes), so the file it writes must hold the frames of the in-memory clip.
"""

import numpy as np
import pytest

from fluidnb import Clip, FrameStream, data
from fluidnb._media import read
from fluidnb.cli import main
from fluidnb.fire import FireParams, fire


def _simulation(n=20, frames=6):
    yy, xx = np.mgrid[:n, :n].astype(np.float32)
    temp = np.stack([np.exp(-((xx - 10) ** 2 + (yy - 13 + k) ** 2) / 25) for k in range(frames)])
    vel = np.zeros((frames, n, n, 2), np.float32)
    vel[..., 0] = -1.0
    vel[..., 1] = 0.3 * np.sin(yy / 3)  # a sideways sway: the advection does something
    return temp, vel


@pytest.fixture(scope="module")
def photo():
    return data.sample("fire", size=48, return_alpha=True)


# Overlapping segments (two keyframes under way at once) and blocks of many frames;
# the paper's set-up (one keyframe a frame at the end); a block of one frame each.
@pytest.mark.parametrize(
    "params",
    [
        FireParams(output_size=32, interval=6, overlap=3),
        FireParams.paper(interval=2),
        FireParams(output_size=64, interval=4, overlap=1),
    ],
)
def test_the_stream_makes_the_frames_of_the_in_memory_clip(photo, params, monkeypatch):
    image, matte = photo
    if params.output_size == 64:  # one frame a block, as at 1920 px
        monkeypatch.setattr("fluidnb.fire._pipeline._Frames._per_block", lambda self: 1)
    held = fire(image, _simulation(), params, matte=matte, seed=5)
    result = fire(image, _simulation(), params, matte=matte, seed=5, stream=True)
    stream = result.clip
    assert isinstance(stream, FrameStream)
    assert result.keyframes is None  # as large as the clip
    assert result.sources is None
    first = stream.clip()
    assert np.array_equal(first.frames, held.clip.frames)
    # Every pass the same (the generator as it was when the stream was made).
    assert np.array_equal(stream.clip().frames, first.frames)
    assert first.metadata["keyframes"] == held.clip.metadata["keyframes"]
    assert first.metadata["seed"] == held.clip.metadata["seed"] == 5
    assert first.metadata["timings"]["synthesis"] > 0
    # The keyframes of the in-memory result are its clip's frames at the starts
    # where no other segment is under way (the first one), before the clip to [0, 1].
    k0 = held.keyframes[0] * held.weights[0, 0]
    assert np.allclose(held.clip.frames[0], np.clip(k0, 0, 1), atol=1e-6)


@pytest.mark.parametrize("suffix", [".npz", ".mp4"])
def test_a_streamed_fire_writes_the_file_of_the_in_memory_one(photo, tmp_path, suffix):
    image, matte = photo
    params = FireParams(output_size=40, interval=4, overlap=2)
    held = fire(image, _simulation(), params, matte=matte, seed=2).clip
    held.save(tmp_path / f"held{suffix}")
    fire(image, _simulation(), params, matte=matte, seed=2, stream=True).clip.save(
        tmp_path / f"streamed{suffix}"
    )
    a, _, _ = read(tmp_path / f"held{suffix}")
    b, fps, metadata = read(tmp_path / f"streamed{suffix}")
    assert a.shape == b.shape == held.frames.shape
    assert np.array_equal(a, b)
    if suffix == ".npz":
        assert np.array_equal(b, held.frames)
    assert fps == held.fps
    assert metadata["seed"] == 2


def test_a_generator_given_as_the_seed_advances_as_before(photo):
    image, matte = photo
    params = FireParams(output_size=24, interval=4)
    gen = np.random.default_rng(11)
    first = fire(image, _simulation(), params, matte=matte, seed=gen).clip
    second = fire(image, _simulation(), params, matte=matte, seed=gen).clip
    assert not np.array_equal(first.frames, second.frames)  # the generator moved on
    again = np.random.default_rng(11)
    assert np.array_equal(
        fire(image, _simulation(), params, matte=matte, seed=again).clip.frames, first.frames
    )


def test_the_command_line_writes_the_in_memory_clip(photo, tmp_path):
    from PIL import Image

    from fluidnb import to_uint8

    image, matte = photo
    Image.fromarray(to_uint8(image)).save(tmp_path / "photo.png")
    Image.fromarray(to_uint8(matte)).save(tmp_path / "matte.png")
    temp, vel = _simulation()
    np.savez(tmp_path / "sim.npz", temperature=temp, velocity=vel)
    args = ["fire", str(tmp_path / "photo.png"), "--matte", str(tmp_path / "matte.png")]
    args += ["--sim", str(tmp_path / "sim.npz"), "--output-size", "32", "--interval", "4"]
    assert main([*args, "--seed", "4", "-o", str(tmp_path / "out.npz")]) == 0
    written = Clip.load(tmp_path / "out.npz")
    # What the library makes from the files as the command reads them.
    from fluidnb import as_image

    photo_read = as_image(tmp_path / "photo.png", mode="rgb")
    matte_read = as_image(tmp_path / "matte.png", mode="grey")
    held = fire(
        photo_read, (temp, vel), FireParams(output_size=32, interval=4), matte=matte_read, seed=4
    ).clip
    assert np.array_equal(written.frames, held.frames)
    assert written.metadata["keyframes"] == held.metadata["keyframes"]
