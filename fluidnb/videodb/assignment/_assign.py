r"""Which database fragment animates each target fragment (Okabe et al., sec. 5).

:func:`assign`:

1. **cut** the target into fragments exactly as the database's
   (:func:`~fluidnb.videodb.assignment.cut_target`); only fragments touching the matte take part;
2. **candidates** (Eq. 1): each target fragment's visual words, the top-``k`` database
   fragments by spatial-pyramid histogram intersection, after dropping those whose mean
   motion disagrees with the user's direction / speed (Okabe et al., Fig. 8);
3. **MRF** (Eq. 4-6): :math:`V_p = 1 - I` (the paper writes :math:`V_p = I`, which a
   minimisation would turn into a reward for dissimilarity), :math:`W_{pq}` from the
   motion spectra and textureness over the overlap; three tables per edge kept, so a
   change of :math:`\sigma`, :math:`\lambda` or :math:`\rho` only recombines and
   re-solves (:meth:`Assignment.resolve`); alpha-expansion from two starts.

The :class:`Assignment` it returns also answers what a lesson or an app asks of it:
what a fragment got (:meth:`Assignment.fragment_info`, :meth:`Assignment.fragment_at`),
the assigned motion as a field (:meth:`Assignment.motion_field`,
:meth:`Assignment.speed_map`), which clip owns each pixel (:meth:`Assignment.clip_map`),
the chosen fragments' looks (:meth:`Assignment.mean_image_mosaic`) and how well their
motions agree (:meth:`Assignment.motion_coherence`).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ..._progress import Progress
from ..._validation import check_finite, check_int, check_range
from .._common._geometry import FRAGMENT, STRIDE, VERSIONS
from .._common._params import AnimateParams
from .._common._weights import blend_values, fragment_weights
from ..database._kinds import as_database
from ..database._store import VideoDatabase
from ..database._words import HISTOGRAM_TOTAL
from ._mrf import _finite, _problem, _tables_problem, grid_edges
from ._retrieval import MIN_MOTION, fragment_speeds, histogram_index
from ._smoothness import TEXTURE_SCALE, pair_smoothness, pair_tables
from ._solve import MAX_SWEEPS, _solve, _solve_from, solve
from ._target import Target, cut_target, fragment_motion

__all__ = ["BARELY", "Assignment", "assign"]

#: Below this median speed of the chosen fragments (px/frame) the assignment says
#: they barely move (:meth:`Assignment.stillness_note`).
BARELY = 0.25


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
    tables : PairTables or None
        The three per-edge tables of Eq. (2), (3), (6); None where they were not kept
        (:func:`assign` with ``keep_tables=False``, :func:`animate` with
        ``stream=True``: a file needs no re-solve).
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
    #: The last :math:`W` :meth:`resolve` combined, keyed by its (sigma, rho): a
    #: lambda-only change (a slider) reuses it. Not passed on by ``replace``.
    _combined: dict = dataclasses.field(default_factory=dict, init=False, repr=False, compare=False)

    def __repr__(self):
        # The dataclass's own repr printed every array (thousands of lines in a lesson).
        p, k = self.candidates.shape
        energy = self.solution.energy if hasattr(self.solution, "energy") else None
        return (
            f"Assignment({p} fragments, K={k}, {len(self.edges)} edges, "
            + (f"energy {float(energy):.4g}, " if energy is not None else "")
            + f"{self.db!r})"
        )

    @property
    def labels(self):
        """The chosen label (candidate index) of every target fragment."""
        return self.solution.labels

    @property
    def fragments(self):
        """The database fragment id assigned to every target fragment, (P,)."""
        return self.candidates[np.arange(len(self.candidates)), self.solution.labels]

    def chosen_speed(self):
        """The median over the target of the chosen fragments' speeds, px/frame.

        Each chosen fragment's median speed over its frames (:func:`fragment_speeds`).
        """
        return float(np.median(fragment_speeds(self.db)[self.fragments]))

    def stillness_note(self):
        """A sentence for the status line when the chosen fragments barely move, else None.

        Below :data:`BARELY` px/frame (the median of :meth:`chosen_speed`) the photo
        will barely move unless strokes or a painted speed move it.
        """
        speed = self.chosen_speed()
        if speed >= BARELY:
            return None
        return (
            f"the chosen fragments barely move (median {speed:.2f} px/frame): draw "
            "strokes, or build from footage with more motion"
        )

    @property
    def energies(self):
        """The energy (Eq. 4) at the start and after every alpha-expansion sweep."""
        return self.solution.energies

    def pairwise(self, sigma=None, rho=None):
        """:math:`W_{pq}` (Eq. 6) for every edge and label pair, (E, K, K)."""
        self._need_tables()
        sigma = self.params.sigma if sigma is None else sigma
        rho = self.params.rho if rho is None else rho
        return self.tables.smoothness(sigma, rho)

    def _need_tables(self):
        if self.tables is None:
            raise ValueError(
                "this assignment did not keep its smoothness tables (assign(..., "
                "keep_tables=False), animate(..., stream=True): 0.9 GB at 1920 px); "
                "assign again to re-solve"
            )

    def resolve(
        self,
        *,
        sigma=None,
        lam=None,
        rho=None,
        progress=None,
        warm=None,
        sweeps=1,
        dtype=np.float64,
    ):
        r"""Re-solve the MRF for new :math:`\sigma`, :math:`\lambda`, :math:`\rho`.

        The candidates and the three tables are kept: only Eq. (6) is recombined and
        Eq. (4) minimised again (a fraction of a second). The last recombined
        :math:`W` is kept on this assignment, keyed by its :math:`\sigma` and
        :math:`\rho`: re-solving it again for another :math:`\lambda` alone skips the
        recombination (a slider dragged: call ``resolve`` on the same assignment).

        Parameters
        ----------
        sigma, lam, rho : float, optional
            The new values (default: this assignment's).
        progress : callable, optional
            ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops.
        warm : Assignment or array_like of int, optional
            For a live preview: start from these labels (an assignment of the same
            target, e.g. the previous preview, or its ``labels``) and run ``sweeps``
            alpha-expansion sweeps from them alone
            (:func:`~fluidnb.videodb.assignment.solve_from`) instead of the full solve
            (ICM and expansions from two starts, :func:`~fluidnb.videodb.assignment.solve`),
            which stays the default and should give the result at rest. Its energy is
            never above the start's, but may stay above the full solve's.
        sweeps : int
            Sweeps of the warm start (default 1); ignored without ``warm``.
        dtype : {numpy.float64, numpy.float32}
            float32: the full solve on W combined in float32
            (:meth:`PairTables.smoothness`: half the memory traffic, entries within
            2e-7 relative; a preview's cheaper full solve). Its energy is still
            Eq. (4) of the float32 W summed in float64; the labels can differ from
            the float64 solve's where two labellings nearly tie. A warm start reads
            the float64 tables entry by entry and ignores it.

        Returns
        -------
        Assignment
        """
        changes = {k: v for k, v in (("sigma", sigma), ("lam", lam), ("rho", rho)) if v is not None}
        params = self.params.replace(**changes)
        started = time.perf_counter()
        if warm is None:
            # The full solve reads W many times over (ICM, two expansions): the
            # combined table (kept for a lambda-only change), not the three tables
            # entry by entry (measured: 17 ms instead of 16 per re-solve, the strided
            # column reads tripled).
            pairwise = self._combined_pairwise(params.sigma, params.rho, dtype)
            prob = _problem(self.unary, pairwise, self.edges, params.lam, finite=True)
            solution = _solve(prob, MAX_SWEEPS, progress)
        else:
            labels = warm.labels if isinstance(warm, Assignment) else warm
            if isinstance(warm, Assignment) and warm.candidates.shape != self.candidates.shape:
                raise ValueError(
                    "warm must be an assignment of the same target and candidates "
                    f"({self.candidates.shape}), got one of {warm.candidates.shape}"
                )
            kept = self._combined.get((float(params.sigma), float(params.rho), np.float64))
            if kept is not None:
                prob = _problem(self.unary, kept, self.edges, params.lam, finite=True)
            else:
                # One sweep reads O(E K) entries of W: from the three tables, never
                # combined whole (the E K^2 combination cost twice the sweep); the
                # same values, so the same result as on pairwise(sigma, rho).
                self._need_tables()
                sigma = check_range("sigma", params.sigma, 0)
                rho = check_range("rho", params.rho, 0) * TEXTURE_SCALE
                prob = _tables_problem(self.unary, self.tables, sigma, rho, self.edges, params.lam)
            solution = _solve_from(prob, labels, sweeps, progress)
        timings = {**self.timings, "resolve": time.perf_counter() - started}
        return dataclasses.replace(self, params=params, solution=solution, timings=timings)

    def _combined_pairwise(self, sigma, rho, dtype=np.float64):
        """:meth:`pairwise` for (sigma, rho), the last one kept (read-only) for reuse."""
        key = (float(sigma), float(rho), np.dtype(dtype).type)
        kept = self._combined.get(key)
        if kept is None:
            self._need_tables()
            kept = self.tables.smoothness(sigma, rho, dtype)
            if not _finite(kept):  # once per W, not per solve
                check_finite("pairwise", kept)  # raises, counting the values
            kept.setflags(write=False)
            # One entry: a slider moves one value at a time (a GIL-atomic swap).
            self._combined.clear()
            self._combined[key] = kept
        return kept

    def motion_field(self):
        """The assigned fragments' mean motion blended over the image, (H, W, 2)."""
        h, w = self.target.shape
        t = self.target
        return blend_values(self.db.mean_motion[self.fragments], t.positions, t.canvas.shape[:2])[
            :h, :w
        ]

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

    def fragment_at(self, row, col):
        """The target fragment under image pixel (row, col): its index, or None.

        Of the taking-part fragments whose 48 x 48 core holds the pixel, the one whose
        centre is nearest (largest coordinate difference; ties to the lower index), so
        each fragment answers for the 24 x 24 cell at its centre, where its weight in
        the blend peaks, and border fragments also for the rest of their core. None
        where no taking-part fragment covers the pixel.
        """
        centre = self.target.positions + FRAGMENT / 2 - 0.5
        d = np.abs(centre - np.array([row, col], float)).max(axis=1)
        i = int(np.argmin(d))
        return i if d[i] <= FRAGMENT / 2 else None

    def fragment_info(self, i):
        """What target fragment ``i`` was given, as a dict of plain values.

        Keys: ``index``, ``position`` (its top-left (row, col) on the target),
        ``fragment`` (the database fragment's id), ``clip`` and ``clip_name`` (its source
        clip), ``version`` (``flip``, ``scale``, ``angle``: the augmentation it was cut
        from), ``frames`` (first and last frame of its window), ``source_position``
        (its top-left (row, col) in that version), ``mean_motion`` ((dy, dx) px/frame),
        ``rank`` (its label: the candidate's rank by Eq. 1, 0 for the best-looking) and
        ``score`` (:math:`I(H_e, H_t)` of Eq. 1, normalised to [0, 1]).
        """
        i = check_int("i", i, 0, len(self.target) - 1)
        fid = int(self.fragments[i])
        db = self.db
        clip, version, first, row, col = (int(v) for v in db.source[fid])
        flip, scale, angle = VERSIONS[version]
        label = int(self.labels[i])
        dy, dx = (float(v) for v in db.mean_motion[fid])
        return {
            "index": i,
            "position": [int(v) for v in self.target.positions[i]],
            "fragment": fid,
            "clip": clip,
            "clip_name": str(db.clips[clip]["name"]),
            "version": {"flip": bool(flip), "scale": float(scale), "angle": float(angle)},
            "frames": [first, first + db.params.N - 1],
            "source_position": [row, col],
            "mean_motion": [dy, dx],
            "rank": label,
            "score": float(self.scores[i, label]) / HISTOGRAM_TOTAL,
        }

    def mean_image_mosaic(self):
        r"""The assigned fragments' mean images, blended where they overlap.

        What the assignment looks like in the database's own pixels: each target
        fragment's chosen database fragment's mean image :math:`A`, pasted at the
        fragment's place and blended with the render's partition-of-unity weights
        (:func:`~fluidnb.videodb.rendering.fragment_weights`). Comparing it with the photo shows
        how well Eq. (1) matched appearance.

        Returns
        -------
        ndarray, shape (H, W, 3), float32
            The mosaic inside the taking-part fragments, the target photo elsewhere.
        """
        target = self.target
        h, w = target.shape
        hc, wc = target.canvas.shape[:2]
        weights = fragment_weights(target.positions, (hc, wc))
        means = self.db.mean_images(self.fragments)
        out = np.zeros((hc, wc, 3), np.float64)
        cover = np.zeros((hc, wc), np.float64)
        for (r, c), wgt, m in zip(target.positions, weights, means):
            out[r : r + FRAGMENT, c : c + FRAGMENT] += wgt[..., None] * m
            cover[r : r + FRAGMENT, c : c + FRAGMENT] += wgt
        inside = cover > 0.5
        out[~inside] = target.canvas[~inside]
        return out[:h, :w].astype(np.float32)

    def motion_coherence(self):
        r"""How much neighbouring fragments agree on where the fluid goes, in [-1, 1].

        The mean, over the MRF's edges (neighbouring target fragments), of the cosine
        of the angle between their assigned fragments' mean motions: 1 when all flow
        the same way, about 0 when directions are random (Okabe et al., sec. 7: a large
        :math:`\sigma` ignores the mean motion and the motion turns random). Edges with
        a still fragment (below :data:`~fluidnb.videodb.assignment._retrieval.MIN_MOTION`) count as
        0; a target of one fragment (no edge) gives 1.

        Returns
        -------
        float
        """
        if len(self.edges) == 0:
            return 1.0
        m = self.db.mean_motion[self.fragments].astype(np.float64)
        p, q = self.edges[:, 0], self.edges[:, 1]
        norm = np.linalg.norm(m[p], axis=1) * np.linalg.norm(m[q], axis=1)
        cos = np.where(
            norm > MIN_MOTION**2, (m[p] * m[q]).sum(axis=1) / np.maximum(norm, 1e-300), 0.0
        )
        return float(cos.mean())


def assign(
    image,
    matte=None,
    db="water",
    params=None,
    *,
    direction=None,
    speed=None,
    progress=None,
    keep_tables=True,
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
    keep_tables : bool
        Keep the three smoothness tables for :meth:`Assignment.resolve` (default).
        False: only :math:`W` of the given :math:`\sigma`, :math:`\rho` is made
        (:func:`~fluidnb.videodb.assignment.pair_smoothness`, the same values), and
        ``tables`` is None: for a result that needs no re-solve (a file), a quarter
        of the memory (0.3 GB instead of 1.2 GB at 1920 px).

    Returns
    -------
    Assignment
    """
    report = Progress(progress)
    load, describe, retrieve, tables, solving = report.split(0.1, 0.2, 0.45, 0.9)
    clock = {}
    t0 = time.perf_counter()
    db = as_database(db, load)
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
    top = histogram_index(db).top_k(
        words,
        k,
        direction=dirs,
        speed=speeds,
        max_angle=params.max_angle,
        max_speed_ratio=params.max_speed_ratio,
    )
    unary = 1.0 - top.scores.astype(np.float64) / HISTOGRAM_TOTAL  # V_p = 1 - I
    clock["retrieval"] = time.perf_counter() - t

    t = time.perf_counter()
    _, edges, horizontal = grid_edges(target.active)
    inputs = (top.ids, edges, horizontal, db.spectra, db.texture)
    if keep_tables:
        tabs = pair_tables(*inputs, progress=tables)
    else:
        tabs = None
        pairwise = pair_smoothness(*inputs, params.sigma, params.rho, progress=tables)
    clock["tables"] = time.perf_counter() - t

    t = time.perf_counter()
    if tabs is not None:
        pairwise = tabs.smoothness(params.sigma, params.rho)
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
