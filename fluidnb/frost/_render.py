r"""Drawing frost as ice lying on the picture (spec: Rendering).

The automaton gives every cell its ice mass. A frozen cell is a receptive cell whose
neighbours are all receptive too, so diffusion brings it nothing and it gains exactly
:math:`\gamma` a step (Amano et al., Eq. (1)): the mass of cell :math:`p` that froze at
frame :math:`f(p)` is :math:`m_t(p) = 1 + \gamma\,(t - f(p))` (plus the little it
overshot 1 by when it froze). Old ice is thick, fresh ice at the front is thin, and
the dendrite arms, which froze first, stand out as ridges.

That mass is drawn as a height field lying on the photo:

- **thickness** :math:`\theta`: the mass above freezing, and how far a cell stands
  above the ice around it (the arms), scaled so the thickest ice of the clip is 1 and
  fresh ice a small ``fresh`` fraction; each pixel blends the three
  lattice points of its triangle (barycentric weights) and the field is smoothed over
  about half a spacing, so arms are round ridges rather than facets;
- **shading**: the surface normal :math:`n \propto (-r\,\partial_x\theta,
  -r\,\partial_y\theta, 1)` (``relief`` :math:`r`) lit from the light direction
  :math:`L` -- Lambert :math:`n \cdot L` plus a Blinn-Phong highlight
  :math:`(n \cdot h)^{s}` -- and a fixed grain of tiny facets that glitter;
- **opacity and colour**: :math:`\alpha = a\,(1 - e^{-k\theta^2})`: thin ice is nearly
  clear, thick ice whiter and nearly opaque;
- **the photo through the ice**: blurred in proportion to the thickness and shifted
  along the slope of the surface (refraction), so thin ice shows the photo, slightly
  soft and wavy;
- **edges**: each cell fades in over ``fade`` frames before it freezes, and the ice
  thins out to nothing over ``edge`` spacings towards the painted region's border,
  so growth that stopped there ends softly instead of as a cut-out.

Pixels without ice are the photo exactly, and outside the region nothing changes.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy import ndimage

from .._image import as_image
from .._kept import LastKept
from .._progress import Progress
from .._stream import FrameStream
from .._validation import check_fps, check_int, check_range
from ._lattice import ROW, HexLattice
from ._reiter import FrostResult

__all__ = ["FrostLook", "ice_mass", "render", "render_ice"]

# Colours (linear RGB in [0, 1]): thin ice is a cool clear blue-white, thick ice is
# white (many crystal faces scatter all colours alike).
_THIN = np.array([0.80, 0.88, 0.97], np.float32)
_THICK = np.array([0.96, 0.98, 1.0], np.float32)
# Refuse clips larger than this (float32 RGB frames) with a clear message, not a crash.
_MAX_BYTES = 2 * 2**30
# alpha = opacity (1 - exp(-k theta^2)): the thickest ice lets 8 % through, ice a third
# as thick 80 % (scattering grows faster than linearly as crystals pile up).
_DEPTH = 2.5


def _ordinal(n):
    """1st, 2nd, 3rd, 4th, ..., 11th, 12th, 13th, 21st, ..."""
    n = int(n)
    if 10 <= n % 100 <= 20:
        return f"{n}th"
    return f"{n}{ {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th') }"


class FrostLook:
    """How the ice is drawn (see the module docstring for the model).

    Parameters
    ----------
    opacity : float
        :math:`a`, the opacity of the thickest ice, in [0, 1].
    azimuth : float
        Direction the light comes from, degrees counter-clockwise from the image's
        right (+x) as seen on the image (135: from the upper left).
    elevation : float
        Height of the light above the surface, degrees in (0, 90].
    relief : float
        :math:`r`, how strongly the thickness bends the surface (0: flat ice).
    specular : float
        Strength of the highlight, in [0, 1].
    shininess : float
        :math:`s`, the highlight's exponent (larger: smaller, sharper highlights).
    blur : float
        Blur of the photo under the thickest ice, in lattice spacings.
    refraction : float
        Shift of the photo under the ice per unit slope, in lattice spacings.
    fresh : float
        Thickness of just-frozen ice relative to the thickest, in [0, 1].
    thickness : float, optional
        The ice mass drawn as fully thick (default: the 95th percentile of the masses
        of the last frame drawn, so every clip spans thin to thick).
    ridges : float
        Share of the thickness that comes from the dendrite ridges (how much a cell
        stands above the ice around it) rather than from the ice's age, in [0, 1].
    edge : float
        Width, in spacings, over which the ice thins out towards the region's border.
    fade : float
        Frames over which a cell fades in before it freezes (> 0).
    grain : float
        Strength of the fixed grain of small facets on the surface, in [0, 1].
    sparkle : float
        Strength of the glints on those facets, in [0, 1].
    """

    def __init__(
        self,
        opacity=0.92,
        azimuth=135.0,
        elevation=40.0,
        relief=1.5,
        specular=0.3,
        shininess=30.0,
        blur=0.6,
        refraction=0.4,
        fresh=0.15,
        thickness=None,
        edge=2.0,
        fade=2.0,
        ridges=0.6,
        grain=0.35,
        sparkle=0.5,
    ):
        self.opacity = check_range("opacity", opacity, 0, 1)
        self.azimuth = check_range("azimuth", azimuth, -360, 360)
        self.elevation = check_range("elevation", elevation, 0, 90, lo_open=True)
        self.relief = check_range("relief", relief, 0, 100)
        self.specular = check_range("specular", specular, 0, 1)
        self.shininess = check_range("shininess", shininess, 1, 1000)
        self.blur = check_range("blur", blur, 0, 10)
        self.refraction = check_range("refraction", refraction, 0, 10)
        self.fresh = check_range("fresh", fresh, 0, 1)
        self.thickness = (
            None if thickness is None else check_range("thickness", thickness, 1, lo_open=True)
        )
        self.edge = check_range("edge", edge, 0, 100)
        self.fade = check_range("fade", fade, 0, lo_open=True)
        self.ridges = check_range("ridges", ridges, 0, 1)
        self.grain = check_range("grain", grain, 0, 1)
        self.sparkle = check_range("sparkle", sparkle, 0, 1)

    @property
    def light(self):
        """Unit vector towards the light, (x right, y up the image, z out of it)."""
        az, el = math.radians(self.azimuth), math.radians(self.elevation)
        return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def ice_mass(result, frame):
    r"""Ice mass of every cell at ``frame``: :math:`1 + \gamma (t - f(p))`, 0 if not ice.

    Exact up to what a cell overshot 1 by when it froze, for cells away from the
    boundary ring (a ring point next to vapour can still feed ice beside it).

    Parameters
    ----------
    result : FrostResult
        What :func:`grow` returned.
    frame : int
        The frame :math:`t`.

    Returns
    -------
    ndarray of float32, shape (n_cells,)
    """
    if not isinstance(result, FrostResult):
        raise ValueError(f"result must be a FrostResult from grow(), got {type(result).__name__}")
    frame = check_int("frame", frame, 0)
    f = result.freeze_frame
    ice = (f >= 0) & (f <= frame)
    mass = np.zeros(f.shape, np.float32)
    mass[ice] = 1.0 + result.params.gamma * (frame - f[ice])
    return mass


def _triangles(lattice, shape):
    """Barycentric cover of the pixels by lattice triangles.

    Returns, for every pixel, three lattice points (as cell indices, -1 if not a
    cell), their barycentric weights, and the mask of pixels that can show frost.
    """
    h, w = shape
    sy, sx = lattice.image_shape[0] / h, lattice.image_shape[1] / w
    rows, cols = np.mgrid[0:h, 0:w]
    y = ((rows + 0.5) * sy - 0.5 - lattice.origin[0]) / (lattice.spacing * ROW)
    x = ((cols + 0.5) * sx - 0.5 - lattice.origin[1]) / lattice.spacing
    r = y
    q = x - r / 2.0
    r0, q0 = np.floor(r), np.floor(q)
    fr, fq = r - r0, q - q0
    upper = fq + fr > 1.0
    r0, q0 = r0.astype(np.int64), q0.astype(np.int64)
    # Lower triangle (q0, r0), (q0 + 1, r0), (q0, r0 + 1); upper (q0 + 1, r0 + 1), B, C.
    qa = np.where(upper, q0 + 1, q0)
    ra = np.where(upper, r0 + 1, r0)
    wa = np.where(upper, fq + fr - 1.0, 1.0 - fq - fr)
    wb = np.where(upper, 1.0 - fr, fq)
    wc = np.where(upper, 1.0 - fq, fr)
    verts = [(qa, ra), (q0 + 1, r0), (q0, r0 + 1)]
    weights = np.stack([wa, wb, wc]).astype(np.float32)
    # Axial (q, r) -> cell index through a lookup table over the lattice's axial box.
    ax = lattice.axial[: lattice.n_cells]
    qmin, rmin = ax.min(axis=0)
    qmax, rmax = ax.max(axis=0)
    table = np.full((rmax - rmin + 1, qmax - qmin + 1), -1, dtype=np.int64)
    table[ax[:, 1] - rmin, ax[:, 0] - qmin] = np.arange(lattice.n_cells)
    index = np.empty((3, h, w), np.int64)
    for k, (qq, rr) in enumerate(verts):
        ok = (qq >= qmin) & (qq <= qmax) & (rr >= rmin) & (rr <= rmax)
        idx = np.full((h, w), -1, np.int64)
        idx[ok] = table[rr[ok] - rmin, qq[ok] - qmin]
        index[k] = idx
    if lattice.mask is not None:
        mr = np.clip(np.rint((rows + 0.5) * sy - 0.5).astype(int), 0, lattice.image_shape[0] - 1)
        mc = np.clip(np.rint((cols + 0.5) * sx - 0.5).astype(int), 0, lattice.image_shape[1] - 1)
        region = lattice.mask[mr, mc]
    else:
        region = np.ones((h, w), bool)
    region &= (index >= 0).any(axis=0)
    return index, weights, region


def _grain(shape, seed=12345):
    """A fixed field of tiny facets: smooth noise of unit spread, and glint positions.

    Its own fixed seed, not the run's: the surface must not change with the frost's
    random numbers.
    """
    g = np.random.default_rng(seed)
    noise = ndimage.gaussian_filter(g.standard_normal(shape).astype(np.float32), 0.8)
    noise /= noise.std() + 1e-12
    glints = g.random(shape, dtype=np.float32)
    return noise, glints


class _Surface:
    """Everything about drawing ice on one picture that does not change between frames.

    Built once per clip: the pixels' triangles and weights, the region's bounding box
    with a margin, the soft edge, the blurred photo and the grain. :meth:`draw` then
    turns per-cell cover and thickness into one frame.
    """

    def __init__(self, base, lattice, look):
        self.look = look
        shape = base.shape[:2]
        index, weights, region = _triangles(lattice, shape)
        # Work in the region's bounding box (plus room for the smoothing): frost is small
        # next to the photo more often than not.
        rows, cols = np.nonzero(region)
        if rows.size == 0:  # the region shrank to nothing at this output size
            rows, cols = np.zeros(1, np.intp), np.zeros(1, np.intp)
        scale = shape[0] / lattice.image_shape[0]
        self.spacing = max(lattice.spacing * scale, 1e-6)  # one spacing in output pixels
        pad = int(math.ceil(3 * self.spacing)) + 2
        r0, r1 = max(rows.min() - pad, 0), min(rows.max() + pad + 1, shape[0])
        c0, c1 = max(cols.min() - pad, 0), min(cols.max() + pad + 1, shape[1])
        self.box = (slice(r0, r1), slice(c0, c1))
        self.region = region[self.box]
        self.box_shape = self.region.shape
        flat = np.flatnonzero(region)
        idx = index.reshape(3, -1)[:, flat]
        wts = weights.reshape(3, -1)[:, flat]
        valid = idx >= 0
        self.idx = np.where(valid, idx, 0)
        self.wts = np.where(valid, wts, 0.0).astype(np.float32)
        self.where = np.flatnonzero(self.region)  # the same pixels, in the box
        # Soft edge: the ice thins to nothing at the region's border.
        if look.edge > 0:
            inside = ndimage.distance_transform_edt(np.pad(self.region, 1))[1:-1, 1:-1]
            ramp = np.clip(inside / (look.edge * self.spacing), 0.0, 1.0)
            self.edge = (ramp * ramp * (3.0 - 2.0 * ramp)).astype(np.float32)
        else:
            self.edge = self.region.astype(np.float32)
        self.photo = np.ascontiguousarray(base[self.box], dtype=np.float32)
        sigma = look.blur * self.spacing
        self.blurred = (
            ndimage.gaussian_filter(self.photo, (sigma, sigma, 0)) if sigma > 0 else self.photo
        )
        self.smooth = 0.5 * self.spacing  # smoothing of the thickness field, pixels
        self.grain, self.glints = _grain(self.box_shape)

    def _field(self, per_cell):
        """Per-cell values -> a smooth field over the box (barycentric, then Gaussian)."""
        field = np.zeros(self.box_shape, np.float32)
        field.ravel()[self.where] = np.einsum("kp,kp->p", self.wts, per_cell[self.idx])
        if self.smooth > 0.3:
            field = ndimage.gaussian_filter(field, self.smooth, truncate=3.0)
        return field

    def draw(self, cover_cell, thick_cell):
        """One frame over the box: the ice pixels and their colours and layers.

        Returns ``(where, rgb, alpha, theta, cover)``: ``where`` the flat indices (in the
        box) of the region's pixels that show ice, ``rgb`` (n, 3) their colour, and the
        full-box fields ``alpha`` (0 off the ice), ``theta`` and ``cover``.
        """
        look = self.look
        cover = np.clip(self._field(cover_cell), 0.0, 1.0) * self.edge
        theta = self._field(thick_cell)
        # The surface: thickness, plus a grain of facets on the ice (none off it).
        height = theta * (1.0 + look.grain * 0.03 * self.grain)
        gy, gx = np.gradient(height)
        # Only pixels with ice change: do the per-pixel work on those alone.
        where = np.flatnonzero(self.region.ravel() & (cover.ravel() > 0))
        c, th = cover.ravel()[where], theta.ravel()[where]
        gy, gx = gy.ravel()[where], gx.ravel()[where]
        # Slopes per spacing, so the look does not depend on the picture's resolution;
        # rows point down the image, y up: the y slope changes sign.
        sx = look.relief * self.spacing * gx
        sy = -look.relief * self.spacing * gy
        norm = 1.0 / np.sqrt(sx * sx + sy * sy + 1.0)
        lx, ly, lz = look.light
        lambert = np.clip((-sx * lx - sy * ly + lz) * norm, 0.0, None) / lz  # 1 when flat
        hx, hy, hz = lx, ly, lz + 1.0  # Blinn's half vector towards a viewer overhead
        hn = math.sqrt(hx * hx + hy * hy + hz * hz)
        n_dot_h = np.clip((-sx * hx - sy * hy + hz) * norm / hn, 0.0, 1.0)
        spec = look.specular * n_dot_h**look.shininess
        spec += look.sparkle * (self.glints.ravel()[where] > 0.995) * n_dot_h**4
        # The photo through the ice: shifted along the slope (refraction) and softened
        # with the thickness.
        under = self._refracted(where, gy, gx)
        soft = np.clip(th * 1.5, 0.0, 1.0)[:, None]
        under = under[0] + (under[1] - under[0]) * soft
        a = c * look.opacity * (1.0 - np.exp(-_DEPTH * th * th))
        colour = _THIN + (_THICK - _THIN) * np.clip(th, 0.0, 1.0)[:, None]
        rgb = under + (colour - under) * a[:, None]
        # Light and shade on the ice layer; translucent ice scatters light into its own
        # shadows, so they stay soft.
        on_ice = c * np.clip(th * 3.0, 0.0, 1.0)
        shade = 1.0 + 0.45 * (np.minimum(lambert, 1.6) - 1.0)
        rgb *= (1.0 + (shade - 1.0) * on_ice)[:, None]
        rgb += (spec * on_ice)[:, None]
        alpha = np.zeros(self.box_shape, np.float32)
        alpha.ravel()[where] = a
        return where, rgb, alpha, theta, cover

    def _refracted(self, where, gy, gx):
        """Sharp and blurred photo at the ice pixels, sampled along the slope (bilinear)."""
        shift = self.look.refraction * self.spacing * self.spacing
        h, w = self.box_shape
        rows, cols = np.divmod(where, w)
        if shift == 0:
            return self.photo.reshape(-1, 3)[where], self.blurred.reshape(-1, 3)[where]
        y = np.clip(rows - shift * gy, 0, h - 1)
        x = np.clip(cols - shift * gx, 0, w - 1)
        y0 = np.minimum(y.astype(np.intp), h - 2) if h > 1 else np.zeros_like(rows)
        x0 = np.minimum(x.astype(np.intp), w - 2) if w > 1 else np.zeros_like(cols)
        fy, fx = (y - y0)[:, None].astype(np.float32), (x - x0)[:, None].astype(np.float32)
        i00 = y0 * w + x0
        i01 = i00 + (x0 + 1 < w)  # the neighbour to the right, or the pixel itself
        i10 = i00 + w * (y0 + 1 < h)
        i11 = i10 + (x0 + 1 < w)
        out = []
        for img in (self.photo, self.blurred):
            flat = img.reshape(-1, 3)
            top = np.take(flat, i00, axis=0)
            top += (np.take(flat, i01, axis=0) - top) * fx
            bottom = np.take(flat, i10, axis=0)
            bottom += (np.take(flat, i11, axis=0) - bottom) * fx
            out.append(top + (bottom - top) * fy)
        return out

    def compose(self, frame, cover_cell, thick_cell):
        """Draw into ``frame`` (the photo, full size) in place; returns the layers."""
        where, rgb, alpha, theta, cover = self.draw(cover_cell, thick_cell)
        rows, cols = np.divmod(where, self.box_shape[1])
        frame[self.box][rows, cols] = rgb  # the box is a view of the frame
        return alpha, theta, cover


def _neighbourhood(lattice):
    n = lattice.n_cells
    nbrs = lattice.neighbours[:n]
    ok = (nbrs >= 0) & (nbrs < n)
    return np.where(ok, nbrs, 0), ok


def _ridges(mass, hood, passes=4):
    """How much each ice cell stands above the ice around it (mass minus its local mean).

    Dendrite arms froze before the ice that later filled in beside them, so they hold
    more mass: this high-pass of the mass picks out the arms and their side branches.
    The mean is over ice cells only, a few rings wide, so the ice's edge is no ridge.
    """
    safe, ok = hood
    ice = (mass > 0).astype(np.float32)
    mean = mass
    for _ in range(passes):
        num = mean * ice + (mean[safe] * ice[safe] * ok).sum(axis=1)
        den = ice + (ice[safe] * ok).sum(axis=1)
        mean = np.where(den > 0, num / np.maximum(den, 1e-9), 0.0)
    return np.where(ice > 0, np.maximum(mass - mean, 0.0), 0.0).astype(np.float32)


class _Thickness:
    r"""Ice mass -> thickness :math:`\theta` in [fresh, 1] (0 for no ice), one scale per clip.

    :math:`\theta` blends the mass above freezing (old ice is thick) with the ridges
    (arms stand out), each scaled by its value at the reference frame.
    """

    def __init__(self, lattice, look, reference_mass):
        self.look = look
        self.hood = _neighbourhood(lattice)
        ice = reference_mass[reference_mass > 0]
        self.mass_ref = (
            look.thickness
            if look.thickness is not None
            else (float(np.percentile(ice, 95)) if ice.size else 1.0)
        )
        ridges = _ridges(reference_mass, self.hood)
        ridges = ridges[ridges > 0]
        self.ridge_ref = float(np.percentile(ridges, 90)) if ridges.size else 1.0

    def __call__(self, mass):
        look = self.look
        excess = np.maximum(mass - 1.0, 0.0) / max(self.mass_ref - 1.0, 1e-6)
        ridge = _ridges(mass, self.hood) / max(self.ridge_ref, 1e-9)
        body = (1.0 - look.ridges) * excess + look.ridges * ridge
        theta = look.fresh + (1.0 - look.fresh) * np.clip(body, 0.0, 1.0)
        return np.where(mass > 0, theta, 0.0).astype(np.float32)


def render_ice(image, lattice, mass, *, look=None, size=None, return_layers=False):
    r"""Draw ice of the given per-cell mass on an image: one frame, for teaching and tests.

    Parameters
    ----------
    image : array_like or path
        The picture, with the lattice's image size.
    lattice : HexLattice
        The lattice.
    mass : array_like, shape (n_cells,)
        Ice mass of each cell (0: no ice; a frozen cell has at least 1), e.g.
        :func:`ice_mass`.
    look : FrostLook, optional
        How the ice is drawn.
    size : int, optional
        Longest side of the output in pixels.
    return_layers : bool
        Also return a dict of the layers over the whole picture: ``alpha`` (opacity
        of the ice), ``thickness`` (:math:`	heta`) and ``cover`` (how much of a pixel
        the ice covers, with the soft edge).

    Returns
    -------
    rgb : ndarray, shape (H, W, 3)
    layers : dict
        Only with ``return_layers=True``.

    Examples
    --------
    >>> from fluidnb.frost import FrostParams, HexLattice, grow, ice_mass
    >>> lat = HexLattice.hexagon(6, spacing=4)
    >>> plate = np.full((*lat.image_shape, 3), 0.3, np.float32)
    >>> np.array_equal(render_ice(plate, lat, np.zeros(lat.n_cells)), plate)  # no ice
    True
    >>> res = grow(lat, [lat.center_cell()], FrostParams(beta=0.5))
    >>> rgb, layers = render_ice(plate, lat, ice_mass(res, 100), return_layers=True)
    >>> float(layers["alpha"].max()) > 0.5
    True
    """
    look = FrostLook() if look is None else _check_look(look)
    if not isinstance(lattice, HexLattice):
        raise ValueError(f"lattice must be a HexLattice, got {type(lattice).__name__}")
    mass = np.asarray(mass, dtype=np.float32)
    if mass.shape != (lattice.n_cells,):
        raise ValueError(
            f"mass must have one value per cell ({lattice.n_cells},), got {mass.shape}"
        )
    base = _base(image, lattice, _out_shape(lattice, size))
    surface = _Surface(base, lattice, look)
    theta = _Thickness(lattice, look, mass)(mass)
    out = base.copy()
    alpha, th, cover = surface.compose(out, (mass > 0).astype(np.float32), theta)
    np.clip(out, 0.0, 1.0, out=out)
    if not return_layers:
        return out
    layers = {}
    for name, value in (("alpha", alpha), ("thickness", th), ("cover", cover)):
        full = np.zeros(out.shape[:2], np.float32)
        full[surface.box] = np.where(surface.region, value, 0.0)
        layers[name] = full
    return out, layers


def _check_look(look):
    if not isinstance(look, FrostLook):
        raise ValueError(f"look must be a FrostLook, got {type(look).__name__}")
    return look


#: The smallest picture frost is drawn on: the ice is shaded by its slope, a
#: difference between neighbouring pixels along each axis.
MIN_SIDE = 2


def check_image_size(shape, name="image"):
    """Raise ValueError unless an image of ``shape`` (H, W, ...) is big enough to draw on."""
    h, w = shape[:2]
    if min(h, w) < MIN_SIDE:
        raise ValueError(
            f"{name} is {h} x {w} pixels; frost needs at least {MIN_SIDE} x {MIN_SIDE} "
            "(the ice is shaded by its slope between neighbouring pixels)"
        )


def _out_shape(lattice, size):
    h0, w0 = lattice.image_shape
    if size is None:
        return (h0, w0)
    size = check_int("size", size, 8)
    scale = size / max(h0, w0)
    # A very long, thin picture keeps MIN_SIDE pixels across.
    return (max(MIN_SIDE, round(h0 * scale)), max(MIN_SIDE, round(w0 * scale)))


def _base(image, lattice, shape):
    h0, w0 = lattice.image_shape
    if image is None:
        base = np.empty((*shape, 3), np.float32)
        base[:] = np.array([0.16, 0.20, 0.26], np.float32)
        return base
    base = as_image(image, mode="rgb")
    if base.shape[:2] != (h0, w0):
        raise ValueError(f"image must have the lattice's size {(h0, w0)}, got {base.shape[:2]}")
    if shape != (h0, w0):
        from skimage.transform import resize

        base = resize(base, shape, order=1, anti_aliasing=True).astype(np.float32)
    return base


# The last small clip's background and surface, kept: a live preview draws the same
# picture on the same lattice again and again while a slider moves (only the growth
# changes), and building them (triangles, soft edge, blurred photo, grain) was a
# fifth of a preview's time. Only small pictures (a preview's).
_KEPT_PIXELS = 320 * 320
_SURFACE = LastKept()


def _surface(image, lattice, shape, look):
    """``(base, _Surface)`` for a clip: built, or the last ones if nothing they use changed."""
    keep = shape[0] * shape[1] <= _KEPT_PIXELS and (image is None or isinstance(image, np.ndarray))
    inputs = (image, lattice, shape, dict(vars(look)))
    if keep:
        found, value = _SURFACE.get(*inputs)
        if found:
            return value
    base = _base(image, lattice, shape)
    value = (base, _Surface(base, lattice, look))
    if keep:
        _SURFACE.keep(inputs, value)
    return value


def render(
    image,
    lattice,
    result,
    *,
    every=1,
    fps=None,
    size=None,
    look=None,
    frames=None,
    stream=False,
    progress=None,
):
    """Draw the frost growing as ice on the image: one clip frame per simulation step.

    Parameters
    ----------
    image : array_like or path, or None
        The background, with the lattice's image size (``None``: a dark blue-grey
        plate).
    lattice : HexLattice
        The lattice of the run.
    result : FrostResult
        What :func:`grow` returned (its :attr:`~FrostResult.freeze_frame` drives the
        frames).
    every : int
        Draw every k-th simulation frame (the clip's fps is divided by ``every`` so
        its timing is unchanged).
    fps : float, optional
        Frames per second of the simulation (default ``result.params.fps``).
    size : int, optional
        Longest side of the output in pixels (default: the image's size).
    look : FrostLook, optional
        Light, relief, opacity and the other settings of the ice.
    frames : int, optional
        Last simulation frame to draw (default: the end frame, or the last simulated
        frame if the run never ended).
    stream : bool
        Return a :class:`fluidnb.FrameStream` of the same frames instead of the clip:
        they are drawn as it is saved, a few at a time, so a file at full size needs
        memory for a few frames, not every step (docs/conventions.md, "Streams"). A
        clip held in memory is refused beyond 2 GiB of frames; a stream is not.
    progress : callable, optional
        ``progress(fraction, message)``.

    Returns
    -------
    Clip or FrameStream
        RGB frames, metadata ``method="frost"``, ``end_frame``, ``every``.

    Examples
    --------
    >>> from fluidnb.frost import HexLattice, grow
    >>> lat = HexLattice.hexagon(6, spacing=4)
    >>> res = grow(lat, [lat.center_cell()])
    >>> res.end_frame
    452
    >>> clip = render(None, lat, res, every=20)  # frames 0, 20, ..., 440 and 452
    >>> clip.n_frames, clip.shape == lat.image_shape, clip.fps
    (24, True, 1.2)
    """
    if not isinstance(lattice, HexLattice):
        raise ValueError(f"lattice must be a HexLattice, got {type(lattice).__name__}")
    if not isinstance(result, FrostResult):
        raise ValueError(f"result must be a FrostResult from grow(), got {type(result).__name__}")
    if result.freeze_frame.shape != (lattice.n_cells,):
        raise ValueError("result was grown on another lattice (its cell count differs)")
    check_image_size(lattice.image_shape, "the lattice's image")
    every = check_int("every", every, 1)
    fps = result.params.fps if fps is None else check_fps(fps)
    look = FrostLook() if look is None else _check_look(look)
    Progress(progress)  # a bad callback is refused now, not at the first frame
    started = time.perf_counter()

    shape = _out_shape(lattice, size)
    last = result.n_frames
    if frames is not None:
        last = check_int("frames", frames, 0, result.n_frames)
    elif result.end_frame is not None:
        last = min(result.n_frames, result.end_frame)
    steps = list(range(0, last + 1, every))
    if steps[-1] != last:
        steps.append(last)

    need = len(steps) * shape[0] * shape[1] * 3 * 4
    if need > _MAX_BYTES and not stream:
        fewer = int(np.ceil(need / _MAX_BYTES)) * every
        raise ValueError(
            f"the clip would hold {len(steps)} frames of {shape[1]}x{shape[0]} "
            f"({need / 2**30:.1f} GiB); draw every {_ordinal(fewer)} step (every={fewer}), "
            "use a smaller size, or stream it to a file (stream=True)"
        )
    base, surface = _surface(image, lattice, shape, look)
    freeze = result.freeze_frame.astype(np.float32)
    freeze[freeze < 0] = np.inf
    # One scale of thickness for the whole clip: that of the last frame drawn.
    thickness = _Thickness(lattice, look, ice_mass(result, last))
    setup = time.perf_counter() - started
    timings = {"grow": result.seconds, "render": setup}
    # Frames a block: about 32 MB of them (at 1920 px four frames).
    per = max(1, min(len(steps), (32 << 20) // (shape[0] * shape[1] * 3 * 4)))

    def blocks():
        report = Progress(progress)
        timings["render"] = setup  # each pass times itself
        for b0 in range(0, len(steps), per):
            clock = time.perf_counter()
            out = np.empty((min(per, len(steps) - b0), *shape, 3), np.float32)
            out[:] = base  # pixels outside the region never change
            for i, t in enumerate(steps[b0 : b0 + len(out)]):
                age = t - freeze  # frames since each cell froze (negative: not yet)
                cover = np.clip(age / look.fade + 1.0, 0.0, 1.0).astype(np.float32)  # fades in
                surface.compose(out[i], cover, ice_thickness(t))
                report((b0 + i + 1) / len(steps), f"frame {t}")
            np.clip(out, 0.0, 1.0, out=out)
            timings["render"] += time.perf_counter() - clock
            yield out

    def ice_thickness(t):
        return thickness(ice_mass(result, t))

    frames_of = FrameStream(
        blocks,
        n_frames=len(steps),
        shape=shape,
        color=True,
        fps=float(fps) / every,
        metadata=lambda: {
            "method": "frost",
            "params": result.params.to_dict(),
            "seed": result.seed,
            "end_frame": result.end_frame,
            "every": every,
            "frames": steps,
            "timings": dict(timings),
            "message": result.message,
        },
    )
    # The clip is the stream collected: one code path, the same frames.
    return frames_of if stream else frames_of.clip()
