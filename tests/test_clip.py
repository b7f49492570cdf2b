"""Tests for fluidnb._clip (the Clip value type) and fluidnb._media (its files and display)."""

from __future__ import annotations

import json
import pickle
import re

import numpy as np
import pytest
from PIL import Image

from fluidnb import _media
from fluidnb._clip import Clip, load_clip

# ---------------------------------------------------------------------- helpers


def smooth_clip(t=16, h=32, w=48, color=True, fps=8.0, metadata=None):
    """A smooth moving pattern: what fluid clips look like, and kind to lossy codecs."""
    tt = np.linspace(0.0, 1.0, t)[:, None, None]
    y, x = np.mgrid[0:h, 0:w]
    y, x = y / h, x / w
    r = 0.5 + 0.4 * np.sin(2 * np.pi * (x + tt))
    if not color:
        return Clip(r, fps=fps, metadata=metadata)
    g = 0.5 + 0.4 * np.cos(2 * np.pi * (y - tt))
    b = 0.5 + 0.3 * np.sin(2 * np.pi * (x + y + 0.5 * tt))
    return Clip(np.stack([r, g, b], axis=-1), fps=fps, metadata=metadata)


def random_clip(shape, seed=0):
    rng = np.random.default_rng(seed)
    return Clip(rng.random(shape, dtype=np.float32))


def quantised(clip):
    return clip.to_uint8().astype(np.float32) / np.float32(255)


METADATA = {
    "method": "flicker",
    "params": {"sigma": 2.5, "lam": 0.1, "mapping": "convex", "sizes": [1, 2]},
    "seed": 0,
    "timings": {"solve": 0.25, "render": 0.125},
    "note": 'unicode ✓ and "quotes" = ; # \\ \n',
}


# ---------------------------------------------------------------------- construction


def test_float_frames_are_copied_to_float32_read_only():
    src = np.random.default_rng(0).random((3, 4, 5))
    clip = Clip(src, fps=10)
    assert clip.frames.dtype == np.float32
    assert clip.frames.flags.c_contiguous
    assert not clip.frames.flags.writeable
    np.testing.assert_array_equal(clip.frames, src.astype(np.float32))
    with pytest.raises(ValueError, match="read-only"):
        clip.frames[0, 0, 0] = 1.0
    with pytest.raises(ValueError, match="WRITEABLE"):
        clip.frames.setflags(write=True)


def test_input_is_not_modified_nor_aliased():
    src = np.random.default_rng(0).random((3, 4, 5)).astype(np.float32)
    before = src.copy()
    clip = Clip(src)
    assert not np.shares_memory(clip.frames, src)
    np.testing.assert_array_equal(src, before)
    assert src.flags.writeable
    src[:] = 0.0  # changing the caller's array afterwards leaves the clip alone
    np.testing.assert_array_equal(clip.frames, before)


def test_metadata_is_copied_in_and_out():
    meta = {"method": "flicker", "params": {"sigma": 1.0}}
    clip = Clip(np.zeros((2, 3, 3)), metadata=meta)
    meta["params"]["sigma"] = 99.0
    got = clip.metadata
    got["method"] = "changed"
    assert clip.metadata == {"method": "flicker", "params": {"sigma": 1.0}}


def test_uint8_uint16_and_bool_are_scaled():
    u8 = np.array([[[0, 128, 255]]], dtype=np.uint8)
    np.testing.assert_allclose(Clip(u8).frames, u8 / 255.0, rtol=1e-6)
    u16 = np.array([[[0, 65535]]], dtype=np.uint16)
    np.testing.assert_array_equal(Clip(u16).frames, [[[0.0, 1.0]]])
    np.testing.assert_array_equal(Clip(np.array([[[True, False]]])).frames, [[[1.0, 0.0]]])


