"""Other libraries' thread counts held at one while fluidnb's own threads work."""

import os
import threading
import time

import numpy as np
import pytest

from fluidnb import _threads
from fluidnb._threads import (
    _blas_controller,
    blas_single_threaded,
    opencv_single_threaded,
    spread_pool,
    usable_cores,
)


def _blas_threads():
    """numpy's BLAS thread counts (threadpoolctl's view of the loaded BLAS libraries)."""
    return [lib["num_threads"] for lib in _blas_controller().select(user_api="blas").info()]


@pytest.fixture
def two_blas_threads():
    """numpy's BLAS on two threads for the test (the count a 2-core machine starts with)."""
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can see")
    with _blas_controller().limit(limits=2, user_api="blas"):
        yield


def test_blas_one_thread_inside_and_restored_after(two_blas_threads):
    assert set(_blas_threads()) == {2}
    with blas_single_threaded():
        assert set(_blas_threads()) == {1}
        with blas_single_threaded():  # nested: the inner end does not restore
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {1}
    assert set(_blas_threads()) == {2}


def test_blas_concurrent_blocks_count(two_blas_threads):
    # Thread A leaves while thread B is still inside: B keeps one thread.
    inside, leave_a, leave_b = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def a():
        with blas_single_threaded():
            inside.set()
            leave_a.wait(5)

    def b():
        inside.wait(5)
        with blas_single_threaded():
            leave_a.set()
            ta.join(5)
            seen["after a left"] = set(_blas_threads())
            leave_b.wait(5)

    ta, tb = threading.Thread(target=a), threading.Thread(target=b)
    ta.start()
    tb.start()
    ta.join(5)
    leave_b.set()
    tb.join(5)
    assert seen["after a left"] == {1}
    assert set(_blas_threads()) == {2}


def test_blas_restored_after_an_error(two_blas_threads):
    with pytest.raises(RuntimeError), blas_single_threaded():
        raise RuntimeError("stop")
    assert set(_blas_threads()) == {2}


def test_opencv_one_thread_inside_and_restored_after():
    cv2 = pytest.importorskip("cv2")
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        with opencv_single_threaded():
            assert cv2.getNumThreads() == 1
            with opencv_single_threaded():
                assert cv2.getNumThreads() == 1
            assert cv2.getNumThreads() == 1
        assert cv2.getNumThreads() == 2
    finally:
        cv2.setNumThreads(before)


def test_quantise_runs_its_products_on_one_blas_thread(two_blas_threads, monkeypatch):
    # quantise's products are followed by fluidnb's own threads (assign's tables):
    # OpenBLAS must not be left spinning on the cores after them.
    from fluidnb.videodb.database import _words

    counts = []

    class Spy(np.ndarray):
        # The centres, noting the BLAS threads whenever a matrix product uses them.
        def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
            if ufunc is np.matmul:
                counts.append(set(_blas_threads()))
            inputs = [np.asarray(a) if isinstance(a, Spy) else a for a in inputs]
            return getattr(ufunc, method)(*inputs, **kwargs)

    rng = np.random.default_rng(0)
    x = rng.integers(0, 255, (50, 128)).astype(np.uint8)
    centres = rng.random((20, 128)) * 255
    real = _words._check_pair

    def check_pair(descriptors, c):
        xx, cc = real(descriptors, c)
        return xx, cc.view(Spy)

    monkeypatch.setattr(_words, "_check_pair", check_pair)
    words = _words.quantise(x, centres)
    assert counts
    assert all(c == {1} for c in counts)
    assert set(_blas_threads()) == {2}
    d = ((x[:, None, :].astype(np.float64) - centres[None]) ** 2).sum(-1)
    np.testing.assert_array_equal(words, d.argmin(axis=1))


def test_blas_limit_from_a_worker_while_the_main_thread_holds_control(two_blas_threads):
    # threadpoolctl lets one thread set OpenBLAS's count and drops the others' settings:
    # a limit set on the main thread and never let go (a plain threadpool_limits() call,
    # or the lesson's cells before an app runs on its worker thread) must not turn the
    # worker's single-threaded block into a no-op.
    held = _blas_controller().limit(limits=2, user_api="blas")  # main takes control
    seen = {}

    def worker():
        with blas_single_threaded():
            seen["inside"] = set(_blas_threads())
        seen["after"] = set(_blas_threads())

    try:
        t = threading.Thread(target=worker)
        t.start()
        t.join(5)
    finally:
        held.restore_original_limits()
    assert seen == {"inside": {1}, "after": {2}}


