"""``fluidnb info``, ``fluidnb sample`` and ``fluidnb convert``."""

from __future__ import annotations

import importlib.metadata
import platform
import sys

from ._common import add_fps_option, add_output_option
from ._paths import add_input

_REPORTED = [
    "numpy",
    "scipy",
    "scikit-image",
    "PyMaxflow",
    "matplotlib",
    "imageio",
    "imageio-ffmpeg",
    "pillow",
    "ipywidgets",
    "ipycanvas",
    "jupyterlab",
]


def register(sub):
    """Add the general-purpose subcommands."""
    p = sub.add_parser("info", help="versions and where the sample data lives")
    p.set_defaults(func=_info)

    p = sub.add_parser("sample", help="write one of the sample images to a file")
    p.add_argument("name", nargs="?", help="sample name (omit to list them)")
    p.add_argument("--size", type=int, default=None, help="longest side in pixels")
    add_output_option(p, required=False, kind="file", help="the image file to write (.png, .jpg)")
    p.set_defaults(func=_sample)

    p = sub.add_parser("convert", help="convert a clip between .npz, .gif, .mp4 and PNG folders")
    add_input(p, "input", help="a clip written by fluidnb (.npz, .gif, .mp4 or PNG folder)")
    add_fps_option(p, None, "override frames per second")
    add_output_option(p)
    p.set_defaults(func=_convert)


def _info(args):
    from .. import __version__, data

    print(f"fluidnb {__version__}")
    print(f"python {platform.python_version()} ({sys.executable})")
    print(f"platform {platform.platform()}")
    for dist in _REPORTED:
        try:
            version = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            version = "not installed"
        print(f"  {dist:<15} {version}")
    print(f"sample data: {data.data_dir()}")
    print(f"samples: {', '.join(data.names())}")
    return 0


def _sample(args):
    from .. import data
    from .._image import to_uint8

    if args.name is None:
        for entry in data.catalogue():
            print(f"{entry['name']:<12} {entry['kind']:<10} {entry['description']}")
        return 0
    if args.output is None:
        raise ValueError("--output is required to write a sample")
    from pathlib import Path

    from PIL import Image

    from .._media import write_atomically

    image = data.sample(args.name, size=args.size)
    # Through a temporary name (it keeps the extension, which picks the format).
    write_atomically(Path(args.output), Image.fromarray(to_uint8(image)).save)
    print(f"wrote {args.output} ({image.shape[1]}x{image.shape[0]})")
    return 0


def _convert(args):
    from .._clip import Clip

    clip = Clip.load(args.input)
    out = clip.save(args.output, fps=args.fps)
    print(f"wrote {out} ({len(clip)} frames)")
    return 0
