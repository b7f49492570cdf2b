"""The video-database method (fluidnb.videodb) at the paper's scale, timed, and its findings.

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
+ throughput):

- ``starter``: each starter database (water, smoke, fire) built from scratch, as a user
  gets it (``starter_database`` in an empty cache: its clips made, each stored and cut
  into fragments as soon as it is made, codebook, words); goal: each under 15 s on 2
  cores (the spec's bound: 2 minutes), and the same database as the cache's.
- ``throughput``: fragments/s of ``build_database`` on the first two starter water
  clips with each flow backend (OpenCV DIS, scikit-image TV-L1), one flow pair's time,
  and the projected time to build a paper-sized database (240,000 fragments) here.
- ``store``: a paper-sized store, synthesised from the starter water database
  (``benchmarks/_videodb_store.py`` says how; cached): its size on disk, the time to
  open it (features into RAM), to index it, and to gather 100 fragments' features from
  RAM against random reads from the zarr store.
- ``paper``: a 640 x 360 target (the "stream" photo resized, with its matte), 100
  candidates, the 240k store: assignment and rendering, stage by stage, against the
  paper's hour; goal: under a minute on 2 cores.
- ``interactive``: on the starter water database, a 320 x 180 target assigned (goal
  < 1 s), re-solved after a sigma, lambda or rho change (goal < 0.5 s), rendered (goal
  < 3 s); rounds interleaved, fastest and median.
- ``rendering``: the flow rendering (beyond the paper) against the paper's, on the
  starter water database with the stream at 320 x 180, a stroke left to right and a
  painted speed of 2 and 0.5 px/frame: the output's optical flow (OpenCV DIS, preset
  MEDIUM, between consecutive frames, mean over the matte) against the painted speed
  and the stroke's direction, the share of neighbouring target fragments that play the
  same fragment in sync before and after the temporal offsets, and the time of each
  rendering's stages (rounds interleaved); goal (issue 24): 0.65-1.35x the painted
  speed, within 20 degrees, a 24-frame render under 0.25 s.
- ``solver``: alpha-expansion (``solve``) against ICM on the real assignments, and on a
  metric sub-case (shared labels = direction / speed bins of the candidates' mean
  motion, Potts or truncated L1) side by side with gco-wrapper (``gco.cut_grid_graph_
  simple``) run in its own environment, and PyMaxflow's ``fastmin.aexpansion_grid``.
- ``findings``: the paper's section 7 (lambda matters little, sigma a lot, rho less) on
  each starter database with a photo of its kind: each of lambda, sigma, rho a decade
  either side of the paper's values, re-solved; the fraction of target fragments whose
  assignment changes and the coherence of the assigned mean motions.

Use a private cache (``FLUIDNB_CACHE_DIR``) to keep the starter databases and the
synthetic store between runs. The peer (gco-wrapper) lives in its own environment,
never in fluidnb's, and runs through ``FLUIDNB_PEERS_PYTHON`` in a subprocess::

    python3 -m venv /tmp/peers && /tmp/peers/bin/pip install gco-wrapper numpy

Timings drift up to 2x within minutes on a shared 2-core machine: repeated cases run
round-robin and are reported as fastest / median, with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# fluidnb is imported inside the functions: the peer part of this script runs in the
# peers' interpreter, which does not have it.

PARTS = (
    "starter",
    "throughput",
    "store",
    "paper",
    "interactive",
    "rendering",
    "solver",
    "findings",
)
KINDS = ("water", "smoke", "fire")
PAPER_FRAGMENTS = 240_000
QUICK_FRAGMENTS = 24_000
PAPER_ASSIGN_S = 30 * 60
PAPER_RENDER_S = 30 * 60
DEFAULTS = "defaults (paper: lambda 0.01, sigma 100, rho 100 sigma)"

# ------------------------------------------------------------------------ helpers


def now():
    return time.perf_counter()


def load():
    return os.getloadavg()[0]


def fmt_s(seconds):
    if seconds is None:
        return "-"
    if seconds < 0.1:
        return f"{1e3 * seconds:.1f} ms"
    if seconds < 100:
        return f"{seconds:.2f} s"
    return f"{seconds:.0f} s"


def table(headers, rows):
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    print("\n".join(lines))


def fastest_median(values):
    v = np.asarray(values, float)
    return float(v.min()), float(np.median(v))


def fm(values):
    lo, med = fastest_median(values)
    return f"{fmt_s(lo)} / {fmt_s(med)}"


def machine():
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


#: build_database's progress messages that end its stages.
STAGE_MARKS = {
    "clips read": "ingest",
    "fragments done": "fragments",
    "codebook ready": "codebook",
    "database ready": "words",
}


class StageClock:
    """A progress callable noting when each of build_database's stages ends."""

    MARKS = STAGE_MARKS

    def __init__(self):
        self.start = now()
        self.ends = {}

    def __call__(self, fraction, message=""):
        stage = self.MARKS.get(message)
        if stage and stage not in self.ends:
            self.ends[stage] = now() - self.start

    def durations(self):
        out, last = {}, 0.0
        for stage in self.MARKS.values():
            end = self.ends.get(stage)
            out[stage] = None if end is None else end - last
            last = end if end is not None else last
        return out


class Context:
    def __init__(self, args):
        self.quick = args.quick
        self.rounds = args.rounds
        self.results = {}
        self.assignments = {}  # label -> Assignment (for the solver part)
        self.paper_db = None
        self.peers = os.environ.get("FLUIDNB_PEERS_PYTHON")

    def starter(self, kind):
        from fluidnb.videodb import starter_database

        return starter_database(kind, quick=self.quick)


# ------------------------------------------------------------------------ targets


def stream_target(shape=None):
    """The "stream" photo (optionally resized to (H, W)) and its hand-drawn water matte."""
    from fluidnb.data import region, sample

    return sample("stream", size=shape, mode="rgb"), region("stream", size=shape)


def clouds_target():
    """The "clouds" photo and its hand-drawn cloud matte."""
    from fluidnb.data import region, sample

    return sample("clouds", mode="rgb"), region("clouds")


def fire_target():
    from fluidnb.data import sample

    img, alpha = sample("fire", mode="rgb", return_alpha=True)
    return img, alpha


PHOTOS = {
    "water": ("stream + its drawn water region", stream_target),
    "smoke": ("clouds + its drawn cloud region", clouds_target),
    "fire": ("fire + its alpha", fire_target),
}


# ------------------------------------------------------------------ 1. starter


#: starter_database's progress messages that end its stages (the clips are made and
#: stored while the first ones are already cut into fragments: "clips read" is when
#: the last clip is stored).
STARTER_MARKS = ("clips read", "fragments done", "codebook ready", "database ready")


def _same_database(a, b):
    """Same codebook and, clip for clip, the same arrays (the manifest's checksums)."""
    from fluidnb.videodb.database._folder import read_manifest

    ma, mb = read_manifest(a)[0], read_manifest(b)[0]
    return ma["codebook"] == mb["codebook"] and [c["checksum"] for c in ma["clips"]] == [
        c["checksum"] for c in mb["clips"]
    ]


