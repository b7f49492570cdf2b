"""The video-database method (fluidnb.videodb) at the paper's scale, timed.

    .venv/bin/python benchmarks/bench_videodb.py                 # every part
    .venv/bin/python benchmarks/bench_videodb.py --part paper --part interactive
    .venv/bin/python benchmarks/bench_videodb.py --quick         # a smoke run, minutes
    FLUIDNB_PEERS_PYTHON=/tmp/peers/bin/python .venv/bin/python benchmarks/bench_videodb.py \\
        --part solver

Seed 000 (Okabe, Anjyo & Onai, "Creating fluid animation from a single image using
video database", Pacific Graphics 2011): the first version of an animation took about
an hour on an Intel Xeon 3.33 GHz with the database on a remote server -- half an hour
for the assignment (dominated by the smoothness terms' random disk reads, 100 x 100
candidate pairs per edge), half an hour for rendering -- over a water database of
~240,000 fragments (151 videos). The parts (``--part``, repeatable; ``build`` = starter
+ throughput), one module each in ``benchmarks/videodb/`` (its docstring says what it
measures and against which goal):

- ``starter`` (``videodb/starter.py``): each starter database built from scratch, as a
  user gets it; goal: each under 15 s on 2 cores, and the same database as the cache's;
- ``throughput`` (``videodb/throughput.py``): fragments/s of ``build_database`` with
  each flow backend, and the projected time to build a paper-sized database;
- ``store`` (``videodb/store.py``): a paper-sized store synthesised from the starter
  water database (``videodb/synthetic_store.py``): its size, open, index and gathers;
- ``paper`` (``videodb/paper.py``): a 640 x 360 target, 100 candidates, the 240k store:
  assignment and rendering against the paper's hour; goal: under a minute;
- ``interactive`` (``videodb/interactive.py``): a 320 x 180 target assigned, re-solved
  and rendered on the starter database, the re-solve at the app's size, the app's
  Render;
- ``rendering`` (``videodb/rendering.py``): the flow rendering against the paper's:
  the output's motion against the painted speed and stroke, neighbours in sync;
- ``solver`` (``videodb/solver.py``): alpha-expansion against ICM on the real
  assignments, and on a metric sub-case beside gco-wrapper and PyMaxflow.

The paper's findings of its section 7 (lambda matters little, sigma a lot, rho less)
are an experiment, not a timing: ``benchmarks/experiments/videodb_findings.py``.

Use a private cache (``FLUIDNB_CACHE_DIR``) to keep the starter databases and the
synthetic store between runs. The peer (gco-wrapper) lives in its own environment,
never in fluidnb's, and runs through ``FLUIDNB_PEERS_PYTHON`` in a subprocess::

    python3 -m venv /tmp/peers && /tmp/peers/bin/pip install gco-wrapper numpy

Timings drift up to 2x within minutes on a shared 2-core machine: repeated cases run
round-robin and are reported as fastest / median, with the load average
(``benchmarks/_report.py``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _report import header, machine, now

# fluidnb is imported inside the parts' functions: the solver part's peer runs this
# script in the peers' interpreter, which does not have it.

PARTS = ("starter", "throughput", "store", "paper", "interactive", "rendering", "solver")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--part",
        action="append",
        choices=(*PARTS, "build", "all"),
        help="what to run (repeatable; default all; build = starter + throughput)",
    )
    parser.add_argument("--quick", action="store_true", help="quick starter databases, small store")
    parser.add_argument("--rounds", type=int, default=7, help="interleaved rounds (interactive)")
    parser.add_argument("--json", help="write every measurement to this JSON file")
    parser.add_argument("--peer", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peer:
        from videodb.solver import peer_main

        return peer_main(args.peer)
    chosen = set(args.part or ["all"])
    if "all" in chosen:
        chosen = set(PARTS)
    if "build" in chosen:
        chosen |= {"starter", "throughput"}
    from videodb._common import Context, cache_folder

    ctx = Context(args)
    print(header(__file__, f"cache {cache_folder()}", "quick" if args.quick else "full"))
    started = now()
    for name in PARTS:
        if name in chosen:
            importlib.import_module(f"videodb.{name}").run(ctx)
            sys.stdout.flush()
    print(f"\n(whole run {now() - started:.0f} s)")
    if args.json:
        ctx.results["machine"] = machine()
        ctx.results["date"] = time.strftime("%Y-%m-%d %H:%M")
        Path(args.json).write_text(json.dumps(ctx.results, indent=1, default=_json_default))
    return None


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


if __name__ == "__main__":
    sys.exit(main())
