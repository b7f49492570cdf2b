"""Parameters of the video-database method (Okabe et al., secs. 4-6)."""

from __future__ import annotations

from dataclasses import dataclass

from ..._params import Params, param

__all__ = ["AUGMENTATIONS", "FLOW_BACKENDS", "RENDERINGS", "AnimateParams", "DatabaseParams"]

#: Optical-flow backends (Okabe et al., sec. 4): ``"dis"`` is OpenCV's DIS flow (preset
#: MEDIUM; fast, the default for building), ``"tvl1"`` scikit-image's TV-L1 (the
#: paper's model, OFLib's, ~50x slower).
FLOW_BACKENDS = ("dis", "tvl1")

#: Which of the 18 versions of a clip go into a database: ``"paper"`` all of them
#: (flip x scales 50/75/100 % x rotations -22.5/0/+22.5 degrees), ``"flip"`` the clip
#: and its mirror image, ``"none"`` the clip alone.
AUGMENTATIONS = ("paper", "flip", "none")

#: The renderings of :func:`fluidnb.videodb.render`: ``"flow"`` moves the photo itself
#: along the assigned motion in a seamless loop and adds the difference frames on top
#: (beyond the paper), ``"paper"`` adds the difference frames to a motion-blurred photo
#: (Okabe et al., sec. 6), whose own texture never moves.
RENDERINGS = ("flow", "paper")


@dataclass(frozen=True)
class DatabaseParams(Params):
    r"""How a video database is built (Okabe et al., sec. 4).

    The fragment geometry is fixed (48 x 48 pixels, stride 24, a 9 x 9 dense-SIFT grid;
    see :mod:`fluidnb.videodb._common._geometry`); these are the choices left.

    Attributes
    ----------
    N : int
        :math:`N`, frames per fragment: a fragment is a temporal window of ``N``
        frames of its clip (our decision; the paper's fragments span a whole video).
        Its mean image is :math:`A = \frac{1}{N}\sum_i F_i` (Okabe et al., sec. 6) and its
        motion spectra have ``(N - 1) // 2 + 1`` frequency bins (Eq. 2's :math:`f = 1
        \ldots N/2`).
    window_overlap : int
        Frames shared by consecutive windows of a clip (0: windows side by side).
    augment : str
        Which versions of each clip are cut into fragments; one of
        :data:`AUGMENTATIONS` (the paper's 18 by default).
    flow : str
        The optical-flow backend, one of :data:`FLOW_BACKENDS`.
    motion_threshold : float
        A pixel moves "significantly" when its flow magnitude averaged over the
        window exceeds this (px/frame); other pixels are masked out of the motion
        features, and fragments with no moving pixel are dropped (Okabe et al., Fig. 5-d).
    words : int
        :math:`k`, visual words in the codebook (the paper: 100, 200, 300 and 500 were
        tried; 200 was best).
    codebook_samples : int
        At most this many SIFT descriptors, drawn with the build's seed, train the
        codebook (repeated cluster bisectioning).
    max_side : int
        Clips whose longer side exceeds this are scaled down on the way in (the
        paper's videos are 640 x 360 or 480 x 360).
    """

    N: int = param(
        32,
        lo=4,
        hi=256,
        integer=True,
        symbol="N",
        eq="Sec. 6, Eq. (2)",
        doc="frames per fragment (a temporal window of its clip)",
        unit="frames",
        ui_range=(8, 64),
        step=2,
    )
    window_overlap: int = param(
        0,
        lo=0,
        hi=255,
        integer=True,
        doc="frames shared by consecutive windows of a clip",
        unit="frames",
        ui_range=(0, 32),
    )
    augment: str = param(
        "paper",
        choices=AUGMENTATIONS,
        eq="Sec. 4, Fig. 4-a",
        doc="versions of each clip: flip x 3 scales x 3 rotations, a flip, or none",
    )
    flow: str = param(
        "dis",
        choices=FLOW_BACKENDS,
        eq="Sec. 4, Fig. 5",
        doc="optical flow: OpenCV DIS (fast) or scikit-image TV-L1 (the paper's)",
    )
    motion_threshold: float = param(
        0.2,
        lo=0,
        hi=100,
        eq="Sec. 4, Fig. 5-d",
        doc="mean flow magnitude above which a pixel moves",
        unit="px/frame",
        ui_range=(0, 2),
        step=0.05,
    )
    words: int = param(
        200,
        lo=2,
        hi=256,
        integer=True,
        symbol="k",
        eq="Sec. 4",
        doc="visual words in the codebook",
        ui_range=(16, 256),
    )
    codebook_samples: int = param(
        1_000_000,
        lo=1000,
        hi=100_000_000,
        integer=True,
        doc="at most this many descriptors train the codebook",
    )
    max_side: int = param(
        640,
        lo=48,
        hi=4096,
        integer=True,
        doc="longer side above which a clip is scaled down on the way in",
        unit="px",
    )

    def check(self):
        """Cross-field rule: windows must advance (``window_overlap < N``)."""
        if self.window_overlap >= self.N:
            raise ValueError(f"window_overlap must be < N ({self.N}), got {self.window_overlap}")

    @property
    def window_step(self):
        """Frames between the starts of consecutive windows."""
        return self.N - self.window_overlap

    @property
    def n_bins(self):
        """Frequency bins of the motion spectra: ``(N - 1) // 2 + 1`` (f = 1 is DC)."""
        return (self.N - 1) // 2 + 1


