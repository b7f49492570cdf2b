"""The photo a command reads, at the size it works on, and the files drawn on it.

Decided once (docs/conventions.md, "Photos on the command line") and applied by every
command that reads a photo (flicker, frost, fire, animate): a photo whose longer side
is larger than ``--max-side`` (default 1920 px) is scaled down as it is read -- a
12 MP phone photo, 4000 x 3000, is worked on at 1920 x 1440 -- and so are the images
drawn on it (mask, matte, speed map, background); positions and velocities given in
the photo's pixels (strokes, start points, a flow) are scaled to match. One line on
stderr says so, and the clip's metadata records it (``downscaled``). ``--max-side 0``
keeps the full size. A file that declares more pixels than anyone photographs
(:func:`fluidnb._image.max_pixels`) is refused at once, from its header.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .._image import as_image, image_size, shrunk_shape

__all__ = ["MAX_SIDE", "Photo", "add_max_side_option"]

#: The default longest side a command works at: HD (1920 x 1080) is never reduced.
MAX_SIDE = 1920


def _max_side(text):
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0 or 0 < value < 8:
        raise argparse.ArgumentTypeError(
            f"--max-side must be a whole number of pixels >= 8, or 0 for the full size, "
            f"got {text!r}"
        )
    return value


def add_max_side_option(parser):
    """Add ``--max-side``: the longest side the command works at."""
    parser.add_argument(
        "--max-side",
        type=_max_side,
        default=MAX_SIDE,
        metavar="PX",
        help=f"work on a larger photo scaled down to this longest side, and the images, "
        f"strokes and points drawn on it with it (default {MAX_SIDE}; 0: the full size, "
        "as much memory as it takes)",
    )


class Photo:
    """A photo given on the command line: its size on disk and the size worked at.

    Reading the header only, the constructor refuses at once a file that is missing,
    not an image, or absurdly large (one line, exit status 2); the pixels are read
    (and scaled, see the module) by :meth:`read`.

    Parameters
    ----------
    path : str
        The photo's file.
    label : str
        How messages name it (``"IMAGE"``, ``"PHOTO"``).
    max_side : int
        ``--max-side``; 0 keeps the full size.
    """

    def __init__(self, path, label, max_side):
        self.path = path
        self.label = label
        self.max_side = max_side or None
        #: (H, W) of the file.
        self.original = image_size(path, label)
        #: (H, W) worked at.
        self.shape = shrunk_shape(self.original, self.max_side or max(self.original))

    @property
    def scaled(self):
        """Whether the photo is worked on smaller than it is."""
        return self.shape != self.original

    def read(self, **kwargs):
        """The photo at :attr:`shape`: :func:`fluidnb.as_image` with these options."""
        return as_image(self.path, name=self.label, max_side=self.max_side, **kwargs)

    def companion(self, path, label, **kwargs):
        """An image drawn on the photo (mask, matte, ...): same size on disk, read alike."""
        size = image_size(path, label)
        if size != self.original:
            raise ValueError(
                f"{label} must have the same height and width as the image {self.original} "
                f"({self.label} {self.path!r}), got {size}"
            )
        return as_image(path, name=label, max_side=self.max_side, **kwargs)

    def _factors(self):
        return np.array(self.shape, float) / np.array(self.original, float)

    def points(self, points):
        """(row, col) pixels of the photo as (row, col) pixels of the image worked on.

        Pixel centres map to pixel centres: ``(p + 0.5) * scale - 0.5``.
        """
        if not self.scaled:
            return points
        k = self._factors()
        return [(np.asarray(p, float) + 0.5) * k - 0.5 for p in points]

    def velocity(self, velocity):
        """A (dy, dx) in the photo's pixels per frame, in the working image's."""
        return tuple(float(v) * k for v, k in zip(velocity, self._factors()))

    @property
    def speed_scale(self):
        """What a speed in the photo's pixels per frame is multiplied by."""
        return max(self.shape) / max(self.original)

    def note(self, prog):
        """Say on stderr, in one line, that the photo is worked on smaller."""
        if self.scaled:
            (h0, w0), (h, w) = self.original, self.shape
            print(
                f"{prog}: note: {self.label} {self.path!r} is {w0} x {h0} pixels: working at "
                f"{w} x {h} (--max-side {self.max_side}; --max-side 0 keeps the full size)",
                file=sys.stderr,
            )

    def metadata(self):
        """What the clip's metadata records: ``{"downscaled": {...}}``, or nothing."""
        if not self.scaled:
            return {}
        return {
            "downscaled": {
                "from": list(self.original),
                "to": list(self.shape),
                "max_side": self.max_side,
            }
        }
