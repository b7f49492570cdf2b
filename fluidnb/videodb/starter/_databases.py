"""Starter databases: one per kind of scene, made by the project itself, cached.

No real fluid footage ships with any package registry, so fluidnb makes its own
(:func:`~fluidnb.videodb.starter.starter_clips`): smoke from its fluid solver, fire from its
fire method, water by advecting water textures along varied flows. The first call of
:func:`starter_database` builds the database from those clips (11-63 s each on two
cores, quiet or with other work up to a load of 5, longer on a busier machine:
benchmarks/README.md#numbers-the-docs-state; seconds in quick mode) and keeps it in the cache folder
(``$FLUIDNB_CACHE_DIR``, else ``~/.cache/fluidnb``); later calls open it.

So that a lesson's first run does not wait for all of that, ``python3 dev.py lab``
starts :func:`prebuild_starters` in a background process while JupyterLab opens
(water first: the lessons' and the app's first need), and Binder builds them when it
builds its image (``binder/postBuild``). A notebook asking for a database the
background process is building waits for it (the cache's lock), then opens it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import threading
from pathlib import Path

from ..._cache import cache_dir
from ..._progress import Progress
from ..._validation import check_choice
from .._common._params import DatabaseParams
from ..database._build import _build
from ..database._folder import folder_state
from ..database._lock import locked
from ..database._store import built_database, open_database
from ._clips import STARTER_KINDS

__all__ = ["prebuild_starters", "starter_database", "starter_params", "starter_path"]


# Bump when the clips or the build change what a starter database holds.
# 4: format version 2 (chunk checksums); 5: water clips whose motion changes in time;
# 6: the water clips' flows made in float32, their random fields blurred by an untruncated
# Gaussian (the same flows to < 0.01 px/frame, the clips' frames a little different);
# 7 (fire only): the fire method's faster keyframe scan (exact 8-bit distances,
# counter-based random candidates) synthesises other, equally valid, fire clips;
# 7 (water, smoke) and 8 (fire): format version 3 (each chunk's checksum by place in the
# manifest, sealed by its digest; the root group's version): the same arrays, other
# manifests and root groups.
_VERSIONS = {"water": 7, "smoke": 7, "fire": 8}


def _quick(quick):
    if quick is None:
        return os.environ.get("FLUIDNB_QUICK", "") not in ("", "0")
    return bool(quick)


def starter_params():
    """The :class:`DatabaseParams` the starter databases are built with.

    The paper's settings (all 18 versions of each clip, k = 200 words, N = 32), the
    codebook fitted on a sample of 100,000 descriptors. The quick databases differ
    by their clips only (two small ones: ~145 fragments, a few seconds to build).
    """
    # The codebook is fitted on 100k descriptors (of ~700k): BisectingKMeans takes
    # ~7 s on them here, ~50 s on all, for words that hardly change.
    return DatabaseParams(codebook_samples=100_000)


def starter_path(kind, *, quick=None):
    """Where the starter database of ``kind`` lives in the cache."""
    check_choice("kind", kind, STARTER_KINDS)
    suffix = "-quick" if _quick(quick) else ""
    return cache_dir() / "videodb" / f"{kind}-v{_VERSIONS[kind]}{suffix}"


def starter_database(kind="water", *, quick=None, rebuild=False, progress=None):
    """The starter database of a kind of scene, built on first use and cached.

    Parameters
    ----------
    kind : {"water", "smoke", "fire"}
        The scene.
    quick : bool, optional
        A small database (fewer, smaller clips; seconds to build) for tests and quick
        notebook runs. Default: ``True`` when the environment variable
        ``FLUIDNB_QUICK`` is set (as CI sets it).
    rebuild : bool
        Build again even if the cache holds one.
    progress : callable, optional
        ``progress(fraction, message)`` while building.

    Returns
    -------
    VideoDatabase
    """
    quick = _quick(quick)
    path = starter_path(kind, quick=quick)
    report = Progress(progress)
    if not rebuild:
        with contextlib.suppress(ValueError):
            db = open_database(path)
            report(1.0, f"starter {kind} database (cached)")
            return db
    with contextlib.ExitStack() as stack:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            # Two notebooks asking for the same starter database: the second waits for
            # the first to build it, then opens it.
            stack.enter_context(
                locked(
                    path.parent / f"{path.name}.lock",
                    "building it",
                    wait=True,
                    on_wait=lambda who: report(0.0, f"starter {kind} database: waiting for {who}"),
                )
            )
        except OSError:
            # An unwritable cache only costs time: build in a temporary folder instead.
            path = Path(tempfile.mkdtemp(prefix=f"fluidnb-{kind}-")) / "db"
        if not rebuild:  # another process may have built it while we waited
            with contextlib.suppress(ValueError):
                db = open_database(path)
                report(1.0, f"starter {kind} database (built by another process)")
                return db
        arrays = _build_starter(kind, quick, path, report)
    return open_database(path) if arrays is None else built_database(path, arrays)


def prebuild_starters(kinds=STARTER_KINDS, *, quick=None, progress=None):
    """Build the starter databases missing from the cache, one after the other.

    What ``python3 dev.py lab`` runs in a background process while JupyterLab starts
    (``python -m fluidnb.videodb``): each kind is built, in the order given (water
    first: what the lessons and the app ask for first), under the cache's lock, so a
    notebook asking for it meanwhile waits and then opens it; a database already
    cached is not opened, and one another process is building is waited for.

    Parameters
    ----------
    kinds : sequence of str
        The kinds, in the order to build them.
    quick : bool, optional
        The quick databases (default: as ``FLUIDNB_QUICK`` says).
    progress : callable, optional
        ``progress(fraction, message)`` over all of them.

    Returns
    -------
    list of str
        The kinds this call built (not those found in the cache).
    """
    kinds = [check_choice("kinds", kind, STARTER_KINDS) for kind in kinds]
    parts = Progress(progress).split(*(i / len(kinds) for i in range(1, len(kinds))))
    built = []
    for kind, part in zip(kinds, parts):
        path = starter_path(kind, quick=quick)
        if folder_state(path) == "database":
            part(1.0, f"starter {kind} database (cached)")
            continue
        starter_database(kind, quick=quick, progress=part)
        built.append(kind)
    return built


def _build_starter(kind, quick, path, report):
    """Build into ``<path>.partial`` (resuming what a killed process left), then move it.

    The clips are made on threads of their own while the build cuts each into
    fragments as soon as it is made (their futures are the build's sources). Returns
    the clips' in-memory arrays, for :func:`built_database` (None if a process before
    had built it all and only the move was left).
    """
    from concurrent.futures import ThreadPoolExecutor

    from ._clips import submit_clips

    partial = path.parent / f"{path.name}.partial"
    arrays = None
    if folder_state(partial) != "database":  # else: built, then killed before the move
        if folder_state(partial) in ("file", "foreign"):
            _remove(partial)
        progress = _Blend(report, 0.3)
        with ThreadPoolExecutor(os.cpu_count() or 1, thread_name_prefix="fluidnb-clips") as pool:
            futures = submit_clips(pool, kind, quick=quick, seed=0, progress=progress.first)
            try:

                def run(resume):
                    # Not build_database: it would open the database in .partial; it
                    # is made of the arrays in memory once moved.
                    return _build(
                        [future.result for future in futures],
                        partial,
                        kind=kind,
                        params=starter_params(),
                        seed=0,
                        client=None,
                        workers=None,
                        resume=resume,
                        progress=progress.second,
                    )

                try:
                    _, arrays = run(resume=True)  # an unfinished build of these clips, or new
                except ValueError:
                    if folder_state(partial) != "unfinished":
                        raise
                    _remove(partial)  # an unfinished build of other clips: start afresh
                    _, arrays = run(resume=False)
            except BaseException:
                for future in futures:
                    future.cancel()
                raise
    if path.exists():
        _remove(path)
    os.replace(partial, path)
    return arrays


class _Blend:
    """One progress bar for two jobs running at once: ``w`` of the first, the rest the second."""

    def __init__(self, report, weight):
        self.report, self.weight = report, weight
        self.fractions = [0.0, 0.0]
        self.lock = threading.Lock()

    def _part(self, i, fraction, message):
        with self.lock:
            self.fractions[i] = max(self.fractions[i], min(max(float(fraction), 0.0), 1.0))
            a, b = self.fractions
            self.report(self.weight * a + (1.0 - self.weight) * b, message)

    def first(self, fraction, message=""):
        self._part(0, fraction, message)

    def second(self, fraction, message=""):
        self._part(1, fraction, message)


def _remove(path):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()
