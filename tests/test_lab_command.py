"""The README's main command (dev.py lab) starts JupyterLab on the notebooks, and the
starter video databases' build in the background."""

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request

import pytest

from fluidnb.videodb import STARTER_KINDS
from fluidnb.videodb.starter._databases import _VERSION
from tests.support.envs import ROOT

pytestmark = pytest.mark.slow


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url, method="GET"):
    req = urllib.request.Request(url, method=method)
    with urllib.request.urlopen(req, timeout=5) as resp:
        return resp.status, resp.read()


def _alive(pid):
    try:
        os.kill(pid, 0)
    except OSError:
        return False
    return True


def test_lab_command_serves_the_notebooks(tmp_path):
    port, token = _free_port(), "fluidnb-test"
    env = dict(os.environ)
    # The quick starter databases (seconds), into this test's own cache.
    cache = tmp_path / "cache"
    env.update(FLUIDNB_CACHE_DIR=str(cache), FLUIDNB_QUICK="1")
    env.pop("FLUIDNB_PREBUILD", None)
    for var in ("CONFIG", "RUNTIME", "DATA"):
        env[f"JUPYTER_{var}_DIR"] = str(tmp_path / var.lower())
    env["JUPYTERLAB_SETTINGS_DIR"] = str(tmp_path / "settings")
    env["JUPYTERLAB_WORKSPACES_DIR"] = str(tmp_path / "workspaces")
    cmd = [
        sys.executable,
        str(ROOT / "dev.py"),
        "lab",
        "--no-browser",
        "--ip=127.0.0.1",
        f"--port={port}",
        "--ServerApp.port_retries=0",
        f"--IdentityProvider.token={token}",
    ]
    log = open(tmp_path / "lab.log", "w")  # noqa: SIM115 - closed in finally
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 240  # the first run may install the package
        while True:
            try:
                status, _ = _get(f"{base}/api/status?token={token}")
                if status == 200:
                    break
            except OSError:
                pass
            assert proc.poll() is None, (tmp_path / "lab.log").read_text()[-3000:]
            assert time.monotonic() < deadline, "JupyterLab did not answer"
            time.sleep(0.5)
        status, body = _get(f"{base}/api/contents?token={token}")
        names = {item["name"] for item in json.loads(body)["content"]}
        assert "00_overview.ipynb" in names
        status, page = _get(f"{base}/lab?token={token}")
        assert status == 200
        assert b"JupyterLab" in page
        # Meanwhile the starter databases are built in the background, into the cache.
        pid = int((cache / "videodb" / "prebuild.pid").read_text())
        built = [cache / "videodb" / f"{kind}-v{_VERSION}-quick" for kind in STARTER_KINDS]
        deadline = time.monotonic() + 300
        while not all((p / "manifest.json").is_file() for p in built):
            assert time.monotonic() < deadline, (cache / "videodb" / "prebuild.log").read_text()
            time.sleep(0.5)
        _get(f"{base}/api/shutdown?token={token}", method="POST")
        proc.wait(timeout=30)
        deadline = time.monotonic() + 60
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not _alive(pid)
        assert (
            "starter databases built: water, smoke, fire"
            in (cache / "videodb" / "prebuild.log").read_text()
        )
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=30)
        log.close()


def test_lab_command_can_leave_the_starter_databases_alone(tmp_path, monkeypatch):
    import dev

    monkeypatch.setenv("FLUIDNB_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("FLUIDNB_PREBUILD", "0")
    assert dev.prebuild() is None
    assert not (tmp_path / "videodb").exists()
