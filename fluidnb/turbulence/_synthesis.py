"""The synthesis loop (Watanabe et al., sec. 2.2): search, paste, add, advect; Table 1."""

from __future__ import annotations

import numbers
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from .._progress import Progress
from ..fields import advect
from ._params import TurbulenceParams
from ._prepare import Prepared, global_search, prepare
from ._search import local_search

__all__ = ["PAPER_TABLE1", "Synthesis", "compare", "local_features", "synthesize", "table1"]

#: The paper's Table 1 (Core i7-2600K, 16 x 24 target, 128 x 192 source, B = 16,
#: b = 4, 200 frames): strategy -> (mean relative error, mean absolute error,
#: seconds per frame). The exhaustive row's error cells were lost in extraction;
#: they are 0 by definition.
PAPER_TABLE1 = {
    "exhaustive": (0.0, 0.0, 0.1145),
    "interval 2": (0.2341, 0.3824, 0.0313),
    "interval 4": (1.1060, 1.2969, 0.0098),
    "interval 8": (3.0804, 3.3836, 0.0036),
    "adaptive": (0.0103, 0.1935, 0.0125),
}


@dataclass(frozen=True, eq=False)
class Synthesis:
    r"""The result of :func:`synthesize`.

    Attributes
    ----------
    velocity : ndarray, (I, H, W, 2)
        :math:`U(i) = U_t(i) + U_h(i)`, the synthesised high-resolution flow.
    detail : ndarray, (I, H, W, 2)
        :math:`U_h(i)`, the pasted high frequencies.
    prepared : Prepared
        The inputs, upsampled and split (for pictures and comparisons).
    global_positions, local_positions : ndarray of int, (I, P, 2)
        :math:`q_l` (target-grid cells) and :math:`q_h` (source cells), top-left
        corners of the chosen patches.
    energies : ndarray, (I, P)
        :math:`E_h` of the chosen local patches.
    best_energies : ndarray or None, (I, P)
        The exhaustive minimum of the same searches (``reference=True``), from which
        :meth:`errors` are computed; ``None`` otherwise.
    evaluations : ndarray of int, (I, P)
        Full patch energies computed by the local search.
    search_seconds : ndarray, (I,)
        Local-search time per frame (what Table 1 reports).
    params : TurbulenceParams
    timings : dict
        Stage -> seconds for the whole run.
    clip : Clip
        The synthesised flow made visible (computed on first use): see
        :attr:`clip`.

    Notes
    -----
    The synthesis draws no random numbers: the same flows and parameters give the
    same result, so there is no ``seed`` to pass, and :attr:`clip` records
    ``seed=None``.
    """

    velocity: np.ndarray
    detail: np.ndarray
    prepared: Prepared
    global_positions: np.ndarray
    local_positions: np.ndarray
    energies: np.ndarray
    best_energies: np.ndarray | None
    evaluations: np.ndarray
    search_seconds: np.ndarray
    params: TurbulenceParams
    timings: dict = field(default_factory=dict)

    @cached_property
    def clip(self):
        """A dye carried through the synthesised flow, as a :class:`fluidnb.Clip`.

        The dye is injected where the target's scene adds smoke
        (:func:`~fluidnb.turbulence.injection`) and carried by :math:`U(i)`
        (:func:`~fluidnb.turbulence.dye_clip`, 24 fps). Its metadata: ``method``
        ("turbulence"), ``params``, ``seed`` (None: nothing here is random) and
        ``timings``. :func:`~fluidnb.turbulence.render` draws the target and the
        source beside it on one brightness scale.
        """
        from ._flows import Flow
        from ._render import dye_clip, injection

        prep = self.prepared
        inject = injection(Flow(prep.u_t, prep.rho_t, 1.0), prep.factor)
        metadata = {
            "method": "turbulence",
            "params": self.params.to_dict(),
            "seed": None,
            "timings": dict(self.timings),
            "flow": "synthesised",
        }
        return dye_clip(self.velocity, inject, metadata=metadata)

    @property
    def n_frames(self):
        """Frames ``I``."""
        return self.velocity.shape[0]

    def errors(self, *, smoke_only=False):
        """Per-frame mean relative and absolute error against the exhaustive search.

        As the paper defines them (Watanabe et al., sec. 4): for each patch, the absolute error is
        :math:`E_h(q_h) - E_h^*` and the relative error that divided by
        :math:`E_h^*`, where :math:`E_h^*` is the exhaustive search's minimum of the
        same search (same window, same temporal term); both are averaged over the
        patches of a frame (patches with :math:`E_h^* = 0` are left out of the
        relative mean). ``smoke_only`` keeps only patches holding target smoke, as
        the paper's Fig. 3-4 also do.

        Returns
        -------
        dict
            ``"relative"`` and ``"absolute"``: arrays (I,) (NaN for a frame with no
            patch counted).

        Raises
        ------
        ValueError
            If the run was made with ``reference=False``.
        """
        if self.best_energies is None:
            raise ValueError("errors need a run with reference=True")
        e, best = self.energies, self.best_energies
        keep = np.ones(e.shape, bool)
        if smoke_only:
            keep = np.stack([self.prepared.smoke_patches(i) for i in range(self.n_frames)])
        absolute = np.maximum(e - best, 0.0)
        rel_keep = keep & (best > 0)
        relative = np.divide(absolute, best, out=np.zeros_like(absolute), where=best > 0)
        with np.errstate(invalid="ignore"):
            abs_mean = np.where(keep.any(1), (absolute * keep).sum(1) / keep.sum(1), np.nan)
            rel_mean = np.where(
                rel_keep.any(1), (relative * rel_keep).sum(1) / rel_keep.sum(1), np.nan
            )
        return {"relative": rel_mean, "absolute": abs_mean}

    def to_flow(self):
        """The synthesised flow as a :class:`Flow` on the source grid (saveable).

        Its density is the target's, bilinearly upsampled (the smoke the user
        designed), so the result can be searched, rendered or saved like any flow.
        """
        from ..fields import upsample
        from ._flows import Flow

        prep = self.prepared
        rho = np.moveaxis(upsample(np.moveaxis(prep.rho_t, 0, -1), prep.factor), -1, 0)
        return Flow(self.velocity, rho, prep.dx_source)

    def summary(self):
        """One Table 1 row: mean errors over all frames and the time per frame."""
        row = {
            "strategy": _label(self.params),
            "seconds_per_frame": float(np.mean(self.search_seconds)),
            "evaluations_per_patch": float(np.mean(self.evaluations)),
        }
        if self.best_energies is not None:
            err = self.errors()
            row["relative_error"] = float(np.nanmean(err["relative"]))
            row["absolute_error"] = float(np.nanmean(err["absolute"]))
        return row


