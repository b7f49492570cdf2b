"""The Stable Fluids solver (fluidnb.fluid), timed side by side with jax-cfd and PhiFlow.

    python benchmarks/bench_fluid.py                      # fluidnb only
    FLUIDNB_PEERS_PYTHON=/tmp/peers-fluid/bin/python python benchmarks/bench_fluid.py
    ... bench_fluid.py --rounds 3 --quick                 # a short check

The paper (Furukawa et al. 2013) gives no timing. Goals (spec 03-fire.md, issue #15):
fluidnb's full step -- walls, buoyancy, vorticity confinement, temperature and density --
at most 1x jax-cfd's periodic step at 128 x 128 and 128 x 192; and the projection alone
against the sparse LU and against one 2-D FFT of the same size (the limit of any
transform-based solve).

Peers (installed in their own environment, never in fluidnb's)::

    python3 -m venv /tmp/peers-fluid && /tmp/peers-fluid/bin/pip install jax-cfd phiflow

- jax-cfd 0.2.1, jitted on the CPU, 64-bit: ``semi_implicit_navier_stokes`` with van
  Leer advection and its FFT pressure solve. Periodic box only (this version has no
  walls), no scalars, no forces: a lighter step than fluidnb's.
- PhiFlow 3.4 (numpy backend, 64-bit; at 32 bit its pressure solve does not converge):
  the textbook closed-box smoke plume -- staggered velocity, semi-Lagrangian advection
  of velocity and smoke, buoyancy, ``fluid.make_incompressible`` with CG to 1e-5,
  warm-started, ``rank_deficiency=1``. No confinement, no temperature.

Timing: every case runs once per round and the rounds go round-robin over all cases,
fluidnb's and the peers' (the peers in one long-lived subprocess of their interpreter,
which times its own steps), so a change in the machine's load hits every case alike.
Reported: the fastest round and the median, per step. The kernels are compiled and the
solvers' set-ups built before the first round.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import subprocess
import sys
import time

SHAPES = [(128, 128), (128, 192)]


# --------------------------------------------------------------------------- fluidnb


def fluidnb_cases(steps, quick):
    """(who, shape, label) -> a callable that times its case, returning s per step/call."""
    import numba

    threads = sorted({1, numba.config.NUMBA_NUM_THREADS})
    cases = {}
    for shape in SHAPES:
        cases.update(_shape_cases(shape, steps, quick, threads))
    return cases


def _shape_cases(shape, steps, quick, threads):
    """The cases of one grid shape (a function of its own, so closures bind its locals)."""
    import numba
    import numpy as np
    import scipy.fft

    from fluidnb.fluid import FluidState, flame_preset, project, smoke_preset, step
    from fluidnb.fluid import _kernels as K
    from fluidnb.fluid._forces import _add_forces
    from fluidnb.fluid._grid import _divergence
    from fluidnb.fluid._poisson import _thomas, poisson_solver
    from fluidnb.fluid._solver import _advect_velocity

    cases = {}
    h, w = shape
    presets = [("flame, open top", flame_preset().params)]
    if not quick:
        presets.append(("smoke, closed box", smoke_preset(shape).params))
    for name, params in presets:
        s0 = FluidState.zeros(shape, params)
        g = np.random.default_rng(0)
        for _ in range(60):  # a developed flow, so the advection is not trivial
            s0 = step(s0, params, rng=g)

        for n in threads:

            def run(s0=s0, params=params, n=n):
                numba.set_num_threads(n)
                s, g = s0, np.random.default_rng(1)
                t0 = time.perf_counter()
                for _ in range(steps):
                    s = step(s, params, rng=g)
                return (time.perf_counter() - t0) / steps

            run()
            cases[("fluidnb", shape, f"step: {name}, {n} thread{'s' * (n > 1)}")] = run

    # The projection alone, against the sparse LU and the FFT limit.
    u = np.random.default_rng(2).normal(size=(h, w, 2))
    d = np.random.default_rng(3).normal(size=shape)
    n_max = max(threads)

    def timer(fn, reps=20, n=n_max):
        def run():
            numba.set_num_threads(n)
            fn()
            t0 = time.perf_counter()
            for _ in range(reps):
                fn()
            return (time.perf_counter() - t0) / reps

        return run

    solver = poisson_solver(shape, "open_top", "fast")
    rhs = np.ascontiguousarray(scipy.fft.dct(d, type=2, axis=1, norm="ortho"))
    scratch = rhs.copy()

    def thomas():
        np.copyto(scratch, rhs)  # the solve works in place
        _thomas(scratch, solver.inv, solver.up)

    extra = {
        "projection: fast (DCT + Thomas), whole project()": lambda: project(u),
        "projection: sparse LU, whole project(method='lu')": lambda: project(u, method="lu"),
        "  Poisson solve alone, fast": lambda: solver.solve(d),
        "    DCT along x, forward": lambda: scipy.fft.dct(d, type=2, axis=1, norm="ortho"),
        "    tridiagonal solves (all x-modes)": thomas,
        "limit: one 2-D FFT (scipy.fft.rfft2)": lambda: scipy.fft.rfft2(d),
        "limit: 2-D FFT round trip (rfft2 + irfft2)": lambda: scipy.fft.irfft2(
            scipy.fft.rfft2(d), s=shape
        ),
    }
    # Where a step's time goes (flame parameters, developed flow).
    params = flame_preset().params
    s = FluidState.zeros(shape, params)
    g = np.random.default_rng(0)
    for _ in range(60):
        s = step(s, params, rng=g)
    v = np.array(s.velocity)
    t = np.array(s.temperature)
    dd = np.array(s.density)
    work = np.array(v)
    out_t, out_d, c = np.empty(shape), np.empty(shape), np.empty(v.shape)
    p = solver.solve(_divergence(v))

    def forces():
        np.copyto(work, v)
        _add_forces(work, t, params)

    extra.update(
        {
            "stage: advect velocity": lambda: _advect_velocity(v, 1.0),
            "stage: forces (buoyancy + confinement)": forces,
            "stage: divergence": lambda: K.divergence(v, out_t),
            "stage: subtract gradient": lambda: K.subtract_gradient(work, p, True),
            "stage: advect T and density": lambda: K.advect_scalars(t, dd, v, 1.0, c, out_t, out_d),
        }
    )
    for label, fn in extra.items():
        cases[("fluidnb", shape, label)] = timer(fn)
    return cases


# ----------------------------------------------------------------------------- peers


def _jax_cfd_case(shape, steps):
    import jax
    import jax_cfd.base as cfd

    jax.config.update("jax_enable_x64", True)
    h, w = shape
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
    many = jax.jit(cfd.funcutils.repeated(one, steps=steps))
    t0 = time.perf_counter()
    out = jax.block_until_ready(many(v0))
    compile_s = time.perf_counter() - t0
    if not all(bool(jax.numpy.isfinite(u.data).all()) for u in out):
        raise RuntimeError("jax-cfd went to NaN")

    def run():
        t0 = time.perf_counter()
        jax.block_until_ready(many(v0))
        return (time.perf_counter() - t0) / steps

    return run, f"compile {compile_s:.1f} s"


def _phiflow_case(shape, steps):
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
    h, w = shape
    bounds = Box(x=w, y=h)
    smoke = CenteredGrid(0, extrapolation.ZERO_GRADIENT, x=w, y=h, bounds=bounds)
    velocity = StaggeredGrid(0, extrapolation.ZERO, x=w, y=h, bounds=bounds)
    inflow = 0.2 * resample(Sphere(x=w / 2, y=0.1 * h, radius=0.06 * w), to=smoke, soft=True)
    state = {"v": velocity, "s": smoke, "p": None}

    def one():
        v, s, p = state["v"], state["s"], state["p"]
        s = advect.semi_lagrangian(s, v, 1.0) + inflow
        buoy = resample(s * (0, 0.1), to=v)
        v = advect.semi_lagrangian(v, v, 1.0) + buoy
        solve = Solve("CG", 1e-5, 1e-5, x0=p, rank_deficiency=1)
        v, p = fluid.make_incompressible(v, (), solve)
        state.update(v=v, s=s, p=p)

    for _ in range(10):  # develop the plume (and warm up)
        one()

    def run():
        t0 = time.perf_counter()
        for _ in range(steps):
            one()
        return (time.perf_counter() - t0) / steps

    return run, ""


def peers_server(steps, quick):
    """Run in the peers' interpreter: build the cases, then time one per request line."""
    import importlib.metadata as md
    import warnings

    warnings.simplefilter("ignore")  # PhiFlow's rank-deficiency notice on closed boxes
    cases, notes, errors = {}, {}, []
    for shape in SHAPES:
        builders = [("jax-cfd periodic step (jit, 64-bit)", _jax_cfd_case, steps)]
        if not quick:
            builders.append(("PhiFlow numpy, closed-box smoke plume, CG", _phiflow_case, 1))
        for label, build, n in builders:
            try:
                run, note = build(shape, n)
            except Exception as exc:  # a peer that does not run is reported, not fatal
                errors.append(f"{label} {shape}: {type(exc).__name__}: {exc}")
                continue
            key = f"{label}|{shape[0]}x{shape[1]}"
            cases[key], notes[key] = run, note
    versions = {}
    for pkg in ("jax-cfd", "jax", "phiflow", "phiml"):
        with contextlib.suppress(md.PackageNotFoundError):
            versions[pkg] = md.version(pkg)
    print(
        json.dumps({"cases": list(cases), "notes": notes, "errors": errors, "versions": versions})
    )
    sys.stdout.flush()
    for line in sys.stdin:
        key = line.strip()
        if not key:
            break
        print(json.dumps({"seconds": cases[key]()}))
        sys.stdout.flush()


