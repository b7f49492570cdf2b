"""Drawing the frost over the image, and the one-call pipeline."""

import numpy as np
import pytest

from fluidnb import Clip, data
from fluidnb.frost import (
    FrostLook,
    FrostParams,
    HexLattice,
    direction_beta,
    frost,
    grow,
    render,
)


@pytest.fixture(scope="module")
def scene():
    image = data.sample("window", size=96)  # (72, 96, 3)
    h, w = image.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    region = ((yy - 36) / 26) ** 2 + ((xx - 48) / 40) ** 2 <= 1
    return image, region


def frost_amount(clip, region):
    """How far each frame departs from the first inside the region."""
    diff = np.abs(clip.frames - clip.frames[0]).sum(axis=-1)
    return np.array([(d[region] > 0.05).mean() for d in diff])


def test_frames_show_frost_growing_from_the_start_point_inside_the_region(scene):
    image, region = scene
    lat = HexLattice.from_mask(region, 3.0)
    res = grow(lat, [[36, 30]], FrostParams(beta=0.5), seed=0)
    clip = render(image, lat, res, every=5)
    assert isinstance(clip, Clip)
    assert clip.shape == image.shape[:2]
    assert clip.is_color
    assert clip.fps == pytest.approx(24 / 5)
    amount = frost_amount(clip, region)
    assert amount[0] == 0
    assert amount[-1] > 0.8
    assert np.all(np.diff(amount) >= -0.02)  # frost spreads, it does not retreat
    # Nothing changes outside the region; the first frame is the plain image.
    assert np.array_equal(
        clip.frames[:, ~region], np.broadcast_to(image[~region], (len(clip), *image[~region].shape))
    )
    # Frame 0 is the image with only the paper's cell frozen.
    first = np.abs(clip.frames[0] - image).sum(-1) > 1e-6
    rows, cols = np.nonzero(first)
    assert first.any()
    assert np.hypot(rows - 36, cols - 30).max() <= 3.5 * 3.0
    # Early frost sits around the start point.
    early = next(i for i, a in enumerate(amount) if a > 0.02)
    changed = np.abs(clip.frames[early] - image).sum(-1) > 0.05
    rows, cols = np.nonzero(changed)
    assert abs(rows.mean() - 36) < 8
    assert abs(cols.mean() - 30) < 8
    meta = clip.metadata
    assert meta["method"] == "frost"
    assert meta["end_frame"] == res.end_frame
    assert meta["frames"][-1] == res.end_frame
    assert meta["every"] == 5


def test_render_options_and_errors(scene):
    image, region = scene
    lat = HexLattice.from_mask(region, 3.0)
    res = grow(lat, [[36, 48]], FrostParams(beta=0.5), frames=40)
    small = render(image, lat, res, every=10, size=48, look=FrostLook(glint=0, sparkle=0))
    assert small.shape == (36, 48)
    plate = render(None, lat, res, every=40)
    assert plate.n_frames == 2
    with pytest.raises(ValueError, match="image must have the lattice's size"):
        render(image[:10], lat, res)
    with pytest.raises(ValueError, match="result must be a FrostResult"):
        render(image, lat, None)
    other = HexLattice.hexagon(3)
    with pytest.raises(ValueError, match="another lattice"):
        render(image, other, res)
    with pytest.raises(ValueError, match="every must be an integer >= 1"):
        render(image, lat, res, every=0)
    huge = grow(lat, [[36, 48]], FrostParams(beta=0.5), frames=40)
    with pytest.raises(ValueError, match=r"GiB\); draw every \d+th step"):
        render(image, lat, huge, size=4000)
    with pytest.raises(ValueError, match=r"opacity must be in \[0, 1\]"):
        FrostLook(opacity=2)


def test_frost_pipeline_records_what_it_did(scene):
    image, region = scene
    params = FrostParams(beta=0.5, spacing=3.0, target=250)
    clip, res = frost(image, region, [[36, 48]], params, seed=3, every=4, return_result=True)
    meta = clip.metadata
    assert meta["seed"] == 3
    assert meta["params"]["beta"] == 0.5
    assert meta["end_frame"] == res.end_frame
    assert meta["n_cells"] == res.lattice.n_cells
    assert {"lattice", "grow", "render", "total"} <= set(meta["timings"])
    again = frost(image, region, [[36, 48]], params, seed=3, every=4)
    assert np.array_equal(clip.frames, again.frames)
    fitted = frost(image, region, [[36, 48]], params, seed=3, every=4, solver="secant")
    opt = fitted.metadata["optimise"]
    assert opt["converged"]
    assert abs(fitted.metadata["end_frame"] - 250) <= 4
    assert fitted.metadata["params"]["beta"] == opt["beta"]


def test_frost_pipeline_errors_keep_inputs(scene):
    image, region = scene
    region_copy = region.copy()
    with pytest.raises(ValueError, match="region is empty"):
        frost(image, np.zeros_like(region), [[36, 48]])
    with pytest.raises(ValueError, match="outside the region"):
        frost(image, region, [[1, 1]])
    with pytest.raises(ValueError, match="same height and width as the image"):
        frost(image, region[:20], [[10, 10]])
    with pytest.raises(ValueError, match="leaves no lattice point inside"):
        frost(image, region, [[36, 48]], FrostParams(spacing=200, max_frames=1000))
    assert np.array_equal(region, region_copy)


def test_direction_dependent_beta_evens_out_the_arrival_at_the_boundary():
    # A long region with the start point near its left end: uniform beta reaches the near
    # boundary long before the far one; beta(theta) closes most of that gap.
    yy, xx = np.mgrid[0:60, 0:100]
    region = ((yy - 30) / 25) ** 2 + ((xx - 50) / 48) ** 2 <= 1
    lat = HexLattice.from_mask(region, 3.0)
    params = FrostParams(beta=0.4, max_frames=3000)
    res = direction_beta(lat, [[30, 25]], params, n_directions=8, rounds=3, seed=0)
    assert res.spread.min() < 0.5 * res.spread[0]
    assert res.beta.shape == (lat.n_cells,)
    assert 0 <= res.beta.min() <= res.beta.max() <= 1
    # Towards the far (east) end beta is larger than towards the near (west) end.
    east, west = res.sector_beta[0, 0], res.sector_beta[0, 4]
    assert east > west
    assert res.distance[0, 0] > res.distance[0, 4]
    run = grow(lat, [[30, 25]], params, beta=res.beta, seed=0)
    assert run.reached
