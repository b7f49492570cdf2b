"""Frost growth (Reiter's automaton + the paper's random threshold), timed side by side.

    python benchmarks/bench_frost.py

The paper gives no timing (it ran in Houdini). The spec's goals: a 200 x 200 lattice
runs 200 steps in well under a second (goal < 0.2 s here), and the beta optimiser's
several runs finish in a few seconds (goal < 3 s). Peers, in the same run:

- the rule written cell by cell in plain Python (``fluidnb.frost._reference``), on a
  small lattice: the per-cell-update ratio is what vectorising buys;
- the same rule vectorised the way one would first write it with SciPy: an axial
  parallelogram array and ``scipy.ndimage.convolve`` with the hexagonal 3 x 3 kernel
  (timing only: its boundary is simply b = 0 outside the parallelogram).
"""

from __future__ import annotations

import math

import numpy as np
from _report import best, header  # benchmarks/ is on sys.path when run as a script
from scipy import ndimage

from fluidnb import data
from fluidnb.frost import FrostParams, HexLattice, grow, optimise_beta, reference_setup
from fluidnb.frost._reference import grow_reference


def square_lattice(n):
    """About n x n lattice points: n rows of n points at spacing 1 px."""
    region = np.ones((math.ceil(n * math.sqrt(3) / 2), n), bool)
    return HexLattice.from_mask(region, 1.0)


# Hexagonal neighbourhood on an axial array: (q +- 1, r), (q, r - 1), (q + 1, r - 1),
# (q, r + 1), (q - 1, r + 1) -> a 3 x 3 kernel with two opposite corners removed.
_HEX = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], float)


def grow_convolve(n, steps, params):
    """Reiter's step on an n x n axial parallelogram with ndimage.convolve (the peer)."""
    alpha, gamma = params.alpha, params.gamma
    u = np.full((n + 2, n + 2), params.beta)
    inner = np.zeros_like(u, bool)
    inner[1:-1, 1:-1] = True
    u[n // 2 + 1, n // 2 + 1] = 1.0
    for _ in range(steps):
        ice = (u >= 1) & inner
        receptive = (ndimage.convolve(ice.astype(np.uint8), _HEX.astype(np.uint8)) > 0) | ice
        receptive &= inner
        b = np.where(receptive, 0.0, u)
        border = ~inner  # the ring: mean of the region neighbours in the diffusion field
        b[border] = 0.0
        total = ndimage.convolve(b, _HEX, mode="constant")
        b = b + alpha / 12 * (-6 * b + total)
        a = np.where(receptive, u + gamma, 0.0)
        u = np.where(inner, a + b, 0.0)
    return u


def main():
    print(header(__file__, f"numpy {np.__version__}"))
    print()

    # 1. 200 x 200 lattice, 200 steps.
    lat = square_lattice(200)
    seed_cell = [lat.center_cell()]
    print(f"lattice: {lat.n_cells} cells ({lat!r})")
    rows = []
    for rth in (0.0, 0.8):
        p = FrostParams(rth=rth, max_frames=200)
        t = best(lambda p=p: grow(lat, seed_cell, p, frames=200, seed=0))
        rows.append((f"grow 200x200, 200 steps, rth={rth}", t))
    t_conv = best(lambda: grow_convolve(200, 200, FrostParams()), repeat=3)
    print("| case | fluidnb | goal |")
    print("|---|---|---|")
    for name, t in rows:
        print(f"| {name} | {t * 1e3:.0f} ms | < 200 ms |")
    print()
    print("| peer | time | ratio (peer / fluidnb, rth=0) |")
    print("|---|---|---|")
    print(
        f"| scipy.ndimage.convolve on an axial 200x200 array | {t_conv * 1e3:.0f} ms "
        f"| {t_conv / rows[0][1]:.1f}x |"
    )

    # 2. Per-cell Python vs vectorised, per cell update.
    small = HexLattice.hexagon(15)
    steps = 40
    p = FrostParams(rth=0.4, beta=0.4)
    t_ref = best(
        lambda: grow_reference(small, [small.center_cell()], p, frames=steps, seed=0), repeat=2
    )
    t_vec = best(lambda: grow(small, [small.center_cell()], p, frames=steps, seed=0), repeat=7)
    t_big = best(lambda: grow(lat, seed_cell, p.replace(max_frames=200), frames=200, seed=0))
    per = small.n_cells * steps
    per_big = lat.n_cells * 200
    print()
    print("| implementation | lattice | time | per cell update |")
    print("|---|---|---|---|")
    print(
        f"| per-cell Python loop | {small.n_cells} cells x {steps} steps | "
        f"{t_ref * 1e3:.0f} ms | {t_ref / per * 1e9:.0f} ns |"
    )
    print(
        f"| fluidnb (vectorised) | {small.n_cells} cells x {steps} steps | "
        f"{t_vec * 1e3:.1f} ms | {t_vec / per * 1e9:.0f} ns |"
    )
    print(
        f"| fluidnb (vectorised) | {lat.n_cells} cells x 200 steps | "
        f"{t_big * 1e3:.0f} ms | {t_big / per_big * 1e9:.1f} ns |"
    )
    print(
        f"per-cell-update ratio: {t_ref / per / (t_vec / per):.0f}x on the small lattice, "
        f"{t_ref / per / (t_big / per_big):.0f}x at 200 x 200"
    )

    # 3. The optimiser end to end.
    print()
    print("| optimiser | runs | time | result | converged | goal |")
    print("|---|---|---|---|---|---|")
    for rth in (0.0, 0.8):
        lattice, starts, params = reference_setup(rth)
        for method, eta in (("steepest", 1e-6), ("steepest", 3e-6), ("secant", None)):
            kw = {"eta": eta, "h": 0.02} if eta else {}

            def fit(lattice=lattice, starts=starts, params=params, method=method, kw=kw):
                return optimise_beta(lattice, starts, 130, params, method=method, seed=0, **kw)

            res = fit()
            t = best(fit, repeat=3)
            label = method + (f" eta={eta:g}" if eta else "")
            print(
                f"| reference rth={rth} ({lattice.n_cells} cells), {label} | "
                f"{res.evaluations} | {t * 1e3:.0f} ms | beta {res.beta:.4f} -> "
                f"{res.end_frame} | {res.converged} | < 3 s |"
            )
    image = data.sample("leaf")
    h, w = image.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    region = ((yy - h / 2) / (0.4 * h)) ** 2 + ((xx - w / 2) / (0.4 * w)) ** 2 <= 1
    lattice = HexLattice.from_mask(region, 4.0)
    starts = lattice.snap([[h / 2, w / 2]])
    params = FrostParams(target=300, rth=0.4)

    def fit_leaf():
        return optimise_beta(lattice, starts, 300, params, seed=0)

    res = fit_leaf()
    t = best(fit_leaf, repeat=2)
    print(
        f"| leaf photo region ({lattice.n_cells} cells, spacing 4 px), rth=0.4, secant, "
        f"target 300 | {res.evaluations} | {t * 1e3:.0f} ms | beta {res.beta:.4f} -> "
        f"{res.end_frame} | {res.converged} | < 3 s |"
    )


if __name__ == "__main__":
    main()
