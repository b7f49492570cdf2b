"""Every subcommand's failure modes: one line ``fluidnb CMD: error: ...``, exit status 2.

The cases are made from the parser and the recipes of tests/support/cli_inputs.py: each
input in turn missing, a folder, or a damaged file; each output under a file or in a
folder nobody can write; an absurd ``--fps``. No traceback, no ``.partial`` file named
or left behind. A few of them run through ``python -m fluidnb`` in a subprocess too.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fluidnb.cli import build_parser, main
from tests.support.cli_inputs import RECIPES, make_hostile_inputs, make_inputs

# Inputs the fault probe of issue 37 made, by the extension of the input they replace:
# (what, file name in the inputs folder) -- see make_hostile_inputs.
HOSTILE = {
    ".png": [
        ("a decompression bomb (30000 x 30000 in 74 bytes)", "bomb.png"),
        ("8000 x 8000 black pixels", "black-8000.png"),
    ],
    ".json": [
        ("nested 200,000 arrays deep", "deep.json"),
        ("points of three coordinates", "three-coordinates.json"),
        ("booleans as coordinates", "booleans.json"),
    ],
}
# What the one line must say for them (a FIFO: what it is, not "no such file").
EXPECTED = {
    "a FIFO": "named pipe (FIFO)",
    "a decompression bomb": "declares 900 MP, more than the 50 MP",
    "8000 x 8000": "declares 8000 x 8000 pixels (64 MP)",
    "nested 200,000": "nested too deeply",
    "three coordinates": "point 0 is [24, 50, 0]: it has 3 coordinates",
    "booleans": "point 1 is [24, True]: coordinates must be numbers",
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = make_inputs(tmp_path_factory.mktemp("inputs"))
    make_hostile_inputs(d)
    (d / "a-folder").mkdir()
    return d


def _unwritable(tmp_path):
    """A folder no file can be created in: /proc on Linux, else a read-only folder."""
    if Path("/proc/self").is_dir():
        return Path("/proc")
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o500)
    return folder


def _suffix(value):
    return Path(value).suffix


def _cases(names, d, o, unwritable):
    """(description, argv) for each way of breaking the recipe of ``names``.

    Each case writes (if at all) into its own folder under ``o``.
    """
    cases = []
    for k, (what, argv) in enumerate(_breaks(names, d, unwritable)):
        (o / str(k)).mkdir()
        cases.append((what, [a.replace("{out}", str(o / str(k))) for a in argv]))
    return cases


def _breaks(names, d, unwritable):
    argv = [str(a) for a in RECIPES[names](d, Path("{out}"))]
    args = build_parser().parse_args(argv)
    breaks = []
    for opt in args.path_options:
        for value in opt.values(args)[:1]:
            at = argv.index(value)

            def swap(new, at=at):
                return [*argv[:at], str(new), *argv[at + 1 :]]

            ext = _suffix(value)
            if opt.role == "input":
                breaks.append((f"{opt.label} missing", swap(d / f"missing{ext}")))
                if not Path(value).is_dir():
                    breaks.append((f"{opt.label} a folder", swap(d / "a-folder")))
                    damaged = d / f"damaged{ext}"
                    damaged.write_bytes(b"not what the name says")
                    breaks.append((f"{opt.label} damaged", swap(damaged)))
                    # Issue 37: what the fault probe still found (see _hostile_inputs).
                    if names[0] != "videodb":  # videodb's sources: after its split
                        fifo = d / f"fifo{ext}"
                        if not fifo.exists():
                            os.mkfifo(fifo)
                        breaks.append((f"{opt.label} a FIFO", swap(fifo)))
                    for what, name in HOSTILE.get(ext, ()):
                        breaks.append((f"{opt.label} {what}", swap(d / name)))
            else:
                breaks.append((f"{opt.label} under a file", swap(d / "photo.png" / f"x{ext}")))
                breaks.append((f"{opt.label} unwritable", swap(unwritable / f"fluidnb-x{ext}")))
    if "--fps" in argv:
        at = argv.index("--fps") + 1
        breaks.append(("--fps 1e30", [*argv[:at], "1e30", *argv[at + 1 :]]))
    return breaks


def _run(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    return code, capsys.readouterr().err


def _one_clear_line(err):
    last = err.strip().splitlines()[-1] if err.strip() else ""
    # A progress bar may precede it on stderr (it ends in a carriage return).
    return last.rsplit("\r", 1)[-1].strip()


@pytest.mark.parametrize("names", sorted(RECIPES), ids=" ".join)
def test_every_failure_is_one_line_and_exit_status_2(names, inputs, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    cases = _cases(names, inputs, out, _unwritable(tmp_path))
    assert cases
    prog = "fluidnb " + " ".join(names)
    for what, argv in cases:
        code, err = _run(argv, capsys)
        line = _one_clear_line(err)
        assert code == 2, f"{what}: exit status {code}: {err!r}"
        assert "Traceback" not in err, f"{what}: {err}"
        assert line.startswith(f"{prog}: error: "), f"{what}: {err!r}"
        assert ".partial" not in err, f"{what}: {line}"
        for key, words in EXPECTED.items():
            if key in what:
                assert words in line, f"{what}: {line}"
    leftovers = [p for p in (*inputs.rglob("*partial*"), *out.rglob("*partial*"))]
    assert not leftovers


def test_simulate_and_sample_failures(tmp_path, capsys):
    Path(tmp_path / "photo.png").write_bytes(b"")
    unwritable = _unwritable(tmp_path)
    for argv in (
        ["simulate", "--frames", "1", "--shape", "8,8", "-o", str(tmp_path / "photo.png/x.npz")],
        ["simulate", "--frames", "1", "--shape", "8,8", "-o", str(unwritable / "f.gif")],
        ["simulate", "--frames", "1", "--shape", "8,8", "--fps", "1e30", "-o", "x.gif"],
        ["simulate", "--frames", "1", "--shape", "8,8", "-o", str(tmp_path / "x.png")],
        ["sample", "ripples", "-o", str(tmp_path / "photo.png/x.png")],
        ["sample", "ripples", "-o", str(unwritable / "x.png")],
        ["videodb", "info", str(tmp_path / "missing")],
    ):
        code, err = _run(argv, capsys)
        assert code == 2, argv
        assert "Traceback" not in err
        assert _one_clear_line(err).startswith(f"fluidnb {argv[0]}"), err
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "read-only") == ["photo.png"]


def test_debug_shows_the_traceback(tmp_path, monkeypatch):
    argv = ["simulate", "--frames", "1", "--shape", "8,8", "-o", str(tmp_path / "a.xyz")]
    assert main(argv) == 2
    with pytest.raises(ValueError, match="must end in"):
        main(["--debug", *argv])
    monkeypatch.setenv("FLUIDNB_DEBUG", "1")
    with pytest.raises(ValueError, match="must end in"):
        main(argv)


def test_a_bug_is_not_hidden(monkeypatch):
    """Only user errors become one line; a bug in fluidnb still shows its traceback."""
    import fluidnb.cli._info as info

    def broken(args):
        raise TypeError("a bug")

    monkeypatch.setattr(info, "_info", broken)
    with pytest.raises(TypeError, match="a bug"):
        main(["info"])


@pytest.mark.parametrize(
    "argv",
    [
        ["convert", "{d}/clip.gif", "--fps", "1e30", "-o", "{o}/x.mp4"],
        ["simulate", "--frames", "1", "--shape", "8,8", "-o", "{d}/photo.png/x.npz"],
        ["convert", "{d}/clip.gif", "-o", "{unwritable}/forbidden.gif"],
        ["convert", "{d}/missing.gif", "-o", "{o}/x.gif"],
    ],
    ids=["fps", "under-a-file", "unwritable", "missing"],
)
def test_the_console_command_prints_no_traceback(argv, inputs, tmp_path):
    values = {"d": inputs, "o": tmp_path, "unwritable": _unwritable(tmp_path)}
    argv = [a.format(**values) for a in argv]
    run = subprocess.run(
        [sys.executable, "-m", "fluidnb", *argv], capture_output=True, text=True, check=False
    )
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr
    assert _one_clear_line(run.stderr).startswith(f"fluidnb {argv[0]}: error: ")
    assert ".partial" not in run.stderr
    assert not list(tmp_path.rglob("*partial*"))
