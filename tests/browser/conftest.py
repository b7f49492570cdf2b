"""Fixtures for the real-browser tests: Chromium, one JupyterLab server, notebooks.

Every test writes its own notebook (from a list of code-cell sources) into its own
folder of the server's root, opens it in JupyterLab, runs it, and drives the widgets
with Playwright. What the kernel received is observed through small JSON files the
notebook writes next to itself (the kernel's working directory is the notebook's
folder). Every test leaves at least one screenshot in the artefact folder
(``FLUIDNB_ARTIFACTS``, default ``/tmp/fluidnb-test-artifacts``), outside the repo.

The browser is the Chromium named by ``FLUIDNB_CHROMIUM`` (``python3 dev.py test``
sets it), else ``/usr/bin/chromium``. Without one the tests fail: they are part of
the suite and are never skipped.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import nbformat
import pytest

from tests.browser.helpers import (
    free_port,
    isolated_env,
    node_slug,
    poll,
    read_json,
    stop,
    wait_http,
)

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
TOKEN = "fluidnb-browser-tests"
ARTIFACTS = Path(os.environ.get("FLUIDNB_ARTIFACTS", "/tmp/fluidnb-test-artifacts"))

# Defined in the first cell of every test notebook: write JSON atomically, so a test
# polling the file never reads half of it.
PRELUDE = """\
import json, os
import numpy as np

def dump(name, obj):
    tmp = name + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f)
    os.replace(tmp, name)
"""


# ---------------------------------------------------------------------- the browser
def chromium_path():
    """The Chromium binary to drive; fails the test run when there is none."""
    path = os.environ.get("FLUIDNB_CHROMIUM") or "/usr/bin/chromium"
    if not Path(path).exists():
        pytest.fail(
            f"no Chromium at {path}: the browser tests need one (they are never skipped). "
            "Install Debian's `chromium` or set FLUIDNB_CHROMIUM to a Chromium/Chrome "
            "binary; `python3 dev.py test` does this for you.",
            pytrace=False,
        )
    return path


@pytest.fixture(scope="session")
def browser_type_launch_args(browser_type_launch_args):
    return {
        **browser_type_launch_args,
        "executable_path": chromium_path(),
        "args": [*browser_type_launch_args.get("args", []), *CHROMIUM_FLAGS],
    }


@pytest.fixture(scope="session")
def base_url():
    # pytest-playwright 0.10's fallback ``base_url`` fixture (used when pytest-base-url
    # is not installed) is an instance method, which pytest 9 deprecates with a warning
    # (an error here). The tests use absolute URLs: provide the fixture ourselves.
    return None


@pytest.fixture(scope="session")
def browser_context_args(browser_context_args):
    return {**browser_context_args, "viewport": {"width": 1280, "height": 1000}}


@pytest.fixture(scope="session")
def lab_context(browser, browser_context_args):
    """One browser context for all tests: JupyterLab's bundles load from its cache."""
    context = browser.new_context(**browser_context_args)
    yield context
    context.close()


@pytest.fixture
def page(lab_context):
    # Overrides pytest-playwright's page (a new context per test, an empty cache).
    page = lab_context.new_page()
    yield page
    page.close()


# ---------------------------------------------------------------------- servers


class LabServer:
    """A running JupyterLab; ``api(method, path)`` calls its REST API."""

    def __init__(self, url, root, proc):
        self.url, self.root, self.proc = url, root, proc

    def api(self, method, path, body=None):
        req = urllib.request.Request(
            f"{self.url}/api/{path}",
            method=method,
            data=None if body is None else json.dumps(body).encode(),
            headers={"Authorization": f"token {TOKEN}", "Content-Type": "application/json"},
        )
        with urllib.request.urlopen(req, timeout=10) as r:
            data = r.read()
        return json.loads(data) if data else None

    def delete_sessions(self, folder):
        """Shut down the kernels of notebooks under ``folder`` (relative to the root)."""
        for s in self.api("GET", "sessions"):
            if s.get("path", "").startswith(f"{folder}/"):
                self.api("DELETE", f"sessions/{s['id']}")