def _label(params):
    if params.strategy == "interval":
        return f"interval {params.interval}"
    if params.strategy == "adaptive" and params.m0 != 8:
        return f"adaptive m0={params.m0}"
    return params.strategy


def synthesize(target, source, params=None, *, reference=False, progress=None, prepared=None):
    """Add the source's turbulent detail to the target flow (Watanabe et al., sec. 2).

    For every frame ``i``: the global search (Eq. 1) finds, for each local patch, a
    source region on the low-resolution grid; the local search (Eq. 2) finds the
    best ``B x B`` patch within the window around it, comparing velocity, mask
    and -- from the second frame on, weighted by ``beta`` -- the previous frame's
    synthesised detail advected by :math:`U_t(i-1)` against the source's detail
    :math:`U_{sh}`; the chosen :math:`U_{sh}` patches are pasted into
    :math:`U_h(i)` and :math:`U(i) = U_t(i) + U_h(i)`.

    Parameters
    ----------
    target, source : Flow
        See :func:`prepare`.
    params : TurbulenceParams, optional
        ``strategy`` picks the local search (Table 1).
    reference : bool
        Also find every search's exhaustive minimum (with the exact search, not
        timed) so that :meth:`Synthesis.errors` can report the paper's error figures.
    progress : callable, optional
        ``progress(fraction, message)`` once per frame; raise
        :class:`fluidnb.Cancelled` from it to stop.
    prepared : Prepared, optional
        A :func:`prepare` result for this pair and ``params`` (B, b, alpha, D_th)
        to reuse across strategies.

    Returns
    -------
    Synthesis

    Examples
    --------
    >>> from fluidnb.turbulence import sample_flows
    >>> target, source = sample_flows(3, scale=2)
    >>> out = synthesize(target, source, TurbulenceParams(strategy="exhaustive"))
    >>> out.velocity.shape
    (3, 96, 64, 2)
    """
    params = TurbulenceParams() if params is None else params
    progress = Progress(progress)
    t0 = time.perf_counter()
    if prepared is None:
        prep = prepare(target, source, params)
    else:
        # The search settings may differ from the ones it was prepared with.
        prep = replace(_check_prepared(prepared, params), params=params)
    t_prep = time.perf_counter() - t0
    n_frames, (H, W), P = prep.n_frames, prep.U_t.shape[1:3], prep.n_patches
    B, n = params.B, prep.window
    ty, tx = prep.tiles
    velocity = np.empty((n_frames, H, W, 2), np.float32)
    detail = np.empty((n_frames, H, W, 2), np.float32)
    q_l_all = np.empty((n_frames, P, 2), np.int64)
    q_h_all = np.empty((n_frames, P, 2), np.int64)
    energies = np.empty((n_frames, P))
    best = np.empty((n_frames, P)) if reference else None
    evaluations = np.empty((n_frames, P), np.int64)
    seconds = np.empty(n_frames)
    t_global = 0.0
    advected = None
    for i in range(n_frames):
        progress(i / n_frames, f"frame {i + 1} / {n_frames}")
        tg = time.perf_counter()
        q_l, _ = global_search(prep, i)
        t_global += time.perf_counter() - tg
        starts = prep.window_starts(q_l)
        S, X = local_features(prep, i, advected, params)
        # The exact bounded search starts from last frame's choices (a hint: it
        # speeds the search up, never changes its answer; the others ignore it).
        hint = q_h_all[i - 1] if i > 0 else None
        found = local_search(
            S, X, starts, n, params.strategy, m0=params.m0, interval=params.interval, hint=hint
        )
        if reference:  # the exhaustive minimum, by the exact search from this answer
            best[i] = local_search(S, X, starts, n, "exact-bounds", hint=found.positions).energies
        U_h = _paste(prep.U_sh[i], found.positions, (ty, tx), B, params.blend)
        detail[i] = U_h
        velocity[i] = prep.U_t[i] + U_h
        # U*_h(i + 1): this frame's detail carried along the target flow (sec. 2.2).
        advected = advect(U_h, prep.U_t[i])
        q_l_all[i], q_h_all[i] = q_l, found.positions
        energies[i], evaluations[i], seconds[i] = found.energies, found.evaluations, found.seconds
    progress(1.0, "done")
    total = time.perf_counter() - t0
    timings = {
        "prepare": t_prep,
        "global_search": t_global,
        "local_search": float(seconds.sum()),
        "total": total,
    }
    return Synthesis(
        velocity, detail, prep, q_l_all, q_h_all, energies, best, evaluations, seconds,
        params, timings,
    )  # fmt: skip


