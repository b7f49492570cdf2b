"""``fluidnb flicker``: animate a photo with flicker ("yuragi")."""

from __future__ import annotations

from ._common import add_output_option, add_params_options, add_seed_option, params_from_args
from ._paths import add_input
from ._photo import Photo, add_max_side_option


def register(sub):
    """Add the ``flicker`` subcommand."""
    from ..flicker import FlickerParams

    p = sub.add_parser(
        "flicker",
        help="flicker animation of one photo (Yamamoto & Sakamoto)",
        description=(
            "Animate IMAGE with flicker from its spatio-temporal spectrum: the luminance "
            "is a pseudo-height whose spatial frequencies oscillate at temporal "
            "frequencies on a plane or a curved surface, with 1/f^beta noise; the "
            "bump-mapped shading of that height changes the photo's brightness. "
            "Defaults are the paper's (64 frames at 8 fps, f0 = 4, convex mapping, "
            "beta = 2)."
        ),
    )
    add_input(p, "image", metavar="IMAGE", help="the photo (any format Pillow reads)")
    add_input(
        p,
        "--mask",
        default=None,
        metavar="MASK",
        help="region to animate: an image of the same size, white = animate "
        "(default: the whole image)",
    )
    add_input(
        p,
        "--flow",
        is_path=_is_strokes_file,
        default=None,
        metavar="DY,DX|STROKES.json",
        help="for --mapping flow: the velocity in pixels per frame (e.g. 0,0.5 = to the "
        "right), or a strokes file (fluidnb.sketch.save_strokes) drawn along the flow, "
        "whose length is the distance travelled in one loop",
    )
    add_params_options(p, FlickerParams)
    add_max_side_option(p)
    add_seed_option(p)
    add_output_option(p)
    p.set_defaults(func=_flicker)


def _flicker(args):
    from .._image import as_mask
    from .._progress import TextProgress
    from ..flicker import FlickerParams, flicker

    params = params_from_args(FlickerParams, args)
    photo = Photo(args.image, "IMAGE", args.max_side)
    image = photo.read()
    mask = None
    if args.mask is not None:
        mask = as_mask(photo.companion(args.mask, "--mask", mode="grey"), name="--mask")
    flow = _flow(args.flow, photo)
    if flow is not None and params.mapping != "flow":
        params = params.replace(mapping="flow")  # --flow alone means the flow mapping
    photo.note(args.prog)
    # Streamed: the frames go to the file a few at a time as they are made.
    frames = flicker(
        image, mask, params, flow=flow, seed=args.seed, stream=True, progress=TextProgress()
    )
    out = frames.with_metadata(**photo.metadata()).save(args.output)
    print(f"wrote {out} ({len(frames)} frames, {frames.fps:g} fps, seed {frames.metadata['seed']})")
    return 0


def _is_strokes_file(text):
    return text.lower().endswith(".json")


def _flow(text, photo):
    """``--flow``: "DY,DX" in pixels per frame, or a strokes file (scaled with the photo)."""
    if text is None:
        return None
    if _is_strokes_file(text):
        from ..sketch import load_strokes

        strokes, _ = load_strokes(text, photo.original)
        return photo.points(strokes)
    try:
        dy, dx = (float(x) for x in text.split(","))
    except ValueError:
        raise ValueError(
            f"--flow must be DY,DX in pixels per frame (e.g. 0,0.5) or a strokes .json file, "
            f"got {text!r}"
        ) from None
    return photo.velocity((dy, dx))
