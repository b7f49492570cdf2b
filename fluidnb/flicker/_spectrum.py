r"""The steps of the spatio-temporal frequency method (Yamamoto & Sakamoto, 2012, sec. 2.1 and 3).

Each function is one step, with the paper's equation number, so that a notebook can
run and plot them one at a time; :class:`~fluidnb.flicker.FlickerModel` chains the
same functions (with a faster real-FFT form of Eq. (4)-(5)).

Units (our decision; the paper leaves them open): spatial frequencies
:math:`\nu_x, \nu_y` are signed, in cycles per pixel (:func:`numpy.fft.fftfreq`);
temporal frequencies are integer DFT bins, i.e. oscillations per loop of ``T`` frames.
"""

from __future__ import annotations

import math

import numpy as np

from .._image import as_image
from .._random import rng
from .._validation import check_array, check_choice, check_int, check_range
from ._params import BRANCHES, FlickerParams

__all__ = [
    "check_velocity",
    "harmonic_height",
    "height_from_luminance",
    "initial_phase",
    "noise_spectrum",
    "phase_spectrum",
    "region_weights",
    "soft_clip",
    "temporal_frequencies",
    "temporal_signals",
]

# Rec. 709 luma weights, the same as fluidnb.as_image(mode="grey") and skimage's rgb2gray.
_LUMA = np.array([0.2125, 0.7154, 0.0721], dtype=np.float32)


def height_from_luminance(image):
    """The initial height :math:`H_{xy}(0)`: the luminance of the input (Sec. 2.1).

    Parameters
    ----------
    image : array_like, path or PIL image
        Grey (H, W) or colour (H, W, 3); anything :func:`fluidnb.as_image` accepts.

    Returns
    -------
    ndarray, shape (H, W), float32
        Luminance in [0, 1] (Rec. 709 weights); the paper's 0..255 divided by 255.

    Examples
    --------
    >>> height_from_luminance(np.array([[0, 255]], dtype=np.uint8)).tolist()
    [[0.0, 1.0]]
    """
    img = as_image(image)
    if img.ndim == 2:
        return img
    return np.clip(img @ _LUMA, 0.0, 1.0).astype(np.float32)


def initial_phase(height, A, C, branch="rising"):
    r"""The initial phase :math:`\alpha_{xy}` of each pixel's oscillation, Eq. (3).

    .. math:: \alpha_{xy} = \sin^{-1}\left(\frac{H_{xy}(0) - C}{A}\right)

    so that Eq. (2), :math:`H_{xy}(0) = A \sin\alpha_{xy} + C`, holds. The arcsine
    gives the rising half of the sine, :math:`|\alpha| \le \pi/2` (the height grows
    at the next frame); ``branch="falling"`` takes :math:`\pi - \alpha` instead
    (wrapped to :math:`(-\pi, \pi]`), which has the same sine but starts downwards.

    Parameters
    ----------
    height : array_like, shape (H, W)
        :math:`H_{xy}(0)` in [0, 1] (:func:`height_from_luminance`).
    A : float
        :math:`A` > 0, the amplitude.
    C : float
        :math:`C`, the centre.
    branch : {"rising", "falling"}
        Which half of the sine the pixels start on.

    Returns
    -------
    ndarray, shape (H, W), float64
        :math:`\alpha` in radians. Heights outside :math:`[C - A, C + A]` have no
        exact phase; they start at the nearest extreme (:math:`\pm\pi/2`).

    Examples
    --------
    >>> a = initial_phase(np.array([0.0, 0.5, 1.0]), A=0.5, C=0.5)
    >>> np.round(a / np.pi, 3).tolist()
    [-0.5, 0.0, 0.5]
    >>> np.round(initial_phase(np.array([0.75]), 0.5, 0.5, "falling") / np.pi, 3).tolist()
    [0.833]
    """
    h = check_array("height", height, ndim=(1, 2, 3), dtype_kinds="biuf")
    A = check_range("A", A, 0, lo_open=True)
    C = check_range("C", C)
    check_choice("branch", branch, BRANCHES)
    alpha = np.arcsin(np.clip((h.astype(np.float64) - C) / A, -1.0, 1.0))
    if branch == "falling":
        # pi - alpha has the same sine and the opposite slope; fold into (-pi, pi].
        alpha = np.where(alpha > 0, np.pi - alpha, -np.pi - alpha)
    return alpha


