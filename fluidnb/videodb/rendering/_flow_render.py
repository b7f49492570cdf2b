r"""The flow rendering: the photo itself moved along the assigned motion (beyond the paper).

The paper's rendering (Okabe et al., sec. 6) adds the chosen fragments' difference
frames :math:`D_i` to a blurred copy of the photo: the photo's own texture never moves,
and the animation reads as a shimmer over a still picture, slower than the motion the
assignment chose (measured on the stream with a painted 2 px/frame: 0.59 px/frame).
Beyond the paper, the flow rendering uses what the assignment knows -- for every target
fragment, a real fluid clip whose motion matches the strokes and the painted speed --
to move the photo along that motion:

1. **the motion field** :math:`v(x)` (:func:`flow_field`): the chosen fragments' mean
   motion, blended across fragment borders with the weights that blend the
   differences, and rescaled to the painted speed where the user painted one;
2. **an Eulerian loop** (:func:`eulerian_loop`): the photo advected along :math:`v` in
   two phases half a cycle apart, cross-faded, each restarted from the photo when its
   weight is zero (Neyret 2003's advected textures; the looping of Holynski et al.
   2021, without their network), so frame 0 is the photo where the warp is concerned,
   the clip loops exactly, and no phase is ever displaced by more than half a cycle's
   travel (no stretching builds up);
3. **the detail**: the paper's blended :math:`D_i` added on top, for the small-scale
   motion a warp cannot make (spray, flicker), then the cell-wise histogram matching
   and the composite through the matte, as the paper's rendering does.

:func:`fluidnb.videodb.rendering.reference_eulerian_loop` is step 2 written out with
:func:`fluidnb.fields.backward_warp`, one frame and one phase at a time.
"""

from __future__ import annotations

import functools
import math
import threading

import numpy as np
from numba import njit
from scipy import ndimage as ndi

from ..._validation import check_array, check_int, check_range, check_vector_field
from .._common._weights import fragment_weights
from ._phase_blend import _blend
from ._threads import _each_frame

__all__ = [
    "FIELD_SIGMA",
    "LANCZOS_A",
    "MAX_REPEATS",
    "STAGGER",
    "SUPERSAMPLE",
    "displacement_maps",
    "eulerian_loop",
    "extend_outside",
    "flow_field",
    "flow_timing",
    "loop_phases",
    "phase_offsets",
    "supersample",
]

#: Standard deviation in pixels of the Gaussian that smooths the motion field beyond
#: the blend's weights (:func:`flow_field`): one stride.
FIELD_SIGMA = 24.0

#: The flow rendering samples the photo from a copy this many times finer
#: (:func:`supersample`), bicubically.
SUPERSAMPLE = 2

#: Lobes of the Lanczos kernel that makes the finer copy (:func:`supersample`).
LANCZOS_A = 3

#: The spacing of :func:`phase_offsets`'s noise grid in units of the travel
#: (:attr:`AnimateParams.travel`); 0: no offsets, one cycle for the whole picture.
STAGGER = 6.0

#: At most this many repeats of the difference frames' loop make one flow-rendered
#: clip (:func:`flow_timing`): slow motion needs long cycles, but each frame costs.
MAX_REPEATS = 4


def flow_field(assignment):
    r"""The motion field :math:`v(x)` of the flow rendering, on the target's canvas.

    Every target fragment's chosen database fragment has a mean motion (its optical
    flow averaged over its pixels and frames, (dy, dx) px/frame); they are spread over
    the canvas with the partition-of-unity weights of the difference frames' blend
    (:func:`~fluidnb.videodb.rendering.fragment_weights`), then smoothed by a Gaussian of one
    stride (:data:`FIELD_SIGMA`, within the fragments' cores): neighbouring fragments
    may move quite differently (the smoke database's slow and fast ones side by side),
    and the sharper field sheared the photo along the line between them into a seam.

    Where the user painted a speed, the field keeps its direction and takes the
    painted speed (our decision: the painted speed is the user's request, and the
    retrieval's motion filter only keeps fragments within ``max_speed_ratio`` of it,
    so the fragments' own speed would miss it by up to that factor). The painted
    speed per fragment (:attr:`Assignment.speed`) is blended with the same weights;
    fragments without paint keep their own speed, and the two mix smoothly where
    painted and unpainted fragments meet.

    Parameters
    ----------
    assignment : Assignment

    Returns
    -------
    ndarray, shape (Hc, Wc, 2), float32
        (dy, dx) in px/frame on the padded canvas; 0 outside every fragment's core.
    """
    target, db = assignment.target, assignment.db
    canvas = target.canvas.shape[:2]
    ids = assignment.fragments
    speed = assignment.speed
    painted = np.zeros(len(ids), bool) if speed is None else np.isfinite(speed)
    # One pass over the fragments for every per-fragment value: the mean motion
    # (dy, dx), whether the user painted a speed there, and that speed.
    values = np.zeros((len(ids), 4))
    values[:, :2] = db.mean_motion[ids]
    values[:, 2] = painted
    if painted.any():
        values[:, 3] = np.where(painted, speed, 0.0)
    acc = np.zeros(canvas + (4,), np.float64)
    covered = np.zeros(canvas, np.float64)
    weights = fragment_weights(target.positions, canvas)
    _spread(np.asarray(target.positions, np.int64), weights, values, acc, covered)
    inside = (covered > 0.5).astype(np.float32)
    # Then a Gaussian of one stride within the fragments' cores (normalised
    # convolution): neighbours that move differently would otherwise shear the photo
    # along a line between them (a visible seam). The values and their weight are
    # blurred side by side, each as one call (OpenCV's rounding may depend on how
    # many channels go together).
    parts = [acc.astype(np.float32) * inside[..., None], inside]
    blurred = [None, None]

    def blur(k):
        blurred[k] = _gaussian(parts[k])

    _each_frame(blur, 2)
    num, den = blurred[0], blurred[1][..., None]
    field = np.divide(num, den, out=np.zeros_like(num), where=den > 1e-6) * inside[..., None]
    v = field[..., :2]
    if not painted.any():
        return np.ascontiguousarray(v)
    # `share` is how much of each pixel painted fragments own, `wanted` their painted
    # speed averaged over that share.
    share = field[..., 2]
    wanted = np.divide(field[..., 3], share, out=np.zeros_like(share), where=share > 1e-6)
    norm = np.hypot(v[..., 0], v[..., 1])
    gain = np.divide(wanted, norm, out=np.ones_like(norm), where=norm > 1e-6)
    gain = 1.0 + share * (gain - 1.0)
    return (v * gain[..., None]).astype(np.float32)


