"""Every subcommand with each output aimed at each of its inputs: refused, inputs intact.

The subcommands and their file options come from the parser itself (the options
declared with ``fluidnb.cli.add_input`` / ``add_output``), so a new subcommand or a new
file option cannot be left out: a command with outputs and no recipe in
tests/support/cli_inputs.py fails :func:`test_every_command_that_writes_has_a_recipe`.
The recipes are valid runs on tiny inputs; only the aimed runs are made, and each must
be refused before any work, with exit status 2 and every byte under the inputs' folder
unchanged.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fluidnb.cli import build_parser, iter_commands, main, path_options
from fluidnb.sketch import save_strokes
from tests.support.cli_inputs import RECIPES, make_inputs, moving_clip


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("inputs"))


# File options a recipe leaves out, and why.
NOT_IN_RECIPES = {
    ("turbulence", "save_sample"): "writes the sample pair; refused with --target/--source",
}


def _leaves():
    return {names: leaf for names, leaf in iter_commands(build_parser())}


def test_every_command_that_writes_has_a_recipe():
    for names, leaf in _leaves().items():
        options = path_options(leaf)
        outputs = [o for o in options if o.role == "output"]
        if outputs and len(options) >= 2:
            assert names in RECIPES, f"add a recipe for `fluidnb {' '.join(names)}`"
    assert set(RECIPES) <= set(_leaves())


def _snapshot(folder):
    """Every file under ``folder``: relative path -> bytes (so listings compare too)."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = Path(root, name)
            out[str(path.relative_to(folder))] = None if path.is_dir() else path.read_bytes()
    return out


def _aimed_runs(names, d, o):
    """(description, argv) of the recipe with each output aimed at each input and output."""
    argv = [str(a) for a in RECIPES[names](d, o)]
    args = build_parser().parse_args(argv)
    options = args.path_options
    given = [(opt, v) for opt in options for v in opt.values(args)]
    for opt in options:
        if (names[-1], opt.dest) not in NOT_IN_RECIPES:
            assert opt.values(args), f"the recipe of {names} leaves out {opt.label}"
    runs = []
    for out_opt, out_value in given:
        if out_opt.role != "output":
            continue
        at = argv.index(out_value)
        for target_opt, target in given:
            if target_opt is out_opt:
                continue
            aimed = [*argv[:at], target, *argv[at + 1 :]]
            runs.append((f"{out_opt.label} at {target_opt.label} {target}", aimed))
            if target_opt.role == "input" and os.path.isdir(target):
                name = {"clip": "inside.gif", "file": "inside.npz", "folder": "inside"}
                inside = os.path.join(target, name[out_opt.kind])
                aimed = [*argv[:at], inside, *argv[at + 1 :]]
                runs.append((f"{out_opt.label} inside {target_opt.label} {target}", aimed))
    return runs


@pytest.mark.parametrize("names", sorted(RECIPES), ids=" ".join)
def test_an_output_aimed_at_an_input_or_output_is_refused(names, inputs, capsys):
    runs = _aimed_runs(names, inputs, inputs / "out")
    assert runs
    before = _snapshot(inputs)
    for what, argv in runs:
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2, f"{what}: exit status {code}, stderr {err!r}"
        assert "Nothing was written" in err, f"{what}: {err!r}"
        assert _snapshot(inputs) == before, f"{what} changed the inputs"


def test_the_recipes_are_valid_commands(inputs):
    """Each recipe parses and names files that exist (so the refusals above are real)."""
    for names in RECIPES:
        argv = [str(a) for a in RECIPES[names](inputs, inputs / "out")]
        args = build_parser().parse_args(argv)
        for opt in args.path_options:
            if opt.role == "input":
                for value in opt.values(args):
                    assert os.path.exists(value), value
    manifest = json.loads((inputs / "db" / "manifest.json").read_text())
    assert manifest["format"] == "fluidnb.videodb"


