"""A paper-sized video database for the benchmark, synthesised from a starter database.

The paper's water database holds ~240,000 fragments from 151 real videos; fluidnb's
starter water database holds ~9,000 from eight generated clips. To time retrieval,
the smoothness tables, the solver and rendering at the paper's scale, this module
writes a store of the same layout (zarr v3 + manifest, opened by ``open_database``)
whose clip groups are copies of the starter database's, each copy perturbed so that
it is not a duplicate:

- copy 0 is the starter database itself, unchanged (its clips keep their indices);
- in every further copy of a clip (its own seeded generator):

  - 15 % of the 81 visual words of every fragment are redrawn from the database's word
    frequencies (so candidate lists are not 27 identical blocks);
  - the motion is turned by one random angle (uniform over the circle) and scaled by
    one random factor (log-uniform in [0.5, 2]) for the whole clip copy: the mean
    motion, the per-frame motion and the DC bin of the spectra (the signed mean motion
    per block) as vectors, the other bins (powers per component) by the factor squared
    with the components mixed by cos^2 / sin^2 of the angle;
  - the textureness is multiplied by a per-fragment factor exp(N(0, 0.1)).

- the frames and the mean images are not copied: each copy's ``frames`` and ``mean``
  folders are symbolic links to the starter clip's, so ``fragment_frames`` (rendering)
  and ``mean_images`` still work (a copy renders its original's pixels).

The last clip is cut so that the total is exactly the requested count. The store is
kept in the cache folder and reused while its recipe, size and base are unchanged.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from pathlib import Path

import numpy as np

#: Bump when the synthesis changes what the store holds (2: format version 2's codecs;
#: 3: format version 3's tables of chunks, sealed manifest and root group's version).
RECIPE = 3
WORD_NOISE = 0.15
SPEED_RANGE = (0.5, 2.0)
TEXTURE_NOISE = 0.1


def _perturb(arrays, gen, word_p):
    """One perturbed copy of a clip's in-memory arrays (see the module docstring)."""
    n = len(arrays["words"])
    words = arrays["words"].copy()
    redraw = gen.random(words.shape) < WORD_NOISE
    words[redraw] = gen.choice(len(word_p), size=int(redraw.sum()), p=word_p).astype(np.uint8)
    theta = gen.uniform(-np.pi, np.pi)
    scale = float(np.exp(gen.uniform(*np.log(SPEED_RANGE))))
    c, s = np.cos(theta), np.sin(theta)
    rot = scale * np.array([[c, -s], [s, c]])

    def turn(v, axis):  # vectors (dy, dx) along ``axis``
        v = np.moveaxis(v.astype(np.float64), axis, -1)
        return np.moveaxis(v @ rot.T, -1, axis)

    spectra = arrays["spectra"].astype(np.float64)
    out = spectra.copy()
    out[:, 0] = turn(spectra[:, 0], 1)
    py, px = spectra[:, 1:, 0], spectra[:, 1:, 1]
    out[:, 1:, 0] = scale**2 * (c * c * py + s * s * px)
    out[:, 1:, 1] = scale**2 * (s * s * py + c * c * px)
    f16 = np.finfo(np.float16).max
    texture = (
        arrays["texture"].astype(np.float64)
        * np.exp(gen.normal(0, TEXTURE_NOISE, n))[:, None, None, None]
    )
    return {
        "words": words,
        "mean_motion": turn(arrays["mean_motion"], 1).astype(np.float32),
        "motion": turn(arrays["motion"], 2).astype(np.float32),
        "spectra": np.clip(out, -f16, f16).astype(np.float16),
        "texture": np.clip(texture, 0, f16).astype(np.float16),
        "source": arrays["source"].copy(),
    }


def _cached(path, base, n_fragments, seed):
    try:
        manifest = json.loads((Path(path) / "manifest.json").read_text())
    except (OSError, ValueError):
        return False
    info = manifest.get("benchmark", {})
    return (
        info.get("recipe") == RECIPE
        and info.get("base") == str(base.path)
        and info.get("base_checksums") == [c["checksum"] for c in base.clips]
        and info.get("seed") == seed
        and manifest.get("fragments") == n_fragments
    )


