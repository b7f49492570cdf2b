"""The progress protocol shared by every long-running library function.

A long function takes ``progress=None`` or a callable ``progress(fraction, message)``
with ``fraction`` in [0, 1]. The library never imports Jupyter: a notebook passes a
callable that moves a progress bar, the command line passes one that prints.

Cancellation goes through the same callable: to stop a run, make the callable raise
:class:`Cancelled` (for example by using a :class:`CancelToken`). Library functions
call ``progress`` between units of work, so the run stops within one unit and leaves
the caller's inputs untouched.

:func:`progress_bar` gives the callable that suits where the code runs: a text bar
on stderr in a script or a terminal, a widget bar in a notebook -- the widget layer
(``fluidnb.widgets``) registers that one with :func:`set_progress_bar` when it is
imported in a kernel, so the library itself never imports Jupyter.
"""

from __future__ import annotations

import sys
import threading
import time

__all__ = [
    "CancelToken",
    "Cancelled",
    "Progress",
    "TextProgress",
    "progress_bar",
    "set_progress_bar",
]


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

    Writes ``[####....]  42% message`` to ``stream`` (stderr by default) at most every
    ``interval`` seconds, and always the final 100 %. In a notebook, use
    :func:`progress_bar` instead: a notebook shows stderr as an error box.

    Parameters
    ----------
    stream : file, optional
        Where to write (default ``sys.stderr``).
    interval : float
        Least seconds between two lines.
    width : int
        Characters of the bar.
    description : str
        What is being done, written before the bar.
    """

    def __init__(self, stream=None, interval=0.25, width=30, description=""):
        self.stream = sys.stderr if stream is None else stream
        self.interval = interval
        self.width = width
        self.description = description
        self._last = -1.0

    def __call__(self, fraction, message=""):
        now = time.monotonic()
        if fraction < 1.0 and now - self._last < self.interval:
            return
        self._last = now
        filled = int(round(self.width * fraction))
        bar = "#" * filled + "." * (self.width - filled)
        end = "\n" if fraction >= 1.0 else "\r"
        lead = f"{self.description}: " if self.description else ""
        self.stream.write(f"{lead}[{bar}] {fraction:4.0%} {message[:40]:<40}{end}")
        self.stream.flush()


_BAR_FACTORY = None


def set_progress_bar(factory):
    """Make :func:`progress_bar` return ``factory(description, cancel=...)`` (None: text).

    ``fluidnb.widgets`` registers its widget bar here when it is imported in a
    notebook kernel. Returns the factory that was registered before.
    """
    global _BAR_FACTORY
    if factory is not None and not callable(factory):
        raise ValueError(f"factory must be None or callable, got {type(factory).__name__}")
    old, _BAR_FACTORY = _BAR_FACTORY, factory
    return old


def progress_bar(description="", *, cancel=False):
    """A progress callable that suits where the code runs, to pass as ``progress=``.

    In a notebook where ``fluidnb.widgets`` has been imported: a progress bar widget
    shown in the cell's output (with a Cancel button if ``cancel``). Elsewhere --
    scripts, the command line -- a :class:`TextProgress` bar on stderr.

    Parameters
    ----------
    description : str
        What is being done ("building the water database").
    cancel : bool
        Offer a Cancel button (widget bar only): the next progress report after a
        click raises :class:`Cancelled`.

    Examples
    --------
    >>> import io
    >>> bar = progress_bar("summing")  # outside a notebook: a text bar on stderr
    >>> isinstance(bar, TextProgress), bar.description
    (True, 'summing')
    """
    if _BAR_FACTORY is not None:
        return _BAR_FACTORY(description, cancel=cancel)
    return TextProgress(description=description)