def part_starter(ctx):
    from fluidnb.videodb import starter_database, starter_path

    print(
        "\n## Starter databases built from scratch (starter_database in an empty cache: "
        "clips made, stored, cut into fragments, codebook, words)"
    )
    rows, out, total = [], [], 0.0
    tmp = Path(tempfile.mkdtemp(prefix="bench-videodb-build-"))
    saved = os.environ.get("FLUIDNB_CACHE_DIR")
    # The run's own cache, if any, for each kind: found before the loop points the cache
    # at an empty folder per kind (read inside it, the second and third kinds' were
    # looked for in the first kind's empty folder).
    cache = {kind: starter_path(kind, quick=ctx.quick) for kind in KINDS}
    try:
        for kind in KINDS:
            cached = cache[kind]
            os.environ["FLUIDNB_CACHE_DIR"] = str(tmp / kind)
            ends = {}
            load0 = load()
            t0, c0 = now(), time.process_time()

            def clock(fraction, message="", ends=ends, t0=t0):
                if message in STARTER_MARKS and message not in ends:
                    ends[message] = now() - t0

            db = starter_database(kind, quick=ctx.quick, progress=clock)
            seconds, cpu = now() - t0, time.process_time() - c0
            same = _same_database(db.path, cached) if (cached / "manifest.json").is_file() else None
            total += seconds
            marks = [ends.get(m) for m in STARTER_MARKS]
            rec = {
                "kind": kind,
                "clips": len(db.clips),
                "fragments": db.n_fragments,
                "total_s": seconds,
                "cpu_s": cpu,
                "marks_s": dict(zip(STARTER_MARKS, marks)),
                "same_as_cached": same,
                "load": (load0, load()),
            }
            out.append(rec)
            rows.append(
                [
                    kind,
                    len(db.clips),
                    f"{db.n_fragments:,}",
                    *(fmt_s(m) for m in marks),
                    f"**{fmt_s(seconds)}**",
                    fmt_s(cpu),
                    "-" if same is None else ("yes" if same else "NO"),
                    f"{load0:.1f} -> {load():.1f}",
                ]
            )
            del db
            shutil.rmtree(tmp / kind, ignore_errors=True)
            print(f"  {kind}: {rec['fragments']} fragments in {seconds:.1f} s", flush=True)
    finally:
        if saved is None:
            os.environ.pop("FLUIDNB_CACHE_DIR", None)
        else:
            os.environ["FLUIDNB_CACHE_DIR"] = saved
        shutil.rmtree(tmp, ignore_errors=True)
    table(
        [
            "kind",
            "clips",
            "fragments",
            "all clips made and stored",
            "fragments done (flow, features, SIFT)",
            "codebook",
            "words + manifest",
            "total (opened)",
            "CPU time",
            "same database as the cache's",
            "load avg",
        ],
        rows,
    )
    goal = 15.0  # issue 25: each under 15 s on 2 cores (the spec's bound: 2 minutes)
    slowest = max(r["total_s"] for r in out)
    print(
        f"\nslowest: {slowest:.1f} s (goal: each < {goal:.0f} s: "
        f"{'met' if slowest < goal else 'NOT met'}, {slowest / goal:.2f}x the goal; the "
        f"spec's 2 minutes: {'met' if slowest < 120 else 'NOT met'}); all three one after "
        f"the other: {total:.0f} s. Times are from the start (the stages overlap: a clip "
        "is cut into fragments as soon as it is made)."
    )
    ctx.results["starter"] = {"kinds": out, "total_s": total}


# -------------------------------------------------------------- 2. throughput


def part_throughput(ctx):
    from fluidnb.videodb import build_database, starter_params
    from fluidnb.videodb.database import optical_flow
    from fluidnb.videodb.database._features import grey
    from fluidnb.videodb.starter import starter_clips

    print("\n## Build throughput per flow backend (first two starter water clips)")
    clips = starter_clips("water", quick=ctx.quick, seed=0)[:2]
    shape = clips[0][1].frames.shape
    n = starter_params().N
    window = grey(np.asarray(clips[0][1].frames[:n]))
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


# ------------------------------------------------------------------- 3. store


def paper_store(ctx):
    """Open (making it first if needed) the synthetic paper-sized store."""
    from _videodb_store import synthetic_store

    from fluidnb._cache import cache_dir
    from fluidnb.videodb import open_database

    n = QUICK_FRAGMENTS if ctx.quick else PAPER_FRAGMENTS
    path = cache_dir() / "videodb" / f"bench-synthetic-{n}"
    base = ctx.starter("water")
    made = synthetic_store(base, path, n, seed=0, log=lambda s: print(s, flush=True))
    return path, base, made, open_database


def part_store(ctx):
    import zarr
    from _videodb_store import disk_usage

    from fluidnb.videodb.assignment._retrieval import histogram_index
    from fluidnb.videodb.database._format import RAM_ARRAYS, checksum, clip_group

    print("\n## A paper-sized store (synthesised from the starter water database)")
    load0 = load()
    path, base, made, open_database = paper_store(ctx)
    n = QUICK_FRAGMENTS if ctx.quick else PAPER_FRAGMENTS
    opens = []
    for _ in range(2 if ctx.quick else 3):
        ctx.paper_db = None
        t0 = now()
        ctx.paper_db = open_database(path)
        opens.append(now() - t0)
    db = ctx.paper_db
    ram = sum(getattr(db, k).nbytes for k in RAM_ARRAYS)
    t0 = now()
    for c in db.clips:  # what open_database spends on checking, of its open time
        lo, hi = c["first"], c["first"] + c["fragments"]
        checksum({k: getattr(db, k)[lo:hi] for k in RAM_ARRAYS})
    checksum_s = now() - t0
    t0 = now()
    index = histogram_index(db)
    index_s = now() - t0
    own, through, linked = disk_usage(path)
    per_fragment = (disk_usage(base.path)[0] - _frames_bytes(base.path)) / base.n_fragments

    # 100 random fragments' features: from RAM (fancy indexing) and from the zarr store.
    gen = np.random.default_rng(0)
    firsts = np.array([c["first"] for c in db.clips])
    ram_s, zarr_s = [], []
    group = zarr.open_group(str(path), mode="r", zarr_format=3)

    def from_ram(ids):
        return [getattr(db, k)[ids] for k in RAM_ARRAYS]

    def from_zarr(ids):
        clip = np.searchsorted(firsts, ids, side="right") - 1
        got = {k: [] for k in RAM_ARRAYS}
        for c in np.unique(clip):
            local = ids[clip == c] - firsts[c]
            for k in RAM_ARRAYS:
                arr = group[f"{clip_group(int(c))}/{k}"]
                got[k].append(arr.get_orthogonal_selection((local,)))
        return got

    for r in range(5 if ctx.quick else 10):
        ids = np.sort(gen.choice(db.n_fragments, 100, replace=False))
        for _ in range(5):
            t0 = now()
            from_ram(ids)
            ram_s.append(now() - t0)
        if r < (3 if ctx.quick else 5):
            t0 = now()
            check = from_zarr(ids)
            zarr_s.append(now() - t0)
            assert np.array_equal(np.concatenate(check["words"]), db.words[ids])
    rec = {
        "fragments": db.n_fragments,
        "clips": len(db.clips),
        "synthesised_s": made,
        "disk_own_bytes": own,
        "disk_linked_bytes": linked,
        "disk_if_copied_bytes": own + through,
        "bytes_per_fragment_real": per_fragment,
        "open_s": opens,
        "checksum_s": checksum_s,
        "ram_bytes": ram,
        "index_s": index_s,
        "index_bytes": index.nbytes,
        "gather_ram_s": fastest_median(ram_s),
        "gather_zarr_s": fastest_median(zarr_s),
        "load": (load0, load()),
    }
    print(
        f"store {path}: {db.n_fragments:,} fragments in {len(db.clips)} clip groups "
        f"({'made in ' + fmt_s(made) if made else 'cached'}); load avg {load0:.1f} -> {load():.1f}"
    )
    table(
        ["quantity", "value"],
        [
            ["fragments / clip groups", f"{db.n_fragments:,} / {len(db.clips)}"],
            [
                "on disk (features written; frames and mean images linked)",
                f"{own / 1e9:.2f} GB (+ {linked / 1e6:.0f} MB linked from the starter database)",
            ],
            [
                "a real store of this size (starter's bytes per fragment incl. mean images, "
                "without frames)",
                f"{per_fragment / 1e3:.1f} kB/fragment -> {per_fragment * n / 1e9:.1f} GB",
            ],
            ["open_database (features into RAM; files in the page cache)", fm(opens)],
            ["of which the per-clip SHA-256 checksums (timed apart)", fmt_s(checksum_s)],
            ["features held in RAM", f"{ram / 1e9:.2f} GB"],
            [
                "HistogramIndex built (first retrieval)",
                f"{fmt_s(index_s)}, {index.nbytes / 1e6:.0f} MB",
            ],
            ["100 random fragments' features gathered from RAM", fm(ram_s)],
            ["the same read at random from the zarr store", fm(zarr_s)],
            ["zarr / RAM (medians)", f"{np.median(zarr_s) / np.median(ram_s):.0f}x"],
        ],
    )
    ctx.results["store"] = rec


