"""Seeding: one way to turn the user's ``seed`` into a random generator."""

from __future__ import annotations

import numbers

import numpy as np

__all__ = ["rng"]


def rng(seed=None):
    """Return a :class:`numpy.random.Generator` for ``seed``.

    Parameters
    ----------
    seed : None, int or numpy.random.Generator
        ``None`` draws fresh entropy; an int (>= 0) gives the same stream every time;
        a Generator is used as it is (so callers can share one stream).

    Examples
    --------
    >>> float(rng(3).random()) == float(rng(3).random())
    True
    """
    if seed is None or isinstance(seed, np.random.Generator):
        return np.random.default_rng(seed)
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(
            f"seed must be None, a non-negative integer or a numpy Generator, got {seed!r}"
        )
    return np.random.default_rng(int(seed))
