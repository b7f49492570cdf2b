"""Lesson 08 (``08_scene.ipynb``): one photo, all methods -- the questions' checks.

The expected values are computed by :mod:`fluidnb.scene` itself (its compositing and
its timeline) on small made-up layers, so a check follows the library.
"""

import numpy as np

from ._core import Choice, Number, Question

__all__ = ["ex1", "ex2", "q1", "q2", "q3", "q4", "q5"]


def _one_pixel(blend, under, colour, alpha):
    """One pixel, one layer over ``under``: what :func:`fluidnb.scene.composite` gives."""
    from fluidnb import Clip
    from fluidnb.scene import LayerClip, composite

    photo = np.full((1, 1, 3), under, np.float32)
    c = np.full((1, 1, 1, 3), colour, np.float32)
    a = np.full((1, 1, 1), alpha, np.float32)
    layer = LayerClip(c, a, 24.0, True, Clip(c, fps=24.0))
    return float(composite(photo, [layer], [blend], [np.zeros(1, int)], 0)[0, 0, 0])


def _frame_shown():
    """Scene frame 30 at 24 fps of a 16-frame loop at 8 fps (q4)."""
    from fluidnb import Clip
    from fluidnb.scene import LayerClip, frame_index

    c = np.zeros((16, 1, 1, 3), np.float32)
    layer = LayerClip(c, np.ones((1, 1), np.float32), 8.0, True, Clip(c, fps=8.0))
    return int(frame_index(30, 24.0, layer))


q1 = Question(
    "q1",
    "At the feathered edge of the water the weight is $a = 0.25$. The photo there is 0.8 "
    "(grey), the water layer's picture 0.2. What does the scene show (`replace`)?",
    Number(lambda: _one_pixel("replace", 0.8, 0.2, 0.25), atol=0.005),
    hints=["$O = (1 - a)\\,O_{k-1} + a\\,C$: a weighted average of the two."],
    solution="""
    $O = (1 - 0.25) \\cdot 0.8 + 0.25 \\cdot 0.2 = 0.6 + 0.05 =$ **0.65**: a quarter of
    the way from the photo to the water's picture.
    """,
    right=(0.65,),
    wrong=(0.2,),
)

q2 = Question(
    "q2",
    "Fire is *added* as light, $O = \\min(1, O_{k-1} + a C)$, not put in place of the photo. Why?",
    Choice(
        "a",
        {
            "a": "the fire clip is the flame on black: adding it keeps the shore behind the "
            "flame where the flame is dark, and a flame brightens what it lies over, as "
            "light does",
            "b": "adding is faster than blending",
            "c": "so that the flame can never be brighter than the photo",
        },
        why={
            "b": "both are one multiply-add a pixel.",
            "c": "adding makes it brighter, up to white.",
        },
    ),
    hints=["What colour is a fire clip where there is no flame?"],
    solution="""
    The fire is synthesised on black. Replacing the region with it would paint a black
    box with a flame in it; adding it leaves the photo where the flame is black and
    brightens it where the flame burns: what a real flame's light does. The $\\min$ keeps
    the sum a colour.
    """,
    right=("a",),
    wrong=("c",),
)

q3 = Question(
    "q3",
    "Frost is drawn twice, on a black and on a white plate. Over a pixel of 0.3, ice whose "
    "premultiplied colour is $C = 0.45$ and opacity $a = 0.6$ covers it "
    "(`cover`). What does the scene show?",
    Number(lambda: _one_pixel("cover", 0.3, 0.45, 0.6), atol=0.005),
    hints=["$O = (1 - a)\\,O_{k-1} + C$ (C already carries its opacity)."],
    solution="""
    $O = (1 - 0.6) \\cdot 0.3 + 0.45 = 0.12 + 0.45 =$ **0.57**. The black plate gives
    $C$ (the ice times its opacity), the white plate minus the black one gives
    $1 - a$: so the ice covers whatever the layers under it show, not only the photo.
    """,
    right=(0.57,),
    wrong=(0.45,),
)

q4 = Question(
    "q4",
    "A flicker layer of $T = 16$ frames at 8 fps loops in a scene at 24 fps. Which of its "
    "frames shows at the scene's frame 30?",
    Number(_frame_shown, atol=0.1),
    hints=["Scene frame 30 is at 30/24 s; the layer shows 8 frames a second, then repeats."],
    solution="""
    $30/24 = 1.25$ s; $1.25 \\cdot 8 = 10$: frame **10** (the loop has not wrapped yet,
    $10 < 16$). At scene frame 48 (2 s) it would be back at frame 0.
    """,
    right=(10,),
    wrong=(30,),
)

q5 = Question(
    "q5",
    "Frost grows once and then holds its last frame; water, clouds, flicker and fire loop. "
    "Why not loop the frost too?",
    Choice(
        "b",
        {
            "a": "the frost method cannot make more than one pass",
            "b": "a growth that restarts would make the ice vanish and grow again every few "
            "seconds: a jump no eye misses; a loop only works for motion that has no start "
            "and no end",
            "c": "it is cheaper",
        },
        why={
            "a": "it could grow again from the start: that is the problem.",
            "c": "looping a clip costs nothing.",
        },
    ),
    hints=["Picture the last frame of the growth followed by its first."],
    solution="""
    Water, clouds and fire are stationary: any moment looks like any other, so a loop (with
    its end cross-faded into its start) hides where it repeats. Frost is a process with a
    beginning and an end: its last frame followed by its first would make the ice vanish at
    once. So it plays once and holds.
    """,
    right=("b",),
    wrong=("c",),
)

ex1 = Question(
    "ex1",
    'Move the frost *under* the fire (`scene.move("frost", 0)`) and render again. How many '
    "layers does `render` run their method for (the check cell counts `scene.renders`)?",
    Number(0, atol=0.1, unit="layers"),
    hints=["What does a layer's cache key (`Layer.key`) hold? Its position?"],
    solution="""
    **0**: a layer's clip depends on the photo, its region, parameters and inputs, not on
    where it sits in the list. Every clip comes from the cache; only the compositing runs
    again, in the new order.
    """,
    right=(0,),
    wrong=(1,),
)

ex2 = Question(
    "ex2",
    "With the frost under the fire, what changes where the two overlap?",
    Choice(
        "a",
        {
            "a": "the fire's light is now added on top of the ice: the flame shines through "
            "the frost instead of being covered by it",
            "b": "nothing: compositing is commutative",
            "c": "the frost grows differently",
        },
        why={
            "b": "cover and light do not commute: $\\min(1, (1-a)O + C + L)$ is not "
            "$(1-a)\\min(1, O + L) + C$.",
            "c": "the frost's clip came from the cache: it is the same growth.",
        },
    ),
    hints=["Write both orders as formulas for one pixel."],
    solution="""
    Fire on top adds its light to whatever is under it, ice included: the flame shows
    through the frost. Frost on top covers the flame with ice of opacity $a$: only
    $(1 - a)$ of the flame's light is left. The layers' clips are the same; only the
    order of the formulas changed.
    """,
    right=("a",),
    wrong=("b",),
)