# ---------------------------------------------------------------------- how paths resolve


@pytest.fixture
def gif(tmp_path):
    moving_clip(4, (0, 1), frames=3).save(tmp_path / "in.gif")
    return tmp_path / "in.gif"


def _refused(argv, capsys, *paths):
    before = {p: p.read_bytes() for p in paths}
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    for p in paths:
        assert p.read_bytes() == before[p]
    return err


def test_output_through_dot_slash_dot_dot_and_a_symlink_is_refused(
    gif, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    err = _refused(["convert", "in.gif", "-o", "./in.gif"], capsys, gif)
    assert "--output './in.gif' is the same file as INPUT 'in.gif'" in err
    (tmp_path / "sub").mkdir()
    err = _refused(["convert", "in.gif", "-o", "sub/../in.gif"], capsys, gif)
    assert "same file" in err
    (tmp_path / "link.gif").symlink_to(gif)
    err = _refused(["convert", "link.gif", "-o", gif], capsys, gif)
    assert "same file" in err
    err = _refused(["convert", gif, "-o", "link.gif"], capsys, gif)
    assert "same file" in err
    (tmp_path / "linked-folder").symlink_to(tmp_path, target_is_directory=True)
    err = _refused(["convert", gif, "-o", "linked-folder/in.gif"], capsys, gif)
    assert "same file" in err


def test_output_differing_in_letter_case(gif, tmp_path, capsys):
    """One file on a case-insensitive disk (refused); two files on a case-sensitive one."""
    upper = tmp_path / "IN.GIF"
    if upper.exists():  # case-insensitive (macOS, Windows): the same file
        err = _refused(["convert", gif, "-o", upper], capsys, gif)
        assert "same file" in err
    else:
        before = gif.read_bytes()
        assert main(["convert", str(gif), "-o", str(upper)]) == 0
        assert gif.read_bytes() == before
        assert upper.exists()


def test_output_folder_that_holds_the_input_is_refused(gif, tmp_path, capsys):
    err = _refused(["convert", gif, "-o", tmp_path], capsys, gif)
    assert "is a folder that holds INPUT" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.gif"]


def test_mp4_sidecar_aimed_at_an_input_is_refused(tmp_path, capsys):
    """``-o x.mp4`` also writes ``x.mp4.json``: aimed at an input, that is refused too."""
    Image.fromarray(np.full((24, 24, 3), 128, np.uint8)).save(tmp_path / "p.png")
    strokes = save_strokes(tmp_path / "x.mp4.json", [[[12, 20], [12, 4]]], (24, 24))
    argv = ["flicker", tmp_path / "p.png", "--flow", strokes, "-o", tmp_path / "x.mp4"]
    err = _refused(argv, capsys, tmp_path / "p.png", strokes)
    assert f"(which writes {str(strokes)!r}) is the same file as --flow" in err
    assert not (tmp_path / "x.mp4").exists()


def test_two_outputs_of_one_command_are_refused(tmp_path, capsys):
    Image.fromarray(np.full((24, 24, 3), 128, np.uint8)).save(tmp_path / "p.png")
    out = tmp_path / "X.npz"
    argv = ["frost", tmp_path / "p.png", "--start", "12,12", "--freeze-times", out, "-o", out]
    err = _refused(argv, capsys)
    assert "--output" in err
    assert "--freeze-times" in err
    assert "two outputs" in err
    assert not out.exists()


def test_output_under_a_file_or_in_a_forbidden_folder_is_refused_up_front(tmp_path, capsys):
    Image.fromarray(np.full((24, 24, 3), 128, np.uint8)).save(tmp_path / "photo.png")
    argv = ["simulate", "--frames", "1", "--shape", "8,8", "-o", tmp_path / "photo.png" / "x.npz"]
    err = _refused(argv, capsys, tmp_path / "photo.png")
    assert "is a file, not a folder" in err
    assert "Traceback" not in err
