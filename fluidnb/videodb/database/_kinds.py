"""A database named by its kind (``"water"``, ``"smoke"``, ``"fire"``) or given by its folder.

:func:`~fluidnb.videodb.assign` takes ``db="water"``: a starter database, made by
fluidnb itself from clips of its own solvers (:mod:`fluidnb.videodb.starter`) the first
time it is asked for. The starter package registers how to open each of its kinds here
(:func:`register_kinds`) when it is imported -- which importing :mod:`fluidnb.videodb`
does -- so that the database and the assignment below it import nothing of the
starter databases, of the fire method or of the fluid solver.
"""

from __future__ import annotations

import os

from ._store import VideoDatabase, open_database

__all__ = ["as_database", "register_kinds"]

# kind -> opener(kind, progress=...) -> VideoDatabase, in the order registered.
_OPENERS = {}


def register_kinds(kinds, opener):
    """Let ``db=kind`` name a database: ``opener(kind, progress=...)`` opens (or makes) it."""
    for kind in kinds:
        _OPENERS[kind] = opener


def as_database(db, progress=None):
    """A VideoDatabase from a database, a folder, or a registered kind's name."""
    if isinstance(db, VideoDatabase):
        return db
    if isinstance(db, str) and db in _OPENERS:
        return _OPENERS[db](db, progress=progress)
    kinds = ", ".join(repr(k) for k in _OPENERS)
    if isinstance(db, (str, os.PathLike)):
        if not os.path.exists(db):
            raise ValueError(
                f"db must be a VideoDatabase, a database folder, or one of {kinds}, got "
                f"{str(db)!r} (no such folder)"
            )
        return open_database(db, progress=progress)
    raise ValueError(
        f"db must be a VideoDatabase, a database folder, or one of {kinds}, got {type(db).__name__}"
    )
