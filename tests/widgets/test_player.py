import io
import time

import numpy as np
import pytest
from PIL import Image

from fluidnb import Clip, data, to_uint8
from fluidnb.widgets import FramePlayer


def clip(n=5):
    frames = np.stack([np.full((8, 12), i / (n - 1), np.float32) for i in range(n)])
    return Clip(frames, fps=6, metadata={"method": "demo"})


def sent_frames(p, timeout=5):
    """The frames the player sent to the page: {index: JPEG bytes}, once all are sent."""
    got = {}
    p.view.send = lambda content, buffers=None: got.update(
        {content["start"] + k: bytes(b) for k, b in enumerate(buffers)}
    )
    return got


def wait_for(cond, timeout=5):
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_frames_are_sent_to_the_page_once_and_playing_needs_no_kernel():
    p = FramePlayer()
    got = sent_frames(p)
    c = clip()
    p.clip = c
    wait_for(lambda: len(got) == 5)
    assert p.view.clip_id == 1
    assert p.view.n_frames == p.view.ready == 5
    assert (p.view.width, p.view.height) == (12, 8)
    # Each frame once, in order; the page plays them: show and play send no frames.
    encoded = dict(p._encoded)
    assert set(got) == set(encoded) == set(range(5))
    assert all(got[i] == encoded[i] for i in range(5))
    got.clear()
    p.show(3)
    assert p.frame == p.view.frame == 3
    p.play()
    assert p.view.playing
    time.sleep(0.1)
    assert got == {}
    # A page that reloads asks for what it misses, and gets the frames encoded before.
    p._message(p.view, {"type": "want", "clip": 1, "have": 2}, [])
    wait_for(lambda: set(got) == {2, 3, 4})
    assert all(got[i] == encoded[i] for i in got)
    got.clear()
    p._message(p.view, {"type": "want", "clip": 0, "have": 0}, [])  # an old clip's
    time.sleep(0.1)
    assert got == {}
    p.close()


def test_frames_are_sent_as_jpeg_close_to_the_frame():
    photo = data.sample("stream", size=96)  # a photo: what the apps play
    p = FramePlayer(Clip(np.stack([photo * 0.5, photo, photo[::-1]]), fps=6))
    shown = np.asarray(Image.open(io.BytesIO(p._encode(1))))
    assert shown.shape == photo.shape
    error = np.abs(shown.astype(float) - to_uint8(photo))
    # (A PNG: 0 and 0; quality 95 here: 2.2 and 15.)
    assert error.mean() < 3
    assert error.max() <= 30


def test_the_page_drives_the_frame_and_fps_follows_the_clip():
    p = FramePlayer()
    assert p.fps == 8  # the page shows no fps before a clip
    assert p.view.clip_id == 0
    p.clip = clip()
    assert p.fps == 6
    p.view.frame = 4  # a scrub in the page
    assert p.frame == 4
    p.fps = 20
    assert p.view.fps == 20
    p.play()
    assert p.playing
    p.play(False)
    assert not p.playing
    p.loop = False
    assert not p.view.loop


def test_new_clip_resets_cache_and_bounds():
    p = FramePlayer(clip(5))
    p.show(4)
    p.clip = clip(3)
    assert p.frame == 2
    assert p.view.n_frames == p.view.ready == 3
    assert p.view.clip_id == 2


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
    assert (p.view.ready, p.view.n_frames) == (2, 6)
    assert "2 of 6 frames so far" in p.info.value
    assert p._gif.disabled
    assert p._mp4.disabled
    with pytest.raises(ValueError, match="still being made"):
        p.export("gif")
    with pytest.raises(ValueError, match=r"frame must be in \[0, 1\]"):
        p.show(4)
    p.show(1)
    encoded = p._encode(1)
    frames[2:] = 1.0
    p.stream(streamed, 6)
    assert p.view.ready == 5 + 1
    assert p.playing
    assert not p._gif.disabled
    final = Clip._trusted(frames, 6, {}).with_metadata(method="demo")
    p.clip = final
    assert p.playing
    assert p._encode(1) is encoded
    assert p.view.clip_id == 2  # the same clip in the page: nothing sent again
    assert "6 frames" in p.info.value
    assert "demo" in p.info.value
    assert Clip.load(p.export("gif")).n_frames == 6
    # Another clip is a new start: its own frames (and it plays on).
    p.clip = clip(3)
    assert p.playing
    assert p._encode(1) is not encoded
    with pytest.raises(ValueError, match="ready must be in"):
        p.stream(clip(3), 0)


def test_a_timed_clip_tells_the_page_how_it_was_made_with_its_first_frame_only():
    p = FramePlayer()
    messages = []
    p.view.send = lambda content, buffers=None: messages.append(dict(content))
    before = time.time() * 1000
    p.show_timed(clip(40), {"changed": 1.0, "started": 2.0, "made": 3.0})
    wait_for(lambda: sum(1 for m in messages if m["clip"] == 1) >= 3)
    first = next(m for m in messages if m["start"] == 0)
    assert first["timeline"] == {"changed": 1.0, "started": 2.0, "made": 3.0}
    assert before <= first["sent"] <= time.time() * 1000  # ms since the epoch
    assert all("timeline" not in m and "sent" not in m for m in messages if m["start"] > 0)
    p.clip = clip(3)  # a clip set plainly has no timeline, whatever came before
    wait_for(lambda: any(m["clip"] == 2 for m in messages))
    assert "timeline" not in next(m for m in messages if m["clip"] == 2)
    p.close()


