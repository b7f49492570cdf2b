"""Contact sheet: frost grown over photographs the method was never tuned on.

The photos come with scikit-image (``skimage.data``: coffee, rocket, chelsea), not from
``fluidnb.data`` (the samples the look was tuned on). On each a hand-painted-looking
region gets two start points; ``gamma_for_target`` picks the gamma that ends the
growth near frame 96 (the paper's gamma = 0.005 would take thousands of frames on
regions this size); the row shows the photo, the frost at a third and two thirds of
the way, the end frame, and a detail of it drawn at twice the size.

Run from the repository root::

    python benchmarks/contact_frost.py            # writes docs/contact/frost.png

``docs/contact/frost_before.png`` is the same sheet drawn by the renderer before the
ice look (commit 868eb2e: a flat translucent decal, a hard edge at the region, a
milky last frame), kept for comparison.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _report import header
from PIL import Image
from skimage import data as skdata
from skimage.transform import resize

from fluidnb.frost import FrostParams, HexLattice, gamma_for_target, grow, render

#: (photo, region centre (fy, fx), radii (fy, fx), start points as fractions (fy, fx), rth)
SCENES = [
    ("coffee", (0.5, 0.5), (0.42, 0.44), [(0.55, 0.30), (0.35, 0.70)], 0.4),
    ("rocket", (0.45, 0.55), (0.38, 0.36), [(0.40, 0.45)], 0.0),
    ("chelsea", (0.5, 0.45), (0.40, 0.40), [(0.65, 0.30), (0.30, 0.60)], 0.8),
]
TARGET = 96  # frames: 4 s at 24 fps


def photo(name, width):
    """A scikit-image sample photo as float RGB, ``width`` pixels wide."""
    image = getattr(skdata, name)()[..., :3].astype(np.float32) / 255.0
    h, w = image.shape[:2]
    return resize(image, (round(h * width / w), width), anti_aliasing=True).astype(np.float32)


def painted_region(shape, centre, radii):
    """An ellipse with a wobbly edge, as a brush would leave it."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    cy, cx = centre[0] * h, centre[1] * w
    angle = np.arctan2(yy - cy, xx - cx)
    wobble = 1 + 0.12 * np.sin(3 * angle + 1) + 0.06 * np.sin(7 * angle)
    return ((yy - cy) / (radii[0] * h)) ** 2 + ((xx - cx) / (radii[1] * w)) ** 2 <= wobble**2


def scene_frames(name, centre, radii, starts, rth, *, width, spacing):
    image = photo(name, width)
    h, w = image.shape[:2]
    region = painted_region((h, w), centre, radii)
    lattice = HexLattice.from_mask(region, spacing)
    points = [(fy * h, fx * w) for fy, fx in starts]
    params = FrostParams(rth=rth, spacing=spacing, max_frames=3000)
    fit = gamma_for_target(lattice, points, TARGET, params, seed=0)
    result = grow(lattice, points, params.replace(gamma=fit.gamma), seed=0)
    end = result.end_frame
    clip = render(image, lattice, result, every=max(1, end // 3))
    frames = clip.frames
    last = frames[-1]
    # A 2x detail around the first start point (drawn at twice the size, not zoomed).
    big = photo(name, 2 * width)
    big_region = painted_region(big.shape[:2], centre, radii)
    big_lattice = HexLattice.from_mask(big_region, 2 * spacing)
    if big_lattice.n_cells == lattice.n_cells:
        big_result = grow(big_lattice, [(2 * r, 2 * c) for r, c in points], result.params, seed=0)
        big_last = render(big, big_lattice, big_result, frames=end, every=end).frames[-1]
    else:  # the larger mask rounded differently: fall back to a plain zoom
        big_last = resize(last, big.shape[:2], order=1)
    r0 = int(np.clip(2 * points[0][0] - h // 2, 0, 2 * h - h))
    c0 = int(np.clip(2 * points[0][1] - w // 2, 0, 2 * w - w))
    detail = big_last[r0 : r0 + h, c0 : c0 + w]
    label = f"{name}: {lattice.n_cells} cells, rth {rth:g}, gamma {fit.gamma:.3f}, end {end}"
    return [image, frames[1], frames[2], last, detail], label


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/contact/frost.png")
    parser.add_argument("--width", type=int, default=240, help="tile width in pixels")
    parser.add_argument("--spacing", type=float, default=2.0, help="lattice spacing, px")
    args = parser.parse_args(argv)
    print(header(__file__))
    rows = []
    for name, centre, radii, starts, rth in SCENES:
        started = time.perf_counter()
        tiles, label = scene_frames(
            name, centre, radii, starts, rth, width=args.width, spacing=args.spacing
        )
        print(f"{label} ({time.perf_counter() - started:.1f} s)")
        h = min(t.shape[0] for t in tiles)
        rows.append(np.concatenate([t[:h] for t in tiles], axis=1))
    w = min(r.shape[1] for r in rows)
    sheet = np.concatenate([r[:, :w] for r in rows], axis=0)
    img = Image.fromarray((np.clip(sheet, 0, 1) * 255 + 0.5).astype(np.uint8))
    # An adaptive palette keeps the sheet small enough to commit (< 300 KB).
    img = img.quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    img.save(out, optimize=True)
    print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KB, {sheet.shape[1]}x{sheet.shape[0]})")


if __name__ == "__main__":
    main()