class _Peers:
    """The long-lived peer process: ask it to time one case, get seconds per step."""

    def __init__(self, exe, steps, quick):
        args = [exe, os.path.abspath(__file__), "--peers-server", "--steps", str(steps)]
        if quick:
            args.append("--quick")
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
        )
        self.info = json.loads(self._line())

    def _line(self):
        while True:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError("the peer process ended")
            if line.startswith("{"):
                return line

    def time(self, key):
        self.proc.stdin.write(key + "\n")
        self.proc.stdin.flush()
        return json.loads(self._line())["seconds"]

    def close(self):
        with contextlib.suppress(OSError):
            self.proc.stdin.write("\n")
            self.proc.stdin.close()
        self.proc.wait(timeout=60)


# ------------------------------------------------------------------------------ main


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="round-robin rounds")
    parser.add_argument("--steps", type=int, default=50, help="steps per timing")
    parser.add_argument("--quick", action="store_true", help="flame and jax-cfd only")
    parser.add_argument("--peers-server", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.peers_server:
        return peers_server(args.steps, args.quick)

    import numba
    import numpy as np

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"# bench_fluid.py -- {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Python {platform.python_version()}, numba "
        f"{numba.__version__} ({numba.config.NUMBA_NUM_THREADS} threads), "
        f"load average {load:.1f} at the start"
    )
    cases = fluidnb_cases(args.steps, args.quick)
    peers = None
    exe = os.environ.get("FLUIDNB_PEERS_PYTHON")
    if exe:
        try:
            peers = _Peers(exe, args.steps, args.quick)
        except Exception as exc:
            print(f"\nThe peer process failed: {exc}")
    if peers is not None:
        for key in peers.info["cases"]:
            label, size = key.split("|")
            shape = tuple(int(x) for x in size.split("x"))
            cases[("peer", shape, label)] = lambda key=key: peers.time(key)
    else:
        print(
            "\nPeers not run: install them in their own environment and point "
            "FLUIDNB_PEERS_PYTHON at its interpreter (see the docstring)."
        )

    secs = {k: [] for k in cases}
    for r in range(args.rounds):
        for k, run in cases.items():
            secs[k].append(run())
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    if peers is not None:
        peers.close()
    load_end = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")

    def ms(k):
        a = np.array(secs[k]) * 1e3
        return a.min(), np.median(a)

    print(
        f"\n{args.rounds} rounds round-robin over every case; ms per step (or per call): "
        f"fastest round / median. Load average {load:.1f} at the start, {load_end:.1f} at "
        f"the end ({os.cpu_count()} cores)."
    )
    if peers is not None:
        print(f"Peers: {peers.info['versions']}")
        for e in peers.info["errors"]:
            print(f"peer error: {e}")
    for shape in SHAPES:
        print(f"\n| {shape[0]} x {shape[1]} | fastest ms | median ms |")
        print("|---|---|---|")
        for k in cases:
            if k[1] == shape:
                lo, med = ms(k)
                note = ""
                if k[0] == "peer" and peers is not None:
                    note = peers.info["notes"].get(f"{k[2]}|{shape[0]}x{shape[1]}", "")
                label = f"{k[2]} ({note})" if note else k[2]
                print(
                    f"| {'fluidnb ' if k[0] == 'fluidnb' else ''}{label} | {lo:.3f} | {med:.3f} |"
                )

    jax = {k[1]: k for k in cases if k[0] == "peer" and k[2].startswith("jax-cfd")}
    if jax:
        print(
            "\n| goal: fluidnb step <= 1x jax-cfd step | grid | fluidnb ms | jax-cfd ms | ratio |"
        )
        print("|---|---|---|---|---|")
        for k in cases:
            if k[0] == "fluidnb" and k[2].startswith("step") and k[1] in jax:
                lo, med = ms(k)
                jlo, jmed = ms(jax[k[1]])
                h, w = k[1]
                print(
                    f"| {k[2]} | {h}x{w} | {lo:.2f} / {med:.2f} | {jlo:.2f} / {jmed:.2f} | "
                    f"{lo / jlo:.2f}x / {med / jmed:.2f}x |"
                )


if __name__ == "__main__":
    main()
