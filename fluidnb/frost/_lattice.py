"""The hexagonal lattice of the frost simulation (Amano et al., sec. 3.1, Fig. 2).

Lattice points sit on a regular triangular lattice (each point has six neighbours at
the same distance: Reiter's hexagonal cells) with spacing ``s`` pixels:

    point (i, j) is at pixel row ``y = i * s * sqrt(3) / 2`` and column
    ``x = (j + (i mod 2) / 2) * s``,

so odd rows are shifted right by half a spacing ("odd-r" offset layout) and point
(0, 0) sits at the lattice's ``origin`` pixel. In axial coordinates
``q = j - floor(i / 2)``, ``r = i`` the six neighbours of (q, r) are

    E (q + 1, r), NE (q + 1, r - 1), NW (q, r - 1),
    W (q - 1, r), SW (q - 1, r + 1), SE (q, r + 1).

The simulation stores the points in one flat vector at ``r * stride + q + const``
("sheared" storage): a rectangular region costs no more than its bounding box (a 2-D
axial array would hold a parallelogram, nearly twice as many points), and every
neighbour is at the same offset (+1, -stride + 1, -stride, -1, +stride - 1, +stride)
from every point, so the update is a handful of contiguous shifted slices.

Every point has a kind: a *cell* of the painted region, a point of the *boundary
ring* just outside it (Amano et al., sec. 3.3: "one size larger than the sketched region"), or
*outside* (not simulated). The ring is every non-region point with a region
neighbour, so each region cell's six neighbours are all cells or ring points.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from .._image import as_mask
from .._validation import check_array, check_int, check_range

__all__ = ["HexLattice"]

OUTSIDE, CELL, RING = 0, 1, 2

#: Row height of the lattice in units of the spacing.
ROW = math.sqrt(3.0) / 2.0

#: The six neighbour directions, counter-clockwise from east (image rows point down,
#: so "north" is row - 1), in the column order of :attr:`HexLattice.neighbours`.
DIRECTIONS = ("E", "NE", "NW", "W", "SW", "SE")
# The same directions in axial coordinates (dq, dr).
AXIAL_DIRECTIONS = ((1, 0), (1, -1), (0, -1), (-1, 0), (-1, 1), (0, 1))


#: Most lattice points :meth:`HexLattice.from_mask` lays over an image (2048 x 2048):
#: building and stepping a lattice costs about 100 bytes a point, so this is ~0.4 GB.
MAX_POINTS = 2048 * 2048


def _points_over(shape, spacing):
    """Lattice points :meth:`HexLattice.from_mask` lays over an image of this shape."""
    h, w = shape
    dy = spacing * ROW
    mi, mj = 3 + math.ceil(1 / dy), 3 + math.ceil(1 / spacing)
    return (math.ceil((h - 1) / dy) + 2 * mi + 1) * (math.ceil((w - 1) / spacing) + 2 * mj + 1)


def _check_size(n_points, spacing, shape):
    """Refuse a spacing that would lay more than :data:`MAX_POINTS` points, before allocating."""
    if n_points <= MAX_POINTS:
        return
    h, w = shape
    # n(s) ~ h w / (s^2 sqrt(3)/2): start from that, then step up to a round value that fits.
    fits = math.sqrt(h * w / (ROW * MAX_POINTS))
    fits = math.ceil(fits * 100) / 100
    while _points_over(shape, fits) > MAX_POINTS:
        fits = round(fits + 0.01, 2)
    raise ValueError(
        f"spacing={spacing:g} px would lay {n_points:,} lattice points over the {w}x{h} "
        f"image, more than the {MAX_POINTS:,} that fit; spacing must be >= {fits:g} px "
        "for this image (a few pixels is usual: each point is one ice cell)"
    )


def neighbour_any(x, out, parity):
    """Logical OR of the six neighbours of every interior point of a 2-D offset grid.

    Used once per lattice to find the boundary ring (the simulation itself runs on
    the sheared flat storage).

    Parameters
    ----------
    x : ndarray of bool, shape (R, C)
        The grid: lattice rows in "odd-r" offset layout.
    out : ndarray of bool, shape (R - 2, C - 2)
        Receives the result for ``x[1:-1, 1:-1]``.
    parity : int
        Parity of the lattice row stored in grid row 1 (0: even).
    """
    v = x[:-2, :] | x[2:, :]  # the rows above and below
    np.logical_or(x[1:-1, :-2], x[1:-1, 2:], out=out)
    out |= v[:, 1:-1]
    even, odd = (0, 1) if parity == 0 else (1, 0)
    out[even::2] |= v[even::2, :-2]  # even rows: the column to the left
    out[odd::2] |= v[odd::2, 2:]  # odd rows: the column to the right
    return out


class HexLattice:
    """Points of a hexagonal lattice inside a region, plus the boundary ring around it.

    Build it with :meth:`from_mask` (a painted region of an image) or :meth:`hexagon`
    (a regular hexagon of cells, for experiments and tests). Per-cell quantities
    (vapour, freeze frames, a per-cell beta) are 1-D arrays over :attr:`points`, in
    the order of :attr:`cells`.

    Attributes
    ----------
    spacing : float
        Distance between neighbouring points, in pixels.
    origin : ndarray, shape (2,)
        Pixel (row, col) of lattice point (0, 0).
    image_shape : tuple of int
        (H, W) of the image the lattice lies on.
    mask : ndarray of bool, shape (H, W), or None
        The painted region (read-only copy), or ``None`` for :meth:`hexagon`.
    kind : ndarray of int8, shape (R, C)
        The points in "odd-r" offset layout: 0 outside, 1 region cell, 2 boundary
        ring. Lattice row ``row0 + i`` and column ``col0 + j`` are ``kind[i, j]``; there
        is a margin of at least one outside point on every side.
    row0, col0 : int
        Lattice indices of ``kind[0, 0]``.
    stride, storage_size : int
        The sheared flat storage the simulation runs on (see the module docstring):
        lattice point ``kind[i, j]`` is element ``i * stride + j - shift(i)``.
    cells, ring : ndarray of intp
        Storage indices of the region cells and of the ring points (raster order).
    points, ring_points : ndarray, shape (n, 2)
        Pixel (row, col) of the cells and of the ring points.
    axial : ndarray of int, shape (n_cells + n_ring, 2)
        Axial coordinates (q, r) of the cells then the ring points:
        ``x = q + r / 2``, ``y = r * sqrt(3) / 2`` in units of the spacing from the
        origin. Rotating by 60 degrees about the origin maps (q, r) to (-r, q + r).
    neighbours : ndarray of intp, shape (n_cells + n_ring, 6)
        For the cells and then the ring points, the index (into the same
        cells-then-ring order) of each of the six neighbours in the order of
        :data:`DIRECTIONS` (E, NE, NW, W, SW, SE), -1 where the neighbour is outside.

    Examples
    --------
    >>> lat = HexLattice.hexagon(2)
    >>> lat.n_cells, lat.n_ring  # 1 + 6 + 12 cells, then a ring of 18
    (19, 18)
    >>> c = lat.center_cell()
    >>> [int(k) for k in lat.neighbours[c]]  # E, NE, NW, W, SW, SE of the centre
    [10, 5, 4, 8, 13, 14]
    """

    def __init__(self, kind, *, spacing, row0, col0, origin, image_shape, mask=None):
        # Private constructor: use from_mask or hexagon, which guarantee the margin.
        self.spacing = float(spacing)
        self.kind = np.ascontiguousarray(kind, dtype=np.int8)
        self.kind.setflags(write=False)
        self.row0, self.col0 = int(row0), int(col0)
        self.origin = np.array(origin, dtype=float)
        self.image_shape = tuple(int(v) for v in image_shape)
        self.mask = mask
        rows, cols = self.kind.shape
        # Sheared storage: element r * stride + q (+ a constant). One spare column keeps
        # consecutive rows from overlapping as their start drifts left every other row.
        self.stride = cols + 1
        self.storage_size = rows * self.stride + 1
        gi, gj = np.indices(self.kind.shape)
        shift = (gi + self.row0) // 2 - self.row0 // 2
        storage = gi * self.stride + gj - shift
        flat = self.kind.ravel()
        self._grid_cells = np.flatnonzero(flat == CELL)
        self._grid_ring = np.flatnonzero(flat == RING)
        self.cells = storage.ravel()[self._grid_cells]
        self.ring = storage.ravel()[self._grid_ring]
        ij = np.stack([gi.ravel(), gj.ravel()], axis=1)
        ij = ij[np.concatenate([self._grid_cells, self._grid_ring])] + [self.row0, self.col0]
        i, j = ij[:, 0], ij[:, 1]
        pix = np.stack(
            [
                i * self.spacing * ROW + self.origin[0],
                (j + 0.5 * (i & 1)) * self.spacing + self.origin[1],
            ],
            axis=1,
        )
        n = self.cells.size
        self.points, self.ring_points = pix[:n], pix[n:]
        self.axial = np.stack([j - i // 2, i], axis=1)
        self.neighbours = self._neighbour_table()
        for arr in (self.cells, self.ring, self.points, self.ring_points, self.axial):
            arr.setflags(write=False)
        self.neighbours.setflags(write=False)
        self._tree = None

    @property
    def offsets(self):
        """Storage offsets of the six neighbours, in the order of :data:`DIRECTIONS`."""
        s = self.stride
        return (1, -s + 1, -s, -1, s - 1, s)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_mask(cls, region, spacing):
        """Lattice points inside a painted region, and the ring just outside it.

        A lattice point belongs to the region when the mask is True at its nearest
        pixel. The lattice is anchored at pixel (0, 0) of the image, so painting more
        of the region adds cells without moving the existing ones.

        Parameters
        ----------
        region : array_like of bool, shape (H, W)
            The painted region (anything :func:`fluidnb.as_mask` accepts). Not
            modified; a read-only copy is kept as :attr:`mask`.
        spacing : float
            Distance between neighbouring lattice points, in pixels (> 0).

        Returns
        -------
        HexLattice

        Raises
        ------
        ValueError
            If the region is empty, or so small for the spacing that no lattice
            point falls inside it.

        Examples
        --------
        >>> region = np.zeros((40, 60), bool)
        >>> region[10:30, 10:50] = True
        >>> lat = HexLattice.from_mask(region, spacing=4)
        >>> lat.n_cells, lat.image_shape
        (60, (40, 60))
        """
        mask = as_mask(region, name="region").copy()
        spacing = check_range("spacing", spacing, 0, lo_open=True)
        h, w = mask.shape
        dy = spacing * ROW
        # Lattice rows/columns covering the image with a margin of three points plus a
        # pixel (a half-shifted row can round onto the image at j = -1; below 1 px
        # spacing several points round onto one pixel), so the ring and a further
        # outside margin always fit.
        mi, mj = 3 + math.ceil(1 / dy), 3 + math.ceil(1 / spacing)
        n_rows = int(math.ceil((h - 1) / dy)) + 2 * mi + 1
        n_cols = int(math.ceil((w - 1) / spacing)) + 2 * mj + 1
        _check_size(n_rows * n_cols, spacing, (h, w))
        i = np.arange(-mi, n_rows - mi)
        j = np.arange(-mj, n_cols - mj)
        ii, jj = np.meshgrid(i, j, indexing="ij")
        y = ii * dy
        x = (jj + 0.5 * (ii & 1)) * spacing
        r = np.rint(y).astype(int)
        c = np.rint(x).astype(int)
        on_image = (r >= 0) & (r < h) & (c >= 0) & (c < w)
        inside = np.zeros(ii.shape, bool)
        inside[on_image] = mask[r[on_image], c[on_image]]
        if not inside.any():
            area = int(mask.sum())
            raise ValueError(
                f"spacing={spacing:g} px leaves no lattice point inside the region "
                f"({area} px painted); use a smaller spacing or paint a larger region"
            )
        mask.setflags(write=False)
        return cls._from_inside(
            inside,
            row0=int(i[0]),
            col0=int(j[0]),
            spacing=spacing,
            origin=(0.0, 0.0),
            image_shape=(h, w),
            mask=mask,
        )

    @classmethod
    def hexagon(cls, radius, spacing=1.0):
        """A regular hexagon of cells: every point within ``radius`` steps of the centre.

        The hexagon is exactly invariant under 60-degree rotations about its centre
        cell, which makes it the region for symmetry checks and reference runs.

        Parameters
        ----------
        radius : int
            Number of rings of cells around the centre (>= 0): ``1 + 3 r (r + 1)``
            cells in all.
        spacing : float
            Distance between neighbouring points, in pixels.

        Returns
        -------
        HexLattice
            With the centre cell at pixel ``origin`` and an image just large enough
            to hold the hexagon and its ring; :attr:`mask` is ``None``.

        Examples
        --------
        >>> HexLattice.hexagon(3).n_cells
        37
        """
        radius = check_int("radius", radius, 0)
        spacing = check_range("spacing", spacing, 0, lo_open=True)
        if (2 * radius + 7) ** 2 > MAX_POINTS:
            most = (math.isqrt(MAX_POINTS) - 7) // 2
            raise ValueError(
                f"radius must be <= {most} (at most {MAX_POINTS:,} points), got {radius}"
            )
        m = radius + 3  # the hexagon, its ring and one outside point, with room to spare
        i = np.arange(-m, m + 1)
        j = np.arange(-m, m + 1)
        ii, jj = np.meshgrid(i, j, indexing="ij")
        q = jj - (ii - (ii & 1)) // 2
        r = ii
        inside = (np.abs(q) + np.abs(r) + np.abs(q + r)) // 2 <= radius
        # Pixel origin so the hexagon and its ring have positive coordinates.
        origin = ((radius + 1.5) * spacing * ROW + 1, (radius + 1.5) * spacing + 1)
        shape = (int(math.ceil(2 * origin[0])) + 1, int(math.ceil(2 * origin[1])) + 1)
        return cls._from_inside(
            inside, row0=-m, col0=-m, spacing=spacing, origin=origin, image_shape=shape
        )

    @classmethod
    def _from_inside(cls, inside, *, row0, col0, **kw):
        # Pad by one so every point of `inside` is an interior point of the padded grid
        # (whose row 1 is lattice row row0).
        ring = np.zeros(inside.shape, bool)
        neighbour_any(np.pad(inside, 1), ring, row0 & 1)
        ring &= ~inside
        kind = np.where(inside, CELL, np.where(ring, RING, OUTSIDE)).astype(np.int8)
        used = np.nonzero(kind)
        lo_i, hi_i = used[0].min() - 1, used[0].max() + 2
        lo_j, hi_j = used[1].min() - 1, used[1].max() + 2
        if lo_i < 0 or lo_j < 0 or hi_i > kind.shape[0] or hi_j > kind.shape[1]:
            raise AssertionError("lattice margin too small")  # pragma: no cover
        return cls(kind[lo_i:hi_i, lo_j:hi_j], row0=row0 + lo_i, col0=col0 + lo_j, **kw)

    # ------------------------------------------------------------------ geometry
    @property
    def n_cells(self):
        """Number of lattice points inside the region (the simulated cells)."""
        return int(self.cells.size)

    @property
    def n_ring(self):
        """Number of boundary points just outside the region."""
        return int(self.ring.size)

    def _neighbour_table(self):
        index = np.full(self.storage_size, -1, dtype=np.intp)
        everyone = np.concatenate([self.cells, self.ring])
        index[everyone] = np.arange(everyone.size)
        return np.stack([index[everyone + d] for d in self.offsets], axis=1)

    def center_cell(self):
        """Index of the cell nearest to the centroid of the region's cells."""
        centroid = self.points.mean(axis=0)
        return int(np.argmin(((self.points - centroid) ** 2).sum(axis=1)))

    def hops(self, cells):
        """Steps from the nearest of ``cells`` to every cell, along the lattice.

        Ice spreads at most one cell a frame (a cell can freeze only after a
        neighbour has), so the ice at frame ``t`` lies within ``t`` hops of the start
        cells: this is the fastest the front can possibly move.

        Parameters
        ----------
        cells : array_like of int
            Start cells (indices into :attr:`points`).

        Returns
        -------
        ndarray of int32, shape (n_cells,)
            Hop distance of every cell (0 at the starts), -1 for cells the starts
            cannot reach (another part of a region painted in pieces).

        Examples
        --------
        >>> lat = HexLattice.hexagon(3)
        >>> np.bincount(lat.hops([lat.center_cell()])).tolist()  # 1 + 6 + 12 + 18 cells
        [1, 6, 12, 18]
        """
        front = np.unique(np.asarray(cells, dtype=np.intp))
        # The last answer is kept: the app's length estimate asks again for the same
        # start cells at every slider move (the lattice does not change).
        kept = getattr(self, "_hops_kept", None)
        if kept is not None and np.array_equal(kept[0], front):
            return kept[1].copy()
        n = self.n_cells
        nbrs = self.neighbours[:n]
        dist = np.full(n, -1, np.int32)
        starts = front
        dist[front] = 0
        k = 0
        while front.size:  # breadth-first, one whole layer per pass
            k += 1
            nxt = nbrs[front].ravel()
            nxt = np.unique(nxt[(nxt >= 0) & (nxt < n)])
            front = nxt[dist[nxt] < 0]
            dist[front] = k
        self._hops_kept = (starts, dist.copy())
        return dist

    # ------------------------------------------------------------------ start points
    def snap(self, points_rc):
        """Cells for start points given in pixel (row, col) coordinates.

        Each point goes to the nearest cell of the region; several points may be
        given, and points landing on the same cell count once.

        Parameters
        ----------
        points_rc : array_like, shape (n, 2) or (2,)
            Start points, (row, col) in image pixels.

        Returns
        -------
        ndarray of intp, shape (m,)
            Cell indices (into :attr:`points`), sorted, without repeats.

        Raises
        ------
        ValueError
            If there are no points, or a point lies outside the region (for a
            painted region: on an unpainted pixel or off the image).

        Examples
        --------
        >>> lat = HexLattice.hexagon(2, spacing=10)
        >>> lat.snap([lat.origin + 3]).tolist()  # near the centre
        [9]
        """
        pts = check_array("start points", points_rc, ndim=(1, 2), dtype_kinds="iuf")
        pts = pts.reshape(-1, 2) if pts.ndim == 1 and pts.size == 2 else pts
        if pts.ndim != 2 or pts.shape[1] != 2:
            raise ValueError(
                f"start points must be (row, col) pairs of shape (n, 2), got {pts.shape}"
            )
        pts = pts.astype(float)
        dist, idx = self._cell_tree().query(pts)
        for (row, col), d in zip(pts, dist):
            if not self._inside(row, col, d):
                raise ValueError(
                    f"start point (row, col) = ({row:g}, {col:g}) is outside the region; "
                    "place start points on the painted area"
                )
        return np.unique(idx).astype(np.intp)

    def _inside(self, row, col, dist):
        if self.mask is not None:
            r, c = int(round(row)), int(round(col))
            h, w = self.mask.shape
            return 0 <= r < h and 0 <= c < w and bool(self.mask[r, c])
        # No mask: inside the union of the cells' hexagons (circumradius s / sqrt 3).
        return dist <= self.spacing / math.sqrt(3.0) + 1e-9

    def _cell_tree(self):
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree

    # ------------------------------------------------------------------ maps
    def to_grid(self, values, fill=0.0):
        """Scatter per-cell values into the (R, C) offset grid of :attr:`kind`.

        Parameters
        ----------
        values : array_like, shape (n_cells,)
            One value per cell.
        fill : scalar
            Value of the ring and outside points.
        """
        values = np.asarray(values)
        if values.shape[:1] != (self.n_cells,):
            raise ValueError(
                f"values must have one entry per cell ({self.n_cells}), got {values.shape}"
            )
        grid = np.full(self.kind.size, fill, dtype=np.result_type(values.dtype, np.asarray(fill)))
        grid[self._grid_cells] = values
        return grid.reshape(self.kind.shape)

    def pixel_cells(self, shape=None):
        """Which cell each pixel of the region shows (for rendering).

        Parameters
        ----------
        shape : (int, int), optional
            Output size (default :attr:`image_shape`); pixel coordinates are scaled.

        Returns
        -------
        ndarray of intp, shape (H, W)
            The nearest cell of every pixel inside the region (the painted mask, or
            for a :meth:`hexagon` the cells' own hexagons), -1 elsewhere.
        """
        shape = self.image_shape if shape is None else tuple(shape)
        sy, sx = self.image_shape[0] / shape[0], self.image_shape[1] / shape[1]
        rr, cc = np.mgrid[0 : shape[0], 0 : shape[1]]
        ry, rx = (rr + 0.5) * sy - 0.5, (cc + 0.5) * sx - 0.5
        if self.mask is not None:
            mr = np.clip(np.rint(ry).astype(int), 0, self.image_shape[0] - 1)
            mc = np.clip(np.rint(rx).astype(int), 0, self.image_shape[1] - 1)
            region = self.mask[mr, mc]
        else:
            region = np.ones(shape, bool)
        out = np.full(shape, -1, dtype=np.intp)
        query = np.stack([ry[region], rx[region]], axis=1)
        _, idx = self._all_tree().query(query)
        idx = np.where(idx < self.n_cells, idx, -1)  # nearest is a ring point
        if self.mask is not None:
            # A painted pixel nearer a ring point still shows its nearest cell.
            far = idx < 0
            if far.any():
                _, idx[far] = self._cell_tree().query(query[far])
        out[region] = idx
        return out

    def _all_tree(self):
        return cKDTree(np.concatenate([self.points, self.ring_points]))

    def __repr__(self):
        return (
            f"HexLattice({self.n_cells} cells + {self.n_ring} ring points, "
            f"spacing={self.spacing:g} px)"
        )
