"""The method's inputs: a flow (velocity + density per frame) and the sample pair."""

from __future__ import annotations

import contextlib
import json
import os
import threading
from dataclasses import dataclass

import numpy as np

from .._cache import cache_dir
from .._progress import Progress
from .._validation import check_array, check_int, check_npz_file, check_range, parse_json

__all__ = ["PAPER_SHAPES", "Flow", "cache_dir", "sample_flows"]

_FORMAT = "fluidnb.turbulence.Flow/1"

#: The paper's grids as (H, W): a 16 x 24 target and a 128 x 192 source (nx x ny; the
#: plume rises along the longer side), 200 frames (Watanabe et al., sec. 4).
PAPER_SHAPES = {"target": (24, 16), "source": (192, 128)}

# The sample pair's physical domain is 4 x 6 units: dx = 0.25 and dX = 0.03125 as in
# the paper's experiment.
_DOMAIN_WIDTH = 4.0


@dataclass(frozen=True, eq=False)
class Flow:
    r"""A 2-D flow sequence: velocity and smoke density per frame on one grid.

    Attributes
    ----------
    velocity : ndarray, shape (I, H, W, 2)
        Cell-centred (dy, dx) velocity of each frame in cells of this grid per frame,
        float32 (the paper's :math:`u_t(i)` or :math:`U_s(i)`).
    density : ndarray, shape (I, H, W)
        Smoke density of each frame, float32; the mask is ``density > D_th``.
    dx : float
        Grid spacing in world units (the paper's :math:`\Delta x`, :math:`\Delta X`).
        Only ratios matter: a target and a source must cover the same domain.
    """

    velocity: np.ndarray
    density: np.ndarray
    dx: float

    def __post_init__(self):
        v = check_array("velocity", self.velocity, ndim=4, dtype_kinds="iuf", min_size=0)
        if v.shape[0] == 0:
            raise ValueError(
                f"a flow needs at least one frame: velocity has 0 frames, shape {v.shape}"
            )
        if v.size == 0:
            raise ValueError(f"velocity must not be empty, got shape {v.shape}")
        if v.shape[-1] != 2:
            raise ValueError(f"velocity must have shape (I, H, W, 2) as (dy, dx), got {v.shape}")
        d = check_array("density", self.density, ndim=3, dtype_kinds="biuf")
        if d.shape != v.shape[:3]:
            raise ValueError(
                f"density must have shape (I, H, W) = {v.shape[:3]} like the velocity, "
                f"got {d.shape}"
            )
        for name, arr in (("velocity", v), ("density", d)):
            arr = np.array(arr, dtype=np.float32)  # a private, read-only copy
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "dx", check_range("dx", self.dx, 0, lo_open=True))

    @property
    def shape(self):
        """(H, W) of the grid."""
        return self.velocity.shape[1:3]

    @property
    def n_frames(self):
        """Number of frames ``I``."""
        return self.velocity.shape[0]

    def __len__(self):
        return self.n_frames

    def __repr__(self):
        h, w = self.shape
        return f"Flow({self.n_frames} frames, {h} x {w}, dx={self.dx:g})"

    def mask(self, D_th):
        """The smoke mask ``density > D_th`` (the paper's :math:`d`, :math:`D`), bool."""
        return self.density > check_range("D_th", D_th, 0)

    def frames(self, start=0, stop=None):
        """The frames ``start:stop`` as a new Flow (e.g. a short piece for a quick look)."""
        sl = slice(start, stop)
        if not len(range(*sl.indices(self.n_frames))):
            raise ValueError(
                f"frames {start}:{stop} select nothing from a flow of {self.n_frames} frames"
            )
        return Flow(self.velocity[sl], self.density[sl], self.dx)

    @classmethod
    def from_simulation(cls, simulation, dx=None):
        """A Flow from a :class:`fluidnb.fluid.Simulation` (velocity averaged to cells).

        ``dx`` defaults to ``4 / W``: every grid spans a domain 4 units wide, so two
        runs at different resolutions of the same box line up.
        """
        w = simulation.velocity.shape[2]
        dx = _DOMAIN_WIDTH / w if dx is None else dx
        return cls(simulation.centred_velocity(), simulation.density, dx)

    def save(self, path):
        """Write an ``.npz`` (arrays plus JSON metadata, no pickle). Returns the path.

        Written under a temporary name and renamed, as :meth:`fluidnb.Clip.save` does:
        a failed save leaves the file that was there before, and an OSError names
        ``path``.
        """
        from pathlib import Path

        from .._media import write_atomically

        path = os.fspath(path)
        if not path.endswith(".npz"):
            raise ValueError(f"path must end in .npz, got {path!r}")
        meta = json.dumps({"format": _FORMAT, "dx": self.dx})
        arrays = {"velocity": self.velocity, "density": self.density, "metadata": np.array(meta)}

        def write(tmp):
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **arrays)

        write_atomically(Path(path), write)
        return path

    @classmethod
    def load(cls, path, dx=None):
        """Read a Flow written by :meth:`save`, or a saved :class:`fluidnb.fluid.Simulation`.

        ``dx`` overrides the stored spacing (a Simulation stores none: see
        :meth:`from_simulation`).
        """
        path = os.fspath(path)
        check_npz_file(path, f"path {path!r} is not a saved Flow or Simulation")
        try:
            with np.load(path, allow_pickle=False) as z:
                meta = _metadata(z)
                fmt = meta.get("format")
                if fmt == _FORMAT:
                    arrays = (np.array(z["velocity"]), np.array(z["density"]), meta["dx"])
        except (OSError, KeyError, ValueError, EOFError) as exc:
            raise ValueError(f"path {path!r} is not a saved Flow or Simulation: {exc}") from None
        if fmt == _FORMAT:
            velocity, density, stored_dx = arrays
            try:
                return cls(velocity, density, stored_dx if dx is None else dx)
            except ValueError as exc:  # a Flow file, but what it holds is not usable
                raise ValueError(f"path {path!r}: {exc}") from None
        if fmt == "fluidnb.fluid.Simulation/1":
            from ..fluid import Simulation

            return cls.from_simulation(Simulation.load(path), dx)
        raise ValueError(f"path {path!r} is not a saved Flow or Simulation (format {fmt!r})")