def synthetic_store(base, path, n_fragments, *, seed=0, log=print):
    """Write (or reuse) a store of ``n_fragments`` made from copies of ``base``'s clips.

    Parameters
    ----------
    base : VideoDatabase
        The database whose clips are copied (the starter water database).
    path : path-like
        Folder of the synthetic store (replaced if it holds another recipe).
    n_fragments : int
        Fragments wanted (the paper's water database: 240,000).
    seed : int
        Seeds the perturbations.
    log : callable
        Called with a line of text now and then.

    Returns
    -------
    seconds : float or None
        Time taken to write it, or None if the cached store was reused.
    """
    import zarr

    # The store's own format, written as a build writes it (the format module's
    # layout, codecs and checksum), so that open_database reads it as any other.
    from fluidnb.videodb.database._format import (
        CHUNK,
        RAM_ARRAYS,
        checksum,
        chunk_table,
        clip_group,
        create_array,
        fragment_layout,
        store_attributes,
        write_manifest,
    )

    path = Path(path)
    if _cached(path, base, n_fragments, seed):
        return None
    started = time.perf_counter()
    if path.exists():
        shutil.rmtree(path)
    path.mkdir(parents=True)
    root = zarr.open_group(str(path), mode="w", zarr_format=3, attributes=store_attributes())
    layout = fragment_layout(base.params)
    counts = np.bincount(base.words.ravel(), minlength=base.params.words).astype(np.float64)
    word_p = counts / counts.sum()
    originals = []
    for clip in base.clips:
        lo, hi = clip["first"], clip["first"] + clip["fragments"]
        originals.append({name: getattr(base, name)[lo:hi] for name in RAM_ARRAYS})
    clips, total, copy, shown = [], 0, 0, 0
    while total < n_fragments:
        for i, clip in enumerate(base.clips):
            count = min(clip["fragments"], n_fragments - total)
            if count <= 0:
                break
            j = len(clips)
            if copy == 0:
                arrays = originals[i]
            else:
                arrays = _perturb(originals[i], np.random.default_rng([seed, copy, i]), word_p)
            arrays = {k: v[:count] for k, v in arrays.items()}
            arrays["source"] = arrays["source"].copy()
            arrays["source"][:, 0] = j
            group = root.require_group(clip_group(j))
            # The linked frames and mean images end in the base's checksums, chunk for chunk.
            tables = {name: clip["chunks"][name] for name in ("frames", "mean")}
            for name in RAM_ARRAYS:
                shape, dtype = layout[name]
                # The database's own codecs (blosc-lz4 + CRC-32C), every chunk written.
                arr = create_array(group, name, (count, *shape), (CHUNK, *shape), dtype)
                arr[...] = arrays[name]
                tables[name] = chunk_table(arr, path)
            for name in ("frames", "mean"):
                target = (base.path / clip_group(i) / name).resolve()
                os.symlink(target, path / clip_group(j) / name, target_is_directory=True)
            name = clip["name"] if copy == 0 else f"{clip['name']}-copy{copy:02d}"
            record = {
                **clip,
                "index": j,
                "name": name,
                "first": total,
                "fragments": count,
                "checksum": checksum(arrays),
                "chunks": tables,
            }
            if copy:
                record["sha256"] = hashlib.sha256(f"{clip['sha256']}/{copy}".encode()).hexdigest()
                record["origin"] = f"synthetic copy {copy} of {clip['name']!r} (benchmark)"
            clips.append(record)
            total += count
        copy += 1
        if total * 10 // n_fragments > shown:  # every tenth of the way
            shown = total * 10 // n_fragments
            log(f"  synthetic store: {total:,}/{n_fragments:,} fragments written")
    manifest = dict(base.manifest)
    manifest.update(
        clips=clips,
        fragments=total,
        benchmark={
            "recipe": RECIPE,
            "base": str(base.path),
            "base_checksums": [c["checksum"] for c in base.clips],
            "seed": seed,
            "note": "synthesised by benchmarks/videodb/synthetic_store.py; frames and mean images "
            "are symbolic links to the base database's",
        },
    )
    write_manifest(path, manifest)
    return time.perf_counter() - started


def disk_usage(path):
    """Bytes under ``path``: its own files, and the folders it links to (as linked, unique).

    Returns
    -------
    own : int
        Files of the store itself (symbolic links not followed).
    through_links : int
        What the linked folders would take if every link were a copy.
    linked : int
        The linked folders themselves, each counted once (the base's frames, means).
    """

    def size(folder):
        return sum(f.stat().st_size for f in Path(folder).rglob("*") if f.is_file())

    own, links = 0, []
    for dirpath, dirnames, filenames in os.walk(path):
        for d in dirnames:
            if os.path.islink(os.path.join(dirpath, d)):
                links.append(os.path.realpath(os.path.join(dirpath, d)))
        for f in filenames:
            own += os.lstat(os.path.join(dirpath, f)).st_size
    sizes = {t: size(t) for t in set(links)}
    return own, sum(sizes[t] for t in links), sum(sizes.values())
