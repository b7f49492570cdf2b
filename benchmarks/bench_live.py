"""Live and smooth in every app: slider -> preview on screen, and playback, in Chromium.

Usage (from the repository root)::

    FLUIDNB_CHROMIUM=/usr/bin/chromium .venv/bin/python benchmarks/bench_live.py
    ... bench_live.py --quick            # the apps' quick sizes (CI-like)
    ... bench_live.py --only FlickerApp,FireApp --shots /tmp/live-shots

Starts JupyterLab and drives each app in Chromium at 1400 x 900 as a lecturer does,
with the mouse: holds a slider's handle and moves it a few times (pausing between
moves, the handle still held), lets go, waits for the full result, and watches it
play. Every time is taken in the page (``performance.now()``, the player's
``fluidnb-frame`` events, the pointer events), as the user sees it:

- *preview*: from a move of the handle (the page's pointermove) to the first frame of
  a new clip drawn in the app's player -- the median over the moves;
- *frames shown / clip fps*: frames the player draws per second over 3 s of playback
  of the full result, against the fps it plays at;
- *first frame*: from the status line saying the full result is done to the first
  frame of that clip drawn (negative: its first frames played before it was done, as
  the video-database app streams them).

Prints one markdown row per app and the machine's load, then each preview's time split
into its parts (the kernel tells the page when it heard the value, began and finished
the preview and sent the first frame: :meth:`FramePlayer.show_timed`): to the kernel,
queued, compute, encode+send, to the page, decode+draw.

``--kernel`` measures instead, in plain Python (no browser, no kernel), what the
kernel does for each preview of the same slider moves: the app's preview
(compute, on the preview worker as the app runs it, BLAS on one thread) and the
JPEG of its first frame (encode), and what runs after the picture
(:meth:`App.after_preview`). Less sensitive to the load than the browser's times.

Goals on a quiet 2-core machine: preview <= 100 ms median; frames shown >= 0.95 x the
clip's fps; first frame <= 0.3 s after the render is done. No asserts.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _lab import close_notebook, lab, open_notebook

PLAYER = ".fluidnb-app .fluidnb-app-player"
CANVAS = f"{PLAYER} canvas.fluidnb-frame"
#: Where the previews show (turbulence's: its vorticity player).
PREVIEW = ".fluidnb-app .fluidnb-preview-player canvas.fluidnb-frame"

_REGION = """\
h, w = app.image.shape[:2]
yy, xx = np.mgrid[:h, :w]
app.set_region(((yy - 0.5 * h) / (0.3 * h)) ** 2 + ((xx - 0.5 * w) / (0.35 * w)) ** 2 < 1)
app.set_starts([[0.5 * h, 0.5 * w]])
"""
_VIDEODB = """\
h, w = app.photo.shape[:2]
matte = np.zeros((h, w), bool)
matte[int(0.45 * h):] = True  # the stream's water
app.set_matte(matte)
app.draw_stroke([[0.7 * h, 0.05 * w], [0.7 * h, 0.95 * w]])
app.run()
"""

#: name -> (constructor, code after it, the slider moved, a first Run to wait for)
APPS = {
    "FlickerApp": ("FlickerApp({q})", "", "kappa", None),
    "FrostApp": ("FrostApp({q})", _REGION, "beta", None),
    "FireApp": ("FireApp({q})", "", "weight", None),
    "TurbulenceApp": ("TurbulenceApp()", "", "interval", None),
    "VideoDBApp": ("VideoDBApp({q})", _VIDEODB, "sigma", "done in"),
}

# In the page: the pointer's moves, the status line's changes and every frame drawn.
WATCH = """() => {
  const log = window.__live = {moves: [], status: [], frames: [], previews: []};
  document.addEventListener('pointermove', e => log.moves.push(e.timeStamp), true);
  document.addEventListener('fluidnb-frame', e => {
    if (e.target.closest('.fluidnb-app-player'))
      log.frames.push([e.detail.t, e.detail.clip, e.detail.frame]);
    if (e.target.closest('.fluidnb-preview-player'))
      log.previews.push([e.detail.t, e.detail.clip, e.detail.frame, e.detail.timeline]);
  });
  const status = document.querySelector('.fluidnb-app .fluidnb-status');
  new MutationObserver(() => log.status.push([performance.now(), status.textContent]))
    .observe(status, {subtree: true, childList: true, characterData: true});
}"""

DONE = ("done in", "rendered in", "ms of search")


def now(page):
    return page.evaluate("() => performance.now()")


def log(page):
    return page.evaluate("() => window.__live")


def shown_clip(page, canvas=CANVAS):
    return page.locator(canvas).get_attribute("data-clip")


#: A preview's time split into its parts (ms), from the kernel's timeline of it
#: (FramePlayer.show_timed) and the page's clock: the slider's value to the kernel,
#: waiting for the preview worker, computing the preview, encoding and sending its
#: first frame, the message's trip to the page, decoding and drawing it.
PARTS = ("to kernel", "queued", "compute", "encode+send", "to page", "decode+draw")
#: The compute's CPU (ms): the preview worker's own, and the whole kernel's meanwhile
#: (the kernel's main thread and the preview's helpers too). Far below the compute's
#: wall time: the preview waited (for the GIL or for a core), rather than computed.
CPU_PARTS = ("compute CPU", "kernel CPU")


def split(move, drawn, timeline, origin):
    """The parts (ms) of one preview; None without the kernel's timeline."""
    if not timeline or timeline.get("changed") is None:
        return None
    cpu = [timeline.get("cpu", float("nan")), timeline.get("kernel_cpu", float("nan"))]
    marks = [
        origin + move,
        timeline["changed"],
        timeline["started"],
        timeline["made"],
        timeline["sent"],
        timeline["arrived"],
        origin + drawn,
    ]
    return [b - a for a, b in zip(marks, marks[1:])] + cpu


