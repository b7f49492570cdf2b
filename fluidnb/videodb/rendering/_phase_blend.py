r"""The flow rendering's cross-fade that keeps the detail's contrast (beyond the paper).

A linear cross-fade :math:`w a + (1 - w) b` of two uncorrelated textures keeps only
:math:`w^2 + (1 - w)^2` of their variance: one half mid-way. The flow rendering's two
advected phases are copies of the photo displaced by a dozen pixels, so their fine
detail (foam, ripples, pebbles) is nearly uncorrelated, and the cross-faded frames
lost half their sharpness and snapped back when one phase alone showed (measured on
the stream: the Laplacian variance of each frame 0.53-0.57 of the photo's, twice a
loop back to 1). Heitz and Neyret (2018) keep a blend's variance by dividing the
blend of the zero-mean parts by :math:`\sqrt{\sum_i w_i^2}`, which is right for
independent inputs but inflates correlated ones (identical inputs would gain
contrast). :func:`variance_blend` measures the correlation locally instead (Yu et al.
2011 do the same for their advected textures): the detail band of the cross-fade is
given back the local energy of its parts, whatever their correlation, so identical
inputs return the input exactly and independent ones keep their variance at every
weight.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..._validation import check_array

__all__ = ["variance_blend"]


def _low(x, scratch=None, name="low"):
    """Burt & Adelson's low pass: one 5-tap pyramid level down and up (OpenCV, reflect-101).

    ``scratch``: a dict of arrays to reuse (:func:`_scratch`), or None.
    """
    import cv2

    h, w = x.shape[:2]
    half = _scratch(scratch, name + "/2", ((h + 1) // 2, (w + 1) // 2) + x.shape[2:])
    low = _scratch(scratch, name, x.shape)
    return cv2.pyrUp(cv2.pyrDown(x, dst=half), dst=low, dstsize=(w, h)).reshape(x.shape)


def _local(e, scratch=None):
    """The local mean of (H, W, 3) energies: two pyramid levels down, then up again."""
    import cv2

    h, w = e.shape[:2]
    halves = ((h + 1) // 2, (w + 1) // 2, 3)
    quarters = ((halves[0] + 1) // 2, (halves[1] + 1) // 2, 3)
    half = cv2.pyrDown(e, dst=_scratch(scratch, "local/2", halves))
    quarter = cv2.pyrDown(half, dst=_scratch(scratch, "local/4", quarters))
    half = cv2.pyrUp(quarter, dst=_scratch(scratch, "local/2up", halves), dstsize=halves[1::-1])
    out = _scratch(scratch, "local", e.shape)
    return cv2.pyrUp(half, dst=out, dstsize=(w, h)).reshape(e.shape)


def _scratch(scratch, name, shape):
    """A float32 array of ``shape`` kept in the dict ``scratch`` for the next call, or None.

    The same memory from call to call (a flat array, grown as needed): arrays of a
    frame's size made afresh for each of a frame's rectangles fault their pages in
    again whenever the allocator has given them back.
    """
    if scratch is None:
        return None
    size = int(np.prod(shape))
    flat = scratch.get(name)
    if flat is None or flat.size < size:
        flat = scratch[name] = np.empty(size, np.float32)
    return flat[:size].reshape(shape)


def variance_blend(a, b, weight):
    r"""Cross-fade two images and give the detail of the result the contrast of its parts.

    With :math:`m = b + w (a - b)` the linear cross-fade, :math:`H_x = x - L(x)` an
    image's finest band (:math:`L`: one level of a Burt & Adelson pyramid, 5-tap,
    down and up), :math:`H_m = H_b + w (H_a - H_b)`, and :math:`E_x` the local mean of
    :math:`|H_x|^2` over the colour channels (two pyramid levels down and up, about
    8 px), the result is

    .. math::

        I = m + (g - 1) H_m, \qquad
        g = \sqrt{\frac{E_b + w (E_a - E_b)}{E_m}}
        \quad\text{clipped to}\quad \Big[1, \frac{1}{\sqrt{w^2 + (1 - w)^2}}\Big].

    :math:`g^2` is the energy the parts bring (their weighted mean) over the energy the
    cross-fade kept: 1 where :math:`a` and :math:`b` agree (identical inputs give
    :math:`m = b` back exactly: :math:`E_m = E_b`, :math:`g = 1`), :math:`1 / (w^2 +
    (1 - w)^2)` for independent parts of equal energy (Heitz & Neyret 2018's
    variance-preserving gain, also its bound, so a part whose weight is small is not
    amplified beyond it), and 1 at :math:`w \in \{0, 1\}`. The low band is cross-faded
    linearly: it holds the scene's shapes, which two displaced copies share.

    Parameters
    ----------
    a, b : ndarray, shape (H, W) or (H, W, C)
        The two images (float32).
    weight : float or ndarray, shape (H, W)
        :math:`w` in [0, 1]: the weight of ``a`` (per pixel or one for all).

    Returns
    -------
    ndarray, shape of ``a``, float32

    References
    ----------
    .. [1] E. Heitz and F. Neyret, "High-performance by-example noise using a
       histogram-preserving blending operator", Proc. ACM on Computer Graphics and
       Interactive Techniques 1(2), 2018.
    .. [2] Q. Yu, F. Neyret, E. Bruneton and N. Holzschuch, "Lagrangian texture
       advection: preserving both spectrum and velocity field", IEEE TVCG 17(11),
       pp. 1612-1623, 2011.

    Examples
    --------
    Two independent noises keep nearly all their variance half-way (the gain acts on
    the detail band, estimated locally), where a linear cross-fade keeps half of it;
    identical inputs give the input back:

    >>> gen = np.random.default_rng(0)
    >>> a, b = gen.standard_normal((2, 64, 64)).astype(np.float32)
    >>> round(float((0.5 * a + 0.5 * b).var() / a.var()), 2)
    0.5
    >>> round(float(variance_blend(a, b, 0.5).var() / a.var()), 1)
    0.9
    >>> bool(np.array_equal(variance_blend(a, a, 0.3), a))
    True
    """
    a = check_array("a", a, ndim=(2, 3), dtype_kinds="biuf").astype(np.float32, copy=False)
    b = check_array("b", b, ndim=(2, 3), dtype_kinds="biuf").astype(np.float32, copy=False)
    if a.shape != b.shape:
        raise ValueError(f"b must have the shape of a {a.shape}, got {b.shape}")
    w = np.asarray(weight, np.float32)
    if w.ndim == 0:
        w = np.full(a.shape[:2], w, np.float32)
    if w.shape != a.shape[:2]:
        raise ValueError(f"weight must be one number or of shape {a.shape[:2]}, got {w.shape}")
    if not (np.all(w >= 0) and np.all(w <= 1)):
        raise ValueError(
            f"weight must be in [0, 1], got values in [{float(w.min()):g}, {float(w.max()):g}]"
        )
    out = np.empty(a.shape, np.float32)
    _blend(a, b, w, out)
    return out


def _blend(a, b, w, out, scratch=None):
    """:func:`variance_blend` of float32 ``a``, ``b`` (H, W[, C]) by ``w`` (H, W), into ``out``.

    ``scratch``: a dict in which the intermediate arrays are kept for the next call
    (:func:`_scratch`), or None: fresh ones.
    """
    a3, b3 = a.reshape(a.shape[:2] + (-1,)), b.reshape(b.shape[:2] + (-1,))
    if scratch is None:
        hm = np.empty(a3.shape, np.float32)
        energy = np.empty(a.shape[:2] + (3,), np.float32)
    else:
        hm = _scratch(scratch, "hm", a3.shape)
        energy = _scratch(scratch, "energy", a.shape[:2] + (3,))
    la = _low(a, scratch, "low a").reshape(a3.shape)
    lb = _low(b, scratch, "low b").reshape(b3.shape)
    _details(a3, b3, la, lb, w, hm, energy)
    _restore(a3, b3, w, hm, _local(energy, scratch), out.reshape(a3.shape))
    return out


@njit(cache=True, nogil=True)
def _details(a, b, la, lb, w, hm, energy):
    """:math:`H_m` and the energies :math:`|H_a|^2, |H_b|^2, |H_m|^2` per pixel (one pass)."""
    h, wd, nc = a.shape
    for r in range(h):
        for c in range(wd):
            wt = w[r, c]
            ea = np.float32(0.0)
            eb = np.float32(0.0)
            em = np.float32(0.0)
            for k in range(nc):
                ha = a[r, c, k] - la[r, c, k]
                hb = b[r, c, k] - lb[r, c, k]
                m = hb + wt * (ha - hb)
                hm[r, c, k] = m
                ea += ha * ha
                eb += hb * hb
                em += m * m
            energy[r, c, 0] = ea
            energy[r, c, 1] = eb
            energy[r, c, 2] = em


@njit(cache=True, nogil=True)
def _restore(a, b, w, hm, energy, out):
    """``m + (g - 1) H_m`` with the clipped gain :math:`g` of :func:`variance_blend`."""
    h, wd, nc = a.shape
    for r in range(h):
        for c in range(wd):
            wt = w[r, c]
            ea, eb, em = energy[r, c, 0], energy[r, c, 1], energy[r, c, 2]
            want = eb + wt * (ea - eb)
            g = np.float32(1.0)
            if em > np.float32(1e-20) and want > em:
                cap = np.float32(1.0) / np.sqrt(wt * wt + (np.float32(1.0) - wt) ** 2)
                g = min(np.sqrt(want / em), cap)
            for k in range(nc):
                if wt == 1:  # one input alone, exactly
                    m = a[r, c, k]
                elif wt == 0:
                    m = b[r, c, k]
                else:
                    m = b[r, c, k] + wt * (a[r, c, k] - b[r, c, k])
                out[r, c, k] = m + (g - np.float32(1.0)) * hm[r, c, k] if g > 1 else m
