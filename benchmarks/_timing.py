"""Timing helper shared by the benchmark scripts."""

import time


def best(fn, repeat=7):
    """Best wall time of ``repeat`` calls of ``fn()`` after one warm-up call, in seconds."""
    fn()  # warm caches and lazy imports
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)
