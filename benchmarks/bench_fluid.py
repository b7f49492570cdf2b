"""The Stable Fluids solver (fluidnb.fluid), timed side by side with jax-cfd and PhiFlow.

    python benchmarks/bench_fluid.py                      # fluidnb only
    FLUIDNB_PEERS_PYTHON=/tmp/peers-fluid/bin/python python benchmarks/bench_fluid.py
    ... bench_fluid.py --rounds 3 --quick                 # a short check (flame, jax-cfd)

The paper (Furukawa et al. 2013) gives no timing. Goals (spec 03-fire.md, issues #15,
#25): fluidnb's full step -- walls, buoyancy, vorticity confinement, temperature and
density -- at most 1x jax-cfd's periodic step at 128 x 128 and 128 x 192 with fluidnb's
default thread count, which must never be slower than one thread; and the projection
alone against the sparse LU and against one 2-D FFT of the same size (the limit of any
transform-based solve).

The step is timed three ways: as a user gets it (``step()`` choosing its thread count
by measurement, fluidnb.fluid._threads), and pinned to one and to two threads
(``fluidnb.fluid._threads.fixed``). The passes of a step ("where the time goes") are
timed on one thread.

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
which times its own steps), so a change in the machine's load hits every case alike;
the order rotates from round to round, so that no case always comes first.
Reported: the fastest round and the median, per step, and the load average at the
start, the end and over the rounds. The last table is the one the README quotes. The
kernels are compiled and the solvers' set-ups built before the first round.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import time

from _report import header, load

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


def _developed(shape, params):
    """A developed flow (60 steps from still air), so the advection is not trivial."""
    import numpy as np

    from fluidnb.fluid import FluidState, step

    s = FluidState.zeros(shape, params)
    g = np.random.default_rng(0)
    for _ in range(60):
        s = step(s, params, rng=g)
    return s


def _shape_cases(shape, steps, quick, threads):
    """The cases of one grid shape (a function of its own, so closures bind its locals)."""
    import numba
    import numpy as np
    import scipy.fft

    from fluidnb.fluid import _kernels as K
    from fluidnb.fluid import flame_preset, project, smoke_preset, step
    from fluidnb.fluid._forces import _push
    from fluidnb.fluid._poisson import _thomas, poisson_solver
    from fluidnb.fluid._threads import fixed

    cases = {}
    h, w = shape
    presets = [("flame, open top", flame_preset().params)]
    if not quick:
        presets.append(("smoke, closed box", smoke_preset(shape).params))
    for name, params in presets:
        s0 = _developed(shape, params)
        for n in [None, *threads]:

            def run(s0=s0, params=params, n=n):
                s, g = s0, np.random.default_rng(1)
                with contextlib.nullcontext() if n is None else fixed(n):
                    t0 = time.perf_counter()
                    for _ in range(steps):
                        s = step(s, params, rng=g)
                    return (time.perf_counter() - t0) / steps

            run()
            who = "default threads" if n is None else f"{n} thread{'s' * (n > 1)}"
            cases[("fluidnb", shape, f"step: {name}, {who}")] = run

    # The projection alone, against the sparse LU and the FFT limit.
    u = np.random.default_rng(2).normal(size=(h, w, 2))
    d = np.random.default_rng(3).normal(size=shape)

    def timer(fn, reps=20):
        """Time ``fn`` on one thread (what each pass costs, without the rendezvous)."""

        def run():
            before = numba.get_num_threads()
            numba.set_num_threads(1)
            try:
                fn()
                t0 = time.perf_counter()
                for _ in range(reps):
                    fn()
                return (time.perf_counter() - t0) / reps
            finally:
                numba.set_num_threads(before)

        return run

    solver = poisson_solver(shape, "open_top", "fast")
    spectrum = scipy.fft.rfft(d, axis=1)
    scratch = np.empty_like(spectrum)

    def thomas():
        np.copyto(scratch, spectrum)  # the solve works in place
        _thomas(scratch.view(np.float64), solver.cos, solver.sin, solver.inv_a, solver.up_a,
                solver.inv_b, solver.up_b, False, 1)  # fmt: skip

    extra = {
        "projection: fast (FFT + Thomas), whole project()": lambda: project(u),
        "projection: sparse LU, whole project(method='lu')": lambda: project(u, method="lu"),
        "  Poisson solve alone, fast": lambda: solver.solve(d),
        "    real FFT along x, forward": lambda: scipy.fft.rfft(d, axis=1),
        "    tridiagonal solves with the transform's turns": thomas,
        "    real FFT along x, inverse": lambda: scipy.fft.irfft(spectrum, n=w, axis=1),
        "limit: one 2-D FFT (scipy.fft.rfft2)": lambda: scipy.fft.rfft2(d),
        "limit: 2-D FFT round trip (rfft2 + irfft2)": lambda: scipy.fft.irfft2(
            scipy.fft.rfft2(d), s=shape
        ),
    }
    # Where a step's time goes (flame parameters, developed flow): the passes of
    # fluidnb.fluid._solver._step, in order.
    params = flame_preset().params
    s = _developed(shape, params)
    v, t, dd = np.array(s.velocity), np.array(s.temperature), np.array(s.density)
    size_y, size_x = (h + 1, w), (h, w + 1)
    qy, qx, ay, ax = np.empty(size_y), np.empty(size_x), np.empty(size_y), np.empty(size_x)
    K.advect_velocity(v, 1.0, qy, qx, ay, ax)
    fy, fx = _push(ay, ax, shape, params.epsilon)
    by, bx, div, vy, vx, t_out, d_out = (np.empty(shape) for _ in range(7))
    K.forces_and_divergence(ay, ax, t, fy, fx, 1.0, params.kappa_b, 0.0, 0.0, False,
                            solver.pos, 1, by, bx, div)  # fmt: skip
    pressure, p0 = solver.pressure(div)
    new = np.empty(v.shape)
    extra.update(
        {
            "pass 1: pad + advect velocity": lambda: K.advect_velocity(v, 1.0, qy, qx, ay, ax),
            "pass 2: vorticity + confinement push": lambda: K.confinement(
                ay, ax, params.epsilon, 1, fy, fx
            ),
            "pass 3: forces + walls + divergence": lambda: K.forces_and_divergence(
                ay, ax, t, fy, fx, 1.0, params.kappa_b, 0.0, 0.0, False, solver.pos, 1, by, bx, div
            ),
            "pass 4: the pressure (FFT, Thomas, inverse FFT)": lambda: solver.pressure(div),
            "pass 5: gradient, store, advect T and density": lambda: K.gradient_and_scalars(
                by, bx, pressure, solver.pos, True, p0, t, dd, 1.0, 1, vy, vx, new, t_out, d_out
            ),
            "pass 6: cooling": lambda: K.cool(t_out, 0.0, 1.0, 0.15, 1.88, t_out),
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

    load = _load()
    numba_line = f"numba {numba.__version__} ({numba.config.NUMBA_NUM_THREADS} threads)"
    print(header(__file__, numba_line) + " at the start")
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
    loads = []
    keys = list(cases)
    for r in range(args.rounds):
        # The order rotates each round: the case that follows the peers' (or another
        # grid's) measured a few percent slow, its caches cold.
        shift = r % len(keys)
        for k in keys[shift:] + keys[:shift]:
            secs[k].append(cases[k]())
        loads.append(_load())
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    if peers is not None:
        peers.close()
    load_end = _load()

    def ms(k):
        a = np.array(secs[k]) * 1e3
        return a.min(), np.median(a)

    print(
        f"\n{args.rounds} rounds round-robin over every case; ms per step (or per call): "
        f"fastest round / median. Load average {load:.1f} at the start, {load_end:.1f} at "
        f"the end, {np.mean(loads):.1f} on average over the rounds ({os.cpu_count()} cores)."
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

    _summary(cases, ms, load, load_end, loads)


def _load():
    """The 1-minute load average (NaN where the system has none): :func:`_report.load`."""
    return load()


def _summary(cases, ms, load, load_end, loads):
    """The README's table: the flame step, fluidnb's thread counts beside jax-cfd's step."""
    import numpy as np

    from fluidnb.fluid._threads import CHOOSER

    def cell(k):
        if k not in cases:
            return "-"
        lo, med = ms(k)
        return f"{lo:.2f} / {med:.2f}"

    counts = sorted({k[2].rsplit(", ", 1)[1] for k in cases if k[2].startswith("step: flame")})
    counts.sort(key=lambda c: (c != "default threads", c))
    print(
        "\n| flame step, ms (fastest / median) | "
        + " | ".join(f"fluidnb {c}" for c in counts)
        + " | jax-cfd (periodic, jit) | default / jax-cfd | load average |"
    )
    print("|---" * (len(counts) + 4) + "|")
    for shape in SHAPES:
        flame = {c: ("fluidnb", shape, f"step: flame, open top, {c}") for c in counts}
        jax = [k for k in cases if k[0] == "peer" and k[1] == shape and k[2].startswith("jax")]
        ratio = "-"
        if jax:
            lo, med = ms(flame["default threads"])
            jlo, jmed = ms(jax[0])
            ratio = f"{lo / jlo:.2f}x / {med / jmed:.2f}x"
        chosen = CHOOSER.choice(shape)
        print(
            f"| {shape[0]} x {shape[1]} (default chose {chosen} at the end) | "
            + " | ".join(cell(flame[c]) for c in counts)
            + f" | {cell(jax[0]) if jax else '-'} | {ratio} | "
            f"{load:.1f} -> {load_end:.1f} (mean {np.mean(loads):.1f}) |"
        )


if __name__ == "__main__":
    main()
