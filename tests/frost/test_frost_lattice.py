"""The hexagonal lattice: geometry, the boundary ring, starts, and bad regions."""

import math

import numpy as np
import pytest

from fluidnb.frost import DIRECTIONS, HexLattice


def ellipse(h=60, w=90, cy=30, cx=45, ry=20, rx=35):
    yy, xx = np.mgrid[0:h, 0:w]
    return ((yy - cy) / ry) ** 2 + ((xx - cx) / rx) ** 2 <= 1


@pytest.mark.parametrize("spacing", [1.0, 2.5, 4.0])
def test_neighbours_are_six_points_at_the_spacing_in_the_named_directions(spacing):
    lat = HexLattice.from_mask(ellipse(), spacing)
    pts = np.concatenate([lat.points, lat.ring_points])
    cells = np.arange(lat.n_cells)
    nb = lat.neighbours[cells]
    assert (nb >= 0).all(), "every region cell has six lattice neighbours"
    vec = pts[nb] - pts[cells, None, :]
    assert np.allclose(np.hypot(vec[..., 0], vec[..., 1]), spacing)
    # Direction k points at 60 k degrees, counter-clockwise from east (rows point down).
    angle = np.degrees(np.arctan2(-vec[..., 0], vec[..., 1]))
    off = (angle - np.arange(6) * 60.0 + 180.0) % 360.0 - 180.0
    assert np.abs(off).max() < 1e-6
    assert DIRECTIONS == ("E", "NE", "NW", "W", "SW", "SE")


def test_neighbour_table_is_symmetric():
    lat = HexLattice.from_mask(ellipse(), 3.0)
    nb = lat.neighbours
    for k in range(6):
        have = nb[:, k] >= 0
        back = nb[nb[have, k], (k + 3) % 6]  # the opposite direction leads back
        assert np.array_equal(back, np.flatnonzero(have))


def test_cells_are_the_painted_points_and_the_ring_surrounds_them():
    mask = ellipse()
    lat = HexLattice.from_mask(mask, 3.0)
    r, c = np.rint(lat.points).astype(int).T
    assert mask[r, c].all()
    rr, rc = np.rint(lat.ring_points).astype(int).T
    on_image = (rr >= 0) & (rr < mask.shape[0]) & (rc >= 0) & (rc < mask.shape[1])
    assert not mask[rr[on_image], rc[on_image]].any()
    # Each region cell's neighbours are cells or ring points; each ring point touches a cell.
    n = lat.n_cells
    assert (lat.neighbours[:n] < n + lat.n_ring).all()
    ring_nb = lat.neighbours[n:]
    assert (((ring_nb >= 0) & (ring_nb < n)).any(axis=1)).all()


def test_lattice_is_anchored_to_the_image_so_painting_more_keeps_cells():
    small = ellipse(ry=10, rx=15)
    big = ellipse(ry=20, rx=35)
    a = HexLattice.from_mask(small, 3.0)
    b = HexLattice.from_mask(big, 3.0)
    bset = {tuple(p) for p in np.round(b.points, 6)}
    assert all(tuple(p) in bset for p in np.round(a.points, 6))


def test_hexagon_counts_and_axial_coordinates():
    for radius in range(5):
        lat = HexLattice.hexagon(radius)
        assert lat.n_cells == 1 + 3 * radius * (radius + 1)
        assert lat.n_ring == 6 * (radius + 1)
    lat = HexLattice.hexagon(3, spacing=2.0)
    c = lat.center_cell()
    assert np.allclose(lat.points[c], lat.origin)
    q, r = (lat.axial[: lat.n_cells] - lat.axial[c]).T
    x = (q + r / 2) * 2.0
    y = r * math.sqrt(3) / 2 * 2.0
    assert np.allclose(lat.points - lat.origin, np.stack([y, x], axis=1))


def test_snap_points_to_cells():
    lat = HexLattice.from_mask(ellipse(), 3.0)
    target = lat.points[10]
    assert lat.snap(target + 0.4).tolist() == [10]
    # Several points; repeats collapse; a (2,) point works too.
    both = lat.snap([target, target + 0.2, lat.points[40]])
    assert both.tolist() == [10, 40]
    assert lat.snap(tuple(target)).tolist() == [10]


def test_snap_refuses_points_outside_the_region():
    lat = HexLattice.from_mask(ellipse(), 3.0)
    with pytest.raises(
        ValueError, match=r"start point \(row, col\) = \(2, 2\) is outside the region"
    ):
        lat.snap([[2, 2]])
    with pytest.raises(ValueError, match="outside the region"):
        lat.snap([[30, 45], [500, 45]])  # off the image
    with pytest.raises(ValueError, match="must not be empty"):
        lat.snap(np.zeros((0, 2)))
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        lat.snap([[1, 2, 3]])
    hexa = HexLattice.hexagon(2, spacing=10)
    with pytest.raises(ValueError, match="outside the region"):
        hexa.snap([hexa.origin + [0, 40]])


def test_bad_regions_are_refused_and_the_mask_is_not_modified():
    with pytest.raises(ValueError, match="region is empty"):
        HexLattice.from_mask(np.zeros((20, 20), bool), 2.0)
    tiny = np.zeros((40, 40), bool)
    tiny[5, 6] = True  # no lattice point at spacing 10 lands on this pixel
    with pytest.raises(ValueError, match=r"spacing=10 px leaves no lattice point inside"):
        HexLattice.from_mask(tiny, 10)
    with pytest.raises(ValueError, match="spacing must be > 0"):
        HexLattice.from_mask(ellipse(), 0)
    mask = ellipse()
    before = mask.copy()
    lat = HexLattice.from_mask(mask, 2.0)
    assert np.array_equal(mask, before)
    assert not lat.mask.flags.writeable
    mask[:] = False  # the lattice kept its own copy
    assert lat.mask.any()


def test_to_grid_and_pixel_cells():
    lat = HexLattice.from_mask(ellipse(), 3.0)
    grid = lat.to_grid(np.arange(lat.n_cells), fill=-1)
    assert grid.shape == lat.kind.shape
    assert sorted(grid[grid >= 0]) == list(range(lat.n_cells))
    with pytest.raises(ValueError, match="one entry per cell"):
        lat.to_grid(np.zeros(3))
    owner = lat.pixel_cells()
    inside = ellipse()
    assert ((owner >= 0) == inside).all()
    r, c = np.nonzero(inside)
    d = np.hypot(*(lat.points[owner[r, c]] - np.stack([r, c], 1)).T)
    assert d.max() <= 3.0  # every painted pixel shows a nearby cell


def test_hops_asked_again_are_the_same_and_a_caller_cannot_spoil_them():
    lat = HexLattice.hexagon(4)
    c = lat.center_cell()
    first = lat.hops([c])
    first[:] = 99  # the caller's own copy
    again = lat.hops([c])
    assert np.bincount(again).tolist() == [1, 6, 12, 18, 24]
    other = lat.hops([0])  # another start: computed, not the kept answer
    assert other[0] == 0
    assert other.max() > 4
    assert np.array_equal(lat.hops([c]), again)
