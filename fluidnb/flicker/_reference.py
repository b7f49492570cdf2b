r"""The flicker model written out literally: one 3-D spectrum, one 3-D inverse DFT.

This is the method as the paper states it (Yamamoto & Sakamoto, sec. 2.1 and 3),
in its own notation and in plain numpy: no grouping of the temporal bins, no pruned
transforms, no thread pool. It holds the whole spectrum :math:`U(f_x, f_y, f_t)` in
memory (``T`` times the image), so it is for small images: the tests check
:class:`~fluidnb.flicker.FlickerModel` (the fast path) against it, and the lesson
teaches from it before switching to the fast path. Use
:func:`fluidnb.flicker.flicker` for real work.
"""

from __future__ import annotations

import math

import numpy as np

from .._image import as_image
from .._random import resolve_seed, rng
from ._flow import as_velocity
from ._params import FlickerParams
from ._shading import apply_shading, feather_weights, shade
from ._spectrum import height_from_luminance, region_weights, soft_clip

__all__ = ["flicker_reference"]


def flicker_reference(image, params=None, *, flow=None, seed=None):
    r"""Heights and frames of the whole loop, straight from Eq. (1)-(10).

    Parameters
    ----------
    image : array_like, shape (H, W) or (H, W, 3)
        A small photo (the whole image is animated).
    params : FlickerParams, optional
        The paper's values by default.
    flow : velocity (dy, dx) or stroke(s), optional
        For ``mapping="flow"``, as for :func:`~fluidnb.flicker.flicker`.
    seed : None, int or numpy.random.Generator
        For the noise phases :math:`\phi(f_t)`.

    Returns
    -------
    H : ndarray, shape (T, H, W), float64
        The height :math:`H(x, y, t)`.
    frames : ndarray, shape (T, H, W[, 3]), float32
        The shaded frames :math:`O_t`.

    Examples
    --------
    >>> img = np.random.default_rng(0).random((8, 12))
    >>> H, frames = flicker_reference(img, FlickerParams(T=8, f0=2, beta=0))
    >>> bool(np.allclose(H[0], img, atol=1e-6)), frames.shape
    (True, (8, 8, 12))
    """
    p = FlickerParams() if params is None else params
    T, A, C = p.T, p.A, p.C
    I = as_image(image)  # noqa: E741  (the paper's I, the input image)
    seed = resolve_seed(seed)

    # Sec. 2.1: the luminance is the initial height H(0).
    H0 = height_from_luminance(I).astype(np.float64)
    # Eq. (3): the initial phase, on the rising (|alpha| <= pi/2) or falling branch.
    alpha = np.arcsin(np.clip((H0 - C) / A, -1, 1))
    if p.branch == "falling":
        alpha = np.where(alpha > 0, np.pi - alpha, -np.pi - alpha)

    # The flow mapping moves the pattern round the periodic DFT domain: a mirrored
    # margin upstream keeps the seam out of view (the fast path's _pad_upstream).
    v = as_velocity(flow, T) if p.mapping == "flow" else None
    pads = [(0, 0), (0, 0)]
    if v is not None:
        from scipy.fft import next_fast_len

        for axis in (0, 1):
            n = alpha.shape[axis]
            if v[axis] != 0:
                extra = next_fast_len(n + math.ceil(T * abs(v[axis])) + 2) - n
                pads[axis] = (extra, 0) if v[axis] > 0 else (0, extra)
    a = np.pad(alpha, pads, mode="symmetric")
    h, w = a.shape
    window = (slice(None),) + tuple(slice(lo, lo + n) for (lo, _), n in zip(pads, alpha.shape))

    # Eq. (4): the 2-D DFT of e^{j alpha}.
    F = np.fft.fft2(np.exp(1j * a))

    # Eq. (6)-(9): the temporal frequency f_c of every spatial frequency (nu in cycles
    # per pixel), rounded to a whole bin so the clip loops.
    nu_y = np.fft.fftfreq(h)[:, None]
    nu_x = np.fft.fftfreq(w)[None, :]
    curvature = p.kappa * (math.ceil(T / 2) - 1 - p.f0) / 0.5
    fc = {
        "plane": p.f0 + 0 * (nu_x + nu_y),
        "convex": p.f0 + curvature * (nu_x**2 + nu_y**2),
        "concave": p.f0 - curvature * (nu_x**2 + nu_y**2),
        "flow": p.f0 - T * ((v[0] * nu_y + v[1] * nu_x) if v is not None else 0 * nu_x),
    }[p.mapping]
    fc = np.rint(fc)

    # Eq. (10): spread each component along f_t with amplitude 1/|f_t - f_c|^(beta/2)
    # (distance around the circle of T bins, weight 1 at f_c) and a random phase
    # phi(f_t). The factor T undoes the 1/T of the inverse DFT over time.
    f_t = np.arange(T)[:, None, None]
    d = np.abs(f_t - np.mod(fc, T))
    d = np.minimum(d, T - d)
    #
    # Eq. (5): the 3-D inverse DFT; the height is C + A Im(I_out).
    if p.beta == 0:
        x = np.fft.ifftn(T * F * (d == 0))[window].imag
    else:
        weight = np.where(d == 0, 1.0, np.maximum(d, 1) ** (-p.beta / 2))
        draw = rng(seed)
        phis = [draw.uniform(0, 2 * np.pi, T)[:, None, None] for _ in range(p.noise_regions)]
        # Beyond the paper (noise_regions > 1): each soft region its own phi, blended.
        blend = region_weights(alpha.shape, p.noise_regions, seed=draw)
        blend /= np.sqrt(np.sum(blend**2, axis=0))
        x = 0
        for phi, w_g in zip(phis, blend):
            U = T * F * weight * np.exp(1j * phi)
            x = x + w_g * np.fft.ifftn(U)[window].imag
    if p.beta > 0 and p.noise_norm == "peak":
        x = x / np.abs(x).max()  # the loudest moment reaches C +- A
    elif p.beta > 0:
        # The RMS of the same mapping without noise, then a soft clip into (-1, 1).
        quiet = np.fft.ifftn(T * F * (d == 0))[window].imag
        x = soft_clip(x * np.sqrt(np.mean(quiet**2)) / np.sqrt(np.mean(x**2)))
    H = C + A * x

    # Sec. 2.1 and our decision: bump-map the height, Lambert shading S_t, and change
    # the photo's brightness by S_t - S_0 (S_0: the shading of the rest height).
    light = {"azimuth": p.azimuth, "elevation": p.elevation, "bump": p.bump}
    S = shade(H, **light)
    S0 = shade(C + A * np.sin(alpha), **light)
    weight = feather_weights(np.ones(H0.shape, bool), p.feather)
    return H, apply_shading(I, S, S0, p.k, weight)
