"""A frame player for a :class:`fluidnb.Clip`: play/pause, scrub, fps, loop, export."""

from __future__ import annotations

import html
import threading
import time
from pathlib import Path

import anywidget
import ipywidgets as W
from traitlets import Any, Bool, Float, Int, Unicode, link, observe

from fluidnb import Clip

from ._common import jpeg, output_dir, shown_path

__all__ = ["FramePlayer"]

_HERE = Path(__file__).resolve().parent
# Frames per message: the first alone (on screen at once), then batches of about this
# many bytes (one message of a whole clip would hold every frame until the last).
_BATCH_BYTES = 1 << 20
# A live preview (a clip shown with show_timed) is seen from its first frame while a
# slider moves; its other frames follow this many seconds later, in smaller batches
# and at a lower JPEG quality. Sent at once, a flicker preview's other 63 frames (750
# KB at quality 95) went through the kernel, the server and the page just as its first
# frame did, and that frame waited for them. Quality 80 halves the bytes, with no
# difference to see at the preview's size (a 128-px loop enlarged 3x).
_PREVIEW_REST_AFTER = 0.04
_PREVIEW_BATCH_BYTES = 1 << 18
_PREVIEW_QUALITY = 80


class _PlayerView(anywidget.AnyWidget):
    """The player's front end (``_player.js``): the clip's frames drawn in the browser.

    The kernel sends each clip's frames once (:class:`_Sender`); playing, scrubbing and
    looping run in the page at :attr:`fps`, with no message per frame.
    """

    _esm = (_HERE / "_player.js").read_text(encoding="utf-8")
    _css = (_HERE / "_player.css").read_text(encoding="utf-8")
    #: Which clip the front end shows (a new number for each clip; 0: none).
    clip_id = Int(0).tag(sync=True)
    n_frames = Int(0).tag(sync=True)  #: The clip's length.
    ready = Int(0).tag(sync=True)  #: Frames made so far (all but while streaming).
    width = Int(0).tag(sync=True)  #: The clip's picture size.
    height = Int(0).tag(sync=True)  #: see :attr:`width`
    display_width = Int(384).tag(sync=True)  #: Width on screen, CSS pixels.
    slider_width = Unicode("").tag(sync=True)  #: CSS width of the frame slider.
    fps = Float(8.0).tag(sync=True)  #: Playback rate.
    playing = Bool(False).tag(sync=True)  #: Whether the page plays the clip.
    loop = Bool(True).tag(sync=True)  #: Play over and over.
    frame = Int(0).tag(sync=True)  #: The frame shown while paused (the page's while playing).
    #: Players of one group show the same frame (the one playing leads).
    group = Unicode("").tag(sync=True)
    #: Draw an enlarged clip smoothly (photos) rather than pixelated (simulation grids).
    smooth = Bool(False).tag(sync=True)
    #: Tell the kernel when a preview's picture is drawn (FramePlayer.wait_drawn).
    tell_drawn = Bool(False).tag(sync=True)


