"""Turbulence synthesis: every local-search strategy side by side, next to Table 1.

    python benchmarks/bench_turbulence.py [--frames 200]
    FLUIDNB_PEERS_PYTHON=/tmp/peers/bin/python python benchmarks/bench_turbulence.py

Watanabe et al.'s experiment (sec. 4, Table 1; Core i7-2600K): a 16 x 24 target and a
128 x 192 source, 200 frames, B = 16, b = 4; the local search's time per frame and
its mean relative / absolute error against the exhaustive search. fluidnb runs the
same set-up on its sample pair (``fluidnb.turbulence.sample_flows``) with every
strategy in one run (``fluidnb.turbulence.compare``): each strategy's errors are
measured against the exhaustive minimum of the very same search (same window, same
temporal term). The goals from the spec: adaptive about 9x faster than exhaustive at
a mean relative error near 0.01; the exact search at least as fast as adaptive with
zero error; the whole 200-frame synthesis in seconds.

Peer (installed in a separate environment, never in fluidnb's, run through
``FLUIDNB_PEERS_PYTHON`` in a subprocess)::

    python3 -m venv /tmp/peers && /tmp/peers/bin/pip install opencv-python-headless

OpenCV's ``cv2.matchTemplate`` with ``TM_SQDIFF`` (optimised C++, an exact sum of
squared differences through correlation) on the same local searches: one call per
patch and channel (it takes at most 4 channels), summed. It works in float32, so
its positions are compared with the exhaustive ones.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from _report import header

# fluidnb is imported inside the functions: the peer part of this script runs in the
# peers' interpreter, which does not have it.


def search_problems(run, frames):
    """The local searches of some frames of a synthesis ``run``, as it made them.

    Each is ``(S, X, starts, n, hint)``: the features with the temporal term, the
    windows, and the previous frame's choices (the hint ``synthesize`` gives).
    """
    from fluidnb.fields import advect
    from fluidnb.turbulence import local_features

    prep, params = run.prepared, run.params
    out = []
    for i in frames:
        previous = advect(run.detail[i - 1], prep.U_t[i - 1]) if i > 0 else None
        S, X = local_features(prep, i, previous, params)
        hint = run.local_positions[i - 1] if i > 0 else None
        out.append((S, X, prep.window_starts(run.global_positions[i]), prep.window, hint))
    return out


def head_to_head(problems, strategies, rounds=5):
    """Seconds per frame of each strategy on the same searches, alternating.

    On a shared machine the speed drifts by up to 2x within minutes; alternating the
    strategies frame by frame and taking each frame's fastest round (and median)
    compares them under the same conditions.
    """
    from fluidnb.turbulence import local_search

    secs = {s: np.empty((len(problems), rounds)) for s in strategies}
    for r in range(rounds):
        for f, (S, X, starts, n, hint) in enumerate(problems):
            for s in strategies:
                secs[s][f, r] = local_search(S, X, starts, n, s, hint=hint).seconds
    return {s: (t.min(1).mean(), np.median(t, 1).mean()) for s, t in secs.items()}


def peer_main(path):
    """Run in the peers' interpreter: OpenCV's matchTemplate on the saved searches."""
    import cv2

    z = np.load(path)
    n = int(z["n"])
    rows = []
    for f in range(int(z["count"])):
        S, X, starts = (z[f"{k}{f}"].astype(np.float32) for k in "SXs")
        starts = starts.astype(int)
        B = X.shape[1]
        t0 = time.perf_counter()
        pos = []
        for p in range(len(X)):
            y, x = starts[p]
            region = S[y : y + n + B - 1, x : x + n + B - 1]
            e = sum(
                cv2.matchTemplate(region[..., c], X[p][..., c], cv2.TM_SQDIFF)
                for c in range(S.shape[-1])
            )
            k = int(np.argmin(e))
            pos.append((y + k // n, x + k % n))
        rows.append(
            {"seconds": time.perf_counter() - t0, "positions": [[int(a), int(b)] for a, b in pos]}
        )
    print(json.dumps({"rows": rows, "version": cv2.__version__}))


def run_peer(problems):
    exe = os.environ.get("FLUIDNB_PEERS_PYTHON")
    if not exe:
        return None, "set FLUIDNB_PEERS_PYTHON to a Python with opencv-python-headless"
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "problems.npz")
        arrays = {"count": len(problems), "n": problems[0][3]}
        for f, (S, X, starts, _) in enumerate(problems):
            arrays.update({f"S{f}": S, f"X{f}": X, f"s{f}": starts})
        np.savez(path, **arrays)
        proc = subprocess.run(
            [exe, __file__, "--peer", path], capture_output=True, text=True, check=False
        )
    if proc.returncode:
        return None, proc.stderr.strip().splitlines()[-1]
    return json.loads(proc.stdout), None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--peer", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peer:
        return peer_main(args.peer)
    from fluidnb.turbulence import (
        PAPER_TABLE1,
        TurbulenceParams,
        compare,
        local_search,
        sample_flows,
        synthesize,
        table1,
    )

    print(header(__file__))
    t0 = time.perf_counter()
    target, source = sample_flows(args.frames)
    print(f"sample pair ({args.frames} frames): {time.perf_counter() - t0:.1f} s (cached after)")
    # Compile the kernels before anything is timed.
    warm = [f.frames(0, 3) for f in (target, source)]
    for s in ("exhaustive", "adaptive", "exact-fft", "exact-bounds"):
        synthesize(*warm, TurbulenceParams(strategy=s), reference=True)

    results = compare(target, source)
    rows = table1(results)
    ex = PAPER_TABLE1["exhaustive"][2]
    print()
    print(
        "| search | rel. error | abs. error | s/frame | speed-up | paper rel. | paper abs. "
        "| paper s/frame | paper speed-up | evaluations/patch |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        paper = PAPER_TABLE1.get(r["strategy"])
        cells = (
            [f"{paper[0]:.4f}", f"{paper[1]:.4f}", f"{paper[2]:.4f}", f"{ex / paper[2]:.1f}x"]
            if paper
            else ["-", "-", "-", "-"]
        )
        print(
            f"| {r['strategy']} | {r['relative_error']:.4f} | {r['absolute_error']:.4f} "
            f"| {r['seconds_per_frame']:.4f} | {r['speedup']:.1f}x | "
            + " | ".join(cells)
            + f" | {r['evaluations_per_patch']:.0f} |"
        )
    for label, res in results.items():
        sm = res.errors(smoke_only=True)
        print(
            f"  {label}: smoke patches only -> rel {np.nanmean(sm['relative']):.4f}, "
            f"abs {np.nanmean(sm['absolute']):.4f}; worst frame rel "
            f"{np.nanmax(res.errors()['relative']):.4f}"
        )

    # The goal "the exact search at least as fast as the adaptive one", head to head:
    # every frame's local search of the exact run, both strategies alternating.
    problems = search_problems(results["exact-bounds"], range(args.frames))
    h2h = head_to_head(problems, ("adaptive", "exact-bounds"))
    (a_min, a_med), (e_min, e_med) = h2h["adaptive"], h2h["exact-bounds"]
    print(
        f"\nhead to head, all {args.frames} frames alternating, 5 rounds (s/frame, "
        f"fastest round / median): adaptive {a_min:.4f} / {a_med:.4f}, exact-bounds "
        f"{e_min:.4f} / {e_med:.4f}; exact / adaptive = {e_min / a_min:.2f} / "
        f"{e_med / a_med:.2f}"
    )

    # The whole synthesis, start to end, as a user runs it.
    for s in ("adaptive", "exact-bounds"):
        t0 = time.perf_counter()
        run = synthesize(target, source, TurbulenceParams(strategy=s))
        total = time.perf_counter() - t0
        t = run.timings
        print(
            f"\nwhole {args.frames}-frame synthesis ({s}): {total:.1f} s "
            f"(prepare {t['prepare']:.1f} s, global search {t['global_search']:.1f} s, "
            f"local search {t['local_search']:.1f} s)"
        )

    # The peer on the same searches (every 20th frame from 10).
    frames = list(range(10, args.frames, 20)) or [1]
    problems = [p[:4] for p in search_problems(results["exhaustive"], frames)]
    peer, err = run_peer(problems)
    if peer is None:
        print(f"\npeer skipped: {err}")
        return None
    ours = {}
    for s in ("exhaustive", "exact-fft", "exact-bounds", "adaptive"):
        secs, same = [], 0
        for (S, X, starts, n), prow in zip(problems, peer["rows"]):
            out = local_search(S, X, starts, n, s)
            t0 = time.perf_counter()
            local_search(S, X, starts, n, s)
            secs.append(time.perf_counter() - t0)
            same += int((out.positions == np.array(prow["positions"])).all(1).sum())
        ours[s] = (float(np.mean(secs)), same)
    total = sum(len(p[1]) for p in problems)
    peer_s = float(np.mean([r["seconds"] for r in peer["rows"]]))
    print(f"\nOpenCV {peer['version']} matchTemplate TM_SQDIFF, {len(frames)} frames:")
    print("| search | s/frame | peer / ours | positions equal to the peer's |")
    print("|---|---|---|---|")
    print(f"| OpenCV matchTemplate (float32) | {peer_s:.4f} | 1.0x | - |")
    for s, (sec, same) in ours.items():
        print(f"| fluidnb {s} | {sec:.4f} | {peer_s / sec:.1f}x | {same}/{total} |")
    return None


if __name__ == "__main__":
    sys.exit(main())