def test_channel_axis_of_one_is_squeezed_and_alpha_dropped():
    grey = Clip(np.zeros((2, 3, 4, 1), dtype=np.uint8))
    assert grey.frames.shape == (2, 3, 4)
    assert not grey.is_color
    rgba = np.random.default_rng(0).integers(0, 256, (2, 3, 4, 4), dtype=np.uint8)
    clip = Clip(rgba)
    assert clip.frames.shape == (2, 3, 4, 3)
    assert clip.is_color
    np.testing.assert_allclose(clip.frames, rgba[..., :3] / 255.0, rtol=1e-6)


def test_nested_lists_and_tiny_float_excursions_are_accepted():
    clip = Clip([[[0.0, 1.0 + 1e-7]], [[-1e-7, 0.5]]])
    assert clip.frames.shape == (2, 1, 2)
    assert clip.frames.min() == 0.0
    assert clip.frames.max() == 1.0


def test_metadata_numpy_values_and_tuples_become_plain_python():
    clip = Clip(
        np.zeros((1, 2, 2)),
        metadata={
            "seed": np.int64(3),
            "sigma": np.float32(0.5),
            "flag": np.bool_(True),
            "size": (4, 5),
            "grid": np.arange(3),
            "name": np.str_("x"),
        },
    )
    meta = clip.metadata
    assert meta == {
        "seed": 3,
        "sigma": 0.5,
        "flag": True,
        "size": [4, 5],
        "grid": [0, 1, 2],
        "name": "x",
    }
    assert type(meta["seed"]) is int
    assert type(meta["sigma"]) is float
    json.dumps(meta)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"frames": np.full((2, 3, 3), np.nan)}, "frames"),
        ({"frames": np.zeros((3, 3))}, "frames"),
        ({"frames": np.zeros((2, 3, 3, 2))}, "frames"),
        ({"frames": np.zeros((0, 3, 3))}, "frames"),
        ({"frames": np.zeros((2, 0, 3))}, "frames"),
        ({"frames": np.full((2, 3, 3), 1.5)}, "frames"),
        ({"frames": np.full((2, 3, 3), -0.5)}, "frames"),
        ({"frames": np.zeros((2, 3, 3), dtype=np.int64)}, "frames"),
        ({"frames": [[[0.0, 1.0]], [[0.0]]]}, "frames"),
        ({"fps": 0}, "fps"),
        ({"fps": -1.0}, "fps"),
        ({"fps": float("nan")}, "fps"),
        ({"fps": float("inf")}, "fps"),
        ({"fps": "8"}, "fps"),
        ({"metadata": {"bad": object()}}, "metadata"),
        ({"metadata": {"bad": {"deeper": {1, 2}}}}, "metadata"),
        ({"metadata": {"x": float("nan")}}, "metadata"),
        ({"metadata": {1: "int key"}}, "metadata"),
        ({"metadata": ["not", "a", "dict"]}, "metadata"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, name):
    args = {"frames": np.zeros((2, 3, 3)), **kwargs}
    with pytest.raises(ValueError, match=rf"\b{name}\b"):
        Clip(**args)


# ---------------------------------------------------------------------- properties


def test_properties():
    clip = Clip(np.zeros((16, 32, 48, 3)), fps=4, metadata={"method": "reiter"})
    assert clip.n_frames == len(clip) == 16
    assert clip.shape == (32, 48)
    assert clip.is_color
    assert clip.fps == 4.0
    assert isinstance(clip.fps, float)
    assert clip.duration == pytest.approx(4.0)
    assert isinstance(clip.metadata, dict)


def test_repr():
    clip = Clip(np.zeros((64, 128, 128, 3)), fps=8, metadata={"method": "flicker"})
    assert repr(clip) == "Clip(64 frames, 128x128 RGB, 8 fps, method='flicker')"
    assert repr(Clip(np.zeros((1, 10, 20)), fps=12.5)) == "Clip(1 frame, 20x10 grey, 12.5 fps)"


