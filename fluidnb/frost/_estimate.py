r"""How long will the frost take? The mass-balance estimate of the end frame.

With the paper's :math:`\gamma = 0.005` (Amano et al., sec. 4) a region painted by hand
on a photo takes thousands of frames. The reason is a balance of vapour that can be
read off before running anything.

*Vapour in, vapour out.* Diffusion only moves vapour; the boundary ring gives as much as
it takes (Amano et al., sec. 3.3). So the total grows by :math:`\gamma` on every cell
that receives it: the ice cells, and the frontier cells whose :math:`r_t(p) > r_{th}`
(Eq. (1)). What an ice cell receives stays in it (its neighbours are all receptive, so
nothing diffuses away): that part only thickens the ice. New ice is paid for by
:math:`\gamma` on the frontier, :math:`\gamma (1 - r_{th})` per frontier cell per frame
on average, and by the starting vapour :math:`\beta` of the cells it uses up.

*Layer by layer.* A compact front around the start points freezes one ring of cells
(one hop of the lattice) after another, and while it works on a ring that ring *is* the
frontier. Freezing :math:`I` cells of :math:`N` (``coverage``, 90 %) from :math:`n_s`
start cells needs :math:`M = I - \beta (N - n_s) - n_s` of vapour beyond what the cells
hold, :math:`m = M / (I - n_s)` per new ice cell, so each ring takes

.. math:: \tau = \frac{m}{\gamma (1 - r_{th})} \quad \text{frames},

at least one (the front moves at most one cell a frame), and the run ends after
:math:`T \approx K \tau` frames, :math:`K` the (fractional) number of rings needed to
reach the coverage. :math:`T` grows with the region's size in cells -- its radius
measured in lattice spacings -- and falls as :math:`1 / \gamma`, so the
:math:`\gamma` that ends at a target :math:`T` is :math:`K m / ((1 - r_{th}) T)`.

The estimate is exact for the smallest region (a start cell and its six neighbours) and
an *upper* estimate otherwise: dendrite arms run ahead of a compact front, so the
frontier is longer than one ring and uses the vapour between the arms sooner, while a
fast supply (few frames a ring) outruns the diffusion that must bring it to the front.
:attr:`EndFrameEstimate.likely` is what runs measured: over 471 runs (ellipses, a
disc, a band, an L and a small disc of 60-5000 cells; one start point at the centre
or near the border, or three; :math:`\beta` 0.25-0.6, :math:`\gamma` 0.003-0.08,
:math:`r_{th}` 0-0.6, spacings 3-8 px) the end frame follows
:math:`T \approx 8.8\, K^{0.75} \tau^{0.70} e^{-2.2 \beta}` (a least-squares fit;
beyond the paper), and 90 % of the runs ended within 0.74-1.3 times it
(:attr:`~EndFrameEstimate.low`, :attr:`~EndFrameEstimate.high`; 41 % within 10 %).
So the estimate says how long a run will take, and how surely, instantly -- enough to
warn that a run will take thousands of frames; the run's own randomness and the
region's shape leave the rest to a run (:func:`gamma_for_target` corrects its
:math:`\gamma` with a run or two at the target's length, which are cheap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import check_int
from ._reiter import _check_lattice, _check_params, _start_cells, grow

# The measured end frame: T ~ exp(c0) K^c1 tau^c2 exp(c3 beta) (least squares over the
# 471 runs the module docstring describes; fitted on 300, the other 171 ended at
# 0.74-1.29 x it, 5-95 %), and the band 90 % of all runs fell in.
_FIT = (2.1795, 0.7463, 0.6995, -2.1827)
_BAND = (0.74, 1.3)

__all__ = ["EndFrameEstimate", "GammaFit", "estimate_end_frame", "gamma_for_target"]


@dataclass(frozen=True)
class EndFrameEstimate:
    r"""The mass-balance estimate of a run's end frame (see the module docstring).

    Attributes
    ----------
    frames : float
        Estimated :math:`T_{sim}`; ``math.inf`` if the run cannot end (no vapour comes
        in, or the start points cannot reach enough of the region).
    fastest : int
        :math:`K_{min}`: no :math:`\beta < 1` ends sooner, because ice spreads at most
        one cell a frame and the coverage lies this many hops from the start points.
    rings : float
        :math:`K`, the rings of cells (hops) the front must freeze, the last one in part.
    need : float
        :math:`m`, vapour to bring to each new ice cell.
    supply : float
        :math:`\gamma (1 - r_{th})`, vapour a frontier cell receives per frame.
    n_cells, n_ice : int
        :math:`N` and the :math:`I` cells that must freeze.
    gamma : float
        The :math:`\gamma` of the estimate.
    rth : float
        The :math:`r_{th}` of the estimate.
    beta : float
        The :math:`\beta` of the estimate.
    """

    frames: float
    fastest: int
    rings: float
    need: float
    supply: float
    n_cells: int
    n_ice: int
    gamma: float
    rth: float
    beta: float = 0.0

    @property
    def likely(self):
        r"""The likely end frame: :math:`8.8\, K^{0.75} \tau^{0.70} e^{-2.2 \beta}`.

        Fitted to measured runs (see the module docstring; beyond the paper): 90 % of
        them ended between :attr:`low` and :attr:`high`. Never below
        :attr:`fastest`; the mass balance itself where it is exact (one ring) or
        the run cannot end.
        """
        if math.isinf(self.frames) or self.rings <= 1 or self.need <= 0:
            return self.frames
        c0, c1, c2, c3 = _FIT
        fit = math.exp(c0 + c1 * math.log(self.rings) + c2 * math.log(self.ring_frames))
        return max(float(self.fastest), fit * math.exp(c3 * self.beta))

    @property
    def low(self):
        """The end frame 95 % of the measured runs reached (0.74 x :attr:`likely`)."""
        if math.isinf(self.frames) or self.rings <= 1 or self.need <= 0:
            return self.frames
        return max(float(self.fastest), _BAND[0] * self.likely)

    @property
    def high(self):
        """The end frame 95 % of the measured runs ended by (1.3 x :attr:`likely`)."""
        if math.isinf(self.frames) or self.rings <= 1 or self.need <= 0:
            return self.frames
        return _BAND[1] * self.likely

    @property
    def ring_frames(self):
        r""":math:`\tau`, frames per ring of cells (at least 1)."""
        if self.need <= 0:
            return 1.0
        return math.inf if self.supply == 0 else max(self.need / self.supply, 1.0)

    def gamma_for(self, target):
        r"""The :math:`\gamma` at which this estimate ends at ``target`` frames.

        Raises
        ------
        ValueError
            If ``target`` is below :attr:`fastest` (no :math:`\gamma` can make the
            front faster than one cell a frame).
        """
        target = check_int("target", target, 1)
        if target < self.fastest:
            raise ValueError(
                f"target must be >= {self.fastest} frames for this region and these start "
                f"points, got {target}: ice spreads at most one cell a frame and "
                f"{self.n_ice} of the {self.n_cells} cells lie up to {self.fastest} cells "
                "away; choose a later target, add start points or use a larger spacing"
            )
        if self.need <= 0 or self.rth >= 1:
            return math.nan  # beta alone freezes it (or no frontier cell ever gets gamma)
        return self.rings * self.need / ((1.0 - self.rth) * target)

    def likely_gamma_for(self, target):
        r"""The :math:`\gamma` at which :attr:`likely` is ``target`` frames.

        By the fit, :math:`T \propto \tau^{0.70} \propto \gamma^{-0.70}` (while a ring
        takes more than a frame): :math:`\gamma' = \gamma\,(T / \text{target})^{1/0.70}`.
        A later target asks for a smaller :math:`\gamma`. NaN where :math:`\gamma` does
        not set the length (see :meth:`gamma_for`).
        """
        if math.isnan(self.gamma_for(target)):
            return math.nan
        if math.isinf(self.likely) or self.ring_frames <= 1:
            return self.gamma_for(target)
        return min(self.gamma * (self.likely / target) ** (1.0 / _FIT[2]), 1.0)

    def __str__(self):
        if math.isinf(self.frames):
            return "never ends (no vapour reaches enough of the region)"
        return (
            f"ends near frame {self.likely:.0f} (likely {self.low:.0f}-{self.high:.0f}; mass "
            f"balance: {self.rings:.1f} rings of cells x {self.ring_frames:.0f} frames each "
            f"at gamma = {self.gamma:g})"
        )


def estimate_end_frame(lattice, starts, params=None, *, beta=None):
    r"""Estimate the end frame :math:`T_{sim}` from the balance of vapour, without a run.

    Parameters
    ----------
    lattice : HexLattice
        The region's lattice.
    starts : array_like
        Start cells or (n, 2) pixel points, as for :func:`grow`.
    params : FrostParams, optional
        :math:`\beta, \gamma, r_{th}` and the ``coverage`` that ends the run.
    beta : float, optional
        Overrides ``params.beta``.

    Returns
    -------
    EndFrameEstimate
        ``frames`` is the estimate; ``fastest`` the hard lower bound.

    Examples
    --------
    >>> from fluidnb.frost import FrostParams, HexLattice
    >>> tiny = HexLattice.hexagon(1)  # a start cell and its six neighbours
    >>> est = estimate_end_frame(tiny, [tiny.center_cell()], FrostParams(beta=0.25))
    >>> round(est.frames)  # exactly (1 - beta) / gamma here
    150
    >>> grow(tiny, [tiny.center_cell()], FrostParams(beta=0.25)).end_frame
    150
    """
    lattice = _check_lattice(lattice)
    params = _check_params(params)
    cells = _start_cells(lattice, starts)
    beta = params.beta if beta is None else params.replace(beta=beta).beta
    n = lattice.n_cells
    n_s = len(cells)
    n_ice = max(math.ceil(params.coverage * n - 1e-9), n_s)
    hops = lattice.hops(cells)
    layers = np.bincount(hops[hops >= 0])
    reach = np.cumsum(layers)
    supply = params.gamma * (1.0 - params.rth)
    common = dict(
        n_cells=n, n_ice=n_ice, gamma=params.gamma, rth=params.rth, supply=supply, beta=beta
    )
    if reach[-1] < n_ice:
        # The region is in pieces and the start points are not in enough of them.
        return EndFrameEstimate(frames=math.inf, fastest=-1, rings=math.inf, need=1.0, **common)
    k = int(np.searchsorted(reach, n_ice))  # the first ring with enough cells
    rings = (k - 1) + (n_ice - reach[k - 1]) / layers[k] if k > 0 else 0.0
    need = (n_ice - beta * (n - n_s) - n_s) / max(n_ice - n_s, 1)
    est = EndFrameEstimate(frames=0.0, fastest=k, rings=rings, need=need, **common)
    frames = max(float(k), rings * est.ring_frames) if k > 0 else 0.0
    return EndFrameEstimate(frames=frames, fastest=k, rings=rings, need=need, **common)


@dataclass(frozen=True)
class GammaFit:
    r"""A :math:`\gamma` that ends the run near a target frame (:func:`gamma_for_target`).

    Attributes
    ----------
    gamma : float
        The :math:`\gamma` to use.
    end_frame : int or None
        :math:`T_{sim}` at :attr:`gamma` (``None`` without runs, ``refine=0``).
    target : int
        :math:`T`.
    estimate : EndFrameEstimate
        The mass-balance estimate at the parameters' own :math:`\gamma`.
    mass_balance_gamma : float
        The :math:`\gamma` the mass balance alone gives for the target.
    steps : tuple of (float, int or None)
        Every run: (:math:`\gamma`, :math:`T_{sim}`).
    seed : int
        The random seed of the runs.
    """

    gamma: float
    end_frame: int | None
    target: int
    estimate: EndFrameEstimate
    mass_balance_gamma: float
    steps: tuple
    seed: int


def gamma_for_target(lattice, starts, target=None, params=None, *, refine=4, seed=0):
    r"""The :math:`\gamma` at which the frost ends near ``target`` frames.

    Starts from the mass-balance value (:func:`estimate_end_frame`) and corrects it
    with up to ``refine`` runs, modelling :math:`T_{sim} \propto \gamma^{-p}`
    (:math:`p = 1` by the mass balance at first, then measured from the last two runs):
    :math:`\gamma \leftarrow \gamma \, (T_{sim}(\gamma) / T)^{1/p}`. Each run lasts about the
    target's length, so this is quick even where the paper's :math:`\gamma` would take
    thousands of frames. :math:`\beta` stays as it is (fine-tune it with
    :func:`optimise_beta` afterwards, as the paper does).

    Parameters
    ----------
    lattice : HexLattice
        The region's lattice.
    starts : array_like
        Start cells or (n, 2) pixel points.
    target : int, optional
        :math:`T` (default ``params.target``).
    params : FrostParams, optional
        The other parameters.
    refine : int
        Most runs for the correction (0: the mass balance alone).
    seed : None, int or numpy.random.Generator
        Random seed of the runs (use the one you will render with).

    Returns
    -------
    GammaFit

    Raises
    ------
    ValueError
        If the target is below the fastest possible end frame
        (:attr:`EndFrameEstimate.fastest`), or no :math:`\gamma \le 1` reaches it.

    Examples
    --------
    >>> from fluidnb.frost import FrostParams, HexLattice
    >>> lat = HexLattice.hexagon(20)
    >>> fit = gamma_for_target(lat, [lat.center_cell()], 130, FrostParams())
    >>> round(fit.estimate.frames)  # the paper's gamma = 0.005: far too slow
    2316
    >>> abs(fit.end_frame - 130) <= FrostParams().tolerance
    True
    """
    from .._random import resolve_seed

    lattice = _check_lattice(lattice)
    params = _check_params(params)
    cells = _start_cells(lattice, starts)
    target = params.target if target is None else target
    target = check_int("target", target, 1)
    refine = check_int("refine", refine, 0, 20)
    seed = resolve_seed(seed)
    est = estimate_end_frame(lattice, cells, params)
    if est.fastest < 0:
        raise ValueError(
            "the start points cannot reach enough of the region (it is painted in pieces): "
            "add a start point in every piece"
        )
    gamma0 = est.gamma_for(target)
    if math.isnan(gamma0):
        raise ValueError(
            f"gamma cannot set the length here: with beta = {params.beta:g} the region "
            f"freezes from its own vapour (or rth = {params.rth:g} gives the frontier none); "
            "lower beta or rth"
        )
    # Start from the likely end frame's gamma (the fit): fewer correcting runs.
    gamma = est.likely_gamma_for(target)
    steps = []
    end = None
    limit = min(max(params.max_frames, 4 * target), 100_000)
    for _ in range(refine):
        p = params.replace(gamma=gamma, max_frames=limit, target=min(params.target, limit))
        end = grow(lattice, cells, p, seed=seed).end_frame
        steps.append((gamma, end))
        if end is not None and abs(end - target) <= params.tolerance:
            break
        if end is None:
            new = min(2.0 * gamma, 1.0)
        else:
            # T_sim ~ gamma^-p: p = 1 by the mass balance, then measured from the last
            # two runs (diffusion does not speed up with gamma, so p < 1 in practice).
            power = 1.0
            prev = [st for st in steps[:-1] if st[1] is not None]
            if prev and prev[-1][1] != end and prev[-1][0] != gamma:
                measured = math.log(prev[-1][1] / end) / math.log(gamma / prev[-1][0])
                power = min(max(measured, 0.3), 2.0)
            new = min(gamma * (end / target) ** (1.0 / power), 1.0)
            # T_sim falls in steps as gamma grows: once two runs bracket the target,
            # halve the bracket (geometrically) if the model's guess leaves it.
            slow = [g for g, e in steps if e is None or e > target]
            fast = [g for g, e in steps if e is not None and e < target]
            if slow and fast:
                lo, hi = max(slow), min(fast)
                if not lo < new < hi:
                    new = math.sqrt(lo * hi)
        if new == gamma:  # pinned at gamma = 1
            break
        gamma = new
    if steps and gamma != steps[-1][0]:
        gamma, end = min(steps, key=lambda s: math.inf if s[1] is None else abs(s[1] - target))
    if gamma >= 1.0 and (end is None or end > target + params.tolerance):
        raise ValueError(
            f"target {target} frames cannot be reached with gamma <= 1 at beta = "
            f"{params.beta:g}: raise beta or choose a later target"
        )
    return GammaFit(
        gamma=float(gamma),
        end_frame=end,
        target=target,
        estimate=est,
        mass_balance_gamma=float(gamma0),
        steps=tuple(steps),
        seed=seed,
    )