class _Sender:
    """Encodes a clip's frames to JPEG once and sends them to the page, in order.

    A thread of its own, so that setting a clip (or streaming one) returns at once;
    a new clip drops what is left of the old one. The page asks (``want``) for what
    it misses after a reload.
    """

    def __init__(self, view):
        self.view = view
        self._cond = threading.Condition()
        self.clip = None
        self.clip_id = 0
        self.ready = 0
        self.encoded = {}  # frame index -> JPEG bytes, of the current clip
        self._sent = 0
        self._wants = []
        self._closed = False
        self._thread = None
        self.timeline = None  # the kernel's times of the clip's making (previews), if any

    def set(self, clip, clip_id, ready, encoded=None, timeline=None, sent=0):
        """The clip to send; its first ``sent`` frames (in ``encoded``) the caller sends."""
        with self._cond:
            self.clip, self.clip_id, self.ready = clip, clip_id, ready
            self.timeline = timeline
            self.encoded = {} if encoded is None else encoded
            self._sent = sent
            self._wants = []
            self._start()

    def more(self, ready):
        with self._cond:
            self.ready = max(self.ready, ready)
            self._cond.notify_all()

    def want(self, clip_id, have):
        with self._cond:
            if clip_id == self.clip_id:
                self._wants.append(max(0, int(have)))
                self._start()

    def encode(self, i, clip=None, preview=None):
        """Frame ``i``'s JPEG of the current clip (or of ``clip``), encoded once.

        ``preview``: at the previews' quality (default: if the clip is a preview).
        """
        with self._cond:
            clip = self.clip if clip is None else clip
            encoded = self.encoded
            if preview is None:
                preview = clip is self.clip and self.timeline is not None
            if clip is self.clip and i in encoded:
                return encoded[i]
        data = jpeg(clip.frames[i], quality=_PREVIEW_QUALITY if preview else 95)
        with self._cond:
            # The first one made is kept (the thread and a caller may both have made it).
            return encoded.setdefault(i, data) if clip is self.clip else data

    def close(self):
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def _start(self):
        self._cond.notify_all()
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="fluidnb-player", daemon=True)
            self._thread.start()

    def _loop(self):
        while True:
            with self._cond:
                while not self._closed and not self._wants and self._sent >= self.ready:
                    self._cond.wait()
                if self._closed:
                    return
                clip, cid, ready = self.clip, self.clip_id, self.ready
                wants, self._wants = self._wants, []
                start = self._sent
                preview = self.timeline is not None
            if clip is None:
                continue
            for have in wants:  # a page that missed frames: resend those encoded
                self.send(cid, have, [self.encoded[i] for i in range(have, start)])
            if preview and start == 1 and ready > 1:
                # The preview's first frame is on its way: let it reach the page first.
                with self._cond:
                    self._cond.wait_for(
                        lambda cid=cid: self._closed or cid != self.clip_id, _PREVIEW_REST_AFTER
                    )
                    if self._closed or cid != self.clip_id:
                        continue
            limit = _PREVIEW_BATCH_BYTES if preview else _BATCH_BYTES
            batch, size, i = [], 0, start
            while i < ready and (not batch or (size < limit and start > 0)):
                if clip is not self.clip:
                    break  # a new clip: its frames come next
                data = self.encode(i, clip)
                batch.append(data)
                size += len(data)
                i += 1
            with self._cond:
                if cid != self.clip_id:
                    continue  # a new clip came meanwhile
                self._sent = i
            if batch:
                self.send(cid, start, batch)

    def send(self, cid, start, frames):
        """Send ``frames`` (JPEG bytes) of clip ``cid`` from frame ``start`` on."""
        for k in range(0, len(frames), 16):
            part = frames[k : k + 16]
            if part:
                msg = {"type": "frames", "clip": cid, "start": start + k, "mime": "image/jpeg"}
                if start + k == 0:
                    # When the kernel sent the first frame (ms since the epoch, as the
                    # page's performance.timeOrigin + now()) and how it was made: the
                    # page hands them to whoever measures (the fluidnb-frame event).
                    msg["sent"] = time.time() * 1000
                    if self.timeline is not None and cid == self.clip_id:
                        msg["timeline"] = self.timeline
                self.view.send(msg, buffers=part)


