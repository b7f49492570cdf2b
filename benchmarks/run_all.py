"""Every benchmark that checks a performance goal, one after another, in one run.

Usage (from the repository root)::

    .venv/bin/python benchmarks/run_all.py --out /tmp/bench-run
    FLUIDNB_PEERS_PYTHON=/tmp/peers-fluid/bin/python FLUIDNB_CHROMIUM=/usr/bin/chromium \\
        .venv/bin/python benchmarks/run_all.py --out /tmp/bench-run
    ... run_all.py --only fluid,interactive          # some of them
    ... run_all.py --busy 1 --out /tmp/bench-load1   # with one other process busy

An issue's rows are "re-measured in one run" when they come from the same minutes of the
same machine: this runs each benchmark as its own process (so none inherits another's
caches, threads or memory), writes what it prints to ``OUT/<name>.txt``, and ends with
a summary of the wall time and the load average before and after each. It asserts
nothing; the tables to read are in the files (and on the screen as they come).

``--busy N`` measures under load: N other processes (each a Python loop that keeps one
core busy, "load about N") run from before the first benchmark to after the last, and
are stopped whatever happens -- a loop left behind by hand would skew every later
measurement on the machine.

The benchmarks (see benchmarks/README.md for each one's cases and peers):

- ``fluid``: ``bench_fluid.py`` -- the flame step against jax-cfd (side by side when
  ``FLUIDNB_PEERS_PYTHON`` names the peers' environment);
- ``interactive``, ``paper``, ``starter``: ``bench_videodb.py --part ...`` -- assign,
  re-solve, render and the app's Render at the interactive scale; the paper's job on
  the 240k-fragment store; the starter database builds;
- ``browser``: ``browser_videodb_app.py`` -- the video-database app in Chromium (needs
  ``FLUIDNB_CHROMIUM`` or /usr/bin/chromium).
"""

from __future__ import annotations

import argparse
import contextlib
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # _report (also when loaded by path, as the tests do)

from _report import header, load  # noqa: E402

RUNS = {
    "fluid": ["bench_fluid.py"],
    "interactive": ["bench_videodb.py", "--part", "interactive"],
    "paper": ["bench_videodb.py", "--part", "paper"],
    "starter": ["bench_videodb.py", "--part", "starter"],
    "browser": ["browser_videodb_app.py", "--rounds", "3"],
}


#: What each ``--busy`` process runs: one core kept busy, nothing else.
BUSY_LOOP = "while True: pass"


@contextlib.contextmanager
def busy(n):
    """``n`` processes each keeping one core busy while the block runs; always stopped."""
    procs = []
    try:
        for _ in range(n):
            procs.append(subprocess.Popen([sys.executable, "-c", BUSY_LOOP]))
        yield procs
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for each one's output")
    parser.add_argument(
        "--only", help=f"comma-separated names among {', '.join(RUNS)} (default: all)"
    )
    parser.add_argument("--quick", action="store_true", help="pass --quick where it is taken")
    parser.add_argument(
        "--busy",
        type=int,
        default=0,
        metavar="N",
        help="keep N other processes busy (one core each) throughout: measure under load",
    )
    args = parser.parse_args()
    if args.busy < 0:
        parser.error(f"--busy must be 0 or more, got {args.busy}")
    names = list(RUNS) if not args.only else [n.strip() for n in args.only.split(",")]
    unknown = [n for n in names if n not in RUNS]
    if unknown:
        parser.error(f"--only: unknown {', '.join(unknown)}; choose among {', '.join(RUNS)}")
    args.out.mkdir(parents=True, exist_ok=True)
    print(header(__file__, f"outputs in {args.out}"))
    with busy(args.busy):
        if args.busy:
            print(f"== {args.busy} other process(es) busy throughout ({BUSY_LOOP!r})", flush=True)
            time.sleep(2)  # the load average starts to show them
        summary = [run(name, args) for name in names]
    print("\nname         exit   wall     load before -> after")
    for name, code, seconds, before, after in summary:
        print(f"{name:<12} {code:>4} {seconds:>7.0f} s  {before:.1f} -> {after:.1f}")
    if args.busy:
        print(f"with {args.busy} other process(es) busy throughout (stopped)")
    print(f"outputs in {args.out}")
    return max((code != 0 for _, code, *_ in summary), default=0)


def run(name, args):
    """Run one benchmark as its own process; returns (name, exit code, s, load before, after)."""
    cmd = [sys.executable, str(HERE / RUNS[name][0]), *RUNS[name][1:]]
    if args.quick:
        cmd.append("--quick")
    before = load()
    started = time.monotonic()
    print(f"== {name}: {' '.join(cmd[1:])} (load {before:.1f})", flush=True)
    with (args.out / f"{name}.txt").open("w") as log:
        proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=HERE.parent
        )
        for line in proc.stdout:
            sys.stdout.write(line)
            log.write(line)
        code = proc.wait()
    seconds = time.monotonic() - started
    return name, code, seconds, before, load()


if __name__ == "__main__":
    sys.exit(main())