def test_indexing_slicing_and_iteration():
    clip = random_clip((6, 4, 5, 3)).with_metadata(method="m")
    frame = clip[2]
    assert frame.shape == (4, 5, 3)
    np.testing.assert_array_equal(frame, clip.frames[2])
    assert not frame.flags.writeable
    np.testing.assert_array_equal(clip[-1], clip.frames[5])
    np.testing.assert_array_equal(clip[np.int64(1)], clip.frames[1])

    sub = clip[1:4]
    assert isinstance(sub, Clip)
    assert sub.n_frames == 3
    assert sub.fps == clip.fps
    assert sub.metadata == clip.metadata
    np.testing.assert_array_equal(sub.frames, clip.frames[1:4])
    assert not sub.frames.flags.writeable

    stepped = clip[::2]
    assert stepped.n_frames == 3
    assert not stepped.frames.flags.writeable
    with pytest.raises(ValueError, match="WRITEABLE"):
        stepped.frames.setflags(write=True)
    np.testing.assert_array_equal(clip[[0, 5]].frames, clip.frames[[0, 5]])

    frames = list(clip)
    assert len(frames) == 6
    np.testing.assert_array_equal(frames[3], clip.frames[3])

    with pytest.raises(IndexError):
        clip[6]
    with pytest.raises(IndexError, match="no frames"):
        clip[3:3]
    with pytest.raises(TypeError):
        clip["a"]


def test_to_uint8_rounds():
    clip = Clip(np.array([[[0.0, 0.5, 1.0, 0.999]]]))
    out = clip.to_uint8()
    assert out.dtype == np.uint8
    assert out.tolist() == [[[0, 128, 255, 255]]]
    out[...] = 0  # a new array: the clip is unaffected
    assert clip.frames.max() == 1.0


def test_with_metadata_shares_frames_and_leaves_original():
    clip = Clip(np.zeros((2, 3, 3)), metadata={"seed": 1, "method": "a"})
    other = clip.with_metadata(method="b", timings={"solve": np.float64(0.5)})
    assert other.metadata == {"seed": 1, "method": "b", "timings": {"solve": 0.5}}
    assert clip.metadata == {"seed": 1, "method": "a"}
    assert np.shares_memory(other.frames, clip.frames)
    assert other.fps == clip.fps
    with pytest.raises(ValueError, match="metadata"):
        clip.with_metadata(bad=object())


def test_pickle_round_trip_stays_read_only():
    clip = smooth_clip(metadata={"method": "x"})
    back = pickle.loads(pickle.dumps(clip))
    np.testing.assert_array_equal(back.frames, clip.frames)
    assert back.fps == clip.fps
    assert back.metadata == clip.metadata
    assert not back.frames.flags.writeable


# ---------------------------------------------------------------------- montage


def test_montage_shape_and_content():
    clip = random_clip((10, 20, 30))
    img = clip.montage(n=4, cols=2)
    assert img.shape == (2 * 20 + 2, 2 * 30 + 2)
    assert img.dtype == np.float32
    np.testing.assert_array_equal(img[:20, :30], clip.frames[0])
    np.testing.assert_array_equal(img[22:, 32:], clip.frames[9])  # last tile: last frame
    assert np.all(img[20:22, :] == 1.0)  # separators
    assert np.all(img[:, 30:32] == 1.0)


def test_montage_defaults_and_caps():
    clip = random_clip((10, 8, 9, 3))
    assert clip.montage().shape == (8, 6 * 9 + 5 * 2, 3)  # one row of six
    assert clip.montage(n=50, cols=4).shape == (3 * 8 + 2 * 2, 4 * 9 + 3 * 2, 3)  # all 10
    one = clip.montage(n=1)
    np.testing.assert_array_equal(one, clip.frames[0])
    assert one.flags.writeable
    with pytest.raises(ValueError, match=r"\bn\b"):
        clip.montage(n=0)
    with pytest.raises(ValueError, match="cols"):
        clip.montage(cols=0)


