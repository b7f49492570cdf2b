"""A frame player for a :class:`fluidnb.Clip`: play/pause, scrub, fps, loop, export."""

from __future__ import annotations

import html
import time
from pathlib import Path

import ipywidgets as W
from traitlets import Any, Int, Unicode, observe

from fluidnb import Clip

from ._canvas import STYLE
from ._common import jpeg, output_dir, shown_path

__all__ = ["FramePlayer"]


class FramePlayer(W.VBox):
    """Play a clip inline, frame by frame, and export it as GIF or MP4.

    Each frame is encoded to JPEG the first time it is shown and kept, so playing
    and scrubbing never re-encode the clip. The Play widget runs in the browser and
    only asks the kernel for the frame to show.

    Parameters
    ----------
    clip : fluidnb.Clip, optional
        What to play (set :attr:`clip` later to change it).
    display_width : int
        Width on screen in pixels (small simulation grids are enlarged, pixelated).
    export_dir : str or Path, optional
        Where the export buttons write (default: the apps' output folder,
        ``fluidnb-output/`` beside the notebook or ``$FLUIDNB_OUTPUT_DIR``; see
        :func:`output_dir`).
    label : str
        The export files' name when the clip's metadata names no method.
    slider_width : str, optional
        CSS width of the frame slider (shorter ones let players sit side by side).

    Examples
    --------
    >>> import numpy as np
    >>> from fluidnb import Clip
    >>> p = FramePlayer(Clip(np.zeros((4, 8, 8)), fps=4))
    >>> p.show(2)
    >>> p.frame
    2
    """

    #: The clip being played (a fluidnb.Clip or None).
    clip = Any(None, allow_none=True)
    #: Index of the frame on screen.
    frame = Int(0)
    #: Where the last export was written ("" before one, and again when the clip changes).
    exported = Unicode("")

    def __init__(
        self, clip=None, *, display_width=384, export_dir=None, label="clip", slider_width=None
    ):
        self.display_width = int(display_width)
        self.export_dir = None if export_dir is None else Path(export_dir)
        self.label = label
        self._encoded = {}
        self._ready = 0  # frames of the clip that are made (all but while streaming)
        self._streaming = None  # the clip being streamed (stream), until it is set
        self.image = W.Image(format="jpeg", layout=W.Layout(width=f"{self.display_width}px"))
        self.image.add_class("fluidnb-frame")
        self._play = W.Play(interval=125, step=1, repeat=True, show_repeat=True)
        self._play.add_class("fluidnb-play")
        self._slider = W.IntSlider(description="frame", readout=True, continuous_update=True)
        # As wide as the picture with the play buttons: the player stays a column of
        # the picture's width (apps put it beside the canvas).
        self._slider.layout.width = slider_width or f"{max(self.display_width - 175, 160)}px"
        self._slider.style.description_width = "40px"
        self._slider.add_class("fluidnb-frame-slider")
        # The slider follows Play in the browser (jslink): no kernel round trip per tick.
        W.jslink((self._play, "value"), (self._slider, "value"))
        self._fps = W.BoundedFloatText(
            value=8.0,
            min=0.5,
            max=60,
            step=0.5,
            description="fps",
            style={"description_width": "30px"},
            layout=W.Layout(width="120px"),
        )
        self._fps.add_class("fluidnb-fps")
        self._gif = W.Button(description="GIF", icon="download", layout=W.Layout(width="80px"))
        self._mp4 = W.Button(description="MP4", icon="download", layout=W.Layout(width="80px"))
        self._gif.add_class("fluidnb-export-gif")
        self._mp4.add_class("fluidnb-export-mp4")
        self.link = W.HTML()
        self.link.add_class("fluidnb-export-link")
        self.info = W.HTML()
        self._slider.observe(lambda c: setattr(self, "frame", c["new"]), "value")
        self._fps.observe(self._fps_changed, "value")
        self._gif.on_click(lambda _: self.export("gif"))
        self._mp4.on_click(lambda _: self.export("mp4"))
        wrap = W.Layout(flex_flow="row wrap", align_items="center")
        controls = W.HBox([self._play, self._slider], layout=wrap)
        exports = W.HBox([self._gif, self._mp4, self._fps, self.link], layout=wrap)
        super().__init__([STYLE, self.image, controls, self.info, exports])
        self.layout.max_width = f"{max(self.display_width, 300)}px"
        self.add_class("fluidnb-player")
        self.clip = clip
        if clip is None:  # no change event for the default: set the empty state now
            self._clip_changed({"new": None})

    @observe("clip")
    def _clip_changed(self, change):
        clip, old = change["new"], change.get("old")
        if clip is not None and not isinstance(clip, Clip):
            raise ValueError(f"clip must be a fluidnb.Clip, got {type(clip).__name__}")
        if _same_pictures(old, clip):
            self._streaming = None
            # The finished clip of a stream (the same frames, now with their metadata):
            # keep the encoded frames and whatever is playing.
            self._ready = len(clip)
            self._show_state(clip)
            return
        self._encoded = {}
        streamed = clip is not None and clip is self._streaming
        if not streamed:
            self._streaming = None
        self._ready = 0 if clip is None else (self._ready if streamed else len(clip))
        # An export link belongs to the clip it was written from.
        self.link.value = ""
        self.exported = ""
        with self.hold_sync():
            self._play.playing = False
            if clip is not None:
                self._fps.value = min(max(float(clip.fps), 0.5), 60)
            self._show_state(clip)
        if clip is None:
            return
        self.frame = min(self.frame, self._ready - 1)
        self._show(self.frame)

    def _show_state(self, clip):
        """Slider range, buttons, size and the info line for ``clip`` (``_ready`` frames made)."""
        n, ready = (0, 0) if clip is None else (len(clip), self._ready)
        with self.hold_sync():
            self._play.max = max(ready - 1, 0)
            self._slider.max = max(ready - 1, 0)
            for b in (self._play, self._slider):
                b.disabled = clip is None
            for b in (self._gif, self._mp4):  # a clip still being made is not exported
                b.disabled = clip is None or ready < n
        if clip is None:
            self.info.value = "<i>no clip yet</i>"
            self.image.value = b""
            # An empty image shows as a broken-image icon: hide it until there is a clip.
            self.image.layout.display = "none"
            return
        h, w = clip.shape
        self.image.layout.display = None
        self.image.layout.width = f"{self.display_width}px"
        # Tiny grids are enlarged by the browser; keep their cells crisp.
        self.image.layout.object_fit = "contain"
        count = f"{n} frames" if ready == n else f"{ready} of {n} frames so far"
        parts = [count, f"{w}x{h}", f"{clip.fps:g} fps"]
        if clip.metadata.get("method"):
            parts.append(html.escape(str(clip.metadata["method"])))
        self.info.value = f"<span style='opacity:0.75'>{', '.join(parts)}</span>"

    def stream(self, clip, ready):
        """Show a clip that is still being made: its first ``ready`` frames are final.

        Play and the frame slider run over those frames; each later call with the
        same clip (more frames made) widens them without stopping playback, and
        setting :attr:`clip` to the finished clip (the same frames) keeps the frames
        already encoded and keeps playing. A new clip keeps the player playing if it
        was. GIF and MP4 wait for the whole clip.

        Parameters
        ----------
        clip : fluidnb.Clip
            The clip's frames (those from ``ready`` on are not made yet).
        ready : int
            How many frames, from the first, are final (1 to ``len(clip)``).
        """
        if not isinstance(clip, Clip):
            raise ValueError(f"clip must be a fluidnb.Clip, got {type(clip).__name__}")
        if not 1 <= int(ready) <= len(clip):
            raise ValueError(f"ready must be in [1, {len(clip)}], got {ready}")
        if clip is not self.clip:
            playing = self.playing
            self._ready = int(ready)
            self._streaming = clip
            self.clip = clip  # shows its first frames (and stops playing)
            if playing:
                self.play(True)
            return
        self._ready = max(self._ready, int(ready))
        self._show_state(clip)

    @observe("frame")
    def _frame_changed(self, change):
        if self.clip is not None:
            self._show(change["new"])

    def _fps_changed(self, change):
        self._play.interval = max(int(round(1000.0 / change["new"])), 10)

    def _encode(self, i):
        data = self._encoded.get(i)
        if data is None:
            data = self._encoded[i] = jpeg(self.clip.frames[i])
        return data

    def _show(self, i):
        i = int(min(max(i, 0), self._ready - 1))
        self.image.value = self._encode(i)
        if self._slider.value != i:
            self._slider.value = i

    def show(self, i):
        """Show frame ``i`` (as the slider does)."""
        if self.clip is None:
            raise ValueError("there is no clip to show yet")
        n = self._ready
        if not 0 <= int(i) < n:
            raise ValueError(f"frame must be in [0, {n - 1}], got {i}")
        self.frame = int(i)

    @property
    def fps(self):
        """Playback rate (frames per second)."""
        return self._fps.value

    @fps.setter
    def fps(self, value):
        self._fps.value = value

    @property
    def playing(self):
        """Whether the browser is playing the clip."""
        return self._play.playing

    def play(self, on=True):
        """Start (or stop) playing in the browser."""
        self._play.playing = bool(on)

    def export(self, fmt="gif"):
        """Write the clip as ``fmt`` ("gif" or "mp4") into :attr:`export_dir`.

        Returns the path, shows a link to it under the player and sets
        :attr:`exported` (an app says where in its status line).
        """
        if self.clip is None:
            raise ValueError("there is no clip to export yet")
        if self._ready < len(self.clip):
            raise ValueError("the clip is still being made: export it when it is done")
        if fmt not in ("gif", "mp4"):
            raise ValueError(f"fmt must be 'gif' or 'mp4', got {fmt!r}")
        folder = output_dir() if self.export_dir is None else self.export_dir
        folder.mkdir(parents=True, exist_ok=True)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        method = str(self.clip.metadata.get("method") or self.label)
        path = folder / f"fluidnb-{method}-{stamp}.{fmt}"
        n = 1
        while path.exists():
            path = folder / f"fluidnb-{method}-{stamp}-{n}.{fmt}"
            n += 1
        clip = self.clip
        self.link.value = f"<i>writing {html.escape(shown_path(path))}…</i>"
        out = clip.save(path, fps=self.fps)
        if self.clip is not clip:  # a new clip came meanwhile: its player shows no old link
            return out
        shown = shown_path(out)
        self.link.value = (
            f"<a href='{html.escape(shown)}' download target='_blank'>{html.escape(shown)}</a>"
            f" <span style='opacity:0.7'>({_size(out.stat().st_size)})</span>"
        )
        self.exported = shown
        return out


def _same_pictures(a, b):
    """Whether two clips show the very same frames (one array's memory, same layout)."""
    if a is None or b is None or a is b:
        return False
    fa, fb = a.frames, b.frames
    return (
        fa.shape == fb.shape
        and fa.strides == fb.strides
        and fa.__array_interface__["data"][0] == fb.__array_interface__["data"][0]
    )


def _size(n):
    """A file size in words a person reads at a glance."""
    if n < 1024:
        return f"{n} bytes"
    if n < 1024**2:
        return f"{n / 1024:.0f} KB"
    return f"{n / 1024**2:.1f} MB"
