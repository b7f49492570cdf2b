"""Contact sheets of the flicker method on photos it was not tuned on.

The bundled samples (``fluidnb.data``) are the photos the defaults were tuned on; these
come from other installed packages: scikit-image's ``grass`` texture (wind over grass,
a stand-in for a stream's surface) and scikit-learn's ``china.jpg`` (trees, and a lake
behind them). Writes two small PNGs under ``docs/contact/``:

``flicker_flow.png``
    The flow mapping against the paper's symmetric convex mapping: a frame, and x-t
    slices (one image row, stacked over the loop; what changes, contrast-stretched)
    for a stroke to the right, the same stroke reversed, and no stroke at all. Slanted
    streaks are ripples carried along; the reverse stroke slants them the other way.
``flicker_noise.png``
    1/f^2 noise normalised by RMS with a soft clip (the default) against the peak
    (Eq. (10) taken literally): x-t slices of the height and the swing of every frame
    (RMS of the height about C over the region) against the clip without noise; and
    the speed of two ends of the region over the loop, with Eq. (10)'s one noise for
    the whole region (they speed up together) and with four noise regions (beyond the
    paper).

Run: ``python benchmarks/contact_flicker.py`` (about half a minute).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _report import header

from fluidnb import as_image
from fluidnb.fields import resize
from fluidnb.flicker import FlickerModel, FlickerParams, flicker

OUT = Path(__file__).resolve().parent.parent / "docs" / "contact"


def grass(size=192):
    import skimage.data

    img = as_image(skimage.data.grass())
    return np.clip(resize(img, (size, size)), 0, 1)


def china(width=320):
    import sklearn.datasets

    img = as_image(sklearn.datasets.load_sample_image("china.jpg"))
    h, w = img.shape[:2]
    return np.clip(resize(img, (round(h * width / w), width)), 0, 1)


def save(fig, path):
    """A small PNG: 72 dpi, quantised to 128 colours (the sheets are plots and greys)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=72, bbox_inches="tight")
    plt.close(fig)
    Image.open(buf).convert("RGB").quantize(128).save(path, optimize=True)


def stretch(x):
    lo, hi = np.percentile(x, [1, 99])
    return np.clip((x - lo) / max(hi - lo, 1e-9), 0, 1)


def xt(frames, row):
    """One row over the loop, what changes only: (T, W)."""
    grey = frames.mean(axis=-1) if frames.ndim == 4 else frames
    line = grey[:, row, :]
    return stretch(line - line.mean(axis=0))