# ---------------------------------------------------------------------- npz


@pytest.mark.parametrize("color", [False, True])
def test_npz_round_trip_is_exact(tmp_path, color):
    clip = random_clip((5, 7, 9, 3) if color else (5, 7, 9)).with_metadata(**METADATA)
    clip = Clip(clip.frames, fps=12.5, metadata=clip.metadata)
    path = clip.save(tmp_path / "clip.npz")
    assert path == tmp_path / "clip.npz"
    back = Clip.load(path)
    np.testing.assert_array_equal(back.frames, clip.frames)
    assert back.frames.dtype == np.float32
    assert back.fps == 12.5
    assert back.metadata == clip.metadata
    assert back.is_color == color
    with np.load(path, allow_pickle=False) as data:
        assert json.loads(str(data["metadata"])) == clip.metadata


def test_save_creates_parents_and_fps_override(tmp_path):
    clip = random_clip((3, 4, 4))
    path = clip.save(str(tmp_path / "a" / "b" / "clip.npz"), fps=24)
    assert path.is_file()
    assert load_clip(path).fps == 24.0
    assert clip.fps == 8.0
    assert not [p for p in path.parent.iterdir() if "partial" in p.name]


def test_npz_without_frames_is_refused(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, fps=8.0)
    with pytest.raises(ValueError, match=r"other\.npz.*'frames'"):
        Clip.load(path)


def test_npy_named_npz_is_refused(tmp_path):
    path = tmp_path / "array.npz"
    with open(path, "wb") as f:
        np.save(f, np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match=r"array\.npz.*not an \.npz archive"):
        Clip.load(path)


def test_npz_with_bad_frames_is_refused(tmp_path):
    path = tmp_path / "bad.npz"
    np.savez(path, frames=np.full((2, 3, 3), 2.0), fps=8.0)
    with pytest.raises(ValueError, match=r"bad\.npz.*frames"):
        Clip.load(path)


# ---------------------------------------------------------------------- PNG folder


@pytest.mark.parametrize("color", [False, True])
def test_png_folder_round_trip(tmp_path, color):
    clip = smooth_clip(t=5, h=9, w=11, color=color, fps=6, metadata=METADATA)
    folder = clip.save(tmp_path / "frames")
    assert folder == tmp_path / "frames"
    names = sorted(p.name for p in folder.iterdir())
    assert names == ["clip.json"] + [f"frame_{t:05d}.png" for t in range(5)]
    with Image.open(folder / "frame_00000.png") as im:
        assert im.mode == ("RGB" if color else "L")
    info = json.loads((folder / "clip.json").read_text(encoding="utf-8"))
    assert info["fps"] == 6.0
    assert info["n_frames"] == 5
    back = Clip.load(folder)
    np.testing.assert_array_equal(back.frames, quantised(clip))
    assert back.fps == 6.0
    assert back.metadata == clip.metadata


def test_png_into_existing_folder_with_a_dot_and_overwrite(tmp_path):
    folder = tmp_path / "out.v1"
    folder.mkdir()
    random_clip((6, 4, 4)).save(folder)
    short = random_clip((2, 4, 4), seed=1)
    short.save(folder)  # the longer clip's extra frames must not linger
    assert sorted(p.name for p in folder.glob("frame_*.png")) == [
        "frame_00000.png",
        "frame_00001.png",
    ]
    back = Clip.load(folder)
    np.testing.assert_array_equal(back.frames, quantised(short))


def test_png_folder_without_clip_json_and_empty_folder(tmp_path):
    folder = tmp_path / "seq"
    random_clip((3, 4, 5, 3)).save(folder)
    (folder / "clip.json").unlink()
    back = Clip.load(folder)
    assert back.n_frames == 3
    assert back.fps == 8.0
    assert back.metadata == {}
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"empty.*frame_00000\.png"):
        Clip.load(empty)


