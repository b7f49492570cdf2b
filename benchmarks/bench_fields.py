"""Shared field operations against real peers, measured side by side in one run.

    python benchmarks/bench_fields.py

Prints, per case, our time and the peer's, and their ratio (peer / ours: > 1 means
we are faster). Peers: scikit-image's ``transform.warp`` (bilinear backward warp) and
scipy's ``ndimage.map_coordinates`` called per channel, for the same warp; scikit-image's
``pyramid_laplacian`` for a pyramid of the same depth (it is not invertible, ours is).
"""

from __future__ import annotations

import numpy as np
from _report import best, header  # benchmarks/ is on sys.path when run as a script
from scipy import ndimage
from skimage import transform

from fluidnb import fields


def warp_cases():
    rng = np.random.default_rng(0)
    for h, w, c in [(128, 128, 2), (128, 192, 2), (512, 512, 3)]:
        field = rng.random((h, w, c), dtype=np.float32)
        velocity = rng.normal(0, 2, (h, w, 2)).astype(np.float32)
        rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
        coords = np.stack([rows - velocity[..., 0], cols - velocity[..., 1]])

        def ours(field=field, velocity=velocity):
            return fields.advect(field, velocity)

        def skimage_warp(field=field, coords=coords, c=c):
            # warp takes (2, H, W) coordinates for one channel at a time.
            return np.stack(
                [
                    transform.warp(field[..., k], coords, order=1, mode="edge", preserve_range=True)
                    for k in range(c)
                ],
                axis=-1,
            )

        def scipy_per_channel(field=field, coords=coords, c=c):
            return np.stack(
                [
                    ndimage.map_coordinates(field[..., k], coords, order=1, mode="nearest")
                    for k in range(c)
                ],
                axis=-1,
            )

        assert np.allclose(ours(), scipy_per_channel(), atol=1e-5)
        yield (
            f"advect {h}x{w}x{c}",
            best(ours),
            {
                "skimage.warp": best(skimage_warp),
                "scipy map_coordinates": best(scipy_per_channel),
            },
        )


def pyramid_cases():
    image = np.random.default_rng(1).random((512, 512, 3), dtype=np.float32)

    def ours():
        return fields.laplacian_pyramid(image, levels=5)

    def skimage_pyr():
        return list(transform.pyramid_laplacian(image, max_layer=4, channel_axis=-1))

    yield (
        "laplacian pyramid 512x512x3, 5 levels",
        best(ours, 3),
        {"skimage.pyramid_laplacian": best(skimage_pyr, 3)},
    )


def main():
    print(header(__file__))
    print(f"{'case':<40} {'ours':>9} {'peer':<28} {'peer':>9} {'ratio':>7}")
    for name, ours, peers in [*warp_cases(), *pyramid_cases()]:
        for peer, t in peers.items():
            print(f"{name:<40} {ours * 1e3:7.2f}ms {peer:<28} {t * 1e3:7.2f}ms {t / ours:6.2f}x")


if __name__ == "__main__":
    main()
