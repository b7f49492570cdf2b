r"""The starter water clips: water textures advected along flows that change in time.

Water-only crops of the bundled photos (cascades, white water, a pool, a lake surface)
and the procedural ripples, as seamless textures (:func:`_mosaic`), moved along
uniform, shear, swirl and falling flows that change in time -- gusts, eddies carried
downstream, swaying waves, choppy in places and calm in others, so that the motion has
power beyond its mean as filmed water's does (:func:`_water_flow`) -- by
:func:`~fluidnb.videodb.starter.flow_map_texture` (two flow-map phases cross-faded,
Neyret 2003). The recipes are :data:`_WATER`;
:func:`~fluidnb.videodb.starter.reference_water_flow` makes the flows one frame at a
time.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft
from numba import njit
from scipy import ndimage as ndi

from ..._random import rng
from ...fields import resize
from ._flow_map import _flow_map

__all__ = []


# ----------------------------------------------------------------------------- water


def _mosaic(sources, shape, patch, gen, overlap=0.25):
    """A seamless periodic texture of ``shape`` from random patches of ``sources``.

    Patches (each from a random source at a random place, randomly mirrored
    left-right) sit on a grid of columns, each column shifted down by a random amount
    so that the seams do not line up, wrapping around the edges. They overlap their
    neighbours by ``overlap`` of their size; their windows are flat inside and ramp
    down (raised cosine) over the overlap, where neighbours are blended about the
    sources' mean with variance-preserving weights: the inside of every patch is the
    photo itself and the seams keep its contrast.
    """
    h, w = shape
    c = sources[0].shape[2]
    ph = min(patch[0], h, *(s.shape[0] for s in sources))
    pw = min(patch[1], w, *(s.shape[1] for s in sources))
    mean = np.mean([s.mean(axis=(0, 1)) for s in sources], axis=0)

    def window(n):
        ramp = max(1, round(overlap * n))
        u = np.ones(n)
        edge = np.sin(0.5 * np.pi * (np.arange(ramp) + 0.5) / ramp) ** 2
        u[:ramp] = edge
        u[n - ramp :] = np.minimum(u[n - ramp :], edge[::-1])
        return u, ramp

    win_y, ramp_y = window(ph)
    win_x, ramp_x = window(pw)
    weights = win_y[:, None] * win_x[None, :]
    ny = math.ceil(h / max(ph - ramp_y, 1))
    nx = math.ceil(w / max(pw - ramp_x, 1))
    acc = np.zeros((h, w, c))
    weight2 = np.zeros((h, w))
    for ix in range(nx):
        cols = (round(ix * w / nx) + np.arange(pw)) % w
        shift = int(gen.integers(0, h))
        for iy in range(ny):
            rows = (shift + round(iy * h / ny) + np.arange(ph)) % h
            source = sources[int(gen.integers(0, len(sources)))]
            sh, sw = source.shape[:2]
            r = int(gen.integers(0, sh - ph + 1))
            q = int(gen.integers(0, sw - pw + 1))
            piece = source[r : r + ph, q : q + pw] - mean
            if gen.random() < 0.5:
                piece = piece[:, ::-1]
            index = np.ix_(rows, cols)
            acc[index] += weights[..., None] * piece
            weight2[index] += weights**2
    out = mean + acc / np.sqrt(np.maximum(weight2, 1e-12))[..., None]
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def _water_texture(spec, shape, gen):
    """The periodic texture of a water recipe at the clip's ``shape``."""
    from ...data import sample

    sources = []
    for name, box in spec["sources"]:
        if name == "ripples":
            # Computed at a fixed size: its waves scale with the picture, not the clip.
            source = sample("ripples", size=(256, 256)).astype(np.float64)
        else:
            top, bottom, left, right = box
            source = sample(name)[top:bottom, left:right].astype(np.float64)
            # Remove the crop's shading (the light falling across it), which tiles
            # into bands: keep the water's own detail about the crop's mean colour.
            sigma = 0.5 * min(bottom - top, right - left)
            shading = ndi.gaussian_filter(source, (sigma, sigma, 0), mode="reflect")
            source = source - shading + source.mean(axis=(0, 1))
        zy, zx = spec.get("zoom", (1.0, 1.0))
        if (zy, zx) != (1.0, 1.0):
            # The photos are small: enlarged, their water fills a fragment as filmed
            # water would (and a falling sheet is drawn out along its fall).
            new = (round(source.shape[0] * zy), round(source.shape[1] * zx))
            source = resize(source, new, order=3)
        sources.append(np.clip(source, 0.0, 1.0))
    return _mosaic(sources, shape, spec.get("patch", (96, 128)), gen)