def test_png_folder_missing_frame_is_reported(tmp_path):
    folder = random_clip((3, 4, 5)).save(tmp_path / "seq")
    (folder / "frame_00001.png").unlink()
    with pytest.raises(ValueError, match=r"frame_00001\.png"):
        Clip.load(folder)


# ---------------------------------------------------------------------- GIF


def test_gif_round_trip_grey_is_exact_after_quantisation(tmp_path):
    clip = smooth_clip(t=8, h=20, w=30, color=False, fps=10, metadata=METADATA)
    back = Clip.load(clip.save(tmp_path / "grey.gif"))
    assert not back.is_color
    np.testing.assert_array_equal(back.frames, quantised(clip))
    assert back.fps == 10.0
    assert back.metadata == clip.metadata


def test_gif_round_trip_few_colours_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    palette = rng.integers(0, 256, (40, 3), dtype=np.uint8)
    clip = Clip(palette[rng.integers(0, 40, (6, 9, 11))], fps=12.5)
    back = Clip.load(clip.save(tmp_path / "few.gif"))
    assert back.is_color
    np.testing.assert_array_equal(back.frames, clip.frames)
    assert back.fps == 12.5


def test_gif_round_trip_smooth_rgb_is_close(tmp_path):
    clip = smooth_clip(t=12, h=40, w=50)
    back = Clip.load(clip.save(tmp_path / "rgb.gif"))
    assert back.frames.shape == clip.frames.shape
    assert np.abs(back.frames - clip.frames).mean() < 0.05  # a 256-colour palette


def test_gif_keeps_repeated_frames_and_grey_with_three_columns(tmp_path):
    # Pillow merges identical consecutive GIF frames; load must restore the count.
    # And a grey clip 3 pixels wide must not be mistaken for one RGB image.
    frames = np.random.default_rng(0).integers(0, 256, (3, 5, 3), dtype=np.uint8)
    frames = np.concatenate([frames[:1], frames[:1], frames[:1], frames[1:], frames[2:]])
    clip = Clip(frames, fps=20)
    back = Clip.load(clip.save(tmp_path / "rep.gif"))
    assert back.frames.shape == (6, 5, 3)
    np.testing.assert_array_equal(back.frames, clip.frames)


def test_foreign_gif_fps_from_frame_delays(tmp_path):
    path = tmp_path / "foreign.gif"
    ims = [Image.fromarray(np.full((4, 6, 3), v, dtype=np.uint8)) for v in (0, 90, 180)]
    ims[0].save(path, save_all=True, append_images=ims[1:], duration=100, loop=0)
    back = Clip.load(path)
    assert back.fps == pytest.approx(10.0)
    assert back.n_frames == 3
    assert not back.is_color  # equal channels come back grey
    assert back.metadata == {}


# ---------------------------------------------------------------------- MP4


def test_mp4_round_trip(tmp_path):
    clip = smooth_clip(t=16, h=48, w=64, fps=12, metadata=METADATA)
    path = clip.save(tmp_path / "clip.mp4")
    assert path.stat().st_size > 0
    back = Clip.load(path)
    assert back.frames.shape == clip.frames.shape
    assert back.fps == 12.0
    assert back.metadata == clip.metadata
    assert np.abs(back.frames - clip.frames).mean() < 0.05


def test_mp4_odd_size_grey_and_fractional_fps(tmp_path):
    # yuv420p needs even sides: saved padded, loaded cropped back.
    clip = smooth_clip(t=9, h=31, w=45, color=False, fps=7.5)
    back = Clip.load(clip.save(tmp_path / "odd.MP4", quality=9))
    assert back.frames.shape == (9, 31, 45)
    assert not back.is_color
    assert back.fps == 7.5
    assert np.abs(back.frames - clip.frames).mean() < 0.05


