"""The data behind a drawing canvas: named layers holding plain numpy arrays.

Kept free of any widget so the canvas's bookkeeping (undo, clear, setters) is
simple to reason about: the canvas only translates mouse events into calls here and
redraws what these hold.
"""

from __future__ import annotations

import numpy as np

from fluidnb._validation import check_array, check_range

__all__ = ["History", "PaintLayer", "PointLayer", "StrokeLayer"]

_HISTORY = 40  # undo steps kept (a 512 x 512 map costs 1 MB a step)


class History:
    """The undo steps of several layers, in the order the actions happened.

    Each layer records the state before each of its actions here; :meth:`undo`
    takes back the last action *whichever layer it was on* -- what a person expects
    of an Undo button -- and a layer's own :meth:`_Layer.undo` its own last one.
    """

    def __init__(self, limit=_HISTORY):
        self.limit = int(limit)
        self._steps = []  # (layer, state before the action)

    def push(self, layer, state):
        self._steps.append((layer, state))
        del self._steps[: -self.limit]

    def undo(self, layer=None):
        """Restore the state before the last action (on ``layer`` only, if given).

        Returns the layer whose action was undone, or None if there was none.
        """
        for i in range(len(self._steps) - 1, -1, -1):
            owner, state = self._steps[i]
            if layer is None or owner is layer:
                del self._steps[i]
                owner._restore(state)
                return owner
        return None

    def can_undo(self, layer=None):
        """Whether :meth:`undo` has something to undo (on ``layer``, if given)."""
        return any(layer is None or owner is layer for owner, _ in self._steps)


class _Layer:
    kind = ""

    def __init__(self, name, color, history=None):
        self.name = name
        self.color = tuple(float(c) for c in color)
        self.history = History() if history is None else history

    def _remember(self):
        self.history.push(self, self._snapshot())

    def undo(self):
        """Restore the state before this layer's last action; False if there is none."""
        return self.history.undo(self) is not None

    @property
    def can_undo(self):
        """Whether :meth:`undo` has something to undo."""
        return self.history.can_undo(self)


class StrokeLayer(_Layer):
    """Polylines drawn with the stroke tool, each an (n, 2) array of (row, col)."""

    kind = "strokes"

    def __init__(self, name, shape, color=(0.2, 0.8, 1.0), history=None):
        super().__init__(name, color, history)
        self.shape = tuple(shape)
        self.strokes = []

    def _snapshot(self):
        return list(self.strokes)

    def _restore(self, state):
        self.strokes = state

    def add(self, points):
        """Append a stroke (kept only if it has at least two distinct points)."""
        pts = _as_points(f"{self.name} stroke", points, self.shape)
        if len(pts) < 2 or not np.any(pts != pts[0]):
            return False
        self._remember()
        self.strokes = [*self.strokes, pts]
        return True

    def set(self, strokes):
        """Replace every stroke (undoable)."""
        new = [_as_points(f"{self.name}[{i}]", s, self.shape) for i, s in enumerate(strokes)]
        self._remember()
        self.strokes = new

    def clear(self):
        """Remove every stroke (undoable)."""
        if self.strokes:
            self._remember()
            self.strokes = []

    @property
    def value(self):
        """A list of (n, 2) float arrays, (row, col) in image pixels (copies)."""
        return [s.copy() for s in self.strokes]


class PaintLayer(_Layer):
    """A scalar map painted with the brush: a float map in [0, 1] or a boolean mask."""

    kind = "paint"

    def __init__(
        self, name, shape, *, mask=False, color=(1.0, 0.35, 0.1), opacity=0.45, history=None
    ):
        super().__init__(name, color, history)
        self.mask = bool(mask)
        self.opacity = float(opacity)
        self.array = np.zeros(tuple(shape)[:2], bool if mask else np.float32)

    def _snapshot(self):
        return self.array.copy()

    def _restore(self, state):
        self.array = state

    def begin(self):
        """Start an action (a brush drag or a fill): remember the state for undo."""
        self._remember()

    def coerce(self, value):
        """The value as this layer stores it (a mask stores value > 0.5)."""
        value = check_range(f"{self.name} value", value, 0, 1)
        return value > 0.5 if self.mask else np.float32(value)

    def set(self, array):
        """Replace the map (undoable); shape must match the image."""
        arr = check_array(self.name, array, ndim=2)
        if arr.shape != self.array.shape:
            raise ValueError(
                f"{self.name} must have the image's shape {self.array.shape}, got {arr.shape}"
            )
        if self.mask:
            new = arr > 0.5 if arr.dtype.kind == "f" else arr.astype(bool)
        else:
            if arr.dtype.kind == "f" and (arr.min() < 0 or arr.max() > 1):
                raise ValueError(f"{self.name} values must lie in [0, 1]")
            new = arr.astype(np.float32)
        self._remember()
        self.array = new

    def clear(self):
        """Set the whole map to zero (undoable)."""
        if self.array.any():
            self._remember()
            self.array = np.zeros_like(self.array)

    @property
    def value(self):
        """A copy of the map: bool (H, W) for a mask, float32 (H, W) otherwise."""
        return self.array.copy()


class PointLayer(_Layer):
    """Points placed with the points tool, an (n, 2) array of (row, col)."""

    kind = "points"

    def __init__(self, name, shape, color=(1.0, 0.9, 0.2), history=None):
        super().__init__(name, color, history)
        self.shape = tuple(shape)
        self.points = np.empty((0, 2))

    def _snapshot(self):
        return self.points.copy()

    def _restore(self, state):
        self.points = state

    def toggle(self, point, pick_radius):
        """Remove the nearest point within ``pick_radius``, else add ``point``."""
        p = np.asarray(point, float)
        self._remember()
        if len(self.points):
            d = np.linalg.norm(self.points - p, axis=1)
            i = int(np.argmin(d))
            if d[i] <= pick_radius:
                self.points = np.delete(self.points, i, axis=0)
                return "removed"
        self.points = np.vstack([self.points, p[None]])
        return "added"

    def set(self, points):
        """Replace every point (undoable)."""
        pts = np.empty((0, 2)) if len(points) == 0 else _as_points(self.name, points, self.shape)
        self._remember()
        self.points = pts

    def clear(self):
        """Remove every point (undoable)."""
        if len(self.points):
            self._remember()
            self.points = np.empty((0, 2))

    @property
    def value(self):
        """A copy of the points, shape (n, 2), (row, col) in image pixels."""
        return self.points.copy()


def _as_points(name, points, shape):
    arr = check_array(name, points, ndim=2, dtype_kinds="iuf").astype(float)
    if arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (n, 2) as (row, col), got {arr.shape}")
    h, w = shape[:2]
    if np.any(arr < -0.5) or np.any(arr[:, 0] > h - 0.5) or np.any(arr[:, 1] > w - 0.5):
        raise ValueError(f"{name} has points outside the image (rows 0..{h - 1}, cols 0..{w - 1})")
    return arr
