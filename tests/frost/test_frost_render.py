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
    ice_mass,
    render,
    render_ice,
)
from fluidnb.frost._render import _ordinal


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
    small = render(image, lat, res, every=10, size=48, look=FrostLook(specular=0, sparkle=0))
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
    with pytest.raises(ValueError, match=r"GiB\); draw every \d+(st|nd|rd|th) step"):
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


# ----------------------------------------------------------------------------- the ice look


def luminance(rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722], np.float32)


@pytest.fixture(scope="module")
def grown(scene):
    image, region = scene
    lat = HexLattice.from_mask(region, 3.0)
    res = grow(lat, [[36, 30]], FrostParams(beta=0.5, gamma=0.03, rth=0.4), seed=0)
    return image, region, lat, res


def interior(region, lat, spacings=3):
    """Region pixels at least a few spacings from its border (no soft edge there)."""
    from scipy import ndimage

    return ndimage.distance_transform_edt(region) > spacings * lat.spacing


def test_no_ice_is_the_photo_exactly(grown):
    image, _region, lat, res = grown
    assert np.array_equal(render_ice(image, lat, np.zeros(lat.n_cells)), image)
    # In a clip, everything the ice has not reached is the photo, bit for bit.
    clip = render(image, lat, res, frames=6, every=6)
    near = np.hypot(*(np.mgrid[0:72, 0:96] - np.array([36, 30])[:, None, None])) < 4 * lat.spacing
    assert np.array_equal(clip.frames[0][~near], image[~near])


def test_thin_ice_shows_the_photo_and_thick_ice_is_whiter_and_more_opaque(grown):
    image, region, lat, _res = grown
    inner = interior(region, lat)
    # Mass 5 is "fully thick", mass 1 fresh ice; thickness from the mass alone (no ridges).
    look = FrostLook(thickness=5.0, ridges=0)
    thin, thin_layers = render_ice(image, lat, np.ones(lat.n_cells), look=look, return_layers=True)
    thick, thick_layers = render_ice(
        image, lat, np.full(lat.n_cells, 5.0), look=look, return_layers=True
    )
    # Thin ice: nearly clear, the photo seen through it (a little softened).
    assert thin_layers["alpha"][inner].max() < 0.15
    assert np.abs(thin - image)[inner].mean() < 0.05
    assert np.corrcoef(luminance(thin)[inner], luminance(image)[inner])[0, 1] > 0.9
    # Thick ice: nearly opaque and whiter than both the photo and the thin ice.
    assert thick_layers["alpha"][inner].min() > 0.8
    assert luminance(thick)[inner].mean() > luminance(thin)[inner].mean() + 0.15
    assert np.all(thick[inner].min(axis=-1) > image[inner].min(axis=-1))  # towards white


def test_ice_ends_in_a_soft_edge_at_the_region_border(grown):
    image, region, lat, _ = grown
    _, layers = render_ice(
        image,
        lat,
        np.full(lat.n_cells, 5.0),
        look=FrostLook(thickness=5.0, ridges=0),
        return_layers=True,
    )
    alpha = layers["alpha"]
    # Along the middle row, from the region's centre out to its right border.
    row = 36
    cols = np.flatnonzero(region[row])
    ramp = alpha[row, 48 : cols.max() + 1]
    assert ramp[0] > 0.8
    assert ramp[-1] < 0.2  # thins out to (nearly) nothing at the border ...
    assert np.abs(np.diff(ramp)).max() < 0.35  # ... gradually: no cut-out step
    assert np.sum((ramp > 0.1) & (ramp < 0.7)) >= 3
    assert np.all(alpha[~region] == 0)


