r"""The starter smoke and fire clips: fluidnb's fluid solver and fire method (beyond the paper).

- smoke: :mod:`fluidnb.fluid` (Stable Fluids) plumes with different sources, winds,
  gusts, pulses and vorticity, the density rendered as grey smoke over black;
- fire: :func:`fluidnb.fire.fire` (texture synthesis from the bundled fire photo on a
  simulated temperature) for flames of different sizes, winds and turbulence.

Both are imported when a clip is made, so that the starter package (and with it
:mod:`fluidnb.videodb`) imports neither the solver nor the fire method.
"""

from __future__ import annotations

import math

import numpy as np

from ..._random import rng

__all__ = []


def _double(frames):
    """Bilinear upsampling of (T, h, w[, C]) frames to (T, 2h, 2w[, C]).

    Pixel centres as :func:`fluidnb.fields.resize` (half-pixel aligned, edges
    repeated): each new pixel is 3/4 of its parent and 1/4 of the nearest neighbour.
    """
    rows = _double_axis1(np.asarray(frames, np.float32))
    return np.ascontiguousarray(_double_axis1(rows.swapaxes(1, 2)).swapaxes(1, 2))


def _double_axis1(a):
    out = np.empty((a.shape[0], 2 * a.shape[1], *a.shape[2:]), np.float32)
    even, odd = out[:, 0::2], out[:, 1::2]
    np.multiply(a, np.float32(0.75), out=even)
    even[:, 1:] += np.float32(0.25) * a[:, :-1]
    even[:, :1] += np.float32(0.25) * a[:, :1]
    np.multiply(a, np.float32(0.75), out=odd)
    odd[:, :-1] += np.float32(0.25) * a[:, 1:]
    odd[:, -1:] += np.float32(0.25) * a[:, -1:]
    return out


def _run_fluid(params, grid, n_frames, warmup, gen, report, *, recipe, velocity=False):
    """Step the solver, keep ``n_frames`` frames after ``warmup``.

    Beyond :func:`fluidnb.fluid.simulate`, the recipe may ask for a wind that sways
    (``gust``: amplitude and period in frames), a source that turns on and off
    (``pulse``: frames on, frames off) and more sources (``more``: (x, radius) pairs,
    fractions of the width), heated the way the solver heats its own.

    Returns
    -------
    temperature, density : ndarray, shape (n_frames, H, W), float32
    velocity : ndarray, shape (n_frames, H, W, 2), float32, or None
        Cell-centred, when ``velocity`` is asked for.
    """
    from ...fluid import FluidState, source_mask, step

    gust = recipe.get("gust")
    pulse = recipe.get("pulse")
    masks = [
        source_mask(grid, params.replace(source_x=x, source_radius=r))
        for x, r in recipe.get("more", ())
    ]
    hot = params.source_T - params.T_amb
    total = warmup + n_frames
    state = FluidState.zeros(grid, params)
    temperature = np.empty((n_frames, *grid), np.float32)
    density = np.empty((n_frames, *grid), np.float32)
    flow = np.empty((n_frames, *grid, 2), np.float32) if velocity else None
    variants = {}
    for k in range(total):
        changes = {}
        if gust is not None:
            amplitude, cycle = gust
            # The wind changes every fourth frame, in steps of a tenth of its swing.
            swing = round(10 * math.sin(2.0 * math.pi * (k - k % 4) / cycle)) / 10
            changes["wind"] = params.wind + amplitude * swing * grid[0] / 128
        burning = pulse is None or k % (pulse[0] + pulse[1]) < pulse[0]
        if not burning:
            changes["source_radius"] = 0.0
        key = tuple(sorted(changes.items()))
        if key not in variants:  # replace() validates: keep the few variants made
            variants[key] = params.replace(**changes) if changes else params
        state = step(state, variants[key], rng=gen)
        if masks and burning:
            t = np.array(state.temperature)
            d = np.array(state.density)
            for m in masks:
                target = params.source_T
                if params.source_flicker > 0:
                    noise = gen.uniform(-1.0, 1.0, size=grid)
                    target = params.T_amb + hot * (1.0 + params.source_flicker * noise)
                t += np.maximum(target - t, 0.0) * m
                d += params.density_rate * params.dt * m
            state = FluidState(state.velocity, t, d, state.frame)
        if k >= warmup:
            temperature[k - warmup] = state.temperature
            density[k - warmup] = state.density
            if velocity:
                flow[k - warmup] = state.centred_velocity
        report((k + 1) / total, f"simulating {k + 1}/{total}")
    return temperature, density, flow


