"""Progress in a notebook: a bar widget instead of text on stderr (a pink error box)."""

from __future__ import annotations

import html
import threading
import time

import ipywidgets as W

from fluidnb import Cancelled
from fluidnb._progress import set_progress_bar

__all__ = ["ProgressBar"]


class ProgressBar(W.HBox):
    """A progress callable that moves a bar: ``progress(fraction, message)``.

    Pass it as ``progress=`` to any long library function; in a notebook,
    :func:`fluidnb.progress_bar` returns one, shown in the cell's output (importing
    ``fluidnb.widgets`` registers it). It reports at most ten times a second, and
    always the end; a fraction of 1 turns the bar green with the elapsed time.

    With ``cancel=True`` a Cancel button is offered: the next report after a click
    raises :class:`fluidnb.Cancelled`. The kernel handles the click once it is free
    of the cell that is running, so Cancel stops work running in the background (a
    thread, as the apps' Run does); a cell's own work stops with the kernel's
    Interrupt (■ in the toolbar).

    Parameters
    ----------
    description : str
        What is being done, shown before the bar.
    cancel : bool
        Offer a Cancel button.
    interval : float
        Least seconds between two updates of the widgets.

    Examples
    --------
    >>> bar = ProgressBar("summing")
    >>> bar(0.5, "half way")
    >>> bar.fraction, bar.message
    (0.5, 'half way')
    """

    def __init__(self, description="", *, cancel=False, interval=0.1):
        self.interval = float(interval)
        self.fraction = 0.0  #: The last fraction reported.
        self.message = ""  #: The last message reported.
        self.cancelled = False  #: Whether Cancel was pressed.
        self._started = time.monotonic()
        self._shown = -1.0  # when the widgets were last updated
        self._lock = threading.Lock()
        self.bar = W.FloatProgress(value=0, min=0, max=1, layout=W.Layout(width="240px"))
        self.text = W.HTML()
        label = W.HTML(f"<b>{html.escape(description)}</b>" if description else "")
        self._cancel = W.Button(
            description="Cancel",
            icon="stop",
            tooltip="stop at the next step (work in a cell: the kernel's Interrupt ■)",
            layout=W.Layout(width="90px", display="" if cancel else "none"),
        )
        self._cancel.on_click(lambda _: self.cancel())
        for widget, cls in [
            (self.bar, "fluidnb-progress-bar"),
            (self.text, "fluidnb-progress-text"),
            (self._cancel, "fluidnb-progress-cancel"),
        ]:
            widget.add_class(cls)
        super().__init__(
            [label, self.bar, self._cancel, self.text],
            layout=W.Layout(align_items="center", flex_flow="row wrap"),
        )
        self.add_class("fluidnb-progressbar")

    def cancel(self):
        """Stop the work at its next report (what the Cancel button does)."""
        self.cancelled = True
        self._cancel.disabled = True
        self.text.value = "cancelling…"

    def __call__(self, fraction, message=""):
        if self.cancelled:
            self.bar.bar_style = "warning"
            self.text.value = f"cancelled at {self.fraction:.0%}"
            raise Cancelled(f"cancelled at {fraction:.0%}")
        fraction = min(max(float(fraction), 0.0), 1.0)
        with self._lock:
            self.fraction, self.message = fraction, str(message)
            now = time.monotonic()
            if fraction < 1.0 and now - self._shown < self.interval:
                return
            self._shown = now
        with self.hold_sync():
            self.bar.value = fraction
            if fraction >= 1.0:
                self.bar.bar_style = "success"
                self._cancel.disabled = True
                seconds = now - self._started
                self.text.value = f"done in {seconds:.1f} s"
            else:
                self.text.value = (
                    f"{fraction:4.0%} <span style='opacity:0.75'>{html.escape(self.message)}</span>"
                )


def _shown_bar(description, cancel=False):
    """The factory :func:`fluidnb.progress_bar` uses in a kernel: a bar, displayed."""
    from IPython.display import display

    bar = ProgressBar(description, cancel=cancel)
    display(bar)
    return bar


def install():
    """Make :func:`fluidnb.progress_bar` return widget bars (done on import in a kernel)."""
    set_progress_bar(_shown_bar)