def test_shading_follows_the_light_direction(grown):
    image, _region, lat, res = grown
    mass = ice_mass(res, res.end_frame)
    from_left, layers = render_ice(
        image, lat, mass, look=FrostLook(azimuth=180), return_layers=True
    )
    from_right = render_ice(image, lat, mass, look=FrostLook(azimuth=0))
    ice = layers["alpha"] > 0.05
    assert np.abs(from_left - from_right)[ice].mean() > 0.01
    # Slopes facing the light are the brighter ones: d(theta)/dx > 0 faces left.
    slope = np.gradient(layers["thickness"], axis=1)
    diff = luminance(from_left) - luminance(from_right)
    assert np.corrcoef(diff[ice], slope[ice])[0, 1] > 0.3
    # A flat surface (no relief) looks the same from every side.
    flat_left = render_ice(image, lat, mass, look=FrostLook(azimuth=180, relief=0))
    flat_right = render_ice(image, lat, mass, look=FrostLook(azimuth=0, relief=0))
    assert np.array_equal(flat_left, flat_right)


def test_the_last_frame_is_ice_of_varied_thickness_not_a_uniform_sheet(grown):
    image, region, lat, res = grown
    clip = render(image, lat, res, every=50)
    rgb, layers = render_ice(image, lat, ice_mass(res, res.end_frame), return_layers=True)
    np.testing.assert_allclose(clip.frames[-1], rgb, atol=1e-6)
    alpha = layers["alpha"][interior(region, lat, 1)]
    assert alpha.std() > 0.12
    assert np.mean(alpha < 0.3) > 0.2  # the photo shows through the thin ice ...
    assert np.mean(alpha > 0.6) > 0.1  # ... between arms of thick white ice
    inner = interior(region, lat, 1)
    thin = inner & (layers["alpha"] < 0.3)
    thick = inner & (layers["alpha"] > 0.6)
    assert np.abs(rgb - image)[thin].mean() < 0.12
    # Thick ice has gone a good part of the way from the photo to white.
    towards_white = (rgb - image) / (1.0 - image + 1e-3)
    assert towards_white[thick].mean() > 0.25
    assert towards_white[thin].mean() < towards_white[thick].mean() - 0.15


def test_ice_mass_grows_by_exactly_gamma_a_step_once_frozen():
    lat = HexLattice.hexagon(8)
    p = FrostParams(beta=0.45, gamma=0.01)
    res = grow(lat, [lat.center_cell()], p, frames=150, record_vapour=True)
    n = lat.n_cells
    by_ring = (lat.neighbours[:n] >= n).any(axis=1)  # a ring point can still feed these
    for t in (60, 100, 150):
        mass = ice_mass(res, t)
        ice = (ice_mass(res, t - 1) > 0) & ~by_ring  # ice since the step before
        assert ice.sum() > 20
        over = res.vapour[t][ice] - mass[ice]  # what each cell overshot 1 by at freezing
        assert over.min() > -1e-6
        assert over.max() < 2 * p.gamma + p.beta
        np.testing.assert_allclose(res.vapour[t][ice] - res.vapour[t - 1][ice], p.gamma, atol=1e-12)


@pytest.mark.parametrize(
    ("n", "word"),
    [
        (1, "1st"),
        (2, "2nd"),
        (3, "3rd"),
        (4, "4th"),
        (11, "11th"),
        (12, "12th"),
        (13, "13th"),
        (21, "21st"),
        (22, "22nd"),
        (101, "101st"),
        (111, "111th"),
    ],
)
def test_ordinals_in_messages(n, word):
    assert _ordinal(n) == word


def test_a_kept_surface_draws_what_a_fresh_one_draws_and_never_a_stale_picture(scene):
    from fluidnb.frost import _render as impl

    image, region = scene
    image = image.copy()
    lat = HexLattice.from_mask(region, 6.0)
    res = grow(lat, lat.snap([[36, 48]]), FrostParams(), seed=1, frames=60)
    impl._SURFACE.forget()
    fresh = render(image, lat, res, every=20)
    kept = render(image, lat, res, every=20)  # the surface of the call before
    assert np.array_equal(fresh.frames, kept.frames)
    image[:, :, 2] = 1.0  # the same array, another picture
    changed = render(image, lat, res, every=20)
    impl._SURFACE.forget()
    assert np.array_equal(changed.frames, render(image, lat, res, every=20).frames)
    assert not np.array_equal(changed.frames, fresh.frames)
    bright = render(image, lat, res, every=20, look=FrostLook(opacity=0.5))
    assert not np.array_equal(bright.frames, changed.frames)  # another look, not kept