def _make_smoke(recipe, size, seed, report):
    from ...fluid import smoke_preset

    gen = rng(seed)
    h, w = size.shape
    # Simulate at half the clip's resolution (the solver's cost, and smoke is soft),
    # with a few extra rows at the bottom holding the source, cut off afterwards.
    grid_h, grid_w = h // 2, w // 2
    margin = max(2, round(0.06 * grid_w))
    grid = (grid_h + margin, grid_w)
    base = smoke_preset(grid, source_x=recipe["source_x"], wind=recipe.get("wind", 0.0)).params
    params = base.replace(
        boundary="open_top",  # the smoke leaves at the top: it keeps moving
        kappa_b=base.kappa_b * recipe.get("buoyancy", 1.0),
        epsilon=base.epsilon * recipe.get("vorticity", 1.0),
        source_y=1.0,  # half the source below the floor, the rest cropped off
        source_radius=recipe.get("radius", 0.06),
        source_flicker=recipe.get("flicker", 0.3),
        density_rate=0.05,
    )
    simulate, render = report.split(0.9)
    _, density, _ = _run_fluid(
        params, grid, size.n_frames, recipe["warmup"], gen, simulate, recipe=recipe
    )
    density = density[:, :grid_h]
    # Optical depth to grey: 1 - exp(-d / d_ref), d_ref set so that the smoke's dense
    # part is light grey whatever the run's total density.
    smoky = density[density > 1e-3]
    ref = float(np.quantile(smoky, 0.9)) / 1.6 if smoky.size else 1.0
    grey = _double(1.0 - np.exp(-density / max(ref, 1e-6)))
    tone = np.asarray(recipe.get("tone", (0.93, 0.95, 1.0)), np.float32)
    frames = np.clip(grey[..., None] * tone, 0.0, 1.0).astype(np.float32)
    render(1.0, "rendered")
    out = {k: v for k, v in recipe.items() if k != "name"}
    out.update(shape=[h, w], n_frames=size.n_frames, grid=list(grid), fluid=params.to_dict())
    return frames, out


_SMOKE = (
    {"name": "plume", "source_x": 0.5, "vorticity": 1.8, "warmup": 120},
    {"name": "wind", "source_x": 0.25, "wind": 0.02, "vorticity": 1.5, "warmup": 110},
    {"name": "puffs", "source_x": 0.55, "pulse": (12, 12), "radius": 0.08, "warmup": 100},
    {
        "name": "turbulent",
        "source_x": 0.7,
        "wind": -0.015,
        "vorticity": 3.0,
        "flicker": 0.6,
        "warmup": 110,
        "tone": (0.95, 0.95, 0.95),
    },
    {
        "name": "billow",
        "source_x": 0.5,
        "radius": 0.14,
        "buoyancy": 0.5,
        "vorticity": 1.5,
        "warmup": 70,
        "tone": (0.97, 0.96, 0.93),
    },
    {"name": "gusts", "source_x": 0.4, "gust": (0.035, 40.0), "vorticity": 1.5, "warmup": 120},
    {
        "name": "twin",
        "source_x": 0.3,
        "more": ((0.7, 0.08),),
        "buoyancy": 1.3,
        "vorticity": 1.5,
        "warmup": 100,
        "tone": (0.9, 0.93, 1.0),
    },
    {
        "name": "drift",
        "source_x": 0.15,
        "wind": 0.035,
        "buoyancy": 0.8,
        "vorticity": 2.2,
        "warmup": 120,
    },
)


