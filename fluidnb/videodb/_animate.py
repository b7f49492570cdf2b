r"""Animating one fluid image from a video database (Okabe et al., secs. 5-6).

:func:`animate` = :func:`assign` + :func:`render`:

1. **cut** the target into fragments exactly as the database's (48 x 48, stride 24,
   the image padded by reflection to whole strides); only fragments touching the matte
   take part;
2. **candidates** (Eq. 1): each target fragment's visual words, the top-``k`` database
   fragments by spatial-pyramid histogram intersection, after dropping those whose mean
   motion disagrees with the user's direction / speed (Okabe et al., Fig. 8);
3. **MRF** (Eq. 4-6): :math:`V_p = 1 - I` (the paper writes :math:`V_p = I`, which a
   minimisation would turn into a reward for dissimilarity), :math:`W_{pq}` from the
   motion spectra and textureness over the overlap; three tables per edge kept, so a
   change of :math:`\sigma`, :math:`\lambda` or :math:`\rho` only recombines and
   re-solves (:meth:`Assignment.resolve`); alpha-expansion from two starts;
4. **render** (section 6): the assigned fragments' difference frames blended with
   Laplacian pyramids, added to the target blurred along the assigned motion, matched
   to the target's histograms cell by cell, composited through the (static or
   dynamic) matte over the untouched image.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass

import numpy as np

from .._clip import Clip
from .._image import as_image
from .._progress import Progress
from .._validation import check_array, check_shape_match, check_vector_field
from ._geometry import FRAGMENT, STRIDE
from ._params import AnimateParams
from ._store import VideoDatabase, open_database

__all__ = [
    "TEXTURE_SCALE",
    "Animation",
    "Assignment",
    "Target",
    "animate",
    "assign",
    "cut_target",
    "fragment_motion",
    "render",
]

# Intersection scores are integers out of this (Lazebnik weights 1, 1, 2 on 81 words).
_SCORE_MAX = 324


@dataclass(frozen=True, eq=False)
class Target:
    """The target image cut into fragments as the database's (Okabe et al., sec. 5).

    Attributes
    ----------
    image : ndarray, shape (H, W, 3), float32
        The target photo.
    matte : ndarray, shape (H, W), float32
        Its alpha matte in [0, 1] (1 everywhere when none was given).
    canvas : ndarray, shape (Hc, Wc, 3), float32
        The image padded by reflection at the bottom and right to whole strides.
    canvas_matte : ndarray, shape (Hc, Wc), float32
        The matte padded with zeros.
    active : ndarray, shape (R, C), bool
        Fragments of the grid that touch the matte (they take part).
    positions : ndarray, shape (P, 2), int64
        Top-left (row, col) of the taking-part fragments on the canvas, raster order.
    fragments : ndarray, shape (P, 48, 48, 3), float32
        Their pixels.
    """

    image: np.ndarray
    matte: np.ndarray
    canvas: np.ndarray
    canvas_matte: np.ndarray
    active: np.ndarray
    positions: np.ndarray
    fragments: np.ndarray

    @property
    def shape(self):
        """(H, W) of the image."""
        return self.image.shape[:2]

    def __len__(self):
        return len(self.positions)


def cut_target(image, matte=None):
    """Cut a target image into the fragments that take part (Okabe et al., sec. 5, Fig. 2-i).

    Parameters
    ----------
    image : array_like or path, shape (H, W, 3), (H, W) or (H, W, 4)
        The photo or painting (any form :func:`fluidnb.as_image` reads). With an alpha
        channel and no ``matte``, the alpha is the matte.
    matte : array_like or path, shape (H, W), optional
        The fluid region's alpha matte in [0, 1] (a painted mask works too). Default:
        the alpha channel, else the whole image.

    Returns
    -------
    Target

    Raises
    ------
    ValueError
        For an image smaller than a fragment, a matte of another size, an empty matte,
        or NaN.

    Examples
    --------
    >>> t = cut_target(np.zeros((60, 100, 3), np.float32))
    >>> t.canvas.shape, t.active.shape, len(t)
    ((72, 120, 3), (2, 4), 8)
    """
    rgb, alpha = as_image(image, mode="rgb", name="image", return_alpha=True)
    h, w = rgb.shape[:2]
    if min(h, w) < FRAGMENT:
        raise ValueError(
            f"image must be at least {FRAGMENT} x {FRAGMENT} pixels (one fragment), got {h} x {w}"
        )
    if matte is None:
        m = np.ones((h, w), np.float32) if alpha is None else alpha
    else:
        m = as_image(matte, mode="grey", name="matte")
        check_shape_match("matte", m, (h, w))
    if not (m > 0).any():
        raise ValueError("matte is empty: paint the fluid region (at least one pixel)")
    if alpha is not None:
        # Premultiplied: the colour of transparent pixels is junk, not fluid.
        rgb = rgb * alpha[..., None]
    hc = -(-h // STRIDE) * STRIDE
    wc = -(-w // STRIDE) * STRIDE
    canvas = np.pad(rgb, ((0, hc - h), (0, wc - w), (0, 0)), mode="reflect")
    cmatte = np.zeros((hc, wc), np.float32)
    cmatte[:h, :w] = m
    rows, cols = (hc - FRAGMENT) // STRIDE + 1, (wc - FRAGMENT) // STRIDE + 1
    touched = np.zeros((rows, cols), bool)
    inside = cmatte > 0
    for i in range(rows):
        for j in range(cols):
            r, c = i * STRIDE, j * STRIDE
            touched[i, j] = inside[r : r + FRAGMENT, c : c + FRAGMENT].any()
    grid = np.argwhere(touched)
    positions = (grid * STRIDE).astype(np.int64)
    offs = np.arange(FRAGMENT)
    frags = canvas[positions[:, 0, None, None] + offs[:, None], positions[:, 1, None, None] + offs]
    return Target(
        image=rgb.astype(np.float32),
        matte=m.astype(np.float32),
        canvas=canvas.astype(np.float32),
        canvas_matte=cmatte,
        active=touched,
        positions=positions,
        fragments=frags.astype(np.float32),
    )


def _as_database(db, progress=None):
    """A VideoDatabase from a database, a folder, or a starter kind's name."""
    if isinstance(db, VideoDatabase):
        return db
    from ._starter import starter_database
    from ._starter_clips import STARTER_KINDS

    if isinstance(db, str) and db in STARTER_KINDS:
        return starter_database(db, progress=progress)
    kinds = ", ".join(repr(k) for k in STARTER_KINDS)
    if isinstance(db, (str, os.PathLike)):
        if not os.path.exists(db):
            raise ValueError(
                f"db must be a VideoDatabase, a database folder, or one of {kinds}, got "
                f"{str(db)!r} (no such folder)"
            )
        return open_database(db, progress=progress)
    raise ValueError(
        f"db must be a VideoDatabase, a database folder, or one of {kinds}, got {type(db).__name__}"
    )


