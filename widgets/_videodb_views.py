"""The video-database app's views: the assignment map, its fragment strip, the energy plot.

Pictures of what :mod:`fluidnb.videodb` returned, drawn by the library's rules
(:func:`fluidnb.videodb.clip_map_picture`, :func:`fluidnb.videodb.motion_arrows`);
no algorithm here.
"""

from __future__ import annotations

import html
import io

import ipywidgets as W
import numpy as np
from ipycanvas import MultiCanvas, hold_canvas
from PIL import Image

from fluidnb import to_uint8
from fluidnb.fields import resize
from fluidnb.sketch import segment_heads
from fluidnb.videodb import FRAGMENT, STRIDE
from fluidnb.videodb.figures import clip_colour, clip_map_picture, motion_arrows

__all__ = ["AssignmentMap", "energy_html", "energy_svg", "stats_html", "strip_png"]

MAP_WIDTH = 300  # the assignment map's width on screen, as the player's picture
_TILE = 60  # pixels per tile of the fragment view


class AssignmentMap(W.VBox):
    """Which source clip each target fragment came from; a click shows that fragment.

    Drawn by the library's rule for pictures of an assignment
    (:func:`fluidnb.videodb.clip_map_picture`, :func:`fluidnb.videodb.motion_arrows`),
    the one the lesson's figures use.
    """

    def __init__(self, width=MAP_WIDTH):
        self.width = int(width)
        self.photo = None
        self.assignment = None
        self.selected = None  #: index of the picked target fragment, or None
        self.on_pick = None  #: called with the picked index
        self.canvas = MultiCanvas(2, width=self.width, height=int(0.75 * self.width))
        self.canvas.layout.width = "100%"
        self.canvas.layout.max_width = f"{self.width}px"
        self.canvas.layout.height = "auto"
        self.canvas.add_class("fluidnb-vdb-map")
        self.canvas.on_mouse_down(self._clicked)
        # Voila drops drawing sent while the notebook runs: redraw for every new view.
        self.canvas.on_client_ready(self.redraw)
        self.legend = W.HTML()
        self.legend.add_class("fluidnb-vdb-legend")
        self.caption = W.HTML(layout=W.Layout(max_width=f"{self.width}px"))
        self.caption.add_class("fluidnb-vdb-fragment")
        self.strip = W.Image(format="png", layout=W.Layout(display="none"))
        self.strip.add_class("fluidnb-vdb-fragment-frames")
        super().__init__([self.canvas, self.legend, self.caption, self.strip])
        self.add_class("fluidnb-vdb-mapbox")

    @property
    def scale(self):
        """Canvas pixels per image pixel."""
        return self.canvas.width / self.photo.shape[1]

    def set_photo(self, photo):
        self.photo = photo
        self.assignment = None
        self.selected = None
        h, w = photo.shape[:2]
        self.canvas.width = self.width
        self.canvas.height = ch = max(1, round(h * self.width / w))
        # The photo at the canvas's size once (each re-solve only re-tints it), and the
        # image pixel under each canvas pixel, as clip_map_picture samples the clips.
        self._shown = resize(photo, (ch, self.width))
        self._rows = np.minimum((np.arange(ch) * h / ch).astype(int), h - 1)
        self._cols = np.minimum((np.arange(self.width) * w / self.width).astype(int), w - 1)
        self.strip.layout.display = "none"
        self.caption.value = ""
        self.legend.value = (
            "<span style='opacity:0.7'>Press Run: each fragment is coloured by the "
            "source clip it came from; click one to see it.</span>"
        )
        self.redraw()

    def set_assignment(self, assignment):
        self.assignment = assignment
        if self.selected is not None and self.selected >= len(assignment.target):
            self.selected = None
        self.legend.value = self._legend()
        self.redraw()
        if self.selected is not None and self.on_pick is not None:
            self.on_pick(self.selected)

    # ------------------------------------------------------------------ drawing
    def picture(self):
        """The map as RGB uint8 at canvas size: the photo tinted by source clip."""
        a = self.assignment
        clips = None if a is None else a.clip_map()[self._rows][:, self._cols]
        return to_uint8(clip_map_picture(self._shown, clips))

    def redraw(self, *_):
        if self.photo is None:
            return
        with hold_canvas():
            self.canvas[0].put_image_data(self.picture(), 0, 0)
            self._draw_marks()

    def _draw_marks(self):
        layer = self.canvas[1]
        layer.clear()
        a = self.assignment
        if a is None:
            return
        s = self.scale
        pos = a.target.positions.astype(float)
        # Cell outlines (each fragment owns the 24 x 24 cell at its centre), and the
        # arrows with their heads, each in one batched command: a re-solve redraws
        # them while a slider moves.
        layer.stroke_style = "rgba(0, 0, 0, 0.35)"
        layer.line_width = 1
        corner = (pos[:, ::-1] + STRIDE / 2) * s  # (x, y)
        layer.stroke_rects(corner[:, 0], corner[:, 1], STRIDE * s, STRIDE * s)
        arrows = (self.motion_segments()[..., ::-1] + 0.5) * s  # (row, col) -> (x, y)
        if len(arrows):
            lines = np.concatenate([arrows, segment_heads(arrows, size=3.5)])
            layer.stroke_style = "rgba(255, 255, 255, 0.95)"
            layer.line_width = 1.5
            layer.stroke_line_segments(lines.reshape(-1, 2), np.full(len(lines), 2))
        if self.selected is not None:
            r, c = pos[self.selected]
            layer.stroke_style = "rgba(255, 214, 10, 1)"
            layer.line_width = 2
            layer.stroke_rect(c * s, r * s, FRAGMENT * s, FRAGMENT * s)

    def motion_segments(self):
        """The assigned fragments' mean motion as arrows (k, 2, 2) (row, col) in the image.

        :func:`fluidnb.videodb.motion_arrows`: one per moving fragment, centred on it.
        """
        if self.assignment is None:
            return np.empty((0, 2, 2))
        return motion_arrows(self.assignment)[0]

    def _legend(self):
        a = self.assignment
        clips = a.db.clip_of(a.fragments)
        used, counts = np.unique(clips, return_counts=True)
        items = []
        for k, n in zip(used, counts):
            r, g, b = (round(255 * v) for v in clip_colour(k))
            name = html.escape(str(a.db.clips[int(k)]["name"]))
            items.append(
                f"<span class='fluidnb-vdb-clip' data-clip='{int(k)}' style='display:inline-flex;"
                "align-items:center;margin-right:10px;white-space:nowrap'>"
                f"<span style='display:inline-block;width:11px;height:11px;margin-right:4px;"
                f"background:rgb({r},{g},{b});border:1px solid rgba(127,127,127,0.6)'></span>"
                f"{name} ({n})</span>"
            )
        return (
            f"<div style='font-size:12px;line-height:1.6;max-width:{self.width}px'>"
            f"{''.join(items)}</div>"
        )

    def show_fragment(self, info, assignment):
        """The database fragment a target fragment got: its mean image, frames, words.

        ``info`` is :meth:`fluidnb.videodb.Assignment.fragment_info`'s.
        """
        db = assignment.db
        n = db.params.N
        mean = db.mean_images([info["fragment"]])[0]
        picks = np.linspace(0, n - 1, 4).round().astype(int)
        frames = db.fragment_frames([info["fragment"]])[0][picks]
        self.strip.value = strip_png([mean, *frames])
        self.strip.layout.display = ""
        v = info["version"]
        flip = "flipped, " if v["flip"] else ""
        dy, dx = info["mean_motion"]
        self.caption.value = (
            "<div style='font-size:12px;line-height:1.4'>"
            f"fragment <b>{info['fragment']}</b> from <b>{html.escape(info['clip_name'])}</b> "
            f"({flip}scale {v['scale']:g}, {v['angle']:g}°), frames {info['frames'][0]}–"
            f"{info['frames'][1]}; mean motion ({dy:.2f}, {dx:.2f}) px/frame (dy, dx); "
            f"candidate {info['rank'] + 1} of {assignment.candidates.shape[1]}, "
            f"I = {info['score']:.2f}.<br><span style='opacity:0.75'>mean image A, then "
            f"frames {', '.join(str(p) for p in picks)}</span></div>"
        )

    # ------------------------------------------------------------------ picking
    def fragment_at(self, row, col):
        """The target fragment under image pixel (row, col), or None (see the library's)."""
        return None if self.assignment is None else self.assignment.fragment_at(row, col)

    def _clicked(self, x, y):
        if self.photo is None:
            return
        s = self.scale
        i = self.fragment_at(y / s - 0.5, x / s - 0.5)
        if i is None:
            return
        self.selected = i
        with hold_canvas():
            self._draw_marks()
        if self.on_pick is not None:
            self.on_pick(i)


