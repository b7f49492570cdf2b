r"""The last steps of the rendering: moving matte, revealed background, loop, composite.

Okabe et al., sec. 6: for fire and smoke the matte moves with the animation,
:math:`B_{i+1} = \tau W_i(B_i) + (1 - \tau)\alpha` (:func:`dynamic_matte`); the
background it uncovers is filled with the photo's own texture
(:func:`inpaint_background`, exemplar-based, beyond the paper, which cloned it by
hand); the frames are laid over the untouched image through the matte
(:func:`composite`). Beyond the paper, a clip can be made to loop seamlessly by
an equal-power cross-fade (:func:`loop_crossfade`).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi

from ..._validation import check_array, check_int, check_range
from ...fields import advect

__all__ = ["composite", "dynamic_matte", "inpaint_background", "loop_crossfade"]

# The area of each B_i is restored to within this relative error (or as close as
# [0, 1] allows).
_AREA_RTOL = 1e-4
_AREA_ITERATIONS = 100


def _restore_area(b, area):
    """Scale ``b`` (in place) so that ``sum(clip(s * b, 0, 1)) == area``.

    ``s -> sum(min(s b, 1))`` is concave and increasing, so the fixed-point iteration
    ``s <- s * area / sum`` approaches the solution monotonically from one side.
    """
    s = 1.0
    for _ in range(_AREA_ITERATIONS):
        total = float(np.minimum(s * b, 1.0, dtype=np.float64).sum())
        if total <= 0.0 or abs(total - area) <= _AREA_RTOL * area:
            break
        s *= area / total
    if s != 1.0:
        np.multiply(b, np.float32(s), out=b)
        np.minimum(b, 1.0, out=b)
    return b


def _uncovered(photo, fill, alpha, matte):
    r"""What shows behind the moving fluid: the photo, the fill only where the fluid left.

    The composite ``back + B_i (frame - back)`` over the filled background alone
    mixes the fill into the photo wherever the matte is soft: a drawn region's wide
    soft edge over white cloud became a dark band of filled-in rock, from frame 0
    on (issue 35). Behind :math:`B_i` the photo :math:`I` is kept, and the fill
    :math:`F` shows only in the part of the matte the fluid has left,
    :math:`\max(0, \alpha - B_i)`:

    .. math::

        (1 - B_i)\, U_i = \big(1 - \max(\alpha, B_i)\big) I
            + \max(0, \alpha - B_i)\, F,

    so :math:`B_i U_i`'s complement sums to one, where :math:`B_i = \alpha` the
    composite of the photo's own fluid is the photo, where the fluid has moved on
    the fill shows as much as it left, and where it moves over the scene the scene
    is the photo. Where :math:`B_i = 1` nothing shows: :math:`U_i = F`.

    ``photo``, ``fill`` (H, W, 3), ``alpha``, ``matte`` (H, W), float32; returns
    :math:`U_i` (H, W, 3).
    """
    reveal = np.maximum(alpha - matte, np.float32(0))
    keep = np.float32(1) - np.maximum(alpha, matte)
    rest = np.float32(1) - matte
    some = rest > np.float32(1e-6)
    out = fill.copy()
    share = np.divide(keep, rest, out=np.zeros_like(rest), where=some)[..., None]
    part = np.divide(reveal, rest, out=np.zeros_like(rest), where=some)[..., None]
    mixed = share * photo + part * fill
    out[some] = mixed[some]
    return out


def dynamic_matte(alpha, motion, *, tau):
    r"""The moving boundary of fire and smoke: :math:`B_{i+1} = \tau W_i(B_i) + (1 - \tau)\alpha`.

    Okabe et al., sec. 6 ("dynamic fluid boundary", after Chuang et al. 2005): a static matte
    makes flames and smoke look cut out, so the matte moves with the animation. Each
    step carries the previous matte along the animation's motion at frame :math:`i`
    (:math:`W_i`, a semi-Lagrangian warp, :func:`fluidnb.fields.advect`) and pulls it
    back towards the user's matte :math:`\alpha` by :math:`1 - \tau`, so it never
    drifts away. Each :math:`B_i` is then rescaled to the area (sum) of
    :math:`\alpha`, keeping its values in [0, 1], as the paper keeps the area constant.

    Parameters
    ----------
    alpha : ndarray, shape (H, W)
        The alpha matte :math:`\alpha`, in [0, 1].
    motion : ndarray, shape (T - 1, H, W, 2)
        The animation's motion :math:`\phi_i` from frame ``i`` to ``i + 1``, (dy, dx) in
        pixels (a flow sequence, see docs/conventions.md).
    tau : float
        :math:`\tau` in [0, 1]: how much of the warped matte is kept each frame
        (0: the static matte; 1: carried along freely).

    Returns
    -------
    ndarray, shape (T, H, W), float32
        :math:`B_1 = \alpha, B_2, \ldots, B_T`, each of the area of :math:`\alpha`
        (relative error below 1e-4 unless the matte would have to exceed 1).
        ``tau = 0`` gives :math:`\alpha` in every frame exactly.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Pacific Graphics 2011, section 6.
    .. [2] Y.-Y. Chuang, D. B. Goldman, K. C. Zheng, B. Curless, D. H. Salesin and
       R. Szeliski, "Animating pictures with stochastic motion textures", ACM
       Transactions on Graphics 24(3), pp. 853-860, 2005.

    Examples
    --------
    >>> alpha = np.zeros((16, 16), dtype=np.float32)
    >>> alpha[4:12, 4:12] = 1.0
    >>> motion = np.zeros((3, 16, 16, 2))
    >>> motion[..., 1] = 1.5  # to the right
    >>> b = dynamic_matte(alpha, motion, tau=0.8)
    >>> b.shape
    (4, 16, 16)
    >>> [round(float(x.sum()), 2) for x in b]
    [64.0, 64.0, 64.0, 64.0]
    """
    a = check_array("alpha", alpha, ndim=2, dtype_kinds="biuf")
    if a.min() < 0 or a.max() > 1:
        raise ValueError(
            f"alpha must be in [0, 1], got values in [{float(a.min()):g}, {float(a.max()):g}]"
        )
    a = a.astype(np.float32)
    m = check_array("motion", motion, ndim=4, dtype_kinds="iuf", min_size=0)
    if m.shape[1:] != a.shape + (2,):
        raise ValueError(
            f"motion must have shape (T - 1, H, W, 2) with (H, W) = {a.shape}, got {m.shape}"
        )
    tau = check_range("tau", tau, 0, 1)
    out = np.empty((m.shape[0] + 1,) + a.shape, dtype=np.float32)
    out[0] = a
    area = float(a.sum(dtype=np.float64))
    for i in range(m.shape[0]):
        if tau == 0.0:
            out[i + 1] = a
            continue
        b = np.float32(tau) * advect(out[i], m[i]) + np.float32(1.0 - tau) * a
        np.clip(b, 0.0, 1.0, out=b)
        out[i + 1] = _restore_area(b, area)
    return out


def inpaint_background(image, matte, *, dilate=2):
    """Fill in the background hidden behind the fluid (beyond the paper).

    A moving boundary (:func:`dynamic_matte`) uncovers pixels that were behind the
    fluid in the photograph; the paper's authors cloned them by hand (Photoshop's
    stamp tool). By default they are filled with the photo's own texture: every pixel
    with ``matte > 0``, grown by ``dilate`` pixels to cover the fluid's soft fringe,
    is filled by exemplar-based completion (:func:`fluidnb.videodb.rendering.exemplar_fill`:
    Wexler et al. 2007 with PatchMatch), so rock continues as rock and sky as sky.
    Telea's diffusion (``cv2.inpaint``), used before, smeared the border's colours
    into streaks across the hole. Measured on the clouds photo's matte (40 % of the
    pixels, 2 shared cores): 0.3-0.6 s at 320 x 180, 3.5 s at 640 x 360; once per
    render.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        The target image, in [0, 1].
    matte : ndarray, shape (H, W)
        The fluid's alpha matte; pixels with a value above 0 are filled.
    dilate : int
        Pixels by which the region grows (>= 0).

    Returns
    -------
    ndarray, shape of ``image``, float32
        The image with the region filled; every pixel outside it unchanged.

    References
    ----------
    .. [1] Y. Wexler, E. Shechtman and M. Irani, "Space-time completion of video",
       IEEE Transactions on Pattern Analysis and Machine Intelligence 29(3),
       pp. 463-476, 2007.

    Examples
    --------
    >>> img = np.full((32, 32), 0.25, dtype=np.float32)
    >>> matte = np.zeros((32, 32))
    >>> matte[12:20, 12:20] = 1.0
    >>> img[matte > 0] = 1.0  # the fluid
    >>> out = inpaint_background(img, matte)
    >>> bool(np.abs(out - 0.25).max() < 1e-3)
    True
    """
    from ._fill import exemplar_fill

    img = check_array("image", image, ndim=(2, 3), dtype_kinds="biuf").astype(np.float32)
    if img.min() < 0 or img.max() > 1:
        raise ValueError(
            f"image must be in [0, 1], got values in [{float(img.min()):g}, {float(img.max()):g}]"
        )
    mt = check_array("matte", matte, ndim=2, dtype_kinds="biuf")
    if mt.shape != img.shape[:2]:
        raise ValueError(
            f"matte must have the image's height and width {img.shape[:2]}, got {mt.shape}"
        )
    dilate = check_int("dilate", dilate, 0)
    region = mt > 0
    if dilate:
        region = ndi.binary_dilation(region, ndi.generate_binary_structure(2, 2), dilate)
    if not region.any():
        return img
    if region.all():
        raise ValueError("matte covers the whole image: no background to fill from")
    return exemplar_fill(img, region)


def loop_crossfade(frames, *, overlap):
    r"""Make a clip loop seamlessly by cross-fading its end into its start.

    The clip is shortened to ``L = T - overlap`` frames: the first ``overlap`` frames
    become mixes of frame ``j`` and frame ``L + j`` (the ones that followed frame
    ``L - 1`` in the original), starting almost all tail and ending almost all head,
    so frame ``L - 1`` -> frame 0 is a step of the original clip.

    Frames are split into their temporal mean :math:`\mu` (kept as is) and zero-mean
    fluctuations (the difference frames :math:`D_i`), which are cross-faded with
    equal-power weights :math:`\sin\theta_j, \cos\theta_j`. Two unrelated stretches of
    a fluid clip are uncorrelated, so their variances add: a linear fade
    :math:`a D + (1 - a) D'` would drop the fluctuation's variance to one half at
    :math:`a = 1/2` and the motion would visibly calm down at every loop, while
    :math:`\sin^2 + \cos^2 = 1` keeps its variance constant.

    Parameters
    ----------
    frames : ndarray, shape (T, ...)
        The clip (any frame shape).
    overlap : int
        Frames to cross-fade, in [0, T // 2].

    Returns
    -------
    ndarray, shape (T - overlap, ...), float32
        ``overlap = 0`` returns a copy of the input.

    Examples
    --------
    >>> clip = np.random.default_rng(0).standard_normal((40, 8, 8)).astype(np.float32)
    >>> loop = loop_crossfade(clip, overlap=8)
    >>> loop.shape
    (32, 8, 8)
    >>> bool(np.array_equal(loop[8:], clip[8:32]))  # untouched after the fade
    True
    """
    f = check_array("frames", frames, dtype_kinds="biuf")
    if f.ndim < 1:
        raise ValueError(f"frames must have a time axis, got shape {f.shape}")
    t_count = f.shape[0]
    overlap = check_int("overlap", overlap, 0, t_count // 2)
    out = f[: t_count - overlap].astype(np.float32)  # a copy
    if overlap == 0:
        return out
    mean = f.mean(axis=0, dtype=np.float64)
    length = t_count - overlap
    for j in range(overlap):
        theta = 0.5 * np.pi * (j + 1) / (overlap + 1)
        head = f[j] - mean
        tail = f[length + j] - mean
        out[j] = mean + np.sin(theta) * head + np.cos(theta) * tail
    return out


def composite(animated, background, matte):
    r"""Lay the animation over the background through the matte.

    ``out = background + matte * (animated - background)`` per frame (Okabe et al., sec. 6:
    the animated fluid over the untouched image, or over the inpainted background
    with a moving matte). Where the matte is 0 the output is the background exactly.

    Parameters
    ----------
    animated : ndarray, shape (T, H, W) or (T, H, W, C)
        The rendered frames.
    background : ndarray, shape (H, W[, C]) or (T, H, W[, C])
        The untouched image (or inpainted background), static or per frame.
    matte : ndarray, shape (H, W) or (T, H, W)
        Static or per-frame matte (:math:`\alpha` or :math:`B_i`), in [0, 1].

    Returns
    -------
    ndarray, shape of ``animated``, float32

    Examples
    --------
    >>> anim = np.ones((2, 2, 3), dtype=np.float32)
    >>> bg = np.zeros((2, 3), dtype=np.float32)
    >>> composite(anim, bg, np.array([[0.0, 0.5, 1.0], [0.0, 0.0, 0.0]]))[0]
    array([[0. , 0.5, 1. ],
           [0. , 0. , 0. ]], dtype=float32)
    """
    a = check_array("animated", animated, ndim=(3, 4), dtype_kinds="biuf")
    frame_shape = a.shape[1:]
    bg = check_array("background", background, ndim=(a.ndim - 1, a.ndim), dtype_kinds="biuf")
    if bg.shape not in (frame_shape, a.shape):
        raise ValueError(f"background must have shape {frame_shape} or {a.shape}, got {bg.shape}")
    m = check_array("matte", matte, ndim=(2, 3), dtype_kinds="biuf")
    if m.shape not in (a.shape[1:3], a.shape[:3]):
        raise ValueError(f"matte must have shape {a.shape[1:3]} or {a.shape[:3]}, got {m.shape}")
    if m.min() < 0 or m.max() > 1:
        raise ValueError(
            f"matte must be in [0, 1], got values in [{float(m.min()):g}, {float(m.max()):g}]"
        )
    m = m.astype(np.float32)
    if a.ndim == 4:
        m = m[..., None]
    bg = bg.astype(np.float32)
    # bg + m (a - bg): where m == 0 this adds exactly zero, so the background comes
    # through bit for bit. In place in one new array (the same operations).
    out = np.subtract(a, bg, dtype=np.float32)
    out *= m
    out += bg
    return out
