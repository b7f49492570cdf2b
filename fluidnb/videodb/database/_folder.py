"""What a database folder holds: a database, an unfinished build, debris, or another's files.

:func:`folder_state` is what :func:`~fluidnb.videodb.build_database`,
:func:`~fluidnb.videodb.add_clips` and ``fluidnb videodb info`` decide by, and
:func:`read_manifest` reads and checks a database's manifest, saying what a folder
without one holds and what to do about it in the same words.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._validation import parse_json
from .._common._params import DatabaseParams
from ._format import (
    BUILD,
    FORMAT,
    MANIFEST,
    READABLE_VERSIONS,
    STATE,
    clip_layout,
    manifest_digest,
)

__all__ = ["folder_state", "pending_addition", "read_manifest", "read_state", "writer_at_work"]


def read_state(root):
    """The state file of an unfinished build or addition in ``root``, or None."""
    try:
        state = parse_json((Path(root) / BUILD / STATE).read_text(encoding="utf-8"), STATE)
    except (OSError, ValueError):  # a damaged state is no state: the folder says what it is
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
        return _root_attributes(root).get("fluidnb") == FORMAT
    except ValueError:
        return False


def _root_attributes(root):
    """The attributes of the store's root group; ValueError naming its ``zarr.json``."""
    file = Path(root) / "zarr.json"
    try:
        meta = parse_json(file.read_text(encoding="utf-8"), repr(str(file)))
        attributes = meta["attributes"]
        if not isinstance(attributes, dict):
            raise TypeError("its attributes are not a JSON object")
    except OSError as exc:
        raise ValueError(f"db: cannot read {str(file)!r}: {exc.strerror or exc}") from None
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"db: {str(file)!r} is damaged ({exc})") from None
    return attributes


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
        text = file.read_text(encoding="utf-8")
    except OSError as exc:  # not "corrupt": another user's file, a disk error
        why = exc.strerror or str(exc)
        if isinstance(exc, PermissionError):
            why += f" (its owner can let others read the database: chmod -R a+rX {str(root)!r})"
        raise ValueError(f"db: cannot read {str(file)!r}: {why}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"db: {str(file)!r} is corrupt: {exc}") from None
    try:
        manifest = parse_json(text, repr(str(file)))
    except ValueError as exc:
        raise ValueError(f"db: {str(file)!r} is corrupt: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ValueError(f"db: {str(file)!r} is not a fluidnb video database manifest")
    version = manifest.get("version")
    if version not in READABLE_VERSIONS or isinstance(version, bool):
        raise ValueError(
            f"db: {str(file)!r} has format version {version!r}; this fluidnb reads versions "
            f"{', '.join(map(str, READABLE_VERSIONS))}: rebuild the database with this version"
        )
    _check_sealed(root, manifest, version)
    try:
        params = DatabaseParams.from_dict(manifest["params"])
        codebook = np.asarray(manifest["codebook"], dtype=np.float64)
        clips = list(manifest["clips"])
        total = int(manifest["fragments"])
        if version >= 3:
            for clip in clips:
                for name in clip_layout(clip, params):
                    bytes.fromhex(clip["chunks"][name])
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f"db: {str(file)!r} is incomplete or damaged ({exc!r})") from None
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


def _check_sealed(root, manifest, version):
    """Refuse a manifest edited after it was written, whatever version it now states.

    Format version 3 seals its manifest with a digest; a digest that does not match --
    in a manifest of any version -- is an edit. Without one, the store itself says
    which version wrote it: version 3's root group records it, and version 2's arrays
    carry checksums (which version 1's do not; :func:`~._format._open_array` checks
    every array as it opens it). A manifest cannot switch off the checks of the
    version that wrote the store.
    """
    file = repr(str(Path(root) / MANIFEST))
    advice = "put back the manifest as it was written, or rebuild the database"
    digest = manifest.get("digest")
    if digest is not None and digest != manifest_digest(manifest):
        raise ValueError(
            f"db: {file} was changed after it was written (its digest does not match its "
            f"content, a checksum of the manifest itself): {advice}"
        )
    if digest is None and version >= 3:
        raise ValueError(f"db: {file} lacks its digest (version 3 seals every manifest): {advice}")
    written = _root_attributes(root).get("version")  # None before version 3
    if written != version and (written is not None or version >= 3):
        raise ValueError(
            f"db: {file} says format version {version}, but the store was written as "
            f"version {'1 or 2' if written is None else repr(written)}: the manifest was "
            f"edited or belongs to another store; {advice}"
        )


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
