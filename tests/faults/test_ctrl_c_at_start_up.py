"""Ctrl-C while the command line starts up: one line and exit status 130, no traceback.

The console script imports ``fluidnb.cli`` and calls ``main()``; numpy, scipy and numba
take seconds to import on a busy machine, and Ctrl-C then printed a traceback from
numba's import (issue 37). The import of ``fluidnb.cli`` is light now and every heavy
import happens inside ``main()``, which catches the interrupt.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

# The console script, interrupted by Ctrl-C as the named module starts to load: a meta
# path finder raises KeyboardInterrupt exactly there, as the signal handler would.
INTERRUPTED = """
import runpy, sys

class CtrlC:
    def find_spec(self, name, path=None, target=None):
        if name == {module!r}:
            raise KeyboardInterrupt
        return None

sys.meta_path.insert(0, CtrlC())
sys.argv = [{script!r}, *{argv!r}]
runpy.run_path({script!r}, run_name="__main__")
"""


def _console_script():
    script = shutil.which("fluidnb", path=str(Path(sys.executable).parent))
    if script is None:
        pytest.skip("the fluidnb console script is not installed beside this Python")
    return script


@pytest.mark.parametrize("module", ["numpy", "scipy", "numba", "PIL"])
def test_ctrl_c_while_a_dependency_loads_is_one_line(module, tmp_path):
    # A real photo: the command reads it before it needs some of the modules (numba
    # loads on a thread of its own beside the model; issue 39).
    from PIL import Image

    Image.new("RGB", (32, 24), (90, 120, 200)).save(tmp_path / "photo.png")
    argv = ["flicker", str(tmp_path / "photo.png"), "-o", str(tmp_path / "o.gif")]
    code = INTERRUPTED.format(module=module, script=_console_script(), argv=argv)
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=tmp_path
    )
    assert "Traceback" not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines()[-1].endswith("cancelled"), run.stderr
    assert run.returncode == 130, run.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["photo.png"]


@pytest.mark.parametrize("delay", [0.5, 1.5])
def test_a_real_ctrl_c_during_start_up_prints_no_traceback(delay, tmp_path):
    from PIL import Image

    Image.new("RGB", (64, 48), (90, 120, 200)).save(tmp_path / "photo.png")
    proc = subprocess.Popen(
        [_console_script(), "flicker", "photo.png", "-o", "o.gif"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert "Traceback" not in err, err
    if proc.returncode != 0:  # (on a fast machine the run may be over already)
        assert proc.returncode == 130, err
        assert err.strip().splitlines()[-1].rsplit("\r", 1)[-1].endswith("cancelled"), err