def harmonic_height(alpha, t, *, A, C, f0, T):
    r"""The base method's height, Eq. (1): :math:`H_{xy}(t) = A \sin(\omega t + \alpha_{xy}) + C`.

    With :math:`\omega = 2\pi f_0 / T`, i.e. a period of :math:`P = T / f_0`
    frames (the paper's Sec. 2.1 calls that period T; in Sec. 3, T is the loop).

    Parameters
    ----------
    alpha : array_like, shape (H, W)
        :math:`\alpha_{xy}` from :func:`initial_phase`.
    t : int, float or array_like of shape (n,)
        Frame time(s).
    A, C : float
        Amplitude and centre.
    f0 : float
        Oscillations per ``T`` frames.
    T : int
        Frames per loop.

    Returns
    -------
    ndarray, shape (H, W) or (n, H, W), float64

    Examples
    --------
    >>> alpha = initial_phase(np.array([[0.5]]), A=0.5, C=0.5)
    >>> [
    ...     round(float(harmonic_height(alpha, t, A=0.5, C=0.5, f0=1, T=4)[0, 0]), 6)
    ...     for t in range(4)
    ... ]
    [0.5, 1.0, 0.5, 0.0]
    """
    a = np.asarray(alpha, dtype=np.float64)
    times = np.asarray(t, dtype=np.float64)
    # Reduce f0 * t modulo T before scaling by 2 pi, so long times keep full precision.
    phase = 2 * np.pi * np.mod(f0 * times, T) / T
    phase = phase.reshape(phase.shape + (1,) * a.ndim)
    return A * np.sin(phase + a) + C


def phase_spectrum(alpha):
    r"""The 2-D DFT of :math:`e^{j\alpha(x, y)}`, Eq. (4).

    .. math:: F(f_x, f_y) = \sum_{x, y} e^{j\alpha(x, y)}
              e^{-j 2\pi (f_x x / X + f_y y / Y)}

    The phase, not the luminance, is transformed, so that the inverse transform of
    the mapped spectrum starts every pixel at its own initial phase.

    Parameters
    ----------
    alpha : array_like, shape (H, W)
        Initial phases (:func:`initial_phase`) of the region to animate.

    Returns
    -------
    ndarray, shape (H, W), complex128
        In :func:`numpy.fft.fft2` order (zero frequency at ``[0, 0]``; use
        :func:`numpy.fft.fftshift` to centre it for plots).

    Examples
    --------
    >>> F = phase_spectrum(np.zeros((4, 4)))
    >>> F[0, 0], float(np.abs(F).sum())
    (np.complex128(16+0j), 16.0)
    """
    a = check_array("alpha", alpha, ndim=2, dtype_kinds="iuf")
    return np.fft.fft2(np.exp(1j * a.astype(np.float64)))


def _frequency_grid(shape, pixel_size):
    h, w = shape
    ny = np.fft.fftfreq(h) / pixel_size
    nx = np.fft.fftfreq(w) / pixel_size
    return ny[:, None], nx[None, :]


