"""Entry point of the ``fluidnb`` console script."""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import sys

from .._progress import Cancelled
from .._version import __version__
from ._paths import check_paths, path_options

__all__ = ["build_parser", "iter_commands", "main"]

# Each module here has ``register(subparsers)``; a method's module adds its own
# subcommand by being listed, with the names it registers (the test of the command
# line checks that they agree). Modules import their heavy dependencies lazily.
_COMMANDS = {
    "fluidnb.cli._info": ("info", "sample", "convert"),
    "fluidnb.cli._flicker": ("flicker",),
    "fluidnb.cli._frost": ("frost",),
    "fluidnb.cli._fluid": ("simulate",),
    "fluidnb.cli._fire": ("fire",),
    "fluidnb.cli._turbulence": ("turbulence",),
    "fluidnb.cli._videodb": ("videodb",),
    "fluidnb.cli._animate": ("animate",),
    "fluidnb.cli._scene": ("scene",),
}
_COMMAND_MODULES = list(_COMMANDS)


def _module_of(argv):
    """The module of the command ``argv`` runs, or None (no command, help, a typo).

    Registering a command imports its method's parameters, and so its package: for
    ``fluidnb flicker`` the other four methods' packages (numba kernels, scipy.ndimage)
    were a second of start-up it never used (issue 39).
    """
    for arg in argv:
        if arg.startswith("-"):
            continue  # --debug; --version and -h print and exit with every command listed
        for module, names in _COMMANDS.items():
            if arg in names:
                return module
        return None
    return None


def build_parser(argv=None):
    """The argument parser with every registered subcommand.

    Parameters
    ----------
    argv : list of str, optional
        The arguments it will parse: if they name a command, only that command is
        registered (its parser is the same as in the full one). By default, all.
    """
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
    only = None if argv is None else _module_of(argv)
    for name in _COMMAND_MODULES if only is None else [only]:
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

    Parameters
    ----------
    argv : list of str, optional
        The arguments; by default ``sys.argv[1:]``, and then the call is taken as the
        whole process (the ``fluidnb`` command, ``python -m fluidnb``), which ends
        when it returns: see below.

    Notes
    -----
    Run as the process (``argv`` not given), the objects left are frozen
    (:func:`gc.freeze`) before returning, so the collection at the interpreter's exit
    does not walk them. After a command that ran numba's kernels that walk was
    0.25-0.5 s at the end of every command (issue 39);
    nothing else changes (files are closed, ``atexit`` handlers run).

    As the process it also asks numpy not to advise the kernel to back new large
    arrays with huge pages (unless ``NUMPY_MADVISE_HUGEPAGE`` is set): a command
    fills a gigabyte or more of fresh arrays once, and where the kernel compacts
    memory on such a fault (``defrag`` = ``madvise``, the default) a busy machine's
    fragmented memory made those faults slow. ``fluidnb flicker`` at 1920 px, three
    interleaved pairs at load 10: 7.3-8.9 s of CPU (1.6-2.0 s system) against
    8.1-9.5 s (2.7-3.9 s system), the frames the same.
    """
    global AS_PROCESS
    as_process = argv is None
    try:
        if as_process:
            _small_pages()  # imports numpy: inside the try, so Ctrl-C there is one line too
            AS_PROCESS = True  # a command may tune its own process (animate's allocator)
        return _run(argv)
    except KeyboardInterrupt:  # before the command started: numpy, the parser
        print("fluidnb: cancelled", file=sys.stderr)
        return 130
    finally:
        if as_process:
            gc.freeze()


#: True once :func:`main` runs as the process (``argv`` not given).
AS_PROCESS = False


def _small_pages():
    """Turn numpy's huge-page advice off for this process, unless the user set it (main)."""
    if "NUMPY_MADVISE_HUGEPAGE" in os.environ:
        return
    import numpy as np

    # numpy's switch for NUMPY_MADVISE_HUGEPAGE once imported (private, hence the guard).
    switch = getattr(getattr(np, "_core", None), "multiarray", None)
    switch = getattr(switch, "_set_madvise_hugepage", None)
    if switch is not None:
        switch(False)


def _run(argv):
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
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
