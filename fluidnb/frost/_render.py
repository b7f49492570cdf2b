"""Drawing frost over an image from the cells' freeze frames (spec: Rendering).

Each pixel of the region is covered by one triangle of three neighbouring lattice
points; it shows the piecewise-linear (barycentric) blend of their ice. Ice arms are
therefore one spacing wide with smooth edges rather than a mosaic of hexagons, and
each cell fades in over a couple of frames so the front moves smoothly. The frost
look: a translucent white-blue layer that thickens and cools with age, a bright glint
at the growth front, a soft halo around the ice, and a fixed sparkle texture.
"""

from __future__ import annotations

import time

import numpy as np

from .._clip import Clip
from .._image import as_image
from .._progress import Progress
from .._validation import check_int, check_range
from ._lattice import ROW, HexLattice
from ._reiter import FrostResult

__all__ = ["FrostLook", "render"]

# Colours (linear RGB in [0, 1]): new ice is nearly white, old ice settles to a pale
# blue; the halo is a cold white mist.
_FRESH = np.array([0.97, 0.99, 1.0], np.float32)
_OLD = np.array([0.74, 0.85, 0.96], np.float32)
_HALO = np.array([0.86, 0.93, 1.0], np.float32)
# Refuse clips larger than this (float32 RGB frames) with a clear message, not a crash.
_MAX_BYTES = 2 * 2**30


class FrostLook:
    """Look of the frost layer (all in [0, 1] unless stated).

    Parameters
    ----------
    opacity : float
        Opacity of fully grown frost.
    fade : float
        Frames over which a newly frozen cell fades in (> 0).
    settle : float
        Frames over which ice goes from fresh white to settled blue, and thickens.
    glint : float
        Brightness of the glint at the growth front.
    halo : float
        Strength of the mist around the ice.
    sparkle : float
        Strength of the fixed sparkle texture.
    """

    def __init__(self, opacity=0.9, fade=2.0, settle=30.0, glint=0.6, halo=0.25, sparkle=0.2):
        self.opacity = check_range("opacity", opacity, 0, 1)
        self.fade = check_range("fade", fade, 0, lo_open=True)
        self.settle = check_range("settle", settle, 0, lo_open=True)
        self.glint = check_range("glint", glint, 0, 1)
        self.halo = check_range("halo", halo, 0, 1)
        self.sparkle = check_range("sparkle", sparkle, 0, 1)


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


def _skeleton(lattice, freeze, last):
    """How much each cell belongs to a dendrite arm rather than the later infill, 0..1.

    Arms freeze well before the cells around them: compare each cell's freeze frame
    with the mean over its neighbourhood (three rings); the infill that froze last
    scores 0, the arm tips and trunks near 1.
    """
    f = np.where(freeze < 0, last + 1, freeze).astype(np.float32)
    around = _cell_halo(lattice, f, passes=3)
    lead = np.maximum(around - f, 0.0)
    scale = np.percentile(lead, 90) if lead.size else 0.0
    return np.clip(lead / scale, 0.0, 1.0) if scale > 0 else np.zeros_like(lead)


def _sparkle(shape, seed=12345):
    """A fixed glitter texture in [0, 1]: sparse bright specks on a fine grain."""
    g = np.random.default_rng(seed)
    grain = g.random(shape, dtype=np.float32)
    specks = (g.random(shape, dtype=np.float32) > 0.985).astype(np.float32)
    return 0.5 * grain + 0.5 * specks