class FramePlayer(W.VBox):
    """Play a clip inline at its fps, in the browser, and export it as GIF or MP4.

    The frames are encoded to JPEG once and sent to the page once; the page plays,
    scrubs and loops them itself (the kernel only swaps the clip), so playback keeps
    the clip's fps however busy the kernel is.

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
    group : str, optional
        Players of one group show the same frame in the page (the one playing leads):
        two views of one simulation, say.

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
    #: Index of the frame on screen while paused (the page knows it while playing).
    frame = Int(0)
    #: Where the last export was written ("" before one, and again when the clip changes).
    exported = Unicode("")

    def __init__(
        self,
        clip=None,
        *,
        display_width=384,
        export_dir=None,
        label="clip",
        slider_width=None,
        group="",
    ):
        self._display_width = int(display_width)
        self.export_dir = None if export_dir is None else Path(export_dir)
        self.label = label
        self._ready = 0  # frames of the clip that are made (all but while streaming)
        self._streaming = None  # the clip being streamed (stream), until it is set
        self._clips = 0
        self._timeline = None  # see show_timed
        self._drawn = 0  # the last clip the page said it drew (previews; see wait_drawn)
        self._drawn_lock = threading.Condition()
        #: The part the page runs: the picture, play/pause, frame slider, loop, fps.
        self.view = _PlayerView(
            display_width=self.display_width, slider_width=slider_width or "", group=group
        )
        self.view.add_class("fluidnb-player-canvas")
        self.view.on_msg(self._message)
        self._sender = _Sender(self.view)
        link((self.view, "frame"), (self, "frame"))
        self._gif = W.Button(description="GIF", icon="download", layout=W.Layout(width="80px"))
        self._mp4 = W.Button(description="MP4", icon="download", layout=W.Layout(width="80px"))
        self._gif.add_class("fluidnb-export-gif")
        self._mp4.add_class("fluidnb-export-mp4")
        self.link = W.HTML()
        self.link.add_class("fluidnb-export-link")
        self.info = W.HTML()
        self.info.add_class("fluidnb-player-info")
        self._gif.on_click(lambda _: self.export("gif"))
        self._mp4.on_click(lambda _: self.export("mp4"))
        wrap = W.Layout(flex_flow="row wrap", align_items="center")
        exports = W.HBox([self._gif, self._mp4, self.link], layout=wrap)
        super().__init__([self.view, self.info, exports])
        self.display_width = self._display_width
        self.add_class("fluidnb-player")
        self.clip = clip
        if clip is None:  # no change event for the default: set the empty state now
            self._clip_changed({"new": None})

    @property
    def display_width(self):
        """Width of the picture on screen, CSS pixels (an app sets it to a clip's own width)."""
        return self._display_width

    @display_width.setter
    def display_width(self, width):
        self._display_width = int(width)
        self.view.display_width = self._display_width
        self.layout.max_width = f"{max(self._display_width, 300)}px"

    @observe("clip")
    def _clip_changed(self, change):
        clip, old = change["new"], change.get("old")
        if clip is not None and not isinstance(clip, Clip):
            raise ValueError(f"clip must be a fluidnb.Clip, got {type(clip).__name__}")
        if _same_pictures(old, clip):
            self._streaming = None
            # The finished clip of a stream (the same frames, now with their metadata):
            # keep the frames sent and whatever is playing.
            self._ready = len(clip)
            with self._sender._cond:
                self._sender.clip = clip
            self._show_state(clip)
            self._sender.more(self._ready)
            return
        streamed = clip is not None and clip is self._streaming
        if not streamed:
            self._streaming = None
        self._ready = 0 if clip is None else (self._ready if streamed else len(clip))
        # An export link belongs to the clip it was written from.
        self.link.value = ""
        self.exported = ""
        self._clips += clip is not None
        with self.view.hold_sync():
            if clip is not None:
                h, w = clip.shape
                self.view.fps = min(max(float(clip.fps), 0.5), 60)
                self.view.width, self.view.height = w, h
                self.view.smooth = bool(clip.metadata.get("smooth", False))
                self.frame = min(self.frame, max(self._ready - 1, 0))
            else:
                self.view.playing = False
                self.frame = 0
            self.view.n_frames = 0 if clip is None else len(clip)
            self.view.ready = self._ready
            self.view.clip_id = self._clips if clip is not None else 0
        timeline, self._timeline = self._timeline, None
        if timeline is not None and clip is not None and self._ready:
            # A preview's first frame goes out from here, right behind the clip's state
            # (no hand-over to the sender's thread, which waited for the GIL while the
            # kernel's thread drew the app's other views), and before the player's info
            # line and whatever the app shows after it: the page draws it first.
            first = self._sender.encode(0, clip, preview=True)
            self._sender.set(clip, self.view.clip_id, self._ready, {0: first}, timeline, sent=1)
            self._sender.send(self.view.clip_id, 0, [first])
        else:
            self._sender.set(clip, self.view.clip_id, self._ready, timeline=timeline)
        self._show_state(clip)

    def _show_state(self, clip):
        """Buttons, the page's frame count and the info line for ``clip``."""
        n, ready = (0, 0) if clip is None else (len(clip), self._ready)
        self.view.ready = ready
        for b in (self._gif, self._mp4):  # a clip still being made is not exported
            b.disabled = clip is None or ready < n
        if clip is None:
            self.info.value = "<i>no clip yet</i>"
            return
        h, w = clip.shape
        count = f"{n} frames" if ready == n else f"{ready} of {n} frames so far"
        parts = [count, f"{w}x{h}", f"{clip.fps:g} fps"]
        if clip.metadata.get("method"):
            parts.append(html.escape(str(clip.metadata["method"])))
        caption = clip.metadata.get("caption")
        text = html.escape(str(caption)) if caption else ", ".join(parts)
        self.info.value = f"<span style='opacity:0.75'>{text}</span>"

    def show_timed(self, clip, timeline):
        """Set :attr:`clip`, with the kernel's times of its making for the page.

        ``timeline`` (a dict of ms since the epoch: when the values came, the work
        began, the picture was made) reaches the page with the first frame, with the
        time it was sent; the page puts it, with when it arrived, in the frame's
        ``fluidnb-frame`` event. The benchmarks split a preview's time with it.
        """
        self._timeline = dict(timeline)
        self.clip = clip

    def stream(self, clip, ready):
        """Show a clip that is still being made: its first ``ready`` frames are final.

        The page plays those frames and waits for the next; each later call with the
        same clip (more frames made) sends the new ones without stopping playback,
        and setting :attr:`clip` to the finished clip (the same frames) keeps the
        frames sent and keeps playing. A new clip keeps the player playing if it
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
            self._ready = int(ready)
            self._streaming = clip
            self.clip = clip
            return
        self._ready = max(self._ready, int(ready))
        self._show_state(clip)
        self._sender.more(self._ready)

    def _message(self, _view, content, _buffers):
        if isinstance(content, dict) and content.get("type") == "want":
            self._sender.want(int(content.get("clip", -1)), int(content.get("have", 0)))
        elif isinstance(content, dict) and content.get("type") == "drawn":
            with self._drawn_lock:
                self._drawn = max(self._drawn, int(content.get("clip", 0)))
                self._drawn_lock.notify_all()

    def wait_drawn(self, timeout):
        """Wait until the page says it drew the clip shown with :meth:`show_timed`.

        With ``view.tell_drawn`` on, the page tells the kernel once it has drawn a
        preview's first frame (a message per preview: off by default); an app sends
        what can wait (the video-database app's map) after it, so that it never
        delays the picture. Returns whether the page said so within ``timeout``
        seconds (False with no page, or for a clip shown otherwise).
        """
        clip_id = self.view.clip_id
        with self._drawn_lock:
            return self._drawn_lock.wait_for(lambda: self._drawn >= clip_id, timeout)

    def _encode(self, i):
        """Frame ``i`` of the clip as the JPEG bytes the page gets (encoded once)."""
        return self._sender.encode(i)

    @property
    def _encoded(self):
        """The JPEG frames encoded so far, by index (the page got or gets them)."""
        return dict(self._sender.encoded)

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
        return self.view.fps

    @fps.setter
    def fps(self, value):
        self.view.fps = min(max(float(value), 0.5), 60)

    @property
    def loop(self):
        """Whether the clip plays over and over."""
        return self.view.loop

    @loop.setter
    def loop(self, on):
        self.view.loop = bool(on)

    @property
    def playing(self):
        """Whether the page is playing the clip."""
        return self.view.playing

    def play(self, on=True):
        """Start (or stop) playing in the browser."""
        self.view.playing = bool(on) and self.clip is not None

    def close(self):
        """Stop the sender and close the widgets."""
        sender = getattr(self, "_sender", None)
        if sender is not None:
            sender.close()
        if hasattr(self, "view"):
            self.view.close()
        super().close()

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
