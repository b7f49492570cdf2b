r"""Neighbours that share a database fragment play it at different times (beyond the paper).

The smoothness term of the MRF (Eq. 6) costs little when two neighbours take the same
database fragment: its motion spectra and textureness agree with themselves. So a
fragment that suits a region is often repeated across it, and, rendered as the paper
does, every copy plays the same frames at the same time: the region shows a tile
pattern (on the cloud photo, a fish-scale pattern 24 px apart).

Our decision: keep the assignment (the MRF is the paper's) and break the sync at render
time. Every fragment's difference frames are first made a seamless loop of their own
(the end cross-faded into the start, as the whole clip's were), and then each fragment
starts its loop at a temporal offset: 0 unless one of its 8 neighbours already plays the
same database fragment, else the first offset of a golden-ratio sequence that is at
least a quarter of the loop away from every such neighbour's (:func:`temporal_offsets`).
A loop shifted in time is still seamless, and fragments that are not repeated render
exactly as before. A slowly changing fragment (smoke) looks alike at every time, so
repeated neighbours are also mirrored, alternately, across the axis of their motion
(:func:`mirror_axes`: a fragment moving sideways is flipped upside down, which keeps its
sideways motion). :func:`sync_share` measures what is left: the share of neighbouring
target fragments that show the same source pixels at the same time.
"""

from __future__ import annotations

import numpy as np

from ..._validation import check_array, check_int
from .._common._geometry import STRIDE
from ._composite import loop_crossfade

__all__ = ["mirror_axes", "stagger", "sync_share", "temporal_offsets"]

# The golden ratio's fractional part: successive multiples spread evenly over a cycle.
_GOLDEN = (5**0.5 - 1) / 2


def _grid(positions):
    pos = check_array("positions", positions, ndim=2, dtype_kinds="iu", min_size=0)
    if pos.shape[1:] != (2,):
        raise ValueError(f"positions must have shape (P, 2) as (row, col), got {pos.shape}")
    return pos // STRIDE


def _check_fragments(fragments, n):
    f = check_array("fragments", fragments, ndim=1, dtype_kinds="iu", min_size=0)
    if len(f) != n:
        raise ValueError(f"fragments must hold one id per position ({n}), got {len(f)}")
    return f


def temporal_offsets(fragments, positions, length):
    r"""Start frames that keep neighbours sharing a database fragment out of sync.

    Target fragments are visited in raster order; a fragment none of whose already
    visited 8 neighbours plays the same database fragment starts at 0; otherwise it
    takes the first offset of :math:`\lfloor \{k \varphi\} L \rfloor`, ``k = 1, 2, ...``
    (:math:`\varphi` the golden ratio's fractional part, :math:`L` the loop's length)
    whose cyclic distance to every such neighbour's offset is at least :math:`L/4`,
    or the farthest one if none is.

    Parameters
    ----------
    fragments : ndarray, shape (P,), int
        The database fragment assigned to each target fragment.
    positions : ndarray, shape (P, 2), int
        The target fragments' top-left (row, col), multiples of 24.
    length : int
        :math:`L`, frames in each fragment's loop (>= 1).

    Returns
    -------
    ndarray, shape (P,), int64
        Offsets in [0, L).

    Examples
    --------
    Four target fragments in a row, all given database fragment 7:

    >>> temporal_offsets([7, 7, 7, 7], [[0, 0], [0, 24], [0, 48], [0, 72]], 24).tolist()
    [0, 14, 5, 14]
    """
    grid = _grid(positions)
    ids = _check_fragments(fragments, len(grid))
    length = check_int("length", length, 1)
    out = np.zeros(len(ids), np.int64)
    if len(ids) == 0 or length == 1:
        return out
    # The distinct offsets of the golden-ratio sequence, in its own order.
    seq = np.floor(np.mod(np.arange(1, 4 * length) * _GOLDEN, 1) * length).astype(np.int64)
    _, first = np.unique(seq, return_index=True)
    choices = seq[np.sort(first)]
    for i, twins in _earlier_twins(ids, grid):
        if twins:
            gaps = np.abs(choices[:, None] - out[twins][None, :]) % length
            gaps = np.minimum(gaps, length - gaps).min(axis=1)
            good = np.flatnonzero(gaps * 4 >= length)
            out[i] = choices[good[0]] if len(good) else choices[np.argmax(gaps)]
    return out


