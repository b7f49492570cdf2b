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
"""

from __future__ import annotations

import contextlib
import functools
import threading

__all__ = ["blas_single_threaded", "opencv_single_threaded"]


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
