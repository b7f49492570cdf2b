"""The built wheel installs into a fresh venv and both layers import from it."""

import zipfile

import pytest

from tests.support.envs import ROOT, make_venv, run

pytestmark = pytest.mark.slow


def test_wheel_installs_and_imports_library_and_widgets(tmp_path):
    dist = tmp_path / "dist"
    run([_python(), "-m", "build", "--wheel", "--outdir", dist, ROOT], cwd=tmp_path)
    (wheel,) = dist.glob("fluidnb-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "fluidnb/widgets/__init__.py" in names
    assert "fluidnb/data/sources.json" in names
    # Enables the server extension with which /voila/render/ typesets math offline.
    config = ".data/data/etc/jupyter/jupyter_server_config.d/fluidnb.json"
    assert any(n.startswith("fluidnb-") and n.endswith(config) for n in names)
    assert not any(n.startswith(("tests/", "widgets/", "notebooks/")) for n in names)

    py = make_venv(tmp_path / "venv")
    run([py, "-m", "pip", "install", "--quiet", wheel], cwd=tmp_path)
    out = run(
        [
            py,
            "-c",
            "import fluidnb, fluidnb.widgets, fluidnb.fields, fluidnb.data;"
            "print(fluidnb.__file__); print(fluidnb.data.sample(fluidnb.data.names()[0]).dtype)",
        ],
        cwd=tmp_path,
    ).stdout
    assert str(tmp_path / "venv") in out, "imported from the checkout, not the installed wheel"
    assert "float32" in out
    version = run([tmp_path / "venv" / "bin" / "fluidnb", "--version"], cwd=tmp_path).stdout
    assert version.startswith("fluidnb ")


def _python():
    import sys

    return sys.executable