def _smooth_noise(shape, gen, sigma):
    r"""The 2-D real FFT of a standard normal field blurred by a Gaussian of ``sigma`` px.

    A periodic blur, applied as a product of spectra: the Gaussian's transfer function
    :math:`e^{-\sigma^2 k^2 / 2}` (``scipy.ndimage.gaussian_filter(..., mode="wrap")``
    but for its kernel's truncation at 4 sigma, ~1e-4 of the field apart; ~1 ms
    instead of ~10 at the starter clips' size), so that the spectrum is nil, to
    round-off, beyond a few wavenumbers.
    """
    ky, kx = _wavenumbers(shape)
    spectrum = scipy.fft.rfft2(gen.standard_normal(shape))
    spectrum *= np.exp(-0.5 * sigma**2 * ky**2)
    spectrum *= np.exp(-0.5 * sigma**2 * kx**2)
    return spectrum


def _stream_function(shape, gen, scale):
    """A smooth, periodic random stream function, as its 2-D real FFT, unit maximum slope."""
    spectrum = _smooth_noise(shape, gen, scale)
    vy, vx = _curl(spectrum, shape)
    return spectrum / max(float(np.hypot(vy, vx).max()), 1e-12)


def _wavenumbers(shape):
    h, w = shape
    ky = 2.0 * np.pi * np.fft.fftfreq(h)[:, None]
    kx = 2.0 * np.pi * np.fft.rfftfreq(w)[None, :]
    return ky, kx


def _curl(spectrum, shape):
    """The divergence-free velocity (dy, dx) = (-dpsi/dx, dpsi/dy) of a stream function.

    ``spectrum`` is (..., H, W // 2 + 1), complex128 or complex64 (then float32 out).
    """
    ky, kx = _wavenumbers(shape)
    dtype = spectrum.dtype
    vy = scipy.fft.irfft2((-1j * kx).astype(dtype) * spectrum, s=shape)
    vx = scipy.fft.irfft2((1j * ky).astype(dtype) * spectrum, s=shape)
    return vy, vx


