"""Helpers every subcommand uses, so options are named like the parameter fields."""

from __future__ import annotations

import argparse

from ._paths import add_output

__all__ = [
    "add_fps_option",
    "add_output_option",
    "add_params_options",
    "add_seed_option",
    "fps_value",
    "params_from_args",
    "reuse_freed_memory",
]

_TYPES = {"int": int, "float": float}


def add_params_options(parser, params_cls):
    """Add one ``--<field>`` option per field of a :class:`fluidnb.Params` subclass.

    Options default to ``None`` so that :func:`params_from_args` passes only what
    the user gave and the dataclass supplies the paper's defaults.
    """
    group = parser.add_argument_group(f"parameters ({params_cls.__name__})")
    for spec in params_cls.specs().values():
        flag = "--" + spec.name.replace("_", "-")
        help_text = f"{spec.describe()} (default: {spec.default!r})".replace("%", "%%")
        kind = spec.kind
        if kind == "bool":
            group.add_argument(
                flag, dest=spec.name, action=argparse.BooleanOptionalAction, help=help_text
            )
        elif kind == "choice":
            group.add_argument(flag, dest=spec.name, choices=spec.choices, help=help_text)
        else:
            group.add_argument(
                flag, dest=spec.name, type=_TYPES[kind], metavar=spec.name.upper(), help=help_text
            )
    return group


def params_from_args(params_cls, args):
    """Build the parameter object from parsed options (validated; ValueError if not)."""
    given = {
        name: getattr(args, name)
        for name in params_cls.specs()
        if getattr(args, name, None) is not None
    }
    return params_cls(**given)


def add_seed_option(parser):
    """Add ``--seed`` (an int; same seed, same frames)."""
    parser.add_argument(
        "--seed", type=int, default=None, help="random seed (same seed, same frames)"
    )


def add_output_option(parser, *, required=True, kind="clip", help=None):
    """Add ``-o/--output``: for a clip the format follows the extension."""
    add_output(
        parser,
        "-o",
        "--output",
        kind=kind,
        required=required,
        metavar="OUT",
        help=help or "output file: .gif, .mp4, .npz, or a new folder for a PNG sequence",
    )


def fps_value(text):
    """``--fps``: a frame rate the library accepts (argparse refuses it otherwise)."""
    from .._validation import check_fps

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"fps must be a number, got {text!r}") from None
    try:
        return check_fps(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_fps_option(parser, default, help):
    """Add ``--fps``, checked as :class:`fluidnb.Clip` checks it."""
    parser.add_argument("--fps", type=fps_value, default=default, help=help)


def reuse_freed_memory():
    """Have glibc's malloc keep freed blocks of up to 32 MB for reuse (this process).

    ``fluidnb animate`` and ``fluidnb scene`` call it before their work. A 1920-px
    video-database render frees and allocates arrays of 5-30 MB for every frame (the
    pyramids of the blend and the phases' cross-fade, the remaps); by default glibc
    hands such blocks back to the kernel (and each thread's arena its 64 MB heaps as
    they empty) and gets fresh pages the next time, each faulted in and zeroed: 8.6
    million faults and 30 s of system time at 96 frames. With blocks up to 32 MB
    (glibc's largest threshold) taken from one heap that is not trimmed: 1.2 million
    and 10 s, and a lower peak (2.6 GB, was 2.8). ``fluidnb scene`` at 1920 px (three
    layers' frames made together): 33.8 -> 31.3 s, 6.7 -> 2.8 s of system time, peak
    2.82 -> 2.46 GB. Nothing else changes; elsewhere than glibc this does nothing.
    """
    import ctypes
    import platform

    # Only when the command is the process (main() without arguments): a notebook or
    # a test calling main(argv) keeps its own allocator's settings.
    from . import _main

    if not _main.AS_PROCESS or platform.libc_ver()[0] != "glibc":
        return
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold, m_arena_max = -1, -3, -8  # malloc.h
    mallopt(m_mmap_threshold, 32 * 2**20)
    mallopt(m_trim_threshold, 2**31 - 1)
    # One arena for every thread: a thread's own arena grows in heaps of at most 64 MB
    # and gives each back when it empties, so the frames' threads kept faulting.
    mallopt(m_arena_max, 1)
