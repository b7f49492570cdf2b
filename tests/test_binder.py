"""binder/ alone builds an environment in which every notebook runs, as Binder would."""

import re

import pytest

from tests.support.envs import clean_env, copy_repo, make_venv, run

pytestmark = pytest.mark.slow

RUN_ALL = """
import pathlib, sys
import nbformat
from nbclient import NotebookClient
for path in sorted(pathlib.Path("notebooks").glob("*.ipynb")):
    nb = nbformat.read(path, as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    print("ran", path.name, flush=True)
"""


def test_binder_files_build_a_working_environment(tmp_path):
    repo = copy_repo(tmp_path / "repo")
    py = make_venv(tmp_path / "venv")
    env = clean_env(FLUIDNB_QUICK="1", MPLBACKEND="Agg")
    env["PATH"] = f"{py.parent}:{env['PATH']}"  # as Binder's image: its python first
    env["JUPYTER_CONFIG_DIR"] = str(tmp_path / "jupyter-config")
    env["JUPYTER_DATA_DIR"] = str(tmp_path / "jupyter-data")
    run([py, "-m", "pip", "install", "--quiet", "-r", "binder/requirements.txt"], cwd=repo, env=env)
    run(["bash", "binder/postBuild"], cwd=repo, env=env)
    out = run([py, "-c", RUN_ALL], cwd=repo, env=env).stdout
    notebooks = sorted(p.name for p in (repo / "notebooks").glob("*.ipynb"))
    assert [f"ran {n}" for n in notebooks] == out.split("\n")[-len(notebooks) - 1 : -1]
    where = run([py, "-c", "import fluidnb; print(fluidnb.__file__)"], cwd=tmp_path, env=env)
    assert str(tmp_path / "venv") in where.stdout
    # The server extension with which /voila/render/ pages typeset math offline is on.
    listed = run([py, "-m", "jupyter", "server", "extension", "list"], cwd=tmp_path, env=env)
    text = re.sub(r"\x1b\[[0-9;]*m", "", listed.stdout + listed.stderr)
    assert re.search(r"fluidnb\._jupyter_server\s+enabled", text), text
    assert re.search(r"fluidnb\._jupyter_server\s+OK", text), text
