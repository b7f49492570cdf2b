"""The ``fluidnb`` command line: one subcommand per method, plus ``info``."""

from ._common import add_output_option, add_params_options, add_seed_option, params_from_args
from ._main import build_parser, main

__all__ = [
    "add_output_option",
    "add_params_options",
    "add_seed_option",
    "build_parser",
    "main",
    "params_from_args",
]
