"""Checks for ``00_overview.ipynb``: why repeated semi-Lagrangian advection blurs.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        why advection blurs, and how much contrast one sub-pixel step keeps
============  =================================================================
"""

import numpy as np

from ._core import Choice, Number, Parts, Question

__all__ = ["q1"]


def _stripes_left():
    """The contrast left of column stripes after one quarter-pixel advection.

    Stripes 0, 1, 0, 1, ... advected once by the uniform velocity (0, 0.25) px/frame,
    their max - min away from the edges: the notebook's route.
    """
    from fluidnb import fields  # the library, imported when the check is first called

    stripes = np.tile(np.array([0.0, 1.0], np.float32), (16, 8))
    velocity = np.zeros((16, 16, 2), np.float32)
    velocity[..., 1] = 0.25
    inner = fields.advect(stripes, velocity)[:, 2:-2]
    return float(inner.max() - inner.min())


q1 = Question(
    "q1",
    "Why does repeated advection blur the image (`why`)? And advect column stripes "
    "0, 1, 0, 1, ... once by the uniform velocity (0, 0.25) px/frame: what fraction of "
    "their contrast (max - min, away from the edges) is left (`left`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "a departure point between pixels is read by bilinear interpolation, a "
                "weighted mean of its neighbours: every step is a small low-pass filter, "
                "and the steps add up",
                "b": "rounding errors of float32 accumulate",
                "c": "the swirl's velocity is not divergence-free",
            },
            why={
                "b": "rounding errors are near 1e-7 a step; the blur is visible after a few.",
                "c": "a constant image stays constant under any velocity: nothing is "
                "compressed or spread by the interpolation's weights, which sum to 1.",
            },
        ),
        left=Number(_stripes_left, rtol=0.02, atol=0.01),
    ),
    hints=[
        "Trace a pixel back by a quarter pixel: which two pixels does bilinear "
        "interpolation mix, and with which weights?",
        "In code: `stripes = np.tile(np.array([0.0, 1.0], np.float32), (16, 8))`, a "
        "velocity `np.zeros((16, 16, 2))` with `[..., 1] = 0.25`, then `fields.advect`.",
    ],
    solution="""
    Each step reads the image at $\\mathbf{x} - \\Delta t\\,\\mathbf{u}$, usually between
    pixels, and bilinear interpolation returns a weighted mean of the four neighbours:
    a small blur. Constants and zero velocity pass unchanged (the weights sum to 1, and
    an integer shift reads pixels exactly), but any sub-pixel shift averages. A quarter
    pixel mixes each pixel with its neighbour as $0.75 \\cdot$ itself $+ 0.25 \\cdot$
    neighbour: stripes 0, 1 become 0.25, 0.75, so **half** the contrast is left after one
    step (a shift of a whole pixel keeps all of it). This numerical diffusion is why
    Stable Fluids (lesson 04) looks smoother than real smoke, and why the fire and
    turbulence methods re-synthesise detail instead of advecting it for ever.
    """,
    right={"why": "a", "left": 0.5},
    wrong={"why": "b", "left": 1.0},
)
