"""The video-database app's drawing: the matte, the flow strokes and the speed map.

Three layers on one :class:`DrawingCanvas` over the photo, as Okabe, Anjyo & Onai
(2011, sec. 5 and Fig. 8) let the user constrain the assignment: a painted matte (the
fluid region), strokes along the flow (interpolated into a direction field by
:func:`fluidnb.sketch.direction_field`, shown as a quiver) and a painted speed in
px/frame. :class:`VideoDBApp` draws with this; it holds no algorithm.
"""

from __future__ import annotations

import ipywidgets as W
import numpy as np

from fluidnb.sketch import direction_field, quiver_segments

from ._canvas import DrawingCanvas
from ._common import row
from ._strokes_file import StrokesFile

__all__ = ["SPEED_MAX", "FlowSketch"]

#: The speed (px/frame) painted by a full-value brush: the speed layer stores
#: ``speed / SPEED_MAX`` in [0, 1] (0 = not painted). The starter databases' fragments
#: move up to ~4 px/frame.
SPEED_MAX = 5.0

_QUIVER = "rgba(255, 214, 10, 0.95)"


class FlowSketch:
    """The drawing half of :class:`VideoDBApp`: canvas, its tools and what they made.

    A mix-in: the app provides ``photo``, ``photo_alpha``, ``_display_size``,
    ``canvas``, ``say`` and ``_drawing_changed``; :meth:`_make_sketch_tools` makes
    the widgets the canvas column shows under the canvas.
    """

    def _make_sketch_tools(self):
        """The speed slider, the Clear buttons, the quiver toggle and the strokes file."""
        self._speed = W.FloatSlider(
            value=2.0,
            min=0.25,
            max=SPEED_MAX,
            step=0.25,
            description="speed",
            readout_format=".2f",
            tooltip="speed brush value in px/frame (Okabe et al. 2011, Fig. 8-c); 0 = not painted",
            layout=W.Layout(width="260px"),
        )
        self._speed_unit = W.HTML("<span style='opacity:0.7'>px/frame</span>")
        self._clear_buttons = {
            layer: W.Button(
                description=f"Clear {label}",
                icon="trash",
                tooltip=f"erase every {label} drawn (undoable)",
                layout=W.Layout(width="125px"),
            )
            for layer, label in (("matte", "matte"), ("flow", "flow"), ("speed", "speed"))
        }
        self._show_quiver = W.Checkbox(
            value=True,
            description="direction field",
            indent=False,
            tooltip="show the strokes' interpolated direction as a quiver",
            layout=W.Layout(width="130px"),
        )
        self._strokes_io = StrokesFile(
            lambda: self.canvas, "flow", say=lambda *a: self.say(*a), lead=[self._show_quiver]
        )
        io_ = self._strokes_io
        self._strokes_file, self._save_button, self._load_button = (
            io_.name,
            io_.save_button,
            io_.load_button,
        )

        self._field_key = self._field = None
        for wid, cls in [
            (self._speed, "fluidnb-vdb-speed"),
            (self._show_quiver, "fluidnb-vdb-show-quiver"),
            (self._strokes_file, "fluidnb-vdb-strokes-file"),
            (self._save_button, "fluidnb-vdb-save-strokes"),
            (self._load_button, "fluidnb-vdb-load-strokes"),
        ]:
            wid.add_class(cls)
        for layer, button in self._clear_buttons.items():
            button.add_class(f"fluidnb-vdb-clear-{layer}")
            button.on_click(lambda _, layer=layer: self.canvas.clear(layer))
        self._speed.observe(lambda _: self._sync_brush(), "value")
        self._show_quiver.observe(lambda _: self._update_quiver(), "value")
        return [
            row(self._speed, self._speed_unit),
            row(*self._clear_buttons.values()),
            self._strokes_io,
        ]

    def _make_canvas(self):
        # The speed brush's value comes from the app's px/frame slider and the matte
        # brush always paints "inside": no 0..1 value slider.
        canvas = DrawingCanvas(
            self.photo,
            strokes=["flow"],
            masks=["matte"],
            maps=["speed"],
            display_size=self._display_size,
            value_slider=False,
            button_width="88px",
        )
        speed = canvas.layers["speed"]
        speed.color, speed.opacity = (1.0, 1.0, 1.0), 0.95  # grey levels: white = fast
        canvas.brush_radius = max(2.0, max(self.photo.shape[:2]) / 24)
        if self.photo_alpha is not None:
            canvas.set_mask(self.photo_alpha > 0.5, "matte")
        canvas.select("brush", "matte")
        return canvas

    def _wire_canvas(self, canvas):
        # The canvas column as wide as the canvas (with room for the tools), narrower
        # on a narrower page -- the canvas shrinks with it -- so the clip, the map and
        # the panel stay beside it (at 1280 px they wrapped under it). 700 px: the
        # clip-and-map column and the panel, with their margins.
        widest = max(canvas.canvas.width, 440)
        self.drawing_width = f"clamp(360px, calc(100% - 700px), {widest}px)"
        canvas.observe(self._drawing_changed, "version")
        canvas.observe(lambda _: self._sync_brush(), ["tool", "layer"])
        self._field_key = self._field = None
        self._sync_brush()
        self._update_quiver()

    def select(self, tool, layer=None):
        """Choose the tool (stroke, brush, eraser, fill) and layer (matte, flow, speed)."""
        self.canvas.select(tool, layer)

    def _sync_brush(self):
        c = self.canvas
        speed = c.layer == "speed" and c.tool in ("brush", "fill")
        self._speed.layout.display = "" if speed else "none"
        self._speed_unit.layout.display = "" if speed else "none"
        c.brush_value = self._speed.value / SPEED_MAX if c.layer == "speed" else 1.0

    def paint_matte(self, points, *, radius=None):
        """Paint the matte along ``points`` ((row, col) image pixels) with the brush."""
        self.canvas.paint(points, radius=radius, layer="matte")

    def erase_matte(self, points, *, radius=None):
        """Erase the matte along ``points`` with the eraser."""
        self.canvas.paint(points, radius=radius, layer="matte", erase=True)

    def draw_stroke(self, points):
        """Draw one flow stroke through ``points`` ((row, col)), in the flow's direction."""
        self.canvas.draw_stroke(points, layer="flow")

    def paint_speed(self, points, speed=None, *, radius=None):
        """Paint the speed map along ``points`` with ``speed`` px/frame (the slider's)."""
        if speed is not None:
            if not 0 < speed <= SPEED_MAX:
                raise ValueError(f"speed must be in (0, {SPEED_MAX:g}] px/frame, got {speed}")
            self._speed.value = float(speed)
        self.canvas.select("brush", "speed")
        self.canvas.paint(points, radius=radius, value=self._speed.value / SPEED_MAX)

    def set_matte(self, matte):
        """Replace the matte (bool or > 0.5 inside; undoable)."""
        self.canvas.set_mask(np.asarray(matte), "matte")

    def set_strokes(self, strokes):
        """Replace the flow strokes, each an (n, 2) (row, col) array (undoable)."""
        self.canvas.set_strokes(strokes, "flow")

    def set_speed(self, speed):
        """Replace the speed map, (H, W) px/frame, 0 = not painted (undoable)."""
        arr = np.asarray(speed, np.float32)
        if arr.size and (arr.min() < 0 or arr.max() > SPEED_MAX):
            raise ValueError(
                f"speed must lie in [0, {SPEED_MAX:g}] px/frame, got [{arr.min():g}, {arr.max():g}]"
            )
        self.canvas.set_map(arr / SPEED_MAX, "speed")

    def matte(self):
        """The matte a run uses, float32 (H, W) in [0, 1].

        The painted mask; where it covers the photo's own soft alpha (an RGBA
        cut-out), that alpha's values, so the edge stays soft.
        """
        painted = self.canvas.get_mask("matte")
        m = painted.astype(np.float32)
        if self.photo_alpha is not None:
            m = np.where(painted & (self.photo_alpha > 0), self.photo_alpha, m)
        return m.astype(np.float32)

    def strokes(self):
        """The flow strokes: a list of (n, 2) (row, col) arrays."""
        return self.canvas.get_strokes("flow")

    def speed_map(self):
        """The painted speed in px/frame, float32 (H, W); 0 where not painted."""
        return self.canvas.get_map("speed") * np.float32(SPEED_MAX)

    def direction_field(self):
        """The strokes' interpolated unit direction field (H, W, 2) (dy, dx), or None."""
        strokes = self.strokes()
        if not strokes:
            return None
        key = tuple(s.tobytes() for s in strokes)
        if key != self._field_key:
            self._field = direction_field(strokes, self.photo.shape[:2])
            self._field_key = key
        return self._field

    def _update_quiver(self):
        try:
            field = self.direction_field() if self._show_quiver.value else None
        except ValueError as exc:
            self.say(str(exc), "error")
            field = None
        if field is None:
            self.quiver_segments = 0
            self.canvas.show_segments(None)
            return
        matte = self.canvas.get_mask("matte")
        if matte.any():  # the field matters only where the fluid is
            field = field * matte[..., None]
        step = max(8, round(max(self.photo.shape[:2]) / 16))
        segments = quiver_segments(field, step=step, length=0.7 * step)
        self.quiver_segments = len(segments)
        self.canvas.show_segments(segments if len(segments) else None, _QUIVER)

    # ------------------------------------------------------------------ strokes file
    def save_strokes(self, path=None):
        """Write the strokes as a ``fluidnb.strokes`` JSON file; returns the path.

        ``path`` (default: the file box's, ``strokes.json``) is a bare file name in the
        output folder (``fluidnb-output/`` beside the notebook), or a path.
        """
        return self._strokes_io.save(path)

    def load_strokes(self, path=None):
        """Replace the strokes by those of a JSON file (undoable); ValueError if refused."""
        return self._strokes_io.load(path)
