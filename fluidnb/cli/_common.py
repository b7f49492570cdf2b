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
