"""fluidnb: five published fluid-animation methods as a fast, tested library.

The library (this package) never imports Jupyter; the interactive layer is the separate
subpackage :mod:`fluidnb.widgets`, built on top of it. See docs/conventions.md for the
array, clip and result, vector-field, parameter, random-seed, citation and error
conventions, and the README's References for the five papers.
"""

import importlib
from typing import TYPE_CHECKING

from ._version import __version__

if TYPE_CHECKING:  # what __getattr__ below provides, for readers and tools
    from ._clip import Clip, load_clip
    from ._image import as_image, as_mask, to_uint8
    from ._params import Params, ParamSpec, param
    from ._progress import Cancelled, CancelToken, Progress, TextProgress, progress_bar
    from ._random import resolve_seed, rng
    from ._stream import FrameStream

__all__ = [
    "CancelToken",
    "Cancelled",
    "Clip",
    "FrameStream",
    "ParamSpec",
    "Params",
    "Progress",
    "TextProgress",
    "__version__",
    "as_image",
    "as_mask",
    "data",
    "fields",
    "fire",
    "flicker",
    "fluid",
    "frost",
    "load_clip",
    "param",
    "progress_bar",
    "resolve_seed",
    "rng",
    "scene",
    "sketch",
    "to_uint8",
    "turbulence",
    "videodb",
]

# Everything loads on first use, so `import fluidnb` imports nothing heavy: `fluidnb
# --version` stays quick, and the command line is already inside main() -- where Ctrl-C
# is one line, not a traceback -- when numpy, scipy or numba start to load (issue 37).
# `fluidnb.fields` and `fluidnb.sketch` pull in scikit-image.
_NAMES = {
    "Clip": "_clip",
    "load_clip": "_clip",
    "FrameStream": "_stream",
    "as_image": "_image",
    "as_mask": "_image",
    "to_uint8": "_image",
    "Params": "_params",
    "ParamSpec": "_params",
    "param": "_params",
    "Cancelled": "_progress",
    "CancelToken": "_progress",
    "Progress": "_progress",
    "TextProgress": "_progress",
    "progress_bar": "_progress",
    "resolve_seed": "_random",
    "rng": "_random",
}
_SUBPACKAGES = {
    "data",
    "fields",
    "fire",
    "flicker",
    "fluid",
    "frost",
    "scene",
    "sketch",
    "turbulence",
    "videodb",
}


def __getattr__(name):
    if name in _NAMES:
        value = getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
        globals()[name] = value  # once: later lookups do not come here
        return value
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | _SUBPACKAGES | set(_NAMES))