@njit(cache=True, nogil=True)
def _spread(positions, weights, values, acc, covered):
    """``acc += w_p v_p`` and ``covered += w_p`` over every fragment's core, in order.

    The float64 products and sums of the numpy loop
    ``acc[r : r + 48, c : c + 48] += w[..., None] * v``, one pixel at a time.
    """
    for p in range(positions.shape[0]):
        r, c = positions[p, 0], positions[p, 1]
        for i in range(weights.shape[1]):
            for j in range(weights.shape[2]):
                w = weights[p, i, j]
                for k in range(values.shape[1]):
                    acc[r + i, c + j, k] += w * values[p, k]
                covered[r + i, c + j] += w


def _gaussian(x):
    """Gaussian blur of standard deviation :data:`FIELD_SIGMA`, zero outside the canvas."""
    import cv2

    out = cv2.GaussianBlur(x, (0, 0), FIELD_SIGMA, borderType=cv2.BORDER_CONSTANT)
    return out.reshape(x.shape)


def loop_phases(n_frames, cycle):
    r"""The two phases' ages and weights of an Eulerian loop, per frame.

    Phase a is the photo advected for :math:`s_a(t)` frames and phase b for
    :math:`s_b(t)`, both in :math:`[-P/2, P/2]` (a negative age is the photo carried
    backwards, i.e. the frames that lead up to it):

    .. math::

        s_a(t) = \big((t + P/2) \bmod P\big) - P/2, \qquad
        s_b(t) = (t \bmod P) - P/2, \qquad
        w_a(t) = 1 - 2|s_a(t)|/P, \qquad w_b = 1 - w_a,

    so :math:`w_a(0) = 1` with :math:`s_a(0) = 0` (frame 0 is the photo), a phase's
    weight is 0 when its age jumps from :math:`+P/2` to :math:`-P/2` (it restarts
    unseen), and both ages grow by one frame per frame in between: both phases move
    with the flow. :math:`P` is ``n_frames`` divided by the whole number of cycles
    nearest to ``n_frames / cycle`` (at least one), so the clip loops:
    :math:`s(t + T) = s(t)`. With one cycle per loop this is Holynski et al.'s
    (2021) loop of :math:`T` frames, a blend of the photo carried forwards and
    backwards; with more, Neyret's (2003) two phases.

    Parameters
    ----------
    n_frames : int
        :math:`T`, frames in the loop (>= 2).
    cycle : float
        Wanted frames per cycle, :math:`P` (>= 2; rounded as said).

    Returns
    -------
    age_a, age_b : ndarray, shape (T,), float64
        :math:`s_a(t)`, :math:`s_b(t)` in frames.
    weight_a : ndarray, shape (T,), float64
        :math:`w_a(t)` in [0, 1] (:math:`w_b = 1 - w_a`).

    Examples
    --------
    >>> a, b, w = loop_phases(8, 4)
    >>> a.tolist()
    [0.0, 1.0, -2.0, -1.0, 0.0, 1.0, -2.0, -1.0]
    >>> b.tolist()
    [-2.0, -1.0, 0.0, 1.0, -2.0, -1.0, 0.0, 1.0]
    >>> w.tolist()
    [1.0, 0.5, 0.0, 0.5, 1.0, 0.5, 0.0, 0.5]
    """
    n_frames = check_int("n_frames", n_frames, 2)
    cycle = check_range("cycle", cycle, 2)
    period = n_frames / max(1, round(n_frames / cycle))
    t = np.arange(n_frames, dtype=np.float64)
    half = period / 2
    age_a = np.mod(t + half, period) - half
    age_b = np.mod(t, period) - half
    weight_a = 1.0 - np.abs(age_a) / half
    return age_a, age_b, np.clip(weight_a, 0.0, 1.0)