def temporal_frequencies(shape, params=None, *, pixel_size=1.0, rounded=True, velocity=None):
    r"""Map every spatial frequency to a temporal frequency :math:`f_c`, Eq. (6)-(9).

    The mapping keeps :math:`f_x, f_y` and sets :math:`f_t` on one of three surfaces,
    all symmetric about the :math:`f_t` axis (Yamamoto & Sakamoto, sec. 3.2):

    * plane, Eq. (7): :math:`f_c = f_0`
    * convex, Eq. (8): :math:`f_c = f_0 + \kappa' (\nu_x^2 + \nu_y^2)`
    * concave, Eq. (9): :math:`f_c = f_0 - \kappa' (\nu_x^2 + \nu_y^2)`

    or, beyond the paper, on a plane tilted by a velocity :math:`v` (px/frame):

    * flow: :math:`f_c = f_0 - T \, (v_y \nu_y + v_x \nu_x)`

    A component :math:`e^{j 2\pi (\nu \cdot x + f_c t / T)}` with this :math:`f_c`
    is :math:`e^{j 2\pi f_0 t / T} e^{j 2\pi \nu \cdot (x - v t)}`: the whole
    pattern moves by :math:`v` per frame while it oscillates at :math:`f_0` (the
    minus sign is what makes it move *along* :math:`v` with the inverse DFT's
    :math:`e^{+j \ldots}`). Rounded to whole bins, the loop still closes.

    with :math:`\nu` in cycles per pixel of the full-resolution image and the
    curvature :math:`\kappa' = \kappa (\lceil T/2 \rceil - 1 - f_0) / (1/2)`, so that
    ``kappa = 1`` sends the finest frequency (the corner :math:`\nu_x = \nu_y = 1/2`)
    to the highest temporal bin below :math:`T/2`. (The paper writes Eq. (8) with
    unit curvature in units it does not state; in cycles per pixel a unit curvature
    would add at most half a bin and change nothing.)

    Parameters
    ----------
    shape : tuple of int
        (H, W) of the spectrum.
    params : FlickerParams, optional
        ``mapping``, ``f0``, ``kappa`` and ``T`` are used; the paper's by default.
    pixel_size : float
        Size of one pixel of this grid in full-resolution pixels (e.g. 4 for a
        preview at a quarter of the size), so that a structure maps to the same
        :math:`f_c` at every resolution.
    rounded : bool
        Round to whole bins (what the method uses: an integer number of
        oscillations per loop makes the clip loop seamlessly with period ``T``).
        ``False`` returns the continuous surface, for plots.
    velocity : array_like, shape (2,), optional
        :math:`v = (v_y, v_x)` in full-resolution pixels per frame, ``dy > 0`` down
        the image; needed by (and only used by) the flow mapping.

    Returns
    -------
    ndarray, shape (H, W)
        :math:`f_c` in oscillations per loop, in :func:`numpy.fft.fft2` order; int64
        when rounded, else float64. Negative values rotate the other way; as DFT
        indices they are taken modulo ``T``.

    Examples
    --------
    >>> fc = temporal_frequencies((4, 4), FlickerParams(T=16, f0=2, mapping="convex"))
    >>> fc[0, 0], fc[2, 2], fc.max()
    (np.int64(2), np.int64(7), np.int64(7))
    >>> int(temporal_frequencies((4, 4), FlickerParams(T=16, f0=2, mapping="concave")).min())
    -3
    """
    params = FlickerParams() if params is None else params
    if not isinstance(params, FlickerParams):
        raise ValueError(f"params must be a FlickerParams, got {type(params).__name__}")
    h = check_int("shape[0]", shape[0], 1)
    w = check_int("shape[1]", shape[1], 1)
    pixel_size = check_range("pixel_size", pixel_size, 0, lo_open=True)
    if params.mapping == "plane":
        fc = np.full((h, w), float(params.f0))
    elif params.mapping == "flow":
        if velocity is None:
            raise ValueError("the flow mapping needs velocity=(dy, dx) in pixels per frame")
        vy, vx = check_velocity(velocity)
        ny, nx = _frequency_grid((h, w), pixel_size)
        fc = params.f0 - params.T * (vy * ny + vx * nx)
    else:
        ny, nx = _frequency_grid((h, w), pixel_size)
        top = math.ceil(params.T / 2) - 1  # the highest bin strictly below T/2
        curvature = params.kappa * (top - params.f0) / 0.5
        sign = 1.0 if params.mapping == "convex" else -1.0
        fc = params.f0 + sign * curvature * (nx**2 + ny**2)
    if rounded:
        # rint rounds halves to even: symmetric, unlike rounding half away from zero.
        return np.rint(fc).astype(np.int64)
    return fc


#: The fastest flow accepted, in pixels per frame: beyond about 1 px/frame the finest
#: detail already wraps round the temporal circle (it aliases and seems to run back).
MAX_SPEED = 4.0


def check_velocity(velocity, name="velocity"):
    """A flow velocity ``(dy, dx)`` in pixels per frame, checked: finite, ``|v| <= 4``.

    Examples
    --------
    >>> check_velocity([0, 0.5]).tolist()
    [0.0, 0.5]
    """
    v = check_array(name, velocity, ndim=1, dtype_kinds="iuf").astype(np.float64)
    if v.shape != (2,):
        raise ValueError(f"{name} must be (dy, dx) in pixels per frame, got shape {v.shape}")
    speed = float(np.hypot(*v))
    if speed > MAX_SPEED:
        raise ValueError(
            f"{name} must be at most {MAX_SPEED:g} pixels per frame, got {speed:.3g} "
            "(draw a shorter stroke: its length is the distance travelled in one loop)"
        )
    return v


