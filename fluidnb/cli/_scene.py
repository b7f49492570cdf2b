"""``fluidnb scene``: several methods on one photo, composited into one clip."""

from __future__ import annotations

from pathlib import Path

from ._common import add_output_option, reuse_freed_memory
from ._paths import add_input, add_output

#: The region options, bottom layer first (the order they are composited in).
_REGIONS = (
    ("water", "the water, animated from the water video database (replaces)"),
    ("clouds", "the clouds or smoke, from the smoke video database (replaces)"),
    ("flicker", "a region animated with flicker (replaces)"),
    ("fire", "where a fire burns, synthesised from the bundled flame photo (adds light)"),
    ("frost", "where frost grows from the region's innermost point (covers)"),
)


def register(sub):
    """Add the ``scene`` subcommand."""
    p = sub.add_parser(
        "scene",
        help="several methods on one photo, composited into one clip",
        description=(
            "Animate several regions of one photo, each with its own method, and "
            "composite them into one clip: water and clouds by the video database, "
            "flicker, fire, frost. Give the photo and at least one region (an image of "
            "the photo's size, white = the region), or a scene folder saved by the "
            "library or SceneApp. Layers are composited bottom to top in the order "
            "water, clouds, flicker, fire, frost; loops repeat, frost grows once and "
            "holds; the clip lasts as long as the longest layer. Outside every region "
            "each frame is the photo."
        ),
        epilog=(
            "Examples: fluidnb scene lake.jpg --water water.png --fire fire.png "
            "--frost corner.png -o scene.mp4 ; fluidnb scene my-scene/ -o scene.gif"
        ),
    )
    add_input(
        p,
        "source",
        metavar="PHOTO|SCENE_FOLDER",
        help="the photo (any format Pillow reads), or a folder with a scene.json",
    )
    for kind, text in _REGIONS:
        add_input(p, f"--{kind}", default=None, metavar="REGION", help=text)
    add_input(
        p,
        "--strokes",
        default=None,
        metavar="STROKES.json",
        help="flow strokes for the water (fluidnb.sketch.save_strokes, drawn on the photo)",
    )
    p.add_argument(
        "--size",
        type=int,
        default=480,
        help="longest side of the scene in pixels (default 480; 0 keeps the photo's)",
    )
    p.add_argument("--fps", type=float, default=24.0, help="frames a second (default 24)")
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        help="seconds (default: the longest layer's)",
    )
    add_output(
        p,
        "--save-scene",
        kind="folder",
        default=None,
        metavar="FOLDER",
        help="also save the scene (JSON and PNG masks) to this folder",
    )
    add_output_option(p)
    p.set_defaults(func=_scene)


def _scene(args):
    from .._image import as_image, as_mask
    from .._progress import TextProgress
    from ..scene import Layer, Scene, load_scene, render, save_scene

    source = Path(args.source)
    regions = [(kind, getattr(args, kind)) for kind, _ in _REGIONS]
    given = [(kind, path) for kind, path in regions if path is not None]
    if source.is_dir():
        if given or args.strokes:
            raise ValueError(
                "a scene folder holds its own regions: give either a folder or a photo "
                "with --water/--clouds/--flicker/--fire/--frost"
            )
        scene = load_scene(source)
        if args.duration is not None:
            scene.duration = args.duration
    else:
        if not given:
            raise ValueError(
                "give at least one region: --water, --clouds, --flicker, --fire or --frost "
                "(an image of the photo's size, white = the region)"
            )
        if args.size < 0:
            raise ValueError(f"--size must be >= 0 (0 keeps the photo's size), got {args.size}")
        photo = as_image(str(source), name="PHOTO")
        scene = Scene(
            photo, size=args.size or None, fps=_positive("--fps", args.fps), duration=args.duration
        )
        for kind, path in given:
            mask = as_mask(path, photo.shape[:2], name=f"--{kind}")
            strokes = ()
            if kind == "water" and args.strokes:
                from ..sketch import load_strokes

                strokes = tuple(load_strokes(args.strokes, photo.shape[:2])[0])
            scene.add(Layer(kind, mask, strokes=strokes))
        if args.strokes and args.water is None:
            raise ValueError("--strokes draws the water's flow: give --water too")
    print(f"{scene}; rendering each layer with its method…")
    reuse_freed_memory()  # as animate: its water or clouds layer is a video-database render
    # Streamed: each layer's frames are made as the scene's are composited and written,
    # so a full-size photo needs a few frames of each layer, not their clips.
    clip = render(scene, stream=True, progress=TextProgress())
    if args.save_scene:
        print(f"saved the scene to {save_scene(scene, args.save_scene)}")
    out = clip.save(args.output)
    layers = ", ".join(
        f"{x['name']} {x['frames']} frames ({x['seconds']} s)" for x in clip.metadata["layers"]
    )
    print(f"wrote {out} ({len(clip)} frames, {clip.fps:g} fps; {layers})")
    return 0


def _positive(name, value):
    if not value > 0:
        raise ValueError(f"{name} must be > 0, got {value}")
    return value
