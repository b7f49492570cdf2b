r"""The keyframe synthesis written out in plain numpy: the scan as one would first write it.

Furukawa et al. (2013), sec. 3.2, Fig. 4, with Ashikhmin's (2001) candidate set. Slow
on purpose (a Python loop over the output pixels); it exists so that the tests can
check the compiled scan of :mod:`fluidnb.fire._synthesis` against the method written
out literally, and so that the lesson can show (and a student can edit) the method in
its most readable form. Use :func:`fluidnb.fire.synthesize` for real work.

Notation (the paper's):

- :math:`I_a` the photo (composited onto black with its matte), :math:`a_a` its alpha;
- :math:`I_t` the target (normalised temperature), :math:`I_s` the output;
- :math:`N_U(p)` the upper L of a :math:`k \times k` square (colours compared),
  :math:`N_L(p)` the lower L (target against alpha compared);
- :math:`w` the user-control weight, :math:`\kappa` the coherence penalty;
- :math:`s(q)` the source in :math:`I_a` of output pixel :math:`q`.
"""

from __future__ import annotations

import numpy as np

from .._random import resolve_seed, rng
from ..fields import advect, backward_warp
from ._synthesis import (
    _check_params,
    _check_photo,
    _check_target,
    _draws,
    _quantise,
    _random_index,
    _random_word,
    neighbourhoods,
)

__all__ = ["advance_reference", "distance", "synthesize_reference"]