# Each app once, headless, at its quick size: compiles the methods' numba kernels into
# their on-disk cache before any notebook kernel needs them. On a fresh install the
# first fire preview compiles for about a minute (62 s at load 3), longer than a
# browser test waits for a picture; afterwards every kernel loads them from the cache.
_COMPILE = """
import os
os.environ["FLUIDNB_QUICK"] = "1"
import numpy as np
from fluidnb.widgets import FireApp, FlickerApp, FrostApp, TurbulenceApp, VideoDBApp

def frost():
    app = FrostApp(quick=True)
    h, w = app.image.shape[:2]
    yy, xx = np.mgrid[:h, :w]
    app.set_region((yy - h / 2) ** 2 + (xx - w / 2) ** 2 < (min(h, w) / 4) ** 2)
    app.set_starts([[h / 2, w / 2]])
    return app

def videodb():
    app = VideoDBApp("stream", size=96, db="water", quick=True)
    h, w = app.photo.shape[:2]
    matte = np.zeros((h, w), bool)
    matte[h // 2 :] = True
    app.set_matte(matte)
    return app

for make in (lambda: FlickerApp(quick=True), lambda: FireApp(quick=True, n_frames=24), frost,
             lambda: TurbulenceApp(n_frames=24), videodb):
    app = make()
    app.run(timeout=900)
    app.preview(app.panel.params)
    app.close()
print("kernels compiled")
"""


@pytest.fixture(scope="session")
def compiled_kernels():
    """Run :data:`_COMPILE` once per session (seconds when the cache is warm)."""
    started = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-c", _COMPILE], capture_output=True, text=True, timeout=1800
    )
    if done.returncode != 0:  # the tests themselves will say what is wrong
        print(f"compiling the kernels failed:\n{done.stderr[-2000:]}", file=sys.stderr)
    else:
        print(f"kernels compiled in {time.monotonic() - started:.0f} s", file=sys.stderr)


@pytest.fixture(scope="session")
def lab_server(tmp_path_factory, compiled_kernels):
    base = tmp_path_factory.mktemp("lab")
    root = base / "root"
    root.mkdir()
    port = free_port()
    log = base / "server.log"
    cmd = [
        sys.executable, "-m", "jupyter", "lab",
        "--no-browser",
        "--ServerApp.ip=127.0.0.1",
        f"--ServerApp.port={port}",
        "--ServerApp.port_retries=0",
        f"--IdentityProvider.token={TOKEN}",
        f"--ServerApp.root_dir={root}",
        "--LabApp.expose_app_in_browser=True",
    ]  # fmt: skip
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        cmd.append("--allow-root")
    with log.open("w") as out:
        proc = subprocess.Popen(
            cmd, env=isolated_env(base), cwd=root, stdout=out, stderr=subprocess.STDOUT
        )
    server = LabServer(f"http://127.0.0.1:{port}", root, proc)
    try:
        wait_http(f"{server.url}/api/status?token={TOKEN}", proc, log)
        yield server
    finally:
        try:
            server.api("POST", "shutdown")
            proc.wait(15)
        except (OSError, urllib.error.URLError, subprocess.TimeoutExpired):
            pass
        stop(proc)


# ---------------------------------------------------------------------- notebooks
_KERNEL_IDLE = """() => {
  const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  const ctx = w && w.sessionContext;
  const k = ctx && ctx.session && ctx.session.kernel;
  if (!k || k.status !== 'idle' || k.connectionStatus !== 'connected') return false;
  const ind = document.querySelector('.jp-Notebook-ExecutionIndicator');
  if (ind && ind.getAttribute('data-status') !== 'idle') return false;
  const bar = document.querySelector('#jp-main-statusbar');
  const text = bar ? bar.textContent : '';
  return !text.includes('No Kernel') && /\\|\\s*Idle/.test(text);
}"""

_PROMPTS = """() => {
  const w = window.jupyterapp.shell.currentWidget;
  return Array.from(w.node.querySelectorAll('.jp-CodeCell .jp-InputPrompt'))
    .map(p => p.textContent.trim());
}"""

