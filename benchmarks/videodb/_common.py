"""What the video-database benchmark's parts share: the run, the photos, the paper's figures.

- :class:`Context`: the run's options, its results (written to ``--json``), the starter
  databases, the paper-sized store once opened and the assignments the solver part
  compares solvers on;
- the targets: the bundled stream, clouds and fire photos with their mattes
  (:data:`PHOTOS`: one per starter database) and :func:`kind_assignments`;
- :func:`output_motion`: the motion of a rendered clip as measured by the library's
  own optical flow (OpenCV DIS, :func:`fluidnb.videodb.database.optical_flow`);
- :class:`StageClock`: the build's stages timed from its progress messages;
- the paper's figures: 240,000 fragments, half an hour each for the assignment and
  the rendering (Okabe et al., sec. 7).
"""

from __future__ import annotations

import os

import numpy as np
from _report import now

KINDS = ("water", "smoke", "fire")
#: The paper's water database: ~240,000 fragments (151 videos).
PAPER_FRAGMENTS = 240_000
#: The synthetic store's size in quick mode.
QUICK_FRAGMENTS = 24_000
#: The paper's first animation: half an hour of assignment, half an hour of rendering.
PAPER_ASSIGN_S = 30 * 60
PAPER_RENDER_S = 30 * 60
DEFAULTS = "defaults (paper: lambda 0.01, sigma 100, rho 100 sigma)"


def cache_folder():
    """The folder the starter databases and the synthetic store are cached in."""
    from fluidnb.videodb import starter_path

    return starter_path("water").parent


#: build_database's progress messages that end its stages.
STAGE_MARKS = {
    "clips read": "ingest",
    "fragments done": "fragments",
    "codebook ready": "codebook",
    "database ready": "words",
}


class StageClock:
    """A progress callable noting when each of build_database's stages ends."""

    MARKS = STAGE_MARKS

    def __init__(self):
        self.start = now()
        self.ends = {}

    def __call__(self, fraction, message=""):
        stage = self.MARKS.get(message)
        if stage and stage not in self.ends:
            self.ends[stage] = now() - self.start

    def durations(self):
        out, last = {}, 0.0
        for stage in self.MARKS.values():
            end = self.ends.get(stage)
            out[stage] = None if end is None else end - last
            last = end if end is not None else last
        return out


class Context:
    """The run's options and results, and what its parts share."""

    def __init__(self, args):
        self.quick = args.quick
        self.rounds = args.rounds
        self.results = {}
        self.assignments = {}  # label -> Assignment (for the solver part)
        self.paper_db = None
        self.peers = os.environ.get("FLUIDNB_PEERS_PYTHON")

    def starter(self, kind):
        from fluidnb.videodb import starter_database

        return starter_database(kind, quick=self.quick)


def stream_target(shape=None):
    """The "stream" photo (optionally resized to (H, W)) and its hand-drawn water matte."""
    from fluidnb.data import region, sample

    return sample("stream", size=shape, mode="rgb"), region("stream", size=shape)


def clouds_target():
    """The "clouds" photo and its hand-drawn cloud matte."""
    from fluidnb.data import region, sample

    return sample("clouds", mode="rgb"), region("clouds")


def fire_target():
    """The bundled fire cut-out and its alpha."""
    from fluidnb.data import sample

    img, alpha = sample("fire", mode="rgb", return_alpha=True)
    return img, alpha


PHOTOS = {
    "water": ("stream + its drawn water region", stream_target),
    "smoke": ("clouds + its drawn cloud region", clouds_target),
    "fire": ("fire + its alpha", fire_target),
}


def kind_assignments(ctx):
    """Each starter database's photo (:data:`PHOTOS`) assigned with the defaults (kept)."""
    from fluidnb.videodb import assign

    for kind in KINDS:
        label = f"findings: {kind} ({PHOTOS[kind][0]})"
        if label not in ctx.assignments:
            img, matte = PHOTOS[kind][1]()
            ctx.assignments[label] = assign(img, matte, ctx.starter(kind))
    return {k: v for k, v in ctx.assignments.items() if k.startswith("findings")}


def output_motion(frames, mask):
    """Mean (dy, dx) px/frame of a clip between consecutive frames, over ``mask``.

    The frames made grey (:func:`fluidnb.as_image`), their flow by the library's own
    :func:`~fluidnb.videodb.database.optical_flow` (OpenCV DIS, preset MEDIUM), each
    pair's flow averaged over the mask, then over the pairs.
    """
    from fluidnb import as_image
    from fluidnb.videodb.database import optical_flow

    grey = np.stack([as_image(f, mode="grey") for f in frames])
    flows = optical_flow(grey, backend="dis")
    return np.mean([f[mask].mean(axis=0) for f in flows], axis=0)
