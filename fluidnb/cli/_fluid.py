"""``fluidnb simulate``: run the Stable Fluids flame/smoke solver."""

from __future__ import annotations

import argparse

from ._common import add_fps_option, add_output_option, add_params_options, add_seed_option


def _shape(text):
    """Parse ``H,W``."""
    try:
        h, w = (int(v) for v in text.split(","))
    except ValueError:
        msg = f"shape must be H,W (rows,columns), got {text!r}"
        raise argparse.ArgumentTypeError(msg) from None
    return (h, w)


def register(sub):
    """Add the ``simulate`` subcommand."""
    from ..fluid import FluidParams

    p = sub.add_parser(
        "simulate",
        help="2-D flame or smoke simulation (Stable Fluids; Furukawa et al. 2013, sec. 3.1)",
        description=(
            "Simulate a 2-D flame or smoke plume with Stam's Stable Fluids: semi-"
            "Lagrangian advection, buoyancy (Eq. 4), vorticity confinement (Eq. 5), an "
            "exact pressure projection and radiative cooling (Eq. 3). The .npz output "
            "holds every frame's velocity (staggered, (dy, dx) px/frame), temperature "
            "and density; a .gif, .mp4 or folder output holds the colour-mapped "
            "--field instead. Parameter options override the preset's values."
        ),
        epilog="Example: fluidnb simulate --preset flame --frames 120 --seed 1 -o flame.npz",
    )
    p.add_argument(
        "--preset",
        choices=("flame", "smoke"),
        default="flame",
        help="flame (128 x 128, open top; default) or smoke (closed box, 128 x 192)",
    )
    p.add_argument(
        "--shape", type=_shape, default=None, metavar="H,W", help="grid size (default: preset's)"
    )
    p.add_argument(
        "--frames", type=int, default=None, metavar="N", help="frames (default: preset's)"
    )
    p.add_argument("--substeps", type=int, default=None, help="solver steps per frame")
    p.add_argument(
        "--field",
        choices=("temperature", "density"),
        default=None,
        help="what a .gif/.mp4/folder output shows (default: temperature for the flame, "
        "density for the smoke)",
    )
    add_fps_option(p, 24.0, "frame rate of a video output")
    add_params_options(p, FluidParams)
    add_seed_option(p)
    add_output_option(
        p, help="OUT.npz (the simulation's arrays) or .gif, .mp4, a folder (a clip of --field)"
    )
    p.set_defaults(func=_simulate)


def _simulate(args):
    import dataclasses

    from .._progress import TextProgress
    from ..fluid import FluidParams, flame_preset, simulate, smoke_preset

    if args.preset == "flame":
        preset = flame_preset()
        if args.shape is not None:
            preset = dataclasses.replace(preset, shape=args.shape)
    else:
        preset = smoke_preset((128, 192) if args.shape is None else args.shape)
    given = {
        name: getattr(args, name)
        for name in FluidParams.specs()
        if getattr(args, name, None) is not None
    }
    params = preset.params.replace(**given)
    sim = simulate(
        params,
        preset.n_frames if args.frames is None else args.frames,
        shape=preset.shape,
        seed=args.seed,
        progress=TextProgress(),
        substeps=preset.substeps if args.substeps is None else args.substeps,
    )
    rate = sim.timings["steps_per_second"]
    if str(args.output).endswith(".npz"):
        out = sim.save(args.output)
    else:
        field = args.field or ("temperature" if args.preset == "flame" else "density")
        out = sim.to_clip(field, fps=args.fps).save(args.output)
    h, w = sim.shape
    print(f"wrote {out} ({len(sim)} frames, {h}x{w}, {rate:.0f} steps/s, seed {sim.seed})")
    return 0
