"""Helpers for the browser tests: servers, polling, mouse drags, coordinates, pixels."""

import json
import os
import re
import signal
import socket
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest


# ---------------------------------------------------------------------- processes
def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def isolated_env(base):
    """Environment for a Jupyter process with its config, runtime and settings in ``base``."""
    env = dict(os.environ)
    for var, sub in [
        ("JUPYTER_CONFIG_DIR", "config"),
        ("JUPYTER_RUNTIME_DIR", "runtime"),
        ("JUPYTERLAB_SETTINGS_DIR", "settings"),
        ("JUPYTERLAB_WORKSPACES_DIR", "workspaces"),
    ]:
        (base / sub).mkdir(parents=True, exist_ok=True)
        env[var] = str(base / sub)
    # No news toast over the widgets.
    notes = base / "settings" / "@jupyterlab" / "apputils-extension"
    notes.mkdir(parents=True, exist_ok=True)
    (notes / "notification.jupyterlab-settings").write_text(
        json.dumps({"fetchNews": "false", "checkForUpdates": False})
    )
    env["MPLBACKEND"] = "Agg"
    return env


def wait_http(url, proc, log, timeout=60, any_status=False):
    """Poll ``url`` until it answers 200 (any HTTP status with ``any_status``).

    Fails with the end of the server's log if the server exits or never answers.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"server exited ({proc.returncode}):\n{log.read_text()[-3000:]}")
        try:
            with urllib.request.urlopen(url, timeout=2) as r:
                if r.status == 200:
                    return
        except urllib.error.HTTPError as err:
            err.close()
            if any_status:
                return
        except (urllib.error.URLError, OSError):
            pass
        time.sleep(0.2)
    pytest.fail(f"server did not answer {url} in {timeout} s:\n{log.read_text()[-3000:]}")


def stop(proc, timeout=10):
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout)


def poll(what, check, timeout=30, interval=0.1):
    """Call ``check()`` until it returns something truthy; fail after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    last = None
    while True:
        last = check()
        if last:
            return last
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout} s waiting for {what} (last: {last!r})")
        time.sleep(interval)


def read_json(path):
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


def node_slug(request):
    """The test's name without pytest-playwright's ``[chromium]`` parameter."""
    return re.sub(r"[^\w-]+", "_", request.node.originalname)


# ---------------------------------------------------------------------- page helpers
def drag(page, start, end, steps=20):
    """Press the mouse at ``start`` (viewport x, y), move to ``end`` in ``steps``, release."""
    page.mouse.move(*start)
    page.mouse.down()
    page.mouse.move(*end, steps=steps)
    page.mouse.up()


def assert_visible(box, min_width=100, min_height=70):
    """Fail unless a bounding box is at least ``min_width`` x ``min_height``."""
    assert box is not None, "element not displayed"
    assert box["width"] >= min_width, box
    assert box["height"] >= min_height, box


def at(box, fx, fy):
    """The viewport point at fractions (fx, fy) of a bounding box."""
    return (box["x"] + fx * box["width"], box["y"] + fy * box["height"])


def to_image(box, point, shape):
    """Viewport (x, y) over a displayed canvas -> image (row, col) of an (H, W) image.

    The canvas may be displayed scaled: the box is what the user sees, and the
    widget's convention puts the centre of the top-left pixel at (0, 0).
    """
    h, w = shape
    x, y = point
    return ((y - box["y"]) / box["height"] * h - 0.5, (x - box["x"]) / box["width"] * w - 0.5)


def canvas_rgba(locator, points, radius=0):
    """RGBA of a displayed ``<canvas>`` at viewport ``points`` (mapped to canvas pixels).

    With ``radius`` > 0, each point gives the list of the RGBA values of the canvas
    pixels in a square of that half-size around it.
    """
    return locator.evaluate(
        """(el, [pts, rad]) => {
          const r = el.getBoundingClientRect();
          const g = el.getContext('2d');
          return pts.map(([x, y]) => {
            const cx = Math.floor((x - r.left) / r.width * el.width);
            const cy = Math.floor((y - r.top) / r.height * el.height);
            const x0 = Math.max(0, cx - rad), y0 = Math.max(0, cy - rad);
            const w = Math.min(el.width, cx + rad + 1) - x0;
            const h = Math.min(el.height, cy + rad + 1) - y0;
            const d = Array.from(g.getImageData(x0, y0, w, h).data);
            const px = [];
            for (let i = 0; i < d.length; i += 4) px.push(d.slice(i, i + 4));
            return rad ? px : px[0];
          });
        }""",
        [[list(p) for p in points], radius],
    )


