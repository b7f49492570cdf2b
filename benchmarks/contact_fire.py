"""Fire on photos it was not tuned on: a contact sheet and the numbers behind it.

    python benchmarks/contact_fire.py [PHOTO ...] [-o docs/contact/fire_after.png]

One flame simulation (the preset, 128 x 128, seed 0) is painted with each photo by
:func:`fluidnb.fire.fire`. Always included: the bundled fire photo as an editor saves a
cut-out (straight RGBA, random colour in its transparent pixels). Any further PHOTO
(an RGBA cut-out or a photo of fire on black) is added as a row; the sheet in
``docs/contact/`` used the Tux Paint stamps ``naturalforces/fire.png`` (the original
cut-out, whose transparent pixels hold orange) and ``seasonal/candle.png`` (a real
candle flame, cropped to its top 300 rows), from the Debian package
``tuxpaint-stamps-default`` (``apt-get download``; GPL-2.0-or-later).

Each row: the photo over a grey checkerboard (so its alpha shows), then five frames.
Printed per photo: r (output luminance against the normalised temperature), the
luminance where the gas is cold (should be 0), the mean colour of the hottest decile
against the photo's brightest decile, and the sharpness (Laplacian variance) of the
last frames over the first.

Run against the code before issue 16 (``fire_flame`` in ``fluidnb.fire``) the same
script calls the old API, which is how ``fire_before.png`` was made.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _report import header
from PIL import Image
from scipy import ndimage

import fluidnb.fire as F
from fluidnb import as_image, data, to_uint8
from fluidnb.fluid import flame_preset

LUMA = np.array([0.2126, 0.7152, 0.0722])
OLD_API = hasattr(F, "fire_flame")
SHOWN = (12, 20, 28, 36, 47)
SIZE = 100  # pixels per frame on the sheet (kept small: the PNGs are committed)


def cutout_of_the_sample(seed=0):
    """The bundled fire photo as a straight-alpha RGBA cut-out with junk where clear."""
    rgb, alpha = data.sample("fire", return_alpha=True)  # stored over black
    straight = np.clip(rgb / np.maximum(alpha[..., None], 1e-6), 0, 1)
    junk = np.random.default_rng(seed).random(rgb.shape)
    straight = np.where(alpha[..., None] > 0, straight, junk)
    return np.dstack([straight, alpha]).astype(np.float32)


def run(rgba, temperature, velocity):
    rgb, alpha = rgba[..., :3], rgba[..., 3]
    if OLD_API:  # what `fluidnb fire cut.png` did: RGB plus its alpha as the matte
        return F.fire(rgb, temperature, velocity, matte=alpha, seed=0)
    return F.fire(rgba, (temperature, velocity), seed=0)


def numbers(result, rgba, normalised):
    frames = result.clip.frames
    lum = frames @ LUMA
    photo = rgba[..., :3] * rgba[..., 3:]
    plum = photo @ LUMA
    flame = plum > 0.05 * plum.max()
    brightest = photo[flame & (plum >= np.quantile(plum[flame], 0.9))].mean(0)
    hot = normalised >= np.quantile(normalised[normalised > 0.05], 0.9)
    sharp = [ndimage.laplace(f @ LUMA).var() for f in frames]
    return {
        "r": np.corrcoef(lum.ravel(), normalised.ravel())[0, 1],
        "cold": lum[normalised < 0.01].mean(),
        "hot": frames[hot].mean(0),
        "photo": brightest,
        "sharpness": np.mean(sharp[-8:]) / np.mean(sharp[4:12]),
    }


def shrink(frame, size):
    im = Image.fromarray(to_uint8(frame)).resize((size, size), Image.LANCZOS)
    return np.asarray(im).astype(np.float32) / 255


def thumbnail(rgba, size):
    h, w = rgba.shape[:2]
    scale = size / max(h, w)
    shape = (max(1, round(w * scale)), max(1, round(h * scale)))
    im = Image.fromarray(to_uint8(rgba), mode="RGBA").resize(shape, Image.LANCZOS)
    yy, xx = np.mgrid[:size, :size]
    board = np.where((yy // 8 + xx // 8) % 2, 90, 140).astype(np.uint8)
    sheet = Image.fromarray(np.dstack([board] * 3 + [np.full_like(board, 255)]), "RGBA")
    sheet.alpha_composite(im, ((size - shape[0]) // 2, (size - shape[1]) // 2))
    return np.asarray(sheet.convert("RGB")).astype(np.float32) / 255


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("photos", nargs="*", help="more photos (RGBA cut-outs or fire on black)")
    parser.add_argument("-o", "--output", default="docs/contact/fire_after.png")
    args = parser.parse_args()
    print(header(__file__))

    preset = flame_preset()
    sim = preset.simulate(48, seed=0)
    temperature, velocity = sim.temperature, sim.centred_velocity()
    normalised = (temperature - temperature.min()) / np.ptp(temperature)
    photos = [("sample as a cut-out, junk where clear", cutout_of_the_sample())]
    for path in args.photos:
        image, alpha = as_image(path, mode="rgb", return_alpha=True)
        alpha = np.ones(image.shape[:2], np.float32) if alpha is None else alpha
        photos.append((Path(path).name, np.dstack([image, alpha])))

    rows = []
    print(f"{'photo':>40} {'r':>5} {'cold':>6} {'hot decile':>20} {'photo top':>20} sharp")
    for name, rgba in photos:
        result = run(rgba, temperature, velocity)
        n = numbers(result, rgba, normalised)
        hot, top = (np.array2string(n[k], precision=2) for k in ("hot", "photo"))
        print(f"{name:>40} {n['r']:5.2f} {n['cold']:6.3f} {hot:>20} {top:>20} {n['sharpness']:.2f}")
        frames = [shrink(f, SIZE) for f in result.clip.frames[list(SHOWN)]]
        rows.append(np.concatenate([thumbnail(rgba, SIZE), *frames], axis=1))
    sheet = np.concatenate(rows, axis=0)
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(to_uint8(sheet)).save(out, optimize=True)
    print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
