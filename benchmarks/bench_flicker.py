"""Flicker against the paper's figure and one 3-D inverse FFT, measured in one run.

    python benchmarks/bench_flicker.py [--repeat N]

The paper's experiment: a 512 x 512 photo, T = 64 frames, 1.5-2 s from input to the
first frame (Core i7-2600K). Cases, all 512 x 512 RGB with the paper's parameters (convex
mapping + 1/f^2 noise, f0 = 4, T = 64) unless said:

* whole clip: ``flicker(...)``, every frame shaded and relit (a 64 x 512 x 512 x 3 clip);
* first frame: build a :class:`FlickerModel` and make frame 0 alone;
* the peer: one complex 3-D inverse FFT of the same size, (64, 512, 512) complex64 with
  ``scipy.fft.ifftn(workers=-1)`` — the paper's Eq. (5) done literally, without the
  shading the method still needs afterwards;
* preview: a 128 x 128 model (``FlickerModel.reduced``) and its first frame, and a whole
  128 x 128 loop per frame — what the app does while a slider moves.

Ratios: peer / ours (> 1: we are faster) and paper / ours.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy
import scipy.fft
from _report import header, loads, machine

from fluidnb import data
from fluidnb.flicker import FlickerModel, FlickerParams, flicker, preview

PAPER_FIRST_FRAME = (1.5, 2.0)  # seconds, Sec. 4.2


def measure(cases, repeat):
    """Best and median seconds per case, the cases run round-robin.

    Round-robin rather than one case after another: on a shared machine the load
    changes from second to second, and interleaving lets every case see the same
    conditions, so the ratios measured in one run stay meaningful.
    """
    for fn in cases.values():
        fn()  # warm caches, FFT plans, thread pools
    times = {name: [] for name in cases}
    for _ in range(repeat):
        for name, fn in cases.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: (min(ts), float(np.median(ts))) for name, ts in times.items()}


def fmt(seconds):
    return f"{seconds * 1e3:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    print(header(__file__))

    photo = data.sample("stream", size=(512, 512))
    params = FlickerParams()  # T = 64, f0 = 4, convex, beta = 2
    plane = params.replace(mapping="plane", beta=0.0)
    spectrum = np.random.default_rng(0).standard_normal((64, 512, 512, 2), dtype=np.float32)
    spectrum = spectrum.view(np.complex64)[..., 0]

    model = FlickerModel(photo, params=params, seed=0)
    frames = iter(range(10**9))
    small = data.sample("stream", size=(128, 128))
    cases = {
        "peer: scipy.fft.ifftn (64, 512, 512) complex64": lambda: scipy.fft.ifftn(
            spectrum, workers=-1
        ),
        "whole clip, convex + noise (the paper's method)": lambda: flicker(
            photo, params=params, seed=0
        ),
        "whole clip, convex, no noise": lambda: flicker(
            photo, params=params.replace(beta=0.0), seed=0
        ),
        "whole clip, plane (Eq. (1))": lambda: flicker(photo, params=plane, seed=0),
        "first frame, convex + noise (model + frame 0)": lambda: FlickerModel(
            photo, params=params, seed=0
        ).frame(0),
        "first frame, convex, no noise": lambda: FlickerModel(
            photo, params=params.replace(beta=0.0), seed=0
        ).frame(0),
        "next frame (model built: lazy playback)": lambda: model.frame(next(frames) % 64),
        "preview 128x128: model + first frame": lambda: FlickerModel(
            small, params=params, seed=0, pixel_size=4
        ).frame(0),
        "preview 128x128: whole loop (64 frames)": lambda: preview(
            photo, params=params, size=128, seed=0
        ),
    }
    results = measure(cases, args.repeat)
    for name, (b, m) in results.items():
        print(f"{name:<50} best {fmt(b):>9}   median {fmt(m):>9}")
    names = list(cases)
    peer = results[names[0]][0]
    whole = results[names[1]][0]
    first = results[names[4]][0]
    pfirst = results[names[7]][0]
    ploop = results[names[8]][0]

    print()
    print(f"whole clip / one 3-D inverse FFT: {whole / peer:.2f}x the FFT's time (goal <= 2)")
    print(f"peer / ours (whole clip): {peer / whole:.2f}x")
    lo, hi = PAPER_FIRST_FRAME
    print(f"paper first frame {lo}-{hi} s / ours {fmt(first)}: {lo / first:.0f}-{hi / first:.0f}x")
    print(f"paper first frame / our whole clip: {lo / whole:.1f}-{hi / whole:.1f}x")
    print(
        f"preview: first frame {fmt(pfirst)}, "
        f"per frame of a whole loop {fmt(ploop / 64)} (goal < 50 ms)"
    )
    print()
    print(
        f"machine: {machine()}, numpy {np.__version__}, scipy {scipy.__version__}; "
        f"load average {', '.join(f'{x:.1f}' for x in loads())}"
    )


if __name__ == "__main__":
    main()