@dataclass(frozen=True)
class AnimateParams(Params):
    r"""How a target image is animated from a database (Okabe et al., secs. 5-6).

    Attributes
    ----------
    sigma : float
        :math:`\sigma` of Eq. (2): the weight of the motion spectra's non-DC
        frequencies against the DC term (the mean motion). Large values ignore the
        mean motion and the result's motion turns random (Okabe et al., sec. 7).
    lam : float
        :math:`\lambda` of Eq. (4): the weight of the smoothness term against the data
        term. The paper found it matters little.
    rho : float
        :math:`\rho` of Eq. (6): the weight of the textureness term against the
        motion term (the paper uses :math:`\rho = 100\,\sigma`).
    candidates : int
        Database fragments kept per target fragment by appearance (Eq. 1): the labels
        of the MRF (the paper: 100).
    max_angle : float
        With a user direction: database fragments whose mean motion points more than
        this many degrees away from it are dropped before the top ``candidates``
        are taken (Okabe et al., sec. 5, Fig. 8).
    max_speed_ratio : float
        With a user speed map: fragments whose mean speed differs from it by more
        than this factor (either way) are dropped.
    shutter : float
        The pseudo shutter time of the approximate mean image (Okabe et al., sec. 6), in
        frames: the target is blurred along the assigned motion over ``shutter``
        frames' worth of movement, standing in for the fragments' mean images
        :math:`A`, which are blurred by the motion over their :math:`N` frames.
    denoise : float
        The extra Gaussian blur of the approximate mean image, in pixels per px/frame
        of motion (Okabe et al., sec. 6: "proportional to the motion's magnitude").
    cell : int
        Side in pixels of the grid cells in which each frame's histograms are matched
        to the target's (Okabe et al., sec. 6, after Heeger & Bergen).
    tau : float
        :math:`\tau` of the dynamic fluid boundary :math:`B_{i+1} = \tau W_i(B_i) +
        (1 - \tau)\alpha` (Okabe et al., sec. 6): 0 keeps the matte still (water seen
        from afar), larger values let fire and smoke move their outline.
    loop : int
        Frames cross-faded from the end of the clip into its start so it loops
        seamlessly (0: no loop; the clip then has :math:`N` frames, else
        :math:`N -` ``loop``).
    rendering : str
        ``"flow"`` (beyond the paper): the photo itself is moved along the assigned
        motion in a seamless loop and the difference frames are added on top;
        ``"paper"``: the difference frames are added to a motion-blurred photo
        (Okabe et al., sec. 6). See :data:`RENDERINGS`.
    travel : float
        The flow rendering's travel in pixels: each of its two advected phases
        carries the photo this far (at the typical speed in the matte) before it
        fades out and restarts. Shorter travel stretches the photo less but makes
        the cross-fade read as motion backwards (the two phases are then offset by
        less than the texture's grain: measured with DIS, 6 px keep 50-70 % of the
        speed, 12 px 80-95 %, 24 px 95-100 %); the clip is made long enough
        (whole repeats of the difference frames' loop) for the cycle to fit.
    detail : float
        The flow rendering's weight of the difference frames :math:`D_i` added on
        top of the moving photo (0: the warp alone). Our decision, by looking at
        clouds, smoke and water: 0.5; at 1 the smoke database's large swirls show
        on smooth clouds as a pattern of their own.
    """

    sigma: float = param(
        100.0,
        lo=0,
        hi=1e6,
        symbol=r"\sigma",
        eq="Eq. (2)",
        doc="weight of the non-DC motion frequencies against the mean motion",
        log=True,
        # The lessons' sweeps: 0.01-100 x the paper's (07b sec. 7), up to 1e6 (its
        # exercise 3).
        ui_range=(1.0, 1e6),
        step=0.1,
    )
    lam: float = param(
        0.01,
        lo=0,
        hi=1e6,
        symbol=r"\lambda",
        eq="Eq. (4)",
        doc="weight of the smoothness term against the data term",
        log=True,
        # 0.01-100 x the paper's 0.01 (07b sec. 7) and up to 10, where the smoothness
        # term alone decides.
        ui_range=(1e-4, 10.0),
        step=0.1,
    )
    rho: float = param(
        1e4,
        lo=0,
        hi=1e8,
        symbol=r"\rho",
        eq="Eq. (6)",
        doc="weight of textureness against motion in the smoothness term",
        log=True,
        # 0.01-100 x the paper's 1e4 (07b sec. 7), and its 100 sigma over sigma's range.
        ui_range=(10.0, 1e8),
        step=0.1,
    )
    candidates: int = param(
        100,
        lo=1,
        hi=1000,
        integer=True,
        eq="Sec. 5",
        doc="database fragments kept per target fragment (the MRF's labels)",
        ui_range=(5, 200),
        step=5,
    )
    max_angle: float = param(
        45.0,
        lo=0,
        hi=180,
        eq="Sec. 5, Fig. 8",
        doc="largest angle between a fragment's mean motion and the drawn direction",
        unit="deg",
        step=5,
    )
    max_speed_ratio: float = param(
        2.0,
        lo=1,
        hi=100,
        eq="Sec. 5, Fig. 8",
        doc="largest factor between a fragment's mean speed and the painted speed",
        ui_range=(1, 10),
        step=0.1,
    )
    shutter: float = param(
        8.0,
        lo=0,
        hi=256,
        eq="Sec. 6",
        doc="pseudo shutter time of the approximate mean image",
        unit="frames",
        ui_range=(0, 32),
        step=0.5,
    )
    denoise: float = param(
        0.5,
        lo=0,
        hi=100,
        eq="Sec. 6",
        doc="Gaussian blur of the approximate mean image per px/frame of motion",
        unit="px",
        ui_range=(0, 4),
        step=0.1,
    )
    cell: int = param(
        48,
        lo=8,
        hi=4096,
        integer=True,
        eq="Sec. 6",
        doc="side of the cells of the per-cell histogram matching",
        unit="px",
        ui_range=(16, 192),
        step=8,
    )
    tau: float = param(
        0.0,
        lo=0,
        hi=1,
        symbol=r"\tau",
        eq="Sec. 6",
        doc="how far the fluid's outline follows its motion (0: still matte)",
        step=0.05,
    )
    loop: int = param(
        8,
        lo=0,
        hi=128,
        integer=True,
        doc="frames cross-faded from the end into the start (0: no loop)",
        unit="frames",
        ui_range=(0, 16),
    )
    rendering: str = param(
        "flow",
        choices=RENDERINGS,
        doc="flow: the photo moves along the assigned motion (beyond the paper); "
        "paper: differences over a blurred photo (sec. 6)",
    )
    travel: float = param(
        16.0,
        lo=1,
        hi=256,
        doc="how far each advected phase carries the photo before it restarts (flow rendering)",
        unit="px",
        ui_range=(4, 48),
        step=1,
    )
    detail: float = param(
        0.5,
        lo=0,
        hi=4,
        doc="weight of the difference frames on the moving photo (flow rendering)",
        ui_range=(0, 2),
        step=0.05,
    )

    @classmethod
    def for_kind(cls, kind, **changes):
        """The defaults for a kind of scene: a moving outline (tau 0.5) for fire and smoke.

        Examples
        --------
        >>> AnimateParams.for_kind("fire").tau
        0.5
        """
        base = {"tau": 0.5} if str(kind) in ("fire", "smoke") else {}
        return cls(**{**base, **changes})
