#!/usr/bin/env python3
"""Set up fluidnb in a virtual environment in this folder, then do one job.

    python3 dev.py lab     # set up, then open JupyterLab on notebooks/
    python3 dev.py test    # set up (with test tools and Chromium), then run every test

Only Python >= 3.10 and the package registries are needed. Both commands are
idempotent: a re-run skips the install unless pyproject.toml changed.

``lab`` also starts building the video-database lessons' starter databases in a
background process (water, smoke, fire; 11-63 s each on two cores, quiet or with
other work up to a load of 5, longer on a busier machine:
benchmarks/README.md#numbers-the-docs-state; cached; a log in the cache folder), so
that they are ready, or nearly, when a lesson asks for them; ``FLUIDNB_PREBUILD=0``
turns that off.
Arguments after the job go to JupyterLab (lab) or pytest (test), e.g.
``python3 dev.py lab --no-browser --port 8899`` or ``python3 dev.py test -k clip``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / ("python.exe" if os.name == "nt" else "python")
CHROMIUM_CANDIDATES = [
    "/usr/bin/chromium",
    "/usr/lib/chromium/chromium",
    "/usr/bin/chromium-browser",
]


def say(msg):
    print(f"[dev.py] {msg}", flush=True)


def run(cmd, **kw):
    say(" ".join(str(c) for c in cmd))
    return subprocess.run([str(c) for c in cmd], check=False, **kw).returncode


def must(cmd, **kw):
    code = run(cmd, **kw)
    if code:
        sys.exit(f"[dev.py] failed ({code}): {' '.join(str(c) for c in cmd)}")


def setup(extras):
    """Create .venv and install the package (editable) with the given extras."""
    if sys.version_info < (3, 10):  # noqa: UP036 - dev.py may be run by an older python3
        sys.exit(f"[dev.py] fluidnb needs Python >= 3.10, this is {sys.version.split()[0]}")
    if not PY.exists():
        say(f"creating virtual environment {VENV}")
        venv.EnvBuilder(with_pip=True, clear=False).create(VENV)
    spec = f".[{extras}]" if extras else "."
    stamp, digest = _stamp(extras)
    # The test environment is a superset of the lab's: either satisfies `lab`.
    candidates = [(stamp, digest)] + ([_stamp("test")] if not extras else [])
    if any(s.exists() and s.read_text() == d for s, d in candidates):
        say(f"environment up to date ({spec})")
        install_jupyter_config()
        return
    must([PY, "-m", "pip", "install", "--upgrade", "--quiet", "pip"])
    must([PY, "-m", "pip", "install", "--quiet", "-e", spec], cwd=ROOT)
    install_jupyter_config()
    stamp.write_text(digest)
    say(f"installed fluidnb {spec} into {VENV}")


def install_jupyter_config():
    """Put jupyter-config/ into .venv/etc/jupyter, where a wheel's data-files go.

    pip's editable install leaves pyproject.toml's data-files out; this one enables
    the server extension with which /voila/render/ pages typeset math offline.
    """
    for source in (ROOT / "jupyter-config").rglob("*.json"):
        target = VENV / "etc" / "jupyter" / source.relative_to(ROOT / "jupyter-config")
        if not target.is_file() or target.read_bytes() != source.read_bytes():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
            say(f"installed {target.relative_to(ROOT)}")


def _stamp(extras):
    spec = f".[{extras}]" if extras else "."
    digest = hashlib.sha256((ROOT / "pyproject.toml").read_bytes() + spec.encode()).hexdigest()
    return VENV / f".fluidnb-installed-{extras or 'base'}", digest


def chromium():
    """Path of a Chromium for the browser tests; installs Debian's when it can."""
    wanted = os.environ.get("FLUIDNB_CHROMIUM")
    if wanted:
        if not Path(wanted).exists():
            sys.exit(f"[dev.py] FLUIDNB_CHROMIUM={wanted} does not exist")
        return wanted
    found = next((p for p in CHROMIUM_CANDIDATES if Path(p).exists()), None)
    if found:
        return found
    is_root = hasattr(os, "geteuid") and os.geteuid() == 0
    if is_root and shutil.which("apt-get"):
        say("installing Debian's chromium for the browser tests (about 30 s)")
        env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
        must(["apt-get", "update", "-qq"], env=env)
        must(["apt-get", "install", "-y", "-qq", "--no-install-recommends", "chromium"], env=env)
        found = next((p for p in CHROMIUM_CANDIDATES if Path(p).exists()), None)
        if found:
            return found
    sys.exit(
        "[dev.py] The browser tests need Chromium and none was found.\n"
        "  On Debian/Ubuntu: sudo apt-get install chromium\n"
        "  Or point FLUIDNB_CHROMIUM at a Chromium/Chrome binary.\n"
        "  (Browser tests are part of the suite and are never skipped.)"
    )


