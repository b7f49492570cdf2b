"""A drawing canvas over an image: strokes, brush painting and points.

Three ipycanvas layers are stacked: the image, the user's drawing, and an overlay
(fields drawn by the app, the stroke in progress). The canvas is shown scaled to fit
the notebook; every coordinate the user produces is mapped back to image pixels,
(row, col) with the centre of the top-left pixel at (0, 0) (docs/conventions.md).
"""

from __future__ import annotations

import html

import ipywidgets as W
import numpy as np
from ipycanvas import MultiCanvas, hold_canvas
from traitlets import Float, Int, Unicode, observe, validate

from fluidnb import as_image, to_uint8
from fluidnb.fields import resize
from fluidnb.sketch import (
    arrow_heads,
    flood_fill,
    paint_segment,
    scalar_to_rgba,
    segment_heads,
)

from ._common import Choice, plural
from ._layers import History, PaintLayer, PointLayer, StrokeLayer

__all__ = ["DrawingCanvas"]

_TOOLS = {
    "stroke": "strokes",
    "brush": "paint",
    "eraser": "paint",
    "fill": "paint",
    "points": "points",
}
# Focused canvases get a browser outline after the first click (ipycanvas focuses on
# mouse-down); the frame would read as part of the picture.
STYLE = W.HTML(
    "<style>.fluidnb-canvas:focus, .fluidnb-canvas canvas:focus { outline: none; }"
    ".fluidnb-frame { image-rendering: pixelated; }</style>",
    layout=W.Layout(display="none"),
)

_ICONS = {
    "stroke": "long-arrow-right",
    "brush": "paint-brush",
    "eraser": "eraser",
    "fill": "tint",
    "points": "map-marker",
}


def _css(color, alpha=1.0):
    r, g, b = (int(round(255 * c)) for c in color)
    return f"rgba({r}, {g}, {b}, {alpha:.3f})"