def energy_html(a):
    """The energy of Eq. (4) per alpha-expansion sweep (ICM's dashed), with its values."""
    if a is None:
        return (
            "<div style='opacity:0.75;font-size:12px;line-height:1.4'>The energy of "
            "Eq. (4) after each alpha-expansion sweep appears here after a run, with "
            "ICM's as a reference.</div>"
        )
    s = a.solution
    sweeps = f"{s.sweeps} sweep{'s' if s.sweeps != 1 else ''}"
    return energy_svg(np.asarray(s.energies, float), float(s.icm_energy)) + (
        "<div style='font-size:12px;line-height:1.4'>"
        f"alpha-expansion: E = {s.energy:.5g} after {sweeps} (from the "
        f"{html.escape(s.start)} start) · ICM: {s.icm_energy:.5g}<br>"
        f"σ = {a.params.sigma:.3g}, λ = {a.params.lam:.3g}, ρ = {a.params.rho:.3g}</div>"
    )


def stats_html(retrievals, resolves, renders):
    """The app's counters in a line (the tests read them from the page)."""
    return (
        "<div style='font-size:12px;opacity:0.85;margin-top:4px'>"
        f"retrievals <b class='fluidnb-vdb-retrievals'>{retrievals}</b> · "
        f"re-solves <b class='fluidnb-vdb-resolves'>{resolves}</b> · "
        f"renders <b class='fluidnb-vdb-renders'>{renders}</b></div>"
    )


