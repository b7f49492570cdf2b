r"""Choosing :math:`\beta` so the frost ends at a target frame (Amano et al., sec. 3.4).

The end frame :math:`T_{sim}(\beta)` is the first frame with 90 % of the region frozen.
Amano et al. minimise :math:`f(\beta) = (T - T_{sim}(\beta))^2` (Eq. (2)) by steepest
descent, :math:`\beta_{i+1} = \beta_i - \eta\, \partial f / \partial \beta` (Eq. (3)),
the derivative by finite differences, and stops once :math:`|T - T_{sim}|` is within
the frames of 1/6 s at the clip's fps (24 fps: 4 frames).

:math:`T_{sim}` is an integer that falls in steps as :math:`\beta` grows, so its finite
differences are noisy (zero on a flat step, huge across a jump) and the step
:math:`\eta f'` depends on the slope of the region at hand. The paper names better
solvers as future work; :func:`optimise_beta` offers one as its default: bracket the
target (:math:`T_{sim}` falls with :math:`\beta`), then regula falsi (secant steps kept
inside the bracket, Illinois variant) with bisection as the fallback.

Every evaluation uses the same random numbers (one seed for all runs): common random
numbers, so :math:`T_{sim}` is a deterministic function of :math:`\beta`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from .._progress import Progress
from .._random import resolve_seed
from .._validation import check_choice, check_int, check_range
from ._estimate import estimate_end_frame
from ._reiter import _check_lattice, _check_params, _start_cells, grow

__all__ = ["OptimiseResult", "OptimiseStep", "optimise_beta"]

_METHODS = ("secant", "steepest")
# Below this bracket width in beta, T_sim is taken to jump across the target band
# (it is a step function of beta; finer beta would not be meaningful to a user).
_MIN_WIDTH = 1e-5
# Spacing of the betas tried on either side of such a jump.
_PROBE = 2e-3


@dataclass(frozen=True)
class OptimiseStep:
    r"""One row of the optimiser's table: a simulation at ``beta`` and its end frame.

    Attributes
    ----------
    step : int
        Row number (0 is the starting :math:`\\beta_0`).
    beta : float
        :math:`\\beta` simulated.
    end_frame : int or None
        :math:`T_{sim}(\\beta)`, ``None`` if the run never reached the coverage.
    note : str
        What the row is ("start", "bracket", "secant", "bisect", "descent").
    """

    step: int
    beta: float
    end_frame: int | None
    note: str = ""

    def to_dict(self):
        """The row as a JSON-serialisable dict."""
        return {
            "step": self.step,
            "beta": self.beta,
            "end_frame": self.end_frame,
            "note": self.note,
        }


@dataclass(frozen=True)
class OptimiseResult:
    r"""What :func:`optimise_beta` found, with its iteration table.

    Attributes
    ----------
    beta : float
        The :math:`\\beta` to use: the converged one, or the best seen.
    end_frame : int or None
        :math:`T_{sim}` at :attr:`beta`.
    target : int
        :math:`T`.
    tolerance : float
        The stopping band in frames (1/6 s at the fps).
    converged : bool
        Whether :math:`|T - T_{sim}| \\le` tolerance.
    method : str
        ``"secant"`` or ``"steepest"``.
    steps : tuple of OptimiseStep
        The table (step, beta, end frame); for steepest descent one row per
        iteration as in the paper's Tables 1-2.
    evaluations : int
        Simulations run (including finite-difference probes).
    message : str
        The outcome in words.
    seed : int
        The random seed every evaluation used (common random numbers).
    seconds : float
        Wall time.
    """

    beta: float
    end_frame: int | None
    target: int
    tolerance: float
    converged: bool
    method: str
    steps: tuple
    evaluations: int
    message: str
    seed: int
    seconds: float = field(default=0.0, repr=False)

    def table(self):
        """The iteration table as aligned text (step, beta, end frame)."""
        lines = [f"{'step':>4}  {'beta':>8}  {'end frame':>9}  note"]
        for s in self.steps:
            end = "never" if s.end_frame is None else str(s.end_frame)
            lines.append(f"{s.step:>4}  {s.beta:8.6f}  {end:>9}  {s.note}")
        return "\n".join(lines)

    def to_dict(self):
        """A JSON-serialisable summary (for clip metadata)."""
        return {
            "method": self.method,
            "beta": self.beta,
            "end_frame": self.end_frame,
            "target": self.target,
            "tolerance": self.tolerance,
            "converged": self.converged,
            "evaluations": self.evaluations,
            "message": self.message,
            "seed": self.seed,
            "steps": [s.to_dict() for s in self.steps],
        }


class _Objective:
    """T_sim(beta) with one seed for every run (common random numbers), memoised."""

    def __init__(self, lattice, starts, params, seed, report):
        self.lattice, self.starts, self.params, self.seed = lattice, starts, params, seed
        self.report = report
        self.cache = {}
        self.fraction = 0.0

    def __call__(self, beta):
        beta = float(beta)
        if beta not in self.cache:
            params = self.params.replace(beta=beta)
            sub = self.report.sub(self.fraction, self.fraction)  # cancellation inside runs
            res = grow(self.lattice, self.starts, params, seed=self.seed, progress=sub)
            self.cache[beta] = res.end_frame
        return self.cache[beta]

    @property
    def evaluations(self):
        return len(self.cache)

    def as_number(self, end):
        # A run that never ends counts as ending at the frame limit (a lower bound).
        return self.params.max_frames if end is None else end


def optimise_beta(
    lattice,
    starts,
    target=None,
    params=None,
    *,
    method="secant",
    beta0=0.25,
    eta=1e-6,
    h=0.01,
    max_iter=20,
    seed=0,
    progress=None,
    on_step=None,
):
    r"""Find :math:`\beta` so that the frost ends at the target frame :math:`T`.

    Parameters
    ----------
    lattice : HexLattice
        The region's lattice.
    starts : array_like
        Start cells or (n, 2) pixel points, as for :func:`grow`.
    target : int, optional
        :math:`T`, the target end frame (default ``params.target``).
    params : FrostParams, optional
        :math:`\gamma, \alpha, r_{th}`, coverage, frame limit, and ``fps`` for the
        stopping band of 1/6 s (24 fps: 4 frames); ``params.beta`` is ignored.
    method : {"secant", "steepest"}
        ``"steepest"``: the paper's steepest descent (Eq. (3)) on
        :math:`f(\beta) = (T - T_{sim}(\beta))^2` (Eq. (2)) with a central finite
        difference :math:`f'(\beta) \approx (f(\beta + h) - f(\beta - h)) / 2h`;
        each step is clipped to [0, 1]. ``"secant"`` (default): bracketing, then regula
        falsi / bisection on :math:`T_{sim}(\beta) - T` -- no :math:`\eta` to tune.
    beta0 : float
        :math:`\beta_0`, the starting value (the paper: 0.25).
    eta : float
        :math:`\eta` of Eq. (3) (the paper: 1e-6). The step is
        :math:`\eta \cdot 2 (T_{sim} - T) \cdot dT_{sim}/d\beta`: it converges well when
        :math:`2 \eta (dT_{sim}/d\beta)^2` is near 1, so regions with another slope
        need another :math:`\eta`.
    h : float
        Finite-difference step of the derivative (steepest descent only).
    max_iter : int
        Most descent iterations, or most simulations for the secant solver.
    seed : int or numpy.random.Generator
        One seed for all runs (common random numbers). Pass the seed you will
        render with, so the rendered clip ends where the optimiser said.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.
    on_step : callable, optional
        ``on_step(row)`` with each new :class:`OptimiseStep`, as soon as it is known
        (to show the table live).

    Returns
    -------
    OptimiseResult
        The :math:`\beta`, its end frame, the table and whether it converged.

    Raises
    ------
    ValueError
        For a bad argument, or a target no :math:`\beta` in [0, 1] can reach (the
        message names the target and the reachable end frames).

    Examples
    --------
    >>> from fluidnb.frost import reference_setup
    >>> lattice, starts, params = reference_setup(rth=0.0)
    >>> res = optimise_beta(lattice, starts, 130, params, seed=0)
    >>> print(res.table())
    step      beta  end frame  note
       0  0.250000        158  start
       1  0.300000        139  bracket
       2  0.350000        123  bracket
       3  0.328125        130  secant
    >>> res.converged
    True
    """
    lattice = _check_lattice(lattice)
    params = _check_params(params)
    starts = _start_cells(lattice, starts)
    target = params.target if target is None else target
    target = check_int("target", target, 1, params.max_frames)
    _check_fast_enough(lattice, starts, target, params)
    method = check_choice("method", method, _METHODS)
    beta0 = check_range("beta0", beta0, 0, 1)
    eta = check_range("eta", eta, 0, lo_open=True)
    h = check_range("h", h, 0, 0.5, lo_open=True)
    max_iter = check_int("max_iter", max_iter, 1)
    if on_step is not None and not callable(on_step):
        raise ValueError(f"on_step must be None or a callable, got {type(on_step).__name__}")
    seed = resolve_seed(seed)  # common random numbers: one fixed seed for every evaluation
    report = Progress(progress)
    objective = _Objective(lattice, starts, params, seed, report)
    tol = params.tolerance
    started = time.perf_counter()
    rows = []

    def record(beta, end, note):
        row = OptimiseStep(len(rows), float(beta), end, note)
        rows.append(row)
        if on_step is not None:
            on_step(row)
        objective.fraction = min(len(rows) / (max_iter + 1), 1.0)
        shown = "never" if end is None else end
        report(objective.fraction, f"step {row.step}: beta={beta:.4f} -> {shown}")
        return row

    solve = _steepest if method == "steepest" else _secant
    converged, message = solve(objective, record, target, tol, beta0, eta, h, max_iter)
    best = _best(rows, target, objective)
    if converged:
        chosen = rows[-1]
    else:
        chosen = best
        _check_reachable(objective, record, target, tol, rows)
    report(1.0, message)
    return OptimiseResult(
        beta=chosen.beta,
        end_frame=chosen.end_frame,
        target=target,
        tolerance=tol,
        converged=converged,
        method=method,
        steps=tuple(rows),
        evaluations=objective.evaluations,
        message=message,
        seed=seed,
        seconds=time.perf_counter() - started,
    )


def _within(end, target, tol):
    return end is not None and abs(end - target) <= tol + 1e-9


def _best(rows, target, objective):
    return min(rows, key=lambda r: abs(objective.as_number(r.end_frame) - target))


def _steepest(objective, record, target, tol, beta, eta, h, max_iter):
    """Amano et al.'s Eq. (3) with a central finite difference of f (Eq. (2))."""

    def f(b):
        return (target - objective.as_number(objective(b))) ** 2

    end = objective(beta)
    record(beta, end, "start")
    for i in range(1, max_iter + 1):
        if _within(end, target, tol):
            return True, f"converged in {i - 1} step(s): T_sim = {end}, target {target} +- {tol:g}"
        lo, hi = max(beta - h, 0.0), min(beta + h, 1.0)
        grad = (f(hi) - f(lo)) / (hi - lo)
        if grad == 0:
            return False, (
                f"stalled at beta = {beta:.6f}: T_sim is flat over beta +- {h:g} "
                "(the finite-difference derivative is 0); try a larger h or the secant solver"
            )
        beta = min(max(beta - eta * grad, 0.0), 1.0)
        end = objective(beta)
        record(beta, end, "descent")
    if _within(end, target, tol):
        return True, f"converged in {max_iter} step(s): T_sim = {end}, target {target} +- {tol:g}"
    return False, (
        f"not converged after {max_iter} steps (T_sim = {_fmt(end)}, target {target}); "
        "eta may be too small or too large for this region's slope dT_sim/dbeta"
    )


