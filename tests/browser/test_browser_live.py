"""Every app in JupyterLab: the preview follows a held slider; the clip plays at its fps.

Issue 36. In each app, at 1400 x 900: hold a slider's handle with the mouse and move
it a few times -- each move brings a new preview picture while the handle is still
held, and no run starts under the hand -- then let go: the full result comes, and
plays in the page at the clip's fps while the kernel is kept asleep (a player that
asked the kernel for its frames would show none then).
"""

import numpy as np
import pytest

from tests.browser.helpers import (
    playback_while_kernel_busy,
    poll,
    preview_follows_held_slider,
    watch_frames,
)

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1400, "height": 900}
PLAYER = ".fluidnb-app .fluidnb-app-player"
PREVIEWS = ".fluidnb-app .fluidnb-preview-player canvas.fluidnb-frame"

APPS = {
    "flicker": (
        "from fluidnb.widgets import FlickerApp\napp = FlickerApp(quick=True)\napp",
        ".fluidnb-param-kappa",
        None,
    ),
    "frost": (
        """\
from fluidnb.frost import FrostParams
from fluidnb.widgets import FrostApp
app = FrostApp(quick=True, params=FrostParams(spacing=3.0, gamma=0.02))
h, w = app.image.shape[:2]
yy, xx = np.mgrid[:h, :w]
app.set_region((yy - h / 2) ** 2 + (xx - w / 2) ** 2 < 40 ** 2)
app.set_starts([[h / 2, w / 2]])
app""",
        ".fluidnb-param-beta",
        None,
    ),
    "fire": (
        "from fluidnb.widgets import FireApp\napp = FireApp(quick=True, n_frames=24)\napp",
        ".fluidnb-param-weight",
        None,
    ),
    "turbulence": (
        "from fluidnb.widgets import TurbulenceApp\napp = TurbulenceApp(n_frames=24)\napp",
        ".fluidnb-param-interval",
        None,
    ),
    "videodb": (
        """\
os.environ["FLUIDNB_QUICK"] = "1"  # the quick starter database (built once, cached)
from fluidnb.widgets import VideoDBApp
app = VideoDBApp("stream", size=192, db="water", display_size=420)
app.panel.set("candidates", 30)
h, w = app.photo.shape[:2]
matte = np.zeros((h, w), bool)
matte[int(0.45 * h):] = True
app.set_matte(matte)
app.draw_stroke([[0.7 * h, 5], [0.7 * h, w - 5]])
app.run()
app""",
        ".fluidnb-param-sigma",
        "done in",
    ),
}


@pytest.fixture
def wide(page):
    page.set_viewport_size(VIEWPORT)
    yield page
    page.set_viewport_size({"width": 1280, "height": 1000})


@pytest.mark.parametrize("name", list(APPS))
def test_preview_follows_a_held_slider_then_the_clip_plays_at_its_fps(name, notebook, wide, shot):
    page = wide
    cell, slider, ready = APPS[name]
    notebook(["import os\n" + cell])
    app = page.locator(".fluidnb-app")
    app.wait_for()
    if ready:  # a first Run, whose assignment the sliders change
        page.locator(".fluidnb-app .fluidnb-status", has_text=ready).wait_for(timeout=240_000)
    # The first picture (a preview, or the run's clip).
    poll(
        "a first picture in the player",
        lambda: page.locator(PREVIEWS).first.get_attribute("data-drawn"),
        timeout=120,
    )
    watch_frames(page)
    page.locator(slider).scroll_into_view_if_needed()
    lags = preview_follows_held_slider(
        page, slider, ".fluidnb-app .fluidnb-preview-player", [0.3, 0.6, 0.85], timeout=30
    )
    assert len(lags) == 3
    shot(app, "preview")
    # Let go: the full result comes by itself, and plays at its fps in the page.
    page.locator(".fluidnb-app .fluidnb-status", has_text="done").or_(
        page.locator(".fluidnb-app .fluidnb-status", has_text="rendered in")
    ).or_(page.locator(".fluidnb-app .fluidnb-status", has_text="synthesised")).or_(
        page.locator(".fluidnb-app .fluidnb-status", has_text="ms of search")
    ).first.wait_for(timeout=240_000)

    def full_clip_shown():
        # A clip ("N frames, ..."), whole and not a preview. (An empty player has no
        # text: the status line can say "ms of search" for a preview before the run.)
        info = page.locator(f"{PLAYER} .fluidnb-player-info").first.inner_text()
        return "frames" in info and "so far" not in info and "preview" not in info

    poll("the full clip in the player", full_clip_shown, timeout=120)
    rate, fps = playback_while_kernel_busy(page, PLAYER, seconds=2.0)
    shot(app, "playing")
    # Slack for a loaded machine (the goal, 0.95 x fps, is the benchmark's).
    assert rate >= 0.75 * fps, (rate, fps, np.round(lags))