def local_features(prep, i, previous=None, params=None):
    r"""The source image ``S`` and target patches ``X`` of frame ``i``'s local search.

    Eq. (2)'s terms become channels of one sum of squared differences: velocity
    (:math:`U_t` against :math:`U_{sl}`), the mask times :math:`\sqrt{\alpha}`
    (:math:`D_t` against :math:`D_s`) and, when ``previous`` is given and
    :math:`\beta > 0`, the detail times :math:`\sqrt{\beta}` (:math:`U^*_h`
    against :math:`U_{sh}`).

    Parameters
    ----------
    prep : Prepared
    i : int
        The frame.
    previous : ndarray, (H, W, 2), optional
        :math:`U^*_h(i)`: the previous frame's detail advected by
        :math:`U_t(i-1)`; ``None`` at the first frame.
    params : TurbulenceParams, optional
        Default: ``prep.params``.

    Returns
    -------
    S : ndarray, (H, W, C)
        Source features, float64.
    X : ndarray, (P, B, B, C)
        Target features of the ``B x B`` tiles, row by row, float64.
    """
    params = prep.params if params is None else params
    B, (ty, tx) = params.B, prep.tiles
    a_w, b_w = np.sqrt(params.alpha), np.sqrt(params.beta)
    tgt = [prep.U_t[i], a_w * prep.D_t[i][..., None]]
    src = [prep.U_sl[i], a_w * prep.D_s[i][..., None]]
    if previous is not None and params.beta > 0:
        tgt.append(b_w * previous)
        src.append(b_w * prep.U_sh[i])
    T = np.concatenate(tgt, -1).astype(np.float64)
    S = np.concatenate(src, -1).astype(np.float64)
    X = T.reshape(ty, B, tx, B, T.shape[-1]).swapaxes(1, 2).reshape(ty * tx, B, B, -1)
    return S, X


