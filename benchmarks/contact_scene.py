"""Two scenes on the bundled photos, as the overview and lesson 08 make them: contact sheets.

    python benchmarks/contact_scene.py [--size 480] [--quick] [-o docs/contact]

``scene_lake.png``: the lake at dusk, its water band flowing (video database, a stroke
right to left), a fire on the shore (bottom right) and frost growing from the top left
corner. ``scene_clouds.png``: the mountain photo, its cloud drifting (video database,
the bundled drawn matte) and a fire on the grass. Each sheet: four frames spread over
the scene's length, left to right, top to bottom. Printed: each layer's frames, fps and
seconds (``clip.metadata["layers"]``) with the load.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from PIL import Image

from fluidnb import data, to_uint8
from fluidnb.frost import FrostParams
from fluidnb.scene import Layer, Scene, render

#: The frost of both scenes: a dense, ragged growth that covers its corner in ~3 s.
FROST = FrostParams(beta=0.6, rth=0.4, spacing=3.0, gamma=0.4, target=72, max_frames=96)


def box(shape, rows, cols):
    """A rectangle of a (H, W) picture, given as fractions of its height and width."""
    h, w = shape
    m = np.zeros((h, w), bool)
    m[int(rows[0] * h) : int(rows[1] * h), int(cols[0] * w) : int(cols[1] * w)] = True
    return m


def lake_scene(size):
    photo = data.sample("lake", size=size)
    h, w = photo.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    corner = (yy / (0.45 * h)) ** 2 + (xx / (0.30 * w)) ** 2 < 1
    flow = [np.array([[0.5 * h, 0.9 * w], [0.5 * h, 0.1 * w]])]  # right to left
    return Scene(
        photo,
        [
            Layer("water", box((h, w), (0.45, 0.58), (0, 1)), strokes=flow),
            Layer("fire", box((h, w), (0.60, 0.98), (0.79, 0.99))),
            Layer("frost", corner, FROST, starts=np.array([[2.0, 2.0]])),
        ],
        size=None,
    )


def clouds_scene(size):
    photo = data.sample("clouds", size=size)
    h, w = photo.shape[:2]
    flow = [np.array([[0.5 * h, 0.1 * w], [0.45 * h, 0.9 * w]])]  # left to right
    return Scene(
        photo,
        [
            Layer("clouds", data.region("clouds", size=size), strokes=flow),
            Layer("fire", box((h, w), (0.70, 0.99), (0.08, 0.24))),
        ],
        size=None,
    )


def sheet(clip, n=4):
    frames = [clip.frames[i] for i in np.linspace(0, len(clip) - 1, n).astype(int)]
    rows = [np.concatenate(frames[i : i + 2], axis=1) for i in range(0, n, 2)]
    return np.concatenate(rows, axis=0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=480)
    ap.add_argument("--quick", action="store_true", help="the quick starter databases")
    ap.add_argument("-o", "--out", default="docs/contact")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, make in (("lake", lake_scene), ("clouds", clouds_scene)):
        scene = make(args.size)
        started = time.perf_counter()
        clip = render(scene, quick=args.quick)
        took = time.perf_counter() - started
        print(f"{name}: {clip} in {took:.1f} s (load {os.getloadavg()[0]:.1f})")
        for layer in clip.metadata["layers"]:
            print(f"  {layer['name']}: {layer['frames']} frames at {layer['fps']:g} fps, "
                  f"{layer['seconds']} s")  # fmt: skip
        Image.fromarray(to_uint8(sheet(clip))).save(out / f"scene_{name}.png", optimize=True)


if __name__ == "__main__":
    main()
