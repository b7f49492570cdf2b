"""What every benchmark reports the same way: the machine, the load, timings, tables.

Each script in benchmarks/ imports this module (benchmarks/ is on ``sys.path`` when a
script runs; a module run in another interpreter, a peer's, needs only numpy):

- :func:`header` -- the first line of a run: the script, the machine, the date, the
  load average (``# bench_x.py -- AMD EPYC, 2 cores, Python 3.11.7; 2026-11-27 18:22;
  load avg 4.8``);
- :func:`machine`, :func:`load`, :func:`loads` -- the same pieces alone (the load
  average is the 1-minute one unless all three are asked for; NaN where the system
  has none);
- :func:`table` -- a markdown table, printed;
- :func:`best`, :func:`fastest_median`, :func:`fm`, :func:`fmt_s`, :func:`met`,
  :func:`now` -- timing and how it is written;
- :func:`doc_number` -- a number the documentation states, printed so that
  ``run_all.py`` collects it into benchmarks/README.md's table "Numbers the docs state".

Timings on a shared machine drift up to 2x within minutes: report the load beside
every timing, interleave the cases compared, report fastest and median.
"""

from __future__ import annotations

import math
import os
import platform
import time
from pathlib import Path

import numpy as np

__all__ = [
    "DOC_NUMBER",
    "best",
    "doc_number",
    "fastest_median",
    "fm",
    "fmt_s",
    "header",
    "load",
    "loads",
    "machine",
    "met",
    "now",
    "table",
]


#: How a number the docs state starts its line (``run_all.py`` reads these lines back).
DOC_NUMBER = "DOC-NUMBER"


def doc_number(key, seconds, load_before, load_after):
    """Print one measured number the documentation states, on a line of its own.

    ``DOC-NUMBER <key> <seconds> <load before> <load after>``; ``run_all.py`` gathers
    these lines from every benchmark it runs into ``docs_numbers.json``, and
    ``run_all.py --docs-table`` makes the table the docs link to of several runs.
    """
    print(f"{DOC_NUMBER} {key} {seconds:.2f} {load_before:.2f} {load_after:.2f}", flush=True)


def now():
    """``time.perf_counter()``: seconds, for differences."""
    return time.perf_counter()


def loads():
    """The 1-, 5- and 15-minute load averages (NaN where the system has none)."""
    try:
        return os.getloadavg()
    except (AttributeError, OSError):
        return (math.nan,) * 3


def load():
    """The 1-minute load average (NaN where the system has none)."""
    return loads()[0]


def machine():
    """The CPU's model name, the number of cores and the Python version, in one line."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def header(script, *details):
    """The first line of a benchmark's output: what ran, where, when, under what load."""
    parts = [machine(), time.strftime("%Y-%m-%d %H:%M"), *details, f"load avg {load():.1f}"]
    return f"# {Path(script).name} -- {'; '.join(parts)}"


def fmt_s(seconds):
    """Seconds as a reader wants them: ``12.3 ms``, ``1.23 s``, ``123 s`` (``-`` for None)."""
    if seconds is None:
        return "-"
    if seconds < 0.1:
        return f"{1e3 * seconds:.1f} ms"
    if seconds < 100:
        return f"{seconds:.2f} s"
    return f"{seconds:.0f} s"


def fastest_median(values):
    """The fastest and the median of timings."""
    v = np.asarray(values, float)
    return float(v.min()), float(np.median(v))


def fm(values):
    """``fastest / median`` of timings, written."""
    lo, med = fastest_median(values)
    return f"{fmt_s(lo)} / {fmt_s(med)}"


def met(fastest, median, goal):
    """Whether a goal (seconds) is met: ``yes`` (the median), ``fastest only`` or ``no``."""
    if median < goal:
        return "yes"
    return "fastest only" if fastest < goal else "no"


def table(headers, rows):
    """Print a markdown table."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    print("\n".join(lines))


def best(fn, repeat=7):
    """Best wall time of ``repeat`` calls of ``fn()`` after one warm-up call, in seconds."""
    fn()  # warm caches and lazy imports
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)