def _check_prepared(prep, params):
    if not isinstance(prep, Prepared):
        raise ValueError(f"prepared must be a Prepared, got {type(prep).__name__}")
    same = all(getattr(prep.params, k) == getattr(params, k) for k in ("B", "b", "alpha", "D_th"))
    if not same:
        raise ValueError("prepared was made with other B, b, alpha or D_th than params")
    return prep


def _paste(U_sh, positions, tiles, B, blend):
    """Tile the chosen ``B x B`` detail patches; with ``blend`` > 0, feather the seams."""
    ty, tx = tiles
    H, W = U_sh.shape[:2]
    if blend == 0:
        rows = positions[:, :1] + np.arange(B)
        cols = positions[:, 1:] + np.arange(B)
        patches = U_sh[rows[:, :, None], cols[:, None, :]]  # (P, B, B, 2)
        return patches.reshape(ty, tx, B, B, 2).swapaxes(1, 2).reshape(H, W, 2)
    o = blend
    size = B + 2 * o
    src = np.pad(U_sh, ((o, o), (o, o), (0, 0)), mode="edge")
    rows = positions[:, :1] + np.arange(size)  # padded coordinates: -o .. B+o
    cols = positions[:, 1:] + np.arange(size)
    patches = src[rows[:, :, None], cols[:, None, :]]
    # A tent over the overlap: 1 inside the tile, falling to 0 over o cells outside.
    ramp = np.minimum(1.0, (np.arange(size) + 0.5) / (2 * o))
    ramp = np.minimum(ramp, ramp[::-1])
    w = np.outer(ramp, ramp)
    acc = np.zeros((H + 2 * o, W + 2 * o, 2))
    wsum = np.zeros((H + 2 * o, W + 2 * o))
    for k, (y, x) in enumerate(np.ndindex(ty, tx)):
        y0, x0 = y * B, x * B  # tile (y, x) covers padded rows y0 .. y0 + size
        acc[y0 : y0 + size, x0 : x0 + size] += w[..., None] * patches[k]
        wsum[y0 : y0 + size, x0 : x0 + size] += w
    return (acc / wsum[..., None])[o : o + H, o : o + W].astype(np.float32)


def compare(target, source, strategies=None, params=None, *, progress=None, keep=None):
    """Run several strategies on one pair, side by side, with errors (Table 1).

    Parameters
    ----------
    target, source : Flow
    strategies : list of dict, optional
        Parameter changes per run; default: Table 1's rows plus the two exact
        searches (``{"strategy": "exhaustive"}``, ``{"strategy": "interval",
        "interval": 2}``, ...).
    params : TurbulenceParams, optional
        The common settings.
    progress : callable, optional
    keep : callable, optional
        ``keep(run_params) -> bool``: which runs to return whole; the others are
        reduced to their :meth:`Synthesis.summary` row as soon as they finish (a
        run holds two high-resolution flows, about 80 MB at the paper's sizes).
        Default: keep every run.

    Returns
    -------
    dict
        Row label -> :class:`Synthesis` (each run with ``reference=True``), or its
        summary row where ``keep`` said no. :func:`table1` takes either.
    """
    params = TurbulenceParams() if params is None else params
    if strategies is None:
        strategies = [
            {"strategy": "exhaustive"},
            {"strategy": "interval", "interval": 2},
            {"strategy": "interval", "interval": 4},
            {"strategy": "interval", "interval": 8},
            {"strategy": "adaptive"},
            {"strategy": "exact-fft"},
            {"strategy": "exact-bounds"},
        ]
    progress = Progress(progress)
    prep = prepare(target, source, params)
    parts = progress.split(*np.linspace(0, 1, len(strategies) + 1)[1:-1])
    out = {}
    for change, part in zip(strategies, parts):
        p = params.replace(**change)
        run = synthesize(target, source, p, reference=True, progress=part, prepared=prep)
        out[_label(p)] = run if keep is None or keep(p) else run.summary()
        del run
    return out


