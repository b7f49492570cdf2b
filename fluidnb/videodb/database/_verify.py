"""Every chunk of a database read and checked: what ``fluidnb videodb info --verify`` reports.

Opening a database checks its in-memory arrays; :func:`verify_database` also reads the
frames and mean images, which are otherwise read on demand, and lists every missing
or damaged chunk instead of stopping at the first.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..._progress import Progress
from ._folder import read_manifest
from ._format import (
    RAM_ARRAYS,
    ChunkTables,
    _chunk_error,
    _chunk_file,
    _open_array,
    _reason,
    _tail,
    checksum,
    clip_group,
    clip_layout,
)

__all__ = ["verify_database"]


def verify_database(path, *, progress=None):
    """Read every chunk of a database and list what is wrong (``info --verify``).

    Checks the manifest, then for every clip every array (the frames, the mean images
    and the in-memory arrays): that it exists with the shape the manifest gives, that
    every chunk exists (format version 2 on), decodes (its checksum matches) and is the
    chunk written in its place (format version 3 on: the manifest's table of the
    checksums), and that the in-memory arrays match the manifest's SHA-256 of them.

    Parameters
    ----------
    path : str or os.PathLike
        The database folder.
    progress : callable, optional
        ``progress(fraction, message)``.

    Returns
    -------
    list of str
        One line per problem found; empty if the database is intact.

    Raises
    ------
    ValueError
        If the folder is not a database or its manifest is damaged (nothing to verify
        against).
    """
    import zarr

    root = Path(path)
    manifest, params, _ = read_manifest(root)
    version = manifest["version"]
    tables = ChunkTables(manifest["clips"]) if version >= 3 else None
    report = Progress(progress)
    try:
        group = zarr.open_group(str(root), mode="r", zarr_format=3)
    except Exception as exc:
        return [f"db: {str(root)!r}: cannot open the zarr store ({exc})"]
    problems = []
    clips = manifest["clips"]
    for k, clip in enumerate(clips):
        where = clip_group(int(clip["index"]))
        arrays, intact = {}, True
        for name, (shape, dtype) in clip_layout(clip, params).items():
            report(k / max(1, len(clips)), f"verifying {clip['name']} ({name})")
            try:
                arr = _open_array(group, root, f"{where}/{name}", shape, dtype, version)
            except ValueError as exc:
                problems.append(str(exc))
                intact = False
                continue
            found, rows = _verify_chunks(arr, root, version >= 2, tables)
            problems += found
            intact = intact and not found
            if name in RAM_ARRAYS:
                arrays[name] = rows
        # The manifest's SHA-256 of the in-memory arrays: for version 1 the only check
        # of a chunk that is missing (read as zeros), for version 2 one more.
        if intact and checksum(arrays) != clip.get("checksum"):
            problems.append(
                f"db: {str(root / where)!r}: the arrays do not match the manifest's "
                "checksum (a file was changed or damaged); rebuild the database"
            )
    report(1.0, f"verified {len(clips)} clips: {len(problems)} problems")
    return problems


def _verify_chunks(arr, root, checked, tables):
    """Problems of every chunk of ``arr``, and its rows (None if one could not be read)."""
    step, problems, parts = arr.chunks[0], [], []
    for i in range(-(-arr.shape[0] // step)):
        file = _chunk_file(arr, root, i)
        if checked and not file.is_file():
            problems.append(_chunk_error(arr, root, i, "is missing"))
            continue
        try:
            parts.append(arr[i * step : (i + 1) * step])
        except Exception as exc:
            problems.append(_chunk_error(arr, root, i, f"cannot be read: {_reason(exc)}"))
            continue
        wrong = tables.check(arr, root, i, _tail(file)) if tables is not None else None
        if wrong is not None:
            problems.append(_chunk_error(arr, root, i, wrong))
    if problems:
        return problems, None
    return problems, np.concatenate(parts) if parts else arr[...]
