"""VideoDBApp in a real browser: slider value -> map and preview on screen, Render -> clip.

Usage (from the repository root)::

    FLUIDNB_CHROMIUM=/usr/bin/chromium .venv/bin/python benchmarks/browser_videodb_app.py
    ... browser_videodb_app.py --quick        # the quick starter database, 256 px

What a lecturer gets from ``VideoDBApp()`` (the stream at 480 px, the full starter water
database, 100 candidates) in JupyterLab in Chromium at 1400 x 900, with a matte over the
water and one stroke set from code. Every time is taken in the page
(``performance.now()``), as the user sees it:

- a *step*: one key press on a slider's handle (one grid step of sigma, lambda or rho),
  with everything at rest before it: the time from the readout showing the new value to
  the map's canvas redrawn with it (its sigma, lambda, rho are read from the energy
  text drawn with the map);
- a *drag*: the handle dragged with the mouse at about 30 moves a second; for every map
  drawn while dragging, its lag behind the value it shows (latest value wins: values
  overtaken are never drawn), the maps drawn per second, and the lag of the last value's
  map and preview after the mouse stops;
- *Render*: from the press to the clip's first frames in the player (the app streams
  the clip as it is made) and to the status line saying the whole clip is rendered;
  *Play*: from the press to the next frame, and frames shown a second; Render pressed
  while the clip plays: the frames shown a second while the new clip streams in.

No asserts: it prints fastest / median, with the machine's load average.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _lab import lab, open_notebook  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _report import header, loads  # noqa: E402

APP = """\
import numpy as np
from fluidnb.widgets import VideoDBApp