def strip_png(images):
    """Tiles side by side (float RGB (48, 48, 3) each) as a PNG with transparent gaps."""
    gap = 4
    n = len(images)
    out = np.zeros((_TILE, n * _TILE + (n - 1) * gap, 4), np.uint8)
    for k, img in enumerate(images):
        x = k * (_TILE + gap)
        out[:, x : x + _TILE, :3] = to_uint8(np.clip(resize(img, (_TILE, _TILE)), 0, 1))
        out[:, x : x + _TILE, 3] = 255
    buf = io.BytesIO()
    Image.fromarray(out).save(buf, format="png")
    return buf.getvalue()


def _tick(value):
    """An axis label of at most 6 characters: 7738, 1.72e4, 0.0123 (the SVG's margin)."""
    text = f"{value:.4g}"
    if len(text) > 6:
        text = f"{value:.2e}".replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")
    return text


def energy_svg(energies, icm, width=280, height=150):
    """A small line plot (inline SVG, theme colours) of the energy after each sweep."""
    left, right, top, bottom = 52, 10, 10, 26
    values = np.append(energies, icm)
    lo, hi = float(values.min()), float(values.max())
    pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
    lo, hi = lo - pad, hi + pad
    n = len(energies)

    def x(i):
        return left + (i / max(n - 1, 1)) * (width - left - right)

    def y(v):
        return top + (hi - v) / (hi - lo) * (height - top - bottom)

    pts = " ".join(f"{x(i):.1f},{y(v):.1f}" for i, v in enumerate(energies))
    dots = "".join(
        f"<circle cx='{x(i):.1f}' cy='{y(v):.1f}' r='3' fill='var(--jp-brand-color1, #1976d2)'/>"
        for i, v in enumerate(energies)
    )
    ticks = "".join(
        f"<text x='{x(i):.1f}' y='{height - 10}' text-anchor='middle'>{i}</text>" for i in range(n)
    )
    axis = "stroke='currentColor' stroke-opacity='0.5'"
    return (
        f"<svg class='fluidnb-vdb-energy-plot' width='{width}' height='{height}' "
        "style='color:var(--jp-ui-font-color1, #333);font-size:10px' "
        f"data-energies='{','.join(f'{e:.6g}' for e in energies)}' data-icm='{icm:.6g}'>"
        f"<line x1='{left}' y1='{top}' x2='{left}' y2='{height - bottom}' {axis}/>"
        f"<line x1='{left}' y1='{height - bottom}' x2='{width - right}' y2='{height - bottom}' "
        f"{axis}/>"
        f"<text x='{left - 4}' y='{y(hi - pad) + 3:.1f}' text-anchor='end' "
        f"fill='currentColor'>{_tick(hi - pad)}</text>"
        f"<text x='{left - 4}' y='{y(lo + pad) + 3:.1f}' text-anchor='end' "
        f"fill='currentColor'>{_tick(lo + pad)}</text>"
        f"<g fill='currentColor' fill-opacity='0.8'>{ticks}</g>"
        f"<text x='{width - right}' y='{height - 1}' text-anchor='end' fill='currentColor' "
        "fill-opacity='0.8'>sweep</text>"
        f"<line x1='{left}' y1='{y(icm):.1f}' x2='{width - right}' y2='{y(icm):.1f}' "
        "stroke='var(--jp-warn-color1, #f57c00)' stroke-width='1.5' stroke-dasharray='5,4'/>"
        f"<text x='{width - right}' y='{y(icm) - 4:.1f}' text-anchor='end' "
        "fill='var(--jp-warn-color1, #f57c00)'>ICM</text>"
        f"<polyline points='{pts}' fill='none' stroke='var(--jp-brand-color1, #1976d2)' "
        "stroke-width='2'/>"
        f"{dots}</svg>"
    )
