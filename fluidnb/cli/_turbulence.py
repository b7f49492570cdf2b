"""``fluidnb turbulence``: add a fine flow's turbulent detail to a coarse one."""

from __future__ import annotations

from pathlib import Path

from ._common import add_fps_option, add_params_options, params_from_args
from ._paths import add_input, add_output


def register(sub):
    """Add the ``turbulence`` subcommand."""
    from ..turbulence import TurbulenceParams

    p = sub.add_parser(
        "turbulence",
        help="example-based turbulence synthesis with adaptive search (Watanabe et al.)",
        description=(
            "Paste the high-frequency detail of a high-resolution SOURCE flow onto a "
            "low-resolution TARGET flow, patch by patch: a global search on the coarse "
            "grid (Eq. 1), then a local search on the fine grid (Eq. 2) with the chosen "
            "--strategy (Table 1). Flows are .npz files written by Flow.save, "
            "--save-sample or `fluidnb simulate`; the target's grid spacing must be a "
            "whole multiple of the source's, on the same domain. --sample uses the "
            "package's sample pair (the paper's sizes: 24 x 16 and 192 x 128; --quick "
            "halves both). The output -o is the synthesised flow on the source grid "
            "(.npz); --render writes a dye carried through it as a clip."
        ),
        epilog=(
            "Examples: fluidnb turbulence --sample --quick -o synth.npz --render synth.gif | "
            "fluidnb turbulence --save-sample pair/ --quick | "
            "fluidnb turbulence --target pair/target.npz --source pair/source.npz "
            "--strategy exact-bounds -o synth.npz"
        ),
    )
    inputs = p.add_argument_group("inputs")
    add_input(
        inputs,
        "--target",
        default=None,
        metavar="T.npz",
        help="the low-resolution flow to add detail to",
    )
    add_input(
        inputs,
        "--source",
        default=None,
        metavar="S.npz",
        help="the high-resolution flow with the detail",
    )
    inputs.add_argument(
        "--sample", action="store_true", help="use the sample pair instead of --target/--source"
    )
    inputs.add_argument(
        "--quick",
        action="store_true",
        help="the sample pair at half size (12 x 8 and 96 x 64; default 40 frames)",
    )
    inputs.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="N",
        help="frames to use (the sample's default: 200, 40 with --quick; --target/--source: all)",
    )
    outputs = p.add_argument_group("outputs")
    add_output(
        outputs,
        "-o",
        "--output",
        default=None,
        metavar="OUT.npz",
        help="write the synthesised flow (velocity, density, dx) here",
    )
    add_output(
        outputs,
        "--render",
        kind="clip",
        default=None,
        metavar="OUT",
        help="write a dye carried by the synthesised flow: .gif, .mp4, .npz or a folder",
    )
    outputs.add_argument(
        "--render-all",
        action="store_true",
        help="--render shows target (upsampled) | source | synthesised side by side",
    )
    add_fps_option(outputs, 24.0, "frame rate of --render")
    add_output(
        outputs,
        "--save-sample",
        kind="folder",
        writes=("target.npz", "source.npz"),
        default=None,
        metavar="DIR",
        help="write the sample pair as DIR/target.npz and DIR/source.npz",
    )
    outputs.add_argument(
        "--errors",
        action="store_true",
        help="also run the exhaustive search (untimed) and print the paper's error figures",
    )
    add_params_options(p, TurbulenceParams)
    p.set_defaults(func=_turbulence)


def _flows(args, progress):
    """(target, source) from the options, checked and cut to --frames."""
    from .._validation import check_int
    from ..turbulence import Flow, sample_flows

    given = (args.target is not None, args.source is not None)
    if any(given) and not all(given):
        raise ValueError("give both --target and --source (or --sample)")
    use_sample = args.sample or (args.save_sample is not None and not any(given))
    if use_sample and any(given):
        raise ValueError("give either --target/--source or --sample, not both")
    if not use_sample and not any(given):
        raise ValueError("give --target T.npz and --source S.npz, or --sample")
    frames = None if args.frames is None else check_int("--frames", args.frames, 1)
    if use_sample:
        n = frames if frames is not None else (40 if args.quick else 200)
        return sample_flows(n, scale=2 if args.quick else 1, progress=progress)
    if args.quick:
        raise ValueError("--quick picks the sample's size: use it with --sample")
    if args.save_sample is not None:
        raise ValueError("--save-sample writes the sample pair: use it without --target/--source")
    pair = []
    for option, path in (("--target", args.target), ("--source", args.source)):
        try:
            pair.append(Flow.load(path))
        except ValueError as exc:
            raise ValueError(f"{option}: {exc}") from None
    if frames is not None:
        have = min(f.n_frames for f in pair)
        if frames > have:
            raise ValueError(f"--frames must be <= the flows' {have} frames, got {frames}")
        pair = [f.frames(0, frames) for f in pair]
    return tuple(pair)


def _turbulence(args):
    from .._progress import TextProgress
    from ..turbulence import TurbulenceParams, render, side_by_side, synthesize

    params = params_from_args(TurbulenceParams, args)
    if args.output is not None and not str(args.output).endswith(".npz"):
        raise ValueError(
            f"-o must end in .npz (the synthesised flow), got {args.output!r}; "
            "use --render for a picture of it"
        )
    if args.render_all and args.render is None:
        raise ValueError("--render-all needs --render OUT")
    if args.output is None and args.render is None and args.save_sample is None:
        raise ValueError("nothing to write: give -o OUT.npz, --render OUT or --save-sample DIR")
    progress = TextProgress()
    target, source = _flows(args, progress)
    if args.save_sample is not None:
        folder = Path(args.save_sample)
        folder.mkdir(parents=True, exist_ok=True)
        for name, flow in (("target", target), ("source", source)):
            path = flow.save(folder / f"{name}.npz")
            h, w = flow.shape
            print(f"wrote {path} ({flow.n_frames} frames, {h}x{w}, dx {flow.dx:g})")
    if args.output is None and args.render is None:
        return 0
    result = synthesize(target, source, params, reference=args.errors, progress=progress)
    row = result.summary()
    (th, tw), (sh, sw) = target.shape, source.shape
    line = (
        f"{row['strategy']}: {1000 * row['seconds_per_frame']:.2f} ms of local search per "
        f"frame, {row['evaluations_per_patch']:.0f} evaluations per patch; {result.n_frames} "
        f"frames, {th}x{tw} -> {sh}x{sw} in {result.timings['total']:.1f} s"
    )
    if args.errors:
        line += (
            f"; relative error {row['relative_error']:.4f}, "
            f"absolute error {row['absolute_error']:.4f}"
        )
    print(line)
    if args.output is not None:
        out = result.to_flow().save(args.output)
        print(f"wrote {out} (synthesised flow, {result.n_frames} frames, {sh}x{sw})")
    if args.render is not None:
        clips = render(result, fps=args.fps)
        clip = clips["synthesised"]
        if args.render_all:
            meta = {**clip.metadata, "flow": "target | source | synthesised"}
            clip = side_by_side([clips[k] for k in ("target", "source", "synthesised")], meta)
        out = clip.save(args.render)
        what = "target | source | synthesised" if args.render_all else "synthesised"
        print(f"wrote {out} (dye render, {what}, {len(clip)} frames, {clip.fps:g} fps)")
    return 0
