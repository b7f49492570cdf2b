"""The Stable Fluids solver (fluidnb.fluid), timed against real peer solvers.

    python benchmarks/bench_fluid.py
    FLUIDNB_PEERS_PYTHON=/tmp/peers/bin/python python benchmarks/bench_fluid.py

The paper (Furukawa et al. 2013) gives no timing. The spec's goal: steps per second at 128 x 128 (the
paper's grid), side by side with a peer solver installed from PyPI, faster than the
peer. fluidnb runs its flame preset (open top, 128 x 128) and its smoke preset (closed
box, 128 x 192); every step has semi-Lagrangian advection of the velocity and of two
scalars, buoyancy, vorticity confinement, an exact sparse-LU pressure solve (factorised
once per grid shape), cooling and the source. All but the LU solve run in numba kernels
(fluidnb/fluid/_kernels.py), compiled on first use and cached on disk; the timed steps
come after a warm-up, so compilation is not in them. A later goal: within 2x of
jax-cfd's compiled step; the last table gives that ratio.

Peers (installed in a separate environment, never in fluidnb's; the peer part runs in
that interpreter through ``FLUIDNB_PEERS_PYTHON``)::

    python3 -m venv /tmp/peers && /tmp/peers/bin/pip install phiflow jax-cfd

- PhiFlow (``phiflow``), numpy backend, 64-bit (at 32 bit its pressure solve does not
  converge): the textbook closed-box smoke plume -- a staggered velocity, semi-
  Lagrangian advection of velocity and smoke, buoyancy from the smoke,
  ``fluid.make_incompressible`` with its conjugate-gradient solver to 1e-5, warm-
  started from the last pressure, told the closed box's pressure has a one-dimensional
  null space (``rank_deficiency=1``; without it CG diverges at 128 x 128). No vorticity
  confinement, no temperature.
- jax-cfd (``jax-cfd``), jitted on the CPU: ``semi_implicit_navier_stokes`` with van Leer
  advection and its FFT pressure solve. Periodic box only (this version has no walls),
  no scalars, no forces: a lighter step than either of the others; shown for scale.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import subprocess
import sys
import time

SHAPES = [(128, 128), (128, 192)]


def fluidnb_rows(n_steps=100):
    import numpy as np
    from _timing import best  # benchmarks/ is on sys.path when run as a script

    from fluidnb.fluid import FluidState, flame_preset, project, smoke_preset, step
    from fluidnb.fluid._poisson import poisson_solver as _poisson

    rows = []
    for shape in SHAPES:
        for name, preset in (
            ("flame (open top)", flame_preset()),
            ("smoke (closed box)", smoke_preset(shape)),
        ):
            params = preset.params
            # Start from a developed flow so the advection is not trivially short.
            s0 = FluidState.zeros(shape, params)
            g = np.random.default_rng(0)
            for _ in range(40):
                s0 = step(s0, params, rng=g)

            def run(s0=s0, params=params):
                s, g = s0, np.random.default_rng(1)
                for _ in range(n_steps):
                    s = step(s, params, rng=g)

            t = best(run, repeat=5)
            _poisson.cache_clear()
            t0 = time.perf_counter()
            project(np.zeros((*shape, 2)), params.boundary)
            build = time.perf_counter() - t0
            u = np.random.default_rng(2).normal(size=(*shape, 2))
            solve = best(lambda u=u, b=params.boundary: project(u, b), repeat=10)
            rows.append(
                {
                    "solver": f"fluidnb {name}",
                    "shape": shape,
                    "steps_per_s": n_steps / t,
                    "ms_per_step": 1e3 * t / n_steps,
                    "factorise_ms": 1e3 * build,
                    "project_ms": 1e3 * solve,
                }
            )
    return rows


# ----------------------------------------------------------------------------- peers


def phiflow_rows(n_steps=10):
    from phi import math
    from phi.flow import (
        Box,
        CenteredGrid,
        Solve,
        Sphere,
        StaggeredGrid,
        advect,
        extrapolation,
        fluid,
        resample,
    )

    math.set_global_precision(64)
    rows = []
    for h, w in SHAPES:
        bounds = Box(x=w, y=h)
        smoke = CenteredGrid(0, extrapolation.ZERO_GRADIENT, x=w, y=h, bounds=bounds)
        velocity = StaggeredGrid(0, extrapolation.ZERO, x=w, y=h, bounds=bounds)
        inflow = 0.2 * resample(Sphere(x=w / 2, y=0.1 * h, radius=0.06 * w), to=smoke, soft=True)
        state = {"v": velocity, "s": smoke, "p": None}

        def one(state=state, inflow=inflow):
            v, s, p = state["v"], state["s"], state["p"]
            s = advect.semi_lagrangian(s, v, 1.0) + inflow
            buoy = resample(s * (0, 0.1), to=v)
            v = advect.semi_lagrangian(v, v, 1.0) + buoy
            solve = Solve("CG", 1e-5, 1e-5, x0=p, rank_deficiency=1)
            v, p = fluid.make_incompressible(v, (), solve)
            state.update(v=v, s=s, p=p)

        for _ in range(20):  # develop the plume (and warm up)
            one()
        t0 = time.perf_counter()
        for _ in range(n_steps):
            one()
        t = time.perf_counter() - t0
        rows.append(
            {
                "solver": "PhiFlow numpy, closed-box smoke plume",
                "shape": (h, w),
                "steps_per_s": n_steps / t,
                "ms_per_step": 1e3 * t / n_steps,
            }
        )
    return rows


def jax_cfd_rows(n_steps=200):
    import jax
    import jax_cfd.base as cfd

    jax.config.update("jax_enable_x64", True)
    rows = []
    for h, w in SHAPES:
        grid = cfd.grids.Grid((h, w), domain=((0, h), (0, w)))
        dt = 0.5
        v0 = cfd.initial_conditions.filtered_velocity_field(
            jax.random.PRNGKey(0), grid, maximum_velocity=1.0, peak_wavenumber=4
        )

        def convect(v, dt=dt):
            return tuple(cfd.advection.advect_van_leer_using_limiters(u, v, dt) for u in v)

        one = cfd.equations.semi_implicit_navier_stokes(
            density=1.0, viscosity=1e-3, dt=dt, grid=grid, convect=convect
        )
        many = jax.jit(cfd.funcutils.repeated(one, steps=n_steps))
        t0 = time.perf_counter()
        jax.block_until_ready(many(v0))
        compile_s = time.perf_counter() - t0
        t = float("inf")
        for _ in range(3):  # best of 3, as for fluidnb: the machine's load varies
            t0 = time.perf_counter()
            out = jax.block_until_ready(many(v0))
            t = min(t, time.perf_counter() - t0)
        finite = bool(all(jax.numpy.isfinite(u.data).all() for u in out))
        rows.append(
            {
                "solver": "jax-cfd jit, periodic box, no scalars",
                "shape": (h, w),
                "steps_per_s": n_steps / t,
                "ms_per_step": 1e3 * t / n_steps,
                "compile_s": compile_s,
                "finite": finite,
            }
        )
    return rows


def peers_main():
    """Run inside the peers' interpreter; print one JSON list."""
    import warnings

    warnings.simplefilter("ignore")  # PhiFlow's rank-deficiency notice on closed boxes
    rows, errors = [], []
    for fn in (phiflow_rows, jax_cfd_rows):
        try:
            rows += fn()
        except Exception as exc:  # a peer that does not install or run is reported
            errors.append(f"{fn.__name__}: {type(exc).__name__}: {exc}")
    import importlib.metadata as md

    versions = {}
    for pkg in ("phiflow", "phiml", "jax-cfd", "jax"):
        with contextlib.suppress(md.PackageNotFoundError):
            versions[pkg] = md.version(pkg)
    print(json.dumps({"rows": rows, "errors": errors, "versions": versions}))


