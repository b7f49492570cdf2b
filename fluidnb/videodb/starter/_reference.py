r"""The starter water clips' flows one frame at a time, in float64 (beyond the paper; slow).

:func:`reference_water_flow` is what the starter clips' ``_water_flow``
(:mod:`fluidnb.videodb.starter._water`) makes for a whole sequence at once in float32;
the tests compare the two.
"""

from __future__ import annotations

import math

import numpy as np

from ._water import _curl, _envelope, _steady_flow, _stream_function, _wavenumbers

__all__ = ["reference_water_flow"]


def reference_water_flow(spec, shape, n_frames, gen):
    r"""A starter water recipe's velocity (T - 1, H, W, 2), one frame at a time in float64.

    Frame :math:`k` is :math:`\bar v (1 + a \sin(2\pi (k / P - s / L) + \phi))` (the
    gust) plus, scaled by the envelope, the curl of the eddies' stream function
    (:math:`\cos\theta_k \hat\psi_1 + \sin\theta_k \hat\psi_2`, shifted by
    :math:`k` times the carry) and each wave :math:`A \cos(2\pi (s / L - k / P) + \phi)
    \hat k_\perp`. :func:`~fluidnb.videodb.starter._water._water_flow` (the starter
    clips' path) makes the whole sequence at once in float32, each term a product of a
    function of time and one of space, from the same random draws: the two agree to
    float32 round-off.
    """
    h, w = shape
    flow = spec["flow"]
    base = _steady_flow(flow, shape, gen)
    n = max(n_frames - 1, 0)
    mean = base.reshape(-1, 2).mean(axis=0)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    envelope = _envelope(flow, shape, gen)[..., None]
    if not n:
        return np.empty((0, h, w, 2), np.float32)
    # The random draws in _water_flow's order: gust phase, eddies, waves' phases.
    gust = flow.get("gust")
    gust_phase = gen.uniform(0, 2 * np.pi) if gust else 0.0
    turbulence = flow.get("turbulence", 0.0)
    scale = flow.get("eddy", 0.14) * min(h, w)
    psi = [_stream_function(shape, gen, scale) for _ in range(2)] if turbulence > 0 else []
    waves = [(*wave, gen.uniform(0, 2 * np.pi)) for wave in flow.get("waves", ())]
    ky, kx = _wavenumbers(shape)
    carry = flow.get("carried", 1.0) * mean
    out = np.empty((n, h, w, 2))
    for k in range(n):
        v = base.copy()
        if gust:
            amplitude, period, wavelength = gust
            along = mean / max(float(np.hypot(*mean)), 1e-12)
            s = yy * along[0] + xx * along[1]
            swell = amplitude * np.sin(2 * np.pi * (k / period - s / wavelength) + gust_phase)
            v *= (1.0 + swell)[..., None]
        unsteady = np.zeros((h, w, 2))
        if psi:
            theta = 2.0 * np.pi * k / flow.get("cycle", 24.0)
            spectrum = math.cos(theta) * psi[0] + math.sin(theta) * psi[1]
            spectrum = spectrum * np.exp(-1j * k * (ky * carry[0] + kx * carry[1]))
            unsteady += turbulence * np.stack(_curl(spectrum, shape), axis=-1)
        for amplitude, period, wavelength, angle, phi in waves:
            rad = math.radians(angle)
            direction = np.array([-math.sin(rad), math.cos(rad)])
            s = yy * direction[0] + xx * direction[1]
            wave = amplitude * np.cos(2 * np.pi * (s / wavelength - k / period) + phi)
            unsteady += wave[..., None] * np.array([direction[1], -direction[0]])
        out[k] = v + unsteady * envelope
    return out.astype(np.float32)