def _earlier_twins(ids, grid):
    """For each target fragment (raster order), its visited 8-neighbours with its id."""
    where = {(int(r), int(c)): i for i, (r, c) in enumerate(grid)}
    order = np.lexsort((grid[:, 1], grid[:, 0]))
    done = np.zeros(len(ids), bool)
    for i in order:
        r, c = grid[i]
        twins = [
            j
            for dr in (-1, 0, 1)
            for dc in (-1, 0, 1)
            if (dr or dc)
            and (j := where.get((int(r + dr), int(c + dc)))) is not None
            and done[j]
            and ids[j] == ids[i]
        ]
        yield i, twins
        done[i] = True


def mirror_axes(fragments, positions, motion):
    r"""Which repeated neighbours to mirror, and across which axis.

    In raster order, a target fragment that has already visited 8-neighbours playing
    the same database fragment is mirrored unless most of them are (so repeats
    alternate); a fragment with no such neighbour is not. The axis keeps the
    fragment's motion: a fragment moving more sideways than up or down (:math:`|dx|
    \ge |dy|`) is flipped upside down (axis 0: its :math:`dy` changes sign), one
    moving up or down is flipped left to right (axis 1).

    Parameters
    ----------
    fragments : ndarray, shape (P,), int
    positions : ndarray, shape (P, 2), int
    motion : ndarray, shape (P, 2)
        Each assigned fragment's mean motion (dy, dx).

    Returns
    -------
    ndarray, shape (P,), int8
        -1: not mirrored; 0: flipped upside down; 1: flipped left to right.

    Examples
    --------
    >>> pos = [[0, 0], [0, 24], [0, 48], [0, 72]]
    >>> mirror_axes([7, 7, 7, 3], pos, [[0, 1.0], [0, 1.0], [0, 1.0], [1.0, 0]]).tolist()
    [-1, 0, -1, -1]
    """
    grid = _grid(positions)
    ids = _check_fragments(fragments, len(grid))
    m = np.asarray(motion, np.float64)
    if m.shape != (len(ids), 2):
        raise ValueError(f"motion must have shape ({len(ids)}, 2), got {m.shape}")
    out = np.full(len(ids), -1, np.int8)
    for i, twins in _earlier_twins(ids, grid):
        if twins and 2 * sum(out[j] >= 0 for j in twins) <= len(twins):
            out[i] = 0 if abs(m[i, 1]) >= abs(m[i, 0]) else 1
    return out


def sync_share(fragments, positions, offsets=None, mirrors=None):
    r"""The share of neighbouring target fragments that play the same frames in sync.

    Over the pairs of 4-neighbouring target fragments, the fraction whose overlap
    shows the same source pixels at the same time: the same database fragment, at the
    same temporal offset, mirrored alike. 0 means no fragment is repeated in sync next
    to itself.

    Parameters
    ----------
    fragments : ndarray, shape (P,), int
    positions : ndarray, shape (P, 2), int
    offsets : ndarray, shape (P,), optional
        Temporal offsets (default all 0: the paper's rendering).
    mirrors : ndarray, shape (P,), optional
        Mirror axes as :func:`mirror_axes` gives them (default none mirrored).

    Returns
    -------
    float
        In [0, 1]; 0 when there is no pair of neighbours.

    Examples
    --------
    >>> pos = [[0, 0], [0, 24], [0, 48]]
    >>> sync_share([5, 5, 6], pos)
    0.5
    >>> sync_share([5, 5, 6], pos, offsets=[0, 12, 0])
    0.0
    """
    grid = _grid(positions)
    ids = _check_fragments(fragments, len(grid))
    offs = np.zeros(len(ids), np.int64) if offsets is None else np.asarray(offsets, np.int64)
    if offs.shape != ids.shape:
        raise ValueError(f"offsets must have shape {ids.shape}, got {offs.shape}")
    flips = np.full(len(ids), -1) if mirrors is None else np.asarray(mirrors, np.int64)
    if flips.shape != ids.shape:
        raise ValueError(f"mirrors must have shape {ids.shape}, got {flips.shape}")
    where = {(int(r), int(c)): i for i, (r, c) in enumerate(grid)}
    pairs = same = 0
    for i, (r, c) in enumerate(grid):
        for dr, dc in ((0, 1), (1, 0)):
            j = where.get((int(r + dr), int(c + dc)))
            if j is None:
                continue
            pairs += 1
            same += ids[i] == ids[j] and offs[i] == offs[j] and flips[i] == flips[j]
    return float(same / pairs) if pairs else 0.0


