import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from fluidnb import Clip, Params, param
from fluidnb.cli import add_params_options, build_parser, main, params_from_args


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("fluidnb ")
    assert main([]) == 0
    assert "info" in capsys.readouterr().out


def test_console_script_entry_point_runs():
    out = subprocess.run(
        [sys.executable, "-m", "fluidnb", "--version"], capture_output=True, text=True, check=True
    )
    assert out.stdout.startswith("fluidnb ")


def test_info_lists_versions_and_data(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "numpy" in out
    assert "sample data:" in out


def test_sample_writes_an_image(tmp_path, capsys):
    assert main(["sample"]) == 0
    listing = capsys.readouterr().out
    name = listing.split()[0]
    out = tmp_path / "s.png"
    assert main(["sample", name, "--size", "32", "-o", str(out)]) == 0
    assert out.exists()
    assert main(["sample", "no-such-sample", "-o", str(out)]) == 2
    assert "no-such-sample" in capsys.readouterr().err


def test_convert_between_formats(tmp_path):
    frames = np.random.default_rng(0).random((3, 8, 10)).astype(np.float32)
    Clip(frames, fps=5, metadata={"method": "test"}).save(tmp_path / "c.npz")
    assert main(["convert", str(tmp_path / "c.npz"), "-o", str(tmp_path / "c.gif")]) == 0
    assert (tmp_path / "c.gif").exists()
    assert main(["convert", str(tmp_path / "c.npz"), "-o", str(tmp_path / "pngs")]) == 0
    assert len(list((tmp_path / "pngs").glob("*.png"))) == 3


def test_convert_reports_bad_input_as_error(tmp_path, capsys):
    (tmp_path / "bad.npz").write_bytes(b"garbage")
    assert main(["convert", str(tmp_path / "bad.npz"), "-o", str(tmp_path / "x.gif")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fluidnb convert: error:")
    assert "bad.npz" in err


@dataclass(frozen=True)
class Demo(Params):
    rth: float = param(0.0, lo=0, hi=1, symbol="r_{th}")
    steps: int = param(10, lo=1, integer=True)
    mapping: str = param("convex", choices=("plane", "convex"))
    shade: bool = param(True)


def test_params_options_follow_field_names():
    import argparse

    parser = argparse.ArgumentParser()
    add_params_options(parser, Demo)
    args = parser.parse_args(["--rth", "0.4", "--mapping", "plane", "--no-shade"])
    p = params_from_args(Demo, args)
    assert p == Demo(rth=0.4, mapping="plane", shade=False)
    assert params_from_args(Demo, parser.parse_args([])) == Demo()
    with pytest.raises(ValueError, match=r"rth must be in \[0, 1\]"):
        params_from_args(Demo, parser.parse_args(["--rth", "2"]))


COMMANDS = [
    "info",
    "sample",
    "convert",
    "flicker",
    "frost",
    "simulate",
    "fire",
    "turbulence",
    "videodb",
    "animate",
]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_is_registered_with_its_help(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: fluidnb {command} ")


def test_parser_routes_commands_to_their_handlers(capsys):
    args = build_parser().parse_args(["convert", "in.npz", "-o", "out.gif"])
    assert (args.command, args.func.__name__) == ("convert", "_convert")
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_each_command_module_registers_the_names_listed():
    # main() registers only the command it runs (start-up, issue 39): the table it
    # looks the command up in must say what each module registers.
    import argparse
    import importlib

    from fluidnb.cli._main import _COMMANDS

    for module, names in _COMMANDS.items():
        parser = argparse.ArgumentParser()
        sub = parser.add_subparsers()
        importlib.import_module(module).register(sub)
        assert tuple(sub.choices) == names, module


def test_a_parser_of_one_command_parses_as_the_full_one():
    argv = ["--debug", "flicker", "in.png", "--mapping", "plane", "--seed", "3", "-o", "o.mp4"]
    one, full = build_parser(argv), build_parser()
    assert set(_commands(one)) == {"flicker"}
    assert len(_commands(full)) > 5
    parsed = [vars(p.parse_args(argv)) for p in (one, full)]
    for args in parsed:  # actions of two parsers: compare what they check
        args["path_options"] = [(a.dest, a.option_strings) for a in args["path_options"]]
    assert parsed[0] == parsed[1]
    assert parsed[0]["mapping"] == "plane"
    assert parsed[0]["seed"] == 3
    # No command, an unknown one, or help alone: every command is listed.
    for argv in ([], ["--help"], ["nosuch"]):
        assert set(_commands(build_parser(argv))) == set(_commands(full))


def _commands(parser):
    import argparse

    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return list(action.choices)


@pytest.mark.parametrize(("setting", "advice"), [(None, "False"), ("1", "True")])
def test_the_command_turns_numpys_huge_page_advice_off_unless_the_user_set_it(setting, advice):
    import os

    code = (
        "import sys; from numpy._core import multiarray as m; from fluidnb.cli import main; "
        "sys.argv = ['fluidnb']; main(); print(m._set_madvise_hugepage(True))"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    if setting is not None:
        env["NUMPY_MADVISE_HUGEPAGE"] = setting
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-1] == advice
