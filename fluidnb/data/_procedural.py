"""Procedural sample images: computed on demand, deterministic, no files.

Every generator takes the output shape ``(H, W)`` and returns ``(image, alpha)``
with float64 values in [0, 1] (``alpha`` is ``None`` when the sample has no matte);
:func:`fluidnb.data.sample` converts to float32 once, through ``as_image``.

The pictures are continuous functions of position measured in units of the longest
side (sums of sinusoids with fixed, seeded parameters), so a larger ``size`` shows the
same picture with more pixels rather than a different random texture.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PROCEDURAL"]

# Seeds of the fixed random parameters (wave directions, phases): part of each
# sample's definition, never the global numpy state.
_SEED_RIPPLES = 20240611
_SEED_FLAME = 7
_SEED_SMOKE = 11
_SEED_WINDOW = 3


def _grid(shape):
    """Pixel-centre coordinates (y, x) in units of the longest side, as (H, 1), (1, W)."""
    h, w = shape
    side = float(max(h, w))
    y = ((np.arange(h, dtype=np.float64) + 0.5) / side)[:, None]
    x = ((np.arange(w, dtype=np.float64) + 0.5) / side)[None, :]
    return y, x


def _waves(shape, seed, n, fmin, fmax, slope=1.0, angle=None, spread=np.pi):
    """Sum ``n`` plane waves into a field of unit variance (spectral synthesis).

    Frequencies (cycles per longest side) are log-uniform in [fmin, fmax], amplitudes
    fall as ``f ** -slope``; directions are uniform within ``spread`` around ``angle``
    (radians, 0 = along x), or uniform over all directions if ``angle`` is None.
    """
    gen = np.random.default_rng(seed)
    freq = np.exp(gen.uniform(np.log(fmin), np.log(fmax), n))
    theta = (
        gen.uniform(-np.pi, np.pi, n)
        if angle is None
        else angle + gen.uniform(-0.5, 0.5, n) * spread
    )
    phase = gen.uniform(0.0, 2.0 * np.pi, n)
    amp = freq**-slope
    amp /= np.sqrt(np.sum(amp**2) / 2.0)  # unit variance for independent phases
    y, x = _grid(shape)
    out = np.zeros(shape, dtype=np.float64)
    for f, t, p, a in zip(freq, theta, phase, amp, strict=True):
        # sin(u + v) = sin u cos v + cos u sin v: two outer products, no (H, W) sin.
        u = 2.0 * np.pi * f * np.cos(t) * x + p
        v = 2.0 * np.pi * f * np.sin(t) * y
        out += a * (np.sin(u) * np.cos(v) + np.cos(u) * np.sin(v))
    return out


def _smoothstep(lo, hi, v):
    t = np.clip((v - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _ramp(v, stops, colours):
    """Piecewise-linear colour map of ``v`` (H, W) through (stop, RGB) pairs."""
    colours = np.asarray(colours, dtype=np.float64)
    return np.stack([np.interp(v, stops, colours[:, c]) for c in range(3)], axis=-1)


def gradient(shape):
    """Smooth RGB ramps: red grows to the right, green downwards, blue falls diagonally."""
    h, w = shape
    u = np.linspace(0.0, 1.0, w)[None, :] if w > 1 else np.full((1, 1), 0.5)
    v = np.linspace(0.0, 1.0, h)[:, None] if h > 1 else np.full((1, 1), 0.5)
    r = np.broadcast_to(u, shape)
    g = np.broadcast_to(v, shape)
    b = 1.0 - 0.5 * (r + g)
    return np.stack([r, g, b], axis=-1), None


def checker(shape):
    """Black and white squares, eight along the longest side, white at the top left."""
    y, x = _grid(shape)
    parity = (np.floor(y * 8.0).astype(np.int64) + np.floor(x * 8.0).astype(np.int64)) % 2
    return (1.0 - parity).astype(np.float64), None


def ripples(shape):
    """Wind-blown water: waves travelling mostly one way, shaded blue-green, with glints."""
    height = _waves(shape, _SEED_RIPPLES, 40, 3.0, 40.0, slope=1.0, angle=np.pi / 2, spread=1.4)
    fine = _waves(shape, _SEED_RIPPLES + 1, 24, 25.0, 90.0, slope=0.5)
    h = np.tanh(0.45 * (height + 0.35 * fine))  # in (-1, 1), mostly within +-0.8
    t = 0.5 * (h + 1.0)
    rgb = _ramp(
        t,
        [0.0, 0.45, 0.8, 1.0],
        [(0.02, 0.16, 0.28), (0.08, 0.36, 0.50), (0.30, 0.62, 0.72), (0.70, 0.88, 0.92)],
    )
    glint = _smoothstep(0.78, 0.98, t)[..., None]
    rgb = rgb * (1.0 - glint) + glint
    return np.clip(rgb, 0.0, 1.0), None


def flame(shape):
    """Draw a single flame over black (premultiplied colour) and its alpha matte."""
    h, w = shape
    side = float(max(h, w))
    y, x = _grid(shape)
    base, top = 0.96 * h / side, 0.04 * h / side
    t = np.clip((base - y) / (base - top), 0.0, 1.0)  # 0 at the base, 1 at the tip
    cx = 0.5 * w / side
    # The flame leans and flickers more towards its tip.
    sway = 0.06 * (h / side) * _waves(shape, _SEED_FLAME, 10, 1.0, 4.0, angle=np.pi / 2, spread=0.5)
    lick = _waves(shape, _SEED_FLAME + 1, 32, 3.0, 20.0, slope=0.8, angle=np.pi / 2, spread=1.2)
    width = 0.36 * min(h, w) / side * np.sqrt(np.clip(t / 0.18, 0.0, 1.0)) * (1.0 - t) ** 1.1
    width = width * (1.0 + 0.25 * t * lick)
    d = np.abs(x - cx - sway * t**1.5) / np.maximum(width, 1e-9)
    body = np.clip(1.0 - d**2, 0.0, 1.0) * (width > 1e-9)
    heat = np.sqrt(body) * (1.0 - 0.55 * t) * (1.0 + 0.08 * lick)
    heat = np.clip(heat, 0.0, 1.0)
    rgb = _ramp(
        heat,
        [0.0, 0.15, 0.4, 0.65, 0.85, 1.0],
        [
            (0.0, 0.0, 0.0),
            (0.4, 0.03, 0.0),
            (0.92, 0.28, 0.02),
            (1.0, 0.62, 0.1),
            (1.0, 0.88, 0.45),
            (1.0, 0.98, 0.85),
        ],
    )
    alpha = _smoothstep(0.0, 0.35, heat)
    return np.clip(rgb, 0.0, 1.0), alpha


def smoke(shape):
    """Draw a plume of grey smoke rising from the bottom centre over a dark background."""
    h, w = shape
    side = float(max(h, w))
    y, x = _grid(shape)
    t = np.clip((h / side - y) / (h / side), 0.0, 1.0)  # 0 at the bottom, 1 at the top
    cx = 0.5 * w / side
    wander = _waves(shape, _SEED_SMOKE, 10, 1.0, 4.0, angle=np.pi / 2, spread=0.4)
    meander = 0.08 * (w / side) * wander
    radius = (0.05 + 0.28 * t) * min(h, w) / side
    plume = np.exp(-(((x - cx - meander * t) / radius) ** 2))
    puffs = _waves(shape, _SEED_SMOKE + 1, 48, 3.0, 48.0, slope=1.0)
    density = np.clip(plume * (0.75 + 0.3 * puffs) * (1.0 - 0.35 * t), 0.0, 1.0)
    alpha = _smoothstep(0.05, 0.9, density)
    background = np.array([0.08, 0.09, 0.12])
    colour = np.array([0.86, 0.86, 0.88])
    rgb = background * (1.0 - alpha[..., None]) + colour * alpha[..., None]
    return np.clip(rgb, 0.0, 1.0), alpha


def window(shape):
    """Soft bluish glass: a sky-lit pane with two faint diagonal reflections."""
    h, w = shape
    side = float(max(h, w))
    y, x = _grid(shape)
    v = y / (h / side)  # 0 at the top, 1 at the bottom
    top = np.array([0.55, 0.68, 0.82])
    bottom = np.array([0.80, 0.87, 0.93])
    rgb = top + (bottom - top) * v[..., None]
    diag = (x + 0.6 * y) / 1.6
    broad = np.exp(-(((diag - 0.30) / 0.05) ** 2))
    thin = np.exp(-(((diag - 0.42) / 0.02) ** 2))
    streak = 0.10 * broad + 0.06 * thin
    haze = 0.02 * _waves(shape, _SEED_WINDOW, 8, 1.0, 4.0)
    rgb = rgb + (streak + haze)[..., None]
    cy, cxx = 0.5 * h / side, 0.5 * w / side
    vignette = 1.0 - 0.12 * ((y - cy) ** 2 + (x - cxx) ** 2) / (cy**2 + cxx**2)
    return np.clip(rgb * vignette[..., None], 0.0, 1.0), None


def _spec(generator, shape, channels, has_alpha, description, methods):
    return {
        "generator": generator,
        "shape": shape,
        "channels": channels,
        "has_alpha": has_alpha,
        "description": description,
        "methods": methods,
    }


# name -> how to make it, its default (H, W), channels (1 grey, 3 RGB), whether it has
# an alpha matte, and what it is for (the README's method names, or "any").
PROCEDURAL = {
    "gradient": _spec(gradient, (96, 128), 3, False, "smooth RGB ramps: a test image", ["any"]),
    "checker": _spec(
        checker, (64, 64), 1, False, "black and white checkerboard, 8 squares a side", ["any"]
    ),
    "ripples": _spec(
        ripples,
        (128, 128),
        3,
        False,
        "wind-blown water: a sum of waves shaded blue-green, with glints",
        ["flicker", "videodb"],
    ),
    "flame": _spec(
        flame, (128, 96), 3, True, "a synthetic flame over black, with its alpha matte", ["fire"]
    ),
    "smoke": _spec(
        smoke,
        (128, 96),
        3,
        True,
        "a rising plume of grey smoke over a dark background, density as alpha",
        ["videodb", "turbulence"],
    ),
    "window": _spec(
        window,
        (96, 128),
        3,
        False,
        "soft bluish glass with faint reflections: a frost background",
        ["frost"],
    ),
}
