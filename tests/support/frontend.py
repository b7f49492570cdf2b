"""Simulate the browser's messages to widgets, without a browser.

ipycanvas has no public way to inject mouse events, so this wraps its private entry
point in ONE place: if ipycanvas changes it, only this file breaks.
"""

from __future__ import annotations


def canvas_event(drawing, event, x, y):
    """Send one mouse event, as the front end does, to a DrawingCanvas's top layer.

    ``x, y`` are canvas pixels (what the browser reports), not image pixels.
    """
    multi = drawing.canvas
    # MultiCanvas forwards its front end's messages to the top layer's handler.
    top = multi._canvases[-1]
    top._handle_frontend_event(multi, {"event": event, "x": float(x), "y": float(y)}, [])


def mouse_drag(drawing, xy_points):
    """A press, moves and a release through canvas pixels ``[(x, y), ...]``."""
    canvas_event(drawing, "mouse_down", *xy_points[0])
    for x, y in xy_points[1:]:
        canvas_event(drawing, "mouse_move", x, y)
    canvas_event(drawing, "mouse_up", *xy_points[-1])


def client_ready(drawing):
    """The message a new front end sends once its canvas exists (Voila, a reload)."""
    top = drawing.canvas._canvases[-1]
    top._handle_frontend_event(drawing.canvas, {"event": "client_ready"}, [])
