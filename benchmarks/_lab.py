"""JupyterLab in Chromium for the browser benchmarks: a server, a page, a notebook run.

Shared by ``browser_videodb_app.py`` and ``bench_live.py``; the fixtures of
``tests/browser`` do the same for the tests (their flags and kernel check are reused).
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.browser.conftest import _KERNEL_IDLE, CHROMIUM_FLAGS, TOKEN  # noqa: E402
from tests.browser.helpers import free_port, isolated_env, stop, wait_http  # noqa: E402


@contextlib.contextmanager
def lab(viewport=(1400, 900)):
    """A JupyterLab server and a Chromium page on it: yields ``(page, url, root)``."""
    from playwright.sync_api import sync_playwright

    base = Path(tempfile.mkdtemp(prefix="fluidnb-bench-lab-"))
    root = base / "root"
    root.mkdir()
    port = free_port()
    cmd = [
        sys.executable, "-m", "jupyter", "lab", "--no-browser", "--ServerApp.ip=127.0.0.1",
        f"--ServerApp.port={port}", "--ServerApp.port_retries=0",
        f"--IdentityProvider.token={TOKEN}", f"--ServerApp.root_dir={root}",
        "--LabApp.expose_app_in_browser=True",
    ]  # fmt: skip
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--allow-root")
    log_file = base / "server.log"
    with log_file.open("w") as out:
        proc = subprocess.Popen(cmd, env=isolated_env(base), cwd=root, stdout=out, stderr=out)
    url = f"http://127.0.0.1:{port}"
    try:
        wait_http(f"{url}/api/status?token={TOKEN}", proc, log_file)
        chromium = os.environ.get("FLUIDNB_CHROMIUM") or "/usr/bin/chromium"
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium, args=CHROMIUM_FLAGS)
            page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
            yield page, url, root
            browser.close()
    finally:
        stop(proc)


def open_notebook(page, url, root, name, cells, ready=".fluidnb-app .fluidnb-run", timeout=600):
    """Write ``cells`` as ``name.ipynb``, open it, Run All; wait for ``ready`` to show."""
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3"}
    nb.cells = [nbformat.v4.new_code_cell(c) for c in cells]
    nbformat.write(nb, root / f"{name}.ipynb")
    page.goto(f"{url}/lab/tree/{name}.ipynb?reset&token={TOKEN}")
    page.wait_for_function(_KERNEL_IDLE, timeout=120_000, polling=100)
    page.evaluate("() => window.jupyterapp.shell.collapseLeft()")
    deadline = time.monotonic() + timeout
    for _ in range(4):  # a Run All while the kernel starts is dropped
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
        try:
            page.locator(ready).first.wait_for(timeout=max(1, deadline - time.monotonic()) * 250)
            break
        except Exception:  # try the Run All again
            continue
    page.locator(ready).first.wait_for(timeout=max(1, deadline - time.monotonic()) * 1000)


def close_notebook(page):
    """Shut the open notebook's kernel down (the next notebook gets the cores)."""
    page.evaluate(
        "() => window.jupyterapp.commands.execute('kernelmenu:shutdown').catch(() => null)"
    )
    page.wait_for_timeout(300)
