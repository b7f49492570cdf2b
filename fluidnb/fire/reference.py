"""The literal numpy version of fire synthesis, in the paper's notation: public for the lessons.

The code lives in ``_reference.py`` beside this file (open it: it is short); the tests
check the fast path against it. Import it as ``from fluidnb.fire import reference``.
"""

from ._reference import *  # noqa: F403 -- this module is its public name
from ._reference import __all__  # noqa: F401