def flow_timing(velocity, matte, n_frames, *, travel, repeats=True, frames=None):
    r"""The flow rendering's clip length and cycle for a motion field.

    Each advected phase of :func:`eulerian_loop` carries the photo for half a cycle
    :math:`P` either side of its restart, :math:`P v / 2` pixels at speed :math:`v`;
    the two phases are then that far apart. Where that is less than the texture's
    grain, the cross-fade from the phase ahead to the phase behind reads as motion
    backwards and cancels the forward motion (measured with OpenCV's DIS on the
    stream and the clouds: 3 px keep 2 % of the speed, 6 px 50-70 %, 12 px 80-95 %,
    24 px 95-100 %). So the cycle is :math:`P = 2\,	ext{travel} / 	ilde v`, with
    :math:`	ilde v` the median speed over the matte, and the clip is the smallest
    whole number of repeats :math:`k` of the difference frames' loop (``n_frames``,
    at most :data:`MAX_REPEATS`) that holds one cycle; a whole number of cycles
    (the most that are at least :math:`P` long) fills it. ``frames`` asks for a clip
    length instead (a whole number of repeats, any number of them); the cycles fill
    it alike.

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        The motion field, px/frame.
    matte : ndarray, shape (H, W)
        Where the speed counts (``matte > 0.5``; everywhere if nowhere).
    n_frames : int
        :math:`T_D`, frames of the difference frames' loop.
    travel : float
        The wanted :math:`P 	ilde v / 2` in pixels (> 0).
    repeats : bool
        Allow more than one repeat (False when the differences do not loop).
    frames : int, optional
        The clip's length :math:`T` asked for: a whole multiple of ``n_frames``
        (``n_frames`` itself unless ``repeats``); default chosen as said.

    Returns
    -------
    n_frames : int
        :math:`T = k\,T_D`.
    cycle : float
        :math:`P`, a whole fraction of :math:`T`.

    Examples
    --------
    >>> v = np.zeros((8, 8, 2))
    >>> v[..., 1] = 0.5
    >>> flow_timing(v, np.ones((8, 8)), 24, travel=16)
    (72, 72.0)
    >>> v[..., 1] = 4.0
    >>> flow_timing(v, np.ones((8, 8)), 24, travel=16)
    (24, 8.0)
    >>> flow_timing(v, np.ones((8, 8)), 24, travel=16, frames=96)
    (96, 8.0)
    """
    v = check_vector_field("velocity", velocity)
    n_frames = check_int("n_frames", n_frames, 2)
    travel = check_range("travel", travel, 0, lo_open=True)
    if frames is not None:
        frames = check_int("frames", frames, n_frames)
        if frames % n_frames or (not repeats and frames != n_frames):
            allowed = f"a multiple of {n_frames}" if repeats else f"{n_frames}"
            raise ValueError(
                f"frames must be {allowed} (whole repeats of the difference frames' "
                f"loop of {n_frames} frames), got {frames}"
            )
    inside = np.asarray(matte) > 0.5
    speed = np.hypot(v[..., 0], v[..., 1])[inside if inside.any() else slice(None)]
    typical = float(np.median(speed)) if speed.size else 0.0
    if typical <= 1e-6:
        total = n_frames if frames is None else frames
        return total, float(total)
    wanted = 2.0 * travel / typical
    k = min(MAX_REPEATS, max(1, math.ceil(wanted / n_frames))) if repeats else 1
    total = k * n_frames if frames is None else frames
    cycles = max(1, math.floor(total / wanted))
    return total, total / cycles


def _remap(image, displacement, grid):
    """``image(x + d(x))``, bilinear, clamped at the border (OpenCV's remap)."""
    return _remap_at(image, grid[1] + displacement[..., 1], grid[0] + displacement[..., 0])


def supersample(image, factor=SUPERSAMPLE):
    r"""The image ``factor`` times finer, Lanczos-interpolated, its own pixels kept exactly.

    Pixel :math:`(i, j)` of the image is pixel :math:`(f i, f j)` of the result, bit
    for bit; between them the image is interpolated with the Lanczos kernel of
    :data:`LANCZOS_A` lobes, :math:`\operatorname{sinc}(x)\operatorname{sinc}(x/a)`
    (normalised to sum 1), one axis after the other, the border repeated. Sampling
    this with OpenCV's bicubic remap (:func:`_sample`) keeps the photo almost as
    sharp as a Lanczos remap (measured on the stream, one phase advected 1-12 frames:
    0.80-0.89 of its Laplacian variance, Lanczos 0.82-0.90, bilinear 0.41-0.56), at
    the cost of a bicubic remap (Lanczos's is about ten times slower).

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
    factor : int
        :math:`f` (>= 1).

    Returns
    -------
    ndarray, shape ((H - 1) f + 1, (W - 1) f + 1[, C]), float32
    """
    img = check_array("image", image, ndim=(2, 3), dtype_kinds="biuf").astype(np.float32)
    factor = check_int("factor", factor, 1)
    for axis in (0, 1):
        img = _supersample_axis(img, factor, axis)
    return img


def _lanczos_taps(frac, a=None):
    """The Lanczos weights of the ``2a`` pixels around a point ``frac`` past a pixel (sum 1)."""
    a = LANCZOS_A if a is None else a
    x = np.arange(-a + 1, a + 1) - frac
    w = np.sinc(x) * np.sinc(x / a)
    return w / w.sum()


