"""Entry point of the ``fluidnb`` console script."""

from __future__ import annotations

import argparse
import importlib
import sys

from .._progress import Cancelled
from .._version import __version__

__all__ = ["build_parser", "main"]

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
]


def build_parser():
    """The argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="fluidnb",
        description="Fluid-animation methods from five papers, from the command line.",
    )
    parser.add_argument("--version", action="version", version=f"fluidnb {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv=None):
    """Run the command line; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 0
    try:
        return args.func(args) or 0
    except ValueError as exc:
        print(f"fluidnb {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (Cancelled, KeyboardInterrupt):
        print(f"fluidnb {args.command}: cancelled", file=sys.stderr)
        return 130
