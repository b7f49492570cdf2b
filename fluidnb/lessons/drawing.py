"""Checks for ``01_drawing_tools.ipynb``: the canvas, its arrays, a tiny app, the player.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        region or map: which says "twice as fast", which "only here"
``q2``        stroke points: image or screen pixels, and which number is the row
``q3``        where two strokes' directions meet
``q4``        why the preview multiplies the speed by its scale
``q5``        GIF or MP4: which one bands, and why
``warm1``     how far a point travels in the drift clip (closed)
``warm2``     the painted region's area, by hand (closed)
``ex1``       a velocity scaled by a painted speed map (your function)
``ex2``       two strokes that point at each other: where the field flips, and why
``ex3``       Run, then Cancel: what is kept
============  =================================================================
"""

import numpy as np

from ._core import Choice, Code, Number, Parts, Question, close

__all__ = ["ex1", "ex2", "ex3", "q1", "q2", "q3", "q4", "q5", "warm1", "warm2"]

_KINDS = {"region": "a **region** (inside or outside)", "map": "a **map** (grey levels)"}

q1 = Question(
    "q1",
    "Which layer says *the water flows twice as fast here as there* (`faster`), and which "
    "says *only the water moves* (`only`)?",
    Parts(
        faster=Choice(
            "map", _KINDS, why={"region": "a region has two values only: no 'twice as'."}
        ),
        only=Choice("region", _KINDS, why={"map": "inside or outside is all it takes: a region."}),
    ),
    hints=["A ratio needs more than two values."],
    solution="""
    *Twice as fast* is a ratio of speeds: it needs grey levels, a **map** (0.5 here, 1
    there). *Only the water moves* is inside or outside: a **region** (a mask).
    """,
    right={"faster": "map", "only": "region"},
    wrong={"faster": "region", "only": "map"},
)

q2 = Question(
    "q2",
    "Are the stroke's numbers screen pixels or image pixels (`units`), and which of the two "
    "numbers of a point is the row (`row`)?",
    Parts(
        units=Choice(
            "image",
            {"image": "image pixels", "screen": "screen pixels"},
            why={"screen": "compare the largest numbers with `photo.shape`, not the display."},
        ),
        row=Choice(
            "first",
            {"first": "the first number", "second": "the second number"},
            why={"second": "the first number stays below `photo.shape[0]`, the height."},
        ),
    ),
    hints=["`photo.shape` is (height, width, 3). Which number never exceeds the height?"],
    solution="""
    Image pixels: the largest values stay within `photo.shape[:2]` whatever the size the
    canvas is shown at. A point is (row, col): the first number counts down from the top
    (it stays below the height `photo.shape[0]`), the second across. docs/conventions.md
    says so for every array in fluidnb.
    """,
    right={"units": "image", "row": "first"},
    wrong={"units": "screen", "row": "first"},
)

q3 = Question(
    "q3",
    "Draw a second stroke in another direction (in code: "
    "`canvas.draw_stroke([[r0, c0], [r1, c1]], layer='flow')`) and re-run the cell. "
    "Where do the two strokes' directions meet?",
    Choice(
        "b",
        {
            "a": "at the end of the first stroke",
            "b": "on a line between the strokes, where each is about as far away as the "
            "other: there the field turns from one direction to the other",
            "c": "nowhere: each stroke's direction fills the half of the image it was drawn in",
        },
        why={
            "a": "the interpolation weighs both strokes everywhere, by distance.",
            "c": "look at the arrows between the strokes: they turn gradually.",
        },
    ),
    hints=["The field is interpolated by distance (a thin-plate spline): who is closer wins."],
    solution="""
    Near each stroke the field follows that stroke; in between, the interpolated vectors
    are weighted mixtures, and the direction turns from one to the other on a band
    roughly halfway between them. (Exercise 2 makes the extreme case: opposite strokes.)
    """,
    right=("b",),
    wrong=("a",),
)

