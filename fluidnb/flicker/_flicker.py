r"""The flicker model: any frame of the loop on demand, or the whole clip at once.

How the paper's 3-D inverse DFT (Eq. (5)) is evaluated here. The mapped spectrum with
noise (Eq. (10)) is :math:`U(f_x, f_y, f_t) = F(f_x, f_y) N_{f_c(f_x, f_y)}(f_t)`,
where the temporal spectrum :math:`N_c` depends only on the integer bin
:math:`c = f_c` (the random phase :math:`\phi` depends on :math:`f_t` only). So

.. math:: I_{out}(x, y, t) = \sum_c B_c(x, y) \, g_c(t), \qquad
          B_c = \mathrm{IDFT}_2\big(F \cdot [f_c = c]\big), \quad
          g_c(t) = \sum_{f_t} N_c(f_t) e^{j 2\pi f_t t / T}

There are only K distinct bins (1 for the plane, ~T/2 for the curved surfaces and the
flow), so the model makes K inverse 2-D DFTs once (for the paper's mappings real FFTs
of :math:`\cos\alpha` and :math:`\sin\alpha`, whose spectra restricted to a bin stay
Hermitian because :math:`f_c` is even in :math:`(f_x, f_y)`; for the flow mapping,
which is not even, complex ones), and then each frame's height
:math:`C + A \, \mathrm{Im}\, I_{out}` is a matrix product over the K bins. Frames
are made in aligned blocks of ``_BLOCK``: a matrix product's rounding depends on how
many rows it has, and computing a single frame through its block makes
:meth:`FlickerModel.frame` bit-identical to the same frame of the whole clip. With
noise, the normalisation needs the whole loop (its RMS from a sample of the region's
pixels, its peak from one pass over the blocks); the heights are then made again block
by block as the frames are made, so no table of the whole loop is held and a stream
(:meth:`FlickerModel.stream`) holds a few frames at a time (issue 39).

:func:`fluidnb.flicker._reference.flicker_reference` is the same model written out
literally (one 3-D spectrum, one 3-D inverse DFT); the tests check this one against it.
"""

from __future__ import annotations

import math
import os
import queue
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._clip import Clip
from .._image import as_image, as_mask
from .._kept import LastKept
from .._progress import Progress
from .._random import resolve_seed, rng
from .._stream import FrameStream, timed
from .._threads import blas_single_threaded
from .._validation import check_int, check_range
from ._flow import as_velocity
from ._kernels import shade_relight, soft_heights
from ._params import FlickerParams
from ._shading import _lambert_frame, _Relight, _Work, feather_weights, light_vector
from ._spectrum import (
    harmonic_height,
    height_from_luminance,
    initial_phase,
    noise_spectrum,
    phase_spectrum,
    region_weights,
    temporal_frequencies,
    temporal_signals,
)

__all__ = ["FlickerModel", "base_method", "flicker", "preview"]

_BLOCK = 16  # frames per matrix product (see the module docstring)
_THREADS = max(1, min(4, os.cpu_count() or 1))  # threads for the per-pixel shading
_BINS_PER_REPORT = 4  # inverse DFTs per progress report
_KNEE = 0.7  # where the soft clip of the RMS-normalised noise starts bending (units of A)
_RMS_SAMPLES = 1 << 16  # pixels the RMS normalisation averages over, at most


def _check_params(params):
    if params is None:
        return FlickerParams()
    if not isinstance(params, FlickerParams):
        raise ValueError(f"params must be a FlickerParams, got {type(params).__name__}")
    return params


def _check_flow(flow, params):
    """The flow mapping's velocity (full-resolution px/frame), or None for the others."""
    velocity = as_velocity(flow, params.T)
    if params.mapping == "flow":
        if velocity is None:
            raise ValueError(
                "mapping='flow' needs flow=: a stroke (n, 2) drawn along the flow, or a "
                "velocity (dy, dx) in pixels per frame"
            )
        return velocity
    if velocity is not None:
        raise ValueError(f"flow= is only used by mapping='flow', got mapping={params.mapping!r}")
    return None


def _pad_upstream(alpha, velocity, T):
    """``alpha`` mirrored out on the upstream side(s), and the slices that crop it back.

    The inverse DFT is periodic, so a pattern moving by ``velocity`` (px/frame of this
    grid) over ``T`` frames pulls in what lies up to ``T |v|`` pixels upstream -- the
    window's other end, with a seam. A mirrored margin at least that wide (grown to a
    fast FFT size) keeps the seam outside the window for the whole loop.
    """
    from scipy.fft import next_fast_len

    if velocity is None:
        return alpha, (slice(None), slice(None))
    pads = []
    for n, v in zip(alpha.shape, velocity):
        if v == 0:
            pads.append((0, 0))
            continue
        extra = next_fast_len(n + math.ceil(T * abs(v)) + 2) - n
        pads.append((extra, 0) if v > 0 else (0, extra))
    padded = np.pad(alpha, pads, mode="symmetric")
    crop = tuple(slice(a, a + n) for (a, _), n in zip(pads, alpha.shape))
    return padded, crop


def _bin_reporter(report, start, span):
    def step(i, k):
        if i % _BINS_PER_REPORT == 0:
            report(start + span * i / k, f"inverse DFT, bin {i + 1} of {k}")

    return step