def _frames_bytes(path):
    return sum(f.stat().st_size for f in Path(path).glob("clips/*/frames/**/*") if f.is_file())


# ------------------------------------------------------------------- 4. paper


def _assign_render(img, matte, db):
    """Assign; render the paper's way with an empty frame cache, and again; the flow way.

    Returns (assignment, the paper's animation, seconds): ``assign``, ``paper`` (the
    first render, every fragment rebuilt), ``paper again`` (the same assignment again:
    its fragments from the cache) and ``flow`` (the flow rendering, the default, also
    with an empty cache).
    """
    from fluidnb.videodb import assign, render

    t0 = now()
    a = assign(img, matte, db)
    secs = {"assign": now() - t0}
    paper = a.params.replace(rendering="paper")
    db.cache.clear()
    t0 = now()
    anim = render(a, paper)
    secs["paper"] = now() - t0
    t0 = now()
    render(a, paper)
    secs["paper again"] = now() - t0
    db.cache.clear()
    t0 = now()
    render(a, a.params.replace(rendering="flow"))
    secs["flow"] = now() - t0
    return a, anim, secs


def rebuild_anatomy(db, ids, margin=12):
    """The render's rebuild of ``ids`` on one thread, piece by piece, with an empty cache.

    What ``fluidnb.videodb.database._frames.rebuild_fragments`` does on each thread: a clip's
    frames read once (decoded from the store's chunks), the luminance of the part of
    each window its fragments read, each fragment re-sampled from it.
    """
    from fluidnb.videodb.database import _frames

    n, side = db.params.N, 48 + 2 * margin
    uniq = np.unique(ids)
    src = db.source[uniq]
    out = {"fragments": len(uniq), "windows": len(np.unique(src[:, [0, 2]], axis=0))}
    out.update(frames=0, read=0.0, grey=0.0, sample=0.0)
    db.cache.clear()
    for clip in np.unique(src[:, 0]):
        mine = src[src[:, 0] == clip]
        starts = np.unique(mine[:, 2])
        wanted = np.unique(starts[:, None] + np.arange(n))
        t0 = now()
        runs = np.split(wanted, np.flatnonzero(np.diff(wanted) != 1) + 1)
        frames = {}
        for run in runs:
            block = _frames._read_frames(db, int(clip), int(run[0]), int(run[-1]) + 1)
            frames.update(zip(run.tolist(), block))
        out["read"] += now() - t0
        out["frames"] += len(wanted)
        shape = next(iter(frames.values())).shape[:2]
        for start in starts:
            rows = mine[mine[:, 2] == start]
            plans = [
                _frames._plan(shape, int(v), int(r) - margin, int(c) - margin, side)
                for _, v, _, r, c in rows
            ]
            box = (
                min(p["top"] for p in plans),
                max(p["bottom"] for p in plans),
                min(p["left"] for p in plans),
                max(p["right"] for p in plans),
            )
            t0 = now()
            part = np.stack([frames[start + t][box[0] : box[1], box[2] : box[3]] for t in range(n)])
            planes = _frames._pixel_major(part, True)
            t1 = now()
            for plan, pre in zip(plans, _frames._prefiltered(planes, box, plans)):
                _frames._sample_planned(planes, box, plan, n, side, True, pre)
            out["grey"] += t1 - t0
            out["sample"] += now() - t1
    return out


