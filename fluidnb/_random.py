"""Seeding: one policy for every method.

Every entry point takes ``seed=`` (None, a non-negative int, or a numpy Generator) and
calls :func:`resolve_seed` once, at its boundary. That returns the **int actually used**,
which the result records (``Clip.metadata["seed"]``), and :func:`rng` turns that int
into the generator the method draws from. So any clip can be remade exactly from its
recorded seed, even one made with ``seed=None``.
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = ["resolve_seed", "rng"]


def _check(seed):
    if seed is None or isinstance(seed, np.random.Generator):
        return
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(
            f"seed must be None, a non-negative integer or a numpy Generator, got {seed!r}"
        )


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
    _check(seed)
    if seed is None or isinstance(seed, np.random.Generator):
        return np.random.default_rng(seed)
    return np.random.default_rng(int(seed))


def resolve_seed(seed=None):
    """Return the int seed a run actually uses, to record beside its result.

    Parameters
    ----------
    seed : None, int or numpy.random.Generator
        An int (>= 0) is returned as it is. ``None`` draws a fresh one from the
        operating system's entropy; a Generator draws one from its stream (so a caller
        sharing one stream still gets reproducible, recordable runs).

    Returns
    -------
    int
        In [0, 2**31), or the int given. Pass it to :func:`rng`.

    Raises
    ------
    ValueError
        If ``seed`` is a negative number, a bool, a float or anything else.

    Examples
    --------
    >>> resolve_seed(7)
    7
    >>> s = resolve_seed(None)
    >>> float(rng(s).random()) == float(rng(s).random())
    True
    """
    _check(seed)
    if seed is None or isinstance(seed, np.random.Generator):
        return int(np.random.default_rng(seed).integers(2**31))
    return int(seed)
