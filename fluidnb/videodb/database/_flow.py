r"""Optical flow of a database clip (Okabe et al., sec. 4, Fig. 5-b).

The paper computes the motion of every video with OFLib's TV-L1 optical flow (Zach,
Pock and Bischof 2007) with :math:`\theta = 1.0`, :math:`\lambda = 0.8` and 25
iterations, "tuned so that the flow is not sensitive to the high-frequency motion of
fluids and comes out relatively smooth". Two backends compute it here:

- ``"dis"``: OpenCV's Dense Inverse Search (Kroeger et al. 2016), preset MEDIUM, on
  8-bit frames. Fast (10-15 ms a 320 x 180 pair, 20-40 ms at 640 x 360 on the
  2-core build machine) and deterministic; the default for building databases.
- ``"tvl1"``: scikit-image's TV-L1 (the paper's model, Zach et al. 2007; Wedel et al.
  2009) with the paper's parameters mapped as explained in :func:`optical_flow`:
  1-2 s a 320 x 180 pair, about 100 times slower.

The flow is computed once per source clip; the augmented versions get theirs by
:func:`fluidnb.videodb.database._augment.transform_flow`, not by estimating again.
"""

from __future__ import annotations

import numpy as np

from ..._image import to_uint8
from ..._progress import Progress
from ..._validation import check_array, check_choice
from .._common._params import FLOW_BACKENDS

__all__ = [
    "MIN_FLOW_SIDE",
    "TVL1_ATTACHMENT",
    "TVL1_INTENSITY_SCALE",
    "TVL1_ITERATIONS",
    "TVL1_LAMBDA",
    "TVL1_THETA",
    "TVL1_WARPS",
    "optical_flow",
]

#: The paper's TV-L1 settings (section 4): :math:`\theta`, :math:`\lambda`, iterations.
TVL1_THETA = 1.0
TVL1_LAMBDA = 0.8
TVL1_ITERATIONS = 25
#: Warps per pyramid level; the paper does not give OFLib's, so scikit-image's default.
TVL1_WARPS = 5
#: OFLib's :math:`\lambda` weighs grey levels in 0-255; our frames are in [0, 1].
TVL1_INTENSITY_SCALE = 255.0
#: scikit-image's ``attachment`` for frames in [0, 1]: :math:`255 \lambda`.
TVL1_ATTACHMENT = TVL1_LAMBDA * TVL1_INTENSITY_SCALE
#: Smallest height and width accepted (OpenCV's DIS refuses frames of 8 x 8 pixels).
MIN_FLOW_SIDE = 16


