"""Run the solver for many frames, keep every frame, save and load (npz + JSON)."""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._clip import Clip
from .._media import write_atomically
from .._progress import Progress
from .._random import resolve_seed
from .._random import rng as _as_rng
from .._validation import check_choice, check_int, check_range, parse_json
from ._colour import temperature_to_rgb
from ._forces import _check_params
from ._grid import _centres
from ._params import FluidParams
from ._solver import FluidState, _check_shape, step

__all__ = ["Preset", "Simulation", "flame_preset", "simulate", "smoke_preset"]

_FORMAT = "fluidnb.fluid.Simulation/1"


#: Bytes a run keeps per cell and frame: velocity (2), temperature, density, float32.
_BYTES_PER_CELL_FRAME = 16
#: Bytes a step works with per cell (float64 state, scratch grids, transforms).
_BYTES_PER_CELL_STEP = 320

#: The longest warm-up, in frames: a flame from still air is developed after about
#: one rise time (90 frames on 128 rows); even the largest grid, 4096 rows, needs
#: about 3000. The kept frames are bounded by memory instead.
MAX_WARMUP = 10_000


def _available_bytes():
    """Memory the system can still give this process (Linux: MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_memory(n_frames, shape):
    """Refuse a run whose frames cannot fit in memory, and say what would fit."""
    avail = _available_bytes()
    if avail is None:
        return
    h, w = shape
    cells = h * w
    need = cells * (n_frames * _BYTES_PER_CELL_FRAME + _BYTES_PER_CELL_STEP)
    if need <= 0.8 * avail:
        return
    budget = 0.8 * avail
    gib = 2.0**30
    frames_fit = int((budget / cells - _BYTES_PER_CELL_STEP) // _BYTES_PER_CELL_FRAME)
    scale = (budget / need) ** 0.5
    fit_shape = (max(int(h * scale), 2), max(int(w * scale), 2))
    raise ValueError(
        f"shape {h}x{w} with n_frames={n_frames} needs about {need / gib:.1f} GiB "
        f"({_BYTES_PER_CELL_FRAME} bytes a cell a frame are kept) but "
        f"{avail / gib:.1f} GiB is available: at this shape at most "
        f"{max(frames_fit, 0)} frames fit; for {n_frames} frames, a grid of about "
        f"{fit_shape[0]}x{fit_shape[1]}"
    )


@dataclass(frozen=True, eq=False)
class Simulation:
    """Every frame of a run of :func:`simulate`.

    Attributes
    ----------
    velocity : ndarray, shape (N, H, W, 2)
        Staggered (dy, dx) velocity of each frame, px/frame, float32 (see
        :mod:`fluidnb.fluid` for the layout; :meth:`centred_velocity` averages it to
        the pixels).
    temperature : ndarray, shape (N, H, W)
        Temperature of each frame, float32.
    density : ndarray, shape (N, H, W)
        Smoke density of each frame, float32.
    params : FluidParams
        The parameters of the run.
    seed : int or None
        The seed the run actually used (:func:`fluidnb.resolve_seed`): the same
        parameters and seed remake it exactly. None only for hand-made instances.
    substeps : int
        Solver steps per frame (each of ``params.dt / substeps``).
    timings : dict
        Stage -> seconds.
    """

    velocity: np.ndarray
    temperature: np.ndarray
    density: np.ndarray
    params: FluidParams
    seed: int | None = None
    substeps: int = 1
    timings: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in ("velocity", "temperature", "density"):
            a = np.asarray(getattr(self, name)).view()  # read-only view; the caller's
            a.setflags(write=False)  # own array keeps its flags
            object.__setattr__(self, name, a)

    @property
    def shape(self):
        """(H, W) of the grid."""
        return tuple(self.temperature.shape[1:])

    @property
    def n_frames(self):
        """Number of frames N."""
        return self.temperature.shape[0]

    def __len__(self):
        return self.n_frames

    def __repr__(self):
        h, w = self.shape
        return f"Simulation({self.n_frames} frames, {h}x{w}, seed={self.seed})"

    def state(self, k):
        """Frame ``k`` as a :class:`FluidState` (float32 data; to resume a run).

        Its ``frame`` counts solver steps: ``(k + 1) * substeps``.
        """
        k = check_int("k", k, -self.n_frames, self.n_frames - 1) % self.n_frames
        return FluidState(
            self.velocity[k],
            self.temperature[k],
            self.density[k],
            frame=(k + 1) * self.substeps,
        )

    def centred_velocity(self, k=None):
        """The velocity averaged to cell centres, (H, W, 2) for frame ``k`` or (N, H, W, 2)."""
        if k is not None:
            k = check_int("k", k, -self.n_frames, self.n_frames - 1)
            return _centres(np.asarray(self.velocity[k], dtype=np.float64))
        return np.stack([_centres(np.asarray(v, dtype=np.float64)) for v in self.velocity])

    def to_clip(self, field="temperature", *, fps=24.0, vmax=None):
        """The frames as a :class:`fluidnb.Clip` for display or export.

        Parameters
        ----------
        field : {"temperature", "density"}
            Temperature is colour-mapped with :func:`temperature_to_rgb` (ambient
            black, ``vmax`` near-white); density is grey, 0 black, ``vmax`` white.
        fps : float
            Frame rate.
        vmax : float, optional
            The value drawn at full brightness (default: ``source_T`` for
            temperature, the clip's 99.5th percentile for density).
        """
        check_choice("field", field, ("temperature", "density"))
        if field == "temperature":
            top = self.params.source_T if vmax is None else check_range("vmax", vmax)
            if top <= self.params.T_amb:
                top = self.params.T_amb + 1.0
            frames = temperature_to_rgb(self.temperature, T_amb=self.params.T_amb, T_max=top)
        else:
            top = float(np.percentile(self.density, 99.5)) if vmax is None else vmax
            top = check_range("vmax", top if top > 0 else 1.0, 0, lo_open=True)
            frames = np.clip(self.density / top, 0.0, 1.0).astype(np.float32)
        meta = {
            "method": "fluid",
            "field": field,
            "params": self.params.to_dict(),
            "seed": self.seed,
            "timings": dict(self.timings),
        }
        return Clip(frames, fps=fps, metadata=meta)

    def save(self, path):
        """Write an ``.npz`` (arrays plus JSON metadata; no pickle). Returns the path."""
        path = os.fspath(path)
        if not path.endswith(".npz"):
            raise ValueError(f"path must end in .npz, got {path!r}")
        meta = {
            "format": _FORMAT,
            "params": self.params.to_dict(),
            "seed": self.seed,
            "substeps": self.substeps,
            "timings": self.timings,
        }
        arrays = {
            "velocity": self.velocity,
            "temperature": self.temperature,
            "density": self.density,
            "metadata": np.array(json.dumps(meta)),
        }
        # Through a temporary file: a failed write keeps the file that was there.
        write_atomically(Path(path), lambda tmp: np.savez(tmp, **arrays))
        return path

    @classmethod
    def load(cls, path):
        """Read a file written by :meth:`save`."""
        path = os.fspath(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = parse_json(str(z["metadata"]), "its metadata")
                if not isinstance(meta, dict):
                    raise ValueError("its metadata is not a JSON object")
                arrays = {k: np.array(z[k]) for k in ("velocity", "temperature", "density")}
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"path {path!r} is not a saved Simulation: {exc}") from None
        if meta.get("format") != _FORMAT:
            raise ValueError(
                f"path {path!r} is not a saved Simulation (format {meta.get('format')!r})"
            )
        return cls(
            **arrays,
            params=FluidParams.from_dict(meta["params"]),
            seed=meta["seed"],
            substeps=meta["substeps"],
            timings=meta.get("timings", {}),
        )


def simulate(
    params,
    n_frames,
    *,
    shape=(128, 128),
    seed=None,
    progress=None,
    substeps=1,
    initial=None,
    warmup=0,
):
    """Run :func:`step` for ``n_frames`` frames from still air and keep every frame.

    Parameters
    ----------
    params : FluidParams
        The parameters; each frame spans ``params.dt``.
    n_frames : int
        Number of frames to produce (>= 1).
    shape : tuple of int
        (H, W) of the grid; the paper uses 128 x 128.
    seed : None, int or numpy.random.Generator
        Randomness of the source flicker; same seed, same frames. The int actually
        used (drawn when None or a Generator is given) is recorded as
        :attr:`Simulation.seed`.
    progress : callable, optional
        ``progress(fraction, message)``, called once per frame; raise
        :class:`fluidnb.Cancelled` from it to stop.
    substeps : int
        Solver steps per frame, each of ``params.dt / substeps`` (smaller steps,
        less numerical dissipation).
    initial : FluidState, optional
        Start from this state instead of still air (its shape wins over ``shape``).
    warmup : int
        Frames simulated first and not kept, so the clip starts on a developed flow
        (a flame from still air begins as a small rising puff); at most
        ``MAX_WARMUP`` (10000).

    Returns
    -------
    Simulation
        Frames 1 ... N (the state after each frame), float32.

    Raises
    ------
    ValueError
        For a bad ``params``, ``n_frames``, ``shape``, ``substeps``, ``warmup`` or
        ``initial``, or when the frames would not fit in the memory available (the message says
        how many frames, or what grid, would).

    Examples
    --------
    >>> sim = simulate(FluidParams(), 4, shape=(24, 16), seed=0)
    >>> sim.temperature.shape, sim.velocity.shape
    ((4, 24, 16), (4, 24, 16, 2))
    """
    params = _check_params(params)
    n_frames = check_int("n_frames", n_frames, 1)
    substeps = check_int("substeps", substeps, 1, 1000)
    warmup = check_int("warmup", warmup, 0, MAX_WARMUP)
    if initial is not None and not isinstance(initial, FluidState):
        raise ValueError(f"initial must be a FluidState or None, got {type(initial).__name__}")
    shape = _check_shape(shape) if initial is None else initial.shape
    _check_memory(n_frames, shape)  # before anything large is allocated
    state = FluidState.zeros(shape, params) if initial is None else initial
    report = Progress(progress)
    seed = resolve_seed(seed)
    gen = _as_rng(seed)
    sub = params if substeps == 1 else params.replace(dt=params.dt / substeps)
    h, w = state.shape
    vel = np.empty((n_frames, h, w, 2), dtype=np.float32)
    temp = np.empty((n_frames, h, w), dtype=np.float32)
    dens = np.empty((n_frames, h, w), dtype=np.float32)
    report(0.0, "simulating")
    t0 = time.perf_counter()
    total = warmup + n_frames
    for k in range(-warmup, n_frames):
        for _ in range(substeps):
            state = step(state, sub, rng=gen)
        if k >= 0:
            vel[k] = state.velocity
            temp[k] = state.temperature
            dens[k] = state.density
        done = k + warmup + 1
        report(done / total, f"warm-up {done}/{warmup}" if k < 0 else f"frame {k + 1}/{n_frames}")
    elapsed = time.perf_counter() - t0
    return Simulation(
        vel,
        temp,
        dens,
        params,
        seed=seed,
        substeps=substeps,
        timings={"simulate": elapsed, "steps_per_second": total * substeps / max(elapsed, 1e-9)},
    )


@dataclass(frozen=True)
class Preset:
    """A ready-made set-up: parameters, grid shape and a suggested length.

    Attributes
    ----------
    name : str
        ``"flame"`` or ``"smoke"``.
    params : FluidParams
        The parameters.
    shape : tuple of int
        (H, W).
    n_frames : int
        A length that shows the flow developed.
    substeps : int
        Solver steps per frame.
    warmup : int
        Frames to simulate before keeping any, at this preset's grid height (scale it
        with the height on another grid: see :meth:`warmup_for`).
    """

    name: str
    params: FluidParams
    shape: tuple
    n_frames: int
    substeps: int = 1
    warmup: int = 0

    def warmup_for(self, shape):
        """The warm-up in frames for a grid of ``shape`` (rise time grows with height)."""
        return int(round(self.warmup * shape[0] / self.shape[0]))

    def simulate(self, n_frames=None, *, seed=None, progress=None):
        """Run :func:`simulate` with this preset (``n_frames`` defaults to the preset's)."""
        return simulate(
            self.params,
            self.n_frames if n_frames is None else n_frames,
            shape=self.shape,
            seed=seed,
            progress=progress,
            substeps=self.substeps,
            warmup=self.warmup,
        )


def flame_preset(**changes):
    """A 2-D flame on the paper's 128 x 128 grid (section 3.1).

    Open top, a flickering heat source at the bottom centre, buoyancy, vorticity
    confinement and radiative cooling. The paper gives no values; these were chosen
    by eye. Keyword arguments change parameters (``flame_preset(epsilon=0)``).

    Returns
    -------
    Preset

    Examples
    --------
    >>> flame_preset().shape
    (128, 128)
    """
    # From still air the flame starts as a small rising puff and reaches the top of the
    # grid after about 50 frames and its cap clears after about 90: the warm-up makes
    # clips start on a burning flame.
    return Preset("flame", FluidParams().replace(**changes), (128, 128), 120, warmup=90)


def smoke_preset(shape=(128, 192), *, source_x=0.5, wind=0.0, **changes):
    """A rising smoke plume in a closed box, for the turbulence method's flows.

    The buoyancy and vorticity confinement are scaled with the grid height (relative to
    128), so a coarse (16 x 24) and a fine (128 x 192) run look alike at their own
    resolution. Two runs can be made to differ by ``source_x`` and ``wind``.

    Parameters
    ----------
    shape : tuple of int
        (H, W); (16, 24) and (128, 192) are the intended sizes.
    source_x : float
        Horizontal position of the source, fraction of the width.
    wind : float
        Side wind on the hot gas (px/frame^2 at 128 rows, scaled like buoyancy).
    **changes
        Any other :class:`FluidParams` field.

    Returns
    -------
    Preset

    Examples
    --------
    >>> p = smoke_preset((16, 24))
    >>> p.shape, p.params.boundary
    ((16, 24), 'closed')
    """
    h, w = _check_shape(shape)
    scale = h / 128
    source_x = check_range("source_x", source_x, 0, 1)
    wind = check_range("wind", wind)
    base = {
        "kappa_b": 0.08 * scale,
        "epsilon": 0.2 * scale,
        "C_r": 0.002,
        "source_x": source_x,
        "source_y": 0.9,
        "source_radius": 0.06,
        "source_T": 1.0,
        "source_flicker": 0.0,
        "density_rate": 0.2,
        "wind": wind * scale,
        "boundary": "closed",
    }
    base.update(changes)
    return Preset("smoke", FluidParams(**base), (h, w), 150)