def test_mp4_fps_and_metadata_live_in_a_json_sidecar(tmp_path):
    clip = smooth_clip(t=6, h=15, w=21, fps=7.5, metadata=METADATA)
    path = clip.save(tmp_path / "clip.mp4")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["clip.mp4", "clip.mp4.json"]
    info = json.loads((tmp_path / "clip.mp4.json").read_text(encoding="utf-8"))
    assert info["fps"] == 7.5
    assert info["shape"] == [15, 21]
    assert info["metadata"] == clip.metadata
    # Without its sidecar the video still loads: the stream's fps, no metadata, and
    # the even-size padding (16 x 22) is not known to be padding.
    (tmp_path / "clip.mp4.json").unlink()
    back = Clip.load(path)
    assert back.fps == 7.5
    assert back.metadata == {}
    assert back.frames.shape == (6, 16, 22, 3)


def test_truncated_mp4_is_refused(tmp_path):
    path = smooth_clip(t=24, h=32, w=32).save(tmp_path / "cut.mp4")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.mp4.*truncated"):
        Clip.load(path)


def test_damaged_mp4_sidecar_is_refused(tmp_path):
    path = random_clip((3, 8, 8)).save(tmp_path / "x.mp4")
    sidecar = tmp_path / "x.mp4.json"
    sidecar.write_text("{not json", encoding="utf-8")
    with pytest.raises(ValueError, match=r"x\.mp4\.json"):
        Clip.load(path)
    sidecar.write_text(json.dumps({"format": "fluidnb.Clip", "fps": -1}), encoding="utf-8")
    with pytest.raises(ValueError, match=r"x\.mp4\.json.*damaged.*fps"):
        Clip.load(path)


def test_save_quality_is_validated(tmp_path):
    with pytest.raises(ValueError, match="quality"):
        random_clip((2, 4, 4)).save(tmp_path / "q.mp4", quality=0)
    with pytest.raises(ValueError, match="fps"):
        random_clip((2, 4, 4)).save(tmp_path / "q.mp4", fps=0)
    assert not list(tmp_path.iterdir())


def test_failed_encode_leaves_no_file(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("encoder exploded")

    monkeypatch.setattr(_media, "_encode_mp4", broken)
    with pytest.raises(OSError, match="exploded"):
        random_clip((2, 4, 4)).save(tmp_path / "x.mp4")
    assert not list(tmp_path.iterdir())


# ---------------------------------------------------------------------- file errors


def test_unknown_extension_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"\.gif.*\.mp4.*\.npz"):
        random_clip((2, 4, 4)).save(tmp_path / "clip.avi")
    assert not list(tmp_path.iterdir())
    (tmp_path / "clip.avi").write_bytes(b"x")
    with pytest.raises(ValueError, match=r"clip\.avi"):
        Clip.load(tmp_path / "clip.avi")


@pytest.mark.parametrize("name", ["x.npz", "x.gif", "x.mp4"])
def test_corrupt_file_is_refused(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"this is not a clip at all" * 10)
    with pytest.raises(ValueError, match=re.escape(name)):
        Clip.load(path)


