"""FramePlayer in JupyterLab: play in the browser, pause, and export a GIF."""

import time

import pytest
from PIL import Image

from tests.browser.helpers import img_rgba, poll

pytestmark = pytest.mark.browser

N = 8  # frames; frame i is a flat grey of level i / (N - 1)

PLAYER = f"""\
from fluidnb import Clip
from fluidnb.widgets import FramePlayer

frames = np.stack([np.full((24, 32), i / {N - 1}) for i in range({N})])
frames[:, :, 16:] = (np.indices((24, 16)).sum(0) // 4) % 2  # a checker on the right
p = FramePlayer(Clip(frames, fps=8))
seen = []

def report(change):
    seen.append(change["new"])
    dump("frames.json", seen)

p.observe(report, "frame")
p
"""


def readout(page):
    return int(page.locator(".fluidnb-frame-slider .widget-readout").inner_text())


def shown_level(page):
    """The grey level of the frame on screen (left half), in frames (None while loading)."""
    rgba = img_rgba(page.locator(".fluidnb-frame"), 0.25, 0.5)
    return None if rgba is None else rgba[0] / 255 * (N - 1)


def test_play_advances_frames_then_pause_stops(notebook, page, shot):
    nb = notebook([PLAYER])
    frame = page.locator(".fluidnb-frame")
    frame.scroll_into_view_if_needed()
    poll("the first frame on screen", lambda: shown_level(page) is not None)
    assert readout(page) == 0
    assert abs(shown_level(page) - 0) < 0.1
    src0 = frame.get_attribute("src")

    page.locator(".fluidnb-play button:has(i.fa-play)").click()
    # 8 fps: in about a second the slider (driven in the browser) and the kernel's
    # frame move through several frames.
    seen = nb.state("frames.json", lambda s: len(set(s)) >= 4, timeout=10)
    assert seen[:3] == sorted(seen[:3]), f"frames do not advance in order: {seen}"
    assert frame.get_attribute("src") != src0
    shot(page.locator(".fluidnb-player"), "playing")

    page.locator(".fluidnb-play button:has(i.fa-pause)").click()
    # Paused: the slider stays put, and the picture shows the slider's frame.
    before = readout(page)
    time.sleep(0.5)  # 4 ticks at 8 fps
    after = readout(page)
    assert before == after, "still playing after pause"
    poll(
        f"frame {after} on screen",
        lambda: (lambda lv: lv is not None and abs(lv - after) < 0.1)(shown_level(page)),
        timeout=10,
    )
    shot(page.locator(".fluidnb-player"))


def test_gif_export_writes_file_and_link(notebook, page, shot):
    nb = notebook([PLAYER])
    button = page.locator(".fluidnb-export-gif")
    button.scroll_into_view_if_needed()
    assert not list(nb.folder.glob("*.gif"))
    button.click()
    link = page.locator(".fluidnb-export-link a")
    link.wait_for(timeout=30_000)
    # Into the output folder beside the notebook, none among the notebooks.
    assert not list(nb.folder.glob("*.gif"))
    gifs = list(nb.folder.glob("fluidnb-output/fluidnb-*.gif"))
    assert len(gifs) == 1, gifs
    assert link.inner_text() == f"fluidnb-output/{gifs[0].name}"
    assert link.get_attribute("href") == f"fluidnb-output/{gifs[0].name}"
    with Image.open(gifs[0]) as im:
        assert im.size == (32, 24)
        assert im.n_frames == N
    shot(page.locator(".fluidnb-player"))
