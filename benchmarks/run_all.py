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
  ``FLUIDNB_CHROMIUM`` or /usr/bin/chromium);
- ``first_run``: ``first_run.py`` -- what a class waits for, from ``python3 dev.py lab``
  in an empty cache to the app's first result and each lesson's first Run All (and a
  second Run All, the databases cached).

**The numbers the docs state** (issue 37: a starter build was 11-12 s in one place,
12-14 s, 15-30 s and "~40 s" in others) come from here alone. A benchmark prints each
as a ``DOC-NUMBER`` line (``_report.doc_number``); this collects them into
``OUT/docs_numbers.json`` with the run's load and ``--busy``, and ::

    .venv/bin/python benchmarks/run_all.py --docs-table /tmp/run-quiet /tmp/run-busy1

prints the table of several runs (each number's range over every run, rounded
outwards to whole seconds, and its median) that benchmarks/README.md keeps under
"Numbers the docs state"; the README, the lessons and the docstrings link to it or
state its ranges (``tests/faults/test_doc_numbers.py`` checks they agree).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # _report (also when loaded by path, as the tests do)

from _report import DOC_NUMBER, header, load  # noqa: E402

RUNS = {
    "fluid": ["bench_fluid.py"],
    "interactive": ["bench_videodb.py", "--part", "interactive"],
    "paper": ["bench_videodb.py", "--part", "paper"],
    "starter": ["bench_videodb.py", "--part", "starter"],
    "browser": ["browser_videodb_app.py", "--rounds", "3"],
    "first_run": ["first_run.py"],
}

#: Each number the docs state: its key (a ``DOC-NUMBER`` key, or the prefix of several:
#: ``starter_build`` is every kind's), what it is, and where the docs state it.
DOC_ROWS = {
    "starter_build": (
        "a starter database's build (water, smoke, fire; each, from an empty cache)",
        "README (videodb row), 07a, 07b, 00_overview, dev.py, starter/_databases.py",
        "starter",
    ),
    "first_run.app": (
        "`python3 dev.py lab` in an empty cache -> the app's first result",
        "README (videodb row)",
        "first_run",
    ),
    "first_run.07a": (
        "`python3 dev.py lab` in an empty cache -> 07a's first Run All (full mode)",
        "README (videodb row), 07a",
        "first_run",
    ),
    "first_run.07b": (
        "`python3 dev.py lab` in an empty cache -> 07b's first Run All (full mode)",
        "README (videodb row), 07b",
        "first_run",
    ),
    # Measured, stated nowhere yet (first measured 2026-11-27, on an overloaded machine).
    "cached_run.07a": ("07a's Run All again, the databases cached", "-", "first_run"),
    "cached_run.07b": ("07b's Run All again, the databases cached", "-", "first_run"),
}

#: The heading of the table in benchmarks/README.md (the docs link to its anchor).
DOC_TABLE = "Numbers the docs state"


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
    parser.add_argument("--out", type=Path, help="folder for each one's output")
    parser.add_argument(
        "--only", help=f"comma-separated names among {', '.join(RUNS)} (default: all)"
    )
    parser.add_argument("--quick", action="store_true", help="pass --quick where it is taken")
    parser.add_argument(
        "--docs-table",
        nargs="+",
        type=Path,
        metavar="RUN",
        help="print the table of the numbers the docs state from these runs' --out folders",
    )
    parser.add_argument(
        "--busy",
        type=int,
        default=0,
        metavar="N",
        help="keep N other processes busy (one core each) throughout: measure under load",
    )
    args = parser.parse_args()
    if args.docs_table:
        try:
            print(docs_table([read_numbers(run) for run in args.docs_table]))
        except ValueError as exc:
            parser.error(str(exc))
        return 0
    if args.out is None:
        parser.error("--out is required (unless --docs-table)")
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
    numbers = [n for *_, found in summary for n in found]
    (args.out / "docs_numbers.json").write_text(
        json.dumps(
            {
                "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                "busy": args.busy,
                "numbers": numbers,
            },
            indent=1,
        )
        + "\n"
    )
    print("\nname         exit   wall     load before -> after")
    for name, code, seconds, before, after, _ in summary:
        print(f"{name:<12} {code:>4} {seconds:>7.0f} s  {before:.1f} -> {after:.1f}")
    if args.busy:
        print(f"with {args.busy} other process(es) busy throughout (stopped)")
    print(f"outputs in {args.out}")
    return max((code != 0 for _, code, *_ in summary), default=0)