def synthesize_reference(photo, target, params=None, *, matte=None, seed=None):
    r"""One keyframe by Ashikhmin's candidate search, pixel by pixel, in numpy.

    Draws the same random numbers as :func:`fluidnb.fire.synthesize` (the random
    candidates), so with the same seed both give the same image. The definition both
    follow, beyond the paper's text:

    - colours, alpha and target are compared as 8-bit levels (0..255), so every sum
      of squared differences is an exact integer;
    - the paper's initial white noise is not drawn: the first pass compares only
      :math:`N_U(p)`, which the raster scan has already synthesised, and the
      neighbourhoods are cut at the output's border, so no noise pixel is ever read;
    - the random candidates are drawn by a counter-based generator (SplitMix64 of a
      key plus the candidate's number, ``_synthesis._draws``), each a flat input
      index;
    - the first candidate of equals wins (ties are broken by the candidates' order:
      p's own source in the second pass, the neighbours' shifted sources in the
      order of the offsets, then the random ones).

    The compiled scan visits the pixels on several threads in sheared tiles
    (``_synthesis._scan_tiles``), an order in which every pixel sees exactly what it
    sees here, so its result is this raster scan's, bit for bit.

    Parameters
    ----------
    photo, target, params, matte, seed
        As for :func:`fluidnb.fire.synthesize` (the candidate search).

    Returns
    -------
    I_s : ndarray, shape (H, W, 3), float32
    s : ndarray, shape (H, W, 2), int64
        The source (row, col) in the photo of each output pixel.

    Examples
    --------
    >>> from fluidnb.data import sample
    >>> from fluidnb.fire import synthesize
    >>> photo, matte = sample("flame", size=12, return_alpha=True)
    >>> target = np.zeros((6, 6), np.float32)
    >>> target[2:, 2:4] = 1.0
    >>> I_s, s = synthesize_reference(photo, target, matte=matte, seed=0)
    >>> bool(np.array_equal(s, synthesize(photo, target, matte=matte, seed=0)[1]))
    True
    """
    params = _check_params(params)
    I_a, a_a = _check_photo(photo, matte)
    I_t = _check_target(target)
    gen = rng(resolve_seed(seed))
    key, n_passes, n_random = _draws(gen, params)
    H, W = I_t.shape
    Ha, Wa = a_a.shape
    k, w, kappa = params.size, params.weight, params.coherence
    N_U, N_L = neighbourhoods(k)  # (dy, dx) offsets of the two Ls
    full_square = np.concatenate([N_U, N_L[1:]])  # all but p itself

    # 8-bit levels, the photo padded so that every input pixel has a whole square.
    h = k // 2
    I_a_q = np.pad(_quantise(I_a), ((h, h), (h, h), (0, 0)), mode="edge").astype(np.int64)
    a_a_q = np.pad(_quantise(a_a), h, mode="edge").astype(np.int64)
    I_t_q = _quantise(I_t).astype(np.int64)
    I_s_q = np.zeros((H, W, 3), np.int64)  # synthesised levels (see above: no noise)

    s = np.full((H, W, 2), -1, dtype=np.int64)
    for pass_ in range(n_passes):
        # First pass: colours over N_U only (the rest is not synthesised yet);
        # second pass: over the whole square.
        colour_offsets = N_U if pass_ == 0 else full_square
        for r in range(H):
            for c in range(W):
                p = np.array([r, c])

                # --- the candidates p_i --------------------------------------------
                coherent = []
                if pass_ > 0:
                    coherent.append(s[r, c])  # p's own source from the first pass
                for offset in colour_offsets:
                    q = p + offset
                    if inside(q, H, W) and s[q[0], q[1], 0] >= 0:
                        # Ashikhmin: the pixel that continues q's patch, s(q) + (p - q).
                        shifted = s[q[0], q[1]] - offset
                        coherent.append(np.clip(shifted, 0, [Ha - 1, Wa - 1]))
                counter = ((pass_ * H + r) * W + c) * n_random + np.arange(n_random)
                words = _random_word(key + counter.astype(np.uint64))
                flat = _random_index(words, Ha * Wa).astype(np.int64)
                random = np.stack([flat // Wa, flat % Wa], axis=1)
                candidates = np.array(coherent + list(random), dtype=np.int64).reshape(-1, 2)
                penalty = np.r_[np.ones(len(coherent)), np.full(len(random), 1.0 + kappa)]
                if len(candidates) == 0:
                    # Nothing synthesised around p and no random candidate (n_random = 0).
                    candidates = np.array([[(r * 7919 + c) % Ha, (c * 104729 + r) % Wa]])
                    penalty = np.ones(1)

                # --- the distance D of every candidate --------------------------------
                D = distance(I_s_q, I_t_q, I_a_q, a_a_q, p, candidates, colour_offsets, N_L, w, h)
                best = np.argmin(penalty * D)  # the first of equals, as in the scan

                # --- copy the best candidate's colour, remember where it came from ---
                s[r, c] = candidates[best]
                I_s_q[r, c] = I_a_q[s[r, c, 0] + h, s[r, c, 1] + h]
    I_s = I_a[s[..., 0], s[..., 1]]
    return I_s, s


def distance(I_s_q, I_t_q, I_a_q, a_a_q, p, candidates, colour_offsets, N_L, w, h):
    r""":math:`D = \frac{w}{|N_L|} SSD_{N_L} + \frac{1 - w}{3 |N_U|} SSD_{N_U}` per candidate.

    In 8-bit levels squared. :math:`|N_L|` and :math:`|N_U|` count only the pixels of
    each L inside the output (so an L cut by the border weighs as much as a whole
    one); the colour SSD runs over the three channels.
    """
    H, W = I_t_q.shape
    # Only the neighbours that exist in the output count.
    colour_offsets = colour_offsets[[inside(p + o, H, W) for o in colour_offsets]]
    N_L = N_L[[inside(p + o, H, W) for o in N_L]]

    # Lower L: the target temperature around p against the photo's alpha around p_i.
    t_p = I_t_q[p[0] + N_L[:, 0], p[1] + N_L[:, 1]]  # (|N_L|,)
    a_pi = a_a_q[
        candidates[:, None, 0] + h + N_L[None, :, 0], candidates[:, None, 1] + h + N_L[None, :, 1]
    ]  # (n_candidates, |N_L|)
    ssd_L = ((t_p[None] - a_pi) ** 2).sum(axis=1)

    # Upper L: the colours synthesised around p against the photo's around p_i.
    ssd_U = np.zeros(len(candidates), np.int64)
    w_U = 0.0
    if len(colour_offsets):
        c_p = I_s_q[p[0] + colour_offsets[:, 0], p[1] + colour_offsets[:, 1]]  # (|N_U|, 3)
        c_pi = I_a_q[
            candidates[:, None, 0] + h + colour_offsets[None, :, 0],
            candidates[:, None, 1] + h + colour_offsets[None, :, 1],
        ]  # (n_candidates, |N_U|, 3)
        ssd_U = ((c_p[None] - c_pi) ** 2).sum(axis=(1, 2))
        w_U = (1 - w) / (3 * len(colour_offsets))
    w_L = w / len(N_L)
    return w_L * ssd_L.astype(np.float64) + w_U * ssd_U.astype(np.float64)


def inside(q, H, W):
    """Whether pixel ``q`` = (row, col) lies in an H x W image."""
    return 0 <= q[0] < H and 0 <= q[1] < W


def advance_reference(d, steps, K, weight, frame):
    r"""One clip frame between keyframes, in numpy (sec. 3.3, Fig. 5).

    For each displacement ``u`` of ``steps`` (the velocity over a part of a simulation
    frame), one more backtrace, :math:`d(x) \leftarrow -u(x) + d(x - u(x))`; then the
    keyframe sampled at :math:`x + d(x)` is added to ``frame`` with ``weight``.
    ``fluidnb.fire._advance`` does the same in one compiled pass per step.

    Returns
    -------
    d : ndarray, shape (H, W, 2)
        The new displacement (``frame`` is updated in place).
    """
    for u in steps:
        d = advect(d, u) - u
    frame += np.float32(weight) * backward_warp(K, d)
    return d
