"""``bench_videodb.py --part interactive``: a photo assigned, re-solved, rendered as one waits.

On the starter water database, a 320 x 180 target assigned (goal < 1 s; issue 25:
< 0.3 s), re-solved after a sigma, lambda or rho change (goal < 0.5 s; kept at 30-40
ms), rendered (goal < 3 s; issue 25: < 0.25 s), rounds interleaved, fastest and
median; then the re-solve at the app's size (compiled against the plain path) and the
app's Render button, headless (to its first frames playing and to the whole clip).
"""

from __future__ import annotations

import numpy as np
from _report import fastest_median, fm, fmt_s, load, met, now, table

from videodb._common import stream_target


def run(ctx):
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
        rows.append([k, fmt_s(lo), fmt_s(med), each, f"< {goal:g} s", met(lo, med, goal)])
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
        ok = met(lo, med, goal) if goal else "-"
        rows.append([label, fmt_s(lo), fmt_s(med), "< 15 ms" if goal else "-", ok])
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
                    met(*fastest_median(firsts), goals[case]),
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
