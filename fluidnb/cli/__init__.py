"""The ``fluidnb`` command line: one subcommand per method, plus ``info``."""

from ._common import add_output_option, add_params_options, add_seed_option, params_from_args
from ._main import build_parser, iter_commands, main
from ._paths import PathOption, add_input, add_output, check_paths, path_options

__all__ = [
    "PathOption",
    "add_input",
    "add_output",
    "add_output_option",
    "add_params_options",
    "add_seed_option",
    "build_parser",
    "check_paths",
    "iter_commands",
    "main",
    "params_from_args",
    "path_options",
]