def _secant(objective, record, target, tol, beta, eta, h, max_iter):
    """Bracket T_sim(beta) = target, then regula falsi (Illinois) with bisection."""
    del eta, h  # steepest descent's knobs

    def g(end):
        # T_sim falls as beta grows; a run that never ends is "too slow" (+inf).
        return math.inf if end is None else end - target

    end = objective(beta)
    record(beta, end, "start")
    if _within(end, target, tol):
        return True, f"converged at the start: T_sim = {end}, target {target} +- {tol:g}"
    ga = g(end)
    a = b = beta
    gb = ga
    # 1. Bracket: walk beta up (too slow) or down (too fast). Steps grow (at most
    # fourfold) and follow the secant through the last two runs once there are two.
    step = 0.05
    up = ga > 0
    while (gb > 0) == up:
        if len(objective.cache) >= max_iter:
            return False, f"no bracket found within {max_iter} simulations"
        if b != a and math.isfinite(ga) and math.isfinite(gb) and gb != ga:
            reach = abs(gb * (b - a) / (gb - ga)) * 1.25  # aim a little past the target
            step = min(max(reach, step), 4 * step)
        elif b != a:
            step *= 2  # no usable secant yet (a run that never ended): double
        nxt = min(b + step, 1.0) if up else max(b - step, 0.0)
        if nxt == b:
            # Pinned at beta = 0 (still too fast) or 1 (still too slow): unreachable.
            return False, f"target {target} not reachable within beta in [0, 1]"
        a, ga = b, gb
        b = nxt
        end = objective(b)
        record(b, end, "bracket")
        gb = g(end)
        if _within(end, target, tol):
            return True, f"converged while bracketing: T_sim = {end}, target {target} +- {tol:g}"
    # Order so that g(lo) > 0 (too slow, small beta) and g(hi) < 0 (too fast).
    (lo, glo), (hi, ghi) = sorted([(a, ga), (b, gb)])
    side = 0
    while len(objective.cache) < max_iter:
        if hi - lo < _MIN_WIDTH:
            return _probe(objective, record, target, tol, lo, hi, max_iter)
        if math.isfinite(glo):
            x = hi - ghi * (hi - lo) / (ghi - glo)
            note = "secant"
            if not lo < x < hi:
                x, note = 0.5 * (lo + hi), "bisect"
        else:
            x, note = 0.5 * (lo + hi), "bisect"
        end = objective(x)
        record(x, end, note)
        gx = g(end)
        if _within(end, target, tol):
            return True, f"converged: T_sim = {end}, target {target} +- {tol:g}"
        if gx > 0:
            lo, glo = x, gx
            if side == 1:
                ghi *= 0.5  # Illinois: stop regula falsi from creeping from one side
            side = 1
        else:
            hi, ghi = x, gx
            if side == -1:
                glo *= 0.5
            side = -1
    return False, f"not converged within {max_iter} simulations (bracket [{lo:.6f}, {hi:.6f}])"