def test_a_preview_sends_its_first_frame_alone_then_the_others_smaller():
    # Issue 36: a flicker preview's 63 other frames (750 KB) went out right behind its
    # first frame, which waited for them on the way to the page. A preview (a clip
    # shown with show_timed) sends its first frame, then the others a moment later, at
    # a lower JPEG quality; a clip set plainly keeps quality 95 and no pause.
    photo = data.sample("stream", size=96)
    frames = np.stack([photo * (0.5 + 0.5 * k / 7) for k in range(8)])
    p = FramePlayer()
    sent = []
    p.view.send = lambda content, buffers=None: sent.append(
        (time.monotonic(), content["clip"], content["start"], [bytes(b) for b in buffers])
    )
    p.show_timed(Clip(frames, fps=8), {"changed": 1.0, "started": 2.0, "made": 3.0})
    wait_for(lambda: sum(len(m[3]) for m in sent if m[1] == 1) == 8)
    mine = [m for m in sent if m[1] == 1]
    assert mine[0][2] == 0  # the first frame alone
    assert len(mine[0][3]) == 1
    assert mine[1][0] - mine[0][0] >= 0.03  # the others after a pause
    preview = {m[2] + k: b for m in mine for k, b in enumerate(m[3])}
    p.clip = Clip(frames, fps=8)
    wait_for(lambda: sum(len(m[3]) for m in sent if m[1] == 2) == 8)
    plain = {m[2] + k: b for m in sent if m[1] == 2 for k, b in enumerate(m[3])}
    for i in range(8):
        assert len(preview[i]) < 0.8 * len(plain[i])  # fewer bytes
        shown = np.asarray(Image.open(io.BytesIO(preview[i]))).astype(float)
        # Still the frame (quality 80 here: ~4.2 grey levels; 95: 2.2; another frame: 10+).
        assert np.abs(shown - to_uint8(frames[i])).mean() < 6
    p.close()


def test_a_previews_first_frame_leaves_before_show_timed_returns_and_before_the_info_line():
    # Issue 36: a preview's first frame went through the sender's thread, which waited
    # for the GIL while the kernel's thread drew the app's other views (the video
    # database's map); they reached the page first and the frame waited behind them.
    # Now the caller sends it, right behind the clip's state, before the info line.
    p = FramePlayer()
    events = []
    p.view.send = lambda content, buffers=None: events.append(
        ("frames", content["clip"], content["start"], len(buffers))
    )
    p.info.observe(lambda change: events.append(("info", change["new"])), "value")
    p.show_timed(clip(3), {"changed": 1.0, "started": 2.0, "made": 3.0})
    assert events[0] == ("frames", 1, 0, 1)  # sent already, alone, before the info line
    assert events[1][0] == "info"
    assert "3 frames" in events[1][1]
    wait_for(lambda: sum(e[3] for e in events if e[0] == "frames") == 3)
    time.sleep(0.1)
    # The others follow from the sender's thread, each once.
    starts = sorted(e[2] + k for e in events if e[0] == "frames" for k in range(e[3]))
    assert starts == [0, 1, 2]
    # A page that lost its frames (a reload) gets the first one again too.
    del events[:]
    p._message(None, {"type": "want", "clip": 1, "have": 0}, [])
    wait_for(lambda: sum(e[3] for e in events if e[0] == "frames") == 3)
    # A plain clip is still sent by the sender's thread (a render's frames).
    del events[:]
    p.clip = clip(2)
    wait_for(lambda: sum(e[3] for e in events if e[0] == "frames" and e[1] == 2) == 2)
    p.close()


def test_the_page_says_when_it_drew_a_preview():
    # The page tells the kernel once it has drawn a preview's first frame (one word per
    # preview); an app sends what can wait after it (the video-database app's map).
    p = FramePlayer()
    assert not p.view.tell_drawn  # (a message per preview: only for an app that waits)
    p.view.tell_drawn = True
    p.view.send = lambda content, buffers=None: None
    p.show_timed(clip(2), {"changed": 1.0, "started": 2.0, "made": 3.0})
    assert not p.wait_drawn(0.01)  # no page has said so
    p._message(None, {"type": "drawn", "clip": p.view.clip_id}, [])
    assert p.wait_drawn(0.0)
    p.show_timed(clip(2), {"changed": 1.0, "started": 2.0, "made": 3.0})
    assert not p.wait_drawn(0.01)  # the next preview needs its own word
    p._message(None, {"type": "drawn", "clip": p.view.clip_id - 1}, [])  # a late word
    assert not p.wait_drawn(0.01)
    p._message(None, {"type": "drawn", "clip": p.view.clip_id}, [])
    assert p.wait_drawn(0.0)
    p.close()
