import io

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, data, to_uint8
from fluidnb.widgets import FramePlayer


def clip(n=5):
    frames = np.stack([np.full((8, 12), i / (n - 1), np.float32) for i in range(n)])
    return Clip(frames, fps=6, metadata={"method": "demo"})


def test_frames_show_and_are_encoded_once():
    p = FramePlayer(clip())
    first = p.image.value
    p.show(3)
    assert p.frame == 3
    assert p._slider.value == 3
    assert p.image.value != first
    cached = p._encoded[3]
    p.show(0)
    p.show(3)
    assert p._encoded[3] is cached  # not re-encoded
    assert bytes(p.image.value) == cached


def test_frames_are_sent_as_jpeg_close_to_the_frame():
    photo = data.sample("stream", size=96)  # a photo: what the apps play
    p = FramePlayer(Clip(np.stack([photo * 0.5, photo, photo[::-1]]), fps=6))
    p.show(1)
    assert p.image.format == "jpeg"
    shown = np.asarray(Image.open(io.BytesIO(bytes(p.image.value))))
    assert shown.shape == photo.shape
    error = np.abs(shown.astype(float) - to_uint8(photo))
    # (A PNG: 0 and 0; quality 95 here: 2.2 and 15.)
    assert error.mean() < 3
    assert error.max() <= 30


def test_slider_drives_the_frame_and_fps_drives_play_interval():
    p = FramePlayer(clip())
    assert p.fps == 6
    p._slider.value = 4
    assert p.frame == 4
    p.fps = 20
    assert p._play.interval == 50
    assert p._play.max == 4
    p.play()
    assert p.playing
    p.play(False)
    assert not p.playing


def test_new_clip_resets_cache_and_bounds():
    p = FramePlayer(clip(5))
    p.show(4)
    p.clip = clip(3)
    assert p.frame == 2
    assert p._play.max == 2
    assert set(p._encoded) == {2}


def test_export_gif_and_mp4_write_files_with_links(tmp_path):
    p = FramePlayer(clip(), export_dir=tmp_path)
    gif = p.export("gif")
    mp4 = p.export("mp4")
    assert gif.exists()
    assert mp4.exists()
    assert gif.parent == tmp_path
    assert Clip.load(gif).n_frames == 5
    assert mp4.name in p.link.value
    assert "<a href=" in p.link.value


def test_export_button_writes_into_the_output_folder_not_beside_the_notebook(tmp_path, monkeypatch):
    # Issue 22, point 8: exports landed among the notebooks (git status dirty).
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("FLUIDNB_OUTPUT_DIR", raising=False)
    p = FramePlayer(clip())
    p._gif.click()
    (written,) = tmp_path.glob("fluidnb-output/fluidnb-demo-*.gif")
    assert list(tmp_path.glob("*.gif")) == []
    assert f"href='fluidnb-output/{written.name}'" in p.link.value
    assert p.exported == f"fluidnb-output/{written.name}"
    monkeypatch.setenv("FLUIDNB_OUTPUT_DIR", str(tmp_path / "class"))
    assert p.export("mp4").parent == tmp_path / "class"


def test_an_export_link_goes_with_its_clip(tmp_path):
    # Issue 22, point 7: an old MP4 link survived a new run.
    p = FramePlayer(clip(), export_dir=tmp_path)
    p.export("gif")
    assert "href" in p.link.value
    p.clip = clip(3)
    assert p.link.value == ""
    assert p.exported == ""
    p.export("gif")
    p.clip = None
    assert p.link.value == ""


def test_errors_without_clip_and_bad_values():
    p = FramePlayer()
    assert p._gif.disabled
    with pytest.raises(ValueError, match="no clip to export"):
        p.export()
    with pytest.raises(ValueError, match="no clip to show"):
        p.show(0)
    p.clip = clip()
    with pytest.raises(ValueError, match=r"frame must be in \[0, 4\]"):
        p.show(9)
    with pytest.raises(ValueError, match="fmt must be 'gif' or 'mp4'"):
        p.export("avi")
    with pytest.raises(ValueError, match=r"clip must be a fluidnb\.Clip"):
        p.clip = np.zeros((3, 4, 4))


def test_info_line_and_small_file_sizes_read_well(tmp_path):
    p = FramePlayer(Clip(np.zeros((2, 4, 4))), export_dir=tmp_path)
    assert "2 frames, 4x4, 8 fps</span>" in p.info.value
    p.export("gif")
    assert "bytes)" in p.link.value
    assert "(0 KB)" not in p.link.value


def test_a_clip_streams_in_and_keeps_playing_when_finished(tmp_path):
    # What an app does while a clip is rendered: the first frames play at once, more
    # come without stopping playback, and the finished clip (the same frames, with
    # its metadata) keeps the encoded frames and the playing.
    p = FramePlayer(clip(4), export_dir=tmp_path)
    p.play()
    frames = np.zeros((6, 8, 12), np.float32)  # the renderer's array, filled in runs
    frames[:2] = 0.5
    streamed = Clip._trusted(frames.view(), 6, {})
    p.stream(streamed, 2)
    assert p.clip is streamed
    assert p.playing
    assert p._play.max == p._slider.max == 1
    assert "2 of 6 frames so far" in p.info.value
    assert p._gif.disabled
    assert p._mp4.disabled
    with pytest.raises(ValueError, match="still being made"):
        p.export("gif")
    with pytest.raises(ValueError, match=r"frame must be in \[0, 1\]"):
        p.show(4)
    p.show(1)
    encoded = p._encoded[1]
    frames[2:] = 1.0
    p.stream(streamed, 6)
    assert p._play.max == 5
    assert p.playing
    assert not p._gif.disabled
    final = Clip._trusted(frames, 6, {}).with_metadata(method="demo")
    p.clip = final
    assert p.playing
    assert p._encoded[1] is encoded
    assert p._play.max == 5
    assert "6 frames" in p.info.value
    assert "demo" in p.info.value
    assert Clip.load(p.export("gif")).n_frames == 6
    # Another clip is a new start: the cache goes, playback stops.
    p.clip = clip(3)
    assert not p.playing
    assert set(p._encoded) == {1}
    with pytest.raises(ValueError, match="ready must be in"):
        p.stream(clip(3), 0)