def _probe(objective, record, target, tol, lo, hi, max_iter):
    """T_sim jumps across the band at [lo, hi]; look a little to either side.

    T_sim is only roughly monotone: a cell that freezes one step earlier can change the
    pockets left at 90 % coverage, so nearby betas may still land in the band.
    """
    jump = f"T_sim jumps from {_fmt(objective(lo))} to {_fmt(objective(hi))} at beta = {lo:.6f}"
    for k in range(1, 4):
        for x in (hi + k * _PROBE, lo - k * _PROBE):
            if len(objective.cache) >= max_iter or not 0.0 <= x <= 1.0:
                continue
            end = objective(x)
            record(x, end, "probe")
            if _within(end, target, tol):
                return True, f"converged next to a jump ({jump}): T_sim = {end}"
    return False, f"no beta found with T_sim within {tol:g} of {target}: {jump}"


def _check_fast_enough(lattice, starts, target, params):
    """Refuse a target sooner than the front can possibly get there.

    Ice spreads at most one cell a frame, so no beta < 1 ends before the coverage's
    hop distance from the start points (beta = 1 is ice everywhere at frame 0: no
    growth at all, which would otherwise "converge" for a target of a frame or two).
    """
    fastest = estimate_end_frame(lattice, starts, params).fastest
    if fastest < 0:
        raise ValueError(
            "the start points cannot reach enough of the region (it is painted in pieces): "
            "add a start point in every piece"
        )
    if target < fastest:
        raise ValueError(
            f"target must be >= {fastest} frames for this region and these start points, "
            f"got {target}: ice spreads at most one cell a frame, and {params.coverage:.0%} "
            f"of the region lies up to {fastest} cells from the start points; choose a "
            "later target, add start points or use a larger spacing"
        )


def _check_reachable(objective, record, target, tol, rows):
    """Raise a clear ValueError if no beta in [0, 1] can reach the target."""
    ends = [objective.as_number(r.end_frame) for r in rows]
    if max(ends) >= target - tol:
        # Some run was slow enough: the target lies within (or above) what was seen,
        # and beta = 1 (everything ice at once) is always fast enough.
        return
    if 0.0 not in objective.cache:
        record(0.0, objective(0.0), "reach?")
    slowest = objective(0.0)
    if slowest is not None and slowest < target - tol:
        raise ValueError(
            f"target {target} frames cannot be reached: even the slowest growth (beta = 0) "
            f"ends at frame {slowest}, so reachable end frames are 0..{slowest} for this "
            "region, these starts and gamma, alpha, rth; lower the target, enlarge the "
            "region, use a smaller spacing or a smaller gamma"
        )


def _fmt(end):
    return "never" if end is None else str(end)
