"""Interactive layer of fluidnb (ipywidgets + ipycanvas); installed as ``fluidnb.widgets``.

Reusable pieces every method's app is made of: :class:`DrawingCanvas` (strokes, brush,
points over an image), :class:`FramePlayer` (play and export a clip),
:class:`ParamPanel` (sliders from a parameter dataclass) and :class:`App` (all of them
with a run button, progress, cancel and a live preview), and one app per method
(:class:`FlickerApp`, :class:`FrostApp`, :class:`FireApp`, :class:`TurbulenceApp`,
:class:`VideoDBApp`), and :class:`SceneApp` (several of them on one photo).
Imported in a notebook kernel, it makes :func:`fluidnb.progress_bar` return a
:class:`ProgressBar` widget.
No algorithm lives here: everything calls :mod:`fluidnb`.
"""

from ._app import App, _in_kernel
from ._canvas import DrawingCanvas
from ._fire import FireApp
from ._flicker import FlickerApp
from ._frost import FrostApp
from ._panel import ParamPanel
from ._player import FramePlayer
from ._progress import ProgressBar, install
from ._scene import SceneApp
from ._turbulence import TurbulenceApp
from ._videodb import VideoDBApp

__all__ = [
    "App",
    "DrawingCanvas",
    "FireApp",
    "FlickerApp",
    "FramePlayer",
    "FrostApp",
    "ParamPanel",
    "ProgressBar",
    "SceneApp",
    "TurbulenceApp",
    "VideoDBApp",
]

# In a notebook, fluidnb.progress_bar() gives a widget bar, not text on stderr.
if _in_kernel():
    install()
