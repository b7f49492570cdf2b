"""Fire as the app shows it, on photos it was not tuned on: contact sheet and numbers.

    python benchmarks/contact_fire.py [--flame FLAME.png] [--candle CANDLE.png]
        [-o docs/contact/fire_after.png]

One flame-preset simulation (128 x 128, 24 frames after the preset's warm-up, seed 0)
painted with each photo by :func:`fluidnb.fire.fire` with its defaults, each with its
full matte and with a partly painted one (three brush strokes of the app's brush
radius over part of the flame, what a user paints in a hurry):

- the bundled ``fire`` sample (a cut-out);
- ``--flame``: a real flame cut-out (RGBA), e.g. OpenArena's ``textures/sfx/flame1.tga``
  from Debian's ``openarena-081-textures`` (inside ``pak4-textures.pk3``; GPL-2+);
- ``--candle``: a real photo of a candle, made into a photo on its own dark background
  (its alpha composited over RGB (30, 25, 25), cropped to the flame), e.g. Tux Paint's
  ``seasonal/candle.png`` from Debian's ``tuxpaint-stamps-default`` (GPL-2+); its
  "full" matte is the stamp's alpha.

Each row: the photo with its matte, then four frames as the app shows them (the code
before issue 35 showed its 128-px frames enlarged to 384 px, nearest neighbour; the
sheet draws them at 256 the same way; after, the frames are drawn at their own size).
Printed per row, on 8-bit frames (shared/notes/measuring-the-look.md): the clip's size
and frame rate, the share of lit 2x2 blocks whose four pixels are equal ("enlarged
pixels", as shown), the share of the lit area outside the largest lit part, the share
of holes in it, and the share of bright pixels next to black (hard edges). Then the
keyframe synthesis time at 128 and 256 pixels (the bench's flame target).

Run against the code before issue 35 (no ``FireParams.paper``) the same script makes
``fire_before.png``.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import cv2
import numpy as np
from _report import header
from PIL import Image
from scipy import ndimage

import fluidnb.fire as F
from fluidnb import as_image, data, to_uint8
from fluidnb.fields import resize
from fluidnb.fluid import flame_preset, simulate
from fluidnb.sketch import paint_segment

NEW = hasattr(F.FireParams, "paper")
SHOWN = (0.2, 0.45, 0.7, 0.95)  # where in the clip the frames on the sheet are
CELL = 256  # pixels per frame on the sheet, as the app shows them


def enlarged_share(frame):
    """Share of lit (grey > 40) 2x2 blocks whose four pixels are equal."""
    img = to_uint8(frame)
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    h, w = (s - s % 2 for s in grey.shape)
    b = img[:h, :w].reshape(h // 2, 2, w // 2, 2, 3)
    equal = (b == b[:, :1, :, :1]).all(axis=(1, 3, 4))
    lit = grey[:h, :w].reshape(h // 2, 2, w // 2, 2).max(axis=(1, 3)) > 40
    return float(equal[lit].mean()) if lit.any() else 0.0


def shape_measures(frame):
    """(outside the largest lit part, holes, hard edges) as shares, on 8-bit grey."""
    grey = cv2.cvtColor(to_uint8(frame), cv2.COLOR_RGB2GRAY).astype(int)
    lit = grey > 40
    if not lit.any():
        return 0.0, 0.0, 0.0
    labels, _ = ndimage.label(lit, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    outside = 1.0 - sizes.max() / lit.sum()
    filled = ndimage.binary_fill_holes(lit)
    holes = (filled & ~lit).sum() / filled.sum()
    dark = grey < 16
    near_dark = ndimage.binary_dilation(dark, structure=ndimage.generate_binary_structure(2, 1))
    bright = grey > 128
    hard = (bright & near_dark).sum() / max(bright.sum(), 1)
    return float(outside), float(holes), float(hard)


def strokes(shape, lines):
    """A partly painted matte: brush strokes (row, col fractions) of the app's radius."""
    h, w = shape
    painted = np.zeros(shape, bool)
    radius = max(2.0, max(h, w) / 20)
    for (r0, c0), (r1, c1) in lines:
        paint_segment(painted, (r0 * h, c0 * w), (r1 * h, c1 * w), radius, True)
    return painted.astype(np.float32)