def measure_previews(page, name, moves, shot=None):
    """Hold the handle, move it ``moves`` times: the lags (ms) from each move to its picture.

    Returns ``(lags, parts)``: ``parts`` the split of each lag (:func:`split`).
    """
    slider = page.locator(f".fluidnb-app .fluidnb-param-{name}")
    slider.scroll_into_view_if_needed()
    handle = slider.locator(".noUi-handle").bounding_box()
    track = slider.locator(".noUi-base").bounding_box()
    x, y = handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2
    step = track["width"] / 14
    direction = 1 if x < track["x"] + track["width"] / 2 else -1
    page.mouse.move(x, y)
    page.mouse.down()
    origin = page.evaluate("() => performance.timeOrigin")
    lags, parts = [], []
    try:
        for k in range(moves):
            page.wait_for_timeout(350)  # everything at rest before the move
            before = shown_clip(page, PREVIEW)
            t0 = now(page)
            x += direction * step * (1 if k % 3 != 2 else -1)
            page.mouse.move(x, y)
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                got = log(page)
                move = [t for t in got["moves"] if t >= t0]
                new = [f for f in got["previews"] if f[0] >= t0 and str(f[1]) != before]
                if move and new:
                    lags.append(new[0][0] - move[0])
                    parts.append(split(move[0], new[0][0], new[0][3], origin))
                    break
                page.wait_for_timeout(10)
        if shot is not None:  # the last preview, the handle still held
            page.screenshot(path=str(shot))
    finally:
        page.mouse.up()
    return lags, [p for p in parts if p is not None]


def measure_result(page, released, timeout):
    """After the release: (first frame of the full result - its 'done', frames/s, fps)."""
    deadline = time.monotonic() + timeout
    done_at = None
    while time.monotonic() < deadline:
        got = log(page)
        done = [t for t, text in got["status"] if t >= released and any(d in text for d in DONE)]
        if done:
            done_at = done[0]
            break
        page.wait_for_timeout(100)
    if done_at is None:
        return None, 0.0, 0.0
    page.wait_for_timeout(500)
    clip = shown_clip(page)
    got = log(page)
    mine = [f for f in got["frames"] if str(f[1]) == clip]
    first = mine[0][0] - done_at if mine else None
    # Playback of the full result: 3 s of frames drawn.
    t0 = now(page)
    page.wait_for_timeout(3000)
    t1 = now(page)
    shown = [f for f in log(page)["frames"] if t0 <= f[0] <= t1 and str(f[1]) == clip]
    fps = float(page.locator(f"{PLAYER} .fluidnb-fps input").input_value() or 0)
    return first, 1000 * len(shown) / (t1 - t0), fps


def bench_app(page, url, root, app, args):
    make, after, slider, ready = APPS[app]
    quick = "quick=True" if args.quick else ""
    cells = [
        "import os\nimport numpy as np\n"
        + ('os.environ["FLUIDNB_QUICK"] = "1"\n' if args.quick else ""),
        f"from fluidnb.widgets import {app}\napp = {make.format(q=quick)}\n{after}app",
    ]
    open_notebook(page, url, root, app, cells)
    page.locator(".fluidnb-app").evaluate("el => el.scrollIntoView({block: 'start'})")
    if ready:
        page.locator(".fluidnb-app .fluidnb-status", has_text=ready).wait_for(timeout=900_000)
    page.wait_for_function(
        "sel => document.querySelector(sel) && document.querySelector(sel).dataset.drawn",
        arg=PREVIEW,
        timeout=300_000,
    )
    page.wait_for_timeout(1500)  # the first preview and its warm-up
    page.evaluate(WATCH)
    load = os.getloadavg()[0]
    held = None
    if args.shots:
        args.shots.mkdir(parents=True, exist_ok=True)
        held = args.shots / f"live-{app}-preview.png"
    lags, parts = measure_previews(page, slider, args.moves, held)
    released = now(page)
    first, rate, fps = measure_result(page, released, args.timeout)
    if args.shots:
        args.shots.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(args.shots / f"live-{app}.png"))
    close_notebook(page)
    return lags, parts, first, rate, fps, load


