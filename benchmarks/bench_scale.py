"""Every method's command line at 480, 960 and 1920 px: time, peak memory, growth (issue 39).

    .venv/bin/python benchmarks/bench_scale.py [--methods flicker frost fire animate scene]
        [--sizes 480 960 1920] [--rounds 1] [--quick]

The inputs are the bundled samples resized to each width (Lanczos), with their drawn
regions resized alike, written as PNG files the way a user would give them:

- ``flicker``: the "stream" photo and its water region, the paper's defaults (64
  frames), to MP4;
- ``frost``: the "leaf" photo, a centred region of two thirds of each side, one
  start point in its middle, 240 simulation steps drawn every 4th (61 frames), to
  MP4 (a fixed number of frames, so the cost is per pixel);
- ``fire``: the "fire" photo (portrait: the width is its longer side) and its alpha
  as a painted matte, the flame preset simulated for 12 frames (34 clip frames, 3
  keyframes), keyframes and clip at the photo's size (``--output-size``), streamed to
  MP4;
- ``animate`` (the video database): the "stream" photo and its region, ``--db water``
  (``--quick``: the small starter database), a 96-frame loop (``--frames``: the
  issue's goal; the photo's own motion would ask for 48), to ``.npz``, as the issue
  measured it;
- ``scene``: the "lake" photo with the layers of lesson 08 (its water band from the
  water database, a fire on the shore, frost from the top left corner; the command
  line's defaults for each), at the photo's size (``--size 0``), streamed to MP4.

Each run is a child process (``python -c "fluidnb.cli.main"``, what the ``fluidnb``
command runs); its wall time, its CPU time and its peak resident memory come from
:func:`os.wait4`, the child's own ``resource`` usage (its encoder, a grandchild, is
counted in it). Rounds are interleaved (every method and size once per round) and the
median is reported. The growth factor is the median time (CPU time, memory) at a size
over that at half the width: 4x the pixels, so linear cost gives 4x (the goal allows 4.4x).
The goals of issue 39 are printed beside the 1920-px column.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _report import fmt_s, header, load, table  # benchmarks/ is on sys.path when run
from PIL import Image

from fluidnb import data, to_uint8

METHODS = ("flicker", "frost", "fire", "animate", "scene")
SIZES = (480, 960, 1920)
#: (seconds, GB) the issue asks of each method at 1920 px on a quiet 2-core machine.
GOALS = {
    "flicker": (8.0, 2.0),
    "frost": (None, 3.0),
    "fire": (None, 3.0),
    "animate": (45.0, 3.0),
    "scene": (None, 3.0),
}
#: The animate row's clip length (issue 39's goal: a 96-frame loop at 1920 px).
ANIMATE_FRAMES = 96
_MAIN = "import sys; from fluidnb.cli import main; sys.exit(main())"


def _save(folder, name, image):
    path = folder / f"{name}.png"
    Image.fromarray(to_uint8(image)).save(path)
    return str(path)


def _sized(name, width):
    """A bundled photo resized so its width (its longer side for a portrait) is ``width``."""
    h, w = data.sample(name).shape[:2]
    if h > w:  # the fire photo stands upright: scale its longer side
        return round(w * width / h), width
    return (round(h * width / w), width)


def _box(shape, rows, cols):
    """A rectangle of a (H, W) picture, as fractions of its height and width."""
    h, w = shape
    m = np.zeros((h, w), bool)
    m[int(rows[0] * h) : int(rows[1] * h), int(cols[0] * w) : int(cols[1] * w)] = True
    return m


def arguments(method, width, folder, quick=False):
    """The command line of ``method`` at ``width`` px (its input files written to ``folder``)."""
    out = folder / f"{method}{width}"
    if method == "flicker":
        size = _sized("stream", width)
        photo = _save(folder, f"stream{width}", data.sample("stream", size=size))
        mask = _save(folder, f"stream{width}_region", data.region("stream", size=size))
        return ["flicker", photo, "--mask", mask, "--seed", "1", "-o", f"{out}.mp4"]
    if method == "frost":
        size = _sized("leaf", width)
        photo = _save(folder, f"leaf{width}", data.sample("leaf", size=size))
        h, w = size
        region = np.zeros(size, np.float32)
        region[h // 6 : h - h // 6, w // 6 : w - w // 6] = 1.0
        mask = _save(folder, f"leaf{width}_region", region)
        start = f"{w // 2},{h // 2}"
        args = ["frost", photo, "--region", mask, f"--start={start}", "--seed", "1"]
        return args + ["--max-frames", "240", "--every", "4", "-o", f"{out}.mp4"]
    if method == "fire":
        size = _sized("fire", width)
        photo, alpha = data.sample("fire", size=size, return_alpha=True)
        photo_path = _save(folder, f"fire{width}", photo)
        matte = _save(folder, f"fire{width}_matte", alpha)
        args = ["fire", photo_path, "--matte", matte, "--seed", "1", "--frames", "12"]
        return args + ["--output-size", str(width), "-o", f"{out}.mp4"]
    if method == "animate":
        size = _sized("stream", width)
        photo = _save(folder, f"stream{width}", data.sample("stream", size=size))
        mask = _save(folder, f"stream{width}_region", data.region("stream", size=size))
        args = ["animate", photo, "--matte", mask, "--db", "water", "--seed", "1"]
        args += ["--frames", str(ANIMATE_FRAMES)]
        return args + (["--quick"] if quick else []) + ["-o", f"{out}.npz"]
    if method == "scene":
        photo = data.sample("lake", size=_sized("lake", width))
        h, w = photo.shape[:2]
        yy, xx = np.mgrid[0:h, 0:w]
        regions = {  # as lesson 08 paints them
            "water": _box((h, w), (0.45, 0.58), (0, 1)),
            "fire": _box((h, w), (0.60, 0.98), (0.79, 0.99)),
            "frost": (yy / (0.45 * h)) ** 2 + (xx / (0.30 * w)) ** 2 < 1,
        }
        args = ["scene", _save(folder, f"lake{width}", photo)]
        for kind, region in regions.items():
            args += [f"--{kind}", _save(folder, f"lake{width}_{kind}", region.astype(np.float32))]
        if quick:
            os.environ["FLUIDNB_QUICK"] = "1"  # the child inherits it: the small database
        return args + ["--size", "0", "-o", f"{out}.mp4"]
    raise ValueError(f"method must be one of {METHODS}, got {method!r}")


def run(args):
    """(wall s, CPU s, peak GB, error or None, frames written or None) of ``fluidnb ARGS``."""
    started = time.perf_counter()
    with tempfile.TemporaryFile() as log:
        child = subprocess.Popen(
            [sys.executable, "-c", _MAIN, *args], stdout=log, stderr=subprocess.STDOUT
        )
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - started
        error = None
        log.seek(0)
        text = log.read().decode(errors="replace").replace("\r", "\n").strip()
        if child.returncode != 0:
            error = text.splitlines()[-1] if text else f"exit {child.returncode}"
    # What the command says it wrote: "wrote PATH (T frames, ...)".
    said = re.search(r"wrote .*?\((\d+) frames", text)
    # ru_maxrss is in kilobytes on Linux.
    frames = int(said.group(1)) if said else None
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1e6, error, frames


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--sizes", nargs="+", type=int, default=list(SIZES))
    parser.add_argument("--rounds", type=int, default=1, help="interleaved rounds (median)")
    parser.add_argument("--quick", action="store_true", help="animate, scene: the small databases")
    opts = parser.parse_args(argv)
    print(header(__file__, f"{opts.rounds} round(s), sizes {opts.sizes}"))
    results = {(m, s): [] for m in opts.methods for s in opts.sizes}
    errors = {}
    counts = {}  # the frames each command said it wrote
    loads_seen = []
    with tempfile.TemporaryDirectory(prefix="bench_scale_") as tmp:
        folder = Path(tmp)
        commands = {(m, s): arguments(m, s, folder, opts.quick) for m, s in results}
        for r in range(opts.rounds):
            for key, args in commands.items():
                if key in errors:
                    continue
                before = load()
                wall, cpu, gb, error, frames = run(args)
                loads_seen.append(max(before, load()))
                print(
                    f"round {r + 1} {key[0]:8s} {key[1]:5d} px: {fmt_s(wall)} wall, "
                    f"{fmt_s(cpu)} CPU, {gb:.2f} GB, load {before:.1f}"
                    + (f", {frames} frames" if frames else "")
                    + (f"  FAILED: {error}" if error else ""),
                    flush=True,
                )
                if frames:
                    counts[key] = frames
                if error:
                    errors[key] = error
                else:
                    results[key].append((wall, cpu, gb))

    def median(key, i):
        values = [v[i] for v in results[key]]
        return statistics.median(values) if values else None

    headers = ["method"]
    for i, s in enumerate(opts.sizes):
        headers.append(f"{s} px: time (CPU), peak")
        if i:
            headers.append(f"growth {opts.sizes[i - 1]}->{s}: time, CPU, memory")
    headers.append("goal at the largest size")
    rows = []
    for m in opts.methods:
        row = [m]
        for i, s in enumerate(opts.sizes):
            key = (m, s)
            if key in errors:
                row.append(f"failed: {errors[key][:60]}")
            else:
                row.append(
                    f"{fmt_s(median(key, 0))} ({fmt_s(median(key, 1))}), {median(key, 2):.2f} GB"
                    + (f", {counts[key]} frames" if key in counts else "")
                )
            if i:
                prev = (m, opts.sizes[i - 1])
                if results[key] and results[prev]:
                    row.append(
                        f"{median(key, 0) / median(prev, 0):.2f}x, "
                        f"{median(key, 1) / median(prev, 1):.2f}x, "
                        f"{median(key, 2) / median(prev, 2):.2f}x"
                    )
                else:
                    row.append("-")
        seconds, gb = GOALS[m]
        row.append(" and ".join(x for x in (seconds and f"<= {seconds:g} s", f"<= {gb:g} GB") if x))
        rows.append(row)
    table(headers, rows)
    if loads_seen:
        print(f"load average during the runs: {min(loads_seen):.1f}-{max(loads_seen):.1f}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
