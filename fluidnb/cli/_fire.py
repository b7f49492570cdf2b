"""``fluidnb fire``: fire that looks like a photo and moves like a simulation."""

from __future__ import annotations

from ._common import add_output_option, add_params_options, add_seed_option, params_from_args
from ._paths import add_input, add_output
from ._photo import Photo, add_max_side_option


def register(sub):
    """Add the ``fire`` subcommand."""
    from ..fire import FireParams

    p = sub.add_parser(
        "fire",
        help="fire from a photo on a fluid simulation (Furukawa, Dobashi & Yamamoto 2013)",
        description=(
            "Texture-synthesise PHOTO onto the temperature of a 2-D fluid simulation at "
            "keyframes (Ashikhmin's method with user control), advect the result with "
            "the simulation's velocity between keyframes and cross-dissolve "
            "overlapping segments. The simulation is read from --sim (an .npz written "
            "by `fluidnb simulate` or Simulation.save, or any .npz with 'temperature' "
            "(T, H, W) and 'velocity' (T, H, W, 2) arrays) or, without --sim, the "
            "flame preset is simulated. By default the keyframes are synthesised at "
            "256 px on the longer side and the clip has 24 frames a second (in-between "
            "frames advected); --paper gives the paper's set-up (keyframes on the "
            "simulation's grid, one frame per simulation frame: 128 x 128, 8 fps)."
        ),
    )
    add_input(
        p,
        "photo",
        metavar="PHOTO",
        help="a photo of fire on a dark background, or a cut-out (RGBA: its alpha is the matte)",
    )
    add_input(
        p,
        "--matte",
        default=None,
        metavar="MATTE",
        help="the photo's alpha matte, same size (default: its alpha channel, if any)",
    )
    add_input(
        p,
        "--sim",
        default=None,
        metavar="SIM.npz",
        help="the fluid simulation (default: run the flame preset)",
    )
    p.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="N",
        help="number of frames (default: all of --sim, or the preset's length)",
    )
    add_output(
        p,
        "--temperature-output",
        kind="clip",
        default=None,
        metavar="OUT",
        help="also write the colour-mapped temperature clip here",
    )
    p.add_argument(
        "--paper",
        action="store_true",
        help=(
            "start from the paper's set-up (FireParams.paper(): --output-size 0, "
            "--fps 8); options given as well change it"
        ),
    )
    add_params_options(p, FireParams)
    add_max_side_option(p)
    add_seed_option(p)
    add_output_option(p)
    p.set_defaults(func=_fire)


def _fire(args):
    from .._progress import TextProgress
    from .._validation import check_int
    from ..fire import FireParams, fire

    params = params_from_args(FireParams, args)
    if args.paper:  # the paper's set-up, then what was given on top
        changed = {k: getattr(args, k) for k in FireParams.specs() if getattr(args, k) is not None}
        params = FireParams.paper().replace(**changed)
    given = Photo(args.photo, "PHOTO", args.max_side)
    photo, alpha = given.read(mode="rgb", return_alpha=True)
    # Without --matte, an RGBA photo's own alpha channel is its matte (fire composites
    # the colour onto black with it, so a cut-out's clear pixels never show).
    matte = alpha
    if args.matte is not None:
        matte = given.companion(args.matte, "--matte", mode="grey")
    if matte is not None and not matte.any():
        where = (
            f"--matte {args.matte!r}"
            if args.matte
            else f"the alpha channel of PHOTO {args.photo!r}"
        )
        raise ValueError(f"{where} has no flame region: it is 0 everywhere (white marks the flame)")
    frames = None if args.frames is None else check_int("--frames", args.frames, 1)
    simulation = None
    if args.sim is not None:
        simulation = _load_simulation(args.sim)
        if frames is not None and frames > len(simulation[0]):
            raise ValueError(
                f"--frames must be <= the simulation's {len(simulation[0])} frames, got {frames}"
            )
    given.note(args.prog)
    # Streamed: the keyframes and frames are made as they are written, a few at a time
    # (at --output-size 1920 the clip would be gigabytes).
    result = fire(
        photo,
        simulation,
        params,
        matte=matte,
        n_frames=frames,
        seed=args.seed,
        stream=True,
        progress=TextProgress(),
    )
    clip = result.clip.with_metadata(**given.metadata())
    out = clip.save(args.output)
    print(f"wrote {out} ({len(clip)} frames, {clip.fps:g} fps, seed {result.seed})")
    if args.temperature_output is not None:
        tout = result.temperature_clip.save(args.temperature_output)
        print(f"wrote {tout} (temperature)")
    return 0


def _load_simulation(path):
    """(temperature, velocity at the pixels) from a saved simulation or a plain npz."""
    import numpy as np

    from .._validation import check_npz_file

    check_npz_file(path, f"--sim {path!r} is not a simulation (.npz)")
    try:
        with np.load(path, allow_pickle=False) as z:
            keys = set(z.files)
            plain = {k: np.array(z[k]) for k in ("temperature", "velocity") if k in keys}
    except (OSError, ValueError) as exc:
        raise ValueError(f"--sim {path!r} is not a readable .npz: {exc}") from None
    if "metadata" in keys:
        from ..fluid import Simulation

        sim = Simulation.load(path)
        return sim.temperature, sim.centred_velocity()
    missing = {"temperature", "velocity"} - set(plain)
    if missing:
        raise ValueError(
            f"--sim {path!r} must hold 'temperature' and 'velocity' arrays, "
            f"missing {', '.join(sorted(missing))}"
        )
    return plain["temperature"], plain["velocity"]