def flow_sheet():
    img = grass()
    h = img.shape[0]
    p = FlickerParams(mapping="flow", T=64, f0=4, beta=0.0, bump=4.0, k=2.0)
    stroke = np.array([[h / 2, 20.0], [h / 2, 20.0 + 32]])  # 32 px per loop: 0.5 px/frame
    runs = {
        "flow, stroke to the right": flicker(img, params=p, flow=stroke).frames,
        "flow, reversed stroke": flicker(img, params=p, flow=stroke[::-1]).frames,
        "convex (paper, symmetric)": flicker(img, params=p.replace(mapping="convex")).frames,
    }
    noisy = flicker(img, params=p.replace(beta=2.0), flow=stroke, seed=0).frames
    fig, axes = plt.subplots(1, 5, figsize=(13, 3.0), gridspec_kw={"wspace": 0.08})
    axes[0].imshow(img, cmap="gray")
    axes[0].plot(stroke[:, 1], stroke[:, 0], color="tab:orange", lw=2)
    axes[0].annotate(
        "", stroke[1, ::-1], stroke[0, ::-1], arrowprops={"arrowstyle": "->", "color": "tab:orange"}
    )
    axes[0].axhline(h // 2 + 20, color="tab:cyan", lw=0.8)
    axes[0].set_title("grass (skimage), stroke, row", fontsize=9)
    row = h // 2 + 20
    for ax, (name, frames) in zip(axes[1:], [*runs.items(), ("flow + 1/f² noise", noisy)]):
        ax.imshow(xt(frames, row), cmap="gray", aspect="auto")
        ax.set_title(f"x-t: {name}", fontsize=9)
        ax.set_xlabel("x (px)", fontsize=8)
    axes[1].set_ylabel("t (frame)", fontsize=8)
    for ax in axes:
        ax.tick_params(labelsize=7)
    axes[0].axis("off")
    save(fig, OUT / "flicker_flow.png")


def noise_sheet():
    img = china()
    h, w = img.shape[:2]
    mask = np.zeros((h, w), bool)
    mask[int(0.6 * h) :, int(0.6 * w) :] = True  # the trees in front, right of the pagoda
    p = FlickerParams(T=64, bump=4.0, k=2.0)
    models = {
        "no noise": FlickerModel(img, mask, p.replace(beta=0.0)),
        "1/f² noise, RMS + soft clip": FlickerModel(img, mask, p, seed=3),
        "1/f² noise, peak (Eq. 10)": FlickerModel(img, mask, p.replace(noise_norm="peak"), seed=3),
    }
    fig = plt.figure(figsize=(13, 5.4))
    grid = fig.add_gridspec(2, 4, height_ratios=[1, 1], wspace=0.15, hspace=0.35)
    ax = fig.add_subplot(grid[0, 0])
    ax.imshow(models["no noise"].frame(0))
    ax.contour(mask, [0.5], colors="tab:orange", linewidths=0.8)
    ax.set_title("china.jpg (scikit-learn), region", fontsize=9)
    ax.axis("off")
    row = int(0.8 * h)  # x-t slices over the region's columns only
    cols = slice(int(0.6 * w), w)
    swings = {}
    for i, (name, model) in enumerate(models.items()):
        H = np.stack([model.height(t) for t in range(p.T)])
        region = H[:, mask] - p.C
        swings[name] = np.sqrt(np.mean(region**2, axis=1))
        a = fig.add_subplot(grid[0, i + 1])
        a.imshow(H[:, row, cols], cmap="gray", vmin=p.C - p.A, vmax=p.C + p.A, aspect="auto")
        a.set_title(f"H x-t: {name}", fontsize=8)
        a.tick_params(labelsize=7)
    a = fig.add_subplot(grid[1, :2])
    for name, s in swings.items():
        a.plot(s / p.A, label=name)
    a.set_xlabel("frame", fontsize=8)
    a.set_ylabel("swing (RMS of H - C) / A", fontsize=8)
    a.set_ylim(0, None)
    a.legend(fontsize=7)
    a.tick_params(labelsize=7)
    # The paper's open problem: every part of the region speeds up at the same time.
    b = fig.add_subplot(grid[1, 2:])
    halves = (slice(int(0.6 * w), int(0.75 * w)), slice(int(0.85 * w), w))
    for k, regions in enumerate((1, 4)):
        model = FlickerModel(img, mask, p.replace(noise_regions=regions), seed=3)
        H = np.stack([model.height(t) for t in range(p.T)])[:, int(0.6 * h) :]
        for half, style in zip(halves, ("-", ":")):
            part = H[:, :, half]
            speed = np.abs(np.roll(part, -1, axis=0) - part).mean(axis=(1, 2))
            b.plot(speed / p.A, style, color=f"C{k + 3}", label=f"noise_regions={regions}")
    b.set_xlabel("frame", fontsize=8)
    b.set_ylabel("mean |H(t+1) - H(t)| / A", fontsize=8)
    b.set_title("speed of two ends of the region (solid, dotted)", fontsize=8)
    b.legend(fontsize=7)
    b.tick_params(labelsize=7)
    save(fig, OUT / "flicker_noise.png")
    return {name: (float(np.median(s) / p.A), float(s.min() / p.A)) for name, s in swings.items()}


def main():
    print(header(__file__))
    OUT.mkdir(parents=True, exist_ok=True)
    flow_sheet()
    swings = noise_sheet()
    for name, (median, low) in swings.items():
        print(f"{name:40s} median swing {median:.3f} A, lowest frame {low:.3f} A")
    for png in sorted(OUT.glob("flicker*.png")):
        print(f"{png.relative_to(OUT.parent.parent)}: {png.stat().st_size / 1024:.0f} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
