"""Save and load a canvas's strokes as a ``fluidnb.strokes`` JSON file."""

from __future__ import annotations

import os

import ipywidgets as W

from fluidnb.sketch import load_strokes, save_strokes

from ._common import output_dir, plural, shown_path

__all__ = ["StrokesFile"]


class StrokesFile(W.HBox):
    """A file name box with Save and Load for the strokes of a canvas layer.

    A bare file name lies in the output folder (:func:`output_dir`,
    ``fluidnb-output/`` beside the notebook); a path with a folder is used as it is.
    What happened is said with ``say`` (a refused file changes nothing).

    Parameters
    ----------
    canvas : callable
        ``canvas() -> DrawingCanvas``: the canvas now shown (an app swaps it with
        its photo).
    layer : str
        The stroke layer saved and loaded.
    say : callable
        ``say(text, kind)``: the app's status line.
    lead : sequence of widgets
        Widgets shown before the box in the same row.
    """

    def __init__(self, canvas, layer, *, say, lead=()):
        self._canvas, self.layer, self._say = canvas, layer, say
        self.name = W.Text(
            value="strokes.json",
            description="strokes",
            tooltip=(
                "the strokes file (fluidnb.strokes JSON) Save writes and Load reads; a "
                "name without a folder is in the output folder (fluidnb-output/)"
            ),
            style={"description_width": "52px"},
            layout=W.Layout(width="170px"),
        )
        self.save_button = W.Button(description="Save", icon="save", layout=W.Layout(width="72px"))
        self.load_button = W.Button(
            description="Load", icon="folder-open", layout=W.Layout(width="72px")
        )
        failed = "could not save the strokes: "
        self.save_button.on_click(lambda _: self._clicked(self.save, failed))
        self.load_button.on_click(lambda _: self._clicked(self.load, ""))
        super().__init__(
            [*lead, self.name, self.save_button, self.load_button],
            layout=W.Layout(flex_flow="row wrap", align_items="center"),
        )

    def path(self, path=None):
        """Where the strokes file ``path`` (default: the box's) is."""
        path = os.path.expanduser(os.fspath(path or self.name.value.strip() or "strokes.json"))
        return path if os.path.dirname(path) else os.path.join(output_dir(), path)

    def save(self, path=None):
        """Write the layer's strokes (:func:`fluidnb.sketch.save_strokes`); returns the path."""
        canvas = self._canvas()
        strokes = canvas.get_strokes(self.layer)
        out = save_strokes(self.path(path), strokes, canvas.image.shape[:2])
        self._say(f"saved {plural(len(strokes), 'stroke')} to {shown_path(out)}", "ok")
        return out

    def load(self, path=None):
        """Replace the layer's strokes by a file's (undoable); ValueError if refused."""
        canvas = self._canvas()
        path = self.path(path)
        strokes, _ = load_strokes(path, shape=canvas.image.shape[:2])
        canvas.set_strokes(strokes, self.layer)
        self._say(f"loaded {plural(len(strokes), 'stroke')} from {shown_path(path)}", "ok")
        return strokes

    def _clicked(self, action, prefix):
        try:
            action()
        except (ValueError, OSError) as exc:
            self._say(f"{prefix}{exc}", "error")
