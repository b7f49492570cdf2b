"""Entry point of the ``fluidnb`` console script."""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from .._progress import Cancelled
from .._version import __version__
from ._paths import check_paths, path_options

__all__ = ["build_parser", "iter_commands", "main"]

# Each module here has ``register(subparsers)``; a method's module adds its own
# subcommand by being listed. Modules import their heavy dependencies lazily.
_COMMAND_MODULES = [
    "fluidnb.cli._info",
    "fluidnb.cli._flicker",
    "fluidnb.cli._frost",
    "fluidnb.cli._fluid",
    "fluidnb.cli._fire",
    "fluidnb.cli._turbulence",
    "fluidnb.cli._videodb",
    "fluidnb.cli._animate",
    "fluidnb.cli._scene",
]


def build_parser():
    """The argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="fluidnb",
        description="Fluid-animation methods from five papers, from the command line.",
    )
    parser.add_argument("--version", action="version", version=f"fluidnb {__version__}")
    parser.add_argument(
        "--debug",
        action="store_true",
        help="show the Python traceback of an error (also FLUIDNB_DEBUG=1)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    # Every command's file options, so main() checks them before the command runs.
    for _, leaf in iter_commands(parser):
        leaf.set_defaults(path_options=tuple(path_options(leaf)), prog=leaf.prog)
    return parser


def iter_commands(parser, names=()):
    """Yield ``(names, parser)`` for every command that runs, e.g. (("videodb", "add"), p)."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if names and not subs:
        yield names, parser
    for action in subs:
        for name, child in action.choices.items():
            yield from iter_commands(child, (*names, name))


def main(argv=None):
    """Run the command line; returns the process exit status.

    A user error (bad input, a file that cannot be read or written, an output aimed at
    an input) is one line ``fluidnb CMD: error: ...`` and exit status 2, never a
    traceback; ``--debug`` (or ``FLUIDNB_DEBUG=1``) shows the traceback instead.
    Ctrl-C is one line ``... cancelled`` and exit status 130, at any moment: while
    numpy, scipy or numba load as much as while a command runs.
    """
    try:
        return _run(argv)
    except KeyboardInterrupt:  # before the command started: building the parser
        print("fluidnb: cancelled", file=sys.stderr)
        return 130


def _run(argv):
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 0
    prog = getattr(args, "prog", f"fluidnb {args.command}")
    debug = args.debug or os.environ.get("FLUIDNB_DEBUG", "") not in ("", "0")
    try:
        check_paths(args, getattr(args, "path_options", ()))
        return args.func(args) or 0
    except (Cancelled, KeyboardInterrupt):
        print(f"{prog}: cancelled", file=sys.stderr)
        return 130
    except Exception as exc:
        message = _user_error(exc)
        if message is None or debug:
            raise
        print(f"{prog}: error: {message}", file=sys.stderr)
        return 2


def _user_error(exc):
    """One line for an error the user can fix, or None for a bug (shown as a traceback)."""
    if isinstance(exc, ValueError):
        return str(exc)
    if isinstance(exc, OSError):
        if not exc.strerror:
            return str(exc) or type(exc).__name__
        text = exc.strerror
        if exc.filename is not None:
            text += f": {str(exc.filename)!r}"
        if exc.filename2 is not None:
            text += f" -> {str(exc.filename2)!r}"
        return text
    if isinstance(exc, MemoryError):
        return "not enough memory: try a smaller size or fewer frames"
    return None