def _supersample_axis(img, factor, axis):
    """:func:`supersample` along one axis: the pixels kept, each sub-pixel one 1-D filter."""
    import cv2

    n = img.shape[axis]
    if factor == 1 or n == 1:
        return img
    a = LANCZOS_A
    shape = list(img.shape)
    shape[axis] = (n - 1) * factor + 1
    out = np.empty(shape, np.float32)
    at = [slice(None)] * img.ndim
    at[axis] = slice(0, None, factor)
    out[tuple(at)] = img  # the image's own pixels, exactly
    keep = [slice(None)] * img.ndim
    keep[axis] = slice(0, n - 1)
    for p in range(1, factor):
        # Sub-pixel p/f past pixel i is sum_k tap_k I[i + k - a + 1] (k = 0 .. 2a - 1):
        # OpenCV's correlation with the taps anchored at a - 1, the border repeated.
        taps = _lanczos_taps(p / factor, a).astype(np.float32)
        kernel, anchor = (taps[None], (a - 1, 0)) if axis == 1 else (taps[:, None], (0, a - 1))
        filtered = cv2.filter2D(img, -1, kernel, anchor=anchor, borderType=cv2.BORDER_REPLICATE)
        at[axis] = slice(p, None, factor)
        out[tuple(at)] = filtered.reshape(img.shape)[tuple(keep)]
    return out


def _sample(fine, coordinates, out=(None, None)):
    """Both phases sampled from ``fine`` (:func:`supersample`) where they are, and :math:`w_a`.

    ``coordinates`` are :meth:`_Loop.coordinates` in ``fine``'s pixels; OpenCV's
    bicubic remap (its kernel, Keys' with a = -0.75, gives a pixel's own value at
    whole coordinates), clamped at the border. A phase without coordinates is None.
    ``out``: the two phases' arrays to sample into (views of a larger array will
    do), or None each.
    """
    import cv2

    xa, ya, xb, yb, w = coordinates
    a, b = (
        None
        if x is None
        else cv2.remap(
            fine, x, y, cv2.INTER_CUBIC, dst=into, borderMode=cv2.BORDER_REPLICATE
        ).reshape(x.shape + fine.shape[2:])
        for (x, y), into in zip(((xa, ya), (xb, yb)), out)
    )
    return a, b, w


def _grid(shape):
    rows, cols = np.mgrid[: shape[0], : shape[1]].astype(np.float32)
    return rows, cols


def displacement_maps(velocity, steps):
    r"""Where the content at each pixel was ``s`` frames ago, for ``s = -steps..steps``.

    A steady flow :math:`v` carries content along its streamlines: the content at
    :math:`x` after :math:`s` frames started at :math:`x + D_s(x)`, with the
    semi-Lagrangian recurrence :math:`D_0 = 0`,
    :math:`D_{s+1}(x) = D_s(x - v(x)) - v(x)` (one backtrace per frame, as
    :func:`fluidnb.fields.advect` moves content) and, backwards in time,
    :math:`D_{s-1}(x) = D_s(x + v(x)) + v(x)`. Each map is warped once, so a frame
    samples the photo once, however old its phase (Neyret 2003's flow maps).

    Parameters
    ----------
    velocity : ndarray, shape (H, W, 2)
        (dy, dx) px/frame.
    steps : int
        The largest age (>= 0).

    Returns
    -------
    ndarray, shape (2 * steps + 1, H, W, 2), float32
        ``out[steps + s]`` is :math:`D_s`.
    """
    v = check_vector_field("velocity", velocity).astype(np.float32)
    steps = check_int("steps", steps, 0)
    return _Maps(v, steps).wait(-steps, steps).maps


class _Maps:
    """:func:`displacement_maps` being made, on a thread of its own.

    Each map can be used as soon as it is made (:meth:`wait`): a renderer starts on
    its first frames while the others are made. The maps of the ages ``first`` are
    made first (forwards as far as they go, then backwards), then the rest: the first
    frames of a loop need a young phase and an old one.

    ``compact``: each map :math:`D_s` is kept as its float16 residual
    :math:`R_s = D_s + s v` (the displacement less the straight line the local flow
    would carry it along: 0 in a uniform flow, a few pixels where the flow bends)
    and read back as :math:`R_s - s v` in float32 (:meth:`at`, :func:`_staggered`),
    half the bytes of float32 maps: a loop of 96 frames needs 97 maps, 2 GB at
    1920 x 1280 as float32 (issue 39). float16 keeps 11 bits: a residual of up to
    2 px is kept to 1/1000 px, of 32 px to 1/64 px, below what the bicubic remap
    resolves (OpenCV tabulates its weights per 1/32 px). The recurrence itself runs
    in float32, so the error does not build up from map to map. Compact maps are laid
    out row by row, ``maps[r, steps + s]`` the row ``r`` of :math:`R_s` (shape
    (H, 2 steps + 1, W, 2)): a staggered frame reads, at neighbouring pixels, maps of
    neighbouring ages (:func:`_staggered`), and with this layout a row's maps of
    every age lie together (760 KB at 1968 px, in the core's cache) instead of a
    cache line of another 12 MB map for nearly every pixel (measured at 1920 px,
    97 maps: 138 ms a frame instead of 257 ms, the same values).
    """

    def __init__(self, v, steps, first=(), *, compact=False):
        h, w = v.shape[:2]
        self.steps = steps
        self.compact = compact
        self.v = v
        if compact:  # row-interleaved (see above)
            self.maps = np.empty((h, 2 * steps + 1, w, 2), np.float16)
            self.maps[:, steps] = 0.0
        else:
            self.maps = np.empty((2 * steps + 1, h, w, 2), np.float32)
            self.maps[steps] = 0.0
        self._made = {1: 0, -1: 0}  # steps made forwards and backwards
        # The float32 map each recurrence last made (compact maps are not read back).
        self._last = {1: np.zeros((h, w, 2), np.float32), -1: np.zeros((h, w, 2), np.float32)}
        self._error = None
        self._ready = threading.Condition()
        early = _reach(first)
        order = [(1, early[1]), (-1, early[-1]), (1, steps), (-1, steps)]
        # Not a daemon (even when made by one, an app's worker): the interpreter waits
        # for it at exit (a few ms) rather than ending the process inside OpenCV, which
        # aborts it.
        threading.Thread(target=self._run, args=(v, order), daemon=False).start()

    def _run(self, v, order):
        def made(sign, s):
            with self._ready:
                self._made[sign] = s
                self._ready.notify_all()

        try:
            grid = _grid(v.shape[:2])
            for sign, upto in order:
                if self.compact:
                    _chain_compact(self, grid, sign, self._made[sign], upto, made)
                else:
                    _chain(self.maps, v, grid, self.steps, sign, self._made[sign], upto, made)
        except BaseException as error:  # handed to whoever waits
            with self._ready:
                self._error = error
                self._ready.notify_all()

    def at(self, i):
        """Map ``i`` (of age ``i - steps``) as float32 :math:`D` (made: :meth:`wait`)."""
        if not self.compact:
            return self.maps[i]
        return self.maps[:, i].astype(np.float32) - np.float32(i - self.steps) * self.v

    def wait(self, *ages):
        """Wait until the maps of these ages (fractional: both whole ones around) are made."""
        need = _reach(ages)
        with self._ready:
            while self._error is None and any(self._made[k] < need[k] for k in need):
                self._ready.wait()
            if self._error is not None:
                raise self._error
        return self