def noise_spectrum(T, beta, *, seed=None):
    r"""The temporal spectrum of one mapped component with 1/f^β noise, Eq. (10).

    .. math:: U(f_x, f_y, f_t) = \frac{F_m(f_x, f_y, f_t)}{|f_t - f_c|^{\beta/2}}
              e^{j\phi(f_t)}

    A component mapped to bin :math:`c` is spread over all ``T`` temporal bins with
    amplitude :math:`1/\Delta f^{\beta/2}` (power :math:`1/\Delta f^\beta`; the paper's
    :math:`\beta = 2` gives amplitude :math:`1/|f_t - f_c|`), weight 1 at
    :math:`\Delta f = 0`, the distance :math:`\Delta f` measured around the circle of
    ``T`` bins, and a random phase :math:`\phi(f_t) \in [0, 2\pi)` that depends on
    :math:`f_t` only, as in Eq. (10).

    Parameters
    ----------
    T : int
        Number of temporal bins (frames per loop), >= 2.
    beta : float
        :math:`\beta` >= 0. ``0`` switches the noise off: the result is the identity
        (each component stays at its own bin with its own phase).
    seed : None, int or numpy.random.Generator
        For the phases :math:`\phi`.

    Returns
    -------
    ndarray, shape (T, T), complex128
        Row ``c`` is the temporal spectrum (over :math:`f_t = 0 .. T-1`) of a
        component mapped to bin ``c``.

    Examples
    --------
    >>> N = noise_spectrum(8, 2.0, seed=0)
    >>> np.round(np.abs(N[0]), 3).tolist()
    [1.0, 1.0, 0.5, 0.333, 0.25, 0.333, 0.5, 1.0]
    >>> bool(np.array_equal(noise_spectrum(8, 0.0), np.eye(8)))
    True
    """
    T = check_int("T", T, 2)
    beta = check_range("beta", beta, 0)
    if beta == 0:
        return np.eye(T, dtype=np.complex128)
    phi = rng(seed).uniform(0.0, 2.0 * np.pi, T)
    c = np.arange(T)
    d = np.abs(c[None, :] - c[:, None])
    d = np.minimum(d, T - d)  # circular distance on the T bins
    with np.errstate(divide="ignore"):
        weight = np.where(d == 0, 1.0, d.astype(np.float64) ** (-beta / 2))
    return weight * np.exp(1j * phi)[None, :]


def temporal_signals(spectrum, times=None):
    r"""The time signal of each row of a temporal spectrum: the :math:`f_t` sum of Eq. (5).

    .. math:: g_c(t) = \sum_{f_t} U_c(f_t) \, e^{j 2\pi f_t t / T}

    Because :math:`\phi` depends on :math:`f_t` only, every spatial frequency mapped
    to bin :math:`c` shares this signal, and Eq. (5) factorises: the output at frame
    :math:`t` is the 2-D inverse DFT of :math:`F(f_x, f_y) \, g_{f_c(f_x, f_y)}(t)`.
    The 1/T of Eq. (5) is compensated (the mapped spectrum holds :math:`T F` at
    :math:`f_c`), so without noise :math:`g_c(t) = e^{j 2\pi c t / T}` exactly.

    Parameters
    ----------
    spectrum : array_like, shape (..., T)
        Temporal spectra (rows of :func:`noise_spectrum`).
    times : array_like of float, optional
        Frame times; by default ``0 .. T-1``. Non-integer times interpolate with the
        band-limited (signed-frequency) trigonometric polynomial, so
        ``g(t + T) = g(t)`` for every real ``t``.

    Returns
    -------
    ndarray, shape (..., n_times), complex128

    Examples
    --------
    >>> g = temporal_signals(noise_spectrum(8, 0.0)[1:2])
    >>> np.round(g.real, 3).tolist()
    [[1.0, 0.707, 0.0, -0.707, -1.0, -0.707, -0.0, 0.707]]
    """
    U = np.asarray(spectrum, dtype=np.complex128)
    T = U.shape[-1]
    t = np.arange(T, dtype=np.float64) if times is None else np.asarray(times, np.float64)
    if t.ndim != 1:
        raise ValueError(f"times must be 1-D, got shape {t.shape}")
    ft = np.fft.fftfreq(T, 1.0 / T)  # signed bins -T/2 .. T/2 - 1
    # (ft t) mod T before the 2 pi: exact for integer t, and for integer t the signed
    # and the unsigned bins give identical angles.
    angle = 2 * np.pi * np.mod(np.outer(ft, t), T) / T
    return U @ np.exp(1j * angle)


