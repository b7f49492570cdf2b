"""Locks that keep two processes from writing one video database at once.

A build, an addition of clips and a resume hold an exclusive lock on the file
``.fluidnb-lock`` inside the database folder; the starter-database cache holds one on
``<name>.lock`` beside each cached database. The lock itself is :mod:`filelock`'s (an
OS-level ``flock``: a process that dies, even by ``SIGKILL``, lets go of it at once).
filelock does not record who holds a lock, so the holder writes that -- pid, host,
what it is doing, since when -- into a sidecar file ``<lock>.holder.json`` it owns and
removes on release: a second process that finds the lock taken can say who has it.

Lock files are never deleted while the folder they guard stays (a waiter must lock the
same inode as the holder), except by a build that removes the folder it made.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
from pathlib import Path

from ..._validation import parse_json

__all__ = [
    "LOCK_FILE",
    "DatabaseBusy",
    "database_lock",
    "describe",
    "holder",
    "lock_files",
    "locked",
]

#: The lock file inside a database folder.
LOCK_FILE = ".fluidnb-lock"
_HOLDER = ".holder.json"


class DatabaseBusy(ValueError):
    """Another process holds the lock of a video database (its message names it)."""


def lock_files(name=LOCK_FILE):
    """The names a lock called ``name`` may leave in its folder (it and its sidecar)."""
    return (name, name + _HOLDER)


def _holder_file(lock_file):
    return Path(str(lock_file) + _HOLDER)


def holder(lock_file, *, live=True):
    """Who holds ``lock_file``, from its sidecar: a dict, or None if nobody says so.

    With ``live`` (default), a sidecar left by a process of this host that no longer
    runs (it was killed before it could remove it) counts as nobody. A process on
    another host cannot be checked and is taken at its word.
    """
    try:
        info = parse_json(_holder_file(lock_file).read_text(encoding="utf-8"), "the holder's file")
        pid, host = int(info["pid"]), str(info["host"])
    except (OSError, ValueError, KeyError, TypeError):  # nobody says so
        return None
    if live and host == socket.gethostname() and not _alive(pid):
        return None
    return info


def describe(info):
    """``pid 123 on host 'box', building it since 2026-11-25 10:00:01`` (or a vaguer line)."""
    if not info:
        return "another process (it has not said which)"
    return (
        f"pid {info['pid']} on host {info['host']!r}, {info.get('action', 'writing it')} "
        f"since {info.get('since', '?')}"
    )


def _alive(pid):
    if os.name == "nt":  # os.kill(pid, 0) would terminate it there: take it at its word
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists but is not ours to signal
        return True
    return True


@contextlib.contextmanager
def locked(lock_file, action, *, wait=False, on_wait=None, busy=None):
    """Hold the exclusive lock ``lock_file`` while the body runs.

    Parameters
    ----------
    lock_file : path-like
        The lock file (created if missing; its folder must exist).
    action : str
        What the holder does, for others' messages (``"building it"``).
    wait : bool
        Wait for the lock (the starter cache) instead of raising :class:`DatabaseBusy`
        at once (builds and additions).
    on_wait : callable, optional
        Called once with the holder's description before waiting.
    busy : callable, optional
        Makes the :class:`DatabaseBusy` message from the holder's description.

    Raises
    ------
    DatabaseBusy
        If ``wait`` is false and another process holds the lock.
    """
    from filelock import FileLock, Timeout

    lock_file = Path(lock_file)
    lock = FileLock(str(lock_file))
    for _ in range(3):
        try:
            lock.acquire(timeout=0)
        except Timeout:
            info = _holder_soon(lock_file)
            if not wait:
                raise DatabaseBusy((busy or str)(describe(info))) from None
            if on_wait is not None:
                on_wait(describe(info))
            lock.acquire()
        # The folder's builder may have removed the folder (and this file) while we
        # waited: then the lock we hold guards nothing; take the new one.
        if lock_file.exists():
            break
        lock.release()
        lock_file.parent.mkdir(parents=True, exist_ok=True)
    else:  # pragma: no cover - the folder kept vanishing under us
        raise DatabaseBusy(f"{lock_file.parent} keeps being removed by another process")
    try:
        _write_holder(lock_file, action)
        yield
    finally:
        with contextlib.suppress(OSError):
            _holder_file(lock_file).unlink()
        lock.release()


def _holder_soon(lock_file):
    # The holder writes its sidecar just after it took the lock: give it a moment.
    for _ in range(10):
        info = holder(lock_file)
        if info is not None:
            return info
        time.sleep(0.02)
    return None


def _write_holder(lock_file, action):
    info = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "action": action,
        "since": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    target = _holder_file(lock_file)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(info), encoding="utf-8")
    os.replace(tmp, target)


@contextlib.contextmanager
def database_lock(root, action):
    """Lock the database folder ``root`` (which must exist) for ``action``, or say who has it.

    Raises
    ------
    DatabaseBusy
        Naming the process that holds it and what to do.
    """

    def busy(who):
        return (
            f"db: {str(root)!r} is locked by {who}: a database takes one writer at a time; "
            "wait for that process to finish, then try again"
        )

    with locked(Path(root) / LOCK_FILE, action, busy=busy):
        yield
