"""Other libraries' thread pools held at one thread while our own threads do the work.

Where fluidnb runs work side by side on its own threads (a database build's clips,
the smoothness tables' batches), a library that starts threads of its own inside
each piece only competes for the same cores. OpenBLAS is the costly case: after a
product on several threads, its idle threads keep spinning for a while, waiting for
the next one, on cores our threads need. Measured here (2 cores): one 2-thread
float32 product in ``assign``'s visual words (a few milliseconds of work) left
OpenBLAS spinning through the smoothness tables that follow, ~0.08 s of CPU per
``assign`` and 15 % of its time (0.225 -> 0.19 s median) -- the products themselves
are the same on one thread.

:func:`blas_single_threaded` and :func:`opencv_single_threaded` set the library's
thread count to one while any block using them runs. The setting is the library's,
for the whole process, so uses are counted: nested and concurrent blocks (two
threads of a build, the app's re-solve beside a render) all run single-threaded,
and the count the process had is restored when the last block ends.

:func:`spread_pool` is the other half: a pool of our own threads for leaf work (work
that starts no threads of its own) that, when it has a thread for every core the
process may use, keeps each thread on a core of its own. With another process busy,
Linux otherwise tends to put two of our threads on one core -- a thread woken by the
other (a GIL hand-over) is placed beside its waker -- and leaves the busy process a
core to itself: measured on 2 cores with one busy loop, the smoothness tables got
1.1 cores' worth of our two threads (1.7-2.0 s for the paper's whole frame) and 1.35
with each thread on its own core (1.5 s); with nothing else running both are the same.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["blas_single_threaded", "opencv_single_threaded", "spread_pool", "usable_cores"]


class _OneThread:
    """A counted "one thread while in use" setting of one library.

    ``limit()`` sets the library to one thread and returns what restores it.
    """

    def __init__(self, limit):
        self._limit = limit
        self._lock = threading.Lock()
        self._users = 0
        self._restore = None

    @contextlib.contextmanager
    def __call__(self):
        with self._lock:
            if self._users == 0:
                self._restore = self._limit()
            self._users += 1
        try:
            yield
        finally:
            with self._lock:
                self._users -= 1
                if self._users == 0:
                    restore, self._restore = self._restore, None
                    restore()


@functools.cache
def _blas_controller():
    # Finding the loaded BLAS libraries walks every shared object of the process:
    # ~3 ms each time with OpenCV, numba and scikit-learn loaded (threadpool_limits
    # does it on every call), ~0.03 ms to reuse. numpy's own BLAS -- the one our
    # products use -- is loaded with numpy, so it is always among those found.
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _release_blas_control():
    # threadpoolctl (3.8) lets one Python thread at a time set OpenBLAS's process-wide
    # thread count -- the first to set it, until it lets go -- and silently drops the
    # settings of every other thread. A limit set (and not let go) by the kernel's main
    # thread would then leave an app's worker thread with OpenBLAS's two threads inside
    # each of the tables' two (measured: an assign on a worker thread after one on the
    # main thread took 0.30-0.34 s instead of 0.17 s). Our uses are counted and
    # serialised by _OneThread's lock, so the thread making the change may take it.
    try:
        from threadpoolctl import OpenBLASController

        OpenBLASController.clear_controlling_thread(force=True)
    except (ImportError, AttributeError):  # threadpoolctl < 3.8: no such rule
        pass


def _limit_blas():
    _release_blas_control()
    limiter = _blas_controller().limit(limits=1, user_api="blas")
    _release_blas_control()

    def restore():
        _release_blas_control()
        limiter.restore_original_limits()
        _release_blas_control()

    return restore


def _limit_opencv():
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    return functools.partial(cv2.setNumThreads, threads)


#: ``with blas_single_threaded(): ...`` -- numpy's (and scipy's) BLAS on one thread.
blas_single_threaded = _OneThread(_limit_blas)

#: ``with opencv_single_threaded(): ...`` -- OpenCV on one thread. Measured on two busy
#: cores: DIS flow took 20-50 % more CPU time and twice the wall time with two OpenCV
#: threads inside each of a build's two workers as with one, for the same flow.
opencv_single_threaded = _OneThread(_limit_opencv)


def usable_cores():
    """The cores this process may run on (its affinity; every core where unknown)."""
    try:
        return sorted(os.sched_getaffinity(os.getpid()))
    except (AttributeError, OSError):  # not Linux
        return list(range(os.cpu_count() or 1))


def spread_pool(workers, thread_name_prefix="fluidnb"):
    """A :class:`~concurrent.futures.ThreadPoolExecutor` of ``workers`` threads, one per core.

    When ``workers`` equals the number of cores the process may use (and the system
    lets a thread choose its core, as Linux does), each thread keeps to a core of its
    own from its start: under another process's load, the scheduler no longer
    stacks two of them on one core (see the module's notes). Otherwise -- fewer
    threads than cores, where the scheduler finds a free core on its own, or no such
    system call -- a plain pool.

    For leaf work only: a thread started inside one of these threads would inherit
    its single core. So that no library starts one there, a pool that pins its
    threads also holds BLAS and OpenCV at one thread (:func:`blas_single_threaded`,
    :func:`opencv_single_threaded`) from its creation until it is shut down, in the
    creating thread: their own thread pools are then neither started nor resized
    inside a pinned thread (our threads are the parallelism anyway). Shut it down
    with ``wait=True`` (as ``with`` does). Hand out the work in many small pieces
    (``submit`` / ``map`` over pieces, never one fixed share per thread): a thread
    that shares its core with a busy process then simply takes fewer of them.

    Parameters
    ----------
    workers : int
        Number of threads, >= 1.
    thread_name_prefix : str
    """
    cores = usable_cores()
    if workers != len(cores) or workers < 2 or not hasattr(os, "sched_setaffinity"):
        return ThreadPoolExecutor(workers, thread_name_prefix=thread_name_prefix)
    return _PinnedPool(workers, thread_name_prefix, cores)


class _PinnedPool(ThreadPoolExecutor):
    """:func:`spread_pool`'s pool when it pins: each thread on ``cores[i]``, libraries at one."""

    def __init__(self, workers, thread_name_prefix, cores):
        order = itertools.count()
        lock = threading.Lock()

        def pin():
            with lock:
                core = cores[next(order) % len(cores)]
            # Pool threads end with the pool: nothing to restore. The OS may refuse (a
            # container's rules); the thread then runs where the scheduler puts it.
            with contextlib.suppress(OSError):
                os.sched_setaffinity(0, {core})

        self._held = contextlib.ExitStack()
        self._held.enter_context(blas_single_threaded())
        try:
            self._held.enter_context(opencv_single_threaded())
            super().__init__(workers, thread_name_prefix=thread_name_prefix, initializer=pin)
        except BaseException:
            self._held.close()
            raise

    def shutdown(self, wait=True, *, cancel_futures=False):
        super().shutdown(wait=wait, cancel_futures=cancel_futures)
        self._held.close()  # back to the libraries' own counts (once; later calls: none)