def stagger(diffs, offsets, *, overlap, rates=None, n_frames=None, mirrors=None):
    r"""Each fragment's difference frames as a loop of its own, started at its offset.

    Every fragment's :math:`N` frames become a seamless loop of :math:`L = N -`
    ``overlap`` frames (:func:`~fluidnb.videodb.rendering.loop_crossfade`, per fragment), and
    fragment ``p`` then plays frame :math:`(o_p + r_p t) \bmod L` at time :math:`t`
    (linear between frames at fractional times). With all offsets 0 and rates 1
    this is the loop of the whole blended clip (both steps are linear, so looping
    before or after the blend is the same, to rounding).

    Parameters
    ----------
    diffs : ndarray, shape (P, N, ...)
        Per fragment, its frames.
    offsets : ndarray, shape (P,)
        :math:`o_p`, in frames.
    overlap : int
        Frames cross-faded, in [1, N // 2].
    rates : ndarray, shape (P,), optional
        :math:`r_p`, frames of the loop played per frame (default 1). The flow
        rendering plays a fragment faster where the painted speed is faster than the
        fragment's own; ``rates * n_frames`` should be a multiple of :math:`L` for
        the result to loop.
    n_frames : int, optional
        Frames to make (default :math:`L`).
    mirrors : ndarray, shape (P,), optional
        Per fragment, the spatial axis its frames are flipped across (0: upside
        down, 1: left to right, -1: none; :func:`mirror_axes`).

    Returns
    -------
    ndarray, shape (P, n_frames, ...), float32
    """
    d = check_array("diffs", diffs, dtype_kinds="iuf", min_size=0)
    offs = np.asarray(offsets, np.float64)
    if d.ndim < 2 or offs.shape != d.shape[:1]:
        raise ValueError(
            f"diffs must be (P, N, ...) with one offset per fragment, got {d.shape} "
            f"and {offs.shape} offsets"
        )
    overlap = check_int("overlap", overlap, 1, d.shape[1] // 2)
    looped = np.moveaxis(loop_crossfade(np.moveaxis(d, 1, 0), overlap=overlap), 0, 1)
    length = looped.shape[1]
    n_frames = length if n_frames is None else check_int("n_frames", n_frames, 1)
    r = np.ones(len(offs)) if rates is None else np.asarray(rates, np.float64)
    if r.shape != offs.shape:
        raise ValueError(f"rates must have shape {offs.shape}, got {r.shape}")
    if mirrors is not None:
        flips = np.asarray(mirrors, np.int64)
        if flips.shape != offs.shape or looped.ndim < 4:
            raise ValueError(
                f"mirrors must have shape {offs.shape} for frames (P, N, H, W, ...), "
                f"got {flips.shape} for {d.shape}"
            )
        for axis in (0, 1):
            sel = flips == axis
            if sel.any():
                looped[sel] = np.flip(looped[sel], axis=2 + axis)
    if not offs.any() and (r == 1).all() and n_frames == length:
        return np.ascontiguousarray(looped)
    times = np.mod(offs[:, None] + r[:, None] * np.arange(n_frames)[None, :], length)
    i0 = np.floor(times).astype(np.int64)
    frac = (times - i0).astype(np.float32)
    rows = np.arange(len(offs))[:, None]
    out = looped[rows, i0 % length]
    if frac.any():
        frac = frac.reshape(frac.shape + (1,) * (looped.ndim - 2))
        out += frac * (looped[rows, (i0 + 1) % length] - out)
    return np.ascontiguousarray(out)