def main():
    print(
        f"# bench_fluid.py -- {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}"
    )
    ours = fluidnb_rows()
    print("\n| fluidnb | grid | steps/s | ms/step | factorise once | one projection |")
    print("|---|---|---|---|---|---|")
    for r in ours:
        h, w = r["shape"]
        print(
            f"| {r['solver']} | {h}x{w} | {r['steps_per_s']:.0f} | {r['ms_per_step']:.1f} | "
            f"{r['factorise_ms']:.0f} ms | {r['project_ms']:.1f} ms |"
        )
    peers_python = os.environ.get("FLUIDNB_PEERS_PYTHON")
    if not peers_python:
        print(
            "\nPeers not run. To compare with PhiFlow and jax-cfd, install them in a "
            "separate environment and point FLUIDNB_PEERS_PYTHON at its interpreter:\n"
            "    python3 -m venv /tmp/peers && /tmp/peers/bin/pip install phiflow jax-cfd\n"
            "    FLUIDNB_PEERS_PYTHON=/tmp/peers/bin/python python benchmarks/bench_fluid.py"
        )
        return
    proc = subprocess.run(
        [peers_python, os.path.abspath(__file__), "--peers"],
        capture_output=True,
        text=True,
        check=False,
    )
    try:
        result = json.loads(proc.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        print(f"\nThe peer run failed (exit {proc.returncode}):\n{proc.stderr[-2000:]}")
        return
    print(f"\nPeers: {result['versions']}")
    print("\n| peer (same machine, same run) | grid | steps/s | ms/step | fluidnb smoke / peer |")
    print("|---|---|---|---|---|")
    smoke = {tuple(r["shape"]): r for r in ours if "smoke" in r["solver"]}
    for r in result["rows"]:
        h, w = r["shape"]
        ratio = smoke[(h, w)]["steps_per_s"] / r["steps_per_s"]
        extra = f" (compile {r['compile_s']:.1f} s)" if "compile_s" in r else ""
        print(
            f"| {r['solver']}{extra} | {h}x{w} | {r['steps_per_s']:.1f} | "
            f"{r['ms_per_step']:.1f} | {ratio:.2f}x |"
        )
    jax = {tuple(r["shape"]): r for r in result["rows"] if r["solver"].startswith("jax-cfd")}
    if jax:
        print("\n| fluidnb vs jax-cfd (goal: within 2x) | grid | fluidnb ms | jax-cfd ms | ratio |")
        print("|---|---|---|---|---|")
        for r in ours:
            h, w = r["shape"]
            peer = jax[(h, w)]["ms_per_step"]
            print(
                f"| {r['solver']} | {h}x{w} | {r['ms_per_step']:.1f} | {peer:.1f} | "
                f"{r['ms_per_step'] / peer:.2f}x |"
            )
    for e in result["errors"]:
        print(f"\npeer error: {e}")


if __name__ == "__main__":
    if "--peers" in sys.argv:
        peers_main()
    else:
        main()
