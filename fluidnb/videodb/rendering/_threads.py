"""The rendering's threads: work per frame, or per layer in order, on the cores.

The kernels the rendering runs release the GIL (numba ``nogil``, OpenCV), so a frame
(or a phase layer of the blend) on each of two threads uses both cores.
"""

from __future__ import annotations

from collections import deque

from ..._threads import spread_pool

__all__ = []

#: Threads over the frames (the matching, the motion blur's bands, the frames of a
#: run) and over the blend's layers.
_THREADS = 2


def _each_frame(fn, n):
    """``fn(t)`` for t in range(n), on up to :data:`_THREADS` threads.

    A frame at a time to whichever thread is free (not a fixed half each: a thread
    whose core another process shares would keep the other waiting at the end).
    """
    workers = min(_THREADS, n)
    if workers <= 1:
        for t in range(n):
            fn(t)
        return
    with spread_pool(workers, "fluidnb-frames") as pool:
        list(pool.map(fn, range(n)))


def _in_order(fn, items):
    """``fn(item)`` for every item, computed on threads, yielded in the items' order.

    At most one more call than there are threads is in flight (each holds a layer's
    pyramids).
    """
    items = list(items)
    workers = min(_THREADS, len(items))
    if workers <= 1:
        yield from map(fn, items)
        return
    with spread_pool(workers, "fluidnb-blend") as pool:
        pending = deque()
        try:
            for item in items:
                pending.append(pool.submit(fn, item))
                if len(pending) > workers:
                    yield pending.popleft().result()
            while pending:
                yield pending.popleft().result()
        finally:
            for future in pending:
                future.cancel()