_ERRORS = """() => {
  const w = window.jupyterapp.shell.currentWidget;
  const out = [];
  for (const cell of w.content.widgets) {
    if (cell.model.type !== 'code') continue;
    for (const o of cell.model.outputs.toJSON()) {
      if (o.output_type === 'error') out.push(o.ename + ': ' + o.evalue + '\\n'
        + (o.traceback || []).join('\\n').replace(/\\x1b\\[[0-9;]*m/g, ''));
    }
  }
  return out;
}"""


class Notebook:
    """A test's notebook, open and executed in JupyterLab."""

    def __init__(self, page, folder):
        self.page = page
        self.folder = folder  # the kernel's working directory

    def state(self, name, until=lambda s: True, timeout=30):
        """Poll the JSON file ``name`` the kernel writes until ``until(data)`` holds."""
        path = self.folder / name
        seen = []

        def check():
            data = read_json(path)
            seen[:] = [data]
            return data if data is not None and until(data) else None

        deadline = time.monotonic() + timeout
        while (data := check()) is None:
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting on {name}; it holds {seen[0]!r}")
            time.sleep(0.1)
        return data


@pytest.fixture
def shot(request):
    """``shot(target, suffix="")``: screenshot a page or locator into the artefact folder."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    base = node_slug(request)

    def take(target, suffix=""):
        path = ARTIFACTS / f"{base}{'-' + suffix if suffix else ''}.png"
        target.screenshot(path=str(path))
        return path

    return take


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    rep = yield
    setattr(item, f"rep_{rep.when}", rep)
    return rep


@pytest.fixture
def notebook(lab_server, page, request):
    """``notebook(cells)``: write, open and run a notebook; returns a :class:`Notebook`.

    ``cells`` are code-cell sources (the :data:`PRELUDE` cell goes first). Waits for a
    really idle kernel, runs all cells, waits until every cell has run and fails with
    the traceback if one raised. The kernel is shut down after the test.
    """
    name = node_slug(request)
    folder = lab_server.root / name
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir()
    page.set_default_timeout(30_000)

    def open_and_run(cells):
        nb = nbformat.v4.new_notebook()
        nb.metadata["kernelspec"] = {
            "name": "python3",
            "display_name": "Python 3 (ipykernel)",
            "language": "python",
        }
        nb.cells = [nbformat.v4.new_code_cell(src) for src in [PRELUDE, *cells]]
        nbformat.write(nb, folder / f"{name}.ipynb")
        # Start the kernel now, while JupyterLab loads: the page joins this session.
        lab_server.api(
            "POST",
            "sessions",
            {"path": f"{name}/{name}.ipynb", "type": "notebook", "kernel": {"name": "python3"}},
        )
        page.goto(f"{lab_server.url}/lab/tree/{name}/{name}.ipynb?reset&token={TOKEN}")
        page.wait_for_function(_KERNEL_IDLE, timeout=60_000, polling=100)
        # More room for the widgets: hide the file browser.
        page.evaluate("() => window.jupyterapp.shell.collapseLeft()")
        n = len(cells) + 1
        # A Run All issued while the kernel is still starting is dropped silently:
        # re-issue it while no cell shows a sign of running.
        for _attempt in range(4):
            page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                prompts = page.evaluate(_PROMPTS)
                if any(re.search(r"\[(\*|\d+)\]", p) for p in prompts):
                    break
                time.sleep(0.1)
            else:
                continue
            break
        poll(
            "every cell to run",
            lambda: (
                (lambda p: len(p) == n and all(re.search(r"\[\d+\]", x) for x in p))(
                    page.evaluate(_PROMPTS)
                )
                or page.evaluate(_ERRORS)
            ),
            timeout=90,
        )
        errors = page.evaluate(_ERRORS)
        if errors:
            pytest.fail("a notebook cell raised:\n" + "\n".join(errors), pytrace=False)
        return Notebook(page, folder)

    yield open_and_run
    rep = getattr(request.node, "rep_call", None)
    if rep is not None and rep.failed:
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        # The page may be gone; the failure itself is reported either way.
        with contextlib.suppress(Exception):
            page.screenshot(path=str(ARTIFACTS / f"{name}-FAILED.png"))
    lab_server.delete_sessions(name)