def photos(flame, candle):
    """(name, RGB photo, full matte, partly painted matte) of each photo."""
    rgb, alpha = data.sample("fire", size=128, return_alpha=True)  # as the app loads it
    lines = [((0.2, 0.45), (0.85, 0.45)), ((0.45, 0.3), (0.75, 0.6))]
    yield "fire sample (cut-out)", rgb, alpha, strokes(alpha.shape, lines)
    if flame:
        rgb, alpha = as_image(flame, mode="rgb", return_alpha=True)
        rgb = rgb * alpha[..., None]  # a cut-out over black, as fire composites it
        rgb, alpha = _fit(rgb, alpha)
        lines = [((0.45, 0.5), (0.85, 0.5)), ((0.6, 0.35), (0.7, 0.6))]
        yield Path(flame).stem + " (cut-out)", rgb, alpha, strokes(alpha.shape, lines)
    if candle:
        rgb, alpha = as_image(candle, mode="rgb", return_alpha=True)
        backdrop = np.array([30, 25, 25], np.float32) / 255
        rgb = rgb * alpha[..., None] + backdrop * (1 - alpha[..., None])
        top = int(0.5 * rgb.shape[0])  # the flame and the wick, not the candle's body
        rgb, alpha = _fit(rgb[:top], alpha[:top])
        lines = [((0.1, 0.5), (0.6, 0.5)), ((0.3, 0.4), (0.7, 0.55))]
        yield Path(candle).stem + " (photo)", rgb, alpha, strokes(alpha.shape, lines)


def _fit(rgb, alpha, size=128):
    """Resized so the longest side is ``size``, as the app loads a photo."""
    scale = size / max(rgb.shape[:2])
    shape = (round(rgb.shape[0] * scale), round(rgb.shape[1] * scale))
    return np.clip(resize(rgb, shape), 0, 1), np.clip(resize(alpha, shape), 0, 1)


def run(rgb, matte, sim):
    temperature, velocity = sim.temperature, sim.centred_velocity()
    if NEW:
        return F.fire(rgb, (temperature, velocity), matte=matte, seed=0)
    # The code before: what FireApp ran (the photo resized to the grid).
    return F.fire(rgb, (temperature, velocity), F.FireParams(input_size=128), matte=matte, seed=0)


def as_shown(frame):
    """The frame as the app draws it, at CELL pixels (nearest neighbour when enlarged)."""
    img = Image.fromarray(to_uint8(frame))
    if img.height != CELL:
        img = img.resize((img.width * CELL // img.height, CELL), Image.NEAREST)
    return np.asarray(img).astype(np.float32) / 255


def photo_cell(rgb, matte):
    """The photo with its matte (grey checkerboard where it is clear)."""
    h, w = matte.shape
    yy, xx = np.mgrid[:h, :w]
    board = np.where((yy // 8 + xx // 8) % 2, 0.35, 0.55)[..., None]
    cell = rgb * matte[..., None] + board * (1 - matte[..., None])
    return as_shown(cell)


def synthesis_times(repeat=5):
    """Keyframe synthesis at 128 and 256 px: (min, median) seconds, the bench's target."""
    out = {}
    for n in (128, 256):
        photo, matte = data.sample("fire", size=n, return_alpha=True)
        yy, xx = np.mgrid[:n, :n] / n
        t = np.exp(-(((xx - 0.5) / 0.14) ** 2 + ((yy - 0.62) / 0.27) ** 2)).astype(np.float32)
        F.synthesize(photo, t, matte=matte, seed=0)  # compile or load the cache
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            F.synthesize(photo, t, matte=matte, seed=0)
            times.append(time.perf_counter() - t0)
        out[n] = (min(times), float(np.median(times)))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--flame", help="a real flame cut-out (RGBA)")
    parser.add_argument("--candle", help="a real candle photo (RGBA stamp)")
    parser.add_argument("-o", "--output", default="docs/contact/fire_after.png")
    args = parser.parse_args()
    print(header(__file__))

    preset = flame_preset()
    sim = simulate(preset.params, 24, shape=preset.shape, seed=0, warmup=preset.warmup)
    print(f"code: {'after' if NEW else 'before'} issue 35; load {os.getloadavg()[0]:.1f}")
    head = "size, fps | enlarged px (as shown) | outside largest | holes | hard edges"
    print(f"{'photo':>34} {'matte':>8} | {head}")
    rows = []
    for name, rgb, full, partial in photos(args.flame, args.candle):
        for kind, matte in (("full", full), ("partial", partial)):
            clip = run(rgb, matte, sim).clip
            n = clip.n_frames
            picks = [clip.frames[min(n - 1, round(f * (n - 1)))] for f in SHOWN]
            shown = [as_shown(f) for f in picks]
            enlarged = np.mean([enlarged_share(f) for f in shown])
            outside, holes, hard = np.mean([shape_measures(f) for f in picks], axis=0)
            h, w = clip.shape
            print(
                f"{name:>34} {kind:>8} | {w}x{h}, {clip.fps:g} | {enlarged:.3f} | "
                f"{outside:.3f} | {holes:.3f} | {hard:.3f}"
            )
            rows.append(np.concatenate([photo_cell(rgb, matte), *shown], axis=1))
    width = max(r.shape[1] for r in rows)
    sheet = np.concatenate([np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows])
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(to_uint8(sheet)).save(out, optimize=True)
    print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KB)")
    for n, (fast, med) in synthesis_times().items():
        print(f"keyframe synthesis {n} x {n}: {fast * 1e3:.0f} ms fastest, {med * 1e3:.0f} median")
    print(f"load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