def _steady_flow(flow, shape, gen):
    """The recipe's mean flow (H, W, 2): uniform, shear, swirl or falling, px/frame."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    kind = flow["type"]
    speed = flow["speed"]
    base = np.zeros((h, w, 2))
    if kind in ("uniform", "shear"):
        angle = math.radians(flow["angle"])  # counter-clockwise on screen from +x
        direction = np.array([-math.sin(angle), math.cos(angle)])
        magnitude = np.full((h, w), speed)
        if kind == "shear":
            # Fastest mid-stream, slower towards the banks: the speed varies only
            # across the flow, so the field is divergence-free.
            normal = np.array([direction[1], -direction[0]])
            across = yy * normal[0] + xx * normal[1]
            s = (across - across.min()) / max(float(np.ptp(across)), 1e-12)
            low = flow.get("bank", 0.3)
            magnitude = speed * (low + (1.0 - low) * np.sin(np.pi * s))
        base = magnitude[..., None] * direction
    elif kind == "swirl":
        cy, cx = flow["centre"][0] * (h - 1), flow["centre"][1] * (w - 1)
        radius = flow["radius"] * min(h, w)
        ry, rx = yy - cy, xx - cx
        r = np.maximum(np.hypot(ry, rx), 1e-9)
        # A vortex whose speed peaks (at ``speed``) at ``radius`` and decays beyond.
        tangential = speed * 2.0 * (r / radius) / (1.0 + (r / radius) ** 2)
        sense = 1.0 if flow.get("counterclockwise", True) else -1.0
        # Counter-clockwise on screen (rows point down): the point right of the centre
        # moves up.
        base[..., 0] = -sense * tangential * rx / r
        base[..., 1] = sense * tangential * ry / r
        base += np.asarray(flow.get("drift", (0.0, 0.0)))
    elif kind == "falling":
        # Falling water accelerates: v = sqrt(v0^2 + 2 g y), here relative to the top.
        accel = flow.get("accel", 1.0)
        ripple = 1.0 + 0.15 * np.sin(2.0 * np.pi * xx / max(w / 5.0, 1.0) + gen.uniform(0, 6.3))
        base[..., 0] = speed * np.sqrt(1.0 + accel * yy / h) * ripple
        base[..., 1] = flow.get("lean", 0.0) * base[..., 0]
    else:  # pragma: no cover - the recipes below use the kinds above
        raise ValueError(f"unknown flow type {kind!r}")
    return base


def _water_flow(spec, shape, n_frames, gen):
    r"""The velocity sequence (T - 1, H, W, 2) of a water recipe, px/frame.

    The recipe's steady flow :math:`\bar v(x)` plus what makes filmed water's motion
    change from frame to frame, so that its motion spectra (Okabe et al., Eq. 2) have
    power beyond the mean, as real footage's do:

    - gusts (``gust``: amplitude :math:`a`, period :math:`P` frames, wavelength
      :math:`L` px): the steady flow swells and slackens,
      :math:`\bar v(x)\,(1 + a \sin(2\pi (t / P - s(x) / L) + \phi))`, the surges
      travelling downstream (:math:`s`: the distance along the mean flow);
    - eddies (``turbulence``: their top speed; ``eddy``: their size as a fraction of
      the frame; ``cycle``: frames in which their pattern turns over): a
      divergence-free random field (the curl of a random stream function) carried
      along by the mean flow, as turbulence is (Taylor's frozen turbulence), and
      changing as it goes, between two random patterns;
    - waves (``waves``: (amplitude px/frame, period frames, wavelength px, direction
      degrees) each): undulations travelling in that direction, each swaying the
      water to and fro across it, :math:`A \cos(k \cdot x - \omega t + \phi)\,\hat
      k_\perp` (divergence-free like the eddies: the texture sways without being
      squeezed);
    - the eddies and waves scaled by a smooth random envelope (``patchy``, mean 1):
      choppy in places, calm in others.
    """
    h, w = shape
    flow = spec["flow"]
    base = _steady_flow(flow, shape, gen)
    n = max(n_frames - 1, 0)
    t = np.arange(n, dtype=np.float64)
    mean = base.reshape(-1, 2).mean(axis=0)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    envelope = _envelope(flow, shape, gen)
    out = np.empty((n, h, w, 2), np.float32)
    if not n:
        return out
    # Each time-varying term is a sum of products of a function of time and a field
    # (sin(a - b) = sin a cos b - cos a sin b): the fields and the per-frame
    # coefficients are made here, the (T - 1, H, W, 2) sequence in one pass of
    # _assemble_flow. gains: 1 + sum_f coefs[k, f] fields[f] scales the steady flow;
    # sways: coefs[k, f] fields[f] along directions[f].
    gains, gain_coefs = [], []
    if "gust" in flow:
        amplitude, period, wavelength = flow["gust"]
        along = mean / max(float(np.hypot(*mean)), 1e-12)
        s = 2.0 * np.pi * (yy * along[0] + xx * along[1]) / wavelength
        a = 2.0 * np.pi * t / period + gen.uniform(0, 2 * np.pi)
        # amplitude sin(a - s) = amplitude (sin a cos s - cos a sin s)
        gains += [np.cos(s), np.sin(s)]
        gain_coefs += [amplitude * np.sin(a), -amplitude * np.cos(a)]
    eddies = np.zeros((2, 0, 1, 1), np.float32)
    turbulence = flow.get("turbulence", 0.0)
    if turbulence > 0:
        scale = flow.get("eddy", 0.14) * min(h, w)
        psi1 = _stream_function(shape, gen, scale)
        psi2 = _stream_function(shape, gen, scale)
        carry = flow.get("carried", 1.0) * mean  # px/frame the eddies drift
        eddies = _eddies(psi1, psi2, shape, t, carry, flow.get("cycle", 24.0))
    sways, sway_coefs, directions = [], [], []
    for amplitude, period, wavelength, angle in flow.get("waves", ()):
        rad = math.radians(angle)
        direction = np.array([-math.sin(rad), math.cos(rad)])  # (dy, dx), up is -y
        s = 2.0 * np.pi * (yy * direction[0] + xx * direction[1]) / wavelength
        a = 2.0 * np.pi * t / period - gen.uniform(0, 2 * np.pi)
        # amplitude cos(s - a) = amplitude (cos a cos s + sin a sin s), across the
        # direction of travel: divergence-free, the texture sways without being
        # squeezed (a wave pushing along its direction would crowd the texture into a
        # visible egg-crate pattern where two of them cross).
        sways += [np.cos(s), np.sin(s)]
        sway_coefs += [amplitude * np.cos(a), amplitude * np.sin(a)]
        directions += [(direction[1], -direction[0])] * 2

    def fields(f):
        return np.array(f, np.float32).reshape(len(f), h, w)

    def coefs(c):
        return np.array(c, np.float32).reshape(len(c), n).T.copy()

    _assemble_flow(
        base.astype(np.float32),
        fields(gains),
        coefs(gain_coefs),
        eddies,
        np.float32(turbulence),
        fields(sways),
        coefs(sway_coefs),
        np.array(directions, np.float32).reshape(-1, 2),
        envelope.astype(np.float32),
        out,
    )
    return out


def _eddies(psi1, psi2, shape, t, carry, cycle):
    """The eddies' velocity (2, T - 1, H, W) float32, frame after frame.

    Frame k's stream function is between the two patterns (``psi1``, ``psi2``: their
    spectra), shifted by k ``carry`` (a phase ramp); its curl is the velocity. One
    batched inverse FFT in single precision, over the columns of the spectra that hold
    anything (> 1e-12 of the largest): the stream functions are a Gaussian blur of
    noise (:func:`_smooth_noise`), their spectra nil beyond a few wavenumbers.
    """
    h, w = shape
    strength = np.maximum(np.abs(psi1), np.abs(psi2)).max(axis=0)
    cols = int(np.flatnonzero(strength > 1e-12 * strength.max())[-1]) + 1
    ky, kx = _wavenumbers(shape)
    kx = kx[:, :cols]
    phase = 2.0 * np.pi * t / cycle
    shift_y = np.exp(-1j * t[:, None, None] * ky[None] * carry[0]).astype(np.complex64)
    shift_x = np.exp(-1j * t[:, None, None] * kx[None] * carry[1]).astype(np.complex64)
    spectra = _outer(np.cos(phase), psi1[:, :cols].astype(np.complex64))
    spectra += _outer(np.sin(phase), psi2[:, :cols].astype(np.complex64))
    spectra *= shift_y
    spectra *= shift_x
    out = np.empty((2, len(t), h, w), np.float32)
    # The curl (dy, dx) = (-dpsi/dx, dpsi/dy); irfft2 is a complex inverse FFT along
    # y, then a real one along x (the columns left out are zeros).
    for c, factor in enumerate((-1j * kx, 1j * ky)):
        along_y = scipy.fft.ifft(factor.astype(np.complex64) * spectra, axis=1)
        out[c] = scipy.fft.irfft(along_y, n=w, axis=2)
    return out


@njit(cache=True, nogil=True)
def _assemble_flow(
    base, gains, gain_coefs, eddies, turbulence, sways, sway_coefs, directions, envelope, out
):
    """The water's velocity, every (T - 1, H, W) term in one pass, in float32.

    ``out[k] = base (1 + sum_f gain_coefs[k, f] gains[f]) + envelope u_k``, where
    ``u_k = turbulence eddies[:, k] + sum_f sway_coefs[k, f] sways[f] directions[f]``
    (``eddies`` may have no frames: no eddies).
    """
    n, h, w = out.shape[0], out.shape[1], out.shape[2]
    with_eddies = eddies.shape[1] > 0
    for k in range(n):
        for i in range(h):
            for j in range(w):
                g = np.float32(1.0)
                for f in range(gains.shape[0]):
                    g += gain_coefs[k, f] * gains[f, i, j]
                u0 = np.float32(0.0)
                u1 = np.float32(0.0)
                if with_eddies:
                    u0 = turbulence * eddies[0, k, i, j]
                    u1 = turbulence * eddies[1, k, i, j]
                for f in range(sways.shape[0]):
                    c = sway_coefs[k, f] * sways[f, i, j]
                    u0 += c * directions[f, 0]
                    u1 += c * directions[f, 1]
                e = envelope[i, j]
                out[k, i, j, 0] = base[i, j, 0] * g + u0 * e
                out[k, i, j, 1] = base[i, j, 1] * g + u1 * e


def _envelope(flow, shape, gen):
    """The smooth random envelope (H, W) of a recipe's eddies and waves, mean 1.

    Filmed water is choppy in places and calm in others: exp(s n - s^2 / 2), n a
    smooth standard normal field, s the recipe's ``patchy``.
    """
    patchy = flow.get("patchy", 0.5)
    noise = scipy.fft.irfft2(_smooth_noise(shape, gen, 0.2 * min(shape)), s=shape)
    noise /= max(float(noise.std()), 1e-12)
    return np.exp(patchy * noise - 0.5 * patchy**2)


def _outer(a, field):
    """``a[k] * field`` for every k: (len(a), *field.shape), in complex64."""
    return np.multiply(np.asarray(a, np.complex64)[:, None, None], field.astype(np.complex64))


def _water(recipe, size, seed, report=None):
    """A water recipe's frames, its velocity (T - 1, H, W, 2) and its texture."""
    gen = rng(seed)
    texture = _water_texture(recipe, size.shape, gen)
    velocity = _water_flow(recipe, size.shape, size.n_frames, gen)
    frames = _flow_map(texture, velocity, size.n_frames, recipe["period"], True, True, gen, report)
    return frames, velocity, texture


