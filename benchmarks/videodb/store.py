"""``bench_videodb.py --part store``: a paper-sized store, its size, its opening, its reads.

A store of the paper's size synthesised from the starter water database
(:mod:`videodb.synthetic_store` says how; cached): its size on disk, the time to open it
(features into RAM, their checksums timed apart), to index it, and to gather 100
fragments' features from RAM against random reads from the zarr store.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from _report import fastest_median, fm, fmt_s, load, now, table

from videodb._common import PAPER_FRAGMENTS, QUICK_FRAGMENTS, cache_folder


def paper_store(ctx):
    """Open (making it first if needed) the synthetic paper-sized store."""
    from fluidnb.videodb import open_database
    from videodb.synthetic_store import synthetic_store

    n = QUICK_FRAGMENTS if ctx.quick else PAPER_FRAGMENTS
    path = cache_folder() / f"bench-synthetic-{n}"
    base = ctx.starter("water")
    made = synthetic_store(base, path, n, seed=0, log=lambda s: print(s, flush=True))
    return path, base, made, open_database


def run(ctx):
    import zarr

    from fluidnb.videodb.assignment import histogram_index

    # The manifest's checksums as open_database computes them: the store's format.
    from fluidnb.videodb.database._format import RAM_ARRAYS, checksum
    from videodb.synthetic_store import disk_usage

    print("\n## A paper-sized store (synthesised from the starter water database)")
    load0 = load()
    path, base, made, open_database = paper_store(ctx)
    n = QUICK_FRAGMENTS if ctx.quick else PAPER_FRAGMENTS
    opens = []
    for _ in range(2 if ctx.quick else 3):
        ctx.paper_db = None
        t0 = now()
        ctx.paper_db = open_database(path)
        opens.append(now() - t0)
    db = ctx.paper_db
    ram = sum(getattr(db, k).nbytes for k in RAM_ARRAYS)
    t0 = now()
    for c in db.clips:  # what open_database spends on checking, of its open time
        lo, hi = c["first"], c["first"] + c["fragments"]
        checksum({k: getattr(db, k)[lo:hi] for k in RAM_ARRAYS})
    checksum_s = now() - t0
    t0 = now()
    index = histogram_index(db)
    index_s = now() - t0
    own, through, linked = disk_usage(path)
    per_fragment = (disk_usage(base.path)[0] - _frames_bytes(base.path)) / base.n_fragments

    # 100 random fragments' features: from RAM (fancy indexing) and from the zarr store.
    gen = np.random.default_rng(0)
    firsts = np.array([c["first"] for c in db.clips])
    ram_s, zarr_s = [], []
    group = zarr.open_group(str(path), mode="r", zarr_format=3)

    def from_ram(ids):
        return [getattr(db, k)[ids] for k in RAM_ARRAYS]

    def from_zarr(ids):
        clip = np.searchsorted(firsts, ids, side="right") - 1
        got = {k: [] for k in RAM_ARRAYS}
        for c in np.unique(clip):
            local = ids[clip == c] - firsts[c]
            for k in RAM_ARRAYS:
                arr = group[f"clips/{int(c):05d}/{k}"]
                got[k].append(arr.get_orthogonal_selection((local,)))
        return got

    for r in range(5 if ctx.quick else 10):
        ids = np.sort(gen.choice(db.n_fragments, 100, replace=False))
        for _ in range(5):
            t0 = now()
            from_ram(ids)
            ram_s.append(now() - t0)
        if r < (3 if ctx.quick else 5):
            t0 = now()
            check = from_zarr(ids)
            zarr_s.append(now() - t0)
            assert np.array_equal(np.concatenate(check["words"]), db.words[ids])
    rec = {
        "fragments": db.n_fragments,
        "clips": len(db.clips),
        "synthesised_s": made,
        "disk_own_bytes": own,
        "disk_linked_bytes": linked,
        "disk_if_copied_bytes": own + through,
        "bytes_per_fragment_real": per_fragment,
        "open_s": opens,
        "checksum_s": checksum_s,
        "ram_bytes": ram,
        "index_s": index_s,
        "index_bytes": index.nbytes,
        "gather_ram_s": fastest_median(ram_s),
        "gather_zarr_s": fastest_median(zarr_s),
        "load": (load0, load()),
    }
    print(
        f"store {path}: {db.n_fragments:,} fragments in {len(db.clips)} clip groups "
        f"({'made in ' + fmt_s(made) if made else 'cached'}); load avg {load0:.1f} -> {load():.1f}"
    )
    table(
        ["quantity", "value"],
        [
            ["fragments / clip groups", f"{db.n_fragments:,} / {len(db.clips)}"],
            [
                "on disk (features written; frames and mean images linked)",
                f"{own / 1e9:.2f} GB (+ {linked / 1e6:.0f} MB linked from the starter database)",
            ],
            [
                "a real store of this size (starter's bytes per fragment incl. mean images, "
                "without frames)",
                f"{per_fragment / 1e3:.1f} kB/fragment -> {per_fragment * n / 1e9:.1f} GB",
            ],
            ["open_database (features into RAM; files in the page cache)", fm(opens)],
            ["of which the per-clip SHA-256 checksums (timed apart)", fmt_s(checksum_s)],
            ["features held in RAM", f"{ram / 1e9:.2f} GB"],
            [
                "HistogramIndex built (first retrieval)",
                f"{fmt_s(index_s)}, {index.nbytes / 1e6:.0f} MB",
            ],
            ["100 random fragments' features gathered from RAM", fm(ram_s)],
            ["the same read at random from the zarr store", fm(zarr_s)],
            ["zarr / RAM (medians)", f"{np.median(zarr_s) / np.median(ram_s):.0f}x"],
        ],
    )
    ctx.results["store"] = rec


def _frames_bytes(path):
    return sum(f.stat().st_size for f in Path(path).glob("clips/*/frames/**/*") if f.is_file())
