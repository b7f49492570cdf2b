r"""Moving a texture along a flow for any time without stretching it: flow maps.

A texture advected for a long time is stretched and torn by the flow. The flow-map
technique (Neyret 2003; Vlachos 2010) keeps two phases of the texture, each advected
from a fresh start every period, cross-faded so that the texture keeps moving with the
flow and is never older than one period (:func:`flow_map_texture`). The starter water
database's clips are made this way (:mod:`fluidnb.videodb.starter._water`): water
textures moved along known flows, a stand-in for filmed water.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..._random import rng
from ..._validation import check_array, check_int
from ...fields import backward_warp

__all__ = ["flow_map_texture"]


def flow_map_texture(
    texture, velocity, n_frames=None, *, period=16, jitter=True, preserve_contrast=True, seed=None
):
    r"""Move a texture along a flow for any time without stretching it (flow maps).

    A texture advected for a long time is stretched and torn by the flow. The
    flow-map technique (Neyret 2003 [1]_; Vlachos 2010 [2]_) keeps two copies, or
    phases, of the texture, each advected from a fresh start every ``period`` frames,
    the second offset by half a period; each phase's weight falls to zero when it
    restarts, and the two weights sum to one:

    .. math::

        w_a(t) = 1 - \left|\frac{2\,(t \bmod P)}{P} - 1\right|, \qquad
        w_b(t) = 1 - w_a(t), \qquad
        I_t = w_a A_t + w_b B_t,

    so the texture keeps moving with the flow and is never older than one period.
    A phase is advected through its flow map :math:`X` (where the content now at
    :math:`x` started): :math:`X_{t+1}(x) = X_t(x - v_t(x))` and
    :math:`A_t(x) = \text{texture}(X_t(x))`, so the texture is sampled once per frame,
    never resampled frame after frame, and :math:`A_{t+1}(x) = A_t(x - v_t(x))`
    exactly as semi-Lagrangian advection (the frames move with ``velocity``).

    Parameters
    ----------
    texture : ndarray, shape (H, W) or (H, W, C)
        The texture, in [0, 1], read as periodic (it wraps around), so it should tile
        seamlessly; the frames have its height and width.
    velocity : ndarray, shape (H, W, 2) or (T - 1, H, W, 2)
        The flow, (dy, dx) in pixels per frame: one steady field, or one per frame
        pair (``velocity[t]`` moves frame ``t`` to frame ``t + 1``, the convention of
        flow sequences).
    n_frames : int, optional
        T, the number of frames; required for a steady ``velocity``, else ``T``.
    period : int
        :math:`P`, frames between two restarts of a phase (even, >= 2). Longer
        periods stretch the texture more; shorter ones make the cross-fade faster.
    jitter : bool
        Restart each phase at a new random offset into the texture (Neyret's
        regeneration), so that the texture does not visibly repeat every period.
    preserve_contrast : bool
        Blend about the texture's mean as
        :math:`\mu + (w_a (A - \mu) + w_b (B - \mu)) / \sqrt{w_a^2 + w_b^2}`, which
        keeps the contrast of two uncorrelated phases (as ``jitter`` makes them)
        constant instead of dipping by up to :math:`1/\sqrt 2` at mid-fade (Yu et al.
        2011 [3]_); the result is clipped to [0, 1]. ``False`` blends linearly.
    seed : None, int or numpy.random.Generator
        The offsets of ``jitter``.

    Returns
    -------
    ndarray, shape (T, H, W) or (T, H, W, C), float32
        The frames, in [0, 1].

    Raises
    ------
    ValueError
        For a texture that is not an (H, W[, C]) array in [0, 1], a velocity of the
        wrong shape or with NaN, a missing or inconsistent ``n_frames``, or a bad
        ``period``.

    References
    ----------
    .. [1] F. Neyret, "Advected textures", Proc. ACM SIGGRAPH/Eurographics Symposium
       on Computer Animation (SCA), pp. 147-153, 2003.
    .. [2] A. Vlachos, "Water flow in Portal 2", SIGGRAPH 2010 course "Advances in
       Real-Time Rendering in 3D Graphics and Games".
    .. [3] Q. Yu, F. Neyret, E. Bruneton, N. Holzschuch, "Lagrangian texture
       advection: preserving both spectrum and velocity field", IEEE Transactions on
       Visualization and Computer Graphics 17(11), pp. 1612-1623, 2011.

    Examples
    --------
    Stripes across the flow, moving one pixel a frame to the right, with a period
    whose half moves them by one stripe period: both phases agree, so the frames are
    exact shifts.

    >>> stripes = np.tile(np.array([0.0, 0.0, 1.0, 1.0], np.float32), (2, 4))
    >>> v = np.zeros((2, 16, 2))
    >>> v[..., 1] = 1.0
    >>> frames = flow_map_texture(stripes, v, 3, period=8, jitter=False, preserve_contrast=False)
    >>> frames[:, 0]
    array([[0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1.],
           [1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1.],
           [1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0.]],
          dtype=float32)
    """
    tex = check_array("texture", texture, ndim=(2, 3), dtype_kinds="iuf")
    if tex.dtype.kind != "f" or tex.min() < 0 or tex.max() > 1:
        raise ValueError(
            f"texture must hold floats in [0, 1], got dtype {tex.dtype} "
            f"and range [{tex.min():g}, {tex.max():g}]"
        )
    tex = tex.astype(np.float32)
    h, w = tex.shape[:2]
    v = check_array("velocity", velocity, ndim=(3, 4), dtype_kinds="iuf")
    if v.shape[-3:] != (h, w, 2):
        raise ValueError(
            f"velocity must have shape (H, W, 2) or (T - 1, H, W, 2) with the texture's "
            f"(H, W) = {(h, w)}, got {v.shape}"
        )
    if v.ndim == 3:
        if n_frames is None:
            raise ValueError("n_frames is required with a steady (H, W, 2) velocity")
        n_frames = check_int("n_frames", n_frames, 1)
    else:
        expected = v.shape[0] + 1
        if n_frames is not None and check_int("n_frames", n_frames, 1) != expected:
            raise ValueError(
                f"n_frames must be len(velocity) + 1 = {expected} for a velocity "
                f"sequence, got {n_frames}"
            )
        n_frames = expected
    period = check_int("period", period, 2)
    if period % 2:
        raise ValueError(f"period must be an even integer >= 2, got {period}")
    gen = rng(seed)
    v = v.astype(np.float32)
    return _flow_map(tex, v, n_frames, period, bool(jitter), bool(preserve_contrast), gen)


def _flow_map(tex, v, n_frames, period, jitter, preserve, gen, report=None, *, compiled=True):
    """:func:`flow_map_texture`'s frames.

    ``compiled=False`` warps with :func:`fluidnb.fields.backward_warp` and blends with
    numpy, literally; the default runs the same arithmetic in two numba kernels, value
    for value (the tests compare the two), about 4 times as fast (each phase's
    corners found once a pixel, for all its channels).
    """
    h, w = tex.shape[:2]
    half = period // 2
    texture = tex.reshape(h, w, -1)
    mean = texture.mean(axis=(0, 1), dtype=np.float64).astype(np.float32)
    steady = v.ndim == 3
    # Both phases' displacement maps D = X - x in one array: they ride the same flow,
    # so one warp of four channels serves both. D is smooth, so clamping it at the
    # border (where the backtrace leaves the frame) extrapolates it sensibly.
    maps = np.zeros((h, w, 4), np.float32)
    spare = np.empty_like(maps)
    offset = np.zeros((2, 2), np.float32)
    frames = np.empty((n_frames, h, w, texture.shape[2]), np.float32)

    def restart(phase):
        maps[..., 2 * phase : 2 * phase + 2] = 0.0
        if jitter:
            # Whole pixels: an offset adds no interpolation blur of its own.
            offset[phase] = (gen.integers(0, h), gen.integers(0, w))

    # Start half a period early (with the first frame's flow), so that at frame 0
    # phase b is half-way through its cycle as it always is then; phase a restarts
    # at frame 0 (and every P frames), phase b half a period later.
    restart(1)
    for t in range(-half, n_frames):
        if t >= 0:
            wa = 1.0 - abs(2.0 * (t % period) / period - 1.0)
            blend = _frame if compiled else _frame_numpy
            blend(texture, maps, offset, wa, mean, preserve, frames[t])
            if report is not None:
                report((t + 1) / n_frames, f"frame {t + 1}/{n_frames}")
        if t == n_frames - 1:
            break
        vt = v if steady else v[max(t, 0)]
        # X_{t+1}(x) = X_t(x - v(x)), i.e. D_{t+1}(x) = D_t(x - v(x)) - v(x).
        if compiled:
            _advance(maps, vt, spare)
            maps[...] = spare
        else:
            maps[...] = backward_warp(maps, -vt)
            maps[..., :2] -= vt
            maps[..., 2:] -= vt
        if (t + 1) % period == 0:
            restart(0)
        elif (t + 1) % period == half:
            restart(1)
    return frames.reshape(n_frames, *tex.shape)


def _weights(wa, preserve):
    """The phases' weights and the mean's: ``I = w_a' A + w_b' B + mean (1 - norm)``."""
    wb = 1.0 - wa
    if not preserve:
        return np.float32(wa), np.float32(wb), np.float32(0.0)
    # mean + (wa (A - mean) + wb (B - mean)) / sqrt(wa^2 + wb^2)
    norm = 1.0 / math.sqrt(wa * wa + wb * wb)
    return np.float32(wa * norm), np.float32(wb * norm), np.float32(1.0 - norm)


def _frame_numpy(texture, maps, offset, wa, mean, preserve, out):
    """One frame, plainly: both phases sampled by backward_warp, then blended."""
    b = backward_warp(texture, maps[..., 2:] + offset[1], mode="wrap")
    if wa > 0:
        a = backward_warp(texture, maps[..., :2] + offset[0], mode="wrap")
        ka, kb, km = _weights(wa, preserve)
        if preserve:
            a *= ka
            b *= kb
            b += a
            b += mean * km
        else:
            # B + wa (A - B): identical phases give B exactly.
            a -= b
            a *= ka
            b += a
    np.clip(b, 0.0, 1.0, out=out)


def _frame(texture, maps, offset, wa, mean, preserve, out):
    ka, kb, km = _weights(wa, preserve)
    _blend_phases(texture, maps, offset, wa > 0, ka, kb, mean * km, preserve, out)


@njit(cache=True, nogil=True, inline="always")
def _wrap(i, n):
    """``i % n`` (Python's, in [0, n)) without a division for ``-n <= i < 2 n``."""
    if i >= n:
        i -= n
        if i >= n:
            i %= n
    elif i < 0:
        i += n
        if i < 0:
            i %= n
    return i


@njit(cache=True, nogil=True, inline="always")
def _corner(c, n, wrap):
    """backward_warp's neighbours of coordinate ``c`` (float64): lo, hi, float32 fraction."""
    if wrap:
        lo = math.floor(c)
        f = np.float32(c - lo)
        i = _wrap(int(lo), n)
        return i, 0 if i == n - 1 else i + 1, f
    c = min(max(c, 0.0), n - 1.0)
    i = int(c)
    return i, min(i + 1, n - 1), np.float32(c - i)


@njit(cache=True, nogil=True, inline="always")
def _bilinear(src, y0, y1, fy, x0, x1, fx, k):
    """backward_warp's bilinear sample of channel ``k`` between the corners, in its order."""
    top = (src[y0, x1, k] - src[y0, x0, k]) * fx + src[y0, x0, k]
    bottom = (src[y1, x1, k] - src[y1, x0, k]) * fx + src[y1, x0, k]
    return (bottom - top) * fy + top


@njit(cache=True, nogil=True)
def _advance(maps, v, out):
    """``out = backward_warp(maps, -v)`` (edges clamped), then each phase's map minus v."""
    h, w = maps.shape[0], maps.shape[1]
    for i in range(h):
        for j in range(w):
            dy, dx = v[i, j, 0], v[i, j, 1]
            # The corners once for the four channels (both phases' maps).
            y0, y1, fy = _corner(np.float64(-dy) + i, h, False)
            x0, x1, fx = _corner(np.float64(-dx) + j, w, False)
            for k in range(4):
                out[i, j, k] = _bilinear(maps, y0, y1, fy, x0, x1, fx, k)
            out[i, j, 0] -= dy
            out[i, j, 1] -= dx
            out[i, j, 2] -= dy
            out[i, j, 3] -= dx


@njit(cache=True, nogil=True)
def _blend_phases(texture, maps, offset, both, ka, kb, mean_term, preserve, out):
    """Both phases of one frame sampled (wrapping) and blended as _frame_numpy does."""
    h, w, c = texture.shape
    for i in range(h):
        for j in range(w):
            # Each phase's corners once for all channels.
            by0, by1, bfy = _corner(np.float64(maps[i, j, 2] + offset[1, 0]) + i, h, True)
            bx0, bx1, bfx = _corner(np.float64(maps[i, j, 3] + offset[1, 1]) + j, w, True)
            ay0, ay1, afy = by0, by1, bfy
            ax0, ax1, afx = bx0, bx1, bfx
            if both:
                ay0, ay1, afy = _corner(np.float64(maps[i, j, 0] + offset[0, 0]) + i, h, True)
                ax0, ax1, afx = _corner(np.float64(maps[i, j, 1] + offset[0, 1]) + j, w, True)
            for k in range(c):
                b = _bilinear(texture, by0, by1, bfy, bx0, bx1, bfx, k)
                if both:
                    a = _bilinear(texture, ay0, ay1, afy, ax0, ax1, afx, k)
                    # in _frame_numpy's order: (b kb + a ka) + mean, or b + (a - b) wa
                    b = (b * kb + a * ka) + mean_term[k] if preserve else b + (a - b) * ka
                out[i, j, k] = min(max(b, np.float32(0.0)), np.float32(1.0))
