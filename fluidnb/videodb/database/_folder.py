"""What a database folder holds: a database, an unfinished build, debris, or another's files.

:func:`folder_state` is what :func:`~fluidnb.videodb.build_database`,
:func:`~fluidnb.videodb.add_clips` and ``fluidnb videodb info`` decide by, and
:func:`read_manifest` reads and checks a database's manifest, saying what a folder
without one holds and what to do about it in the same words.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._common._params import DatabaseParams
from ._format import BUILD, FORMAT, MANIFEST, READABLE_VERSIONS, STATE

__all__ = ["folder_state", "pending_addition", "read_manifest", "read_state", "writer_at_work"]


def read_state(root):
    """The state file of an unfinished build or addition in ``root``, or None."""
    try:
        state = json.loads((Path(root) / BUILD / STATE).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return state if isinstance(state, dict) else None


def pending_addition(root, manifest):
    """The state of an unfinished addition of clips to the database, or None.

    A state left by a build or an addition that did finish (the process stopped
    between writing the manifest and removing ``build/``) is not pending.
    """
    state = read_state(root)
    if state and state.get("mode") == "add" and state.get("base") == len(manifest["clips"]):
        return state
    return None


def folder_state(root):
    """What a folder holds, as :func:`build_database`, :func:`add_clips` and ``info`` see it.

    Returns one of ``"missing"`` (no such folder), ``"file"``, ``"empty"`` (nothing, or
    only lock files), ``"database"`` (a manifest), ``"unfinished"`` (a build's state
    file: resume it), ``"debris"`` (only what a build makes, but no state: a build that
    stopped or was rolled back before it recorded its state; a new build clears it) and
    ``"foreign"`` (anything else: not ours to touch).
    """
    from ._lock import LOCK_FILE, lock_files

    root = Path(root)
    if not root.exists():
        return "missing"
    if not root.is_dir():
        return "file"
    if (root / MANIFEST).is_file():
        return "database"
    state = read_state(root)
    if state is not None and state.get("mode") == "build":
        return "unfinished"
    names = {p.name for p in root.iterdir()}
    names -= set(lock_files())
    names = {n for n in names if not n.startswith((f".{LOCK_FILE}", f".{MANIFEST}."))}
    if not names:
        return "empty"
    if names <= {"zarr.json", "clips", BUILD} and _our_zarr(root):
        return "debris"
    return "foreign"


def _our_zarr(root):
    try:
        meta = json.loads((Path(root) / "zarr.json").read_text(encoding="utf-8"))
        return meta["attributes"]["fluidnb"] == FORMAT
    except (OSError, ValueError, KeyError, TypeError):
        return False


def writer_at_work(root):
    """The lock holder's description if a live process is writing ``root``, else None."""
    from ._lock import LOCK_FILE, describe, holder

    info = holder(Path(root) / LOCK_FILE)
    return None if info is None else describe(info)


def read_manifest(path):
    """Read and check a database's manifest; ValueError naming the file if it is wrong.

    The message for a folder without a manifest says what it holds and what to do, in
    the same words :func:`~fluidnb.videodb.build_database` uses.
    """
    root = Path(path)
    file = root / MANIFEST
    if not root.is_dir():
        raise ValueError(f"db: no such database folder {str(root)!r}")
    if not file.is_file():
        raise ValueError(_not_a_database(root))
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"db: {str(file)!r} is corrupt: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ValueError(f"db: {str(file)!r} is not a fluidnb video database manifest")
    version = manifest.get("version")
    if version not in READABLE_VERSIONS:
        raise ValueError(
            f"db: {str(file)!r} has format version {version!r}; this fluidnb reads versions "
            f"{', '.join(map(str, READABLE_VERSIONS))}: rebuild the database with this version"
        )
    try:
        params = DatabaseParams.from_dict(manifest["params"])
        codebook = np.asarray(manifest["codebook"], dtype=np.float64)
        clips = list(manifest["clips"])
        total = int(manifest["fragments"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"db: {str(file)!r} is incomplete or damaged ({exc})") from None
    if codebook.shape != (params.words, 128) or not np.all(np.isfinite(codebook)):
        raise ValueError(
            f"db: {str(file)!r}: the codebook must be {params.words} x 128 finite numbers, "
            f"got shape {codebook.shape}"
        )
    first = 0
    for i, clip in enumerate(clips):
        if clip.get("index") != i or clip.get("first") != first:
            raise ValueError(f"db: {str(file)!r}: clip {i} is out of order or its range is wrong")
        first += int(clip["fragments"])
    if first != total:
        raise ValueError(
            f"db: {str(file)!r}: the clips hold {first} fragments but the manifest says {total}"
        )
    return manifest, params, codebook


def _not_a_database(root):
    where = repr(str(root))
    state = folder_state(root)
    writer = writer_at_work(root)
    if writer is not None and state in ("unfinished", "debris", "empty"):
        return f"db: {where} is being built right now by {writer}: wait for it to finish"
    if state == "unfinished":
        return (
            f"db: {where} holds an unfinished build (no {MANIFEST}): continue it with "
            "`fluidnb videodb build --resume` and the same clips (build_database(..., "
            "resume=True)), or delete the folder"
        )
    what = {
        "empty": "it is empty; build one into it",
        "debris": "it holds the remains of a build that stopped before recording its "
        "state; building into it again starts afresh",
    }.get(state)
    return f"db: {where} is not a fluidnb video database (no {MANIFEST})" + (
        f": {what}" if what else ""
    )