# ------------------------------------------------------------------ spread_pool

needs_affinity = pytest.mark.skipif(
    not hasattr(os, "sched_setaffinity"), reason="the system does not let threads choose a core"
)


def _affinities(pool, n_tasks=16):
    """Each pool thread's cores, as the thread itself sees them (name -> set)."""
    seen = {}

    def task(_):
        time.sleep(0.005)  # every thread gets some
        seen[threading.current_thread().name] = frozenset(os.sched_getaffinity(0))

    with pool:
        list(pool.map(task, range(n_tasks)))
    return seen


@needs_affinity
def test_spread_pool_one_core_per_thread_when_it_has_one_for_every_core(monkeypatch):
    # Any machine: pretend the process may use two of its cores (or the one it has
    # twice over, which still must be pinned thread by thread).
    cores = sorted(os.sched_getaffinity(0))
    two = [cores[0], cores[-1]] if len(cores) > 1 else [cores[0], cores[0]]
    monkeypatch.setattr(_threads, "usable_cores", lambda: two)
    seen = _affinities(spread_pool(2, "test-spread"))
    assert len(seen) == 2
    assert sorted(seen.values(), key=sorted) == sorted((frozenset({c}) for c in two), key=sorted)
    # The caller's own thread is never pinned.
    assert os.sched_getaffinity(0) == set(cores)


@needs_affinity
def test_spread_pool_plain_when_fewer_threads_than_cores(monkeypatch):
    cores = sorted(os.sched_getaffinity(0))
    monkeypatch.setattr(_threads, "usable_cores", lambda: [*cores, max(cores) + 1])
    seen = _affinities(spread_pool(len(cores), "test-plain"))
    assert set(seen.values()) == {frozenset(cores)}


def test_spread_pool_runs_every_task_once():
    workers = len(usable_cores())
    with spread_pool(workers) as pool:
        out = list(pool.map(lambda x: x * x, range(100)))
    assert out == [x * x for x in range(100)]


def test_usable_cores_is_the_process_affinity():
    cores = usable_cores()
    assert cores == sorted(cores)
    assert len(cores) >= 1
    if hasattr(os, "sched_getaffinity"):
        assert set(cores) == os.sched_getaffinity(0)


@needs_affinity
def test_pinned_pool_holds_blas_and_opencv_at_one_thread_until_shutdown(
    monkeypatch, two_blas_threads
):
    # So that neither library starts or resizes its own thread pool inside a pinned
    # thread (its threads would inherit the one core): the limits are set and
    # restored in the creating thread, around the pool's whole life.
    cv2 = pytest.importorskip("cv2")
    cores = sorted(os.sched_getaffinity(0))
    monkeypatch.setattr(_threads, "usable_cores", lambda: [cores[0], cores[-1]])
    before = cv2.getNumThreads()
    cv2.setNumThreads(2)
    try:
        seen = []

        def task(_):
            with opencv_single_threaded():  # a worker's own use, ended inside the pool
                pass
            seen.append((set(_blas_threads()), cv2.getNumThreads()))

        with spread_pool(2, "test-holds") as pool:
            list(pool.map(task, range(8)))
            assert (set(_blas_threads()), cv2.getNumThreads()) == ({1}, 1)
        assert seen == [({1}, 1)] * 8
        assert (set(_blas_threads()), cv2.getNumThreads()) == ({2}, 2)
    finally:
        cv2.setNumThreads(before)


def test_plain_pool_leaves_the_libraries_alone(monkeypatch, two_blas_threads):
    cores = usable_cores()
    monkeypatch.setattr(_threads, "usable_cores", lambda: [*cores, max(cores) + 1])
    with spread_pool(len(cores)) as pool:
        assert pool.submit(_blas_threads).result() == _blas_threads()
        assert set(_blas_threads()) == {2}