def fragment_motion(target, direction=None, speed=None):
    """The user's motion over each target fragment (Okabe et al., sec. 5, Fig. 8).

    Parameters
    ----------
    target : Target
    direction : sequence of strokes, or ndarray (H, W, 2), optional
        Flow strokes ((n, 2) polylines in (row, col) pixels, drawn along the flow),
        interpolated over the image with radial basis functions
        (:func:`fluidnb.sketch.direction_field`), or a direction field (dy, dx) whose
        zero vectors mean "no direction here".
    speed : ndarray (H, W), optional
        Speed in px/frame; 0 means "not painted here".

    Returns
    -------
    direction : ndarray, shape (P, 2) or None
        Unit mean direction over each fragment's pixels, NaN where none.
    speed : ndarray, shape (P,) or None
        Mean painted speed over each fragment's painted pixels, NaN where none.
    field : ndarray, shape (H, W, 2) or None
        The direction field over the image.
    """
    h, w = target.shape
    field = dirs = speeds = None
    if direction is not None:
        arr = direction if isinstance(direction, np.ndarray) and direction.ndim == 3 else None
        if arr is None:
            from ..sketch import direction_field

            field = direction_field(direction, (h, w))
        else:
            field = check_vector_field("direction", arr, shape=(h, w)).astype(np.float32)
        sums = _fragment_means(target, np.concatenate([field, np.ones((h, w, 1))], axis=2))
        dirs = sums[:, :2]
        norm = np.linalg.norm(dirs, axis=1, keepdims=True)
        dirs = np.where(norm > 1e-6, dirs / np.maximum(norm, 1e-12), np.nan)
    if speed is not None:
        s = check_array("speed", speed, ndim=2, dtype_kinds="biuf").astype(np.float32)
        check_shape_match("speed", s, (h, w))
        if s.min() < 0:
            raise ValueError(f"speed must be >= 0 px/frame (0: not painted), got {s.min():g}")
        painted = (s > 0).astype(np.float32)
        num = _fragment_means(target, (s * painted)[..., None])[:, 0]
        den = _fragment_means(target, painted[..., None])[:, 0]
        speeds = np.where(den > 0, num / np.maximum(den, 1e-12), np.nan)
    return dirs, speeds, field


