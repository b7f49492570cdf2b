"""Video-database animations on photos, before and after issue 24: contact sheets and numbers.

    python benchmarks/contact_videodb.py [--fresh FOLDER] [-o docs/contact/videodb_after.png]

Cases (each a row of the sheet; mattes and strokes painted by code, never tuned to the
result), all at 320 px wide on the full starter databases:

- ``stream``: the bundled stream photo, its drawn water region, a stroke left to right
  and 2 px/frame painted over the water (the issue's test); also 0.5 px/frame;
- ``clouds``: the bundled clouds-over-rocks photo with its drawn cloud (the overview's
  row: smoke database, its defaults, tau 0.5);
- ``fire``: the bundled fire cut-out, a stroke upwards;
- ``smoke over a photo``: a smoke cut-out (a frame of the smoke starter's solver clip,
  its density as alpha) laid over a real photo, animated with the smoke database
  (tau 0.5: the moving outline uncovers the photo, filled by the inpainting).

With ``--fresh FOLDER`` (photos nobody here tuned on: Debian's
``plasma-workspace-wallpapers`` ``BytheWater`` and ``Path`` 1920x1080 and
``mate-backgrounds`` ``nature/Storm.jpg``, unpacked with ``apt-get download`` and
``dpkg-deb -x`` into FOLDER) three more rows: the lake beyond a pier (a polygon over
the water, a stroke left to right, 1 px/frame), the storm clouds (a polygon above the
horizon, a stroke left to right), and smoke over the forest path.

With ``--real DATABASE`` (a database built from real footage, e.g. issue 35's two clips
from Debian packages, a rocket launch's exhaust and churning white water:
``fluidnb videodb build DATABASE oa4_launch.webm diver.mov --kind water``) one more row:
the stream with its region and no strokes, animated from it.

Each row: the photo with its matte's outline and strokes, frames 0, T/3 and 2T/3, and
an x-t slice (one row of pixels through the matte, time going down: slanted streaks
are motion). Printed per case: the painted speed, the optical flow of the output
(the library's, OpenCV DIS, preset MEDIUM, between consecutive frames, mean over the
matte: ``benchmarks/videodb/_common.py``'s ``output_motion``), its
ratio to the painted speed and its angle to the strokes, the share of
neighbouring target fragments that play the same database fragment in sync, and the
look's measures (``/work/shared/notes/measuring-the-look.md``; issue 35): each frame's
sharpness, the Laplacian variance of its grey levels inside the matte (eroded by 12 px)
over the photo's (min, median, min/max over the frames), the mean |frame difference|
inside it (/255) and the mean DIS flow magnitude (px/frame).

Run against the code before issue 24 (no ``rendering`` parameter) the same script
renders the paper's way, which is how ``videodb_before.png`` was made.

Two more sheets (with the new code only):

- ``videodb_clouds_sync.png``: the overview's clouds (480 x 300, its stroke, 100
  candidates), the cloud cropped, two frames per row: the paper's rendering with every
  fragment in sync (no loop: every fragment from its first frame, none mirrored, as the
  code before issue 24 played them), the paper's rendering with the offsets and
  mirrors, and the flow rendering;
- ``videodb_fill.png``: what a moving matte uncovers, filled by Telea's diffusion
  (``cv2.inpaint``, before) and by the exemplar fill (after), on the clouds over rocks
  and on the smoke cut-out over a photo.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import cv2
import numpy as np
from _report import header
from PIL import Image, ImageDraw
from videodb._common import output_motion

from fluidnb import data, to_uint8
from fluidnb.videodb import AnimateParams, assign, open_database, render, starter_database
from fluidnb.videodb.starter import starter_clips

NEW_API = "rendering" in AnimateParams.specs()
SIZE = (180, 320)
THUMB = 160  # pixels per frame on the sheet (kept small: the PNGs are committed)


def polygon(shape, points):
    """A soft matte from a polygon of (row, col) fractions of the image."""
    h, w = shape
    im = Image.new("L", (w, h), 0)
    ImageDraw.Draw(im).polygon([(c * w, r * h) for r, c in points], fill=255)
    m = np.asarray(im, np.float32) / 255
    return cv2.GaussianBlur(m, (0, 0), 1.5)


def resized(path, shape=SIZE):
    img = Image.open(path).convert("RGB").resize(shape[::-1], Image.LANCZOS)
    return np.asarray(img, np.float32) / 255


def smoke_cutout(backdrop, seed=0):
    """A smoke density frame from the smoke starter's clips as alpha over ``backdrop``."""
    clips = starter_clips("smoke", quick=True)
    frames = clips[seed % len(clips)][1].frames
    f = np.asarray(frames[len(frames) // 2], np.float32)
    density = f.mean(axis=2) if f.ndim == 3 else f
    density = cv2.resize(density, SIZE[::-1], interpolation=cv2.INTER_AREA)
    alpha = np.clip(density / max(float(np.percentile(density, 99.5)), 1e-6), 0, 1)
    # The solver leaves a faint haze over its whole box: a cut-out ends where smoke does.
    alpha = np.clip((alpha - 0.05) / 0.95, 0, 1)
    smoke = np.array([0.86, 0.87, 0.9], np.float32)
    img = backdrop * (1 - alpha[..., None]) + smoke * alpha[..., None]
    return img.astype(np.float32), alpha.astype(np.float32)


def cases(fresh, real=None):
    h, w = SIZE
    stream, stream_m = (
        data.sample("stream", size=SIZE, mode="rgb"),
        data.region("stream", size=SIZE),
    )
    right = [np.array([[0.5 * h, 0.05 * w], [0.5 * h, 0.95 * w]])]
    out = [
        ("stream, stroke right, 2 px/frame", "water", stream, stream_m, right, 2.0),
        ("stream, stroke right, 0.5 px/frame", "water", stream, stream_m, right, 0.5),
        (
            "clouds over rocks (overview)",
            "smoke",
            data.sample("clouds", size=SIZE, mode="rgb"),
            data.region("clouds", size=SIZE),
            None,
            None,
        ),
    ]
    if real is not None:
        out.append(
            ("stream, real-footage database, no strokes", real, stream, stream_m, None, None)
        )
    fire, fire_a = data.sample("fire", return_alpha=True)
    fire = cv2.resize(fire, (120, 250), interpolation=cv2.INTER_AREA)
    fire_a = cv2.resize(fire_a, (120, 250), interpolation=cv2.INTER_AREA)
    up = [np.array([[0.95 * 250, 60.0], [0.1 * 250, 60.0]])]
    out.append(("fire cut-out, stroke up", "fire", fire, fire_a, up, None))
    smoke, alpha = smoke_cutout(data.sample("lake", size=SIZE, mode="rgb"))
    out.append(("smoke cut-out over the lake photo", "smoke", smoke, alpha, right, None))
    if fresh is not None:
        root = Path(fresh)
        lake = resized(root / "usr/share/wallpapers/BytheWater/contents/images/1920x1080.jpg")
        lake_m = polygon(SIZE, [(0.27, 0), (0.25, 1), (0.35, 1), (0.5, 0)])
        out.append(
            ("lake beyond a pier, stroke right, 1 px/frame", "water", lake, lake_m, right, 1.0)
        )
        storm = resized(root / "usr/share/backgrounds/mate/nature/Storm.jpg")
        storm_m = polygon(SIZE, [(0, 0), (0, 1), (0.55, 1), (0.6, 0)])
        out.append(("storm clouds, stroke right", "smoke", storm, storm_m, right, None))
        path = resized(root / "usr/share/wallpapers/Path/contents/images/1920x1080.jpg")
        smoke, alpha = smoke_cutout(path, seed=1)
        out.append(("smoke cut-out over a forest path", "smoke", smoke, alpha, right, None))
    return out


def look(frames, photo, matte):
    """Sharpness per frame over the photo's, mean |frame difference| (/255), DIS |flow|."""

    def grey(f):
        return cv2.cvtColor(to_uint8(f), cv2.COLOR_RGB2GRAY)

    inner = cv2.erode((matte > 0.5).astype(np.uint8), np.ones((25, 25), np.uint8)) > 0
    ref = cv2.Laplacian(grey(photo), cv2.CV_32F)[inner].var()
    sharp = np.array([cv2.Laplacian(grey(f), cv2.CV_32F)[inner].var() / ref for f in frames])
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    g = [grey(f) for f in frames]
    diff = np.mean([np.abs(a.astype(np.float32) - b)[inner].mean() for a, b in zip(g, g[1:])])
    mag = np.mean([np.hypot(*dis.calc(a, b, None)[inner].T).mean() for a, b in zip(g, g[1:])])
    return sharp, float(diff), float(mag)


def thumb(frame, height=THUMB * 9 // 16):
    h, w = frame.shape[:2]
    size = (max(1, round(w * height / h)), height)
    return np.asarray(Image.fromarray(to_uint8(frame)).resize(size, Image.LANCZOS)) / 255.0


def row(photo, matte, strokes, frames):
    shown = (photo * 0.85 + 0.15 * (matte > 0.5)[..., None]).clip(0, 1)
    im = Image.fromarray(to_uint8(shown))
    draw = ImageDraw.Draw(im)
    for s in strokes or []:
        draw.line([(float(c), float(r)) for r, c in s], fill=(255, 40, 40), width=3)
    t = len(frames)
    r = int(np.argmax((matte > 0.5).sum(axis=1)))  # the row with the most fluid
    xt = np.repeat(frames[:, r], max(1, 96 // t), axis=0)[:96]
    tiles = [np.asarray(im) / 255.0] + [frames[i] for i in (0, t // 3, 2 * t // 3)]
    tiles = [thumb(x) for x in tiles] + [thumb(xt)]
    return np.concatenate(tiles, axis=1)


def sync_sheet(path):
    """The overview's clouds: in sync, with offsets and mirrors, and the flow rendering."""
    photo, matte = data.sample("clouds", mode="rgb"), data.region("clouds")
    h, w = matte.shape
    stroke = np.array([(0.5, 0.1), (0.45, 0.9)]) * (h, w)
    params = AnimateParams.for_kind("smoke", candidates=100)
    a = assign(photo, matte, starter_database("smoke"), params, direction=[stroke])
    paper = params.replace(rendering="paper")
    # Every fragment from its first frame, none mirrored, as before issue 24: the
    # rendering without a loop (loop 0) starts no fragment late (and cross-fades none).
    before = render(a, paper.replace(loop=0))
    runs = {
        "paper, in sync (before)": before,
        "paper, offsets and mirrors (after)": render(a, paper),
        "flow (after)": render(a, params),
    }
    crop = (slice(20, 180), slice(20, 340))
    rows = []
    from fluidnb.videodb.rendering import sync_share

    for name, anim in runs.items():
        f = anim.clip.frames
        share = sync_share(
            a.fragments, a.target.positions, anim.stages["offsets"], anim.stages["mirrors"]
        )
        print(f"{'clouds: ' + name:>48} in sync: {share:.2f}")
        rows.append(np.concatenate([f[0][crop], f[len(f) // 2][crop]], axis=1))
    sheet = np.concatenate([np.pad(r, ((0, 2), (0, 0), (0, 0))) for r in rows])
    Image.fromarray(to_uint8(sheet)).save(path)
    print(f"wrote {path}")


def look_sheet(path):
    """Crops at full size: the stream's water mid-blend, the overview's cloud's lower edge.

    The stream (480 x 376, its region, a stroke right and 2 px/frame painted): frames 0,
    T/4 and T/2 cropped to the water, where the cross-fade of two displaced copies
    doubled the rocks' edges and washed the foam out; the overview's clouds (480 x 300,
    its stroke): frames 0 and T/2 cropped to the cloud's lower edge, where the dark band
    was (issue 35).
    """
    rows = []
    photo, matte = data.sample("stream", mode="rgb"), data.region("stream")
    h, w = matte.shape
    right = [np.array([[0.5 * h, 0.05 * w], [0.5 * h, 0.95 * w]])]
    speed = np.where(matte > 0.5, 2.0, 0).astype(np.float32)
    params = AnimateParams.for_kind("water")
    a = assign(photo, matte, starter_database("water"), params, direction=right, speed=speed)
    f = render(a, params).clip.frames
    crop = (slice(150, 310), slice(0, 240))
    rows.append(
        np.concatenate([photo[crop]] + [f[i][crop] for i in (0, len(f) // 4, len(f) // 2)], axis=1)
    )
    photo, matte = data.sample("clouds", mode="rgb"), data.region("clouds")
    h, w = matte.shape
    stroke = np.array([(0.5, 0.1), (0.45, 0.9)]) * (h, w)
    params = AnimateParams.for_kind("smoke")
    a = assign(photo, matte, starter_database("smoke"), params, direction=[stroke])
    f = render(a, params).clip.frames
    crop = (slice(60, 220), slice(20, 260))
    rows.append(
        np.concatenate([photo[crop]] + [f[i][crop] for i in (0, len(f) // 3, len(f) // 2)], axis=1)
    )
    sheet = np.concatenate([np.pad(r, ((0, 2), (0, 0), (0, 0))) for r in rows])
    Image.fromarray(to_uint8(sheet)).save(path)
    print(f"wrote {path}")


def fill_sheet(path, fresh):
    """Telea's diffusion against the exemplar fill, behind the clouds and a smoke cut-out."""
    from scipy import ndimage as ndi

    from fluidnb.videodb.rendering import exemplar_fill

    backdrop = (
        data.sample("lake", size=SIZE, mode="rgb")
        if fresh is None
        else resized(Path(fresh) / "usr/share/wallpapers/Path/contents/images/1920x1080.jpg")
    )
    smoke, alpha = smoke_cutout(backdrop, seed=1)
    scenes = [
        (data.sample("clouds", size=SIZE, mode="rgb"), data.region("clouds", size=SIZE)),
        (smoke, alpha),
    ]
    rows = []
    for photo, matte in scenes:
        hole = ndi.binary_dilation(matte > 0, ndi.generate_binary_structure(2, 2), 2)
        telea = np.stack(
            [
                cv2.inpaint(to_uint8(photo[..., c]), hole.astype(np.uint8), 3, cv2.INPAINT_TELEA)
                for c in range(3)
            ],
            axis=-1,
        )
        t0 = time.perf_counter()
        ours = exemplar_fill(photo, hole)
        print(
            f"{'fill of ' + str(int(hole.sum())) + ' pixels':>48} {time.perf_counter() - t0:.2f} s"
        )
        rows.append(np.concatenate([photo, telea / 255.0, ours], axis=1))
    sheet = np.concatenate([np.pad(r, ((0, 2), (0, 0), (0, 0))) for r in rows])
    Image.fromarray(to_uint8(sheet)).save(path)
    print(f"wrote {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fresh", help="folder with the unpacked Debian wallpapers (see above)")
    parser.add_argument(
        "-o", "--output", default="docs/contact/videodb_after.png", help="the sheet ('-': none)"
    )
    parser.add_argument("--rendering", default=None, help="flow or paper (default: the default)")
    parser.add_argument("--real", help="a database built from real footage (see above)")
    parser.add_argument("--look-output", help="also the full-size crops of look_sheet")
    parser.add_argument("--sync-output", help="also the clouds' sync sheet (new code only)")
    parser.add_argument("--fill-output", help="also the fill sheet (new code only)")
    args = parser.parse_args()
    print(header(__file__))
    if args.sync_output:
        sync_sheet(args.sync_output)
    if args.fill_output:
        fill_sheet(args.fill_output, args.fresh)
    if args.look_output:
        look_sheet(args.look_output)
    if args.output == "-":
        return
    rows = []
    print(
        f"{'case':>48} {'painted':>7} {'flow (dy, dx)':>16} {'speed':>6} {'ratio':>5} "
        f"{'angle':>6} {'sync':>11} {'frames':>6} {'render':>7} "
        f"{'sharp min/med/min:max':>21} {'diff':>5} {'|flow|':>6}"
    )
    for name, kind, photo, matte, strokes, painted in cases(args.fresh, args.real):
        db = starter_database(kind) if kind in ("water", "smoke", "fire") else open_database(kind)
        kind = db.kind
        speed = None if painted is None else np.where(matte > 0.5, painted, 0).astype(np.float32)
        params = AnimateParams.for_kind(kind)
        if NEW_API and args.rendering:
            params = params.replace(rendering=args.rendering)
        a = assign(photo, matte, db, params, direction=strokes, speed=speed)
        t0 = time.perf_counter()
        anim = render(a, params)
        seconds = time.perf_counter() - t0
        frames = anim.clip.frames
        fluid = matte > 0.5
        flow = output_motion(frames, fluid)
        mag = float(np.hypot(*flow))
        ratio = "-" if painted is None else f"{mag / painted:.2f}"
        angle = "-"
        if strokes is not None:
            s = strokes[0]
            want = np.arctan2(*(s[-1] - s[0]))
            got = np.arctan2(*flow)
            angle = f"{np.degrees(np.angle(np.exp(1j * (got - want)))):+.0f}"
        sync = "-"
        if NEW_API:
            from fluidnb.videodb.rendering import sync_share

            before = sync_share(a.fragments, a.target.positions)
            after = sync_share(
                a.fragments, a.target.positions, anim.stages["offsets"], anim.stages["mirrors"]
            )
            sync = f"{before:.2f}->{after:.2f}"
        sharp, diff, flow_mag = look(frames, photo, matte)
        print(
            f"{name:>48} {painted or '-':>7} {np.array2string(flow, precision=3):>16} "
            f"{mag:6.3f} {ratio:>5} {angle:>6} {sync:>11} {len(frames):>6} {seconds:6.2f}s "
            f"{sharp.min():5.2f}/{np.median(sharp):5.2f}/{sharp.min() / sharp.max():5.2f} "
            f"{diff:5.2f} {flow_mag:6.2f}"
        )
        rows.append(row(photo, matte, strokes, frames))
    width = max(r.shape[1] for r in rows)
    sheet = np.concatenate([np.pad(r, ((0, 2), (0, width - r.shape[1]), (0, 0))) for r in rows])
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(to_uint8(sheet)).save(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