def optical_flow(frames, *, backend="dis", progress=None):
    r"""Forward optical flow between consecutive frames of a grey clip.

    ``flow[t]`` moves frame ``t`` onto frame ``t + 1``:
    ``frames[t + 1](x + flow[t](x)) ~= frames[t](x)`` (docs/conventions.md).

    Parameters
    ----------
    frames : ndarray, shape (T, H, W), float
        Grey frames in [0, 1], ``T >= 2``, ``H, W >= 16``.
    backend : {"dis", "tvl1"}
        ``"dis"``: OpenCV's DIS flow [2]_ (preset MEDIUM) on the frames rounded to
        8 bits. ``"tvl1"``: scikit-image's TV-L1 [3]_ [4]_ with the paper's settings
        (see Notes).
    progress : callable, optional
        ``progress(fraction, message)``, called after every frame pair.

    Returns
    -------
    ndarray, shape (T - 1, H, W, 2), float32
        (dy, dx) in pixels per frame; ``dx > 0`` is motion to the right, ``dy > 0``
        motion down.

    Raises
    ------
    ValueError
        If ``frames`` is not a (T, H, W) float array with ``T >= 2`` and ``H, W >= 16``,
        holds NaN or values outside [0, 1], or ``backend`` is unknown.

    Notes
    -----
    **DIS.** OpenCV returns (dx, dy); the components are swapped to (dy, dx). The
    result does not depend on OpenCV's thread count (checked with 1, 2 and the
    default); a build runs it on one (``fluidnb._threads.opencv_single_threaded``),
    as it runs clips side by side itself.

    **TV-L1 and the paper's parameters** [1]_. Zach et al. [3]_ minimise
    :math:`\int |\nabla u| + \frac{1}{2\theta}(u - v)^2 + \lambda |\rho(v)|` with the
    linearised residual :math:`\rho(v) = I_1(x + u_0) + \nabla I_1 \cdot (v - u_0) -
    I_0(x)`, alternating a pointwise thresholding step on :math:`v` (threshold
    :math:`\lambda\theta|\nabla I_1|^2`) and Chambolle's projection for the ROF
    problem on :math:`u` with weight :math:`\theta`. scikit-image's ``_tvl1`` is the
    same scheme term for term: ``attachment * tightness`` is its threshold
    :math:`\lambda\theta` and ``dt / tightness`` its :math:`\tau / \theta` (with
    :math:`\tau` = 0.25), so ``attachment`` is :math:`\lambda` and ``tightness`` is
    :math:`\theta` (its docs call the latter tau). ``num_iter`` is the number of
    these alternations per warp, ``num_warp`` the re-linearisations per pyramid level.

    The data term scales with the grey levels, so :math:`\lambda` is tied to them:
    on 0-255 images it equals :math:`255\lambda` on our [0, 1] frames. We read the
    paper's :math:`\lambda = 0.8` as one on 0-255 grey levels (the scale of OpenCV's
    and IPOL's TV-L1, whose default is :math:`\lambda = 0.15`) and pass
    ``attachment = 0.8 * 255 = 204``, ``tightness = 1.0``, ``num_iter = 25`` (the
    paper's iteration count) and ``num_warp = 5`` (scikit-image's default; OFLib's is
    not given). Measured on synthetic textures whose flow is known exactly (48 x 64,
    tests/videodb/database/test_videodb_flow.py):

    - a sub-pixel translation comes out within 0.02-0.08 px mean endpoint error and
      a 2-degree rotation within 0.07 px (inside a 4-pixel border);
    - a sinusoidal shear keeps a gain of 0.88 at a wavelength of 64 px but only 0.37
      at 16 px (scikit-image's defaults: 0.94 and 0.52): smoother than the defaults,
      "not sensitive to high-frequency motion", as the paper says;
    - reading :math:`\lambda = 0.8` on [0, 1] grey levels instead (``attachment =
      0.8``) makes the data term so weak that only near-rigid motion survives: gains
      0.0 and 0.31 at 16 and 64 px, and 0.4 px error on a 3-degree rotation. The
      motion of a 48 x 48 fragment would be flattened towards its mean, which the
      motion spectra (Eq. 2) could not use.

    The paper does not say which OFLib it used. Zach's own GPU TV-L1 (GPU-KLT+FLOW)
    divides its image derivatives by 255 before the thresholding step, i.e. weighs
    :math:`\lambda` against [0, 1] grey levels; if that was the paper's library, its
    flows were smoother than these.

    References
    ----------
    .. [1] M. Okabe, K. Anjyo, R. Onai, "Creating fluid animation from a single image
       using video database", Computer Graphics Forum 30(7) (Pacific Graphics 2011),
       section 4.
    .. [2] T. Kroeger, R. Timofte, D. Dai, L. Van Gool, "Fast optical flow using dense
       inverse search", ECCV 2016.
    .. [3] C. Zach, T. Pock, H. Bischof, "A duality based approach for realtime TV-L1
       optical flow", DAGM 2007, LNCS 4713, pp. 214-223.
    .. [4] A. Wedel, T. Pock, C. Zach, H. Bischof, D. Cremers, "An improved algorithm
       for TV-L1 optical flow", Statistical and Geometrical Approaches to Visual
       Motion Analysis, LNCS 5604, 2009, pp. 23-45.

    Examples
    --------
    A smooth blob moving two pixels to the right between two frames:

    >>> y, x = np.mgrid[0:48, 0:64]
    >>> frames = np.stack(
    ...     [np.exp(-((y - 24) ** 2 + (x - c) ** 2) / 50.0) for c in (30, 32)]
    ... ).astype(np.float32)
    >>> flow = optical_flow(frames)
    >>> flow.shape
    (1, 48, 64, 2)
    >>> np.round(flow[0, 24, 30], 2).tolist()  # (dy, dx)
    [0.0, 2.0]
    """
    arr = _check_frames(frames)
    backend = check_choice("backend", backend, FLOW_BACKENDS)
    report = Progress(progress)
    pairs = arr.shape[0] - 1
    out = np.empty((pairs, *arr.shape[1:], 2), np.float32)
    estimate = _dis_estimator() if backend == "dis" else _tvl1
    for t in range(pairs):
        out[t] = estimate(arr[t], arr[t + 1])
        report((t + 1) / pairs, f"optical flow ({backend}): pair {t + 1} of {pairs}")
    return out


def _check_frames(frames):
    arr = check_array("frames", frames, ndim=3, dtype_kinds="f")
    t, h, w = arr.shape
    if t < 2:
        raise ValueError(f"frames must hold at least 2 frames, got shape {arr.shape}")
    if h < MIN_FLOW_SIDE or w < MIN_FLOW_SIDE:
        raise ValueError(
            f"frames must be at least {MIN_FLOW_SIDE} x {MIN_FLOW_SIDE} pixels, "
            f"got shape {arr.shape}"
        )
    lo, hi = float(arr.min()), float(arr.max())
    if lo < -1e-3 or hi > 1 + 1e-3:
        raise ValueError(f"frames must be grey levels in [0, 1], got values in [{lo:g}, {hi:g}]")
    return arr


def _dis_estimator():
    import cv2

    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)

    def estimate(first, second):
        # No initial flow is passed, so the instance carries nothing between pairs.
        flow = dis.calc(to_uint8(first), to_uint8(second), None)
        return flow[..., ::-1]

    return estimate


def _tvl1(first, second):
    from skimage.registration import optical_flow_tvl1

    flow = optical_flow_tvl1(
        np.clip(first, 0.0, 1.0),
        np.clip(second, 0.0, 1.0),
        attachment=TVL1_ATTACHMENT,
        tightness=TVL1_THETA,
        num_iter=TVL1_ITERATIONS,
        num_warp=TVL1_WARPS,
        dtype=np.float32,
    )
    return np.moveaxis(flow, 0, -1)
