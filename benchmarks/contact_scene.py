"""Two scenes on the bundled photos, as the overview and lesson 08 make them: contact sheets.

    python benchmarks/contact_scene.py [--size 480] [--quick] [-o docs/contact]

``scene_lake.png``: the lake at dusk, its water band flowing (video database, a stroke
right to left), a fire on the shore (bottom right) and frost growing from the top left
corner. ``scene_clouds.png``: the mountain photo, its cloud drifting (video database,
the bundled drawn matte) and a fire on the grass. Each sheet: four frames spread over
the scene's length, left to right, top to bottom. Printed: each layer's frames, fps and
seconds (``clip.metadata["layers"]``) with the load.

``--hd``: the lake with lesson 08's layers and the scene's default parameters (what
``fluidnb scene`` and SceneApp give), worked on as SceneApp does at 1920 px: a 480-px
proxy rendered in memory, then ``render(proxy.resized(), stream=True)`` at 1920 x 1080.
Writes full-size crops of one late frame, ``scene_hd_frost_1to1.png`` (the top left
corner) and ``scene_hd_water_fire_1to1.png`` (the shore), and
``scene_hd_frost_480_vs_1920.png``: the proxy's corner enlarged 4x (nearest) beside
the same corner at full size -- the same frost at both sizes.
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


def hd_crops(out, quick=False, width=1920, proxy_size=480):
    """Lesson 08's lake scene with the default parameters: a proxy, then full size."""
    h = width * 9 // 16
    photo = data.sample("lake", size=(h, width))
    yy, xx = np.mgrid[0:h, 0:width]
    regions = {  # as lesson 08 (and benchmarks/bench_scale.py's scene row) paints them
        "water": box((h, width), (0.45, 0.58), (0, 1)),
        "fire": box((h, width), (0.60, 0.98), (0.79, 0.99)),
        "frost": (yy / (0.45 * h)) ** 2 + (xx / (0.30 * width)) ** 2 < 1,
    }
    proxy = Scene(photo, [Layer(k, m) for k, m in regions.items()], size=proxy_size)
    cpu = time.process_time()
    small = render(proxy, quick=quick)
    print(f"proxy {proxy}: {len(small)} frames in {time.process_time() - cpu:.1f} s CPU "
          f"(load {os.getloadavg()[0]:.1f})")  # fmt: skip
    full = proxy.resized()
    cpu = time.process_time()
    stream = render(full, quick=quick, stream=True)
    # A late frame: the frost grown, the fire and water in mid-loop.
    pick = round(0.8 * (len(stream) - 1))
    frame = next(f for t, f in enumerate(stream.frames()) if t == pick)
    print(f"full {full}: frame {pick} of {len(stream)} in {time.process_time() - cpu:.1f} s "
          f"CPU (load {os.getloadavg()[0]:.1f})")  # fmt: skip
    f = width // proxy.shape[1]
    corner = frame[:500, :800]
    Image.fromarray(to_uint8(corner)).save(out / "scene_hd_frost_1to1.png", optimize=True)
    shore = frame[h - 560 :, width - 900 :]
    Image.fromarray(to_uint8(shore)).save(out / "scene_hd_water_fire_1to1.png", optimize=True)
    t_small = min(len(small) - 1, round(pick * len(small) / len(stream)))
    enlarged = np.repeat(np.repeat(small.frames[t_small, : 500 // f, : 800 // f], f, 0), f, 1)
    gap = np.ones((500, 8, 3), np.float32)
    pair = np.concatenate([enlarged, gap, corner], axis=1)
    Image.fromarray(to_uint8(pair)).save(out / "scene_hd_frost_480_vs_1920.png", optimize=True)


def sheet(clip, n=4):
    frames = [clip.frames[i] for i in np.linspace(0, len(clip) - 1, n).astype(int)]
    rows = [np.concatenate(frames[i : i + 2], axis=1) for i in range(0, n, 2)]
    return np.concatenate(rows, axis=0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=480)
    ap.add_argument("--quick", action="store_true", help="the quick starter databases")
    ap.add_argument("-o", "--out", default="docs/contact")
    ap.add_argument("--hd", action="store_true", help="1920-px crops of the default scene")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.hd:
        hd_crops(out, quick=args.quick)
        return
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