app = VideoDBApp()
h, w = app.photo.shape[:2]
matte = np.zeros((h, w), bool)
matte[int(0.45 * h):, :] = True  # the stream's water
app.set_matte(matte)
app.draw_stroke([[0.7 * h, 0.05 * w], [0.7 * h, 0.95 * w]])
app
"""

# In the page: a log of what the user sees change, with performance.now() times.
WATCH = """() => {
  const log = window.__log = [];
  const now = () => performance.now();
  const app = document.querySelector('.fluidnb-app');
  for (const name of ['sigma', 'lam', 'rho']) {
    const r = app.querySelector(`.fluidnb-param-${name} .widget-readout`);
    new MutationObserver(() => log.push({t: now(), kind: 'value', name, text: r.textContent}))
      .observe(r, {subtree: true, childList: true, characterData: true});
  }
  const energy = app.querySelector('.fluidnb-vdb-energy');
  const params = () => {
    const m = energy.textContent.match(/σ = ([-+0-9.e]+), λ = ([-+0-9.e]+), ρ = ([-+0-9.e]+)/);
    return m ? m.slice(1, 4).map(Number) : null;
  };
  const map = app.querySelector('canvas.fluidnb-vdb-map');
  const ctx = map.getContext('2d');
  const draw = ctx.drawImage.bind(ctx);
  let last = 0;
  ctx.drawImage = (...a) => {
    draw(...a);
    const t = now();
    if (t - last > 2) log.push({t, kind: 'map', params: params()});  // one per redraw
    last = t;
  };
  const player = app.querySelector('.fluidnb-app-player');
  // Every new clip's first frame drawn by the player (its fluidnb-frame events).
  let shownClip = null;
  document.addEventListener('fluidnb-frame', e => {
    if (!e.target.closest('.fluidnb-app-player')) return;
    if (e.detail.clip !== shownClip || e.detail.playing) {
      shownClip = e.detail.clip;
      log.push({t: e.detail.t, kind: 'frame', caption: player.textContent});
    }
  });
  // The player's caption ("k of n frames so far" while a clip streams in).
  let caption = null;
  new MutationObserver(() => {
    const text = player.textContent;
    if (text !== caption) {
      caption = text;
      log.push({t: now(), kind: 'caption', text});
    }
  }).observe(player, {subtree: true, childList: true, characterData: true});
  const status = app.querySelector('.fluidnb-status');
  new MutationObserver(() => log.push({t: now(), kind: 'status', text: status.textContent}))
    .observe(status, {subtree: true, childList: true, characterData: true});
  document.addEventListener('mousedown', () => log.push({t: now(), kind: 'press'}), true);
}"""

NAMES = {"sigma": 0, "lam": 1, "rho": 2}


def now_ms(page):
    return page.evaluate("() => performance.now()")


def close(a, b):
    return abs(a - b) <= 0.006 * max(abs(a), abs(b))


def number(text):
    try:
        return float(text)
    except ValueError:
        return None


def preview_params(caption):
    m = re.search(r"σ = ([-+0-9.e]+), λ = ([-+0-9.e]+), ρ = ([-+0-9.e]+)", caption)
    return None if m is None else [float(v) for v in m.groups()]


def lags(log, name):
    """For each map and preview drawn: (kind, time, lag behind the value it shows)."""
    i = NAMES[name]
    values = [(e["t"], number(e["text"])) for e in log if e["kind"] == "value"]
    values = [(t, v) for t, v in values if v is not None and e_name(log, t) == name]
    out = []
    for e in log:
        if e["kind"] == "map" and e["params"]:
            shown = e["params"][i]
        elif e["kind"] == "frame" and (p := preview_params(e["caption"])):
            shown = p[i]
        else:
            continue
        # The latest time the readout showed that value before it was drawn.
        seen = [t for t, v in values if t <= e["t"] and close(v, shown)]
        if seen:
            out.append((e["kind"], e["t"], e["t"] - seen[-1]))
    return out


def e_name(log, t):
    for e in log:
        if e["kind"] == "value" and e["t"] == t:
            return e["name"]
    return None


def settle(page, timeout=120, playing=False):
    """Wait until the app rests: the whole clip in the player, no render running, and
    nothing on screen changed for 0.8 s (``playing``: frames may change)."""
    deadline = time.monotonic() + timeout
    seen = -1
    while time.monotonic() < deadline:
        n, rendering, clip = page.evaluate(
            """() => [
              (window.__log || []).length,
              /rendering/.test(document.querySelector('.fluidnb-app .fluidnb-status').textContent),
              / frames, /.test(document.querySelector('.fluidnb-app .fluidnb-player').textContent),
            ]"""
        )
        if (n == seen or playing) and clip and not rendering:
            return
        seen = n
        page.wait_for_timeout(800)
    raise TimeoutError("the app did not come to rest")


def stats(values):
    v = np.asarray(values, float)
    if not len(v):
        return "none"
    return f"{v.min():.0f} / {np.median(v):.0f} ms (n = {len(v)})"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="FLUIDNB_QUICK=1: small sizes")
    parser.add_argument("--rounds", type=int, default=3, help="drags and steps per slider")
    parser.add_argument("--shots", type=Path, help="save screenshots into this folder")
    args = parser.parse_args()
    print(header(__file__))
    head = 'import os\nos.environ["FLUIDNB_QUICK"] = "1"\n' if args.quick else "import os\n"
    with lab() as (page, url, root):
        open_notebook(page, url, root, "app", [head, APP], timeout=120)
        page.locator(".fluidnb-app").evaluate("el => el.scrollIntoView({block: 'start'})")
        started = time.monotonic()
        page.locator(".fluidnb-app .fluidnb-run").click()
        page.locator(".fluidnb-app .fluidnb-status", has_text="done in").wait_for(timeout=600_000)
        print(f"Run (retrieval, MRF, render): {time.monotonic() - started:.1f} s")
        settle(page)
        page.locator(".fluidnb-app").evaluate("el => el.scrollIntoView({block: 'start'})")
        page.evaluate(WATCH)
        report(page, args)
        if args.shots:
            args.shots.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.shots / "bench-app.png"))
    print("load average after:", " ".join(f"{x:.2f}" for x in loads()))


def report(page, args):
    step_map, drag_map, drag_preview = [], [], []
    final_map, final_preview = [], []
    rates = []
    load = loads()
    for r in range(args.rounds):
        for name in NAMES:
            # A step: one key press, everything at rest before it.
            handle = page.locator(f".fluidnb-app .fluidnb-param-{name} .noUi-handle")
            page.evaluate("() => { window.__log.length = 0; }")
            handle.focus()
            handle.press("ArrowRight" if r % 2 == 0 else "ArrowLeft")
            settle(page)
            log = page.evaluate("() => window.__log")
            got = lags(log, name)
            step_map += [lag for kind, _, lag in got if kind == "map"][:1]

            # A drag: ~30 moves a second over a third of the track.
            slider = page.locator(f".fluidnb-app .fluidnb-param-{name}")
            box = handle.bounding_box()
            track = slider.locator(".noUi-base").bounding_box()
            x0, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            span = track["width"] / 3 * (1 if x0 < track["x"] + track["width"] / 2 else -1)
            page.evaluate("() => { window.__log.length = 0; }")
            page.mouse.move(x0, y)
            page.mouse.down()
            moves = 45
            t0 = page.evaluate("() => performance.now()")
            for k in range(1, moves + 1):
                page.mouse.move(x0 + span * k / moves, y)
                page.wait_for_timeout(33)
            t1 = page.evaluate("() => performance.now()")
            page.mouse.up()
            settle(page)
            log = page.evaluate("() => window.__log")
            got = lags(log, name)
            during = [(kind, t, lag) for kind, t, lag in got if t <= t1]
            drag_map += [lag for kind, _, lag in during if kind == "map"]
            drag_preview += [lag for kind, _, lag in during if kind == "frame"]
            maps = [t for kind, t, _ in during if kind == "map"]
            rates.append(len(maps) / ((t1 - t0) / 1000))
            # The last value: its map and preview (or the clip, if that came first).
            values = [e for e in log if e["kind"] == "value" and e["name"] == name]
            last = number(values[-1]["text"]) if values else None
            mine = [(kind, t, lag) for kind, t, lag in got if t > values[-1]["t"]] if values else []
            if last is not None:
                final_map += [lag for kind, _, lag in mine if kind == "map"][:1]
                final_preview += [lag for kind, _, lag in mine if kind == "frame"][:1]

    # Render: from the press to the clip's first frames in the player (the app streams
    # the clip as it is made: the caption says "k of n frames so far") and to the status
    # line naming the whole clip; then Play: from the press to the next frame, and the
    # frames shown per second while it plays. Last, Render while the clip plays: the
    # frames shown per second while the new clip streams in.
    render_first, render_whole, play_first, play_rate, stream_rate = [], [], [], [], []
    play = page.locator(".fluidnb-app .fluidnb-app-player button.fluidnb-play").first
    render = page.locator(".fluidnb-app .fluidnb-vdb-render")
    for _ in range(args.rounds):
        page.evaluate("() => { window.__log.length = 0; }")
        render.click()
        page.wait_for_timeout(300)
        settle(page)
        log = page.evaluate("() => window.__log")
        press = [e["t"] for e in log if e["kind"] == "press"]
        after = [e for e in log if press and e["t"] > press[0]]
        first = [e["t"] for e in after if e["kind"] == "caption" and "frames so far" in e["text"]]
        done = [e["t"] for e in after if e["kind"] == "status" and "rendered in" in e["text"]]
        if first:
            render_first.append(first[0] - press[0])
        if done:
            render_whole.append(done[0] - press[0])
        page.evaluate("() => { window.__log.length = 0; }")
        play.click()
        page.wait_for_timeout(2000)
        log = page.evaluate("() => window.__log")
        press = [e["t"] for e in log if e["kind"] == "press"]
        frames = [e["t"] for e in log if e["kind"] == "frame" and press[0] < e["t"]]
        if frames:
            play_first.append(frames[0] - press[0])
            play_rate.append(1000 * len(frames) / (now_ms(page) - press[0]))
        # Still playing: Render again, and count the frames shown while it streams.
        page.evaluate("() => { window.__log.length = 0; }")
        render.click()
        page.wait_for_timeout(300)
        settle(page, playing=True)
        log = page.evaluate("() => window.__log")
        press = [e["t"] for e in log if e["kind"] == "press"]
        done = [e["t"] for e in log if e["kind"] == "status" and "rendered in" in e["text"]]
        if press and done:
            shown = [e for e in log if e["kind"] == "frame" and press[0] < e["t"] < done[0]]
            stream_rate.append(1000 * len(shown) / (done[0] - press[0]))
        play.click()  # pause
    print(f"load average before the drags: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    print("fastest / median, value on the readout -> on screen:")
    print(f"  step, map:                {stats(step_map)}")
    print(f"  drag, each map drawn:     {stats(drag_map)}; {np.median(rates):.1f} maps/s")
    print(f"  drag, each preview:       {stats(drag_preview)}")
    print(f"  drag, last value's map:   {stats(final_map)}")
    print(f"  drag, last value preview: {stats(final_preview)}")
    print(f"Render pressed -> its first frames in the player: {stats(render_first)}")
    print(f"Render pressed -> the whole clip in the player ('rendered in'): {stats(render_whole)}")
    print(
        "Render pressed while playing -> frames shown per second until the whole clip: "
        f"{np.median(stream_rate) if stream_rate else 0:.1f}"
    )
    print(
        f"Play pressed -> next frame: {stats(play_first)}; frames shown per second "
        f"while playing: {np.median(play_rate) if play_rate else 0:.1f}"
    )


if __name__ == "__main__":
    main()
