"""Where results that are slow to make and the same every time are kept on disk."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir"]


def cache_dir():
    """The folder where fluidnb keeps what it made once (sample flows, starter databases).

    ``$FLUIDNB_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/fluidnb`` or
    ``~/.cache/fluidnb``. A missing, unreadable or unwritable cache only costs time.

    Examples
    --------
    >>> cache_dir().name != ""
    True
    """
    env = os.environ.get("FLUIDNB_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "fluidnb"
