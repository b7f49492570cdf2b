"""What the lessons' figures share: their checks, a figure without pyplot, axes without ticks."""

from __future__ import annotations

from ..._validation import check_int
from ..assignment._assign import Assignment
from ..database._store import VideoDatabase

__all__ = []


def _check_db(db):
    if not isinstance(db, VideoDatabase):
        raise ValueError(f"db must be a VideoDatabase, got {type(db).__name__}")
    return db


def _check_fragment(db, fragment, name="fragment"):
    return check_int(name, fragment, 0, db.n_fragments - 1)


def _check_assignment(assignment, name="assignment"):
    if not isinstance(assignment, Assignment):
        raise ValueError(f"{name} must be an Assignment, got {type(assignment).__name__}")
    return assignment


def _figure(figsize):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _off(ax):
    ax.set_xticks([])
    ax.set_yticks([])


def _clip_name(db, clip):
    return str(db.clips[int(clip)]["name"])