def _make_water(recipe, size, seed, report):
    frames, _, _ = _water(recipe, size, seed, report)
    params = {k: v for k, v in recipe.items() if k != "name"}
    params.update(
        shape=list(size.shape),
        n_frames=size.n_frames,
        technique="flow maps: two phases, cross-faded (Neyret 2003)",
    )
    return frames, params


# Crops (top, bottom, left, right) of the bundled photos that hold water only.
_FALLS = (  # the falling sheets of the three cascades
    ("stream", (105, 125, 198, 246)),
    ("stream", (147, 166, 200, 251)),
    ("stream", (288, 310, 140, 192)),
)
_FOAM = (  # white water below the cascades
    ("stream", (224, 246, 96, 150)),
    ("stream", (308, 326, 136, 172)),
    ("stream", (322, 336, 140, 236)),
)
_CALM = ("stream", (340, 372, 100, 245))  # the calm pool at the bottom
_GOLD = ("lake", (116, 156, 190, 420))  # the lake's surface in the sunset's reflection
_BLUE = ("lake", (116, 156, 0, 190))  # the lake's surface under the blue sky
_RIPPLES = ("ripples", None)

# Quick mode makes the first two of each kind; the shear clip is the one whose flow
# the tests recover with optical flow. Every flow changes in time -- gusts, eddies
# carried downstream, waves -- as filmed water's does: its motion spectra have power
# beyond the mean (Eq. 2), so that sigma matters on water as on smoke and fire.
_WATER = (
    {
        "name": "river",
        "sources": _FOAM,
        "zoom": (2.0, 2.5),
        "period": 16,
        "flow": {
            "type": "shear",
            "angle": 0.0,
            "speed": 1.6,
            "gust": (0.39, 14.0, 160.0),
            "turbulence": 0.72,
            "eddy": 0.14,
            "cycle": 20.0,
        },
    },
    {
        "name": "cascade",
        "sources": _FALLS,
        "zoom": (6.0, 2.0),
        "patch": (96, 32),
        "period": 12,
        "flow": {
            "type": "falling",
            "speed": 2.5,
            "accel": 1.5,
            "lean": 0.05,
            "gust": (0.28, 9.0, 150.0),
            "waves": ((0.9, 10.0, 160.0, -90.0),),  # the falling sheet sways sideways
        },
    },
    {
        "name": "whirlpool",
        "sources": (_RIPPLES,),
        "period": 16,
        "flow": {
            "type": "swirl",
            "speed": 1.5,
            "centre": (0.5, 0.45),
            "radius": 0.35,
            "counterclockwise": True,
            "turbulence": 0.62,
            "cycle": 14.0,
            "waves": ((0.51, 12.0, 192.0, 30.0),),
        },
    },
    {
        "name": "lake",
        "sources": (_GOLD,),
        "zoom": (2.0, 2.0),
        "period": 24,
        "flow": {
            "type": "uniform",
            "angle": 180.0,
            "speed": 0.6,
            "turbulence": 0.26,
            "waves": ((0.77, 16.0, 256.0, 200.0), (0.45, 10.0, 144.0, 150.0)),
        },
    },
    {
        "name": "pool",
        "sources": (_CALM,),
        "zoom": (2.0, 2.0),
        "period": 20,
        "flow": {
            "type": "uniform",
            "angle": -25.0,
            "speed": 1.0,
            "gust": (0.56, 18.0, 200.0),
            "turbulence": 0.51,
            "cycle": 18.0,
        },
    },
    {
        "name": "waves",
        "sources": (_RIPPLES,),
        "period": 16,
        "flow": {
            "type": "shear",
            "angle": 160.0,
            "speed": 1.3,
            "bank": 0.5,
            "turbulence": 0.36,
            "waves": ((1.02, 12.0, 192.0, 160.0), (0.58, 8.0, 120.0, 100.0)),
        },
    },
    {
        "name": "bay",
        "sources": (_BLUE,),
        "zoom": (2.0, 2.0),
        "period": 16,
        "flow": {
            "type": "swirl",
            "speed": 1.2,
            "centre": (0.45, 0.6),
            "radius": 0.4,
            "counterclockwise": False,
            "drift": (0.0, 0.3),
            "turbulence": 0.36,
            "waves": ((0.64, 14.0, 224.0, 90.0),),
        },
    },
    {
        "name": "chute",
        "sources": _FALLS,
        "zoom": (4.0, 1.5),
        "patch": (72, 24),
        "period": 12,
        "flow": {
            "type": "falling",
            "speed": 3.5,
            "accel": 0.6,
            "lean": -0.15,
            "gust": (0.22, 8.0, 140.0),
            "turbulence": 0.62,
            "eddy": 0.1,
            "cycle": 12.0,
        },
    },
)
