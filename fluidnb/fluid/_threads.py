"""How many threads a solver step runs on: the count that measured fastest, per grid.

Two threads are not always faster than one. A step is a handful of parallel loops of
a few tens of microseconds each, and every loop is a rendezvous: on a machine whose
other core is busy (a classroom server, a notebook beside a browser, CI, other
people's jobs) the second thread is often descheduled and every loop waits for it;
and with the passive OpenMP waiting fluidnb sets (see ``_kernels.py``) waking it costs
about 40 microseconds a loop on the 2-core VMs we measured on, even idle. There a
128 x 128 step took 0.60-0.75 ms on two threads against 0.50-0.53 on one, idle or
busy; with a short spin instead (``GOMP_SPINCOUNT``) two threads took 0.34 ms idle.
Neither the grid size nor the load average predicts this, so the solver measures what
the second thread buys:

- grids below :data:`SMALL_CELLS` always run on one thread (waking a second costs more
  than the half of the work it would take over);
- otherwise the first steps on a grid alternate one thread and numba's thread count
  (``numba.get_num_threads()``, which the user may lower:
  ``numba.set_num_threads(1)`` pins one thread), :data:`PROBE_STEPS` timed steps each,
  after one untimed step (set-up and loading the compiled kernels);
- the step then uses the more threads only if their median step time is at least
  :data:`MARGIN` below one thread's: a second core that buys less is better left to
  the machine's other work;
- the probe is repeated after :data:`REPROBE_SECONDS` of stepping, since the machine's
  load changes; each time the more threads lose again the wait doubles, up to
  :data:`MAX_REPROBE_SECONDS` (on a busy machine a probe's steps on two threads took
  3-5 ms against 0.6 on one: probing every 2 s cost more than it could find).

The results do not depend on the choice: every kernel gives the same bits on any
number of threads (tested), so this only moves time.
"""

from __future__ import annotations

import statistics
import threading
import time
from contextlib import contextmanager

import numba

__all__ = ["ThreadChooser", "fixed"]

#: Grids with fewer cells run on one thread.
SMALL_CELLS = 64 * 64
#: Timed steps per candidate in a probe (interleaved: 1, n, 1, n, ...).
PROBE_STEPS = 3
#: Seconds of stepping between two probes of the same grid while more threads pay.
REPROBE_SECONDS = 2.0
#: The longest wait between probes, reached while more threads keep losing.
MAX_REPROBE_SECONDS = 64.0
#: More threads are chosen only when they save at least this fraction of a step.
MARGIN = 0.10


class _Grid:
    """What the chooser knows about one grid shape at one thread count."""

    __slots__ = ("choice", "interval", "next_probe", "plan", "times")

    def __init__(self, top):
        self.choice = 1
        self.interval = REPROBE_SECONDS
        self.next_probe = 0.0
        # The first step pays the set-up (and the kernels' loading): not timed.
        self.plan = [(1, False)] + [(1, True), (top, True)] * PROBE_STEPS
        self.times = {}


class ThreadChooser:
    """Pick the thread count of each step by measurement (see the module docstring).

    Parameters
    ----------
    clock : callable
        Seconds, monotonic (``time.perf_counter``; tests pass a fake one).
    """

    def __init__(self, clock=time.perf_counter):
        self.clock = clock
        self._grids = {}
        self._lock = threading.Lock()
        self._fixed = threading.local()

    def pick(self, shape, top=None):
        """The thread count for the next step on a grid of ``shape``.

        ``top`` is numba's thread count (``numba.get_num_threads()`` if not given).
        Returns ``(n, probe)``: ``probe`` is True when the step is one of a probe's,
        to be reported with :meth:`record`.
        """
        forced = getattr(self._fixed, "n", None)
        if forced is not None:
            return forced, False
        if top is None:
            top = numba.get_num_threads()
        if top <= 1 or shape[0] * shape[1] < SMALL_CELLS:
            return 1, False
        key = (tuple(shape), top)
        with self._lock:
            grid = self._grids.get(key)
            if grid is None:
                if len(self._grids) >= 64:  # a long session of many grids: start afresh
                    self._grids.clear()
                grid = self._grids[key] = _Grid(top)
            if not grid.plan and self.clock() >= grid.next_probe:
                grid.plan = [(1, True), (top, True)] * PROBE_STEPS
                grid.times = {}
            if grid.plan:
                return grid.plan[0][0], True
            return grid.choice, False

    def record(self, shape, n, seconds, top=None):
        """Report that a probe's step on ``shape`` with ``n`` threads took ``seconds``."""
        key = (tuple(shape), numba.get_num_threads() if top is None else top)
        with self._lock:
            grid = self._grids.get(key)
            if grid is None or not grid.plan or grid.plan[0][0] != n:
                return  # another Python thread's step took this probe slot
            timed = grid.plan.pop(0)[1]
            if timed:
                grid.times.setdefault(n, []).append(seconds)
            if not grid.plan:
                self._decide(grid, key[1])

    def _decide(self, grid, top):
        one = statistics.median(grid.times.get(1, [float("inf")]))
        many = statistics.median(grid.times.get(top, [float("inf")]))
        grid.choice = top if many < (1.0 - MARGIN) * one else 1
        if grid.choice == 1:
            grid.interval = min(2.0 * grid.interval, MAX_REPROBE_SECONDS)
        else:  # being wrong now costs the most: a busy core stalls every step
            grid.interval = REPROBE_SECONDS
        grid.next_probe = self.clock() + grid.interval

    def choice(self, shape):
        """The thread count chosen for ``shape`` so far (1 before any measurement)."""
        grid = self._grids.get((tuple(shape), numba.get_num_threads()))
        return 1 if grid is None else grid.choice

    @contextmanager
    def step(self, shape):
        """Run the body on the picked thread count; time it when it is a probe's."""
        before = numba.get_num_threads()
        n, probe = self.pick(shape, before)
        if n != before:
            numba.set_num_threads(n)
        t0 = self.clock()
        try:
            yield n
        finally:
            elapsed = self.clock() - t0
            if n != before:
                numba.set_num_threads(before)
        if probe:
            self.record(shape, n, elapsed, before)

    @contextmanager
    def fixed(self, n):
        """Run every step inside on ``n`` threads (in this Python thread), chooser off."""
        before = getattr(self._fixed, "n", None)
        self._fixed.n = int(n)
        try:
            yield
        finally:
            self._fixed.n = before


#: The chooser every :func:`fluidnb.fluid.step` consults.
CHOOSER = ThreadChooser()


def fixed(n):
    """Context manager: the steps inside run on ``n`` threads (benchmarks, tests)."""
    return CHOOSER.fixed(n)