class DrawingCanvas(W.VBox):
    """An image with tools to sketch strokes, paint maps and place points.

    Parameters
    ----------
    image : array_like or path
        The picture to draw on (anything :func:`fluidnb.as_image` accepts).
    strokes, masks, maps, points : sequence of str
        Names of the layers to offer: stroke layers (flow strokes), boolean masks
        (regions, mattes), scalar maps in [0, 1] (speed maps), point sets (seeds).
    display_size : int
        The longest side of the canvas on screen, in pixels (the image is scaled to
        it; the canvas also shrinks with the notebook's width).
    scale : float, optional
        Screen pixels per image pixel; overrides ``display_size``.
    value_slider : bool
        Offer the 0..1 slider of :attr:`brush_value`. An app that sets the value
        itself (from a slider in its own units) leaves it out: a slider on screen
        snaps the value to its 0.05 grid in the browser and sends it back.
    button_width : str
        CSS width of each tool button (narrower ones fit a narrow column).

    Examples
    --------
    >>> import numpy as np
    >>> c = DrawingCanvas(np.zeros((64, 96)), strokes=["flow"], masks=["region"])
    >>> c.draw_stroke([[10, 5], [10, 60]])
    >>> c.get_strokes("flow")[0].shape[1]
    2
    >>> c.paint([[32, 48]], radius=4, layer="region")
    >>> bool(c.get_mask("region")[32, 48])
    True
    """

    #: The active tool: "stroke", "brush", "eraser", "fill" or "points".
    tool = Unicode("brush").tag(sync=False)
    #: The name of the layer the tool acts on.
    layer = Unicode("").tag(sync=False)
    #: The value the brush and fill paint (0..1; masks store value > 0.5).
    brush_value = Float(1.0).tag(sync=False)
    #: The brush radius in image pixels.
    brush_radius = Float(6.0).tag(sync=False)
    #: Incremented after every change to any layer (observe it to react to drawing).
    version = Int(0).tag(sync=False)

    def __init__(
        self,
        image,
        *,
        strokes=(),
        masks=(),
        maps=(),
        points=(),
        display_size=420,
        scale=None,
        value_slider=True,
        button_width="auto",
    ):
        self.image = as_image(image)
        h, w = self.image.shape[:2]
        self.layers = {}
        #: Every layer's undo steps in the order they happened (Undo takes back the
        #: last action, whichever layer it was on).
        self.history = History()
        steps = {"history": self.history}
        for name in strokes:
            self.layers[name] = StrokeLayer(name, (h, w), **steps)
        for name in masks:
            self.layers[name] = PaintLayer(name, (h, w), mask=True, **steps)
        for i, name in enumerate(maps):
            color = [(0.2, 1.0, 0.4), (0.6, 0.4, 1.0), (1.0, 0.2, 0.6)][i % 3]
            self.layers[name] = PaintLayer(name, (h, w), color=color, opacity=0.6, **steps)
        for name in points:
            self.layers[name] = PointLayer(name, (h, w), **steps)
        if not self.layers:
            raise ValueError(
                "DrawingCanvas needs at least one layer (strokes, masks, maps, points)"
            )
        if len(set(self.layers)) != len(strokes) + len(masks) + len(maps) + len(points):
            raise ValueError("layer names must be unique")

        if scale is None:
            scale = display_size / max(h, w)
        self.scale = float(scale)
        cw, ch = max(1, round(w * self.scale)), max(1, round(h * self.scale))
        self._sx, self._sy = cw / w, ch / h
        self.canvas = MultiCanvas(3, width=cw, height=ch)
        self.canvas.layout.width = "100%"
        self.canvas.layout.max_width = f"{cw}px"
        self.canvas.layout.height = "auto"
        self.canvas.add_class("fluidnb-canvas")
        self._image_layer, self._draw_layer, self._overlay = (self.canvas[i] for i in range(3))
        # Line widths and marker sizes in canvas pixels, proportional to the canvas so
        # they stay visible when a large canvas is shown scaled down in a narrow cell.
        self._pen = max(2.5, max(cw, ch) / 250)
        self._overlay_segments = None
        self._current = None  # the points of the drag in progress

        self._tool_buttons = W.ToggleButtons(
            options=[t for t in _TOOLS if any(_TOOLS[t] == y.kind for y in self.layers.values())],
            style={"button_width": button_width},
            layout=W.Layout(width="auto"),
        )
        self._tool_buttons.icons = [_ICONS[t] for t in self._tool_buttons.options]
        self._layer_pick = Choice(description="layer", layout=W.Layout(width="180px"))
        self._value_slider = W.FloatSlider(
            value=1.0,
            min=0,
            max=1,
            step=0.05,
            description="value",
            style={"description_width": "40px"},
            layout=W.Layout(width="190px"),
        )
        self._radius_slider = W.FloatSlider(
            value=6.0,
            min=0.5,
            max=max(2.0, max(h, w) / 4),
            step=0.5,
            description="radius",
            style={"description_width": "46px"},
            layout=W.Layout(width="190px"),
        )
        self._undo = W.Button(
            description="Undo",
            icon="undo",
            tooltip="take back the last change, on any layer",
            layout=W.Layout(width="82px"),
        )
        self._clear = W.Button(
            description="Clear",
            icon="trash",
            tooltip="clear the chosen layer (undoable)",
            layout=W.Layout(width="82px"),
        )
        self.status = W.HTML(layout=W.Layout(min_height="1.5em"))
        self.caption = ""
        for wid, cls in [
            (self._tool_buttons, "fluidnb-tools"),
            (self._layer_pick, "fluidnb-layer"),
            (self._value_slider, "fluidnb-value"),
            (self._radius_slider, "fluidnb-radius"),
            (self._undo, "fluidnb-undo"),
            (self._clear, "fluidnb-clear"),
        ]:
            wid.add_class(cls)
        W.link((self._tool_buttons, "value"), (self, "tool"))
        W.link((self._value_slider, "value"), (self, "brush_value"))
        W.link((self._radius_slider, "value"), (self, "brush_radius"))
        self._layer_pick.on_pick(self._layer_picked)
        self._undo.on_click(lambda _: self.undo())
        self._clear.on_click(lambda _: self.clear())

        toolbar = W.HBox(
            [self._tool_buttons, self._layer_pick], layout=W.Layout(flex_flow="row wrap")
        )
        brushbar = W.HBox(
            [
                *([self._value_slider] if value_slider else []),
                self._radius_slider,
                self._undo,
                self._clear,
            ],
            layout=W.Layout(flex_flow="row wrap"),
        )
        super().__init__([STYLE, toolbar, brushbar, self.canvas, self.status])
        self.add_class("fluidnb-drawing")

        first = next(iter(self.layers.values()))
        self.tool = {"strokes": "stroke", "paint": "brush", "points": "points"}[first.kind]
        self._sync_layer_choices()

        self.canvas.on_mouse_down(self._on_mouse_down)
        self.canvas.on_mouse_move(self._on_mouse_move)
        self.canvas.on_mouse_up(self._on_mouse_up)
        self.canvas.on_mouse_out(self._on_mouse_up)
        # In Voila, drawing sent while the notebook executes is lost: redraw when a
        # front end says it is ready (and once now, for JupyterLab).
        self.canvas.on_client_ready(self.redraw)
        self.redraw()

    # ------------------------------------------------------------------ coordinates
    def to_image(self, x, y):
        """Canvas pixel (x, y) -> image (row, col)."""
        return (y / self._sy - 0.5, x / self._sx - 0.5)

    def to_canvas(self, row, col):
        """Image (row, col) -> canvas pixel (x, y)."""
        return ((col + 0.5) * self._sx, (row + 0.5) * self._sy)

    def _clamp(self, rc):
        h, w = self.image.shape[:2]
        return (min(max(rc[0], 0.0), h - 1.0), min(max(rc[1], 0.0), w - 1.0))

    # ------------------------------------------------------------------ tools
    @validate("tool")
    def _check_tool(self, proposal):
        tool = proposal["value"]
        if tool not in _TOOLS:
            raise ValueError(f"tool must be one of {', '.join(_TOOLS)}, got {tool!r}")
        if not any(_TOOLS[tool] == lay.kind for lay in self.layers.values()):
            raise ValueError(f"tool {tool!r} has no layer to act on in this canvas")
        return tool

    @observe("tool")
    def _tool_changed(self, change):
        self._sync_layer_choices()

    @validate("layer")
    def _check_layer(self, proposal):
        name = proposal["value"]
        if name not in self.layers:
            raise ValueError(f"layer must be one of {', '.join(self.layers)}, got {name!r}")
        return name

    def _layer_picked(self, name):
        if name is not None:
            self.layer = name

    @observe("layer")
    def _layer_changed(self, change):
        if self._layer_pick.value != change["new"] and change["new"] in self._layer_pick.options:
            self._layer_pick.value = change["new"]

    def _sync_layer_choices(self):
        kind = _TOOLS[self.tool]
        names = [n for n, lay in self.layers.items() if lay.kind == kind]
        current = self.layer if self.layer in names else names[0]
        self.layer = current
        self._layer_pick.set_options(names, current)
        # The layer choice shows when the tool has several layers. Where some tool has
        # (a matte and a speed map, say), its room is kept for every tool: the canvas
        # must not jump under the mouse when the tool changes.
        if any(self._layer_count(k) > 1 for k in set(_TOOLS.values())):
            self._layer_pick.layout.visibility = "visible" if len(names) > 1 else "hidden"
        else:
            self._layer_pick.layout.display = "none"
        painting = kind == "paint"
        # Hidden, their room kept: the canvas under them must not move when the tool
        # changes (a click meant for the picture would land elsewhere).
        shown = {True: "visible", False: "hidden"}
        self._value_slider.layout.visibility = shown[painting and self.tool != "eraser"]
        self._radius_slider.layout.visibility = shown[painting and self.tool != "fill"]
        if not any(lay.kind == "paint" for lay in self.layers.values()):
            # No brush at all: the sliders never show and take no room.
            self._value_slider.layout.display = self._radius_slider.layout.display = "none"

    def _layer_count(self, kind):
        return sum(lay.kind == kind for lay in self.layers.values())

    def select(self, tool, layer=None):
        """Choose the tool (and the layer it acts on), as the toolbar does."""
        self.tool = tool
        if layer is not None:
            if self.layers.get(layer) is None or self.layers[layer].kind != _TOOLS[tool]:
                raise ValueError(f"layer {layer!r} cannot take the {tool} tool")
            self.layer = layer

    # ------------------------------------------------------------------ events
    def _on_mouse_down(self, x, y):
        rc = self.to_image(x, y)
        active = self.layers[self.layer]
        if self.tool == "points":
            pick = 8.0 / min(self._sx, self._sy)  # 8 screen pixels
            h, w = self.image.shape[:2]
            if -0.5 <= rc[0] <= h - 0.5 and -0.5 <= rc[1] <= w - 0.5:
                what = active.toggle(self._clamp(rc), pick)
                self._changed(f"{what} a point on {active.name}")
            return
        if self.tool == "fill":
            active.begin()
            active.array = flood_fill(
                active.array, self._clamp(rc), active.coerce(self.brush_value)
            )
            self._changed(f"filled {active.name}")
            return
        self._current = [self._clamp(rc)]
        if self.tool in ("brush", "eraser"):
            active.begin()
            self._paint_to(self._current[0])

    def _on_mouse_move(self, x, y):
        if self._current is None:
            return
        rc = self._clamp(self.to_image(x, y))
        if self.tool == "stroke":
            self._current.append(rc)
            self._draw_live_stroke()
        else:
            self._paint_to(rc)

    def _on_mouse_up(self, x, y):
        if self._current is None:
            return
        points, self._current = self._current, None
        active = self.layers[self.layer]
        if self.tool == "stroke":
            added = active.add(np.array(points))
            self._changed(
                f"added a stroke to {active.name}"
                if added
                else "a click is not a stroke: drag along the flow"
            )
        else:
            self._changed(f"painted {active.name}")

    def _paint_to(self, rc):
        active = self.layers[self.layer]
        value = active.coerce(0.0 if self.tool == "eraser" else self.brush_value)
        start = self._current[-1]
        paint_segment(active.array, start, rc, self.brush_radius, value)
        self._current.append(rc)
        # Show the dab at once with a vector line; the exact raster replaces it on
        # mouse-up (one image message per drag, not one per move).
        x0, y0 = self.to_canvas(*start)
        x1, y1 = self.to_canvas(*rc)
        layer = self._draw_layer
        with hold_canvas():
            layer.line_cap = "round"
            layer.line_width = max(1.0, 2 * self.brush_radius * self._sx)
            if self.tool == "eraser":
                layer.global_composite_operation = "destination-out"
                layer.stroke_style = "rgba(0, 0, 0, 1)"
            else:
                layer.global_composite_operation = "source-over"
                alpha = active.opacity * (1.0 if active.mask else float(value))
                layer.stroke_style = _css(active.color, alpha)
            layer.stroke_line(x0, y0, x1, y1)
            layer.global_composite_operation = "source-over"

    def _draw_live_stroke(self):
        # Drawn as a finished stroke is (_draw_strokes), arrow head included, so the
        # direction is seen while dragging, not only after the release.
        pts = np.array([self.to_canvas(*p) for p in self._current])
        layer = self._overlay
        with hold_canvas():
            layer.clear()
            self._draw_overlay_segments()
            layer.stroke_style = _css(self.layers[self.layer].color)
            layer.line_width = self._pen
            layer.line_cap = "round"
            layer.line_join = "round"
            layer.stroke_lines(pts.tolist())
            for tip, end in arrow_heads(pts, size=4 * self._pen):
                layer.stroke_line(*tip, *end)

    def _changed(self, message):
        """Redraw, say what happened (every change says, so no old message lingers)."""
        self.redraw()
        self._say(message)
        self.version += 1

    def _say(self, message):
        #: What the caption under the canvas says (plain text; see :attr:`status`).
        self.caption = message
        self.status.value = f"<span style='opacity:0.7'>{html.escape(message)}</span>"

    # ------------------------------------------------------------------ drawing
    def redraw(self):
        """Redraw every layer from the arrays (one batched message)."""
        h, w = self.image.shape[:2]
        ch, cw = self.canvas.height, self.canvas.width
        rgb = self.image if self.image.ndim == 3 else np.repeat(self.image[..., None], 3, -1)
        shown = resize(rgb, (ch, cw), order=0) if (ch, cw) != (h, w) else rgb
        with hold_canvas():
            self._image_layer.put_image_data(to_uint8(shown), 0, 0)
            self._draw_layer.clear()
            paint = self._paint_rgba()
            if paint is not None:
                self._draw_layer.put_image_data(paint, 0, 0)
            for layer in self.layers.values():
                if layer.kind == "strokes":
                    self._draw_strokes(layer)
                elif layer.kind == "points":
                    self._draw_points(layer)
            self._overlay.clear()
            self._draw_overlay_segments()

    def _paint_rgba(self):
        """All paint layers composited into one RGBA image at canvas size, or None."""
        out = None
        for layer in self.layers.values():
            if layer.kind != "paint" or not layer.array.any():
                continue
            rgba = scalar_to_rgba(
                layer.array.astype(np.float32), layer.color, opacity=layer.opacity
            )
            if out is None:
                out = rgba.astype(np.float32) / 255
            else:  # "over" compositing, so several maps stay visible
                a = rgba[..., 3:] / 255.0
                out[..., :3] = rgba[..., :3] / 255.0 * a + out[..., :3] * (1 - a)
                out[..., 3:] = a + out[..., 3:] * (1 - a)
        if out is None:
            return None
        ch, cw = self.canvas.height, self.canvas.width
        rows = np.minimum((np.arange(ch) / self._sy).astype(int), out.shape[0] - 1)
        cols = np.minimum((np.arange(cw) / self._sx).astype(int), out.shape[1] - 1)
        return to_uint8(out[rows][:, cols])

    def _draw_strokes(self, layer):
        d = self._draw_layer
        d.stroke_style = _css(layer.color)
        d.line_width = self._pen
        d.line_cap = "round"
        d.line_join = "round"
        head = 4 * self._pen
        for stroke in layer.strokes:
            pts = np.array([self.to_canvas(*p) for p in stroke])
            d.stroke_lines(pts.tolist())
            for seg in arrow_heads(pts, size=head):
                d.stroke_line(*seg[0], *seg[1])

    def _draw_points(self, layer):
        d = self._draw_layer
        if not len(layer.points):
            return
        xy = np.array([self.to_canvas(*p) for p in layer.points])
        d.fill_style = _css(layer.color)
        d.stroke_style = "rgba(0, 0, 0, 0.8)"
        d.line_width = 0.6 * self._pen
        d.fill_circles(xy[:, 0], xy[:, 1], 2.4 * self._pen)
        d.stroke_circles(xy[:, 0], xy[:, 1], 2.4 * self._pen)

    def _draw_overlay_segments(self):
        if self._overlay_segments is None:
            return
        segs, color = self._overlay_segments
        o = self._overlay
        o.stroke_style = color
        o.line_width = 0.6 * self._pen
        xy = segs[..., ::-1] * [self._sx, self._sy] + [self._sx / 2, self._sy / 2]
        # The shafts and heads in one batched command (a quiver has hundreds).
        heads = segment_heads(xy, size=1.6 * self._pen)
        lines = np.concatenate([xy, heads]) if len(heads) else xy
        if len(lines):
            o.stroke_line_segments(lines.reshape(-1, 2), np.full(len(lines), 2))

    def show_segments(self, segments, color="rgba(255, 255, 255, 0.85)"):
        """Draw line segments (k, 2, 2) in image (row, col) on the overlay, with arrow heads.

        Use :func:`fluidnb.sketch.quiver_segments` to show a vector field. ``None``
        clears the overlay.
        """
        self._overlay_segments = None if segments is None else (np.asarray(segments, float), color)
        with hold_canvas():
            self._overlay.clear()
            self._draw_overlay_segments()

    def set_image(self, image):
        """Replace the picture (same size); the drawing is kept."""
        new = as_image(image)
        if new.shape[:2] != self.image.shape[:2]:
            raise ValueError(
                f"image must keep the canvas's size {self.image.shape[:2]}, got {new.shape[:2]}"
            )
        self.image = new
        self.redraw()

    # ------------------------------------------------------------------ undo / clear
    def undo(self, layer=None):
        """Take back the last action: on any layer (default, the Undo button), or on ``layer``.

        Returns the name of the layer whose action was undone, or None.
        """
        if layer is not None and layer not in self.layers:
            raise ValueError(f"layer must be one of {', '.join(self.layers)}, got {layer!r}")
        target = self.history.undo(None if layer is None else self.layers[layer])
        if target is None:
            self._say(f"nothing to undo{'' if layer is None else ' on ' + layer}")
            return None
        self._changed(f"undid the last change to {target.name}")
        return target.name

    def clear(self, layer=None):
        """Clear ``layer`` (default: the active one); undoable."""
        target = self.layers[layer or self.layer]
        target.clear()
        self._changed(f"cleared {target.name}")

    # ------------------------------------------------------------------ getters / setters
    def _layer(self, name, kind):
        if name is None:
            names = [n for n, lay in self.layers.items() if lay.kind == kind]
            if not names:
                raise ValueError(f"this canvas has no {kind} layer")
            name = names[0]
        layer = self.layers.get(name)
        if layer is None or layer.kind != kind:
            names = [n for n, lay in self.layers.items() if lay.kind == kind]
            raise ValueError(f"no {kind} layer named {name!r}; there are: {', '.join(names)}")
        return layer

    def get_strokes(self, layer=None):
        """Strokes as a list of (n, 2) float arrays, (row, col) in image pixels."""
        return self._layer(layer, "strokes").value

    def get_mask(self, layer=None):
        """A painted mask as bool (H, W); for a scalar map, where it is > 0."""
        value = self._layer(layer, "paint").value
        return value if value.dtype == bool else value > 0

    def get_map(self, layer=None):
        """A painted map as float32 (H, W) in [0, 1]."""
        return self._layer(layer, "paint").value.astype(np.float32)

    def get_points(self, layer=None):
        """Points as an (n, 2) float array, (row, col) in image pixels."""
        return self._layer(layer, "points").value

    def set_strokes(self, strokes, layer=None):
        """Replace the strokes of a layer (undoable)."""
        target = self._layer(layer, "strokes")
        target.set(strokes)
        self._changed(f"{target.name}: {plural(len(target.strokes), 'stroke')}")

    def set_mask(self, mask, layer=None):
        """Replace a painted mask or map (undoable)."""
        target = self._layer(layer, "paint")
        target.set(mask)
        share = float(np.mean(target.array > 0))
        self._changed(f"{target.name}: {share:.0%} of the image painted")

    set_map = set_mask

    def set_points(self, points, layer=None):
        """Replace the points of a layer (undoable)."""
        target = self._layer(layer, "points")
        target.set(points)
        self._changed(f"{target.name}: {plural(len(target.points), 'point')}")

    # ------------------------------------------------------------------ headless driving
    def drag(self, points, tool=None, layer=None):
        """Drag the mouse through ``points`` (image (row, col)) with a tool.

        Goes through the same handlers as the browser's mouse events, so a notebook
        or a test can draw exactly what a user would.
        """
        if tool is not None:
            self.select(tool, layer)
        elif layer is not None:
            self.layer = layer
        xy = [self.to_canvas(*p) for p in np.asarray(points, float)]
        if not xy:
            raise ValueError("points must hold at least one (row, col) point")
        self._on_mouse_down(*xy[0])
        for p in xy[1:]:
            self._on_mouse_move(*p)
        self._on_mouse_up(*xy[-1])

    def draw_stroke(self, points, layer=None):
        """Draw one stroke through ``points`` (image (row, col)) with the stroke tool."""
        self.drag(points, tool="stroke", layer=layer)

    def paint(self, points, *, radius=None, value=None, layer=None, erase=False):
        """Paint (or erase) along ``points`` (image (row, col)) with the brush."""
        if radius is not None:
            self.brush_radius = radius
        if value is not None:
            self.brush_value = value
        self.drag(points, tool="eraser" if erase else "brush", layer=layer)

    def fill(self, point, *, value=None, layer=None):
        """Flood-fill from ``point`` (image (row, col))."""
        if value is not None:
            self.brush_value = value
        self.drag([point], tool="fill", layer=layer)

    def click(self, point, layer=None):
        """Click at ``point`` (image (row, col)) with the points tool (add/remove)."""
        self.drag([point], tool="points", layer=layer)