def _make_fire(recipe, size, seed, report):
    from ...data import sample
    from ...fire import FireParams, fire
    from ...fluid import flame_preset

    gen = rng(seed)
    h, w = size.shape
    # Like the smoke: simulated and synthesised at half resolution, the sources'
    # rows cut off so the flames rise from below the frame.
    grid_h, grid_w = h // 2, w // 2
    radius = recipe["radius"]
    margin = max(2, round(radius * grid_w * 0.6))
    grid = (grid_h + margin, grid_w)
    params = flame_preset().params.replace(
        source_x=recipe["source_x"],
        source_y=1.0,
        source_radius=radius,
        kappa_b=0.15 * recipe.get("buoyancy", 1.5) * grid_h / 128,
        epsilon=0.4 * recipe.get("vorticity", 1.0) * grid_h / 128,
        wind=recipe.get("wind", 0.0) * grid_h / 128,
        source_flicker=recipe.get("flicker", 0.5),
        C_r=recipe.get("cooling", 0.05),
    )
    # Keyframes every 16 frames, each advected for 24 and cross-dissolved over 8
    # (Furukawa et al.'s N and m): fewer syntheses, the slow part. The paper's set-up
    # (keyframes on the simulation's grid, one frame per simulation frame): the clip
    # is scaled and timed below, as every starter clip is.
    fire_params = FireParams.paper(
        interval=24,
        overlap=8,
        input_size=round(grid_h * recipe.get("photo", 1.1)),
        cutoff=0.0,  # the cut is made above, relative to the source temperature
    )
    # A fresh keyframe looks grainier than one advected for a few frames: start the
    # clip half a segment in, so that its first frame is not a raw keyframe.
    lead = fire_params.interval // 2
    simulate, synthesise = report.split(0.4)
    temperature, _, velocity = _run_fluid(
        params,
        grid,
        size.n_frames + lead,
        recipe.get("warmup", 80) - lead,
        gen,
        simulate,
        recipe=recipe,
        velocity=True,
    )
    # The flame ends where its gas has cooled below ``cut`` of the source's
    # temperature: the faint warm wisps beyond would be synthesised as a dim,
    # speckled glow.
    cut = recipe.get("cut", 0.2) * params.source_T
    photo, matte = sample("fire", return_alpha=True)
    result = fire(
        photo,
        (np.maximum(temperature[:, :grid_h] - cut, 0.0), velocity[:, :grid_h]),
        fire_params,
        matte=matte,
        seed=gen,
        progress=synthesise,
    )
    frames = np.clip(_double(result.clip.frames[lead:]), 0.0, 1.0)
    out = {k: v for k, v in recipe.items() if k != "name"}
    out.update(
        shape=[h, w],
        n_frames=size.n_frames,
        grid=list(grid),
        fluid=params.to_dict(),
        fire=fire_params.to_dict(),
    )
    return frames, out


# Positions and radii are fractions of the grid's width; buoyancy, vorticity and wind
# scale the flame preset's values at 128 rows.
_FIRE = (
    {"name": "flame", "source_x": 0.5, "radius": 0.12},
    {"name": "wind", "source_x": 0.3, "radius": 0.12, "wind": 0.03},
    {
        "name": "bonfire",
        "source_x": 0.5,
        "radius": 0.2,
        "buoyancy": 2.0,
        "vorticity": 1.5,
        "photo": 1.4,
    },
    {
        "name": "gusty",
        "source_x": 0.68,
        "radius": 0.1,
        "buoyancy": 1.8,
        "wind": -0.02,
        "vorticity": 1.8,
        "flicker": 0.9,
    },
    {"name": "pair", "source_x": 0.3, "radius": 0.1, "more": ((0.72, 0.12),)},
    {
        "name": "row",
        "source_x": 0.5,
        "radius": 0.08,
        "more": ((0.17, 0.07), (0.83, 0.09)),
        "vorticity": 1.5,
        "flicker": 0.9,
    },
)