@pytest.mark.parametrize("name", ["x.npz", "x.gif", "x.mp4"])
def test_truncated_or_empty_file_is_refused(tmp_path, name):
    path = smooth_clip(t=8).save(tmp_path / name)
    data = path.read_bytes()
    for cut in (data[: len(data) // 3], b""):
        path.write_bytes(cut)
        with pytest.raises(ValueError, match=re.escape(name)):
            Clip.load(path)


def test_damaged_clip_information_is_refused(tmp_path):
    folder = random_clip((2, 4, 4)).save(tmp_path / "seq")
    (folder / "clip.json").write_text("[1, 2", encoding="utf-8")
    with pytest.raises(ValueError, match=r"clip\.json.*Clip\.save"):
        Clip.load(folder)
    bad = {"format": "fluidnb.Clip", "fps": 8.0, "metadata": ["not", "a", "dict"]}
    (folder / "clip.json").write_text(json.dumps(bad), encoding="utf-8")
    with pytest.raises(ValueError, match=r"seq.*metadata must be a dict"):
        Clip.load(folder)
    path = tmp_path / "bad.gif"
    Image.fromarray(np.zeros((4, 4), dtype=np.uint8)).save(
        path, comment=json.dumps({"format": "fluidnb.Clip", "fps": "fast"})
    )
    with pytest.raises(ValueError, match=r"bad\.gif.*damaged.*fps"):
        Clip.load(path)
    path = tmp_path / "meta.npz"
    np.savez(path, frames=np.zeros((1, 2, 2)), fps=8.0, metadata=np.array("{oops"))
    with pytest.raises(ValueError, match=r"meta\.npz.*metadata"):
        Clip.load(path)


def test_png_renamed_to_gif_is_refused(tmp_path):
    path = tmp_path / "frame.gif"
    Image.fromarray(np.zeros((4, 4), dtype=np.uint8)).save(path, format="PNG")
    with pytest.raises(ValueError, match="expected a GIF"):
        Clip.load(path)


@pytest.mark.parametrize("name", ["missing.npz", "missing.gif", "missing.mp4", "missing"])
def test_missing_file_is_refused(tmp_path, name):
    with pytest.raises(ValueError, match=re.escape(name)):
        Clip.load(tmp_path / name)


def test_bad_path_type():
    with pytest.raises(ValueError, match="path"):
        Clip.load(42)


# ---------------------------------------------------------------------- display


def test_repr_html_is_a_video_cached():
    clip = smooth_clip(t=64, h=128, w=128, metadata={"method": "flicker"})
    html = clip._repr_html_()
    assert "<video" in html
    assert "data:video/mp4;base64," in html
    assert "autoplay" in html
    assert "loop" in html
    assert "64 frames" in html
    assert "flicker" in html
    # Encoded once: the second display returns the very same string (no re-encode).
    assert clip._repr_html_() is html


def test_repr_html_single_frame_is_a_png():
    html = Clip(np.zeros((1, 10, 12, 3)))._repr_html_()
    assert "<img" in html
    assert "data:image/png;base64," in html
    assert "<video" not in html


def test_repr_html_falls_back_to_gif(monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("no ffmpeg here")

    monkeypatch.setattr(_media, "_encode_mp4", broken)
    html = smooth_clip(t=4)._repr_html_()
    assert "<video" not in html
    assert "data:image/gif;base64," in html


def _display_size(html):
    m = re.search(r'width="(\d+)" height="(\d+)"', html)
    return int(m.group(1)), int(m.group(2))


def test_repr_html_sizes():
    big = Clip(np.zeros((2, 600, 1000)))
    w, h = _display_size(big._repr_html_())
    assert w <= 480
    assert h <= 480
    assert w % 2 == 0
    assert h % 2 == 0
    tiny = Clip(np.zeros((2, 15, 21, 3)))
    w, h = _display_size(tiny._repr_html_())
    assert w >= 128
    assert w % 2 == 0
    assert h % 2 == 0


def test_an_npz_clip_is_stored_not_deflated(tmp_path):
    # Deflating float32 photo frames saves ~30 % at 15-28x the time (issue 39): stored
    # members, which numpy.load reads as any .npz, the frames exactly.
    import zipfile

    frames = np.random.default_rng(0).random((3, 8, 10, 3), dtype=np.float32)
    Clip(frames, fps=12).save(tmp_path / "c.npz")
    with zipfile.ZipFile(tmp_path / "c.npz") as archive:
        assert {i.compress_type for i in archive.infolist()} == {zipfile.ZIP_STORED}
    with np.load(tmp_path / "c.npz") as f:
        np.testing.assert_array_equal(f["frames"], frames)
    np.testing.assert_array_equal(Clip.load(tmp_path / "c.npz").frames, frames)
