"""The searches in plain numpy, in the paper's notation: the math as one would first write it.

Slow on purpose (Python loops over patches and positions). This module exists so
that the tests can check the compiled searches (:func:`fluidnb.turbulence.global_search`,
:func:`fluidnb.turbulence.local_search`) against the equations written out literally,
and so that the lesson (``notebooks/06_turbulence.ipynb``) can teach from code a
student can read and edit. Use the compiled searches for real work.

Notation (Watanabe et al., sec. 2): lower case lives on the target's coarse grid,
upper case on the source's fine grid; ``x``, ``X`` are target patches, ``z``, ``Z``
source patches; subscripts ``u`` (velocity) and ``d`` (smoke mask); a star marks
the temporal-coherence term (the previous frame's detail).
"""

from __future__ import annotations

import time

import numpy as np

from ._search import SearchResult

__all__ = [
    "E_h",
    "E_l",
    "energy",
    "global_search_reference",
    "local_search_reference",
    "window_positions",
]


def E_l(x_u, x_d, z_u, z_d, alpha):
    r"""Eq. (1): :math:`E_l = \|x_u - z_u\|^2 + \alpha \|x_d - z_d\|^2`.

    ``x_u``, ``z_u``: ``b x b`` velocity patches, shape (b, b, 2); ``x_d``, ``z_d``:
    mask patches, shape (b, b).
    """
    return np.sum((x_u - z_u) ** 2) + alpha * np.sum((x_d - z_d) ** 2)


def E_h(X_u, X_d, Z_u, Z_d, alpha, beta=0.0, X_star=None, Z_star=None):
    r"""Eq. (2): :math:`E_h = \|X_u - Z_u\|^2 + \alpha\|X_d - Z_d\|^2 + \beta\|X^*_u - Z^*_u\|^2`.

    ``X_u``: a ``B x B`` patch of the upsampled target velocity :math:`U_t`;
    ``Z_u``: of the source's low frequencies :math:`U_{sl}`; ``X_d``, ``Z_d``: of the
    masks :math:`D_t`, :math:`D_s`; ``X_star``: of :math:`U^*_h`, the previous frame's
    detail advected by the target flow; ``Z_star``: of the source's detail
    :math:`U_{sh}`. Without ``X_star`` (the first frame) the third term is left out.
    """
    e = np.sum((X_u - Z_u) ** 2) + alpha * np.sum((X_d - Z_d) ** 2)
    if X_star is not None:
        e += beta * np.sum((X_star - Z_star) ** 2)
    return e


def energy(X_p, Z):
    r"""The sum of squared differences of two patches, every channel at once.

    With :math:`\sqrt\alpha` and :math:`\sqrt\beta` folded into the channels
    (:func:`fluidnb.turbulence.local_features`), this one sum is :func:`E_h`.
    """
    return np.sum((X_p - Z) ** 2)


def window_positions(strategy, n, *, m0=8, interval=2, best=None):
    """The window offsets a strategy visits, round by round (Watanabe et al., sec. 3).

    Parameters
    ----------
    strategy : str
        ``"exhaustive"``, ``"interval"`` or ``"adaptive"``.
    n : int
        Positions per axis of the window.
    m0, interval : int
        As in :class:`~fluidnb.turbulence.TurbulenceParams`.
    best : callable, optional
        ``best(offsets) -> (row, col)``, the adaptive search's choice among the
        offsets it holds after a round: the first round's, then the current best
        followed by the new round's (default: the one nearest the window's centre,
        a stand-in for real energies).

    Returns
    -------
    list of ndarray, shape (k, 2)
        One array per round (one round for the non-adaptive strategies).

    Examples
    --------
    >>> [len(r) for r in window_positions("adaptive", 32, m0=8)]
    [16, 24, 24, 24]
    """
    if strategy in ("exhaustive", "interval"):
        m = 1 if strategy == "exhaustive" else interval
        g = np.arange(0, n, m)
        return [np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)]
    if strategy != "adaptive":
        raise ValueError(
            f"strategy must be 'exhaustive', 'interval' or 'adaptive', got {strategy!r}"
        )

    def nearest_centre(pts):
        return tuple(pts[np.argmin(((np.asarray(pts) - (n - 1) / 2) ** 2).sum(1))])

    pick = best or nearest_centre
    # Round 0: the window every m0 positions.
    g = np.arange(0, n, m0)
    rounds = [np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)]
    cy, cx = pick(rounds[0])
    m = m0
    while m > 1:
        # Around the best so far: offsets -m..+m at step m/2 (a 5 x 5 grid less its
        # centre, which is measured already), inside the window.
        half = m // 2
        pts = [
            (a, b)
            for a in range(cy - m, cy + m + 1, half)
            for b in range(cx - m, cx + m + 1, half)
            if 0 <= a < n and 0 <= b < n and (a, b) != (cy, cx)
        ]
        rounds.append(np.array(pts, dtype=int).reshape(-1, 2))
        cy, cx = pick(rounds[-1] if not pts else np.vstack([[cy, cx], rounds[-1]]))
        m = half
    return rounds