q4 = Question(
    "q4",
    "Why must the preview (at `scale < 1`) multiply the speed by `scale` too?",
    Choice(
        "a",
        {
            "a": "a velocity is in pixels per frame; the half-size image has half as many "
            "pixels over the same distance, so the same motion is half as many pixels a frame",
            "b": "to make the preview run faster",
            "c": "advection is unstable above one pixel per frame on a small image",
        },
        why={
            "b": "the work per frame does not depend on the speed.",
            "c": "semi-Lagrangian advection is stable at any speed (notebook 00).",
        },
    ),
    hints=["docs/conventions.md: a velocity is in *pixels* per frame."],
    solution="""
    Velocities are in pixels per frame. At half the size a pixel covers twice the
    distance, so the same motion (the water crossing the image in 10 s) is half as many
    pixels per frame: the speed scales with the image, like the strokes' coordinates.
    Without it the preview would move twice as fast as the full clip.
    """,
    right=("a",),
    wrong=("b",),
)

q5 = Question(
    "q5",
    "Export the clip as a GIF and as an MP4 (in code: `clip.save('drift.gif')`, "
    "`clip.save('drift.mp4')`). Which one shows bands in the smooth parts?",
    Choice(
        "gif",
        {
            "gif": "the GIF: at most 256 colours a frame, so a smooth ramp becomes steps",
            "mp4": "the MP4: its compression removes fine gradations",
            "both": "both, equally",
        },
        why={
            "mp4": "an MP4 keeps 8 bits per channel (16 million colours); it blurs, not bands.",
            "both": "count the colours of one frame of each.",
        },
    ),
    hints=["Count the distinct colours in one frame of each file."],
    solution="""
    The GIF: each frame has a palette of at most 256 colours, so a smooth gradient of a
    photo (the sky, the water) is quantised into visible steps. The MP4 stores 8 bits per
    channel; its losses are blur and blocks, not bands.
    """,
    right=("gif",),
    wrong=("mp4",),
)

warm1 = Question(
    "warm1",
    "With `speed` = 3 and 32 frames, how many pixels does a point on the stroke travel "
    "between the first and the last frame?",
    Number(3.0 * 31, rtol=0.01, unit="pixels"),
    hints=["Frame 0 is the photo itself: how many steps are there between 32 frames?"],
    solution="""
    32 frames are 31 steps of 3 px: 93 px (on the stroke, where the direction field has
    length 1 and the region is fully painted).
    """,
    right=(93,),
    wrong=(96,),
)


def _stadium_fraction():
    """The preloaded region's area by hand: a rectangle plus a disc, over the image."""
    from fluidnb import data

    h, w = data.sample("stream", size=320).shape[:2]
    r, length = 0.12 * h, 0.6 * w
    return (2 * r * length + np.pi * r**2) / (h * w)


warm2 = Question(
    "warm2",
    "The region was painted along a straight line of length 0.6 w with a brush of radius "
    "0.12 h. Work out by hand the fraction of the image it covers (take the photo's "
    "`h, w` from `photo.shape`), then compare with `region.mean()`.",
    Number(_stadium_fraction, rtol=0.03),
    hints=["A brush dragged along a line paints a stadium: a rectangle and two half discs."],
    solution="""
    A stadium: a rectangle $2r \\times L$ and two half discs, area $2rL + \\pi r^2$ with
    $r = 0.12h$, $L = 0.6w$; over $hw$ that is $0.144 + 0.0144\\pi\\,h/w \\approx 0.18$ for
    the stream. `region.mean()` agrees to a pixel's rounding.
    """,
    right=(0.18,),
    wrong=(0.144,),
)


def _judge_velocity(fn):
    rng = np.random.default_rng(4)
    theta = rng.uniform(-np.pi, np.pi, (6, 7))
    direction = np.stack([np.sin(theta), np.cos(theta)], axis=-1)
    region = (rng.random((6, 7)) > 0.3).astype(float)
    speed_map = rng.random((6, 7))
    want = direction * 1.5 * (region * speed_map)[..., None]
    got = np.asarray(fn(direction, region, speed_map, 1.5), float)
    if got.shape != want.shape:
        return False, f"it returned shape {got.shape}, a velocity is (H, W, 2): {want.shape}."
    if close(got, want):
        return True, "painted brighter moves faster, in proportion; black stands still."
    if close(got, direction * 1.5 * region[..., None]):
        return False, "the speed map does not change your velocity yet."
    return False, "it differs from direction x speed x region x speed map."