def run(name, args):
    """Run one benchmark as its own process.

    Returns (name, exit code, s, load before, after, the numbers the docs state it
    printed: :func:`doc_numbers`).
    """
    cmd = [sys.executable, str(HERE / RUNS[name][0]), *RUNS[name][1:]]
    if args.quick:
        cmd.append("--quick")
    before = load()
    started = time.monotonic()
    print(f"== {name}: {' '.join(cmd[1:])} (load {before:.1f})", flush=True)
    lines = []
    with (args.out / f"{name}.txt").open("w") as log:
        proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=HERE.parent
        )
        for line in proc.stdout:
            sys.stdout.write(line)
            log.write(line)
            lines.append(line)
        code = proc.wait()
    seconds = time.monotonic() - started
    return name, code, seconds, before, load(), doc_numbers(lines)


def doc_numbers(lines):
    """The ``DOC-NUMBER key seconds load-before load-after`` lines among ``lines``, as dicts."""
    found = []
    for line in lines:
        parts = line.split()
        if len(parts) == 5 and parts[0] == DOC_NUMBER:
            seconds, before, after = map(float, parts[2:])
            found.append({"key": parts[1], "seconds": seconds, "load": [before, after]})
    return found


def read_numbers(folder):
    """The ``docs_numbers.json`` a run wrote into ``folder`` (or that file, kept under
    another name in benchmarks/docs_numbers/); ValueError naming it."""
    file = Path(folder)
    if file.is_dir():
        file = file / "docs_numbers.json"
    try:
        run = json.loads(file.read_text(encoding="utf-8"))
        [(float(n["seconds"]), str(n["key"])) for n in run["numbers"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"--docs-table: cannot read {str(file)!r} ({exc})") from None
    return run


def doc_range(values):
    """``"lo-hi s"``: the values' range rounded outwards to whole seconds."""
    lo, hi = math.floor(min(values)), math.ceil(max(values))
    return f"{lo} s" if lo == hi else f"{lo}-{hi} s"


#: The docs state what holds on a class's machine: quiet, or with one or two other
#: processes busy (the 1-minute load average up to this, before and after, on 2 cores).
#: What was measured on a machine more loaded than that is in the table, not in the docs.
STATED_LOAD = 5.0


def docs_table(runs):
    """The markdown table of the numbers the docs state, over several runs.

    Each row: every value of its key (or of the keys it is the prefix of) in every
    run measured at a load average up to :data:`STATED_LOAD` -- its range rounded
    outwards (what the docs state), its median, how many values from how many runs,
    the load over them (1-minute, before and after) -- and the values measured on a
    machine more loaded than that.
    """
    rows = [
        f"| number | range (load <= {STATED_LOAD:g}) | median | values (runs) | load avg "
        f"| on a machine more loaded | stated in |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, (what, where, bench) in DOC_ROWS.items():
        found = [
            (n["seconds"], n["load"], i)
            for i, run in enumerate(runs)
            for n in run["numbers"]
            if n["key"] == key or n["key"].startswith(key + ".")
        ]
        stated = [f for f in found if max(f[1]) <= STATED_LOAD]
        more = [f for f in found if max(f[1]) > STATED_LOAD]
        over = "-"
        if more:
            loads = [x for _, pair, _ in more for x in pair]
            over = f"{doc_range([v for v, _, _ in more])} (load {min(loads):.1f}-{max(loads):.1f})"
        if not stated:
            rows.append(f"| {what} | not measured (`--only {bench}`) | | 0 | | {over} | {where} |")
            continue
        values = [v for v, _, _ in stated]
        loads = [x for _, pair, _ in stated for x in pair]
        rows.append(
            f"| {what} | **{doc_range(values)}** | {statistics.median(values):.1f} s "
            f"| {len(values)} ({len({i for *_, i in stated})}) "
            f"| {min(loads):.1f}-{max(loads):.1f} | {over} | {where} |"
        )
    when = "; ".join(
        f"{r.get('when', '?')} (busy {r.get('busy', 0)}"
        + (f", {r['source']}" if r.get("source") else "")
        + ")"
        for r in runs
    )
    return "\n".join(rows) + f"\n\nRuns: {when}."


if __name__ == "__main__":
    sys.exit(main())