def sample_flows(n_frames=200, *, scale=1, progress=None):
    """A target/source pair at the paper's sizes, made by :mod:`fluidnb.fluid`.

    The source is a detailed high-resolution smoke plume (192 x 128, a centred
    source, vorticity confinement); the target is an independent low-resolution
    run (24 x 16) of a differently designed scene -- its source a third of the way
    across and a side wind bending the plume -- so the search has real work to do:
    the source is an example of detail, not the same scene. Both start after a short
    warm-up. The pair is simulated on the first call (a few seconds) and cached in
    memory and in :func:`cache_dir`.

    Parameters
    ----------
    n_frames : int
        Frames of each flow (the paper uses 200).
    scale : {1, 2}
        1: the paper's grids; 2: both grids halved (12 x 8 and 96 x 64), for quick runs.
    progress : callable, optional
        ``progress(fraction, message)`` while simulating.

    Returns
    -------
    (Flow, Flow)
        ``(target, source)``; spacings 0.25 and 0.03125 at ``scale=1``.

    Examples
    --------
    >>> target, source = sample_flows(4, scale=2)
    >>> target.shape, source.shape, source.dx / target.dx
    ((12, 8), (96, 64), 0.125)
    """
    n_frames = check_int("n_frames", n_frames, 1, 2000)
    scale = check_int("scale", scale, 1, 2)
    if scale == 2 and n_frames > 400:
        raise ValueError(f"n_frames must be <= 400 at scale 2, got {n_frames}")
    return _sample_flows(n_frames, scale, Progress(progress))


_SAMPLE_VERSION = 2  # bump when the scene or the solver changes what the pair holds


def _sample_flows(n_frames, scale, progress):
    key = (n_frames, scale)
    if key in _MEMORY:
        progress(1.0, "sample flows (cached)")
        return _MEMORY[key]
    file = cache_dir() / f"turbulence-sample-v{_SAMPLE_VERSION}-s{scale}-{n_frames}.npz"
    pair = _read_pair(file)
    if pair is None:
        pair = _simulate_pair(n_frames, scale, progress)
        _write_pair(file, pair)
    progress(1.0, "sample flows ready")
    _MEMORY[key] = pair
    return pair


_MEMORY: dict = {}


def _simulate_pair(n_frames, scale, progress):
    from ..fluid import simulate, smoke_preset

    th, tw = (s // scale for s in PAPER_SHAPES["target"])
    sh, sw = (s // scale for s in PAPER_SHAPES["source"])
    steps = progress.split(0.15)
    # The target is the user's design: another source position and a side wind.
    target = smoke_preset((th, tw), source_x=0.35, wind=0.04)
    source = smoke_preset((sh, sw))
    flows = []
    for preset, part, what in ((target, steps[0], "target"), (source, steps[1], "source")):
        part(0.0, f"simulating the {what} ({preset.shape[0]} x {preset.shape[1]})")
        sim = simulate(
            preset.params,
            n_frames,
            shape=preset.shape,
            seed=0,
            warmup=20,
            progress=lambda f, m, part=part, what=what: part(f, f"simulating the {what}"),
        )
        flows.append(Flow.from_simulation(sim))
    return tuple(flows)


def _read_pair(file):
    try:
        with np.load(file, allow_pickle=False) as z:
            meta = _metadata(z)
            return tuple(
                Flow(z[f"{k}_velocity"], z[f"{k}_density"], meta[f"{k}_dx"])
                for k in ("target", "source")
            )
    except (OSError, KeyError, ValueError, EOFError):
        return None  # absent or unreadable: simulate again


def _write_pair(file, pair):
    arrays = {}
    meta = {"format": "fluidnb.turbulence.sample/1"}
    for k, flow in zip(("target", "source"), pair):
        arrays[f"{k}_velocity"] = flow.velocity
        arrays[f"{k}_density"] = flow.density
        meta[f"{k}_dx"] = flow.dx
    # A name of this process and thread, opened as every file we write is (mode 0666
    # less the umask): mkstemp's 0600 kept the cache from the other users of a shared
    # cache folder (issue 37).
    tmp = file.with_name(f".{file.stem}.partial-{os.getpid()}-{threading.get_ident()}.npz")
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "xb") as f:
            np.savez_compressed(f, metadata=np.array(json.dumps(meta)), **arrays)
        os.replace(tmp, file)
    except OSError:
        # A read-only home: the memory cache still serves this session.
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def _metadata(archive):
    """The JSON object in an archive's ``metadata`` (ValueError if it is not one)."""
    meta = parse_json(str(archive["metadata"]), "its metadata")
    if not isinstance(meta, dict):
        raise ValueError("its metadata is not a JSON object")
    return meta