def _fragment_means(target, field):
    """Mean of an (H, W, C) field over each taking-part fragment's 48 x 48 pixels."""
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    padded = np.zeros((hc, wc, field.shape[2]), np.float64)
    padded[:h, :w] = field
    covered = np.zeros((hc, wc), np.float64)
    covered[:h, :w] = 1.0
    ii = np.pad(padded.cumsum(0).cumsum(1), ((1, 0), (1, 0), (0, 0)))
    ci = np.pad(covered.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    r0, c0 = target.positions[:, 0], target.positions[:, 1]
    r1, c1 = r0 + FRAGMENT, c0 + FRAGMENT
    total = ii[r1, c1] - ii[r0, c1] - ii[r1, c0] + ii[r0, c0]
    count = ci[r1, c1] - ci[r0, c1] - ci[r1, c0] + ci[r0, c0]
    return total / np.maximum(count, 1.0)[:, None]


@dataclass(frozen=True, eq=False)
class Assignment:
    r"""Which database fragment animates each target fragment (Okabe et al., sec. 5).

    Made by :func:`assign`. It keeps the candidates, the data term and the three
    smoothness tables, so :meth:`resolve` re-solves for other :math:`\sigma`,
    :math:`\lambda`, :math:`\rho` in a fraction of a second.

    Attributes
    ----------
    db : VideoDatabase
    target : Target
    params : AnimateParams
    candidates : ndarray, shape (P, K), int64
        Per target fragment, its ``K`` candidate database fragments (Eq. 1, after
        the motion filter), best first.
    scores : ndarray, shape (P, K), int32
        Their intersection scores out of 324.
    n_eligible : ndarray, shape (P,)
        Database fragments that passed the user's motion filter (all: no filter).
    unary : ndarray, shape (P, K), float64
        :math:`V_p = 1 - I` (Eq. 5, spec decision: the paper's :math:`V_p = I` would
        reward dissimilarity under minimisation).
    edges : ndarray, shape (E, 2)
        Neighbouring target fragments (4-neighbourhood).
    tables : PairTables
        The three per-edge tables of Eq. (2), (3), (6).
    solution : MRFSolution
        Labels, energy per sweep, ICM's energy (Eq. 4).
    direction, speed : ndarray or None
        The user's motion per fragment (NaN: none); ``field`` the direction field.
    timings : dict
        Seconds per stage.
    """

    db: VideoDatabase
    target: Target
    params: AnimateParams
    candidates: np.ndarray
    scores: np.ndarray
    n_eligible: np.ndarray
    unary: np.ndarray
    edges: np.ndarray
    tables: object
    solution: object
    direction: object = None
    speed: object = None
    field: object = None
    timings: dict = dataclasses.field(default_factory=dict)

    @property
    def labels(self):
        """The chosen label (candidate index) of every target fragment."""
        return self.solution.labels

    @property
    def fragments(self):
        """The database fragment id assigned to every target fragment, (P,)."""
        return self.candidates[np.arange(len(self.candidates)), self.solution.labels]

    @property
    def energies(self):
        """The energy (Eq. 4) at the start and after every alpha-expansion sweep."""
        return self.solution.energies

    def pairwise(self, sigma=None, rho=None):
        """:math:`W_{pq}` (Eq. 6) for every edge and label pair, (E, K, K)."""
        sigma = self.params.sigma if sigma is None else sigma
        rho = self.params.rho if rho is None else rho
        return self.tables.smoothness(sigma, rho * TEXTURE_SCALE)

    def resolve(self, *, sigma=None, lam=None, rho=None, progress=None):
        r"""Re-solve the MRF for new :math:`\sigma`, :math:`\lambda`, :math:`\rho`.

        The candidates and the three tables are kept: only Eq. (6) is recombined and
        Eq. (4) minimised again (a fraction of a second).

        Returns
        -------
        Assignment
        """
        from ._mrf import solve

        changes = {k: v for k, v in (("sigma", sigma), ("lam", lam), ("rho", rho)) if v is not None}
        params = self.params.replace(**changes)
        started = time.perf_counter()
        solution = solve(
            self.unary,
            self.pairwise(params.sigma, params.rho),
            self.edges,
            params.lam,
            progress=progress,
        )
        timings = {**self.timings, "resolve": time.perf_counter() - started}
        return dataclasses.replace(self, params=params, solution=solution, timings=timings)

    def motion_field(self):
        """The assigned fragments' mean motion blended over the image, (H, W, 2)."""
        h, w = self.target.shape
        return _blend_vectors(self.target, self.db.mean_motion[self.fragments])[:h, :w]

    def speed_map(self):
        """The speed of :meth:`motion_field` (px/frame), to edit as the paper advises."""
        return np.linalg.norm(self.motion_field(), axis=-1).astype(np.float32)

    def clip_map(self):
        """Per pixel, the source clip of the fragment whose cell holds it (-1: none)."""
        h, w = self.target.shape
        hc, wc = self.target.canvas.shape[:2]
        out = np.full((hc, wc), -1, np.int64)
        clips = self.db.clip_of(self.fragments)
        quarter = STRIDE // 2
        # Each fragment owns the 24 x 24 cell at its centre (where its weight peaks).
        for (r, c), k in zip(self.target.positions, clips):
            out[r + quarter : r + quarter + STRIDE, c + quarter : c + quarter + STRIDE] = k
        return out[:h, :w]


#: The unit of the textureness term: Eq. (6) is ``smooth + rho * TEXTURE_SCALE *
#: texture``. The paper's units are unknown; ours are (px/frame)^2 for the motion
#: terms and luminance in [0, 1] summed over the N frames for the textureness, which
#: is ~10^5 times larger. With this factor the paper's rho = 100 sigma = 10^4 weighs
#: the textureness about as much as the mean motion: medians over candidate pairs on
#: the starter databases, DC term / rho-scaled textureness, water 1290 / 1180, smoke
#: 3980 / 4590, fire 8580 / 1160.
TEXTURE_SCALE = 1e-5


def _blend_vectors(target, vectors):
    """Per-fragment values (P, ..., C) spread over the canvas by the blend's weights."""
    from ._blend import blend_values

    return blend_values(vectors, target.positions, target.canvas.shape[:2])


def assign(
    image, matte=None, db="water", params=None, *, direction=None, speed=None, progress=None
):
    r"""Choose a database fragment for every fragment of the target (Okabe et al., sec. 5).

    Parameters
    ----------
    image : array_like or path, shape (H, W, 3)
        The target: a photo or painting of fluid (RGBA: its alpha is the matte).
    matte : array_like or path, shape (H, W), optional
        The fluid region (alpha matte in [0, 1]); default the alpha channel, else
        the whole image.
    db : VideoDatabase, path, or {"water", "smoke", "fire"}
        The database (a starter kind is built on first use and cached).
    params : AnimateParams, optional
        Default :meth:`AnimateParams.for_kind` of the database's kind.
    direction : strokes or ndarray (H, W, 2), optional
        The flow direction (Okabe et al., Fig. 8-a, b); see :func:`fragment_motion`.
    speed : ndarray (H, W), optional
        The speed map in px/frame, 0 where not painted (Okabe et al., Fig. 8-c).
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    Assignment
    """
    from ._mrf import grid_edges, pair_tables, solve

    report = Progress(progress)
    load, describe, retrieve, tables, solving = report.split(0.1, 0.2, 0.45, 0.9)
    clock = {}
    t0 = time.perf_counter()
    db = _as_database(db, load)
    params = _check_params(params, db)
    target = cut_target(image, matte)
    if len(target) == 0:
        raise ValueError("matte is empty: paint the fluid region")
    dirs, speeds, field = fragment_motion(target, direction, speed)
    clock["load"] = time.perf_counter() - t0

    t = time.perf_counter()
    describe(0.0, f"describing {len(target)} target fragments (dense SIFT, visual words)")
    words = db.describe(target.fragments)
    clock["describe"] = time.perf_counter() - t

    t = time.perf_counter()
    k = params.candidates
    if k > db.n_fragments:
        raise ValueError(
            f"candidates ({k}) is larger than the database ({db.n_fragments} fragments): "
            "lower candidates or use a larger database"
        )
    retrieve(0.0, f"top {k} candidates by histogram intersection (Eq. 1)")
    top = db.index.top_k(
        words,
        k,
        direction=dirs,
        speed=speeds,
        max_angle=params.max_angle,
        max_speed_ratio=params.max_speed_ratio,
    )
    unary = 1.0 - top.scores.astype(np.float64) / _SCORE_MAX
    clock["retrieval"] = time.perf_counter() - t

    t = time.perf_counter()
    _, edges, horizontal = grid_edges(target.active)
    tabs = pair_tables(top.ids, edges, horizontal, db.spectra, db.texture, progress=tables)
    clock["tables"] = time.perf_counter() - t

    t = time.perf_counter()
    pairwise = tabs.smoothness(params.sigma, params.rho * TEXTURE_SCALE)
    solution = solve(unary, pairwise, edges, params.lam, progress=solving)
    clock["solve"] = time.perf_counter() - t
    clock["total"] = time.perf_counter() - t0
    return Assignment(
        db=db,
        target=target,
        params=params,
        candidates=top.ids,
        scores=top.scores,
        n_eligible=top.n_eligible,
        unary=unary,
        edges=edges,
        tables=tabs,
        solution=solution,
        direction=dirs,
        speed=speeds,
        field=field,
        timings=clock,
    )


def _check_params(params, db):
    if params is None:
        return AnimateParams.for_kind(db.kind)
    if not isinstance(params, AnimateParams):
        raise ValueError(f"params must be an AnimateParams, got {type(params).__name__}")
    return params


#: Context around each fragment rebuilt for the blend (the render's phase tiles: 3 x 24
#: pixels apart, 12 px of a fragment's own surroundings fill the gap).
_MARGIN = 12


@dataclass(frozen=True, eq=False)
class Animation:
    """An animated fluid image and how it was made (Okabe et al., secs. 5-6).

    Attributes
    ----------
    clip : Clip
        The animation (the target's size, ``N`` frames, or ``N - loop`` looping).
    assignment : Assignment
        The fragments chosen, with the energy per sweep.
    stages : dict of ndarray
        The rendering's intermediate pictures, for the lesson: ``"differences"`` the
        blended difference frames :math:`D_i` (T, H, W), ``"mean"`` the approximate
        mean image (H, W, 3), ``"unmatched"`` the frames before histogram matching,
        ``"matte"`` the (dynamic) matte :math:`B_i` (T, H, W), ``"background"`` the
        image behind the fluid.
    timings : dict
        Seconds per stage (assignment and rendering).
    """

    clip: Clip
    assignment: Assignment
    stages: dict
    timings: dict


def render(assignment, params=None, *, background=None, fps=24.0, progress=None):
    r"""Render the animation of an assignment (Okabe et al., sec. 6).

    1. Rebuild every assigned fragment's frames from its source clip (with 12 px of
       context) and its difference frames :math:`D_i = F_i - A` (luminance);
    2. blend them with Laplacian pyramids over the overlaps
       (:func:`blend_differences`) and, with ``loop``, cross-fade the end into the
       start (:func:`loop_crossfade`);
    3. add them to the approximate mean image: the target blurred along the assigned
       motion (:func:`motion_blur`);
    4. match each frame's histograms to the target's cell by cell
       (:func:`match_histograms_cells`), in the principal axes of the target's
       colours (Heeger & Bergen's decorrelation), so no foreign hue appears;
    5. composite through the matte over the untouched image — for ``tau > 0`` through
       the dynamic matte :math:`B_i` (:func:`dynamic_matte`) over the background
       (given, or inpainted behind the fluid, :func:`inpaint_background`).

    Parameters
    ----------
    assignment : Assignment
    params : AnimateParams, optional
        Rendering settings (shutter, denoise, cell, tau, loop); default the
        assignment's.
    background : array_like, shape (H, W, 3), optional
        What shows where a moving outline uncovers the scene (``tau > 0``); default
        the target inpainted under its matte.
    fps : float
        Frame rate of the clip.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    Animation
    """
    from ._appearance import match_histograms_cells, motion_blur
    from ._blend import blend_differences
    from ._composite import composite, dynamic_matte, inpaint_background, loop_crossfade

    if not isinstance(assignment, Assignment):
        raise ValueError(f"assignment must be an Assignment, got {type(assignment).__name__}")
    params = assignment.params if params is None else _check_params(params, assignment.db)
    db, target = assignment.db, assignment.target
    n = db.params.N
    if params.loop > n // 2:
        raise ValueError(
            f"loop must be <= N/2 = {n // 2} frames for this database, got {params.loop}"
        )
    h, w = target.shape
    hc, wc = target.canvas.shape[:2]
    if background is not None:
        background = as_image(background, mode="rgb", name="background")
        check_shape_match("background", background, (h, w))
    report = Progress(progress)
    rebuild, blend, mean, match, comp = report.split(0.35, 0.6, 0.7, 0.9)
    clock = {}

    t = time.perf_counter()
    rebuild(0.0, f"rebuilding {len(target)} fragments from their source clips")
    ids = assignment.fragments
    diffs = np.empty((len(ids), n, FRAGMENT + 2 * _MARGIN, FRAGMENT + 2 * _MARGIN), np.float32)
    step = 32
    for lo in range(0, len(ids), step):
        frames = db.fragment_frames(ids[lo : lo + step], margin=_MARGIN, grey=True)
        diffs[lo : lo + step] = frames - frames.mean(axis=1, keepdims=True)  # D_i = F_i - A
        rebuild(min(1.0, (lo + step) / len(ids)), "rebuilding fragments")
    clock["rebuild"] = time.perf_counter() - t

    t = time.perf_counter()
    blend(0.0, "blending the difference frames (Laplacian pyramids)")
    d = blend_differences(diffs, target.positions, (hc, wc), margin=_MARGIN)
    del diffs
    if params.loop:
        d = loop_crossfade(d, overlap=params.loop)
    clock["blend"] = time.perf_counter() - t

    t = time.perf_counter()
    mean(0.0, "approximate mean image (pseudo motion blur)")
    velocity = _blend_vectors(target, db.mean_motion[ids])
    approx = motion_blur(target.canvas, velocity, shutter=params.shutter, denoise=params.denoise)
    frames = approx[None] + d[..., None]
    clock["mean"] = time.perf_counter() - t

    t = time.perf_counter()
    match(0.0, "matching histograms cell by cell")
    # In the target's principal colour axes (Heeger & Bergen 1995 decorrelate colour by
    # PCA): matching R, G and B independently can mix hues the photo does not have (a
    # white-hot flame turned lilac); matching decorrelated axes keeps its colours.
    centre, axes = _colour_axes(target.canvas, target.canvas_matte)
    matched = match_histograms_cells(
        (frames - centre) @ axes,
        (target.canvas - centre) @ axes,
        target.canvas_matte,
        cell=params.cell,
    )
    matched = matched @ axes.T + centre
    clock["match"] = time.perf_counter() - t

    t = time.perf_counter()
    comp(0.0, "compositing")
    if params.tau > 0:
        motion = _blend_vectors(target, db.motion[ids])  # (Hc, Wc, N - 1, 2)
        motion = np.moveaxis(motion, 2, 0)[: len(matched) - 1]
        matte = dynamic_matte(target.canvas_matte, motion, tau=params.tau)
        if background is None:
            back = inpaint_background(target.canvas, target.canvas_matte)
        else:
            back = target.canvas.copy()
            back[:h, :w] = background
    else:
        matte = target.canvas_matte
        back = target.canvas
    out = composite(matched, back, matte)[:, :h, :w]
    np.clip(out, 0.0, 1.0, out=out)
    clock["composite"] = time.perf_counter() - t
    comp(1.0, "done")

    timings = {**{f"assign_{k}": v for k, v in assignment.timings.items()}, **clock}
    timings["render"] = sum(clock.values())
    meta = {
        "method": "videodb",
        "params": params.to_dict(),
        "seed": None,
        "timings": timings,
        "database": {
            "path": str(db.path),
            "kind": db.kind,
            "fragments": db.n_fragments,
        },
        "energy": float(assignment.solution.energy),
    }
    clip = Clip(out, fps=fps, metadata=meta)
    stages = {
        "differences": d[:, :h, :w],
        "mean": np.clip(approx[:h, :w], 0, 1),
        "unmatched": np.clip(frames[:, :h, :w], 0, 1),
        "matte": (matte if matte.ndim == 3 else np.broadcast_to(matte, (len(out), hc, wc)))[
            :, :h, :w
        ],
        "background": back[:h, :w],
    }
    return Animation(clip=clip, assignment=assignment, stages=stages, timings=timings)


def _colour_axes(image, matte):
    """Mean colour and principal axes (3, 3) of the image's pixels inside the matte."""
    pix = image[matte > 0.5] if (matte > 0.5).any() else image.reshape(-1, 3)
    centre = pix.mean(axis=0)
    cov = np.cov((pix - centre).T.astype(np.float64)) + 1e-9 * np.eye(3)
    _, vecs = np.linalg.eigh(cov)
    return centre.astype(np.float32), vecs[:, ::-1].astype(np.float32)


def animate(
    image,
    matte=None,
    db="water",
    params=None,
    *,
    direction=None,
    speed=None,
    background=None,
    fps=24.0,
    seed=None,
    progress=None,
):
    r"""Animate a still image of fluid from a video database (Okabe et al. 2011).

    :func:`assign` (retrieval, Eq. 1; the MRF of Eq. 4-6 by alpha-expansion) then
    :func:`render` (section 6). The method is deterministic; ``seed`` is accepted for
    the library's convention and recorded.

    Parameters
    ----------
    image, matte, db, params, direction, speed
        As for :func:`assign`.
    background, fps
        As for :func:`render`.
    seed : None, int or numpy.random.Generator
        Nothing here is random; the int :func:`fluidnb.resolve_seed` makes of it is
        recorded in the clip's metadata, as every method does.
    progress : callable, optional
        ``progress(fraction, message)``; raise :class:`fluidnb.Cancelled` to stop.

    Returns
    -------
    Animation
        ``.clip`` is the animation.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Computer Graphics Forum 30(7) (Pacific Graphics 2011),
       sections 5-6.
    """
    from .._random import resolve_seed

    seed = resolve_seed(seed)  # validated and recorded, as at every entry point
    first, second = Progress(progress).split(0.5)
    assignment = assign(image, matte, db, params, direction=direction, speed=speed, progress=first)
    result = render(assignment, background=background, fps=fps, progress=second)
    meta = result.clip.metadata
    meta["seed"] = seed
    return dataclasses.replace(result, clip=result.clip.with_metadata(**meta))
