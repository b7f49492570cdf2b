"""The choice of thread count for a solver step (fluidnb.fluid._threads), on a fake clock."""

import numba
import numpy as np
import pytest

from fluidnb.fluid import FluidParams, FluidState, _threads, step
from fluidnb.fluid._threads import (
    MARGIN,
    MAX_REPROBE_SECONDS,
    PROBE_STEPS,
    REPROBE_SECONDS,
    SMALL_CELLS,
)

needs_two = pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
BIG = (128, 128)


class Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _run(chooser, shape, seconds_for):
    """Take one step's worth of picking and reporting; return the count used."""
    n, probe = chooser.pick(shape)
    if probe:
        chooser.record(shape, n, seconds_for(n))
    chooser.clock.now += seconds_for(n)
    return n


@needs_two
@pytest.mark.parametrize(("two", "expect"), [(0.5e-3, 2), (0.95e-3, 1), (1.4e-3, 1)])
def test_more_threads_only_when_they_save_a_margin(two, expect):
    # One thread takes 1 ms a step; two take `two`. Two are chosen only if they save
    # more than MARGIN of a step: never a default slower than one thread.
    top = numba.get_num_threads()
    chooser = _threads.ThreadChooser(Clock())
    times = {1: 1e-3, top: two}
    used = [_run(chooser, BIG, times.__getitem__) for _ in range(1 + 2 * PROBE_STEPS)]
    assert used == [1] + [1, top] * PROBE_STEPS  # an untimed first step, then interleaved
    choice = top if expect == 2 else 1
    assert chooser.choice(BIG) == choice
    assert {_run(chooser, BIG, times.__getitem__) for _ in range(20)} == {choice}
    assert (two < (1 - MARGIN) * 1e-3) == (expect == 2)


@needs_two
def test_the_first_untimed_step_does_not_count_and_outliers_do_not_decide():
    top = numba.get_num_threads()
    chooser = _threads.ThreadChooser(Clock())
    calls = {"n": 0}

    def seconds(n):
        calls["n"] += 1
        if calls["n"] == 1:
            return 5.0  # set-up and loading the kernels
        if calls["n"] == 3:
            return 0.5  # one step of two threads caught behind another program
        return 1e-3 if n == 1 else 0.5e-3

    for _ in range(1 + 2 * PROBE_STEPS):
        _run(chooser, BIG, seconds)
    assert chooser.choice(BIG) == top  # the median ignores the one slow step


@needs_two
def test_the_probe_is_repeated_as_the_load_changes():
    top = numba.get_num_threads()
    clock = Clock()
    chooser = _threads.ThreadChooser(clock)
    idle = {1: 1e-3, top: 0.6e-3}
    for _ in range(1 + 2 * PROBE_STEPS):
        _run(chooser, BIG, idle.__getitem__)
    assert chooser.choice(BIG) == top
    # Another program takes the second core: two threads now wait for each other.
    busy = {1: 1e-3, top: 2e-3}
    used = []
    while clock.now < 2 * REPROBE_SECONDS + 1:
        used.append(_run(chooser, BIG, busy.__getitem__))
    assert chooser.choice(BIG) == 1
    assert used[-50:] == [1] * 50
    # ... and is freed again: found at the next probe, after a wait that doubled
    # while two threads kept losing.
    later = []
    while clock.now < 200:
        later.append(_run(chooser, BIG, busy.__getitem__))
    probes = later.count(top)
    assert PROBE_STEPS * 4 <= probes <= PROBE_STEPS * 9  # not 100 probes in 200 s
    start = clock.now
    while chooser.choice(BIG) == 1:
        _run(chooser, BIG, idle.__getitem__)
    assert clock.now - start <= MAX_REPROBE_SECONDS + 1
    assert chooser.choice(BIG) == top


def test_small_grids_and_a_single_thread_are_not_probed(monkeypatch):
    chooser = _threads.ThreadChooser(Clock())
    small = (16, SMALL_CELLS // 16 - 1)
    assert chooser.pick(small) == (1, False)
    monkeypatch.setattr(_threads.numba, "get_num_threads", lambda: 1)
    assert chooser.pick(BIG) == (1, False)


@needs_two
def test_fixed_overrides_the_choice_in_this_thread_only():
    chooser = _threads.ThreadChooser(Clock())
    with chooser.fixed(2):
        assert chooser.pick((8, 8)) == (2, False)
        with chooser.fixed(1):
            assert chooser.pick(BIG) == (1, False)
        assert chooser.pick(BIG) == (2, False)
    assert chooser.pick(BIG) == (1, True)  # back to measuring


@needs_two
def test_step_restores_numba_s_thread_count_and_the_choice_does_not_change_results():
    params = FluidParams(source_flicker=0.0)
    s0 = FluidState.zeros((70, 66), params)
    before = numba.get_num_threads()
    runs = []
    for fixed in (1, 2, None):
        s = s0
        if fixed is None:
            for _ in range(12):  # the probe: one and two threads in turn
                s = step(s, params)
        else:
            with _threads.fixed(fixed):
                for _ in range(12):
                    s = step(s, params)
        assert numba.get_num_threads() == before
        runs.append(s)
    assert runs[0] == runs[1] == runs[2]
    assert np.abs(runs[0].velocity).max() > 0