def table1(results):
    """Table 1 rows from :func:`compare`'s results, next to the paper's figures.

    Parameters
    ----------
    results : mapping or sequence
        Label -> row, or a sequence of rows that carry their own ``"strategy"``.
        A row is a :class:`Synthesis` (its :meth:`Synthesis.summary` is used), a
        mapping with at least ``"seconds_per_frame"`` (and, to show them,
        ``"relative_error"``, ``"absolute_error"``, ``"evaluations_per_patch"``;
        its ``"strategy"`` defaults to the label), or a tuple
        ``(relative_error, absolute_error, seconds_per_frame)`` as in
        :data:`PAPER_TABLE1`. Keep the small rows, not the flows, when collecting
        many runs.

    Returns
    -------
    list of dict
        Per strategy: ``strategy``, ``relative_error``, ``absolute_error``,
        ``seconds_per_frame``, ``evaluations_per_patch`` (those given),
        ``speedup`` (exhaustive time / this time, when an exhaustive row is
        present) and the paper's ``paper_relative_error``,
        ``paper_absolute_error``, ``paper_seconds``, ``paper_speedup`` where the
        paper has the row.

    Raises
    ------
    ValueError
        For a row of any other kind, or without a strategy or a time.

    Examples
    --------
    >>> rows = table1({"exhaustive": (0.0, 0.0, 0.1), "adaptive": (0.01, 0.2, 0.01)})
    >>> round(rows[1]["speedup"], 6), rows[1]["paper_relative_error"]
    (10.0, 0.0103)
    """
    items = results.items() if isinstance(results, Mapping) else ((None, r) for r in results)
    rows = [_row(label, r) for label, r in items]
    ex = next((r for r in rows if r["strategy"] == "exhaustive"), None)
    for r in rows:
        if ex is not None:
            r["speedup"] = ex["seconds_per_frame"] / r["seconds_per_frame"]
        paper = PAPER_TABLE1.get(r["strategy"])
        if paper is not None:
            r["paper_relative_error"], r["paper_absolute_error"], r["paper_seconds"] = paper
            r["paper_speedup"] = PAPER_TABLE1["exhaustive"][2] / paper[2]
    return rows


_TUPLE_FIELDS = ("relative_error", "absolute_error", "seconds_per_frame")


def _row(label, r):
    """One row of :func:`table1` as a new dict (the caller's row is never changed)."""
    if isinstance(r, Synthesis):
        row = r.summary()
    elif isinstance(r, Mapping):
        row = dict(r)
    elif isinstance(r, tuple) and len(r) == 3:
        row = dict(zip(_TUPLE_FIELDS, r))
    else:
        raise ValueError(
            f"a table1 row must be a Synthesis, a mapping or a tuple {_TUPLE_FIELDS}, "
            f"got {type(r).__name__}"
        )
    if label is not None:
        row.setdefault("strategy", str(label))
    if "strategy" not in row:
        raise ValueError(f"a table1 row needs a strategy (a label or a 'strategy' key), got {row}")
    if not isinstance(row.get("seconds_per_frame"), numbers.Real):
        raise ValueError(
            f"table1 row {row['strategy']!r} needs a number 'seconds_per_frame', "
            f"got {row.get('seconds_per_frame')!r}"
        )
    return row
