"""The progress protocol shared by every long-running library function.

A long function takes ``progress=None`` or a callable ``progress(fraction, message)``
with ``fraction`` in [0, 1]. The library never imports Jupyter: a notebook passes a
callable that moves a progress bar, the command line passes one that prints.

Cancellation goes through the same callable: to stop a run, make the callable raise
:class:`Cancelled` (for example by using a :class:`CancelToken`). Library functions
call ``progress`` between units of work, so the run stops within one unit and leaves
the caller's inputs untouched.
"""

from __future__ import annotations

import sys
import threading
import time

__all__ = ["CancelToken", "Cancelled", "Progress", "TextProgress"]


class Cancelled(Exception):
    """Raised through a progress callable to stop a long computation."""


class CancelToken:
    """A thread-safe flag that turns a progress callable into a cancellable one.

    Parameters
    ----------
    callback : callable, optional
        ``callback(fraction, message)`` to forward reports to (e.g. a progress bar).

    Examples
    --------
    >>> token = CancelToken()
    >>> token(0.5, "half way")
    >>> token.cancel()
    >>> token(0.6, "more")
    Traceback (most recent call last):
    ...
    fluidnb._progress.Cancelled: cancelled at 60%
    """

    def __init__(self, callback=None):
        self._event = threading.Event()
        self._callback = callback

    def cancel(self):
        """Ask the computation to stop at its next progress report."""
        self._event.set()

    @property
    def cancelled(self):
        """Whether :meth:`cancel` has been called."""
        return self._event.is_set()

    def __call__(self, fraction, message=""):
        if self._event.is_set():
            raise Cancelled(f"cancelled at {fraction:.0%}")
        if self._callback is not None:
            self._callback(fraction, message)


class Progress:
    """Adapter the library uses internally around the user's optional callable.

    It clamps fractions, maps sub-stages into a parent's range and makes ``None``
    cost nothing, so library code can always write ``report(i / n, "step i")``.

    Parameters
    ----------
    callback : callable or None
        The user's ``progress(fraction, message)``.
    start, stop : float
        The part of the parent's [0, 1] range this reporter covers.

    Examples
    --------
    >>> seen = []
    >>> report = Progress(lambda f, m: seen.append((round(f, 2), m)))
    >>> first, second = report.split(0.25)
    >>> first(1.0, "analysed")
    >>> second(0.5, "rendering")
    >>> seen
    [(0.25, 'analysed'), (0.62, 'rendering')]
    """

    def __init__(self, callback=None, start=0.0, stop=1.0):
        if isinstance(callback, Progress):
            start, stop = (
                callback.start + start * (callback.stop - callback.start),
                callback.start + stop * (callback.stop - callback.start),
            )
            callback = callback.callback
        if callback is not None and not callable(callback):
            raise ValueError(
                "progress must be None or a callable progress(fraction, message), "
                f"got {type(callback).__name__}"
            )
        self.callback = callback
        self.start = float(start)
        self.stop = float(stop)

    def __call__(self, fraction, message=""):
        if self.callback is None:
            return
        f = min(max(float(fraction), 0.0), 1.0)
        self.callback(self.start + f * (self.stop - self.start), message)

    def sub(self, start, stop):
        """A reporter for the part [start, stop] of this one's range."""
        return Progress(self, start, stop)

    def split(self, *cuts):
        """Reporters for consecutive stages ending at the given cut points.

        ``split(0.25)`` gives two stages, [0, 0.25] and [0.25, 1].
        """
        edges = [0.0, *cuts, 1.0]
        return [self.sub(a, b) for a, b in zip(edges[:-1], edges[1:])]


class TextProgress:
    """A plain-text progress line for scripts and the command line.

    Writes ``message  42%`` to ``stream`` (stderr by default) at most every
    ``interval`` seconds, and always the final 100 %.
    """

    def __init__(self, stream=None, interval=0.25, width=30):
        self.stream = sys.stderr if stream is None else stream
        self.interval = interval
        self.width = width
        self._last = -1.0

    def __call__(self, fraction, message=""):
        now = time.monotonic()
        if fraction < 1.0 and now - self._last < self.interval:
            return
        self._last = now
        filled = int(round(self.width * fraction))
        bar = "#" * filled + "." * (self.width - filled)
        end = "\n" if fraction >= 1.0 else "\r"
        self.stream.write(f"[{bar}] {fraction:4.0%} {message[:40]:<40}{end}")
        self.stream.flush()