def img_rgba(locator, fx=0.5, fy=0.5):
    """RGBA of an ``<img>``'s or a ``<canvas>``'s picture at fractions (fx, fy).

    None before an image loads or while a player's canvas shows no frame yet.
    """
    return locator.evaluate(
        """(el, [fx, fy]) => {
          if (el.tagName === 'CANVAS') {
            if (!el.width || el.dataset.drawn === undefined) return null;
            const x = Math.min(el.width - 1, Math.floor(fx * el.width));
            const y = Math.min(el.height - 1, Math.floor(fy * el.height));
            return Array.from(el.getContext('2d').getImageData(x, y, 1, 1).data);
          }
          if (!el.complete || !el.naturalWidth) return null;
          const c = document.createElement('canvas');
          c.width = el.naturalWidth; c.height = el.naturalHeight;
          const g = c.getContext('2d');
          g.drawImage(el, 0, 0);
          const x = Math.min(c.width - 1, Math.floor(fx * c.width));
          const y = Math.min(c.height - 1, Math.floor(fy * c.height));
          return Array.from(g.getImageData(x, y, 1, 1).data);
        }""",
        [fx, fy],
    )


def contrast(locator):
    """WCAG contrast ratio of an element's text colour against its effective background.

    The background is the first opaque-enough one among the element and its
    ancestors (the page's when none is set).
    """
    return locator.evaluate(
        r"""el => {
          const parse = s => (s.match(/[\d.]+/g) || []).map(Number);
          const lum = ([r, g, b]) => {
            const f = v => {
              v /= 255;
              return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4;
            };
            return 0.2126 * f(r) + 0.7152 * f(g) + 0.0722 * f(b);
          };
          let bg = [255, 255, 255];
          for (let n = el; n; n = n.parentElement) {
            const c = parse(getComputedStyle(n).backgroundColor);
            if (c.length >= 3 && (c.length < 4 || c[3] > 0.5)) { bg = c.slice(0, 3); break; }
          }
          const fg = parse(getComputedStyle(el).color);
          // Text colour with alpha (and the element's opacity) blends into the background.
          let a = (fg.length > 3 ? fg[3] : 1);
          for (let n = el; n; n = n.parentElement) a *= Number(getComputedStyle(n).opacity);
          const mix = fg.slice(0, 3).map((v, i) => a * v + (1 - a) * bg[i]);
          const [l1, l2] = [lum(mix), lum(bg)].sort((p, q) => q - p);
          return {ratio: (l1 + 0.05) / (l2 + 0.05), fg: mix, bg};
        }"""
    )


def notebook_view(page):
    """The part of the page that shows the notebook (the page minus JupyterLab's bars)."""
    return page.evaluate(
        """() => {
          const o = window.jupyterapp.shell.currentWidget.node
            .querySelector('.jp-WindowedPanel-outer').getBoundingClientRect();
          return {x: Math.max(o.left, 0), y: Math.max(o.top, 0),
                  width: Math.min(o.right, innerWidth) - Math.max(o.left, 0),
                  height: Math.min(o.bottom, innerHeight) - Math.max(o.top, 0)};
        }"""
    )


def inside(box, view, what):
    """Fail unless the bounding ``box`` of ``what`` lies wholly inside ``view``."""
    assert box is not None, f"{what} is not displayed"
    right, bottom = box["x"] + box["width"], box["y"] + box["height"]
    assert box["x"] >= view["x"] - 1, (what, box, view)
    assert box["y"] >= view["y"] - 1, (what, box, view)
    assert right <= view["x"] + view["width"] + 1, (what, box, view)
    assert bottom <= view["y"] + view["height"] + 1, (what, box, view)


def open_app(notebook, page, cells):
    """Run ``cells`` (ending with an App) and return (nb, app, canvas locator, canvas box)."""
    nb = notebook(cells)
    app = page.locator(".fluidnb-app")
    app.wait_for()
    canvas = page.locator(".fluidnb-app .fluidnb-canvas")
    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()
    assert_visible(box)
    return nb, app, canvas, box


def drag_slider(page, slider, fraction, steps=8):
    """Drag a slider's handle to ``fraction`` of its track; return the readout's value.

    The kernel receives intermediate values too (continuous_update): assert on the
    returned final one.
    """
    slider.scroll_into_view_if_needed()
    handle = slider.locator(".noUi-handle").bounding_box()
    track = slider.locator(".noUi-base").bounding_box()
    page.mouse.move(handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2)
    page.mouse.down()
    page.mouse.move(
        track["x"] + fraction * track["width"], track["y"] + track["height"] / 2, steps=steps
    )
    page.mouse.up()
    return float(slider.locator(".widget-readout").inner_text())


# ---------------------------------------------------------------------- the player
# Every frame a player draws is announced by a bubbling "fluidnb-frame" event on its
# canvas (widgets/_player.js): logged here with the time, to measure what is shown.
_WATCH = """() => {
  if (window.__fluidnbFrames) return;
  window.__fluidnbFrames = [];
  document.addEventListener('fluidnb-frame', e => window.__fluidnbFrames.push(
    {t: e.detail.t, clip: e.detail.clip, frame: e.detail.frame, el: e.target}));
}"""


