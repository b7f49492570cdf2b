"""Streams (fluidnb.FrameStream): a file written as the frames come holds the frames of
the in-memory clip, and memory stays a few frames, not the clip."""

import tracemalloc

import numpy as np
import pytest

from fluidnb import Clip, FrameStream, data
from fluidnb._media import read
from fluidnb.flicker import FlickerModel, FlickerParams, flicker


@pytest.fixture(scope="module")
def model():
    photo = data.sample("ripples", size=48)
    mask = np.zeros(photo.shape[:2], bool)
    mask[6:40, 4:44] = True
    return FlickerModel(photo, mask, FlickerParams(T=40, beta=1.0), seed=7)


@pytest.mark.parametrize("suffix", [".npz", ".mp4", ".gif", ""])
def test_a_streamed_flicker_writes_the_frames_of_the_in_memory_one(model, tmp_path, suffix):
    clip = model.clip()
    clip.save(tmp_path / f"held{suffix}")
    model.stream().save(tmp_path / f"streamed{suffix}")
    held, _, _ = read(tmp_path / f"held{suffix}")
    streamed, fps, metadata = read(tmp_path / f"streamed{suffix}")
    if suffix == ".npz":  # exact float32: the very frames of the clip
        assert np.array_equal(streamed, clip.frames)
    # The same frames decoded (MP4 / GIF / PNG 8-bit): the same file contents.
    assert streamed.shape == held.shape
    assert np.array_equal(streamed, held)
    assert fps == clip.fps
    assert metadata["seed"] == clip.metadata["seed"] == 7
    assert metadata["params"] == clip.metadata["params"]
    assert metadata["timings"]["render"] > 0


def test_the_library_call_streams_the_same_frames(tmp_path):
    photo = data.sample("ripples", size=32)
    params = FlickerParams(T=24)
    clip = flicker(photo, None, params, seed=3)
    stream = flicker(photo, None, params, seed=3, stream=True)
    assert isinstance(stream, FrameStream)
    assert len(stream) == 24
    assert np.array_equal(stream.clip().frames, clip.frames)
    # Two passes over one stream make the same frames (a recipe, not a buffer).
    assert np.array_equal(np.concatenate(list(stream)), clip.frames)


def test_saving_a_stream_holds_a_few_frames_not_the_clip(tmp_path):
    photo = data.sample("ripples", size=(48, 64))
    model = FlickerModel(photo, None, FlickerParams(T=512), seed=1)
    stream = model.stream()
    stream.save(tmp_path / "warm.npz")  # numba's compiled kernels loaded (not frames)
    tracemalloc.start()
    try:
        stream.save(tmp_path / "out.npz")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # Blocks of 16 frames (the one written, the next two being made) and a block's
    # heights, and the writer's buffers: about 100 frames of the 512.
    assert peak < stream.nbytes / 4, (peak, stream.nbytes)
    tracemalloc.start()
    try:
        model.clip()
        _, held = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert held > stream.nbytes  # the check above can fail: holding the clip costs it


def test_a_producer_that_breaks_its_promise_leaves_no_file(tmp_path):
    def short():
        yield np.zeros((3, 4, 5), np.float32)

    stream = FrameStream(short, n_frames=4, shape=(4, 5), fps=10)
    for name in ("out.npz", "out.mp4", "out.gif"):
        with pytest.raises(RuntimeError, match="ended after 3 of the 4"):
            stream.save(tmp_path / name)
        assert not (tmp_path / name).exists()

    def wrong_size():
        yield np.zeros((4, 4, 6), np.float32)

    with pytest.raises(RuntimeError, match="does not fit"):
        FrameStream(wrong_size, n_frames=4, shape=(4, 5), fps=10).save(tmp_path / "x.npz")
    assert not (tmp_path / "x.npz").exists()


def test_a_clip_as_a_stream_saves_the_same_file(tmp_path):
    rng = np.random.default_rng(0)
    clip = Clip(rng.random((5, 6, 7, 3), dtype=np.float32), fps=9, metadata={"method": "x"})
    FrameStream.of_clip(clip).save(tmp_path / "a.npz")
    frames, fps, metadata = read(tmp_path / "a.npz")
    assert np.array_equal(frames, clip.frames)
    assert fps == 9
    assert metadata["method"] == "x"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_frames": 0, "shape": (2, 2), "fps": 5}, "n_frames"),
        ({"n_frames": 2, "shape": (2,), "fps": 5}, "shape"),
        ({"n_frames": 2, "shape": (2, 2), "fps": 0}, "fps"),
    ],
)
def test_bad_stream_arguments_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FrameStream(lambda: iter(()), **kwargs)
    with pytest.raises(ValueError, match="blocks must be a callable"):
        FrameStream([], n_frames=1, shape=(1, 1), fps=1)


def test_a_streamed_frost_writes_the_frames_of_the_in_memory_one(tmp_path, monkeypatch):
    from fluidnb.frost import FrostParams, HexLattice, _render, grow, render

    lattice = HexLattice.hexagon(8, spacing=4)
    grown = grow(lattice, [lattice.center_cell()], FrostParams(beta=0.5), seed=2)
    clip = render(None, lattice, grown, every=7)
    stream = render(None, lattice, grown, every=7, stream=True)
    stream.save(tmp_path / "frost.npz")
    frames, fps, metadata = read(tmp_path / "frost.npz")
    assert np.array_equal(frames, clip.frames)
    assert fps == clip.fps
    assert metadata["frames"] == clip.metadata["frames"]
    assert clip.frames[1:].std(axis=0).max() > 0.05  # the ice grows: frames differ
    # A clip too large to hold is refused with the way out; a stream of it is made.
    monkeypatch.setattr(_render, "_MAX_BYTES", clip.frames.nbytes // 2)
    with pytest.raises(ValueError, match=r"every=14.*stream=True"):
        render(None, lattice, grown, every=7)
    render(None, lattice, grown, every=7, stream=True).save(tmp_path / "big.npz")
    assert np.array_equal(read(tmp_path / "big.npz")[0], clip.frames)
