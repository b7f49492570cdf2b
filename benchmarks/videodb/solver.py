"""``bench_videodb.py --part solver``: alpha-expansion against ICM, and beside gco and PyMaxflow.

Alpha-expansion (:func:`~fluidnb.videodb.assignment.solve`'s two runs) against ICM on
the real assignments (the other parts' and each starter database's photo); then a
metric sub-case (labels shared by all nodes: direction / speed bins of the candidates'
mean motion, Potts or truncated L1) side by side with gco-wrapper
(``gco.cut_grid_graph_simple``, run in its own environment through
``FLUIDNB_PEERS_PYTHON``) and PyMaxflow's ``fastmin.aexpansion_grid``. The peer runs
``bench_videodb.py --peer`` in its interpreter: :func:`peer_main` needs numpy and gco
only.
"""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from _report import fm, fmt_s, load, now, table

from videodb._common import kind_assignments, stream_target


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


def run(ctx):
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
    kind_assignments(ctx)
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
            [exe, str(Path(__file__).resolve().parents[1] / "bench_videodb.py"), "--peer", path],
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