def watch_frames(page):
    """Start logging the frames every player draws (idempotent)."""
    page.evaluate(_WATCH)


def frames_drawn(page, selector, since=0.0, until=None):
    """[(t ms, clip, frame)] drawn by the player canvas at ``selector`` in [since, until]."""
    return page.evaluate(
        """([sel, since, until]) => {
          const el = document.querySelector(sel);
          return (window.__fluidnbFrames || [])
            .filter(f => f.el === el && f.t >= since && (until === null || f.t <= until))
            .map(f => [f.t, f.clip, f.frame]);
        }""",
        [selector, since, until],
    )


def now_ms(page):
    return page.evaluate("() => performance.now()")


def clip_fps(page, player):
    """The fps the player at selector ``player`` plays at (its fps box)."""
    return float(page.locator(f"{player} .fluidnb-fps input").input_value())


def run_in_kernel(page, code):
    """Execute ``code`` in the open notebook's kernel without a cell (returns at once)."""
    page.evaluate(
        """code => window.jupyterapp.shell.currentWidget.sessionContext.session.kernel
             .requestExecute({code, silent: true})""",
        code,
    )


def playback_while_kernel_busy(page, player, seconds=2.0):
    """Frames a second the player draws while the kernel sleeps, and the clip's fps.

    The kernel is kept busy (``time.sleep``) for the whole window: a player that
    asked the kernel for its frames would show none; one that plays in the page
    shows the clip's fps. Starts playback if it is paused.
    """
    watch_frames(page)
    canvas = f"{player} canvas.fluidnb-frame"
    button = page.locator(f"{player} button.fluidnb-play")
    if button.get_attribute("aria-label") == "play":
        button.click()
    page.wait_for_function(
        "sel => document.querySelector(sel).getAttribute('aria-label') === 'pause'",
        arg=f"{player} button.fluidnb-play",
    )
    run_in_kernel(page, f"import time; time.sleep({seconds + 1.0})")
    page.wait_for_timeout(400)  # the kernel is asleep now
    t0 = now_ms(page)
    page.wait_for_timeout(int(seconds * 1000))
    t1 = now_ms(page)
    shown = frames_drawn(page, canvas, t0, t1)
    page.wait_for_timeout(800)  # the kernel wakes up
    return 1000 * len(shown) / (t1 - t0), clip_fps(page, player)


def preview_follows_held_slider(page, slider, player, fractions, timeout=10):
    """Hold ``slider``'s handle and move it to each fraction of its track in turn.

    After each move, wait (mouse still down) until the player draws a new clip;
    returns the lags in ms from each move to its new picture. While the handle is
    held the app must not start its full run (its Cancel button would be enabled).
    Releases the mouse at the end.
    """
    watch_frames(page)
    canvas = f"{player} canvas.fluidnb-frame"
    loc = page.locator(slider)
    loc.scroll_into_view_if_needed()
    handle = loc.locator(".noUi-handle").bounding_box()
    track = loc.locator(".noUi-base").bounding_box()
    y = handle["y"] + handle["height"] / 2
    page.mouse.move(handle["x"] + handle["width"] / 2, y)
    page.mouse.down()
    lags = []
    try:
        for f in fractions:
            before = page.locator(canvas).get_attribute("data-clip")
            t0 = now_ms(page)
            page.mouse.move(track["x"] + f * track["width"], y, steps=2)
            deadline = time.monotonic() + timeout
            while True:
                new = [fr for fr in frames_drawn(page, canvas, t0) if str(fr[1]) != before]
                if new:
                    lags.append(new[0][0] - t0)
                    break
                if time.monotonic() > deadline:
                    pytest.fail(f"no new preview in {timeout} s after moving {slider} to {f}")
                time.sleep(0.02)
            page.wait_for_timeout(400)  # held, still: a pause is not a release
            assert page.locator(".fluidnb-app .fluidnb-cancel").first.is_disabled(), (
                "a run started while the slider was held"
            )
    finally:
        page.mouse.up()
    return lags


def shown_frame(locator):
    """Which clip and frame a player's canvas shows ("clip:frame"; None before one)."""
    return locator.evaluate(
        "el => el.dataset.clip === undefined ? null : el.dataset.clip + ':' + el.dataset.frame"
    )


#: ``page.wait_for_function`` body: the canvas ``el`` shows another frame than ``was``.
ANOTHER_FRAME = "([el, was]) => (el.dataset.clip + ':' + el.dataset.frame) !== was"


def pause(page, player):
    """Pause the player at selector ``player`` (if it plays)."""
    button = page.locator(f"{player} button.fluidnb-play")
    if button.get_attribute("aria-label") == "pause":
        button.click()
