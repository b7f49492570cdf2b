"""``bench_videodb.py --part rendering``: the flow rendering (beyond the paper) against the paper's.

On the starter water database with the stream at 320 x 180, a stroke left to right
and a painted speed of 2 and 0.5 px/frame: the output's motion (the library's optical
flow, OpenCV DIS, between consecutive frames, mean over the matte:
:func:`videodb._common.output_motion`) against the painted speed and the stroke's
direction, the share of neighbouring target fragments that play the same fragment in
sync before and after the temporal offsets, and the time of each rendering's stages
(rounds interleaved); goal (issue 24): 0.65-1.35x the painted speed, within 20
degrees, a 24-frame render under 0.25 s.
"""

from __future__ import annotations

import numpy as np
from _report import fm, load, now, table

from videodb._common import output_motion, stream_target


def run(ctx):
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
            flow = output_motion(anim.clip.frames, fluid)
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
