"""binder/ alone builds an environment in which every notebook runs, as Binder would."""

import re

import pytest

from tests.support.envs import clean_env, copy_repo, make_venv, run

pytestmark = pytest.mark.slow

# Every notebook, two at a time (CI's second core is otherwise idle while one kernel
# runs; tests/test_notebooks.py does the same), each in its own folder, process and
# kernel (notebooks may write exports next to themselves), longest first so that the
# two lines end together; then "ran NAME" for each, in name order.
RUN_ALL = r"""
import pathlib, shutil, subprocess, sys, tempfile
from concurrent.futures import ThreadPoolExecutor

ONE = (
    "import sys, pathlib, nbformat\n"
    "from nbclient import NotebookClient\n"
    "path = pathlib.Path(sys.argv[1])\n"
    "nb = nbformat.read(path, as_version=4)\n"
    "NotebookClient(nb, timeout=600, kernel_name='python3',\n"
    "               resources={'metadata': {'path': str(path.parent)}}).execute()\n"
)
LONGEST_FIRST = ["07b", "00", "06_", "08", "05", "07a", "03", "02", "06b", "04", "01"]


def rank(p):
    known = [i for i, k in enumerate(LONGEST_FIRST) if p.name.startswith(k)]
    return known[0] if known else len(LONGEST_FIRST)


def run(p):
    # inside the copied repo, under the test's tmp_path: pytest removes it
    folder = pathlib.Path(tempfile.mkdtemp(prefix=p.stem, dir="."))
    shutil.copy(p, folder / p.name)
    cmd = [sys.executable, "-c", ONE, str(folder / p.name)]
    return subprocess.run(cmd, capture_output=True, text=True)


paths = sorted(pathlib.Path("notebooks").glob("*.ipynb"), key=rank)
with ThreadPoolExecutor(max_workers=2) as pool:
    done = dict(zip(paths, pool.map(run, paths)))
for p in sorted(done):
    if done[p].returncode:
        print(p.name, "failed:", done[p].stderr[-3000:], file=sys.stderr)
    else:
        print("ran", p.name, flush=True)
sys.exit(1 if any(r.returncode for r in done.values()) else 0)
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