def region_weights(shape, n, *, seed=None):
    r"""A smooth partition of the image into ``n`` soft regions (beyond the paper).

    Each region :math:`g` has a random centre :math:`c_g` (spread out: best of 10
    candidates, Mitchell 1991); its weight is a Gaussian
    of the distance, normalised so the weights add up to 1 at every pixel:
    :math:`w_g(x) \propto \exp(-|x - c_g|^2 / 2\sigma^2)`, with :math:`\sigma` such
    that each region covers about ``1/n`` of the image. Positions are fractions of the
    image, so a reduced preview gets the same regions.

    Parameters
    ----------
    shape : tuple of int
        (H, W).
    n : int
        Number of regions, >= 1 (1 gives a single weight of 1 everywhere).
    seed : None, int or numpy.random.Generator
        For the centres.

    Returns
    -------
    ndarray, shape (n, H, W), float64
        Weights in [0, 1] that sum to 1 over the first axis.

    Examples
    --------
    >>> w = region_weights((20, 30), 3, seed=0)
    >>> w.shape, bool(np.allclose(w.sum(axis=0), 1))
    ((3, 20, 30), True)
    """
    h = check_int("shape[0]", shape[0], 1)
    w = check_int("shape[1]", shape[1], 1)
    n = check_int("n", n, 1)
    aspect = w / h  # distances in units of the image height
    # Spread the centres out (Mitchell's best candidate): each new one is the farthest
    # of 10 random candidates from those already placed, so no two regions crowd.
    gen = rng(seed)
    centres = gen.random((1, 2))
    for _ in range(n - 1):
        cand = gen.random((10, 2))
        gap = (
            (cand[:, None, 0] - centres[None, :, 0]) ** 2
            + (aspect * (cand[:, None, 1] - centres[None, :, 1])) ** 2
        ).min(axis=1)
        centres = np.vstack([centres, cand[np.argmax(gap)]])
    y = (np.arange(h) + 0.5)[:, None] / h
    x = (np.arange(w) + 0.5)[None, :] / w
    sigma = 0.6 / math.sqrt(math.pi * n) * math.sqrt(aspect)
    d2 = (y[None] - centres[:, 0, None, None]) ** 2 + (
        aspect * (x[None] - centres[:, 1, None, None])
    ) ** 2
    logw = -d2 / (2 * sigma**2)
    logw -= logw.max(axis=0)  # softmax, safe far from every centre
    weights = np.exp(logw)
    return weights / weights.sum(axis=0)


def soft_clip(u, knee=0.7, *, out=None):
    r"""Squash values into (-1, 1): identity for :math:`|u| \le k` (the ``knee``), then bent.

    .. math:: \sigma(u) = \mathrm{sign}(u) \Big(k + (1 - k) \frac{r}{1 + r}\Big),
              \qquad r = \frac{|u| - k}{1 - k} \quad (|u| > k)

    The slope is 1 on both sides of the knee and :math:`\sigma \to \pm 1` far out, so a
    height pushed past :math:`C \pm A` by the noise is bent smoothly back instead of
    cut into a plateau (a plateau has no slope, and the shading would go flat there).
    (:math:`r / (1 + r)` rather than :math:`\tanh r`: the same shape near the knee,
    and several times cheaper on a whole clip.)

    Parameters
    ----------
    u : array_like
        Heights relative to :math:`C`, in units of :math:`A`.
    knee : float
        :math:`k` in [0, 1): where the bending starts.
    out : ndarray, optional
        Where to write the result (may be ``u`` itself, float32 or float64).

    Returns
    -------
    ndarray, float32 for float32 input, else float64

    Examples
    --------
    >>> np.round(soft_clip(np.array([0.2, 0.7, 1.0, 9.0, -9.0])), 3).tolist()
    [0.2, 0.7, 0.85, 0.99, -0.99]
    """
    knee = check_range("knee", knee, 0, 1, hi_open=True)
    u = np.asarray(u)
    if u.dtype != np.float32:
        u = u.astype(np.float64)
    k = u.dtype.type(knee)
    inner = np.clip(u, -k, k)
    r = np.subtract(u, inner, out=out)  # the signed excess over the knee
    r /= 1 - k
    # r / (1 + |r|): keeps the sign, tends to +-1
    den = np.abs(r)
    den += 1
    r /= den
    r *= 1 - k
    r += inner
    return r