_WATCH_ENERGY = """() => {
  const log = window.__energy = {changes: [], moves: [], previews: []};
  const box = document.querySelector('.fluidnb-app .fluidnb-vdb-energy');
  new MutationObserver(() => log.changes.push(performance.now()))
    .observe(box, {subtree: true, childList: true, characterData: true});
  document.addEventListener('pointermove', e => log.moves.push(e.timeStamp), true);
  document.addEventListener('fluidnb-frame', e => {
    const made = e.detail.timeline && e.detail.timeline.made;  // (a preview's timeline)
    if (made && e.target.closest('.fluidnb-preview-player'))
      log.previews.push([e.detail.t, e.detail.clip]);
  });
}"""


def test_videodb_a_held_sliders_preview_frame_is_drawn_before_its_map(notebook, wide, shot):
    # Issue 36: the map's picture and marks, the energy plot and the counters reached
    # the page beside the preview frame, and the frame waited for them (decode+draw
    # 18-21 ms quiet, 40 at load 6). Now, while the handle is held, each move's frame
    # is drawn first: no energy plot changes between a move and its first new frame,
    # and the held slider's last value gets its energy plot after its frame.
    page = wide
    cell, slider, ready = APPS["videodb"]
    notebook(["import os\n" + cell])
    app = page.locator(".fluidnb-app")
    page.locator(".fluidnb-app .fluidnb-status", has_text=ready).wait_for(timeout=240_000)
    poll(
        "a first picture in the player",
        lambda: page.locator(PREVIEWS).first.get_attribute("data-drawn"),
        timeout=120,
    )
    page.locator(".fluidnb-app .fluidnb-vdb-energy-plot").wait_for()
    page.wait_for_timeout(1000)  # the run's own map and the preview cache, at rest
    page.evaluate(_WATCH_ENERGY)
    lags = preview_follows_held_slider(
        page, slider, ".fluidnb-app .fluidnb-preview-player", [0.3, 0.6, 0.85], timeout=30
    )
    assert len(lags) == 3
    shot(app, "held")
    log = page.evaluate("() => window.__energy")
    firsts = {}  # each preview clip's first drawing
    for t, clip in log["previews"]:
        firsts.setdefault(clip, t)
    frames = sorted(firsts.values())
    assert len(frames) >= 3, log["previews"]
    # The moves: pointer moves more than 200 ms after the one before (the helper holds
    # the handle still for 400 ms between them).
    moves = [t for k, t in enumerate(log["moves"]) if k == 0 or t - log["moves"][k - 1] > 200]
    checked = 0
    for k, move in enumerate(moves):
        after = [t for t in frames if t > move]
        following = moves[k + 1] if k + 1 < len(moves) else float("inf")
        if not after or after[0] > following:
            continue  # (the pointer's way to the handle, before the press)
        between = [t for t in log["changes"] if move < t < after[0]]
        assert not between, ("the energy plot changed before the move's frame", between, log)
        checked += 1
        last = after[0]  # the last held move's first frame
    assert checked >= 3, (frames, log["moves"])
    # (Not after the very last frame: the release's float64 solve may draw the same
    # plot as the held value's float32 one, and an unchanged plot is not redrawn.)
    assert any(t > last for t in log["changes"]), ("no energy plot after its frame", log)
