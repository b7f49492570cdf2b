"""``fluidnb frost``: frost growing over a painted region of an image."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_output_option, add_params_options, add_seed_option, params_from_args
from ._paths import add_input, add_output
from ._photo import Photo, add_max_side_option


def _start_point(text):
    """Parse ``X,Y`` (column, row in pixels) into (row, col)."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"start point must be X,Y (column,row in pixels), got {text!r}"
        ) from None
    return (y, x)


def register(sub):
    """Add the ``frost`` subcommand."""
    from ..frost import FrostParams

    p = sub.add_parser(
        "frost",
        help="frost growing over a painted region (Amano, Sato & Itoh; Reiter 2005)",
        description=(
            "Grow frost over the white part of MASK on IMAGE from one or more start "
            "points, with Reiter's hexagonal automaton and the paper's random threshold "
            "rth; with --target, first optimise beta so that 90% of the region is ice "
            "at that frame. Defaults are the paper's (beta 0.35, gamma 0.005, rth 0, "
            "24 fps) and Reiter's alpha = 1."
        ),
        epilog=(
            "Start points are X,Y = column,row in image pixels (as image editors show "
            "them), counted from the top-left pixel; they must lie in the region. "
            "Example: fluidnb frost leaf.png --region mask.png --start 240,180 "
            "--target 130 -o frost.mp4"
        ),
    )
    add_input(p, "image", metavar="IMAGE", help="the picture (any format Pillow reads)")
    add_input(
        p,
        "--region",
        default=None,
        metavar="MASK",
        help="where frost may grow: an image of the same size, white = frost "
        "(default: the whole image)",
    )
    p.add_argument(
        "--start",
        dest="starts",
        action="append",
        type=_start_point,
        required=True,
        metavar="X,Y",
        help="a start point, X,Y = column,row in pixels (repeat for several)",
    )
    add_params_options(p, FrostParams)
    p.add_argument(
        "--solver",
        choices=("secant", "steepest"),
        default="secant",
        help="how --target optimises beta: 'secant' (bracketing + secant, robust) or "
        "'steepest' (the paper's steepest descent, Eq. (3)); default secant",
    )
    p.add_argument(
        "--fit-gamma",
        action="store_true",
        help="with --target: first set gamma so the run ends near the target (the "
        "mass-balance estimate, corrected by a few short runs), then optimise beta; the "
        "paper's gamma = 0.005 takes thousands of frames on a region painted by hand",
    )
    p.add_argument(
        "--eta",
        type=float,
        default=1e-6,
        help="eta of the steepest descent (the paper: 1e-6)",
    )
    p.add_argument(
        "--fd-step",
        type=float,
        default=0.01,
        help="finite-difference step h of the steepest descent (default 0.01)",
    )
    p.add_argument("--every", type=int, default=1, help="draw every k-th step (default 1)")
    p.add_argument("--size", type=int, default=None, help="longest side of the output in pixels")
    add_max_side_option(p)
    add_output(
        p,
        "--freeze-times",
        default=None,
        metavar="NPZ",
        help="also save each cell's freeze frame and pixel position to this .npz",
    )
    add_seed_option(p)
    add_output_option(p)
    p.set_defaults(func=_frost)


def _frost(args):
    import numpy as np

    from .._image import as_mask
    from .._media import write_atomically
    from .._progress import TextProgress
    from .._random import resolve_seed
    from ..frost import (
        FrostParams,
        HexLattice,
        estimate_end_frame,
        gamma_for_target,
        grow,
        optimise_beta,
        render,
    )
    from ..frost._render import check_image_size

    params = params_from_args(FrostParams, args)
    if args.freeze_times is not None and not args.freeze_times.endswith(".npz"):
        raise ValueError(f"--freeze-times must end in .npz, got {args.freeze_times!r}")
    photo = Photo(args.image, "IMAGE", args.max_side)
    image = photo.read(mode="rgb")
    check_image_size(image.shape, f"IMAGE {args.image!r}")
    if args.region is None:
        region = np.ones(image.shape[:2], bool)
    else:
        region = as_mask(photo.companion(args.region, "--region", mode="grey"), name="--region")
    photo.note(args.prog)
    lattice = HexLattice.from_mask(region, params.spacing)
    given = np.array(args.starts, float)  # (row, col) in the photo's pixels
    points = photo.points([given])[0]  # in the image worked on
    for (row, col), (row0, col0) in zip(points, given):
        try:
            lattice.snap([row, col])
        except ValueError:
            raise ValueError(
                f"--start {col0:g},{row0:g} (X,Y = column,row) is outside the region; "
                "place start points on the white part of --region"
            ) from None
    starts = lattice.snap(points)
    # One seed for the optimiser and the clip (common random numbers), printed so the
    # clip can be made again.
    seed = resolve_seed(args.seed)
    print(f"lattice: {lattice.n_cells} cells, spacing {params.spacing:g} px")
    # Say up front how long it will take (the balance of vapour), before anyone waits.
    est = estimate_end_frame(lattice, starts, params)
    print(f"at gamma = {params.gamma:g} the frost {est}")
    if est.likely > params.max_frames:
        print(f"  beyond --max-frames {params.max_frames}: raise --gamma (or use --fit-gamma)")
    if args.fit_gamma:
        if args.target is None:
            raise ValueError("--fit-gamma needs --target: the end frame to fit gamma to")
        fit = gamma_for_target(lattice, starts, params.target, params, seed=seed)
        params = params.replace(gamma=fit.gamma)
        print(f"gamma = {fit.gamma:.4g} ends at frame {fit.end_frame} (target {fit.target})")
    optimise = None
    if args.target is not None:
        result = optimise_beta(
            lattice,
            starts,
            params.target,
            params,
            method=args.solver,
            eta=args.eta,
            h=args.fd_step,
            seed=seed,
            progress=TextProgress(),
        )
        print(f"optimising beta for end frame {result.target} ({args.solver}):")
        print(result.table())
        print(result.message)
        params = params.replace(beta=result.beta)
        optimise = result.to_dict()
    grown = grow(lattice, starts, params, seed=seed, progress=TextProgress())
    print(f"beta = {params.beta:.6g}: {grown.message}")
    # Streamed: the frames go to the file a few at a time as they are drawn.
    clip = render(
        image,
        lattice,
        grown,
        every=args.every,
        size=args.size,
        stream=True,
        progress=TextProgress(),
    )
    extra = {"seed": seed, "n_cells": lattice.n_cells, **photo.metadata()}
    if optimise is not None:
        extra["optimise"] = optimise
    clip = clip.with_metadata(**extra)
    out = clip.save(args.output)
    print(f"wrote {out} ({len(clip)} frames, {clip.fps:g} fps, seed {seed})")
    if args.freeze_times is not None:
        arrays = {
            "freeze_frame": grown.freeze_frame,
            "points_rc": lattice.points,
            "end_frame": -1 if grown.end_frame is None else grown.end_frame,
            "spacing": lattice.spacing,
        }

        def write(tmp):
            with open(tmp, "wb") as f:  # a file object: numpy would append ".npz" to a name
                np.savez_compressed(f, **arrays)

        write_atomically(Path(args.freeze_times), write)
        print(f"wrote {args.freeze_times} (freeze frame of {lattice.n_cells} cells)")
    return 0