def _chain_compact(maps, grid, sign, start, stop, made):
    """:func:`_chain` for a compact :class:`_Maps`: the float32 recurrence, kept as residuals.

    The same float32 operations as :func:`_chain` (each map warped from the one
    before, in float32), each map then stored as :math:`R_s = D_s + s v` in float16.
    """
    import cv2

    if stop <= start:
        return
    v = maps.v
    mx = grid[1] + (-sign * v)[..., 1]
    my = grid[0] + (-sign * v)[..., 0]
    step = sign * v
    prev = maps._last[sign]
    for s in range(start + 1, stop + 1):
        d = np.empty_like(prev)
        cv2.remap(prev, mx, my, cv2.INTER_LINEAR, dst=d, borderMode=cv2.BORDER_REPLICATE)
        np.subtract(d, step, out=d)
        age = sign * s
        maps.maps[:, maps.steps + age] = d + np.float32(age) * v
        maps._last[sign] = prev = d
        made(sign, s)


def _reach(ages):
    """The steps forwards (key 1) and backwards (-1) the maps of these ages need."""
    need = {1: 0, -1: 0}
    for age in ages:
        for s in (math.floor(age), math.ceil(age)):
            if s:
                sign = 1 if s > 0 else -1
                need[sign] = max(need[sign], abs(s))
    return need


def _chain(out, v, grid, steps, sign, start, stop, made):
    """One recurrence of :func:`displacement_maps`: ``out[steps + sign * s]``, s = start+1..stop.

    ``D_{s+1}(x) = D_s(x - v) - v`` (sign 1); backwards ``D_{s-1}(x) = D_s(x + v) + v``
    (sign -1). Every step samples at the same points ``x - sign v``, so they are
    worked out once; each map is written in place (the operations of
    ``_remap(prev, -sign * v, grid) - sign * v``); ``made(sign, s)`` after each.
    """
    import cv2

    if stop <= start:
        return
    mx = grid[1] + (-sign * v)[..., 1]
    my = grid[0] + (-sign * v)[..., 0]
    step = sign * v
    for s in range(start + 1, stop + 1):
        d = out[steps + sign * s]
        cv2.remap(
            out[steps + sign * (s - 1)], mx, my, cv2.INTER_LINEAR, dst=d,
            borderMode=cv2.BORDER_REPLICATE,
        )  # fmt: skip
        np.subtract(d, step, out=d)
        made(sign, s)


def _at_age(at, steps, age):
    """The displacement map of a (possibly fractional) age, linear between whole ones.

    ``at(i)`` is map ``i`` (of age ``i - steps``) as float32.
    """
    lo = math.floor(age)
    frac = age - lo
    d = at(steps + lo)
    if frac > 1e-9:
        d = d + np.float32(frac) * (at(steps + lo + 1) - d)
    return d


@functools.cache
def _half_table():
    """float32 of every float16 bit pattern (65,536 entries): an exact conversion table."""
    table = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float32)
    table.setflags(write=False)
    return table


