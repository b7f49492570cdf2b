"""The paper's findings (Okabe et al., sec. 7) on fluidnb's starter databases: an experiment.

    .venv/bin/python benchmarks/experiments/videodb_findings.py [--quick] [--json OUT]

The paper reports that lambda has little effect on the assignment, sigma a large one
and rho a smaller one. On each starter database (water, smoke, fire) with a photo of
its kind (the stream, the clouds, the fire cut-out, each with its matte), each of
lambda, sigma and rho is moved a decade either side of the paper's values and the
assignment re-solved (:meth:`~fluidnb.videodb.Assignment.resolve`, the tables kept):
the fraction of target fragments whose assignment changes, and the coherence of the
assigned mean motions between neighbours (mean cosine, mean angle), against random
candidates. Also printed: the median of each smoothness term over every edge's
candidate pairs, and the sigma and rho at which the others' medians equal the mean
motion's (DC) term. Nothing is timed; the numbers depend only on the databases (and
``--quick``'s smaller ones).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/

from _report import header, load, table
from videodb._common import DEFAULTS, KINDS, Context, kind_assignments


def coherence(a, assignment_fragments=None):
    """Mean cosine and mean angle (degrees) between MRF neighbours' assigned mean motions."""
    ids = a.fragments if assignment_fragments is None else assignment_fragments
    mm = a.db.mean_motion[ids].astype(np.float64)
    u = mm / np.maximum(np.linalg.norm(mm, axis=1, keepdims=True), 1e-12)
    cos = np.clip((u[a.edges[:, 0]] * u[a.edges[:, 1]]).sum(1), -1, 1)
    return float(cos.mean()), float(np.degrees(np.arccos(cos)).mean())


def findings(ctx):
    from fluidnb.videodb.assignment import TEXTURE_SCALE

    print("\n## The paper's findings (section 7): lambda, sigma, rho a decade either side")
    load0 = load()
    assignments = kind_assignments(ctx)
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the quick starter databases")
    parser.add_argument("--json", help="write the numbers to this JSON file")
    args = parser.parse_args()
    args.rounds = 1
    ctx = Context(args)
    print(header(__file__, "quick" if args.quick else "full"))
    findings(ctx)
    if args.json:
        Path(args.json).write_text(json.dumps(ctx.results, indent=1, default=str))


if __name__ == "__main__":
    main()
