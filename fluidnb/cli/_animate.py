"""``fluidnb animate``: bring a photo of fluid to life from a video database (Okabe et al.)."""

from __future__ import annotations

import time

from ._common import (
    add_fps_option,
    add_output_option,
    add_params_options,
    add_seed_option,
    reuse_freed_memory,
)
from ._paths import add_input
from ._photo import Photo, add_max_side_option

_STARTERS = ("water", "smoke", "fire")


def register(sub):
    """Add the ``animate`` subcommand."""
    from ..videodb import AnimateParams

    p = sub.add_parser(
        "animate",
        help="animate a still photo of water, smoke or fire from a video database (Okabe et al.)",
        description=(
            "Cut PHOTO into 48 x 48 fragments, give each the database fragments that look "
            "most like it (histogram intersection of visual words, Eq. 1), choose among "
            "them by alpha-expansion on an MRF whose smoothness term compares the "
            "neighbours' motion spectra and textureness (Eq. 4-6: sigma, lambda, rho), "
            "then render. --rendering flow (the default, beyond the paper) moves the photo "
            "itself along the chosen fragments' motion (at the painted speed where you "
            "painted one) in a seamless loop and adds their difference frames on top; "
            "--rendering paper blends the difference frames by Laplacian pyramids over a "
            "motion-blurred photo (Okabe et al., sec. 6). Both are histogram-matched to "
            "the photo and composited through the matte. --db water|smoke|fire uses a "
            "starter database (built on first use, about a minute, and cached); a folder "
            "uses your own database "
            "(`fluidnb videodb build`). Only the matte's region moves."
        ),
        epilog=(
            "Examples: fluidnb animate river.jpg --matte river-matte.png --db water -o "
            "river.mp4 | fluidnb animate fire.png --db fire --strokes up.json --speed "
            'speed.png --sigma 1000 -o fire.gif. A strokes file is JSON: {"format": '
            '"fluidnb.strokes", "version": 1, "shape": [H, W], "strokes": [[[row, '
            "col], ...], ...]}, each stroke drawn along the flow (the app saves it)."
        ),
    )
    add_input(p, "photo", metavar="PHOTO", help="the still image (RGBA: its alpha is the matte)")
    add_input(
        p,
        "--matte",
        default=None,
        metavar="MATTE",
        help="the fluid region: a grey image, white = fluid (default: the alpha, else all)",
    )
    add_input(
        p,
        "--db",
        is_path=_is_folder_name,
        default="water",
        metavar="DB",
        help="water, smoke or fire (starter databases) or a database folder (default water)",
    )
    p.add_argument(
        "--quick", action="store_true", help="use the small starter databases (seconds to build)"
    )
    add_input(
        p,
        "--strokes",
        default=None,
        metavar="STROKES.json",
        help="flow strokes: the direction the fluid moves (Okabe et al., Fig. 8-a)",
    )
    add_input(
        p,
        "--speed",
        default=None,
        metavar="SPEED",
        help="a grey speed map: white = --max-speed px/frame, black = not painted",
    )
    p.add_argument(
        "--max-speed",
        type=float,
        default=4.0,
        metavar="PX",
        help="the speed of white in --speed, px/frame (default 4)",
    )
    add_input(
        p,
        "--background",
        default=None,
        metavar="IMAGE",
        help="what a moving outline uncovers (--tau > 0; default: the photo inpainted)",
    )
    add_max_side_option(p)
    p.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="T",
        help="the clip's length: whole repeats of the database's loop (N - loop frames, "
        "24 for the starters; --rendering flow only; default: what --travel needs, "
        "at most 4 repeats)",
    )
    add_fps_option(p, 24.0, "frame rate of the output (24)")
    group = add_params_options(p, AnimateParams)
    group.add_argument(
        "--lambda", dest="lam", type=float, default=None, metavar="LAM", help="the same as --lam"
    )
    add_seed_option(p)
    add_output_option(p)
    p.set_defaults(func=_animate)


def _is_folder_name(db):
    """``--db`` names a folder unless it is a starter database's name."""
    return db not in _STARTERS


def _animate(args):
    import numpy as np

    from .._progress import TextProgress
    from ..sketch import load_strokes
    from ..videodb import AnimateParams, animate, open_database, starter_database

    picture = Photo(args.photo, "photo", args.max_side)
    image, alpha = picture.read(mode="rgb", return_alpha=True)
    shape = image.shape[:2]
    matte = None if args.matte is None else picture.companion(args.matte, "matte", mode="grey")
    strokes = None
    if args.strokes is not None:
        strokes = picture.points(load_strokes(args.strokes, picture.original)[0])
    speed = None
    if args.speed is not None:
        if not args.max_speed > 0:
            raise ValueError(f"--max-speed must be > 0 px/frame, got {args.max_speed:g}")
        # px/frame of the photo, so px/frame of the image worked on once scaled with it
        white = np.float32(args.max_speed * picture.speed_scale)
        speed = picture.companion(args.speed, "speed", mode="grey") * white
    background = None
    if args.background is not None:
        background = picture.companion(args.background, "background", mode="rgb")
    picture.note(args.prog)
    reuse_freed_memory()
    report = TextProgress()
    if args.db in _STARTERS:
        db = starter_database(args.db, quick=args.quick or None, progress=report)
    else:
        db = open_database(args.db, progress=report)
    # The kind's defaults (a moving outline for fire and smoke), then what was given.
    given = {k: getattr(args, k) for k in AnimateParams.specs() if getattr(args, k) is not None}
    params = AnimateParams.for_kind(db.kind, **given)
    # An RGBA photo's alpha is its matte unless one is given (animate reads it there).
    photo = np.dstack([image, alpha]) if alpha is not None and matte is None else image
    started = time.perf_counter()
    result = animate(
        photo,
        matte,
        db,
        params,
        direction=strokes,
        speed=speed,
        background=background,
        fps=args.fps,
        seed=args.seed,
        progress=report,
        stream=True,
        frames=args.frames,
    )
    # Streamed: the frames go to the file a run at a time as they are made (a
    # full-size photo's clip is never held: issue 39).
    out = result.clip.with_metadata(**picture.metadata()).save(args.output)
    a = result.assignment
    t = result.timings
    # The render's own clock sums its stages, which overlap on the cores (the next
    # frames blended while these are made): what the user waited is the wall clock.
    rendered = time.perf_counter() - started - t.get("assign_total", 0)
    print(
        f"wrote {out} ({len(result.clip)} frames, {shape[0]}x{shape[1]}): {len(a.target)} "
        f"fragments from {len(set(db.clip_of(a.fragments).tolist()))} clips of {db.kind!r}, "
        f"energy {a.solution.energy:.4g} (ICM {a.solution.icm_energy:.4g}), assigned in "
        f"{t.get('assign_total', 0):.1f} s, rendered and written in {rendered:.1f} s"
    )
    note = a.stillness_note()
    if note is not None:
        print(f"note: {note}")
    return 0
