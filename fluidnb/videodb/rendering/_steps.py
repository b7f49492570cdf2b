r"""The two renderings' frames after the blend, a run of frames at a time (Okabe et al., sec. 6).

:class:`_BlendedFrames` plays and blends the difference frames a run needs;
:class:`_PaperFrames` adds them to the approximate mean image (the paper's rendering)
and :class:`_FlowFrames` to the photo carried along the motion field (the flow
rendering, beyond the paper); both then match the histograms in the target's colour
axes and composite through the (moving) matte, each frame from its own inputs, on the
cores.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from .._common._weights import FEATHER, blend_values
from ._blend import BLEND_LEVELS, MARGIN, _blend
from ._colour_axes import _advected_in_axes, _composite_from_axes, colours_in_axes, frames_in_axes
from ._composite import _restore_area, _uncovered, dynamic_matte
from ._flow_render import SUPERSAMPLE, _blend_phases, _carry, _sample
from ._loops import play_loops
from ._motion_blur import motion_blur
from ._shared import _advected_layer, _behind, _blend_plan, _colour_matching
from ._threads import _each_frame

__all__ = []


def _tick(clock, key, t):
    """Add the seconds since ``t`` to ``clock[key]``; the time now."""
    now = time.perf_counter()
    clock[key] = clock.get(key, 0.0) + now - t
    return now


class _BlendedFrames:
    """The blended difference frames :math:`D_i` (Hc, Wc) on demand, each made once.

    ``get(idx)`` plays the fragments' loops (:func:`play_loops`: from their offsets,
    mirrored, at their rates) at the frames ``idx`` not made yet and blends them
    (:func:`blend_differences`), in one batch. ``length`` frames in all: the clip's
    (fragments at different rates) or one loop's (the loop is then repeated).
    """

    def __init__(self, loops, offsets, rates, mirrors, length, target, clock):
        self.loops, self.offsets, self.rates, self.mirrors = loops, offsets, rates, mirrors
        self.target, self.clock = target, clock
        self.positions, self.canvas = target.positions, target.canvas.shape[:2]
        canvas = self.canvas
        self.length = length
        self.done = np.zeros(self.length, bool)
        self.frames = np.empty((self.length,) + canvas, np.float32)
        self.plan = None  # the blend's weights (_BlendPlan), kept for the target
        self.played = None  # the last run's played loops (P, s, s, T), reused

    def get(self, idx, *, keep=True):
        """The blended frames ``idx`` (T, Hc, Wc); ``keep=False``: made, not kept.

        A clip that plays each frame of the loop once (its length is the loop's)
        need not keep them: a full-size photo's 96 blended frames are a gigabyte.
        """
        idx = np.asarray(idx)
        if not keep:
            return self._make(idx)
        todo = np.unique(idx[~self.done[idx]])
        if len(todo):
            self.frames[todo] = self._make(todo)
            self.done[todo] = True
        return self.frames[idx]

    def _make(self, todo):
        t = time.perf_counter()
        # Every fragment's loop played from its offset, mirrored, at its rate (what
        # stagger does), pixel-major as the blend reads it; into the last run's array
        # when it has the same size (the blend below is done with it when it returns).
        if self.loops:
            side = self.loops[0].shape[1]
            shape = (len(self.loops), side, side, len(todo))
            if self.played is None or self.played.shape != shape:
                self.played = None  # (the old one freed first)
                self.played = np.empty(shape, np.float32)
        played = play_loops(
            self.loops,
            self.offsets,
            rates=self.rates,
            mirrors=self.mirrors,
            frames=todo,
            out=self.played if self.loops else None,
        )
        t = _tick(self.clock, "rebuild", t)
        if self.plan is None:
            self.plan = _blend_plan(self.target)
        # The private entry: these differences were made just above (finite,
        # checked shape).
        made = _blend(played, self.positions, self.canvas, MARGIN, BLEND_LEVELS, FEATHER, self.plan)
        _tick(self.clock, "blend", t)
        return made


class _Frames:
    """What both renderings do with a run of frames after the blend.

    With a moving matte, ``fill`` is what the fluid uncovers, ``photo`` and
    ``alpha`` the target's canvas and matte (:func:`_uncovered`); else ``fill`` is
    None and ``back`` is behind every frame.

    :meth:`blend` blends a run's differences (one batch: :class:`_BlendedFrames`);
    :meth:`frames` then makes each frame from its own inputs (:meth:`_frame`: the
    rendering's own steps, then :meth:`_finish`: the matching in the colour axes and
    the composite) on the cores, straight into the clip. :func:`render` blends the
    next run while the frames of one are made.
    """

    fill = None
    span = None  # where each frame's histogram bins span its values (None: everywhere)

    def _axes(self, target, cell):
        """The target's colour axes and the matching to it in them (kept for the target)."""
        self.centre, self.axes, self.matching = _colour_matching(target, cell)

    def blend(self, t0, t1):
        """The run's blended differences (T, Hc, Wc) (the loop repeated to the clip's length).

        Kept for the repeats only: a clip as long as the loop blends each frame once.
        """
        length = self.blended.length
        return self.blended.get(np.arange(t0, t1) % length, keep=length < self.n_frames)

    def frames(self, t0, d, out):
        """Each frame of the run from its differences ``d``, on the cores, into ``out``."""
        t1 = t0 + len(d)
        start = time.perf_counter()
        times = [{} for _ in range(t1 - t0)]
        _each_frame(lambda i: self._frame(t0 + i, d[i], out[i], times[i]), t1 - t0)
        # The frames were made side by side: the run's seconds shared out between the
        # stages by the time each took on its thread.
        spent = {}
        for each in times:
            for k, v in each.items():
                spent[k] = spent.get(k, 0.0) + v
        total = sum(spent.values())
        wall = time.perf_counter() - start
        for k, v in spent.items():
            self.clock[k] = self.clock.get(k, 0.0) + (wall * v / total if total > 0 else 0.0)

    def _finish(self, rotated, matte, out):
        """A frame in the colour axes (Hc, Wc, 3) matched, back in RGB and composited.

        Each frame's histograms matched to the target's cell by cell (Okabe et al.,
        sec. 6) in the target's principal colour axes, then laid over the background
        through ``matte`` and clipped, into ``out`` (H, W, 3).
        """
        matched = self.matching.match(rotated, np.empty_like(rotated), self.span)
        back = self.back
        if self.fill is not None:  # a moving matte: the photo, the fill where it left
            h, w = matte.shape
            back = _uncovered(self.photo[:h, :w], self.fill[:h, :w], self.alpha[:h, :w], matte)
        _composite_from_axes(matched, self.centre, self.axes, back, matte, out)


class _PaperFrames(_Frames):
    """The paper's rendering after the blend (steps 3-5 of :func:`render`), by frames."""

    def __init__(self, assignment, params, blended, mirrors, background, clock, keep):
        db, target = assignment.db, assignment.target
        h, w = target.shape
        hc, wc = target.canvas.shape[:2]
        self.target, self.params, self.blended, self.clock = target, params, blended, clock
        self.n_frames = n = blended.length
        ids = assignment.fragments
        t = time.perf_counter()
        velocity = blend_values(db.mean_motion[ids], target.positions, (hc, wc))
        self.approx = motion_blur(
            target.canvas, velocity, shutter=params.shutter, denoise=params.denoise
        )
        t = _tick(clock, "mean", t)
        self._axes(target, params.cell)
        if params.tau > 0:
            per_fragment = db.motion[ids].astype(np.float32)  # (P, N - 1, 2)
            for axis in (0, 1):  # a mirrored fragment moves mirrored
                per_fragment[mirrors == axis, :, axis] *= -1
            motion = blend_values(per_fragment, target.positions, (hc, wc))  # (Hc, Wc, N-1, 2)
            motion = np.moveaxis(motion, 2, 0)[: n - 1]
            matte = dynamic_matte(target.canvas_matte, motion, tau=params.tau)
            back = _behind(target, background)
            self.fill, self.photo, self.alpha = back, target.canvas, target.canvas_matte
        else:
            matte = target.canvas_matte
            back = target.canvas
        self.matte, self.back = matte[..., :h, :w], back[:h, :w]
        _tick(clock, "composite", t)
        self.stages = {"mean": np.clip(self.approx[:h, :w], 0, 1), "background": self.back}
        self.keep = keep
        if keep:
            self.stages["differences"] = np.empty((n, h, w), np.float32)
            self.stages["unmatched"] = np.empty((n, h, w, 3), np.float32)
            self.stages["matte"] = (
                self.matte if matte.ndim == 3 else np.broadcast_to(self.matte, (n, h, w))
            )

    def _frame(self, t, d, out, times):
        """Frame ``t`` into ``out`` (H, W, 3), from its blended differences ``d`` (Hc, Wc)."""
        st = self.stages
        h, w = self.target.shape
        clock = time.perf_counter()
        # The frame approx + D_i made straight in the colour axes, with the picture of
        # it before matching, in one pass.
        if self.keep:
            st["differences"][t] = d[:h, :w]
            rotated, st["unmatched"][t : t + 1] = frames_in_axes(
                self.approx, d[None], self.centre, self.axes, unmatched=(h, w)
            )
        else:
            rotated = frames_in_axes(self.approx, d[None], self.centre, self.axes)
        clock = _tick(times, "match", clock)
        self._finish(rotated[0], self.matte[t] if self.matte.ndim == 3 else self.matte, out)
        _tick(times, "composite", clock)


#: The flow rendering with a still matte makes each frame on the matte's bounding box
#: only (:func:`_matte_box`); False: on the whole canvas (the tests compare the two).
_BOX = True

#: The box's margin around the matte and the grid its corners are on, in pixels. The
#: phases' cross-fade (:func:`variance_blend`) filters them with pyramids two levels
#: deep (its detail band one level, its local energies two, 5-tap kernels): a pixel
#: depends on the pixels up to ~16 px away (measured: a box's blend is the canvas's
#: bit for bit from 15 px inside its edges), and a pyramid of the box is the canvas's
#: pyramid cut out only when the box starts on the coarsest level's grid (4 px).
BOX_MARGIN = 32
BOX_GRID = 8

#: The flow rendering's histogram matching bins each frame over its values within
#: this many pixels of the matte (the bands of :func:`_band_spans`, :meth:`_Matching.match`'s
#: ``span``), not over the whole canvas: a frame whose phases are sampled only
#: within :data:`BOX_MARGIN` of the matte is exact there, and the pixels far from
#: the fluid, which the composite does not show, do not set the bins.
SPAN_MARGIN = 16

#: The flow rendering with a still matte makes each frame on the spans near the
#: matte only: the matte's box in bands of this many rows (:func:`_band_spans`),
#: each with the columns within :data:`SPAN_MARGIN` of the matte (at 1920 px, the
#: stream's spans are 55 % of its box); False: the whole box (the tests compare the
#: two).
BAND = 32
_BANDS = True

#: The spans' frames cross-fade their phases (:func:`variance_blend`) on rectangles
#: of the box around the spans (:func:`_blend_groups`), each grown by this many
#: pixels, and sample the phases within this many pixels of the spans
#: (:func:`_pieces`; the layer elsewhere in the rectangles): the cross-fade's
#: pyramids (one level for the detail, two for its energies) make a pixel from the
#: phases up to 15 px away, and a rectangle's blend is the box's bit for bit from
#: 16 px inside its edges (measured on random phases at every alignment: the
#: pyramids' reflected borders reach 15 px in), when it starts on the box's grid
#: of :data:`BLEND_GRID` (the coarsest level's).
BLEND_CONTEXT = 16
BLEND_GRID = 4

#: What one more rectangle of the cross-fade costs, in pixels of its area (the calls,
#: the small pyramids' edges): spans are grouped when their rectangle wastes less.
BLEND_CALL = 8192


def _matte_box(alpha, shape, margin=BOX_MARGIN, grid=BOX_GRID):
    """The box (r0, r1, c0, c1) on the canvas around ``alpha > 0``, or None.

    The matte's bounding box grown by ``margin`` and out to the next multiples of
    ``grid``, within the canvas (``alpha``'s shape); None when there is nothing to
    gain: no matte, or a box that holds the whole picture (``shape``, (H, W)).
    """
    rows = np.flatnonzero((alpha > 0).any(axis=1))
    cols = np.flatnonzero((alpha > 0).any(axis=0))
    if not len(rows):
        return None
    hc, wc = alpha.shape
    r0, c0 = ((int(x[0]) - margin) // grid * grid for x in (rows, cols))
    r1, c1 = (-((-int(x[-1]) - 1 - margin) // grid) * grid for x in (rows, cols))
    box = (max(r0, 0), min(r1, hc), max(c0, 0), min(c1, wc))
    if box[0] == 0 and box[2] == 0 and box[1] >= shape[0] and box[3] >= shape[1]:
        return None
    return box


def _band_spans(alpha, box, margin, band=BAND):
    """The parts of ``box`` within ``margin`` pixels of ``alpha > 0``, band by band.

    (n, 4) int rows (r0, r1, c0, c1) on the canvas: the box's rows in bands of
    ``band`` (the last one shorter), each with the columns of the matte in its rows
    and ``margin`` rows either side, grown by ``margin`` and cut to the box; bands
    with no matte that near are left out. Every pixel within ``margin`` (in both
    axes) of a matte pixel is in one of them.
    """
    inside = alpha > 0
    hc = inside.shape[0]
    any_row = inside.any(axis=1)
    first = np.where(any_row, inside.argmax(axis=1), inside.shape[1])
    last = np.where(any_row, inside.shape[1] - 1 - inside[:, ::-1].argmax(axis=1), -1)
    r0, r1, c0, c1 = box
    spans = []
    for b0 in range(r0, r1, band):
        b1 = min(b0 + band, r1)
        lo, hi = max(b0 - margin, 0), min(b1 + margin, hc)
        if not any_row[lo:hi].any():
            continue
        s0 = max(int(first[lo:hi].min()) - margin, c0)
        s1 = min(int(last[lo:hi].max()) + 1 + margin, c1)
        if s1 > s0:
            spans.append((b0, b1, s0, s1))
    return np.array(spans, np.int64).reshape(-1, 4)


def _blend_groups(spans, box, context=BLEND_CONTEXT, grid=BLEND_GRID, call=BLEND_CALL):
    """The rectangles on which the cross-fade makes ``spans`` exact, and the spans each holds.

    ``spans`` (n, 4) rows (r0, r1, c0, c1) on the canvas, in order of their rows
    (:func:`_band_spans`). Consecutive spans are grouped; a group's rectangle is
    their hull grown by ``context`` on every side, its corner moved out onto the
    ``grid`` of ``box``'s corner, all cut to ``box``: each span is then ``context``
    pixels or more inside its rectangle, or at the box's own edge. The groups
    minimise the rectangles' area plus ``call`` pixels each (dynamic programming
    over the cuts). Returns a list of ``(rect, spans)``, ``rect`` (r0, r1, c0, c1).
    """
    spans = np.asarray(spans, np.int64).reshape(-1, 4)
    br0, br1, bc0, bc1 = box
    if not len(spans):
        return []

    def rect(i, j):  # the rectangle of spans[i:j]
        part = spans[i:j]
        r0 = max(br0 + (int(part[0, 0]) - context - br0) // grid * grid, br0)
        c0 = max(bc0 + (int(part[:, 2].min()) - context - bc0) // grid * grid, bc0)
        r1 = min(int(part[-1, 1]) + context, br1)
        c1 = min(int(part[:, 3].max()) + context, bc1)
        return r0, r1, c0, c1

    n = len(spans)
    best = [0.0] + [np.inf] * n  # best[j]: the cheapest grouping of spans[:j]
    cut = [0] * (n + 1)
    for j in range(1, n + 1):
        for i in range(j - 1, -1, -1):
            r0, r1, c0, c1 = rect(i, j)
            cost = best[i] + (r1 - r0) * (c1 - c0) + call
            if cost < best[j]:
                best[j], cut[j] = cost, i
    groups, j = [], n
    while j > 0:
        groups.append((rect(cut[j], j), spans[cut[j] : j]))
        j = cut[j]
    return groups[::-1]


class _FlowFrames(_Frames):
    r"""The flow rendering's steps after the blend (beyond the paper; :func:`render`), by frames.

    The motion field's displacement maps, the layer that is advected (the photo
    extended outside the matte) and the colour axes are made once; each run of frames
    is then warped (:func:`eulerian_loop`), given its detail, matched and composited.
    With a still matte and no stages, a frame is made on the matte's box only
    (:meth:`_boxed`; the stream's matte covers 37 % of the picture) and is the photo
    elsewhere, as the composite makes it where the matte is 0.
    """

    def __init__(self, assignment, params, blended, plan, background, clock, keep):
        target = assignment.target
        h, w = target.shape
        self.target, self.params, self.blended, self.clock = target, params, blended, clock
        t = time.perf_counter()
        velocity, self.n_frames = plan["velocity"], plan["n_frames"]
        n = self.n_frames
        self.loop = plan["loop"]  # each pixel's phases' ages and weights
        age_a, age_b, weight_a = self.loop.age_a, self.loop.age_b, self.loop.weight_a
        self.maps = plan["maps"]  # being made: each frame waits for its own
        # What flows in across the matte's edge is the fluid's own texture, mirrored;
        # the phases sample it supersampled.
        self.layer, self.fine, self.grid = _advected_layer(target)
        t = _tick(clock, "advect", t)
        self._axes(target, params.cell)
        self.alpha = target.canvas_matte
        if params.tau > 0:
            self.area = float(self.alpha.sum(dtype=np.float64))
            back = _behind(target, background)
            self.fill, self.photo = back, target.canvas
        else:
            back = target.canvas
        self.back = back
        # With a still matte, a frame is the photo wherever the matte is 0 (the
        # composite's back + 0 (x - back)): only the matte's box is made (its pixels
        # the same as on the whole canvas: the phases are sampled at the same points of
        # the whole finer layer, the detail cut from the whole blend, the matching's
        # cells and mass the whole canvas's), the rest is the photo.
        self.box = self.bands = None
        self.span = _matte_box(self.alpha, (0, 0), SPAN_MARGIN, 1)
        if self.span is not None:  # the matte's bounding box grown, then band by band
            self.span = _band_spans(self.alpha, self.span, SPAN_MARGIN)
        if _BOX and params.tau == 0 and not keep:
            self.box = _matte_box(self.alpha, (h, w))
        if self.box is not None:
            r0, _, c0, _ = self.box
            self.box_matching = self.matching.cropped(self.box)
            self.box_span = None
            if self.span is not None:
                self.box_span = self.span - np.array([r0, r0, c0, c0])
            self.still = np.clip(back[:h, :w], 0, 1)
            if _BANDS and self.loop.offsets is not None and self.span is not None:
                # The frame is made on the spans its bins read (self.span) only: the
                # cross-fade on rectangles around them (_blend_groups), whose phases
                # are sampled within BLEND_CONTEXT of the spans (self.bands) and are
                # the layer elsewhere, which no pixel of the spans depends on; the
                # colour axes on the spans.
                self.groups = _blend_groups(self.span, self.box)
                self.bands, self.fills = _pieces(self.groups, self.span, self.box)
                # The matching maps, and the composite shows, only the matte's own
                # spans, on the bands of self.span (inside them: what the frame holds
                # there is made); elsewhere the frame is the photo, exactly as the
                # composite makes it where the matte is 0.
                shown = _band_spans(self.alpha, _matte_box(self.alpha, (0, 0), SPAN_MARGIN, 1), 0)
                self.shown = shown - np.array([r0, r0, c0, c0])
                self.composited = np.minimum(shown, [h, h, w, w])
                self.lock, self.free = threading.Lock(), []  # _buffers
        _tick(clock, "composite", t)
        offsets = self.loop.offsets
        self.stages = {
            "velocity": velocity[:h, :w],
            "weights": np.stack([weight_a, 1.0 - weight_a], axis=1),
            "ages": np.stack([age_a, age_b], axis=1),
            "phase_offsets": (np.zeros((h, w), np.float32) if offsets is None else offsets[:h, :w]),
            "background": back[:h, :w],
        }
        self.keep = keep
        if keep:
            # The lesson's pictures, written run by run: the phases and their blend on
            # the canvas, shown cropped.
            self.phases = np.empty((2, n) + self.layer.shape, np.float32)
            self.moved = np.empty((n,) + self.layer.shape, np.float32)
            self.stages.update(
                phase_a=self.phases[0, :, :h, :w],
                phase_b=self.phases[1, :, :h, :w],
                advected=self.moved[:, :h, :w],
                differences=np.empty((n, h, w), np.float32),
                unmatched=np.empty((n, h, w, 3), np.float32),
                matte=(
                    np.empty((n, h, w), np.float32)
                    if params.tau > 0
                    else np.broadcast_to(self.alpha[:h, :w], (n, h, w))
                ),
            )

    def _frame(self, t, d, out, times):
        """Frame ``t`` into ``out`` (H, W, 3), from its blended differences ``d`` (Hc, Wc)."""
        params, st = self.params, self.stages
        h, w = self.target.shape
        clock = time.perf_counter()
        # The photo carried by the loop (a phase of weight 0 everywhere is not even
        # sampled, unless the lesson shows it), with the detail D_i on top, in the
        # colour axes.
        maps = self.maps.wait(*self.loop.ages(t))  # a compact _Maps
        clock = _tick(times, "field", clock)
        if self.box is not None:
            self._boxed(t, d, maps, out, times, clock)
            return
        at = self.loop.coordinates(maps, self.grid, t, scale=SUPERSAMPLE, both=self.keep)
        a, b, wa = _sample(self.fine, at)
        moved = self.moved[t] if self.keep else np.empty(self.layer.shape, np.float32)
        _blend_phases(a, b, wa, moved)
        detail = np.float32(params.detail)
        if self.keep:
            self.phases[0, t], self.phases[1, t] = a, b
            frame = moved + detail * d[..., None]
            st["differences"][t] = d[:h, :w]
            np.clip(frame[:h, :w], 0, 1, out=st["unmatched"][t])
            rotated = colours_in_axes(frame, self.centre, self.axes)
        else:  # the same operations in one pass
            rotated = np.empty(self.layer.shape, np.float32)
            _advected_in_axes(moved, detail, d, self.centre, self.axes, rotated)
        clock = _tick(times, "advect", clock)
        if params.tau > 0:
            # The outline moves with the fluid by the same loop (the loop closes),
            # pulled towards alpha by 1 - tau as the paper's B_i are.
            # The outline is smooth: no pulse to stagger, and unstaggered its frame 0
            # is alpha (the photo outside the matte).
            carried = _carry(self.alpha, self.loop.coordinates(maps, self.grid, t, staggered=False))
            matte = np.float32(params.tau) * carried + np.float32(1 - params.tau) * self.alpha
            np.clip(matte, 0.0, 1.0, out=matte)
            if t > 0:
                _restore_area(matte, self.area)
            if self.keep:
                st["matte"][t] = matte[:h, :w]
        else:
            matte = self.alpha
        clock = _tick(times, "composite", clock)
        self._finish(rotated, matte, out)
        _tick(times, "match", clock)

    def _boxed(self, t, d, maps, out, times, clock):
        """:meth:`_frame` on the matte's box (a still matte, no stages), the photo elsewhere.

        The same operations on the box's pixels; the matching's bins span the frame's
        values in the box (:meth:`_Matching.cropped`).
        """
        if self.bands is not None:
            self._spanned(t, d, maps, out, times, clock)
            return
        h, w = self.target.shape
        r0, r1, c0, c1 = self.box
        shape = (r1 - r0, c1 - c0, 3)
        at = self.loop.coordinates(maps, self.grid, t, scale=SUPERSAMPLE, box=self.box)
        a, b, wa = _sample(self.fine, at)
        moved = _blend_phases(a, b, wa, np.empty(shape, np.float32))
        rotated = np.empty(shape, np.float32)
        detail = np.ascontiguousarray(d[r0:r1, c0:c1])
        _advected_in_axes(
            moved, np.float32(self.params.detail), detail, self.centre, self.axes, rotated
        )
        clock = _tick(times, "advect", clock)
        matched = self.box_matching.match(rotated, np.empty_like(rotated), self.box_span)
        # The photo outside the box (what the composite gives where the matte is 0),
        # the box composited as on the whole canvas.
        _outside(out, self.still, (r0, min(r1, h), c0, min(c1, w)))
        hb, wb = max(0, min(r1, h) - r0), max(0, min(c1, w) - c0)
        _composite_from_axes(
            matched, self.centre, self.axes, self.back[r0:r1, c0:c1],
            self.alpha[r0:r1, c0:c1], out[r0 : r0 + hb, c0 : c0 + wb],
        )  # fmt: skip
        _tick(times, "match", clock)

    def _spanned(self, t, d, maps, out, times, clock):
        """:meth:`_boxed` on the spans near the matte (:attr:`bands`), the photo elsewhere.

        The same values as the box's where the frame reads them: the cross-fade of
        each rectangle of :attr:`groups` (its spans :data:`BLEND_CONTEXT` inside it,
        or at the box's edge) is the box's there, bit for bit; the colour axes on
        the spans the bins read (:attr:`span`), the matching's map and the composite
        on the matte's own spans (:attr:`shown`), and the photo elsewhere (what the
        composite gives where the matte is 0: ``back + 0 (x - back)``, clipped).
        """
        r0, _, c0, _ = self.box
        buffers = self._buffers()
        a, b, wa = self._banded(maps, t, buffers)
        rotated = buffers["rotated"]  # written on the spans only
        detail = np.float32(self.params.detail)
        for (g0, g1, f0, f1), spans in self.groups:
            cut = (slice(g0 - r0, g1 - r0), slice(f0 - c0, f1 - c0))
            moved = buffers["moved"][: (g1 - g0) * (f1 - f0) * 3].reshape(g1 - g0, f1 - f0, 3)
            _blend_phases(a[cut], b[cut], wa[cut], moved, buffers["blend"])
            for s0, s1, e0, e1 in spans:
                _advected_in_axes(
                    moved[s0 - g0 : s1 - g0, e0 - f0 : e1 - f0], detail, d[s0:s1, e0:e1],
                    self.centre, self.axes, rotated[s0 - r0 : s1 - r0, e0 - c0 : e1 - c0],
                )  # fmt: skip
        clock = _tick(times, "advect", clock)
        # Matched in place: each pixel is read, then written (after the histograms).
        matched = self.box_matching.match(
            rotated, rotated, self.box_span, self.shown, counted=self.shown
        )
        _outside_spans(out, self.still, self.composited)
        for s0, s1, e0, e1 in self.composited:
            _composite_from_axes(
                matched[s0 - r0 : s1 - r0, e0 - c0 : e1 - c0], self.centre, self.axes,
                self.back[s0:s1, e0:e1], self.alpha[s0:s1, e0:e1], out[s0:s1, e0:e1],
            )  # fmt: skip
        self._release(buffers)
        _tick(times, "match", clock)

    def _buffers(self):
        """A frame's box-sized arrays, reused from frame to frame (one set per frame at work).

        Fresh arrays of this size can cost their pages' faults every frame (measured
        at 1920 px, the steps of a frame: 0.34 s with fresh arrays, 0.23 s reused).
        """
        with self.lock:
            if self.free:
                return self.free.pop()
        r0, r1, c0, c1 = self.box
        box = (r1 - r0, c1 - c0)
        most = max((g1 - g0) * (f1 - f0) for (g0, g1, f0, f1), _ in self.groups)
        names = ("a", "b", "rotated")
        made = {k: np.empty(box + (3,), np.float32) for k in names}
        made |= {"wa": np.empty(box, np.float32), "moved": np.empty(3 * most, np.float32)}
        return made | {"blend": {}}  # the cross-fade's own, as it needs them (_scratch)

    def _release(self, buffers):
        with self.lock:
            self.free.append(buffers)

    def _banded(self, maps, t, buffers=None):
        """Frame ``t``'s phases and :math:`w_a` on the box, made on :attr:`groups`' rectangles.

        Within :attr:`bands` (:data:`BLEND_CONTEXT` of the spans), the same values
        as sampled on the whole box (each pixel's coordinates and its bicubic sample
        depend on that pixel alone); elsewhere in the rectangles both phases are the
        layer and :math:`w_a = 1`: finite values that no pixel of the spans depends
        on. The rest of the box is not written (``buffers``: :meth:`_buffers`).
        """
        r0, _, c0, _ = self.box
        if buffers is None:
            buffers = self._buffers()
        a, b, wa = buffers["a"], buffers["b"], buffers["wa"]
        for p0, p1, q0, q1 in self.bands:
            at = self.loop.coordinates(maps, self.grid, t, scale=SUPERSAMPLE, box=(p0, p1, q0, q1))
            cut = (slice(p0 - r0, p1 - r0), slice(q0 - c0, q1 - c0))
            _sample(self.fine, at, out=(a[cut], b[cut]))
            wa[cut] = at[4]
        for p0, p1, q0, q1 in self.fills:
            cut = (slice(p0 - r0, p1 - r0), slice(q0 - c0, q1 - c0))
            a[cut] = b[cut] = self.layer[p0:p1, q0:q1]
            wa[cut] = 1
        return a, b, wa


def _pieces(groups, spans, box, reach=BLEND_CONTEXT):
    """Where :meth:`_FlowFrames._banded` samples the phases and where it puts the layer.

    The cross-fade makes a pixel from the phases up to ``reach`` pixels away
    (:data:`BLEND_CONTEXT`): each row of ``box`` is sampled within ``reach`` of the
    ``spans`` the frame needs (rows and columns), within the rectangles of
    ``groups`` (:func:`_blend_groups`) that hold the row, and given the layer in the
    rest of them (their hull in that row). Returns the two lists of rectangles
    (r0, r1, c0, c1), sampled and layer, disjoint: runs of rows alike.
    """
    r0, r1, c0, c1 = box
    n = r1 - r0
    none = np.iinfo(np.int64).max

    def hull(rects, grow):  # each row's hull of the rectangles grown by ``grow``, cut to box
        lo, hi = np.full(n, none, np.int64), np.full(n, -1, np.int64)
        for a0, a1, e0, e1 in rects:
            rows = slice(max(a0 - grow, r0) - r0, max(min(a1 + grow, r1) - r0, 0))
            lo[rows] = np.minimum(lo[rows], max(e0 - grow, c0))
            hi[rows] = np.maximum(hi[rows], min(e1 + grow, c1))
        return lo, hi

    lo, hi = hull([rect for rect, _ in groups], 0)
    near = hull(spans, reach)
    s0, s1 = np.maximum(near[0], lo), np.minimum(near[1], hi)
    rows = np.stack([lo, hi, s0, s1], axis=1)
    starts = np.concatenate([[0], np.flatnonzero(np.any(rows[1:] != rows[:-1], axis=1)) + 1])
    sampled, layered = [], []
    for i0, i1 in zip(starts, np.append(starts[1:], n)):
        a, z, e0, e1 = (int(x) for x in rows[i0])
        if z <= a:
            continue
        at = (r0 + int(i0), r0 + int(i1))
        if e1 <= e0:
            e0 = e1 = z
        else:
            sampled.append(at + (e0, e1))
        layered += [at + x for x in ((a, e0), (e1, z)) if x[1] > x[0]]
    return np.array(sampled, np.int64).reshape(-1, 4), layered


def _outside_spans(out, still, spans):
    """``out = still`` outside the ``spans`` (r0, r1, c0, c1), disjoint, in order of rows."""
    row = 0
    for r0, r1, c0, c1 in spans:
        out[row:r0] = still[row:r0]
        out[r0:r1, :c0] = still[r0:r1, :c0]
        out[r0:r1, c1:] = still[r0:r1, c1:]
        row = max(row, r1)
    out[row:] = still[row:]


def _outside(out, still, box):
    """``out = still`` outside the box (r0, r1, c0, c1), in four strips."""
    r0, r1, c0, c1 = box
    out[:r0] = still[:r0]
    out[r1:] = still[r1:]
    out[r0:r1, :c0] = still[r0:r1, :c0]
    out[r0:r1, c1:] = still[r0:r1, c1:]
