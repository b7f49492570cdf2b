"""The video-database lessons' first run, from a clean cache: what a class waits for.

    .venv/bin/python benchmarks/first_run.py                   # app, 07a, 07b (~10 min)
    .venv/bin/python benchmarks/first_run.py --case app --case 07a
    .venv/bin/python benchmarks/first_run.py --quick           # the quick databases

Goals (issue 22, point 2; 2 cores): from a fresh ``python3 dev.py lab`` to the
video-database app's first result in under 60 s, and each lesson's (07a, 07b) first Run
All in under 90 s. Each case starts from an empty cache folder of its own:

1. ``python3 dev.py lab --no-browser`` starts (JupyterLab, and the starter databases'
   build in the background, water first);
2. as soon as JupyterLab answers, a kernel runs -- as a person who opens the lesson and
   runs it -- either the app's cell of 07a (``VideoDBApp`` on the stream photo with its
   water painted, then **Run**: retrieval, MRF and rendering, waited for with
   ``app.run(block=True)``) or the whole lesson (nbclient, full mode unless
   ``--quick``; the kernel is started the way JupyterLab starts one);
3. the time from step 1 to the app's clip (or to the lesson's last cell) is the
   number; JupyterLab's start, the kernel's start and the imports are in it;
4. for a lesson, once the background build has ended, the lesson is run again in a
   fresh kernel: a Run All with the starter databases cached (what a class's second
   session waits for).

Each number is also printed as a ``DOC-NUMBER`` line (full mode): ``run_all.py``
collects them into the table of the numbers the docs state (benchmarks/README.md).

The background build's log says when each database was ready. Timings on a shared
machine drift: the load average is printed with each case.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from _report import doc_number, header, load

ROOT = Path(__file__).resolve().parents[1]
CASES = ("app", "07a", "07b")
NOTEBOOKS = {
    "07a": ROOT / "notebooks" / "07a_videodb_database.ipynb",
    "07b": ROOT / "notebooks" / "07b_videodb_animation.ipynb",
}
GOALS = {"app": 60.0, "07a": 90.0, "07b": 90.0}

# What the app cell of 07a does, then Run, waited for (a script run by a kernel).
APP_CELL = """
import time
from fluidnb import data
from fluidnb.widgets import VideoDBApp
QUICK = {quick}
app_size = 256 if QUICK else 480
app = VideoDBApp("stream", matte=data.region("stream", size=app_size), size=app_size)
clip = app.run(timeout=900, block=True)
assert clip is not None, app.status
print("RESULT", len(clip), "frames;", app.status)
"""


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def lab_answers(base, token):
    try:
        with urllib.request.urlopen(f"{base}/api/status?token={token}", timeout=2) as r:
            return r.status == 200
    except OSError:
        return False


def run_notebook(nb_path, env, quick):
    """Execute a notebook (or the app cell) in a fresh kernel; returns seconds."""
    import nbformat
    from nbclient import NotebookClient

    if nb_path == "app":
        cell = nbformat.v4.new_code_cell(APP_CELL.format(quick=quick))
        nb = nbformat.v4.new_notebook(cells=[cell])
        cwd = ROOT / "notebooks"
    else:
        nb = nbformat.read(nb_path, as_version=4)
        cwd = nb_path.parent
    old = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)  # the kernel inherits this process's environment
    try:
        started = time.perf_counter()
        client = NotebookClient(
            nb, timeout=1800, kernel_name="python3", resources={"metadata": {"path": str(cwd)}}
        )
        client.execute()
        return time.perf_counter() - started, nb
    finally:
        os.environ.clear()
        os.environ.update(old)


def case(name, quick):
    work = Path(tempfile.mkdtemp(prefix=f"first-run-{name}-"))
    cache = work / "cache"
    env = dict(os.environ)
    env.pop("FLUIDNB_PREBUILD", None)
    env.update(FLUIDNB_CACHE_DIR=str(cache), MPLBACKEND="Agg")
    for var in ("CONFIG", "RUNTIME", "DATA"):
        env[f"JUPYTER_{var}_DIR"] = str(work / var.lower())
    env["JUPYTERLAB_SETTINGS_DIR"] = str(work / "settings")
    env["JUPYTERLAB_WORKSPACES_DIR"] = str(work / "workspaces")
    if quick:
        env["FLUIDNB_QUICK"] = "1"
    else:
        env.pop("FLUIDNB_QUICK", None)
    port, token = free_port(), "first-run"
    base = f"http://127.0.0.1:{port}"
    load0 = load()
    log = open(work / "lab.log", "w")  # noqa: SIM115 - closed below
    t0 = time.perf_counter()
    lab = subprocess.Popen(
        [
            sys.executable,
            str(ROOT / "dev.py"),
            "lab",
            "--no-browser",
            "--ip=127.0.0.1",
            f"--port={port}",
            "--ServerApp.port_retries=0",
            f"--IdentityProvider.token={token}",
        ],
        cwd=work,
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    builder = None
    try:
        while not lab_answers(base, token):
            if lab.poll() is not None:
                raise RuntimeError((work / "lab.log").read_text()[-2000:])
            time.sleep(0.1)
        up = time.perf_counter() - t0
        pid_file = cache / "videodb" / "prebuild.pid"
        builder = int(pid_file.read_text()) if pid_file.is_file() else None
        ran, _ = run_notebook(NOTEBOOKS.get(name, "app"), env, quick)
        total = time.perf_counter() - t0
        load1 = load()
        cached = None
        if name in NOTEBOOKS:  # again, every database cached and nothing building
            _wait_for(builder)
            load2 = load()
            cached, _ = run_notebook(NOTEBOOKS[name], env, quick)
            cached_load = (load2, load())
    finally:
        try:
            req = urllib.request.Request(f"{base}/api/shutdown?token={token}", method="POST")
            urllib.request.urlopen(req, timeout=5)
        except OSError:
            pass
        try:
            lab.wait(timeout=30)
        except subprocess.TimeoutExpired:
            lab.send_signal(signal.SIGTERM)
            lab.wait(timeout=30)
        log.close()
    built_log = (cache / "videodb" / "prebuild.log").read_text() if cache.exists() else ""
    if builder is not None and not _wait_for(builder):  # our own background build
        os.kill(builder, signal.SIGTERM)
    shutil.rmtree(work, ignore_errors=True)
    return {
        "case": name,
        "lab_up_s": up,
        "ran_s": ran,
        "total_s": total,
        "load": (load0, load1),
        "cached_s": cached,
        "cached_load": cached_load if cached is not None else None,
        "background": [ln for ln in built_log.splitlines() if "built" in ln or "ready" in ln],
    }


def _wait_for(pid, timeout=300):
    """Wait (at most ``timeout`` s) for process ``pid`` to end; whether it did."""
    deadline = time.monotonic() + timeout
    while pid is not None and _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.5)
    return pid is None or not _alive(pid)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except OSError:
        return False
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", action="append", choices=CASES, help="repeatable; default all")
    parser.add_argument("--quick", action="store_true", help="the quick databases and sizes")
    args = parser.parse_args()
    cases = args.case or list(CASES)
    mode = "quick" if args.quick else "full"
    print(header(__file__, f"{mode} mode; each case from an empty cache"))
    rows = []
    for name in cases:
        r = case(name, args.quick)
        goal = GOALS[name]
        met = "met" if r["total_s"] < goal else "NOT met"
        what = "app's first result" if name == "app" else f"{name}'s first Run All"
        cached = "-" if r["cached_s"] is None else f"{r['cached_s']:.1f} s"
        rows.append(
            f"| {what} | {r['lab_up_s']:.1f} s | {r['ran_s']:.1f} s | **{r['total_s']:.1f} s** "
            f"| < {goal:.0f} s: {met} | {r['load'][0]:.1f} -> {r['load'][1]:.1f} | {cached} |"
        )
        print(f"  {name}: {r['total_s']:.1f} s; background build: {r['background']}", flush=True)
        if not args.quick:  # what the docs state: full mode
            doc_number(f"first_run.{name}", r["total_s"], *r["load"])
            if r["cached_s"] is not None:
                doc_number(f"cached_run.{name}", r["cached_s"], *r["cached_load"])
    print(
        "\n| from `python3 dev.py lab` to | JupyterLab answers | kernel run | total | goal "
        "| load avg | Run All again, databases cached |\n|---|---|---|---|---|---|---|"
    )
    print("\n".join(rows))


if __name__ == "__main__":
    sys.exit(main())