def local_search_reference(S, X, starts, n, strategy, *, m0=8, interval=2):
    """The paper's three local searches, position by position, in plain numpy.

    The same problem as :func:`fluidnb.turbulence.local_search` (same arguments,
    weights folded into the channels of ``S`` and ``X``), and the same answer: for
    each patch ``p``, the window position ``q`` with the least
    ``energy(X[p], Z(q))`` among those the strategy visits; a tie goes to the
    position first in raster order.

    Parameters
    ----------
    S : ndarray, shape (H, W, C)
    X : ndarray, shape (P, B, B, C)
    starts : ndarray of int, shape (P, 2)
    n : int
    strategy : {"exhaustive", "interval", "adaptive"}
    m0, interval : int

    Returns
    -------
    SearchResult
    """
    t0 = time.perf_counter()
    B = X.shape[1]
    positions, energies, evaluations = [], [], []
    for p in range(len(X)):
        y0, x0 = starts[p]

        def E(q, p=p, y0=y0, x0=x0):
            a, b = q
            Z = S[y0 + a : y0 + a + B, x0 + b : x0 + b + B]  # the source patch Z(q)
            return energy(X[p], Z)

        def pick(offsets):
            # The least energy; ties to the first in raster order.
            return min((tuple(q) for q in offsets), key=lambda q: (E(q), q))

        rounds = window_positions(strategy, n, m0=m0, interval=interval, best=pick)
        if strategy == "adaptive":  # the rounds were chosen by pick; the last choice wins
            visited = np.vstack(rounds)
            q = pick(visited)
        else:
            q = pick(rounds[0])
        positions.append((y0 + q[0], x0 + q[1]))
        energies.append(E(q))
        evaluations.append(sum(len(r) for r in rounds))
    seconds = time.perf_counter() - t0
    return SearchResult(
        np.array(positions, np.int64).reshape(-1, 2),
        np.array(energies, float),
        np.array(evaluations, np.int64),
        seconds,
    )


def global_search_reference(prep, i):
    r"""The global search of Eq. (1) at frame ``i``, by brute force over every position.

    For each local patch ``p``: its ``b x b`` global patch :math:`x(p)` of the
    (edge-padded) target, compared by :func:`E_l` with every ``b x b`` patch
    :math:`z(q_l)` of the downsampled source. Same answer as
    :func:`fluidnb.turbulence.global_search` (ties to the first in raster order).

    Returns
    -------
    q_l : ndarray of int, (P, 2)
    E : ndarray, (P,)
    """
    b, alpha = prep.params.b, prep.params.alpha
    u_t = np.pad(prep.u_t[i], ((b, b), (b, b), (0, 0)), mode="edge").astype(np.float64)
    d_t = np.pad(prep.d_t[i], b, mode="edge").astype(np.float64)
    u_s, d_s = prep.u_s[i].astype(np.float64), prep.d_s[i].astype(np.float64)
    h, w = d_s.shape
    q_l, best = [], []
    for y, x in prep.target_corners + b:  # the global patch's top-left, padded grid
        x_u, x_d = u_t[y : y + b, x : x + b], d_t[y : y + b, x : x + b]
        energies = {}
        for qy in range(h - b + 1):
            for qx in range(w - b + 1):
                z_u, z_d = u_s[qy : qy + b, qx : qx + b], d_s[qy : qy + b, qx : qx + b]
                energies[qy, qx] = E_l(x_u, x_d, z_u, z_d, alpha)
        q = min(energies, key=lambda q: (energies[q], q))
        q_l.append(q)
        best.append(energies[q])
    return np.array(q_l, np.int64), np.array(best)
