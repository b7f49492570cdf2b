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
from ._synthesis import _check_params, _check_photo, _check_target, _draws, neighbourhoods

__all__ = ["synthesize_reference"]


def synthesize_reference(photo, target, params=None, *, matte=None, seed=None):
    r"""One keyframe by Ashikhmin's candidate search, pixel by pixel, in numpy.

    Draws the same random numbers as :func:`fluidnb.fire.synthesize` (the initial
    noise, the random candidates), so with the same seed both give the same image.

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
    I_s, random_rows, random_cols = _draws(gen, I_t.shape, I_a.shape[:2], params)
    I_s = I_s.copy()  # starts as white noise
    H, W = I_t.shape
    Ha, Wa = I_a.shape[:2]
    k, w, kappa = params.size, params.weight, params.coherence
    N_U, N_L = neighbourhoods(k)  # (dy, dx) offsets of the two Ls
    full_square = np.concatenate([N_U, N_L[1:]])  # all but p itself

    # Pad the photo so that every input pixel has a whole k x k neighbourhood.
    h = k // 2
    I_a_pad = np.pad(I_a, ((h, h), (h, h), (0, 0)), mode="edge")
    a_a_pad = np.pad(a_a, h, mode="edge")

    s = np.full((H, W, 2), -1, dtype=np.int64)
    n_passes = 2 if params.second_pass else 1
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
                random = np.stack([random_rows[pass_, r, c], random_cols[pass_, r, c]], axis=1)
                candidates = np.array(coherent + list(random), dtype=np.int64).reshape(-1, 2)
                penalty = np.r_[np.ones(len(coherent)), np.full(len(random), 1.0 + kappa)]
                if len(candidates) == 0:
                    # Nothing synthesised around p and no random candidate (n_random = 0).
                    candidates = np.array([[(r * 7919 + c) % Ha, (c * 104729 + r) % Wa]])
                    penalty = np.ones(1)

                # --- the distance D of every candidate --------------------------------
                D = distance(I_s, I_t, I_a_pad, a_a_pad, p, candidates, colour_offsets, N_L, w, h)
                best = np.argmin(penalty * D)  # the first of equals, as in the scan

                # --- copy the best candidate's colour, remember where it came from ---
                s[r, c] = candidates[best]
                I_s[r, c] = I_a[s[r, c, 0], s[r, c, 1]]
    return I_s, s


def distance(I_s, I_t, I_a_pad, a_a_pad, p, candidates, colour_offsets, N_L, w, h):
    r""":math:`D = (1 - w)\,\overline{SSD}_{N_U} + w\,\overline{SSD}_{N_L}` per candidate.

    The means run over the pixels of each L that lie inside the output (so an L cut by
    the border weighs as much as a whole one); the colour SSD is also averaged over
    the three channels.
    """
    H, W = I_t.shape
    # Only the neighbours that exist in the output count.
    colour_offsets = colour_offsets[[inside(p + o, H, W) for o in colour_offsets]]
    N_L = N_L[[inside(p + o, H, W) for o in N_L]]

    # Lower L: the target temperature around p against the photo's alpha around p_i.
    t_p = I_t[p[0] + N_L[:, 0], p[1] + N_L[:, 1]]  # (|N_L|,)
    a_pi = a_a_pad[
        candidates[:, None, 0] + h + N_L[None, :, 0], candidates[:, None, 1] + h + N_L[None, :, 1]
    ]  # (n_candidates, |N_L|)
    ssd_L = ((t_p[None] - a_pi).astype(np.float64) ** 2).sum(axis=1) / len(N_L)

    # Upper L: the colours synthesised around p against the photo's around p_i.
    ssd_U = np.zeros(len(candidates))
    if len(colour_offsets):
        c_p = I_s[p[0] + colour_offsets[:, 0], p[1] + colour_offsets[:, 1]]  # (|N_U|, 3)
        c_pi = I_a_pad[
            candidates[:, None, 0] + h + colour_offsets[None, :, 0],
            candidates[:, None, 1] + h + colour_offsets[None, :, 1],
        ]  # (n_candidates, |N_U|, 3)
        ssd_U = ((c_p[None] - c_pi).astype(np.float64) ** 2).sum(axis=(1, 2)) / (
            3 * len(colour_offsets)
        )
    return (1 - w) * ssd_U + w * ssd_L


def inside(q, H, W):
    """Whether pixel ``q`` = (row, col) lies in an H x W image."""
    return 0 <= q[0] < H and 0 <= q[1] < W
