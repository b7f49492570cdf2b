"""``bench_videodb.py --part throughput``: ``build_database``'s fragments/s per flow backend.

On the first two starter water clips, with each flow backend (OpenCV DIS, scikit-image
TV-L1): the build's stages timed from its progress messages, one flow pair's time, and
the projected time to build a paper-sized database (240,000 fragments) here.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from _report import fmt_s, load, now, table

from videodb._common import PAPER_FRAGMENTS, StageClock


def run(ctx):
    from fluidnb import as_image
    from fluidnb.videodb import build_database, starter_params
    from fluidnb.videodb.database import optical_flow
    from fluidnb.videodb.starter import starter_clips

    print("\n## Build throughput per flow backend (first two starter water clips)")
    clips = starter_clips("water", quick=ctx.quick, seed=0)[:2]
    shape = clips[0][1].frames.shape
    n = starter_params().N
    window = np.stack([as_image(f, mode="grey") for f in clips[0][1].frames[:n]])
    pairs = 2 if ctx.quick else 4
    rows, out = [], []
    tmp = Path(tempfile.mkdtemp(prefix="bench-videodb-flow-"))
    try:
        for backend in ("dis", "tvl1"):
            load0 = load()
            optical_flow(window[:2], backend=backend)  # warm-up (imports, OpenCV init)
            t0 = now()
            optical_flow(window[: pairs + 1], backend=backend)
            per_pair = (now() - t0) / pairs
            clock = StageClock()
            t0 = now()
            db = build_database(
                clips,
                tmp / backend,
                kind="water",
                params=starter_params().replace(flow=backend),
                seed=0,
                progress=clock,
            )
            secs = now() - t0
            f = db.n_fragments
            rate = f / secs
            step = starter_params().window_step
            windows = sum((c.frames.shape[0] - n) // step + 1 for _, c in clips)
            flow_cpu = windows * (n - 1) * per_pair
            st = clock.durations()
            # The per-clip stages scale with the fragments; the codebook is fitted once on
            # a capped sample (100k descriptors), so it is counted once.
            linear = st["ingest"] + st["fragments"] + st["words"]
            projected = PAPER_FRAGMENTS / f * linear + st["codebook"]
            rec = {
                "backend": backend,
                "clips": [name for name, _ in clips],
                "clip_shape": list(shape),
                "fragments": f,
                "build_s": secs,
                "stages_s": clock.durations(),
                "fragments_per_s": rate,
                "flow_s_per_pair": per_pair,
                "flow_pairs": windows * (n - 1),
                "projected_240k_s": projected,
                "load": (load0, load()),
            }
            out.append(rec)
            rows.append(
                [
                    backend,
                    f"{f:,}",
                    fmt_s(secs),
                    fmt_s(st["fragments"]),
                    fmt_s(st["codebook"]),
                    f"{rate:.0f} ({f / st['fragments']:.0f})",
                    fmt_s(per_pair),
                    f"{windows * (n - 1)} pairs, {fmt_s(flow_cpu)} CPU",
                    f"{projected / 60:.0f} min ({projected / 3600:.1f} h)",
                    f"{load0:.1f} -> {load():.1f}",
                ]
            )
            shutil.rmtree(tmp / backend, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    h, w = shape[1:3]
    print(f"clips {', '.join(name for name, _ in clips)}: {shape[0]} frames {h} x {w}, N = {n}")
    table(
        [
            "flow",
            "fragments",
            "build",
            "fragments stage (flow, features, SIFT)",
            "codebook",
            "fragments/s (in the fragments stage)",
            "flow per pair (1 thread)",
            "flow work",
            "projected 240k fragments here",
            "load avg",
        ],
        rows,
    )
    ratio = out[1]["build_s"] / out[0]["build_s"]
    print(
        f"\nTV-L1 / DIS build time: {ratio:.1f}x. The paper gives no build time (its flow: "
        "OFLib's TV-L1, 25 iterations). Projection = ingest + fragments + words scaled to "
        "240,000 fragments + the codebook once; it assumes the starter clips' ratio of "
        "fragments to flow pairs (18 versions of each window share one flow), 2 threads."
    )
    ctx.results["throughput"] = out