def cache_dir():
    """fluidnb's cache folder (as ``fluidnb._cache.cache_dir``, which dev.py cannot import)."""
    env = os.environ.get("FLUIDNB_CACHE_DIR")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "fluidnb"


def _running(pid):
    if os.name == "nt":
        return False  # not checked there: a second builder only waits on the first's locks
    try:
        os.kill(pid, 0)
    except (OSError, ValueError):
        return False
    return True


def prebuild():
    """Start building the starter video databases in a detached background process.

    The first run of the video-database lessons would otherwise spend minutes in
    their first cell. ``python -m fluidnb.videodb`` builds the ones missing from the
    cache (water first), each under the cache's lock: a notebook that asks for one
    meanwhile waits for it and then opens it. It outlives this command (JupyterLab
    replaces it), writes its log to ``<cache>/videodb/prebuild.log`` and its pid to
    ``prebuild.pid``. Returns the process, or None when it is off or already running.
    """
    if os.environ.get("FLUIDNB_PREBUILD", "1").strip().lower() in ("0", "no", "false", "off"):
        return None
    folder = cache_dir() / "videodb"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        pid_file = folder / "prebuild.pid"
        if pid_file.is_file() and _running(int(pid_file.read_text().strip() or 0)):
            say("the starter video databases are being built already (see prebuild.log)")
            return None
        log = open(folder / "prebuild.log", "ab")  # noqa: SIM115 - the child keeps it
    except (OSError, ValueError) as exc:  # an unwritable cache: the lessons build them
        say(f"not building the starter video databases in the background: {exc}")
        return None
    if os.name == "nt":
        flags = subprocess.DETACHED_PROCESS | subprocess.CREATE_NEW_PROCESS_GROUP
        detach = {"creationflags": flags}
    else:
        detach = {"start_new_session": True}
    with log:
        proc = subprocess.Popen(
            [str(PY), "-m", "fluidnb.videodb"],
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
            **detach,
        )
    pid_file.write_text(str(proc.pid))
    say(f"building the starter video databases in the background (pid {proc.pid}, log {log.name})")
    return proc


def lab(args):
    setup("")
    prebuild()
    cmd = [BIN / "jupyter", "lab", "--notebook-dir", ROOT / "notebooks"]
    if hasattr(os, "geteuid") and os.geteuid() == 0 and "--allow-root" not in args:
        cmd.append("--allow-root")
    cmd += args
    say(" ".join(str(c) for c in cmd))
    os.execv(str(cmd[0]), [str(c) for c in cmd])


def test(args):
    setup("test")
    env = dict(os.environ, FLUIDNB_CHROMIUM=chromium())
    must([BIN / "ruff", "check", "."], cwd=ROOT)
    must([BIN / "ruff", "format", "--check", "."], cwd=ROOT)
    # The 25 slowest tests close the log: where a CI run's 30 minutes go, seen each run.
    code = run([PY, "-m", "pytest", "--durations=25", *args], cwd=ROOT, env=env)
    if code == 5:
        sys.exit("[dev.py] pytest collected no tests: that is a failure, not a pass")
    if code:
        sys.exit(f"[dev.py] tests failed (pytest exit status {code})")
    say("all checks passed")


def main(argv):
    jobs = {"lab": lab, "test": test, "setup": lambda a: setup("test")}
    if not argv or argv[0] not in jobs:
        sys.exit(__doc__)
    jobs[argv[0]](argv[1:])


if __name__ == "__main__":
    main(sys.argv[1:])