def kernel_bench(app_name, moves, quick=False):
    """The kernel's side of ``moves`` previews of ``app_name``: lists of ms per preview.

    Returns ``(compute, cpu, encode, after, shape, n_frames)``: the preview call (wall
    time, and the CPU time of the process meanwhile: on a loaded machine the wall time
    grows with the load, the CPU time hardly), the first frame's JPEG,
    :meth:`App.after_preview`; the last preview's frame shape and length.
    """
    import numpy as np

    from fluidnb.widgets._common import jpeg

    make, after_code, slider, _ = APPS[app_name]
    ns = {"np": np}
    made = make.format(q="quick=True" if quick else "")
    exec(f"from fluidnb.widgets import {app_name}\napp = {made}\n{after_code}", ns)
    app = ns["app"]
    app.wait_preview(900)
    compute, cpu, encode, after, last = [], [], [], [], [None]
    preview = app.preview
    after_preview = getattr(app, "after_preview", lambda params: None)  # (older apps: none)

    def timed(params):  # on the preview worker, inside the app's own settings
        t0, c0 = time.perf_counter(), time.process_time()
        clip = preview(params)
        t1, c1 = time.perf_counter(), time.process_time()
        if clip is not None:
            jpeg(clip.frames[0])
            compute.append(1000 * (t1 - t0))
            cpu.append(1000 * (c1 - c0))
            encode.append(1000 * (time.perf_counter() - t1))
            last[0] = clip
        return clip

    def timed_after(params):
        t0 = time.perf_counter()
        after_preview(params)
        after.append(1000 * (time.perf_counter() - t0))

    app.preview, app.after_preview = timed, timed_after
    control = app.panel.controls[slider]
    options = list(getattr(control, "options", ()) or ())
    for k in range(moves):
        sign = 1 if k % 3 != 2 else -1  # as the browser's moves: two on, one back
        if options:
            i = options.index(control.value) + sign
            control.value = options[i if 0 <= i < len(options) else i - 2 * sign]
        else:
            step = (control.max - control.min) / 14
            v = control.value + sign * step
            control.value = v if control.min <= v <= control.max else control.value - sign * step
        app.wait_preview(900)
    app.close()
    clip = last[0]
    shape, n = (None, 0) if clip is None else (clip.shape, len(clip))
    return compute, cpu, encode, after, shape, n


def main_kernel(apps, args):
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}", flush=True)
    rows = []
    for app in apps:
        compute, cpu, encode, after, shape, n = kernel_bench(app, args.moves, args.quick)
        med = lambda xs: statistics.median(xs) if xs else float("nan")  # noqa: E731
        rows.append(
            f"| {app} | {med(compute):.0f} | {med(cpu):.0f} | {med(encode):.1f} | "
            f"{med(compute) + med(encode):.0f} | {med(after):.1f} | "
            f"{shape[1] if shape else 0}x{shape[0] if shape else 0} x {n} | "
            f"{len(compute)} | {os.getloadavg()[0]:.2f} |"
        )
        print(rows[-1], flush=True)
    print()
    print(
        "| app | compute, median ms | its CPU ms | JPEG of the first frame | compute + encode "
        "| after the picture | preview frames | previews | load (1 min) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the apps' quick sizes")
    parser.add_argument("--moves", type=int, default=8, help="slider moves per app")
    parser.add_argument("--timeout", type=float, default=600, help="s to wait for a result")
    parser.add_argument("--only", help="comma-separated app names")
    parser.add_argument("--shots", type=Path, help="save a screenshot per app here")
    parser.add_argument(
        "--kernel", action="store_true", help="the kernel's side alone, in plain Python"
    )
    args = parser.parse_args()
    apps = list(APPS) if not args.only else args.only.split(",")
    if args.kernel:
        main_kernel(apps, args)
        return
    rows, split_rows = [], []
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}", flush=True)
    with lab() as (page, url, root):
        for app in apps:
            lags, parts, first, rate, fps, load = bench_app(page, url, root, app, args)
            if parts:
                medians = [
                    statistics.median(p[k] for p in parts)
                    for k in range(len(PARTS) + len(CPU_PARTS))
                ]
                split_rows.append(
                    f"| {app} | " + " | ".join(f"{m:.0f}" for m in medians) + f" | {load:.2f} |"
                )
                print(split_rows[-1], flush=True)
            med = statistics.median(lags) if lags else float("nan")
            first_text = "—" if first is None else f"{first / 1000:+.2f} s"
            rows.append(
                f"| {app} | {med:.0f} | {rate:.1f} / {fps:g} | {first_text} | "
                f"{len(lags)} moves, {min(lags, default=0):.0f}-{max(lags, default=0):.0f} ms "
                f"| {load:.2f} |"
            )
            print(rows[-1], flush=True)
    print()
    print(
        "| app | preview, median ms (slider move -> new preview on screen) | frames shown "
        "per second / clip fps | first frame after done | preview range | load (1 min) |"
    )
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    if split_rows:
        print()
        print(f"| app | {' | '.join(PARTS + CPU_PARTS)} | load (1 min) |  (medians, ms)")
        print("|---" * (len(PARTS) + len(CPU_PARTS) + 2) + "|")
        print("\n".join(split_rows))
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