def phase_offsets(shape, scale, *, seed=0):
    r"""Each pixel's offset into the loop's cycle, :math:`o(x) \in [0, 1)`: smooth and uniform.

    With one cycle for the whole picture, every pixel is half-way between its two
    phases at the same moment, twice a cycle: the picture pulses. Offsetting each
    pixel's cycle by :math:`o(x) P` (the staggered phases of texture advection: Neyret
    2003; the noise offsets of flow-map water, Vlachos 2010) spreads the moments out:
    at any time only a few pixels are mid-way, and as many at every frame. :math:`o`
    is white noise on a grid of ``scale`` pixels interpolated bicubically (smooth, so
    neighbouring pixels' phases move together), then made uniform on [0, 1) by rank
    (every offset equally common, so each frame has as many pixels at each point of
    their cycle). Its gradient shears the advected picture: a pixel's phase is
    :math:`P\,o(x)` frames older than its neighbour's, so a larger ``scale`` distorts
    less and staggers less.

    Parameters
    ----------
    shape : (int, int)
        (H, W).
    scale : float
        The noise's grid spacing in pixels (> 0).
    seed : int
        The noise's seed (the rendering is deterministic: 0).

    Returns
    -------
    ndarray, shape (H, W), float32
        :math:`o(x)`, in [0, 1).

    Examples
    --------
    >>> o = phase_offsets((60, 80), 16)
    >>> float(o.min()), bool(o.max() < 1), round(float(np.median(o)), 2)
    (0.0, True, 0.5)
    """
    import cv2

    h, w = (check_int("shape", n, 1) for n in shape)
    scale = check_range("scale", scale, 0, lo_open=True)
    gen = np.random.default_rng(seed)
    coarse = gen.random((math.ceil(h / scale) + 3, math.ceil(w / scale) + 3)).astype(np.float32)
    # The coarse grid's points `scale` apart over the picture (one point beyond each side).
    rows = (np.arange(h, dtype=np.float32) / np.float32(scale) + 1.0).astype(np.float32)
    cols = (np.arange(w, dtype=np.float32) / np.float32(scale) + 1.0).astype(np.float32)
    mx, my = np.meshgrid(cols, rows)
    noise = cv2.remap(coarse, mx, my, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
    rank = np.empty(h * w, np.float64)
    rank[np.argsort(noise.ravel(), kind="stable")] = np.arange(h * w)
    return (rank / (h * w)).reshape(h, w).astype(np.float32)


def eulerian_loop(
    image, velocity, n_frames, *, cycle, offsets=None, maps=None, return_phases=False
):
    r"""Move an image along a steady flow in a seamless loop (Eulerian looping).

    Two phases of the image, advected for :math:`s_a` and :math:`s_b` frames
    (:func:`loop_phases`), each pixel's cycle offset by :math:`o(x) P` (``offsets``,
    :func:`phase_offsets`; 0 if not given), are blended so that the result keeps
    the contrast of its parts (:func:`variance_blend`):

    .. math::

        s_a(t, x) = \big((t + o(x) P + P/2) \bmod P\big) - P/2, \qquad
        s_b(t, x) = \big((t + o(x) P) \bmod P\big) - P/2,

        I_t(x) = \operatorname{blend}\Big(I\big(x + D_{s_a}(x)\big),\,
            I\big(x + D_{s_b}(x)\big);\ w_a = 1 - 2|s_a|/P\Big)

    with the displacement maps :math:`D_s` of :func:`displacement_maps` (linear
    between whole ages), the image sampled from its :func:`supersample` with
    OpenCV's bicubic remap, clamped at the border (bilinear sampling kept only
    0.41-0.56 of the photo's Laplacian variance in a phase). So :math:`I_T = I_0` (the
    loop closes), the content moves with :math:`v` between restarts, no phase is
    displaced by more than :math:`P/2` frames of travel, and a phase restarts where
    its weight is 0. Where :math:`v = 0` every frame is the image, bit for bit; without
    ``offsets``, so is frame 0.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        The image (float).
    velocity : ndarray, shape (H, W, 2)
        The steady flow (dy, dx) in px/frame.
    n_frames : int
        :math:`T`, frames in the loop (>= 2).
    cycle : float
        Wanted frames per cycle :math:`P` (>= 2; see :func:`loop_phases`).
    offsets : ndarray, shape (H, W), optional
        :math:`o(x)` in [0, 1) (:func:`phase_offsets`); default 0 everywhere.
    maps : ndarray, optional
        :func:`displacement_maps` of ``velocity`` for at least ``ceil(P / 2)`` steps,
        if already made (the matte and the image share them).
    return_phases : bool
        Also return the two phases.

    Returns
    -------
    frames : ndarray, shape (T, H, W[, C]), float32
        :math:`I_t`.
    phase_a, phase_b : ndarray, shape (T, H, W[, C]), float32
        With ``return_phases``: :math:`I(x + D_{s_a}(x))` and :math:`I(x + D_{s_b}(x))`.

    References
    ----------
    .. [1] F. Neyret, "Advected textures", Proc. ACM SIGGRAPH/Eurographics Symposium
       on Computer Animation (SCA), pp. 147-153, 2003.
    .. [2] A. Holynski, B. Curless, S. M. Seitz and R. Szeliski, "Animating pictures
       with Eulerian motion fields", CVPR 2021.

    Examples
    --------
    A uniform flow of one pixel a frame to the right moves the picture one pixel a
    frame (the phases' blend and the finer copy's Lanczos lobes leave a little
    around the line), and frame 0 is the picture itself:

    >>> img = np.zeros((4, 12), np.float32)
    >>> img[:, 2] = 1.0
    >>> v = np.zeros((4, 12, 2), np.float32)
    >>> v[..., 1] = 1.0
    >>> frames = eulerian_loop(img, v, 8, cycle=8)
    >>> bool(np.array_equal(frames[0], img))
    True
    >>> [round(float(x), 1) for x in frames[1, 0, :6]]
    [-0.0, -0.0, -0.0, 0.8, -0.0, -0.0]
    """
    img = check_array("image", image, ndim=(2, 3), dtype_kinds="biuf").astype(np.float32)
    v = check_vector_field("velocity", velocity, shape=img.shape[:2])
    loop = _Loop(n_frames, cycle, offsets, img.shape[:2])
    if maps is None:
        maps = displacement_maps(v, loop.steps)
    elif maps.shape[0] < 2 * loop.steps + 1 or maps.shape[1:] != img.shape[:2] + (2,):
        raise ValueError(
            f"maps must be displacement_maps(velocity, {loop.steps}) of shape "
            f"({2 * loop.steps + 1}, {img.shape[0]}, {img.shape[1]}, 2), got {maps.shape}"
        )
    fine = supersample(img)
    grid = _grid(img.shape[:2])
    out = np.empty((n_frames,) + img.shape, np.float32)
    phases = np.empty((2, n_frames) + img.shape, np.float32) if return_phases else None
    for t in range(n_frames):
        a, b, w = loop.phases(fine, maps, grid, t, both=return_phases)
        if return_phases:
            phases[0, t], phases[1, t] = a, b
        _blend_phases(a, b, w, out[t])
    if return_phases:
        return out, phases[0], phases[1]
    return out


class _Loop:
    """The timing of an Eulerian loop: each pixel's phases' ages and weights at each frame.

    ``age_a``, ``age_b``, ``weight_a`` (T,) are :func:`loop_phases`'s (the pixels at
    offset 0); ``period`` is :math:`P`; ``steps`` the largest whole age any pixel
    reaches (the displacement maps needed); ``offsets`` :math:`o(x)` or None.
    """

    def __init__(self, n_frames, cycle, offsets, shape):
        self.age_a, self.age_b, self.weight_a = loop_phases(n_frames, cycle)
        self.period = n_frames / max(1, round(n_frames / cycle))
        if offsets is not None:
            offsets = check_array("offsets", offsets, ndim=2, dtype_kinds="f")
            if offsets.shape != tuple(shape):
                raise ValueError(f"offsets must have shape {tuple(shape)}, got {offsets.shape}")
            if offsets.min() < 0 or offsets.max() >= 1:
                raise ValueError(
                    f"offsets must be in [0, 1), got values in "
                    f"[{float(offsets.min()):g}, {float(offsets.max()):g}]"
                )
            offsets = offsets.astype(np.float32, copy=False)
            self.steps = math.ceil(self.period / 2)
        else:
            self.steps = math.ceil(max(np.abs(self.age_a).max(), np.abs(self.age_b).max()))
        self.offsets = offsets

    def ages(self, t):
        """The ages frame ``t`` needs (for :meth:`_Maps.wait`)."""
        if self.offsets is None:
            return self.age_a[t], self.age_b[t]
        return -self.steps, self.steps

    def coordinates(self, maps, grid, t, *, scale=1, both=False, staggered=True, box=None):
        """Where each phase samples the picture at frame ``t`` and phase a's weight.

        ``(xa, ya, xb, yb, w)``: (H, W) float32 coordinates times ``scale`` (in the
        picture :func:`supersample` made finer), and :math:`w_a` one number
        (no offsets or not ``staggered``: the loop at offset 0; a phase of weight 0
        then has None coordinates unless ``both``) or (H, W). ``box`` (r0, r1, c0, c1):
        only the pixels ``[r0:r1, c0:c1]``, the same values (the flow rendering's
        frames outside the matte's box are the photo: :class:`_FlowFrames`).
        """
        if box is not None and (self.offsets is None or not staggered):
            # The loop at offset 0 (rare: no stagger): made whole, then cut.
            cut = (slice(box[0], box[1]), slice(box[2], box[3]))
            full = self.coordinates(maps, grid, t, scale=scale, both=both, staggered=staggered)
            return tuple(x if x is None or np.ndim(x) == 0 else x[cut] for x in full)
        # The maps as an array of D_s, or a _Maps that keeps them compact (float16
        # residuals: decoded here, the same values wherever they are read).
        compact = isinstance(maps, _Maps) and maps.compact
        array = maps.maps if isinstance(maps, _Maps) else maps
        have = (array.shape[1 if compact else 0] - 1) // 2
        if self.offsets is None or not staggered:
            sa, sb, wa = self.age_a[t], self.age_b[t], self.weight_a[t]
            xa = ya = xb = yb = None
            k = np.float32(scale)
            at = maps.at if compact else (lambda i: array[i])
            if wa > 0 or both:
                d = _at_age(at, have, sa)
                xa, ya = (grid[1] + d[..., 1]) * k, (grid[0] + d[..., 0]) * k
            if wa < 1 or both:
                d = _at_age(at, have, sb)
                xb, yb = (grid[1] + d[..., 1]) * k, (grid[0] + d[..., 0]) * k
            return xa, ya, xb, yb, wa
        h, w = grid[0].shape
        r0, r1, c0, c1 = (0, h, 0, w) if box is None else box
        xa, ya, xb, yb, wa = (np.empty((r1 - r0, c1 - c0), np.float32) for _ in range(5))
        if compact:
            array, table, v = array.view(np.uint16), _half_table(), maps.v
        else:
            table, v = None, np.zeros((1, 1, 2), np.float32)
        _staggered(
            array, table, v, have, float(t), float(self.period), self.offsets,
            np.float32(scale), r0, c0, xa, ya, xb, yb, wa,
        )  # fmt: skip
        return xa, ya, xb, yb, wa

    def phases(self, fine, maps, grid, t, *, both=False):
        """Frame ``t``'s two phases sampled from ``fine`` (:func:`supersample`), and :math:`w_a`.

        A phase of weight 0 everywhere is None unless ``both``.
        """
        return _sample(fine, self.coordinates(maps, grid, t, scale=SUPERSAMPLE, both=both))


@njit(cache=True, nogil=True, inline="always")
def _displacement(maps, table, v, i, steps, r, c):
    """``D`` of map ``i`` at pixel (r, c), float32.

    float32 maps (2 steps + 1, H, W, 2) as they are (``table`` None), or a compact
    map's float16 residual (its bits, through ``table``; the row-interleaved layout
    (H, 2 steps + 1, W, 2) of :class:`_Maps`) less ``(i - steps) v``.
    """
    if table is None:
        return maps[i, r, c, 0], maps[i, r, c, 1]
    age = np.float32(i - steps)
    return table[maps[r, i, c, 0]] - age * v[r, c, 0], table[maps[r, i, c, 1]] - age * v[r, c, 1]


@njit(cache=True, nogil=True)
def _staggered(maps, table, v, steps, t, period, offsets, scale, r0, c0, xa, ya, xb, yb, wa):
    r"""Each pixel's phase coordinates (times ``scale``) and weight at frame ``t``, by its offset.

    The pixels ``[r0 : r0 + h, c0 : c0 + w]`` of the canvas, ``(h, w)`` the outputs' shape.

    The ages in float64: :math:`u = t + o P`, :math:`s_b = (u \bmod P) - P/2`,
    :math:`s_a = ((u + P/2) \bmod P) - P/2` (the modulo as ``u - P floor(u / P)``).
    ``maps`` float32 :math:`D_s` (``table`` None) or a compact :class:`_Maps`'s
    float16 bits (``table`` :func:`_half_table`, ``v`` the flow).
    """
    h, w = xa.shape
    half = period / 2.0
    inv = 1.0 / period
    top = 2 * steps
    for rr in range(h):
        r = r0 + rr
        for cc in range(w):
            c = c0 + cc
            u = t + offsets[r, c] * period
            age_b = u - period * math.floor(u * inv) - half
            age_a = age_b + half if age_b < 0.0 else age_b - half
            wa[rr, cc] = min(max(1.0 - abs(age_a) / half, 0.0), 1.0)
            for k in range(2):
                age = age_a if k == 0 else age_b
                lo = math.floor(age)
                frac = np.float32(age - lo)
                i = min(max(steps + int(lo), 0), top)
                dy, dx = _displacement(maps, table, v, i, steps, r, c)
                if frac > 1e-9:
                    j = min(i + 1, top)
                    ey, ex = _displacement(maps, table, v, j, steps, r, c)
                    dy = dy + frac * (ey - dy)
                    dx = dx + frac * (ex - dx)
                x, y = (c + dx) * scale, (r + dy) * scale
                if k == 0:
                    xa[rr, cc], ya[rr, cc] = x, y
                else:
                    xb[rr, cc], yb[rr, cc] = x, y


def _blend_phases(a, b, w, out, scratch=None):
    """The phases' blend into ``out``: one alone where its weight is 1, else variance_blend.

    ``scratch``: a dict that keeps the blend's intermediate arrays for the next call.
    """
    if np.ndim(w) == 0 and w == 1:
        out[...] = a
    elif np.ndim(w) == 0 and w == 0:
        out[...] = b
    else:
        weights = np.full(a.shape[:2], w, np.float32) if np.ndim(w) == 0 else w
        _blend(a, b, weights, out, scratch)
    return out


def _carry(alpha, coordinates, scale=1):
    """A matte carried by the loop: both phases sampled bilinearly, cross-faded linearly.

    ``coordinates`` (:meth:`_Loop.coordinates`) are ``scale`` times the matte's pixels.
    """
    xa, ya, xb, yb, w = coordinates
    k = np.float32(1 / scale)
    a = None if xa is None else _remap_at(alpha, xa * k, ya * k)
    b = None if xb is None else _remap_at(alpha, xb * k, yb * k)
    if a is None:
        return b
    if b is None:
        return a
    return b + np.asarray(w, np.float32) * (a - b)


def _remap_at(image, mx, my):
    import cv2

    out = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(image.shape)


def extend_outside(image, matte):
    r"""The image inside the matte, mirrored into the rest: what the flow may carry in.

    The flow rendering advects the fluid from upstream, which near the matte's edge
    lies outside it: rock or sky would flow into the water. So the layer that is
    advected is the image where the matte is above 0, and outside it the image
    reflected back across the matte's edge (each outside pixel :math:`p` takes the
    pixel :math:`2b - p` mirrored about its nearest matte pixel :math:`b`, or
    :math:`b` itself when the mirror point falls outside the matte or the image):
    the fluid's own texture continues, without the streaks of repeating the edge.

    Parameters
    ----------
    image : ndarray, shape (H, W, C)
    matte : ndarray, shape (H, W)
        Pixels with ``matte > 0`` are kept.

    Returns
    -------
    ndarray, shape (H, W, C), float32
        Equal to ``image`` wherever ``matte > 0``.
    """
    img = np.asarray(image, np.float32)
    inside = np.asarray(matte) > 0
    if inside.all() or not inside.any():
        return img.copy()
    _, (rows, cols) = ndi.distance_transform_edt(~inside, return_indices=True)
    h, w = inside.shape
    yy, xx = np.mgrid[:h, :w]
    my, mx = 2 * rows - yy, 2 * cols - xx
    ok = (my >= 0) & (my < h) & (mx >= 0) & (mx < w)
    my, mx = np.where(ok, my, rows), np.where(ok, mx, cols)
    ok = inside[my, mx]
    my, mx = np.where(ok, my, rows), np.where(ok, mx, cols)
    return img[my, mx]