def _basis_symmetric(alpha, index, bins, step):
    r"""Rows (Re B_c, Im B_c) of :math:`B_c = \mathrm{IDFT}_2(F [f_c = c])`, (2K, h w).

    For the paper's mappings: :math:`f_c` is even in :math:`(f_x, f_y)`, so the two
    real fields :math:`\cos\alpha` and :math:`\sin\alpha` keep Hermitian spectra
    on each bin, and real FFTs of half the size give Re B_c and Im B_c directly. The
    inverse DFT is done as its two 1-D passes: a bin is an annulus of spatial
    frequencies, so the first pass (along y) only needs the columns the annulus
    crosses, about half of them on average.

    The bins are shared out among ``_THREADS`` threads, each doing whole bins with
    single-threaded transforms: besides the transforms, a bin is a few passes of
    numpy (selecting it, zeroing, copying its rows) that one thread did while the
    other core waited (at 1920 px 1.2 s before the first frame; issue 39). A bin's
    rows do not depend on which thread makes them.
    """
    import scipy.fft

    h, w = alpha.shape
    half = scipy.fft.rfft2(np.stack([np.cos(alpha), np.sin(alpha)]), workers=-1)
    half = half.astype(np.complex64)
    lookup = np.zeros(int(index.max()) + 1, np.intp)
    lookup[bins] = np.arange(len(bins))
    inverse = lookup[index[:, : w // 2 + 1]]
    k = len(bins)
    basis = np.empty((2 * k, h * w), np.float32)
    done = queue.SimpleQueue()
    stop = threading.Event()

    def bins_of(first, every):
        work = np.empty((2, h, w // 2 + 1), np.complex64)
        try:
            for i in range(first, k, every):
                if stop.is_set():
                    return
                select = inverse == i
                cols = np.flatnonzero(select.any(axis=0))
                c0, c1 = int(cols[0]), int(cols[-1]) + 1
                work.fill(0)
                work[:, :, c0:c1] = scipy.fft.ifft(half[:, :, c0:c1] * select[:, c0:c1], axis=-2)
                rows = scipy.fft.irfft(work, n=w, axis=-1)
                basis[2 * i : 2 * i + 2] = rows.reshape(2, h * w)
                done.put(True)  # a bin made
        finally:
            done.put(False)  # this thread has ended (or failed)

    threads = min(_THREADS, k)
    with ThreadPoolExecutor(threads, thread_name_prefix="fluidnb-flicker") as pool:
        running = [pool.submit(bins_of, j, threads) for j in range(threads)]
        made = ended = 0
        try:
            while ended < threads:
                if done.get():
                    step(made, k)
                    made += 1
                else:
                    ended += 1
        finally:
            stop.set()  # a cancelled progress (or a failed thread): the others stop
        for f in running:
            f.result()
    return basis


def _basis_flow(padded, index, bins, crop, velocity, step):
    r"""The same rows for the flow mapping, whose :math:`f_c` is not even.

    :math:`B_c` is complex now: full complex inverse DFTs of the padded field, cropped
    to the window. A bin is a band of spatial frequencies across the velocity, so the
    first 1-D pass runs only over the columns (flow mostly along x) or rows (mostly
    along y) the band crosses, and the second only over the window's lines.
    """
    import scipy.fft

    rows, cols = crop
    F = scipy.fft.fft2(np.exp(1j * padded), workers=-1).astype(np.complex64)
    # Prune across the flow: transform first along the axis the bands run along.
    along = 0 if abs(velocity[1]) >= abs(velocity[0]) else 1
    if along == 1:  # work on the transpose, so the code below is written once
        F, index, rows, cols = F.T, index.T, cols, rows
    hp, wp = F.shape
    k = len(bins)
    out = np.empty((2 * k,) + padded[crop].shape, np.float32)
    work = np.empty((hp, wp), np.complex64)
    for i, c in enumerate(bins):
        step(i, k)
        select = index == c
        used = np.flatnonzero(select.any(axis=0))
        c0, c1 = int(used[0]), int(used[-1]) + 1
        work.fill(0)
        work[:, c0:c1] = scipy.fft.ifft(F[:, c0:c1] * select[:, c0:c1], axis=0, workers=-1)
        B = scipy.fft.ifft(work[rows], axis=1, workers=-1)[:, cols]
        if along == 1:
            B = B.T
        out[2 * i] = B.real
        out[2 * i + 1] = B.imag
    return out.reshape(2 * k, -1)


def _window(mask, margin=1):
    """Slices of the region's bounding box (+ margin), grown to a fast FFT size."""
    from scipy.fft import next_fast_len

    h, w = mask.shape
    if mask.all():
        return (slice(0, h), slice(0, w))
    out = []
    for axis, n in ((1, h), (0, w)):
        idx = np.flatnonzero(mask.any(axis=axis))
        lo, hi = max(int(idx[0]) - margin, 0), min(int(idx[-1]) + 1 + margin, n)
        size = min(next_fast_len(hi - lo, real=True), n)
        lo = min(max(lo - (size - (hi - lo)) // 2, 0), n - size)
        out.append(slice(lo, lo + size))
    return tuple(out)


class _Scene:
    """What both methods share: the photo, the region, the initial phases, the shading.

    Heights are shaded relative to C and pre-multiplied by ``bump / (2 pixel_size)``
    (the shading kernel's input): the constant C does not change a slope, and scaling
    the few coefficients instead of every pixel saves a pass over each frame.
    """

    def __init__(self, image, mask, params, pixel_size):
        self.params = params
        self.image = as_image(image)
        shape = self.image.shape[:2]
        self.mask = np.ones(shape, bool) if mask is None else as_mask(mask, shape, name="mask")
        self.pixel_size = check_range("pixel_size", pixel_size, 0, lo_open=True)
        self.window = _window(self.mask)
        self.luminance = height_from_luminance(self.image)
        p = params
        self.alpha = initial_phase(self.luminance[self.window], p.A, p.C, p.branch)
        self.light = light_vector(p.azimuth, p.elevation)
        #: Heights (relative to C) times this are what the shading kernel takes.
        self.slope_scale = p.bump / (2.0 * self.pixel_size)
        # Eq. (2): the rest height A sin(alpha) (+ C), equal to the luminance where it
        # lies in [C - A, C + A]; its shading S_0 is what the photo already shows.
        rest = (p.A * self.slope_scale * np.sin(self.alpha)).astype(np.float32)
        self.reference = np.empty(rest.shape, np.float32)
        _lambert_frame(rest, self.light, self.reference, _Work(rest.shape))
        weight = feather_weights(self.mask[self.window], p.feather, pixel_size=pixel_size)
        self.relighter = _Relight(self.image[self.window], self.reference, p.k * weight)

    def render(self, slopes, out):
        """Frames ``out`` (n, h, w[, 3]) of the window from pre-scaled heights (n, h, w).

        Compiled, one pass a frame (:func:`._kernels.shade_relight`); the numpy
        version, :meth:`render_reference`, is what the tests compare it with.
        """
        relight = self.relighter
        light = self.light.astype(np.float32)
        for i in range(slopes.shape[0]):
            frame = out[i] if out.ndim == 4 else out[i][..., None]
            shade_relight(
                slopes[i],
                light,
                relight.kw,
                relight.offset,
                relight.cap,
                relight.can_go_negative,
                relight.planes,
                frame,
            )
        return out

    def render_reference(self, slopes, out):
        """:meth:`render` in numpy: :func:`_lambert_frame`, then ``_Relight.frame``."""
        work = _Work(slopes.shape[1:])
        shading = np.empty(slopes.shape[1:], np.float32)
        factor = np.empty(slopes.shape[1:], np.float32)
        for i in range(slopes.shape[0]):
            _lambert_frame(slopes[i], self.light, shading, work)
            self.relighter.frame(shading, out[i], factor)
        return out

    def submit(self, slopes, out, pool):
        """Start :meth:`render` split over the pool's threads; returns the futures.

        numpy releases the GIL in its loops, so the threads run in parallel, and the
        caller can compute the next block's heights meanwhile.
        """
        n = slopes.shape[0]
        parts = min(_THREADS, n)
        cuts = [round(i * n / parts) for i in range(parts + 1)]
        return [
            pool.submit(self.render, slopes[a:b], out[a:b])
            for a, b in zip(cuts[:-1], cuts[1:])
            if b > a
        ]

    def empty_clip(self, n):
        """(n, H, W[, 3]) frames holding the photo outside the window."""
        img = self.image
        out = np.empty((n,) + img.shape, np.float32)
        rows, cols = self.window
        # Only the four slabs around the window: the window is overwritten anyway.
        for r, c in (
            (slice(0, rows.start), slice(None)),
            (slice(rows.stop, None), slice(None)),
            (rows, slice(0, cols.start)),
            (rows, slice(cols.stop, None)),
        ):
            if img[r, c].size:
                out[:, r, c] = img[r, c]
        return out

    def frame_from(self, slopes):
        """One full frame (H, W[, 3]) from pre-scaled heights (h, w) of the window."""
        out = self.image.copy()
        sub = np.empty(slopes.shape + self.image.shape[2:], np.float32)
        self.render(slopes[None], sub[None])
        out[self.window] = sub
        return out


class FlickerModel:
    r"""A precomputed flicker animation that can make any single frame alone.

    Builds the expensive parts once: the initial phases (Eq. (3)), the spectrum
    (Eq. (4)), the mapping (Eq. (7)-(9)), the noise (Eq. (10)) and one inverse 2-D DFT
    per distinct temporal bin, so that each frame of Eq. (5) is then a small matrix
    product plus the shading. Only the bounding box of the region (the *window*,
    grown to a fast FFT size) is transformed; the photo's own phases fill it, so the
    region's edge adds no artificial high frequencies.

    Parameters
    ----------
    image : array_like, path or PIL image, shape (H, W) or (H, W, 3)
        The photo (anything :func:`fluidnb.as_image` accepts).
    mask : array_like of bool, shape (H, W), optional
        The region to animate (painted; value > 0.5 is inside). Default: the whole
        image. Pixels outside it are never changed.
    params : FlickerParams, optional
        The paper's values by default.
    seed : None, int or numpy.random.Generator
        For the noise phases :math:`\phi` of Eq. (10). ``None`` draws a seed and
        records it in :attr:`seed`, so the clip can be made again.
    pixel_size : float
        Size of one pixel of ``image`` in pixels of the full-resolution photo the
        parameters are meant for (a quarter-size preview passes 4): the mapping,
        the slopes and the feather then mean the same at every size.
    progress : callable, optional
        ``progress(fraction, message)``; may raise :class:`fluidnb.Cancelled`.

    Attributes
    ----------
    params : FlickerParams
    seed : int or None
        The seed used (None when a Generator was given).
    n_frames : int
        ``T``.
    window : tuple of slice
        The analysed rows and columns.
    alpha : ndarray, shape (h, w), float64
        :math:`\alpha` over the window (Eq. (3)).
    bins : ndarray of int
        The K distinct temporal bins :math:`f_c \bmod T` in use.
    velocity : ndarray, shape (2,), or None
        :math:`v = (v_y, v_x)` of the flow mapping, full-resolution px/frame.
    normalisation : float
        With noise, what :math:`I_{out}` is divided by: with ``noise_norm="rms"``
        the factor that gives the heights the RMS of the same mapping without
        noise (over the region and the loop; the soft clip comes after); with ``"peak"`` the peak of
        :math:`|\mathrm{Im}\, I_{out}|`, so the heights span exactly
        :math:`[C - A, C + A]`. 1 without noise (the heights are then Eq. (5) as it
        is, so frame 0 is the photo).
    timings : dict of str to float
        Seconds per stage of the precomputation.

    Notes
    -----
    The height is :math:`H(x, y, t) = C + A \, \mathrm{Im}\, I_{out}(x, y, t)`. With the
    plane mapping and no noise, :math:`I_{out} = e^{j(\alpha + 2\pi f_0 t / T)}`
    and this is Eq. (1) exactly. The curved mappings dephase the spatial frequencies,
    so :math:`|I_{out}|` is no longer 1 at every pixel and, without noise, the height
    can leave :math:`[C - A, C + A]` by some tenths of A where they add up; it is not
    clipped (only its slopes are used, and clipping would flatten them into
    plateaus).

    With noise (decision of spec 01-flicker; Eq. (10) leaves the scale open) the
    default divides the field so that its RMS swing is that of the clip without
    noise, and bends the few heights that pass :math:`C \pm A` back with
    :func:`soft_clip`: :math:`H = C + A \, \sigma(\mathrm{Im}\, I_{out})`. Divided by
    its peak instead (``noise_norm="peak"``), the loudest moment of the loop sets the
    scale and the typical swing falls to about a third of the noise-free one.

    The random phase :math:`\phi(f_t)` of Eq. (10) is shared by every spatial
    frequency, so the noise speeds up and slows down the whole region at once; the
    paper names this as its open problem (Yamamoto & Sakamoto, sec. 5).
    ``noise_regions = n > 1`` (beyond the paper) gives each of ``n`` soft regions
    (:func:`region_weights`) its own phases and blends the heights with weights
    :math:`w_g / \sqrt{\sum_g w_g^2}`, which keeps the RMS of the independent parts.

    The flow mapping's pattern moves round the periodic DFT domain; the window is
    mirrored out upstream by at least the distance travelled in one loop, so the
    seam never comes into view. A structure can only travel and still loop if it
    moves a whole number of its wavelengths per loop: structures larger than
    :math:`T |v|` pixels stay in place and only oscillate.

    Examples
    --------
    >>> img = np.random.default_rng(0).random((32, 48))
    >>> model = FlickerModel(img, params=FlickerParams(T=16), seed=1)
    >>> model.frame(3).shape, model.n_frames
    ((32, 48), 16)
    >>> bool(np.array_equal(model.frame(3), model.frames()[3]))
    True
    """

    def __init__(
        self, image, mask=None, params=None, *, flow=None, seed=None, pixel_size=1.0, progress=None
    ):
        report = Progress(progress)
        params = _check_params(params)
        self.velocity = _check_flow(flow, params)
        self.seed = resolve_seed(seed)
        self.params = params
        self.timings = {}
        clock = time.perf_counter()

        report(0.0, "initial phase")
        scene = _Scene(image, mask, params, pixel_size)
        self._scene = scene
        self.window = scene.window
        self.alpha = scene.alpha
        # The flow mapping moves the pattern, and the DFT wraps it round the window: pad
        # the upstream side so the seam never travels into view within one loop.
        v = None if self.velocity is None else self.velocity / scene.pixel_size
        self._analysed, self._crop = _pad_upstream(self.alpha, v, params.T)
        now = time.perf_counter()
        self.timings["analyse"], clock = now - clock, now

        report(0.1, "spectrum")
        fc = temporal_frequencies(
            self._analysed.shape, params, pixel_size=scene.pixel_size, velocity=self.velocity
        )
        index = np.mod(fc, params.T)
        # The distinct bins in use.
        self.bins = np.flatnonzero(np.bincount(index.ravel(), minlength=params.T))
        # g_c(t) for the bins in use, (K, T) complex: one set per noise region (one, as
        # in Eq. (10), unless noise_regions > 1).
        draw = rng(self.seed)
        regions = params.noise_regions if params.beta > 0 else 1
        self._region_signals = [
            temporal_signals(noise_spectrum(params.T, params.beta, seed=draw)[self.bins])
            for _ in range(regions)
        ]
        self._signals = self._region_signals[0]
        self._blend = None
        if regions > 1:
            # Independent processes blended with weights w_g keep their RMS when divided
            # by sqrt(sum w_g^2).
            w = region_weights(self.alpha.shape, regions, seed=draw)
            w /= np.sqrt(np.sum(w**2, axis=0))
            self._blend = w.reshape(regions, -1).astype(np.float32)
        now = time.perf_counter()
        self.timings["spectrum"], clock = now - clock, now

        progress_bins = _bin_reporter(report, 0.15, 0.6)
        if v is None:
            self._basis = _basis_symmetric(self.alpha, index, self.bins, progress_bins)
        else:
            self._basis = _basis_flow(
                self._analysed, index, self.bins, self._crop, v, progress_bins
            )
        now = time.perf_counter()
        self.timings["synthesis"], clock = now - clock, now

        self.normalisation = 1.0
        self._cache = {}
        self._rest = None
        # Im(B g) = Re B Im g + Im B Re g, with A folded in; one set per noise region.
        self._coefficients = self._make_coefficients(params.A)
        self._region_coefficients = [
            self._make_coefficients(params.A, signals) for signals in self._region_signals
        ]
        self._noisy = params.beta > 0
        if self._noisy:
            # The random phases can add up anywhere in the loop, so the scale needs the
            # whole loop: its RMS from a sample of the region's pixels (a ratio of
            # averages needs no more), its peak from one pass over every frame. The
            # heights themselves are made again block by block as frames are made, so
            # no (T, h w) table of the whole loop is ever held (at 1920 px it was 0.6 GB).
            report(0.8, "noise normalisation")
            inside = np.flatnonzero(scene.mask[self.window].ravel())
            if params.noise_norm == "peak":
                peak = self._peak(inside)
                self.normalisation = peak / params.A if peak > 0 else 1.0
            else:
                self.normalisation = self._rms_ratio(inside)
        # The shading kernel's input (pre-scaled slopes) is the heights times this, or,
        # without noise, a product with coefficients that have it folded in.
        self._slope_scale = np.float32(scene.slope_scale)
        self._slope_coefficients = self._make_coefficients(params.A * scene.slope_scale)
        self.timings["normalise"] = time.perf_counter() - clock
        report(1.0, "ready")

    def _raw_heights(self, t0, t1, columns=slice(None), out=None):
        r""":math:`A \, \mathrm{Im}\, I_{out}` of frames t0..t1 before normalisation, (n, m).

        With ``noise_regions > 1`` the regions' independent heights blended by their
        weights (Notes of the class). ``out`` (n, m) float32, if given, receives them.
        """
        basis = self._basis if isinstance(columns, slice) else self._basis[:, columns]
        rows = _product(self._region_coefficients[0][t0:t1], basis, out)
        if self._blend is not None:
            rows *= self._blend[0, columns]
            for coefficients, weight in zip(self._region_coefficients[1:], self._blend[1:]):
                part = _product(coefficients[t0:t1], basis)
                part *= weight[columns]
                rows += part
        return rows

    def _heights(self, t0, t1, out=None):
        r"""Heights relative to C of frames t0..t1 of one aligned block, (n, h * w).

        With noise, :math:`A \, \mathrm{Im}\, I_{out}` divided by
        :attr:`normalisation` (and, for ``"rms"``, bent by :func:`soft_clip`). ``out``
        as for :meth:`_raw_heights`.
        """
        if not self._noisy:
            return _product(self._coefficients[t0:t1], self._basis, out)
        rows = self._raw_heights(t0, t1, out=out)
        p = self.params
        if p.noise_norm == "peak":
            rows *= np.float32(1.0 / self.normalisation)
            return rows
        # Heights relative to C in units of A, then bent smoothly into (-1, 1). (As a
        # ratio of RMS the normalisation is in units of A already.)
        # (row *= scale; soft_clip(row, _KNEE, out=row); row *= A, compiled: one pass.)
        scale, A = np.float32(1.0 / (p.A * self.normalisation)), np.float32(p.A)
        soft_heights(rows, scale, np.float32(_KNEE), A)
        return rows

    def _peak(self, inside):
        r"""The peak of :math:`|A \, \mathrm{Im}\, I_{out}|` over the region and the loop."""
        peak = 0.0
        if not len(inside):
            return peak
        everywhere = len(inside) == self._basis.shape[1]
        for t0 in range(0, self.params.T, _BLOCK):
            rows = self._raw_heights(t0, min(t0 + _BLOCK, self.params.T))
            part = rows if everywhere else rows[:, inside]
            peak = max(peak, float(part.max()), -float(part.min()))
        return peak

    def _rms_ratio(self, inside):
        """RMS of the noisy heights over that of the same mapping without noise.

        Both over the whole loop and the region: every pixel of it up to
        ``_RMS_SAMPLES`` values, else an even sample (a ratio of averages needs no
        more).
        """
        T = self.params.T
        step = max(1, -(-len(inside) * T // _RMS_SAMPLES))
        inside = inside[::step]
        if not len(inside):
            return 1.0
        # Without noise each bin is a pure turn, g_c(t) = e^{j 2 pi c t / T}.
        turns = np.mod(np.outer(self.bins, np.arange(T)), T)
        quiet_signals = np.exp(2j * np.pi * turns / T)
        quiet = _product(
            self._make_coefficients(self.params.A, quiet_signals), self._basis[:, inside]
        )
        noisy = self._raw_heights(0, T, inside)
        target = float(np.sqrt(np.mean(np.square(quiet, dtype=np.float64))))
        actual = float(np.sqrt(np.mean(np.square(noisy, dtype=np.float64))))
        return actual / target if target > 0 and actual > 0 else 1.0

    @classmethod
    def reduced(
        cls, image, mask=None, params=None, *, flow=None, size=128, seed=None, progress=None
    ):
        """A model of a reduced copy of the photo that behaves like the full-size one.

        The photo and the region are resized so that the longest side is ``size``
        pixels, and the model gets the matching ``pixel_size``, so the mapping, the
        slopes and the feather keep their full-resolution meaning (a preview).

        Parameters
        ----------
        image, mask, params, seed, progress
            As for the constructor, at full resolution.
        size : int
            Longest side in pixels (>= 8). An image already that small is used as it
            is.

        Returns
        -------
        FlickerModel
            With :attr:`pixel_size` = full-resolution pixels per pixel.

        Examples
        --------
        >>> img = np.random.default_rng(0).random((100, 60, 3))
        >>> m = FlickerModel.reduced(img, size=50, params=FlickerParams(T=8, f0=2))
        >>> m.shape, m.pixel_size
        ((50, 30), 2.0)
        """
        from ..fields import resize  # scikit-image: imported only when reducing

        img = as_image(image)
        size = check_int("size", size, 8)
        h, w = img.shape[:2]
        region = None if mask is None else as_mask(mask, (h, w), name="mask")
        scale = max(h, w) / size
        if scale <= 1:
            return cls(img, region, params, flow=flow, seed=seed, progress=progress)
        shape = (max(1, round(h / scale)), max(1, round(w / scale)))
        small, small_mask = _reduced_inputs(img, region, shape, resize)
        pixel_size = max(h / shape[0], w / shape[1])
        # A stroke is in full-resolution pixels, and so is the velocity the model takes.
        return cls(
            small,
            small_mask,
            params,
            flow=flow,
            seed=seed,
            pixel_size=pixel_size,
            progress=progress,
        )

    # ------------------------------------------------------------------ internals
    @property
    def _n_blocks(self):
        return -(-self.params.T // _BLOCK)

    def _make_coefficients(self, factor, signals=None):
        g = (self._signals if signals is None else signals).T * factor  # (T, K) complex
        coef = np.empty((g.shape[0], 2 * g.shape[1]), np.float32)
        coef[:, 0::2] = g.imag
        coef[:, 1::2] = g.real
        return coef

    def _slopes(self, t0, t1, out=None):
        """The shading kernel's input for frames t0..t1 of one aligned block, (n, h * w).

        Made by whole aligned blocks (a matrix product's rounding depends on its number
        of rows), so any frame alone is bit-identical to the same frame of the clip.
        Without noise one product with the slope scale folded in; with noise the
        normalised heights, scaled. ``out`` (n, h * w) float32, if given, receives
        them (the render reuses one: at 1920 px a block's rows are 0.1 GB).
        """
        if self._noisy:
            rows = self._heights(t0, t1, out=out)
            rows *= self._slope_scale
            return rows
        return _product(self._slope_coefficients[t0:t1], self._basis, out)

    def _row(self, which, t):
        """Frame ``t`` (any integer: period T), (h, w): heights relative to C or slopes."""
        t = int(t) % self.params.T
        b = t // _BLOCK
        key = (which, b)
        if key not in self._cache:
            t0, t1 = b * _BLOCK, min((b + 1) * _BLOCK, self.params.T)
            # Keep one block of each kind: playing the frames in order reuses it.
            self._cache = {k: v for k, v in self._cache.items() if k[0] != which}
            make = self._heights if which == "height" else self._slopes
            self._cache[key] = make(t0, t1)
        return self._cache[key][t - b * _BLOCK].reshape(self.alpha.shape)

    def _check_t(self, t):
        return check_int("t", t)

    # ------------------------------------------------------------------ public API
    @property
    def n_frames(self):
        """The number of frames in the loop, ``T``."""
        return self.params.T

    @property
    def shape(self):
        """(H, W) of the frames."""
        return self._scene.image.shape[:2]

    @property
    def pixel_size(self):
        """Size of one pixel in full-resolution pixels (1 unless :meth:`reduced`)."""
        return self._scene.pixel_size

    @property
    def mask(self):
        """The animated region, bool (H, W) (a copy)."""
        return self._scene.mask.copy()

    @property
    def luminance(self):
        """:math:`H_{xy}(0)`, the photo's luminance, float32 (H, W) (a copy)."""
        return self._scene.luminance.copy()

    @property
    def spectrum(self):
        """:math:`F(f_x, f_y)` of Eq. (4) over the window, complex128, fft2 order.

        For the flow mapping, of the window with its mirrored upstream margin; crop an
        inverse transform with ``_crop`` to get back to the window.
        """
        return phase_spectrum(self._analysed)

    @property
    def frequencies(self):
        """:math:`f_c` of every spatial frequency of the window (Eq. (7)-(9)), int, fft2 order."""
        return temporal_frequencies(
            self._analysed.shape,
            self.params,
            pixel_size=self._scene.pixel_size,
            velocity=self.velocity,
        )

    def height(self, t):
        r"""The height :math:`H(x, y, t) = C + A \, \mathrm{Im}\, I_{out}(x, y, t)` at frame ``t``.

        Parameters
        ----------
        t : int
            Any integer frame; the loop has period ``T``, so ``t + T`` is ``t``.

        Returns
        -------
        ndarray, shape (H, W), float32
            Inside the window the model's height; outside it the rest height of
            Eq. (2), which never moves.
        """
        t = self._check_t(t)
        if self._rest is None:
            p = self.params
            alpha = initial_phase(self._scene.luminance, p.A, p.C, p.branch)
            self._rest = (p.A * np.sin(alpha)).astype(np.float32)
        out = self._rest.copy()
        out[self.window] = self._row("height", t)
        out += np.float32(self.params.C)
        return out

    def field(self, t):
        r""":math:`I_{out}(x, y, t)` of Eq. (5) over the window (divided by :attr:`normalisation`).

        Parameters
        ----------
        t : int
            Frame.

        Returns
        -------
        ndarray, shape (h, w), complex128
            ``height(t)[window] == C + A * field(t).imag`` up to float32 rounding
            (with ``noise_norm="rms"``, of ``C + A * soft_clip(field(t).imag)``).
        """
        t = self._check_t(t) % self.params.T
        re, im = self._basis[0::2].astype(np.float64), self._basis[1::2].astype(np.float64)
        # Rows are (Re B_c, Im B_c) for the flow mapping and (IDFT(cos part), IDFT(sin
        # part)) for the others: either way B_c = rows[0] + j rows[1].
        field = 0
        for k, signals in enumerate(self._region_signals):
            g = signals[:, t] / self.normalisation
            part = (g @ re) + 1j * (g @ im)
            field = field + (part if self._blend is None else self._blend[k] * part)
        return field.reshape(self.alpha.shape)

    def frame(self, t):
        """Frame ``t`` of the clip, computed alone (bit-identical to ``frames()[t]``).

        Parameters
        ----------
        t : int
            Any integer frame (period ``T``).

        Returns
        -------
        ndarray, shape (H, W) or (H, W, 3), float32 in [0, 1]
        """
        t = self._check_t(t)
        return self._scene.frame_from(self._row("slope", t))

    def _render(self, report, out=None):
        """Make the frames in order; yields them a few at a time, (n, H, W[, 3]).

        Heights come an aligned block of ``_BLOCK`` frames at a time (one matrix
        product); the shading runs on the pool's threads a few frames at a time
        (``_per_yield``), the next few while the caller takes the last ones (writes
        them, encodes them). With ``out`` (T, H, W[, 3]) the frames are written into it
        and the views yielded; without, each few are a new array. Either way the same
        code makes the same frames.
        """
        scene = self._scene
        T = self.params.T
        h, w = self.alpha.shape
        per = self._per_yield()
        blocks = self._n_blocks
        # Two buffers for the heights, in turn: the threads may still shade the last
        # frames of one block while the next block's are made.
        buffers = np.empty((min(2, blocks), min(_BLOCK, T), h * w), np.float32)
        recycled = _Recycled(scene, per)
        with ThreadPoolExecutor(_THREADS, thread_name_prefix="fluidnb-flicker") as pool:
            pending = None
            for b in range(blocks):
                t0, t1 = b * _BLOCK, min((b + 1) * _BLOCK, T)
                report(b / blocks, f"frames {t0 + 1}-{t1}")
                # The next block's heights while the last frames are still shaded.
                rows = self._slopes(t0, t1, out=buffers[b % 2, : t1 - t0])
                rows = rows.reshape(t1 - t0, h, w)
                for s0 in range(t0, t1, per):
                    s1 = min(s0 + per, t1)
                    frames = recycled.take(s1 - s0) if out is None else out[s0:s1]
                    # Shaded straight into the frames (a strided view when the window is
                    # a box inside the image).
                    target = frames[(slice(None), *self.window)]
                    running = scene.submit(rows[s0 - t0 : s1 - t0], target, pool)
                    if pending is not None:
                        yield _finished(*pending)
                    pending = (running, frames)
            yield _finished(*pending)

    def _per_yield(self):
        """Frames shaded and handed on at a time: about 32 MB, and work for every thread."""
        h, w = self.shape
        size = h * w * (3 if self._scene.image.ndim == 3 else 1) * 4
        return int(min(_BLOCK, max(_THREADS, (32 << 20) // size)))

    def frames(self, progress=None):
        """All ``T`` frames, shape (T, H, W[, 3]), float32 in [0, 1]."""
        report = Progress(progress)
        out = self._scene.empty_clip(self.params.T)
        for _ in self._render(report, out):
            pass
        report(1.0, "done")
        return out

    def _metadata(self, timings):
        return {
            "method": "flicker",
            "params": self.params.to_dict(),
            "seed": self.seed,
            "timings": timings,
            "bins": len(self.bins),
            "normalisation": self.normalisation,
            "velocity": None if self.velocity is None else self.velocity.tolist(),
            "pixel_size": self._scene.pixel_size,
        }

    def clip(self, progress=None):
        """The whole loop as a :class:`fluidnb.Clip` with method, params, seed and timings."""
        started = time.perf_counter()
        frames = self.frames(progress)
        timings = {**self.timings, "render": time.perf_counter() - started}
        return Clip._trusted(frames, float(self.params.fps), {}).with_metadata(
            **self._metadata(timings)
        )

    def stream(self, progress=None):
        """The loop as a :class:`fluidnb.FrameStream`: the frames of :meth:`clip`, made in order.

        Saved (``model.stream().save("out.mp4")``), a few frames are held at a time
        beside the model, never the whole loop: the way to a file at full size.

        Returns
        -------
        FrameStream
            ``T`` frames; the metadata of :meth:`clip`, ``timings["render"]`` the
            seconds spent making the frames (not writing them).
        """
        timings = dict(self.timings)

        def blocks():
            report = Progress(progress)
            timings["render"] = 0.0
            yield from timed(self._render(report), timings, "render")
            report(1.0, "done")

        return FrameStream(
            blocks,
            n_frames=self.params.T,
            shape=self.shape,
            color=self._scene.image.ndim == 3,
            fps=float(self.params.fps),
            metadata=lambda: self._metadata(timings),
        )


def _product(coefficients, basis, out=None):
    """``coefficients @ basis`` (into ``out``, if given) on one BLAS thread.

    The render makes these while its own threads shade the frames before, and
    OpenBLAS's second thread would spin between products on the cores they need. One
    thread for every product of the model, not only the render's: OpenBLAS rounds
    differently on one thread and on two, and a frame made alone must be the clip's
    frame bit for bit.
    """
    with blas_single_threaded():
        return np.matmul(coefficients, basis, out=out)


class _Recycled:
    """Blocks of frames for a stream, written again once nothing else holds them.

    A new block of 1920-px frames is fresh memory, which the system maps and zeroes
    page by page, and the photo outside the window is copied into it again: a
    64-frame loop asked for 2.2 GB of it, a block every two frames. A block the
    consumer has let go of is used again instead (it still holds the photo outside
    the window). "Let go" is exact: a block, and every view of it, refers to the
    array made here, so its reference count says whether anything else still holds
    it -- a consumer that keeps the blocks (``list(stream)``) gets new ones.
    """

    def __init__(self, scene, per):
        self._scene = scene
        self._per = per
        self._made = []

    def take(self, n):
        """A block of ``n`` frames, (n, H, W[, 3]), the photo outside the window."""
        for block in self._made:
            # Held by the list, this loop and getrefcount's argument alone: free.
            if sys.getrefcount(block) == 3:
                return block[:n]
        block = self._scene.empty_clip(max(n, self._per))
        self._made.append(block)
        return block[:n]


def _finished(futures, frames):
    for f in futures:
        f.result()
    return frames


def flicker(image, mask=None, params=None, *, flow=None, seed=None, stream=False, progress=None):
    r"""Animate a photo with flicker ("yuragi") from its spatio-temporal spectrum.

    The method of Yamamoto & Sakamoto [1]_: the luminance is a pseudo-height whose
    initial phases (Eq. (3)) are transformed to a 2-D spectrum (Eq. (4)), each
    spatial frequency is given a temporal frequency on a plane or a curved surface
    (Eq. (7)-(9)), spread with 1/f^β noise (Eq. (10)), and the 3-D inverse DFT
    (Eq. (5)) gives the height of every frame; a bump-mapped Lambert shading of that
    height changes the photo's brightness (the base method [4] of Sec. 2.1).

    Parameters
    ----------
    image : array_like, path or PIL image, shape (H, W) or (H, W, 3)
        The photo.
    mask : array_like of bool, shape (H, W), optional
        The region to animate; default the whole image. Pixels outside stay exactly
        as in the photo in every frame.
    params : FlickerParams, optional
        The paper's values by default (T = 64 frames at 8 fps, f0 = 4, convex
        mapping, β = 2).
    seed : None, int or numpy.random.Generator
        For the noise; same seed, same frames. ``None`` draws one and records it in
        the clip's metadata.
    stream : bool
        Return a :class:`fluidnb.FrameStream` of the same frames instead of the
        clip: they are made as it is saved, a few at a time, so a file of a
        full-size photo needs memory for a few frames, not the loop
        (docs/conventions.md, "Streams").
    progress : callable, optional
        ``progress(fraction, message)``; raising :class:`fluidnb.Cancelled` stops it.

    Returns
    -------
    Clip or FrameStream
        ``T`` frames that loop seamlessly; metadata ``method="flicker"``, ``params``,
        ``seed``, ``timings`` (seconds per stage), ``bins`` (the number of distinct
        temporal frequencies) and ``normalisation``.

    Raises
    ------
    ValueError
        For an unreadable image, NaN values, a mask of another size or an empty
        mask, or parameters that are not a :class:`FlickerParams`.

    See Also
    --------
    FlickerModel : The same computation, one frame at a time.
    base_method : Eq. (1) alone (the paper's Sec. 2.1).

    References
    ----------
    .. [1] Yamamoto K., Sakamoto Y., "一枚の画像からの時空間周波数を用いた揺らめき動画生成法"
       ("A method of generating flicker animation from a single image using
       spatio-temporal frequencies"), Graduate School of Information Science and
       Technology, Hokkaido University.
    .. [4] Mori T., Sakamoto Y., "写真に揺らめき表現を付加した動画生成に関する研究"
       ("Generating animation with flicker added to photographs"), ITE Technical
       Report 32(46), pp. 39-42 (2008).

    Examples
    --------
    >>> from fluidnb import data
    >>> photo = data.sample("ripples", size=48)
    >>> clip = flicker(photo, params=FlickerParams(T=16), seed=0)
    >>> clip
    Clip(16 frames, 48x48 RGB, 8 fps, method='flicker')
    >>> clip.metadata["seed"], sorted(clip.metadata["timings"])
    (0, ['analyse', 'normalise', 'render', 'spectrum', 'synthesis'])
    """
    first, second = Progress(progress).split(0.4)
    model = FlickerModel(image, mask, params, flow=flow, seed=seed, progress=first)
    if stream:
        return model.stream(progress=second)
    return model.clip(progress=second)


# The last reduced photo and region, kept: a live preview reduces the same photo and
# region at every slider move, and the anti-aliased resize was a quarter of its time.
_REDUCED = LastKept()


def _reduced_inputs(img, region, shape, resize):
    """``img`` and ``region`` reduced to ``shape`` (as :meth:`FlickerModel.reduced` does)."""
    found, value = _REDUCED.get(img, region, shape)
    if found:
        return value
    small = np.clip(resize(img, shape), 0.0, 1.0)
    small_mask = None
    if region is not None:
        cover = resize(region.astype(np.float32), shape)
        # A reduced pixel moves when most of it is painted; a tiny region still shows.
        small_mask = cover > 0.5 if (cover > 0.5).any() else cover > 0
    for a in (small, small_mask):
        if a is not None:
            a.flags.writeable = False  # shared by every model made from them
    _REDUCED.keep((img, region, shape), (small, small_mask))
    return small, small_mask


def preview(image, mask=None, params=None, *, flow=None, size=128, seed=None, progress=None):
    """A reduced-size flicker clip that looks like the full one, fast enough to follow a slider.

    The photo and the region are resized so the longest side is ``size`` pixels;
    the model gets the matching ``pixel_size``, so the mapping, the slopes and the
    feather keep their full-resolution meaning.

    Parameters
    ----------
    image, mask, params, seed, progress
        As for :func:`flicker`.
    size : int
        Longest side of the preview in pixels (>= 8). An image already that small
        is used as it is.

    Returns
    -------
    Clip
        All ``T`` frames at the reduced size; metadata as :func:`flicker`, with
        ``pixel_size``.

    See Also
    --------
    FlickerModel.reduced : The model behind it.

    Examples
    --------
    >>> from fluidnb import data
    >>> photo = data.sample("stream", size=256)
    >>> preview(photo, params=FlickerParams(T=16), size=64, seed=0).shape
    (50, 64)
    """
    first, second = Progress(progress).split(0.4)
    model = FlickerModel.reduced(
        image, mask, params, flow=flow, size=size, seed=seed, progress=first
    )
    return model.clip(progress=second)


def base_method(image, mask=None, params=None, *, progress=None):
    r"""The base method [4] of Sec. 2.1: every pixel's height a simple harmonic motion.

    .. math:: H_{xy}(t) = A \sin(\omega t + \alpha_{xy}) + C, \qquad
              \omega = 2\pi f_0 / T  \quad (1)

    with the initial phases of Eq. (3), shaded as in :func:`flicker`. This equals the
    plane mapping (Eq. (7)) without noise; it is here for comparison.

    Parameters
    ----------
    image, mask, params, progress
        As for :func:`flicker` (``mapping``, ``kappa`` and ``beta`` are not used).

    Returns
    -------
    Clip
        ``T`` frames, metadata ``method="flicker-base"``.

    Examples
    --------
    >>> img = np.random.default_rng(0).random((16, 16))
    >>> base_method(img, params=FlickerParams(T=8, f0=2)).n_frames
    8
    """
    report = Progress(progress)
    params = _check_params(params)
    started = time.perf_counter()
    scene = _Scene(image, mask, params, 1.0)
    T = params.T
    out = scene.empty_clip(T)
    with ThreadPoolExecutor(_THREADS, thread_name_prefix="fluidnb-flicker") as pool:
        for t0 in range(0, T, _BLOCK):
            t1 = min(t0 + _BLOCK, T)
            report(t0 / T, f"frames {t0 + 1}-{t1}")
            heights = harmonic_height(
                scene.alpha, np.arange(t0, t1), A=params.A, C=0.0, f0=params.f0, T=T
            )
            slopes = (heights * scene.slope_scale).astype(np.float32)
            for f in scene.submit(slopes, out[(slice(t0, t1), *scene.window)], pool):
                f.result()
    report(1.0, "done")
    return Clip._trusted(out, float(params.fps), {}).with_metadata(
        method="flicker-base",
        params=params.to_dict(),
        timings={"render": time.perf_counter() - started},
    )