def _cell_halo(lattice, value, passes=2):
    """Average each cell with its neighbours a few times: a cheap mist around ice."""
    n = lattice.n_cells
    nbrs = lattice.neighbours[:n]
    ok = (nbrs >= 0) & (nbrs < n)
    safe = np.where(ok, nbrs, 0)
    out = value
    for _ in range(passes):
        out = (out + (out[safe] * ok).sum(axis=1)) / 7.0
    return out


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
    progress=None,
):
    """Draw the frost growth over an image: one clip frame per simulation step.

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
        Colours and strengths of the frost layer.
    frames : int, optional
        Last simulation frame to draw (default: the end frame, or the last simulated
        frame if the run never ended).
    progress : callable, optional
        ``progress(fraction, message)``.

    Returns
    -------
    Clip
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
    every = check_int("every", every, 1)
    fps = result.params.fps if fps is None else check_range("fps", fps, 0, lo_open=True)
    look = FrostLook() if look is None else look
    if not isinstance(look, FrostLook):
        raise ValueError(f"look must be a FrostLook, got {type(look).__name__}")
    report = Progress(progress)
    started = time.perf_counter()

    h0, w0 = lattice.image_shape
    if size is not None:
        size = check_int("size", size, 8)
        scale = size / max(h0, w0)
        shape = (max(1, round(h0 * scale)), max(1, round(w0 * scale)))
    else:
        shape = (h0, w0)
    last = result.n_frames
    if frames is not None:
        last = check_int("frames", frames, 0, result.n_frames)
    elif result.end_frame is not None:
        last = min(result.n_frames, result.end_frame)
    steps = list(range(0, last + 1, every))
    if steps[-1] != last:
        steps.append(last)

    need = len(steps) * shape[0] * shape[1] * 3 * 4
    if need > _MAX_BYTES:
        fewer = int(np.ceil(need / _MAX_BYTES)) * every
        raise ValueError(
            f"the clip would hold {len(steps)} frames of {shape[1]}x{shape[0]} "
            f"({need / 2**30:.1f} GiB); draw every {fewer}th step (every={fewer}) or "
            "use a smaller size"
        )
    if image is None:
        base = np.empty((*shape, 3), np.float32)
        base[:] = np.array([0.16, 0.20, 0.26], np.float32)
    else:
        base = as_image(image, mode="rgb")
        if base.shape[:2] != (h0, w0):
            raise ValueError(f"image must have the lattice's size {(h0, w0)}, got {base.shape[:2]}")
        if shape != (h0, w0):
            from skimage.transform import resize

            base = resize(base, shape, order=1, anti_aliasing=True).astype(np.float32)

    index, weights, region = _triangles(lattice, shape)
    pix = np.flatnonzero(region)
    idx = index.reshape(3, -1)[:, pix]
    wts = weights.reshape(3, -1)[:, pix]
    valid = idx >= 0
    idx = np.where(valid, idx, 0)
    wts = np.where(valid, wts, 0.0).astype(np.float32)
    texture = _sparkle(shape).ravel()[pix]

    freeze = result.freeze_frame.astype(np.float32)
    never = freeze < 0
    freeze[never] = np.inf
    skeleton = _skeleton(lattice, result.freeze_frame, last)
    base_px = base.reshape(-1, 3)[pix]
    # Frosted surface under the crystals: desaturated, brighter and colder.
    grey = base_px.mean(axis=1, keepdims=True)
    frosted = 0.55 * grey + 0.45 * _HALO
    out = np.empty((len(steps), *shape, 3), np.float32)
    out[:] = base  # pixels outside the region never change
    feat = np.empty((lattice.n_cells, 5), np.float32)
    for n, t in enumerate(steps):
        age = t - freeze  # frames since each cell froze (negative: not yet)
        grown = age >= 0
        feat[:, 0] = np.clip(age / look.fade + 1.0, 0.0, 1.0)  # fades in
        feat[:, 1] = np.where(grown, np.clip(age / look.settle, 0.0, 1.0), 0.0)
        feat[:, 2] = np.where(grown, np.exp(-np.maximum(age, 0.0) / 2.0), 0.0)  # front
        feat[:, 3] = _cell_halo(lattice, feat[:, 0])
        feat[:, 4] = skeleton * feat[:, 0]
        # One gather for all features, blended with the barycentric weights.
        px = np.einsum("kp,kpf->pf", wts, feat[idx])
        cover, mature, glow, mist, skel = px.T
        cover = cover * cover * (3.0 - 2.0 * cover)  # smoothstep: crisp arm edges
        layer = base_px + (_HALO - base_px) * (look.halo * np.clip(mist - cover, 0, 1))[:, None]
        layer += (frosted - layer) * (0.7 * cover)[:, None]
        colour = _FRESH + (_OLD - _FRESH) * (0.7 * mature * (1.0 - skel))[:, None]
        colour += look.glint * glow[:, None] * (1.0 - colour)
        alpha = look.opacity * cover * (0.35 + 0.65 * np.maximum(skel, 0.2 * mature))
        alpha *= 1.0 - look.sparkle + look.sparkle * texture
        layer += (colour - layer) * alpha[:, None]
        layer += (look.sparkle * cover * (texture > 0.9))[:, None]
        out[n].reshape(-1, 3)[pix] = layer
        report((n + 1) / len(steps), f"frame {t}")
    np.clip(out, 0.0, 1.0, out=out)
    metadata = {
        "method": "frost",
        "params": result.params.to_dict(),
        "seed": result.seed,
        "end_frame": result.end_frame,
        "every": every,
        "frames": steps,
        "timings": {"grow": result.seconds, "render": time.perf_counter() - started},
        "message": result.message,
    }
    # Frames are a fresh array owned here: hand them over without another copy.
    return Clip._trusted(out, float(fps) / every, {}).with_metadata(**metadata)
