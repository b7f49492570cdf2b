"""Tiny valid inputs for every fluidnb subcommand, and a valid command line for each.

The fault tests (tests/faults) aim outputs at these inputs and break them one at a
time; a recipe here is a run that would succeed, so a refusal is the check's doing.
"""

from __future__ import annotations

import numpy as np
from PIL import Image
from scipy import ndimage as ndi

from fluidnb import Clip, to_uint8
from fluidnb.sketch import save_strokes

H, W = 48, 64


def moving_clip(seed, velocity, frames=12, shape=(H, W)):
    gen = np.random.default_rng(seed)
    base = ndi.gaussian_filter(gen.random(shape), 1.5, mode="wrap")
    base = (base - base.min()) / (base.max() - base.min())
    dy, dx = velocity
    out = np.stack([np.roll(base, (t * dy, t * dx), axis=(0, 1)) for t in range(frames)])
    return Clip(np.repeat(out[..., None], 3, axis=3), fps=12)


def make_inputs(d):
    """Write a tiny valid input of every kind the commands read into the folder ``d``."""
    from fluidnb import data
    from fluidnb.turbulence import sample_flows
    from fluidnb.videodb import DatabaseParams, build_database

    photo = data.sample("ripples", size=W)[:H]  # 48 x 64
    Image.fromarray(to_uint8(photo)).save(d / "photo.png")
    Image.fromarray(to_uint8(photo[::-1])).save(d / "background.png")
    mask = np.zeros((H, W), np.uint8)
    mask[8:40, 10:54] = 255
    Image.fromarray(mask).save(d / "mask.png")
    Image.fromarray(mask // 4).save(d / "speed.png")
    save_strokes(d / "strokes.json", [[[24, 50], [24, 12]]], (H, W))
    fire_photo, fire_matte = data.sample("fire", size=40, return_alpha=True)
    Image.fromarray(to_uint8(fire_photo)).save(d / "fire.png")
    Image.fromarray(to_uint8(fire_matte)).save(d / "fire-matte.png")
    yy, xx = np.mgrid[:24, :24].astype(np.float32)
    temperature = np.stack([np.exp(-((xx - 12) ** 2 + (yy - 15 + k) ** 2) / 30) for k in range(4)])
    velocity = np.zeros((4, 24, 24, 2), np.float32)
    velocity[..., 0] = -1.0
    np.savez(d / "sim.npz", temperature=temperature, velocity=velocity)
    moving_clip(1, (0, 1)).save(d / "clip.gif")
    moving_clip(2, (1, 0), frames=16, shape=(96, 120)).save(d / "right.mp4")
    moving_clip(3, (0, -1)).save(d / "frames")  # a folder of frames, as a video source
    target, source = sample_flows(2, scale=2)
    target.save(d / "target.npz")
    source.save(d / "source.npz")
    params = DatabaseParams(N=8, augment="flip", words=16, codebook_samples=5000)
    build_database([d / "right.mp4"], d / "db", kind="water", params=params, workers=1)
    (d / "out").mkdir()  # where the recipes' own outputs would go
    return d


def make_hostile_inputs(d):
    """Write the inputs of issue 37's fault probe into ``d`` (beside make_inputs' ones).

    A 74-byte PNG that declares 30000 x 30000 pixels (a decompression bomb), a valid
    PNG of 8000 x 8000 black pixels (62 KB), a strokes file nested 200,000 arrays deep,
    one whose points have three coordinates and one with booleans as coordinates.
    """
    import json
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", 30000, 30000, 8, 0, 0, 0, 0)
    (d / "bomb.png").write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\0" * 1000))
        + chunk(b"IEND", b"")
    )
    Image.new("L", (8000, 8000)).save(d / "black-8000.png")
    head = json.dumps({"format": "fluidnb.strokes", "version": 1, "shape": [H, W]})[:-1]
    (d / "deep.json").write_text(head + ', "strokes": ' + "[" * 200_000 + "]" * 200_000 + "}")
    for name, stroke in (
        ("three-coordinates.json", [[24, 50, 0], [24, 12, 0]]),
        ("booleans.json", [[24, 50], [24, True]]),
    ):
        data = {"format": "fluidnb.strokes", "version": 1, "shape": [H, W], "strokes": [stroke]}
        (d / name).write_text(json.dumps(data))
    return d


SMALL_DB = ["--N", "8", "--augment", "flip", "--words", "16", "--codebook-samples", "5000"]

# A valid run of every command that reads and writes files: ``recipe(d, o)`` with the
# inputs in ``d`` (make_inputs) and the outputs in ``o``.
RECIPES = {
    ("convert",): lambda d, o: ["convert", d / "clip.gif", "--fps", "10", "-o", o / "c.npz"],
    ("flicker",): lambda d, o: [
        *("flicker", d / "photo.png", "--mask", d / "mask.png", "--flow", d / "strokes.json"),
        *("--T", "12", "--f0", "2", "-o", o / "flicker.gif"),
    ],
    ("frost",): lambda d, o: [
        *("frost", d / "photo.png", "--region", d / "mask.png", "--start", "30,24"),
        *("--spacing", "3", "--beta", "0.6", "--every", "20"),
        *("--freeze-times", o / "freeze.npz", "-o", o / "frost.gif"),
    ],
    ("fire",): lambda d, o: [
        *("fire", d / "fire.png", "--matte", d / "fire-matte.png", "--sim", d / "sim.npz"),
        *("--frames", "3", "--interval", "2", "--overlap", "1", "--no-second-pass"),
        *("-o", o / "fire.gif", "--temperature-output", o / "temperature.gif"),
    ],
    ("turbulence",): lambda d, o: [
        *("turbulence", "--target", d / "target.npz", "--source", d / "source.npz"),
        *("-o", o / "synth.npz", "--render", o / "synth.gif"),
    ],
    ("videodb", "build"): lambda d, o: [
        *("videodb", "build", o / "newdb", d / "right.mp4", d / "frames", "--kind", "water"),
        *SMALL_DB,
    ],
    ("videodb", "add"): lambda d, o: ["videodb", "add", d / "db", d / "frames"],
    ("animate",): lambda d, o: [
        *("animate", d / "photo.png", "--matte", d / "mask.png", "--db", d / "db"),
        *("--strokes", d / "strokes.json", "--speed", d / "speed.png"),
        *("--background", d / "background.png", "--candidates", "5", "--loop", "2"),
        *("-o", o / "animate.gif"),
    ],
    ("scene",): lambda d, o: [
        *("scene", d / "photo.png", "--water", d / "mask.png", "--clouds", d / "mask.png"),
        *("--flicker", d / "mask.png", "--fire", d / "mask.png", "--frost", d / "mask.png"),
        *("--strokes", d / "strokes.json", "--save-scene", o / "scene", "-o", o / "scene.gif"),
    ],
}