def part_paper(ctx):
    from fluidnb.videodb import assign, render
    from fluidnb.videodb.assignment._retrieval import histogram_index

    print("\n## Paper scale: a 640 x 360 target, 100 candidates, the synthetic 240k store")
    load0 = load()
    if ctx.paper_db is None:
        path, _, _, open_database = paper_store(ctx)
        t0 = now()
        ctx.paper_db = open_database(path)
        print(f"opened the store in {fmt_s(now() - t0)}")
    db = ctx.paper_db
    t0 = now()
    _ = histogram_index(db)
    index_s = now() - t0
    # Compile / load every kernel before timing (numba caches them on disk).
    warm_img, warm_matte = stream_target((96, 160))
    render(assign(warm_img, warm_matte, ctx.starter("water")))
    cases = {
        "stream 640x360 + matte": stream_target((360, 640)),
        "stream 640x360, whole frame": (stream_target((360, 640))[0], None),
    }
    runs = {c: [] for c in cases}
    rounds = 1 if ctx.quick else max(2, ctx.rounds // 2)
    for r in range(rounds):
        for c, (img, matte) in cases.items():
            a, anim, secs = _assign_render(img, matte, db)
            runs[c].append((a, anim, secs))
            print(
                f"  round {r + 1} {c}: assign {secs['assign']:.1f} s, render {secs['paper']:.1f} s "
                f"(again, from the cache: {secs['paper again']:.1f} s; the flow rendering "
                f"{secs['flow']:.1f} s); load {load():.1f}",
                flush=True,
            )
    out = {}
    for c, rs in runs.items():
        a = rs[-1][0]
        ctx.assignments[f"paper: {c}"] = a
        stages_a = ["describe", "retrieval", "tables", "solve"]
        stages_r = ["rebuild", "blend", "mean", "match", "composite"]
        rows = []
        for s in stages_a:
            rows.append([f"assign: {s}", fm([x[0].timings[s] for x in rs])])
        rows.append(["**assignment**", fm([x[2]["assign"] for x in rs])])
        for s in stages_r:
            rows.append([f"render: {s}", fm([x[1].timings[s] for x in rs])])
        rows.append(
            ["**rendering**, the paper's (empty frame cache)", fm([x[2]["paper"] for x in rs])]
        )
        total = [x[2]["assign"] + x[2]["paper"] for x in rs]
        rows.append(["**end to end**", fm(total)])
        rows.append(
            ["rendering again (fragments from the cache)", fm([x[2]["paper again"] for x in rs])]
        )
        rows.append(["the flow rendering (empty frame cache)", fm([x[2]["flow"] for x in rs])])
        sol = a.solution
        print(
            f"\n### {c}: {len(a.target)} target fragments, {len(a.edges)} edges, "
            f"{a.candidates.shape[1]} candidates, {db.n_fragments:,} fragments; solve = ICM "
            f"{fmt_s(sol.timings['icm'])} + expansion from argmin "
            f"{fmt_s(sol.timings['expansion_argmin'])} + from ICM "
            f"{fmt_s(sol.timings['expansion_icm'])} ({sol.sweeps} sweeps)"
        )
        table([f"stage (fastest / median of {len(rs)})", "time"], rows)
        best = min(total)
        paper = PAPER_ASSIGN_S + PAPER_RENDER_S
        fast_a, fast_r = min(x[2]["assign"] for x in rs), min(x[2]["paper"] for x in rs)
        print(
            f"end to end {best:.1f} s (median {np.median(total):.1f} s): goal < 4 s (issue 25) "
            f"{_met(best, float(np.median(total)), 4)}, < 60 s (spec) "
            f"{_met(best, float(np.median(total)), 60)}; paper ~{paper / 60:.0f} min -> "
            f"{paper / best:.0f}x faster (assignment {PAPER_ASSIGN_S / fast_a:.0f}x, "
            f"rendering {PAPER_RENDER_S / fast_r:.0f}x)"
        )
        anatomy = rebuild_anatomy(db, a.fragments)
        print(
            "render's rebuild on one thread, piece by piece (empty cache): "
            f"{anatomy['fragments']} fragments from {anatomy['windows']} (clip, window) pairs, "
            f"{anatomy['frames']} frames: reading {fmt_s(anatomy['read'])}, luminance "
            f"{fmt_s(anatomy['grey'])}, resampling {fmt_s(anatomy['sample'])} (the render "
            "runs it on two threads)"
        )
        out[c] = {
            "nodes": len(a.target),
            "edges": len(a.edges),
            "seconds": [x[2] for x in rs],
            "assign_stages": {s: [x[0].timings[s] for x in rs] for s in stages_a},
            "render_stages": {s: [x[1].timings[s] for x in rs] for s in stages_r},
            "solve_parts": sol.timings,
            "sweeps": sol.sweeps,
            "rebuild_anatomy": anatomy,
        }
    opens = ctx.results.get("store", {}).get("open_s")
    if opens:
        first = (
            min(opens)
            + index_s
            + min(min(x[2]["assign"] + x[2]["paper"] for x in rs) for rs in runs.values())
        )
        print(
            f"\nthe first animation after opening the store adds open {fmt_s(min(opens))} + index "
            f"{fmt_s(ctx.results['store']['index_s'])}: ~{first:.0f} s"
        )
    print(f"load avg {load0:.1f} -> {load():.1f}")
    ctx.results["paper"] = out


# ------------------------------------------------------------- 5. interactive


def part_interactive(ctx):
    from fluidnb.videodb import assign, render

    print("\n## Interactive scale: a 320 x 180 target on the starter water database")
    load0 = load()
    db = ctx.starter("water")
    img, matte = stream_target((180, 320))
    render(assign(img, matte, db))  # warm-up: kernels, the database's index
    renders = ("render (empty frame cache)", "render again", "render after the sigma x10 re-solve")
    names = ["assign", "resolve sigma x10", "resolve lambda x10", "resolve rho x10"]
    names += [f"{r}, {how}" for how in ("paper", "flow") for r in renders]
    secs = {k: [] for k in names}
    frames = {}  # frames per clip: the flow rendering's slow motion makes longer clips
    stages = {k: [] for k in ("describe", "retrieval", "tables", "solve")}
    rstages = {k: [] for k in ("rebuild", "blend", "mean", "match", "composite")}
    rounds = 3 if ctx.quick else ctx.rounds
    for _ in range(rounds):
        t0 = now()
        a = assign(img, matte, db)
        secs["assign"].append(now() - t0)
        for k in stages:
            stages[k].append(a.timings[k])
        p = a.params
        solved = {}
        for name, change in (
            ("resolve sigma x10", {"sigma": 10 * p.sigma}),
            ("resolve lambda x10", {"lam": 10 * p.lam}),
            ("resolve rho x10", {"rho": 10 * p.rho}),
        ):
            t0 = now()
            solved[name] = a.resolve(**change)
            secs[name].append(now() - t0)
        for how in ("paper", "flow"):
            q = p.replace(rendering=how)
            db.cache.clear()  # the first render of a database opened afresh
            t0 = now()
            anim = render(a, q)
            secs[f"{renders[0]}, {how}"].append(now() - t0)
            frames[f"{renders[0]}, {how}"] = len(anim.clip)
            if how == "paper":
                for k in rstages:
                    rstages[k].append(anim.timings[k])
            t0 = now()
            again = render(a, q)  # Render pressed again (or after moving only shutter, tau...)
            secs[f"{renders[1]}, {how}"].append(now() - t0)
            t0 = now()
            after = render(solved["resolve sigma x10"], q)  # the app: move sigma, then Render
            secs[f"{renders[2]}, {how}"].append(now() - t0)
            frames[f"{renders[1]}, {how}"] = len(again.clip)
            frames[f"{renders[2]}, {how}"] = len(after.clip)
    ctx.assignments["interactive: stream 320x180 + matte"] = a
    changed = int((solved["resolve sigma x10"].fragments != a.fragments).sum())
    goals = {"assign": 0.3}
    print(
        f"{len(a.target)} target fragments, {len(a.edges)} edges, {db.n_fragments:,} fragments, "
        f"{rounds} interleaved rounds after a warm-up; load avg {load0:.1f} -> {load():.1f}; "
        f"sigma x10 changes {changed} of {len(a.target)} fragments"
    )
    rows = []
    for k in names:
        goal = goals.get(k, 0.25 if k.startswith("render") else 0.05)
        lo, med = fastest_median(secs[k])
        n = frames.get(k)
        each = f"{n} frames: {fmt_s(lo * 24 / n)}" if n else "-"
        rows.append([k, fmt_s(lo), fmt_s(med), each, f"< {goal:g} s", _met(lo, med, goal)])
    table(["case", "fastest", "median", "per 24 frames", "goal (issue 25)", "met"], rows)
    print(
        "goals: issue 25 (assign < 0.3 s, re-solve kept at 30-40 ms, render < 0.25 s); the "
        "spec's (assign < 1 s, re-solve < 0.5 s, render < 3 s)\n"
        "assign stages (fastest / median): "
        + ", ".join(f"{k} {fm(v)}" for k, v in stages.items())
        + "\nthe paper's render stages (empty cache): "
        + ", ".join(f"{k} {fm(v)}" for k, v in rstages.items())
    )
    resolve_app = _resolve_at_app_size(ctx, db, rounds)
    app = _app_render(ctx, rounds)
    ctx.results["interactive"] = {
        "nodes": len(a.target),
        "edges": len(a.edges),
        "seconds": secs,
        "assign_stages": stages,
        "render_stages": rstages,
        "resolve_changed": changed,
        "resolve_app_size": resolve_app,
        "app": app,
        "load": (load0, load()),
    }


def _resolve_at_app_size(ctx, db, rounds):
    """The re-solve while a slider is dragged, at the app's working size.

    The stream photo at 480 px on its longer side (``VideoDBApp``'s size), a matte over
    its lower 55 %: 171 fragments, K = 100, 314 edges. Each round re-solves for five
    sigma values (the drag) with ``Assignment.resolve`` (the tables recombined in one
    compiled pass, ICM and the two compiled expansions) and, interleaved, the plain
    path: Eq. (6)'s three numpy statements, ``reference_icm``, and
    ``reference_alpha_expansion`` from both starts (numpy terms, PyMaxflow's cut, every
    move tried). Both give the same labels. Goal: < 15 ms median on a quiet machine.
    """
    from fluidnb.data import sample
    from fluidnb.videodb import assign
    from fluidnb.videodb.assignment import (
        TEXTURE_SCALE,
        energy,
        reference_alpha_expansion,
        reference_icm,
    )

    img = sample("stream", size=480, mode="rgb")
    h, w = img.shape[:2]
    matte = np.zeros((h, w), np.float32)
    matte[int(0.45 * h) :] = 1
    a = assign(img, matte, db)
    t, sigma0 = a.tables, a.params.sigma

    def plain(sigma):
        p = a.params.replace(sigma=sigma)
        pairwise = t.rest * p.sigma
        pairwise += t.dc
        pairwise += p.rho * TEXTURE_SCALE * t.tex
        base = reference_icm(a.unary, pairwise, a.edges, p.lam)
        runs = [reference_alpha_expansion(a.unary, pairwise, a.edges, p.lam, init=init)
                for init in (None, base.labels)]  # fmt: skip
        return runs[1].labels if runs[1].energy < runs[0].energy else runs[0].labels

    factors = (1.2, 2.0, 5.0, 0.5, 0.2)
    a.resolve(sigma=sigma0)  # warm-up (compiled kernels)
    load0 = load()
    secs = {"compiled": [], "plain": []}
    solvers = {"compiled": lambda sigma: a.resolve(sigma=sigma).labels, "plain": plain}
    for r in range(max(rounds, 3)):
        for f in factors:
            labels = {}
            for case in ("compiled", "plain")[:: 1 if r % 2 else -1]:
                t0 = now()
                labels[case] = solvers[case](sigma0 * f)
                secs[case].append(now() - t0)
            assert np.array_equal(labels["compiled"], labels["plain"]), f
    pw = a.pairwise()
    print(
        f"\n### Re-solve at the app's size: the stream at {w} x {h}, matte over the lower "
        f"55 %, {len(a.target)} fragments, K = {a.candidates.shape[1]}, {len(a.edges)} edges; "
        f"{len(factors)} sigma values x {max(rounds, 3)} rounds, interleaved; load avg "
        f"{load0:.1f} -> {load():.1f}; energy at the defaults "
        f"{energy(a.labels, a.unary, pw, a.edges, a.params.lam):.1f}"
    )
    rows = []
    for case, label in (
        ("compiled", "resolve (compiled: one pass for W, ICM, two expansions side by side)"),
        ("plain", "the plain path (numpy W, reference_icm, reference_alpha_expansion x 2)"),
    ):
        lo, med = fastest_median(secs[case])
        goal = 0.015 if case == "compiled" else None
        met = _met(lo, med, goal) if goal else "-"
        rows.append([label, fmt_s(lo), fmt_s(med), "< 15 ms" if goal else "-", met])
    table(["case", "fastest", "median", "goal", "met"], rows)
    ratio = np.median(secs["plain"]) / np.median(secs["compiled"])
    print(f"the same labels both ways; the compiled re-solve {ratio:.1f}x faster at the median")
    return {"fragments": len(a.target), "edges": len(a.edges), "seconds": secs, "load": load0}


def _app_render(ctx, rounds):
    """The app's Render button, headless, at the app's own working size (as the user sees it).

    ``VideoDBApp`` (widgets) works on the photo at 480 px on its longer side (256 in
    quick mode): the stream photo is 480 x 376 there, four times the pixels of the
    320 x 180 rows above. The matte is the whole photo; the rendering the app's
    default (flow). Timed from pressing Render: to the clip's first frames in the
    player, playing (the app streams the clip as render makes it, ``CHUNK`` frames at
    a time: ``FramePlayer.stream``), and to the whole clip in the player; the worker
    thread's status included, not the browser's drawing. And how many frames a second
    reach the player after the first ones (a 24 fps player must never wait for them).
    """

    from fluidnb.videodb import render
    from fluidnb.widgets import VideoDBApp

    load0 = load()
    app = VideoDBApp("stream", db="water", quick=ctx.quick)
    try:
        h, w = app.photo.shape[:2]
        app.set_matte(np.ones((h, w), np.float32))
        t0 = now()
        app.run(timeout=600)
        run_s = now() - t0
        a = app.assignment
        first = {}
        real = app.player.stream

        def stream(clip, ready):
            real(clip, ready)
            t = now()
            first.setdefault("t", t)  # this render's first frames are in the player
            first.setdefault("ready", ready)
            first["last"], first["done"] = t, ready

        app.player.stream = stream
        app.settle = 1e9  # no render on rest: Render is pressed here
        sigma = a.params.sigma
        cases = {"empty": ([], []), "again": ([], []), "resolved": ([], [])}
        rates = {case: [] for case in cases}  # frames made a second after the first ones
        for _ in range(rounds):
            for case, (firsts, wholes) in cases.items():
                if case == "empty":
                    a.db.cache.clear()
                if case == "resolved":
                    # Only the run's fragments in the cache; sigma x10 re-solved: Render
                    # rebuilds the fragments the new assignment brings.
                    a.db.cache.clear()
                    render(a, stages=False)
                    app.panel.set("sigma", sigma * 10)
                    app.wait_resolve()
                first.clear()
                t0 = now()
                app.render_clip(timeout=600)
                wholes.append(now() - t0)
                firsts.append(first["t"] - t0)
                rates[case].append((first["done"] - first["ready"]) / (first["last"] - first["t"]))
                if case == "resolved":
                    new = set(app.assignment.fragments.tolist()) - set(a.fragments.tolist())
                    app.panel.set("sigma", sigma)
                    app.wait_resolve()
        frames = len(app.result)
        # Issue 25's 0.5 s, then the streaming's own goals: the first frames within
        # 0.2 s (0.35 s when every fragment is read from its clip), and the rest made
        # at 45 a second or more (a 24 fps player never waits, a browser beside it).
        goals = {"empty": 0.35, "again": 0.2, "resolved": 0.2}
        rows = []
        labels = (
            ("empty", "empty frame cache"),
            ("again", "fragments cached"),
            ("resolved", f"after sigma x10: {len(new)} new fragments"),
        )
        for case, label in labels:
            firsts, wholes = cases[case]
            rows += [
                [
                    f"Render -> first frames playing ({label})",
                    *(fmt_s(x) for x in fastest_median(firsts)),
                    f"< {goals[case]:g} s",
                    _met(*fastest_median(firsts), goals[case]),
                ],
                [
                    f"frames made a second after the first ({label})",
                    *(f"{x:.0f}" for x in sorted(rates[case], reverse=True)[:1]),
                    f"{np.median(rates[case]):.0f}",
                    ">= 45",
                    "yes"
                    if np.median(rates[case]) >= 45
                    else ("fastest only" if max(rates[case]) >= 45 else "no"),
                ],
                [
                    f"Render -> all {frames} frames ({label})",
                    *(fmt_s(x) for x in fastest_median(wholes)),
                    "-",
                    "-",
                ],
            ]
        rows.insert(0, ["Run (assign + render + show), first", fmt_s(run_s), "-", "-", "-"])
        print(
            f"\n### The app's Render button (VideoDBApp, headless): the stream at {w} x {h}, "
            f"whole-frame matte, {len(a.target)} fragments, {frames} frames; load avg "
            f"{load0:.1f} -> {load():.1f}"
        )
        table(["case", "fastest", "median", "goal", "met"], rows)
        return {"shape": [h, w], "fragments": len(a.target), "run_s": run_s, "frames": frames,
                "first_frames_s": cases["empty"][0], "render_s": cases["empty"][1],
                "first_frames_again_s": cases["again"][0],
                "first_frames_resolved_s": cases["resolved"][0],
                "render_resolved_s": cases["resolved"][1],
                "render_again_s": cases["again"][1],
                "frames_per_s": rates}  # fmt: skip
    finally:
        app.close()


def _met(lo, med, goal):
    if med < goal:
        return "yes"
    return "fastest only" if lo < goal else "no"


# --------------------------------------------------------------- 5b. rendering


def dis_flow(frames, mask):
    """Mean (dy, dx) of OpenCV DIS (MEDIUM) between consecutive frames, over ``mask``."""
    import cv2

    from fluidnb import to_uint8

    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    grey = [cv2.cvtColor(to_uint8(f), cv2.COLOR_RGB2GRAY) for f in frames]
    flows = [dis.calc(a, b, None)[mask][:, ::-1].mean(axis=0) for a, b in zip(grey, grey[1:])]
    return np.mean(flows, axis=0)


def part_rendering(ctx):
    from fluidnb.videodb import assign, render
    from fluidnb.videodb.rendering import sync_share

    print("\n## Renderings: the flow rendering (beyond the paper) against the paper's")
    load0 = load()
    db = ctx.starter("water")
    img, matte = stream_target((180, 320))
    h, w = matte.shape
    stroke = np.array([[0.5 * h, 0.05 * w], [0.5 * h, 0.95 * w]])
    fluid = matte > 0.5
    rows, out = [], {}
    rounds = 2 if ctx.quick else 5
    for painted in (2.0, 0.5):
        speed = np.where(fluid, painted, 0.0).astype(np.float32)
        a = assign(img, matte, db, direction=[stroke], speed=speed)
        params = {r: a.params.replace(rendering=r) for r in ("paper", "flow")}
        anims, secs, stages = {}, {r: [] for r in params}, {r: {} for r in params}
        for p in params.values():
            render(a, p)  # warm-up
        for _ in range(rounds):
            for r, p in params.items():
                t0 = now()
                anims[r] = render(a, p)
                secs[r].append(now() - t0)
                for k, v in anims[r].timings.items():
                    if not k.startswith("assign_") and k != "render":
                        stages[r].setdefault(k, []).append(v)
        for r, anim in anims.items():
            flow = dis_flow(anim.clip.frames, fluid)
            mag = float(np.hypot(*flow))
            angle = float(np.degrees(np.arctan2(flow[0], flow[1])))  # the stroke: 0 degrees
            sync = (
                sync_share(a.fragments, a.target.positions),
                sync_share(
                    a.fragments, a.target.positions, anim.stages["offsets"], anim.stages["mirrors"]
                ),
            )
            rows.append(
                [
                    f"{painted:g} px/frame",
                    r,
                    f"{mag:.2f} ({mag / painted:.2f}x)",
                    f"{angle:+.0f}",
                    f"{sync[0]:.2f} -> {sync[1]:.2f}",
                    str(len(anim.clip)),
                    fm(secs[r]),
                    ", ".join(f"{k} {fm(v)}" for k, v in stages[r].items()),
                ]
            )
            out[f"{painted}:{r}"] = {
                "flow": flow,
                "ratio": mag / painted,
                "angle": angle,
                "sync": sync,
                "frames": len(anim.clip),
                "seconds": secs[r],
                "stages": stages[r],
            }
    print(
        f"stream 320 x 180 + its matte, a stroke left to right, {rounds} interleaved rounds "
        f"after a warm-up; load avg {load0:.1f} -> {load():.1f}"
    )
    table(
        ["painted", "rendering", "measured", "angle", "in sync", "frames", "render", "stages"],
        rows,
    )
    ctx.results["rendering"] = out


# ------------------------------------------------------------------ 6. solver


def _findings_assignments(ctx):
    from fluidnb.videodb import assign

    for kind in KINDS:
        label = f"findings: {kind} ({PHOTOS[kind][0]})"
        if label not in ctx.assignments:
            img, matte = PHOTOS[kind][1]()
            ctx.assignments[label] = assign(img, matte, ctx.starter(kind))
    return {k: v for k, v in ctx.assignments.items() if k.startswith("findings")}


def metric_problem(a, labels, kind):
    """A metric MRF with labels shared by all nodes, from an assignment's unary terms.

    The labels are bins of the candidates' mean motion: ``labels`` direction bins
    (``kind`` "potts" or "linear": a truncated circular distance), or direction x 4
    speed bins ("linear2": truncated L1 on the direction circle x the speed line). A
    node's cost for a label is its best candidate's ``1 - I`` within the bin (1 if
    none), times 1000, rounded (gco takes integers). Returns int32 unary (P, L) and
    pairwise (L, L).
    """
    mm = a.db.mean_motion[a.candidates].astype(np.float64)  # (P, K, 2) (dy, dx)
    ang = np.arctan2(mm[..., 0], mm[..., 1])
    n_dir = labels if kind != "linear2" else labels // 4
    d = np.floor((ang + np.pi) / (2 * np.pi) * n_dir).astype(int) % n_dir
    if kind == "linear2":
        speed = np.linalg.norm(mm, axis=-1)
        s = np.clip(np.floor(np.log2(np.maximum(speed, 1e-9) / 0.5)).astype(int), 0, 3)
        d = d * 4 + s
    unary = np.full((len(a.unary), labels), 1.0)
    for p in range(len(unary)):
        np.minimum.at(unary[p], d[p], a.unary[p])
    u = np.rint(1000 * unary).astype(np.int32)
    i, j = np.meshgrid(np.arange(labels), np.arange(labels), indexing="ij")
    if kind == "potts":
        pair = 60 * (i != j)
    elif kind == "linear":
        circ = np.minimum(np.abs(i - j), labels - np.abs(i - j))
        pair = 25 * np.minimum(circ, 4)
    else:
        di, dj, si, sj = i // 4, j // 4, i % 4, j % 4
        circ = np.minimum(np.abs(di - dj), n_dir - np.abs(di - dj))
        pair = 25 * np.minimum(circ + np.abs(si - sj), 5)
    return u, pair.astype(np.int32)


def part_solver(ctx):
    import maxflow

    from fluidnb.videodb import assign
    from fluidnb.videodb.assignment import alpha_expansion, energy, grid_edges, icm

    print("\n## Solver quality: alpha-expansion (solve) against ICM on the real assignments")
    load0 = load()
    if not any(k.startswith("interactive") for k in ctx.assignments):
        img, matte = stream_target((180, 320))
        ctx.assignments["interactive: stream 320x180 + matte"] = assign(
            img, matte, ctx.starter("water")
        )
    _findings_assignments(ctx)
    rows, out = [], []
    for label, a in ctx.assignments.items():
        w = a.pairwise()
        lam = a.params.lam
        start = np.argmin(a.unary, axis=1)
        e_start = energy(start, a.unary, w, a.edges, lam)
        run_icm = icm(a.unary, w, a.edges, lam)
        run_a = alpha_expansion(a.unary, w, a.edges, lam)
        run_b = alpha_expansion(a.unary, w, a.edges, lam, init=run_icm.labels)
        best = min(run_a.energy, run_b.energy)
        assert abs(best - a.solution.energy) <= 1e-9 * max(1.0, abs(best))
        rec = {
            "case": label,
            "nodes": len(a.unary),
            "edges": len(a.edges),
            "argmin": e_start,
            "icm": run_icm.energy,
            "expansion_argmin": run_a.energy,
            "expansion_icm": run_b.energy,
            "nonsubmodular": (run_a.nonsubmodular, run_b.nonsubmodular),
            "sweeps": (run_a.sweeps, run_b.sweeps),
            "seconds": (run_icm.seconds, run_a.seconds, run_b.seconds),
        }
        out.append(rec)
        rows.append(
            [
                label,
                f"{len(a.unary)} / {len(a.edges)}",
                f"{e_start:.4f}",
                f"{run_icm.energy:.4f}",
                f"{run_a.energy:.4f}",
                f"{run_b.energy:.4f}",
                f"{100 * (best - run_icm.energy) / run_icm.energy:+.2f} %",
                f"{run_a.nonsubmodular:.0%} / {run_b.nonsubmodular:.0%}",
                f"{run_a.sweeps} / {run_b.sweeps}",
                f"{fmt_s(run_icm.seconds)} / {fmt_s(run_a.seconds)} / {fmt_s(run_b.seconds)}",
            ]
        )
    table(
        [
            "assignment",
            "nodes / edges",
            "E argmin",
            "E ICM",
            "E expansion from argmin",
            "E expansion from ICM",
            "solve vs ICM",
            "non-submodular (from argmin / ICM)",
            "sweeps",
            "time ICM / exp. argmin / exp. ICM",
        ],
        rows,
    )
    print(
        "K = 100 labels per node (its own candidates), lambda = 0.01, sigma = 100, rho = 1e4; "
        f"load avg {load0:.1f} -> {load():.1f}"
    )

    # -- a metric sub-case with shared labels, side by side with gco and PyMaxflow
    print(
        "\n### Metric sub-case (labels shared by all nodes), fluidnb vs gco-wrapper vs "
        "PyMaxflow fastmin"
    )
    img, _ = stream_target((180, 320))
    targets = {"320x180 whole frame, starter water": assign(img, None, ctx.starter("water"))}
    if ctx.paper_db is not None:
        big, _ = stream_target((360, 640))
        targets["640x360 whole frame, 240k store"] = assign(big, None, ctx.paper_db)
    problems = []
    for tname, a in targets.items():
        rows_, cols_ = a.target.active.shape
        assert a.target.active.all()
        _, edges, _ = grid_edges(a.target.active)
        for kind, labels in (("potts", 16), ("linear", 16), ("linear2", 64)):
            u, pair = metric_problem(a, labels, kind)
            problems.append(
                {
                    "name": f"{tname}: {labels} labels, {kind}",
                    "u": u,
                    "pair": pair,
                    "shape": (rows_, cols_),
                    "edges": edges,
                }
            )
    rounds = 3 if ctx.quick else 5
    ours = {p["name"]: [] for p in problems}
    pmf = {p["name"]: [] for p in problems}
    peer = {p["name"]: [] for p in problems}
    results, peer_error, peer_version = {}, None, None
    for _ in range(rounds):
        for p in problems:
            u = p["u"].astype(np.float64)
            w = np.broadcast_to(p["pair"].astype(np.float64), (len(p["edges"]), *p["pair"].shape))
            t0 = now()
            run = alpha_expansion(u, w, p["edges"], 1.0)
            ours[p["name"]].append(now() - t0)
            h, wd = p["shape"]
            t0 = now()
            lab_pmf = maxflow.fastmin.aexpansion_grid(
                p["u"].reshape(h, wd, -1).astype(np.float64), p["pair"].astype(np.float64)
            )
            pmf[p["name"]].append(now() - t0)
            results[p["name"]] = {
                "fluidnb": run.energy,
                "icm": icm(u, w, p["edges"], 1.0).energy,
                "argmin": energy(np.argmin(u, 1), u, w, p["edges"], 1.0),
                "pymaxflow": energy(lab_pmf.reshape(-1), u, w, p["edges"], 1.0),
            }
        if ctx.peers and peer_error is None:
            got, peer_error = run_gco(ctx.peers, problems)
            if got is not None:
                peer_version = got["version"]
                for p, g in zip(problems, got["results"]):
                    peer[p["name"]].append(g["seconds"])
                    u = p["u"].astype(np.float64)
                    w = np.broadcast_to(
                        p["pair"].astype(np.float64), (len(p["edges"]), *p["pair"].shape)
                    )
                    results[p["name"]]["gco"] = energy(
                        np.asarray(g["labels"]), u, w, p["edges"], 1.0
                    )
    rows = []
    for p in problems:
        r = results[p["name"]]
        gco_e = r.get("gco")
        rows.append(
            [
                p["name"],
                f"{r['argmin']:.0f}",
                f"{r['icm']:.0f}",
                f"{r['fluidnb']:.0f}",
                f"{gco_e:.0f}" if gco_e is not None else "-",
                f"{r['pymaxflow']:.0f}",
                fm(ours[p["name"]]),
                fm(peer[p["name"]]) if peer[p["name"]] else "-",
                fm(pmf[p["name"]]),
                f"{np.median(peer[p['name']]) / np.median(ours[p['name']]):.2f}x"
                if peer[p["name"]]
                else "-",
            ]
        )
    table(
        [
            "problem",
            "E argmin",
            "E ICM",
            "E fluidnb alpha_expansion",
            "E gco expansion",
            "E PyMaxflow aexpansion_grid",
            "time fluidnb (fastest / median)",
            "time gco",
            "time PyMaxflow",
            "gco / fluidnb (medians)",
        ],
        rows,
    )
    if not ctx.peers:
        print(
            "gco not run: install gco-wrapper in its own environment and point "
            "FLUIDNB_PEERS_PYTHON at it:\n    python3 -m venv /tmp/peers && "
            "/tmp/peers/bin/pip install gco-wrapper numpy"
        )
    elif peer_error:
        print(f"gco failed: {peer_error}")
    else:
        print(f"gco-wrapper {peer_version}, in {ctx.peers}")
    print(
        "Energies are Eq. (4) with lambda = 1 on the integer problem (unary = 1000 (1 - I) of "
        "the best candidate in the bin, 1000 if none; Potts 60 [l != m]; truncated linear "
        "25 min(d, 4) on 16 direction bins; 64 labels = 16 directions x 4 speed octaves, "
        "25 min(d_dir + d_speed, 5)). Times exclude process start-up and problem transfer."
    )
    ctx.results["solver"] = {
        "real": out,
        "metric": [
            {
                "problem": p["name"],
                "energies": results[p["name"]],
                "fluidnb_s": ours[p["name"]],
                "gco_s": peer[p["name"]],
                "pymaxflow_s": pmf[p["name"]],
            }
            for p in problems
        ],
        "gco_version": peer_version,
    }


def run_gco(exe, problems):
    """Run gco-wrapper on the problems in the peers' interpreter; (result, error)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "problems.npz")
        arrays = {"count": len(problems)}
        for i, p in enumerate(problems):
            h, w = p["shape"]
            arrays[f"u{i}"] = p["u"].reshape(h, w, -1)
            arrays[f"p{i}"] = p["pair"]
        np.savez(path, **arrays)
        proc = subprocess.run(
            [exe, os.path.abspath(__file__), "--peer", path],
            capture_output=True,
            text=True,
            check=False,
        )
    if proc.returncode:
        return None, (proc.stderr.strip().splitlines() or ["?"])[-1]
    return json.loads(proc.stdout.strip().splitlines()[-1]), None


def peer_main(path):
    """In the peers' interpreter: gco-wrapper's expansion on every saved problem."""
    import importlib.metadata as md

    import gco

    z = np.load(path)
    out = []
    for i in range(int(z["count"])):
        u, pair = z[f"u{i}"].astype(np.int32), z[f"p{i}"].astype(np.int32)
        t0 = time.perf_counter()
        labels = gco.cut_grid_graph_simple(u, pair, n_iter=-1, connect=4, algorithm="expansion")
        secs = time.perf_counter() - t0
        out.append({"seconds": secs, "labels": np.asarray(labels).reshape(-1).tolist()})
    print(json.dumps({"version": md.version("gco-wrapper"), "results": out}))


# ---------------------------------------------------------------- 7. findings


def coherence(a, assignment_fragments=None):
    """Mean cosine and mean angle (degrees) between MRF neighbours' assigned mean motions."""
    ids = a.fragments if assignment_fragments is None else assignment_fragments
    mm = a.db.mean_motion[ids].astype(np.float64)
    u = mm / np.maximum(np.linalg.norm(mm, axis=1, keepdims=True), 1e-12)
    cos = np.clip((u[a.edges[:, 0]] * u[a.edges[:, 1]]).sum(1), -1, 1)
    return float(cos.mean()), float(np.degrees(np.arccos(cos)).mean())


def part_findings(ctx):
    from fluidnb.videodb.assignment import TEXTURE_SCALE

    print("\n## The paper's findings (section 7): lambda, sigma, rho a decade either side")
    load0 = load()
    assignments = _findings_assignments(ctx)
    settings = [
        (DEFAULTS, {}),
        ("lambda 0 (each fragment's best candidate)", {"lam": 0.0}),
        ("lambda 0.001", {"lam": 0.001}),
        ("lambda 0.1", {"lam": 0.1}),
        ("sigma 10", {"sigma": 10.0}),
        ("sigma 1000", {"sigma": 1000.0}),
        ("sigma 10000", {"sigma": 10000.0}),
        ("rho 1000", {"rho": 1e3}),
        ("rho 100000", {"rho": 1e5}),
        ("paper's other: sigma 1000, rho 100000", {"sigma": 1000.0, "rho": 1e5}),
    ]
    out = {}
    summary = []
    for kind, (label, a) in zip(KINDS, assignments.items()):
        t = a.tables
        dc, rest, tex = (float(np.median(x)) for x in (t.dc, t.rest, t.tex * TEXTURE_SCALE))
        gen = np.random.default_rng(0)
        rows_p = np.arange(len(a.candidates))
        rand = [
            coherence(a, a.candidates[rows_p, gen.integers(0, a.candidates.shape[1], len(rows_p))])
            for _ in range(20)
        ]
        sigma_eq, rho_eq = dc / max(rest, 1e-300), dc / max(tex, 1e-300)
        print(
            f"\n### {kind}: {label.split('(')[1][:-1]}, {len(a.target)} target fragments, "
            f"{len(a.edges)} edges, starter {kind} database ({a.db.n_fragments:,} fragments)\n"
            f"medians over the candidate pairs of every edge: DC term {dc:.3g}, other "
            f"frequencies {rest:.3g} (x sigma; equal to DC at sigma ~{sigma_eq:.3g}), "
            f"textureness x 1e-5 {tex:.3g} (x rho; equal to DC at rho ~{rho_eq:.3g})"
        )
        base = a.fragments
        rows, recs = [], []
        for name, change in settings:
            b = a.resolve(**change) if change else a
            cos, ang = coherence(b)
            changed = float(np.mean(b.fragments != base))
            recs.append(
                {"setting": name, "change": change, "changed": changed, "cos": cos, "angle": ang}
            )
            rows.append(
                [name, f"{changed:.0%}", f"{cos:.3f}", f"{ang:.1f}", f"{b.solution.energy:.4f}"]
            )
        rows.append(
            [
                "(random candidate per fragment, 20 draws)",
                "-",
                f"{np.mean([r[0] for r in rand]):.3f}",
                f"{np.mean([r[1] for r in rand]):.1f}",
                "-",
            ]
        )
        table(
            [
                "setting",
                "fragments changed vs defaults",
                "coherence (mean cos between neighbours)",
                "mean angle (deg)",
                "energy",
            ],
            rows,
        )
        by = {r["setting"]: r for r in recs}

        def span(*names, by=by):
            return max(by[n]["changed"] for n in names)

        summary.append(
            [
                kind,
                f"{span('lambda 0.001', 'lambda 0.1'):.0%}",
                f"{span('sigma 10', 'sigma 1000'):.0%}",
                f"{span('rho 1000', 'rho 100000'):.0%}",
                " / ".join(f"{by[n]['cos']:.2f}" for n in ("sigma 10", DEFAULTS, "sigma 1000")),
                f"{by['sigma 10000']['changed']:.0%}, {by['sigma 10000']['cos']:.2f}",
                " / ".join(f"{by[n]['cos']:.2f}" for n in ("rho 1000", DEFAULTS, "rho 100000")),
                f"{np.mean([r[0] for r in rand]):.2f}",
                f"{sigma_eq:.3g} / {rho_eq:.3g}",
            ]
        )
        out[kind] = {
            "label": label,
            "nodes": len(a.target),
            "edges": len(a.edges),
            "median_dc": dc,
            "median_rest": rest,
            "median_tex_scaled": tex,
            "settings": recs,
            "random_cos": float(np.mean([r[0] for r in rand])),
        }
    print("\n### Summary: largest fraction changed by a decade either side, and coherence")
    table(
        [
            "database",
            "lambda x0.1 / x10",
            "sigma x0.1 / x10",
            "rho x0.1 / x10",
            "coherence at sigma 10 / 100 / 1000",
            "sigma 10^4: changed, coherence",
            "coherence at rho 10^3 / 10^4 / 10^5",
            "coherence of random candidates",
            "sigma / rho where the term's median equals DC's",
        ],
        summary,
    )
    print(f"load avg {load0:.1f} -> {load():.1f}")
    ctx.results["findings"] = out


# --------------------------------------------------------------------------- main


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
        return peer_main(args.peer)
    chosen = set(args.part or ["all"])
    if "all" in chosen:
        chosen = set(PARTS)
    if "build" in chosen:
        chosen |= {"starter", "throughput"}
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from fluidnb._cache import cache_dir

    ctx = Context(args)
    print(
        f"# bench_videodb.py -- {machine()}; {time.strftime('%Y-%m-%d %H:%M')}; cache "
        f"{cache_dir()}; {'quick' if args.quick else 'full'}; load avg {load():.1f}"
    )
    started = now()
    for name in PARTS:
        if name in chosen:
            globals()[f"part_{name}"](ctx)
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