ex1 = Question(
    "ex1",
    "Write the velocity line of `drift` as a function "
    "`velocity(direction, region, speed_map, speed)` in which the painted speed map "
    "(values in [0, 1]) scales the speed, and check it; then use it in `drift`.",
    Code(_judge_velocity, "velocity(direction, region, speed_map, speed) -> (H, W, 2)"),
    hints=[
        "Each of region and speed_map is (H, W); the direction is (H, W, 2).",
        "Multiply per pixel, and add an axis: `(region * speed_map)[..., None]`.",
    ],
    solution="""
    ```python
    def velocity(direction, region, speed_map, speed):
        return direction * speed * (region * speed_map)[..., None]
    ```
    In `drift`: `speed_map = fields.resize(canvas.get_map("speed"), shape)` and
    `velocity = velocity(direction, region, speed_map, params.speed * scale)`. Parts
    painted brighter move faster, in proportion; unpainted ones (0) stand still.
    """,
    right=(lambda d, r, s, v: d * v * (r * s)[..., None],),
    wrong=(lambda d, r, s, v: d * v * r[..., None],),
)

ex2 = Question(
    "ex2",
    "Two strokes that point at each other, on a 96 x 128 grid: "
    "`[[48, 10], [48, 50]]` (to the right) and `[[48, 118], [48, 78]]` (to the left). "
    "In which column does the direction field first point left (`field[48, :, 1] < 0`), "
    "and why does it flip there (`why`)?",
    Parts(
        column=Number(64, atol=1.5),
        why=Choice(
            "a",
            {
                "a": "halfway, the two interpolated directions cancel; normalising a vector "
                "near zero turns it abruptly: a line where the flow converges",
                "b": "the second stroke was drawn last, so it wins from there on",
                "c": "the field is clipped to the strokes' bounding box",
            },
            why={
                "b": "the order of the strokes does not matter to the interpolation.",
                "c": "the field is defined over the whole image.",
            },
        ),
    ),
    hints=[
        "`field = sketch.direction_field([a, b], (96, 128))`, then "
        "`np.flatnonzero(field[48, :, 1] < 0)[0]`.",
    ],
    solution="""
    Column 64, halfway between the strokes' tips (50 and 78). The interpolated vector
    shrinks to zero there and changes sign; normalised to unit length, it jumps from
    right to left in one pixel: a line where the flow runs together. A drift along it
    would pile the photo up on that line.
    """,
    right={"column": 64, "why": "a"},
    wrong={"column": 64, "why": "b"},
)

ex3 = Question(
    "ex3",
    "Press **Run** with 120 frames and **Cancel** half-way. What is kept? (In code: "
    '`app.panel.set("frames", 120); app.run(block=False); app.cancel(); app.wait()`, then '
    "compare `app.result` with the clip before.)",
    Choice(
        "a",
        {
            "a": "the previous clip, the drawing and the settings: the cancelled run "
            "leaves nothing behind",
            "b": "the frames computed up to the Cancel",
            "c": "nothing: the player is emptied",
            "d": "the clip, but the drawing is cleared",
        },
        why={
            "b": "a half-made clip is not shown: `app.result` is still the old one.",
            "c": "the player still plays the last finished clip.",
            "d": "nothing you drew is ever cleared by a run (the team's standard).",
        },
    ),
    hints=["Read the app's status line after the Cancel."],
    solution="""
    The run stops at its next progress report; the status line says "cancelled; your
    drawing and settings are unchanged", and the player keeps the last finished clip
    (`app.result` is the same object as before).
    """,
    right=("a",),
    wrong=("b",),
)
