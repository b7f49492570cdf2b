"""The spec's recipe for the assignment's MRF: ICM, then alpha-expansion from two starts.

:func:`solve` keeps the lower of the expansion from the unary argmin and the expansion
from ICM's result, so it is never worse than ICM; on two cores the first runs on a
thread of its own beside the other two.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FuturesTimeout
from dataclasses import dataclass

import numpy as np

from ..._progress import Cancelled, Progress
from ..._threads import usable_cores
from ..._validation import check_int
from ._expansion import _diagonal, _expand, _tables
from ._icm import _icm
from ._mrf import _problem, _start

__all__ = ["MRFSolution", "solve", "solve_from"]


@dataclass(frozen=True, eq=False)
class MRFSolution:
    """The result of :func:`solve`.

    Attributes
    ----------
    labels : ndarray of int64, shape (P,)
        The labelling of lower energy (label indices into each node's candidates).
    energy : float
        Its energy, Eq. (4).
    energies : ndarray of float64
        The winning expansion run's energy at its start and after every sweep.
    icm_energy : float
        The energy ICM reached from the unary argmin (``energy <= icm_energy``); NaN
        for :func:`solve_from` (no ICM run).
    start : str
        ``"argmin"`` or ``"icm"``: which start the winning expansion ran from;
        ``"given"`` for :func:`solve_from`.
    nonsubmodular : float
        Fraction of truncated move terms in the winning run.
    sweeps : int
        Sweeps of the winning run.
    timings : dict
        Seconds spent in ``"icm"``, ``"expansion_argmin"`` and ``"expansion_icm"``
        (:func:`solve_from`: ``"expansion_given"``).
    """

    labels: np.ndarray
    energy: float
    energies: np.ndarray
    icm_energy: float
    start: str
    nonsubmodular: float
    sweeps: int
    timings: dict


#: Largest number of sweeps of each run by default.
MAX_SWEEPS = 20


def solve(unary, pairwise, edges, lam, *, max_sweeps=MAX_SWEEPS, progress=None):
    r"""Minimise Eq. (4) the spec's way: alpha-expansion from two starts, keep the lower.

    Runs ICM from the unary argmin, then :func:`alpha_expansion` once from the unary
    argmin and once from ICM's result, and keeps the labelling of lower energy (the
    argmin start on a tie). Since expansion never raises the energy, the result is
    never worse than ICM. The run from the argmin does not wait for ICM: on two or
    more cores it runs on a thread of its own beside the other two (the same result,
    ~30 % sooner at the app's size).

    Parameters
    ----------
    unary, pairwise, edges, lam
        As :func:`alpha_expansion`.
    max_sweeps : int
        Largest number of sweeps of each run.
    progress : callable, optional
        ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops.

    Returns
    -------
    MRFSolution

    Examples
    --------
    >>> unary = [[0.0, 0.5], [0.6, 0.0], [0.6, 0.0]]
    >>> potts = [[[0.0, 1.0], [1.0, 0.0]]] * 2
    >>> result = solve(unary, potts, [[0, 1], [1, 2]], lam=1.0)
    >>> result.labels.tolist(), result.energy, result.icm_energy
    ([1, 1, 1], 0.5, 0.5)
    """
    return _solve(_problem(unary, pairwise, edges, lam), max_sweeps, progress)


def _solve(prob, max_sweeps, progress):
    """:func:`solve` of a checked problem (a :class:`_Problem` or the tables' own)."""
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    report = Progress(progress)
    stage_icm, stage_b, stage_a = report.split(0.1, 0.55)
    start = prob.argmin()
    diag = _diagonal(prob.pairwise)  # the same for both runs

    def from_start(report):
        return _expand(prob, start, max_sweeps, report, tables=_tables(prob, start, diag))

    def from_icm_result():
        base = _icm(prob, start, max_sweeps, stage_icm)
        tables = _tables(prob, base.labels, diag)
        return base, _expand(prob, base.labels, max_sweeps, stage_b, tables=tables)

    if _side_by_side(prob):
        base, from_icm, from_argmin = _beside(from_start, from_icm_result, stage_a)
    else:
        base, from_icm = from_icm_result()
        from_argmin = from_start(stage_a)
    best, name = (from_argmin, "argmin")
    if from_icm.energy < from_argmin.energy:
        best, name = (from_icm, "icm")
    report(1.0, "MRF solved")
    return MRFSolution(
        labels=best.labels,
        energy=best.energy,
        energies=best.energies,
        icm_energy=base.energy,
        start=name,
        nonsubmodular=best.nonsubmodular,
        sweeps=best.sweeps,
        timings={
            "icm": base.seconds,
            "expansion_argmin": from_argmin.seconds,
            "expansion_icm": from_icm.seconds,
        },
    )


def solve_from(unary, pairwise, edges, lam, init, *, max_sweeps=1, progress=None):
    r"""Minimise Eq. (4) by alpha-expansion from a given labelling only (a warm start).

    A cheap re-solve for a live preview: when :math:`\sigma`, :math:`\lambda` or
    :math:`\rho` moved a little, the previous labels are a good start, and one sweep
    of expansion moves from them (no ICM, no second start, one thread) lands near
    :func:`solve`'s result. Not the spec's recipe: :func:`solve` stays the default;
    the energy is never above that of ``init`` (expansion never raises it), but it
    can stay above :func:`solve`'s. Measured on the stream photo at 480 px (161
    fragments, K = 100), sigma, lambda, rho each dragged over 0.5-2x its default
    (one-sweep warm starts chained from the previous move's labels): see
    ``tests/videodb/assignment/test_videodb_mrf.py::test_solve_from_*``.

    Parameters
    ----------
    unary, pairwise, edges, lam
        As :func:`alpha_expansion`.
    init : array_like of int, shape (P,)
        The labelling to start from (e.g. the previous re-solve's labels).
    max_sweeps : int
        Largest number of sweeps over all :math:`\alpha` (default 1: a preview).
    progress : callable, optional
        ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops.

    Returns
    -------
    MRFSolution
        ``start`` is ``"given"``, ``icm_energy`` NaN.
    """
    return _solve_from(_problem(unary, pairwise, edges, lam), init, max_sweeps, progress)


def _solve_from(prob, init, max_sweeps, progress):
    """:func:`solve_from` of a checked problem (a :class:`_Problem` or the tables' own)."""
    max_sweeps = check_int("max_sweeps", max_sweeps, 1)
    labels = _start(prob, init)
    run = _expand(prob, labels, max_sweeps, Progress(progress))
    return MRFSolution(
        labels=run.labels,
        energy=run.energy,
        energies=run.energies,
        icm_energy=float("nan"),
        start="given",
        nonsubmodular=run.nonsubmodular,
        sweeps=run.sweeps,
        timings={"expansion_given": run.seconds},
    )


#: Problems with fewer node labels (P K) than this are solved on one thread (a thread
#: costs ~0.1 ms; at the app's 171 x 100 the second one saves ~3 of 10 ms).
_SIDE_BY_SIDE = 4096


def _side_by_side(prob):
    """Whether :func:`solve` runs its two expansions on two threads."""
    return len(usable_cores()) > 1 and prob.n_nodes * prob.n_labels >= _SIDE_BY_SIDE


def _beside(aside, main, report):
    """``aside(report)`` on a thread of its own while ``main()`` runs here.

    The expansions release the GIL, so the two run at once on two cores. The caller's
    ``report`` is only called from this thread: while waiting for ``aside``, with its
    progress (so raising :class:`Cancelled` stops both; ``aside`` stops at its next
    report). Returns ``(*main(), aside(...))``.
    """
    stop = threading.Event()
    done = [0.0]

    def relay(fraction, message):  # aside's reports, on its thread
        if stop.is_set():
            raise Cancelled("stopped with the other run")
        done[0] = fraction

    with ThreadPoolExecutor(1, thread_name_prefix="fluidnb-mrf") as pool:
        future = pool.submit(aside, relay)
        try:
            result = main()
            while True:
                try:
                    return (*result, future.result(timeout=0.05))
                except FuturesTimeout:
                    report(done[0], "alpha-expansion from the unary argmin")
        except BaseException:
            stop.set()
            raise
