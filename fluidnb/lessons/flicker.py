r"""Checks for ``02_flicker.ipynb``: Yamamoto & Sakamoto's flicker from one photo.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        which pixels the lamp moves most: slopes, not heights
``q2``        when the rising and falling curves meet again, and why
``q3``        azimuth 315: which pixels brighten, why frame 0 stays
``q4``        why transform :math:`e^{j\\alpha}`, not the brightness
``q5``        a frequency mapped above T/2 (aliasing)
``q6``        the factor T in ``flicker_reference``
``q7``        ``"peak"``: why one moment sets the scale; the shared rhythm's symbol
``q8``        tilted stripes in a space-time slice
``q9``        the flow's lean, and a stroke twice as long
``q10``       the parameters that set the frequency in hertz; a calm pond
``warm1``     the paper's loop: seconds and hertz (closed)
``warm2``     an initial phase by Eq. (3) (closed)
``ex1``       plane + no noise against the base method; the branch
``ex2``       kappa above 1
``ex3``       beta from 4 to 0.5, and beta = 0 against 0.1
``ex4``       the convex mapping on a photo with little fine detail
``ex5``       half the loop, twice the fps: the new f0
============  =================================================================
"""

import numpy as np

from ._core import Choice, Number, Parts, Question, Truth

__all__ = [
    "ex1",
    "ex2",
    "ex3",
    "ex4",
    "ex5",
    "q1",
    "q2",
    "q3",
    "q4",
    "q5",
    "q6",
    "q7",
    "q8",
    "q9",
    "q10",
    "warm1",
    "warm2",
]

q1 = Question(
    "q1",
    "The lamp of section 3 lights the height surface. Which pixels will it make move most?",
    Choice(
        "c",
        {
            "a": "the white foam: it is highest",
            "b": "the dark shadows under the rocks: they are lowest",
            "c": "the borders between light and dark: the shading follows the surface's "
            "slopes (its normals), and a flat patch is lit the same at any height",
        },
        why={
            "a": "a flat high plateau has the same normal as a flat low one: lit alike.",
            "b": "a flat low patch has the same normal as a flat high one: lit alike.",
        },
    ),
    hints=["Lambert shading uses the normal n, and n comes from the slopes of H."],
    solution="""
    The highest surface is the white foam, the lowest the dark shadows, but the lamp
    sees only the normals, $S = \\max(0, n \\cdot l)$, and the normals come from the
    slopes of $H$. Where the brightness changes quickly (foam against rock, the edges of
    ripples) neighbouring pixels start at different phases, their heights move apart
    and together, and the slopes, hence the shading, change most.
    """,
    right=("c",),
    wrong=("a",),
)

q2 = Question(
    "q2",
    "With the paper's loop ($T = 64$, $f_0 = 4$), how many frames after frame 0 do the "
    "solid (rising) and dotted (falling) curves of one pixel meet again (`frames`), and why "
    "(`why`)?",
    Parts(
        frames=Number(8, atol=0.01, unit="frames"),
        why=Choice(
            "a",
            {
                "a": "the two start phases are mirror images, $\\pi - \\alpha$ and $\\alpha$; "
                "half a period later both sines are at $-\\sin\\alpha$",
                "b": "the noise brings them together",
                "c": "they meet at the centre $C$ every half period",
            },
            why={
                "b": "there is no noise in Eq. (1).",
                "c": "they meet at $C - (H_0 - C)$, the mirror of the start, not at C.",
            },
        ),
    ),
    hints=[
        "A period is $T/f_0$ frames. Write both heights at $\\omega t = \\pi$.",
    ],
    solution="""
    A period is $T / f_0 = 16$ frames, half a period **8 frames**. At $\\omega t = \\pi$:
    $\\sin(\\pi + \\alpha) = -\\sin\\alpha$ and $\\sin(\\pi + \\pi - \\alpha) =
    \\sin(2\\pi - \\alpha) = -\\sin\\alpha$: both at $C - (H_0 - C)$, the start mirrored
    about $C$. They meet again every half period.
    """,
    right={"frames": 8, "why": "a"},
    wrong={"frames": 16, "why": "a"},
)

q3 = Question(
    "q3",
    "Set `azimuth` to 315 (in code: `base_method(photo, params=params.replace(azimuth=315))`). "
    "Which pixels brighten now (`brighten`), and why does frame 0 not change (`frame0`)?",
    Parts(
        brighten=Choice(
            "a",
            {
                "a": "slopes that face the bottom right, where the light now comes from",
                "b": "the pixels that were bright in the photo",
                "c": "the same pixels as before: the light's direction does not matter",
            },
            why={
                "b": "brightness is the height; the light sees slopes.",
                "c": "Lambert shading depends on the angle between normal and light.",
            },
        ),
        frame0=Choice(
            "a",
            {
                "a": "frame 0 adds $k(S_0 - S_0) = 0$: it is the photo whatever the light",
                "b": "the light is switched on only from frame 1",
                "c": "frame 0 is cached",
            },
            why={"b": "look at $O_t$ at $t = 0$.", "c": "look at $O_t$ at $t = 0$."},
        ),
    ),
    hints=["Write $O_0$ from the formula of section 3."],
    solution="""
    The shading now comes from the bottom right: slopes facing it brighten as they tilt
    towards it, those facing away darken. Frame 0 is
    $I(1 + k(S_0 - S_0)) = I$, the photo, for any light: only the *change* of shading
    alters the picture. (`np.abs(clip.frames[0] - photo).max()` is 0.)
    """,
    right={"brighten": "a", "frame0": "a"},
    wrong={"brighten": "b", "frame0": "a"},
)

q4 = Question(
    "q4",
    "Why does Eq. (4) transform the phases $e^{j\\alpha}$ and not the brightness itself?",
    Choice(
        "b",
        {
            "a": "the brightness has no spectrum",
            "b": "transformed back at $t = 0$ it gives $e^{j\\alpha}$ again, whose imaginary part "
            "$\\sin\\alpha$ makes $H(0) = C + A\\sin\\alpha$: frame 0 is the photo",
            "c": "it is faster",
        },
        why={
            "a": "every image has a spectrum.",
            "c": "both are one FFT.",
        },
    ),
    hints=[
        "What must frame 0 be, and what does $H = C + A\\,\\mathrm{Im}\\,I_{out}$ give at t = 0?"
    ],
    solution="""
    Frame 0 must be the photo. At $t = 0$ the inverse transform returns what was
    transformed, $e^{j\\alpha}$, and $H = C + A\\,\\mathrm{Im}\\,e^{j\\alpha} = C + A\\sin\\alpha$
    is the photo's brightness by Eq. (2)-(3). Every later frame advances each spatial
    frequency's phase by its own $2\\pi f_c t / T$.
    """,
    right=("b",),
    wrong=("a",),
)

q5 = Question(
    "q5",
    "With $T = 64$, a spatial frequency mapped to $f_t = 40$ oscillations per loop: as which "
    "temporal frequency does it show in the clip (signed: negative turns backwards)?",
    Number(40 - 64, atol=0.01, unit="oscillations per loop"),
    hints=["A DFT bin is taken modulo T: 40 and 40 - 64 are the same bin."],
    solution="""
    $40 - 64 = -24$: the DFT's bins wrap round at $T$, so 40 turns per loop sampled 64
    times look like 24 turns the *other* way (the wagon wheel in a film). A frequency
    mapped above $T/2$ runs backwards, fast: that is why $\\kappa = 1$ sends the finest
    detail just *below* $T/2$.
    """,
    right=(-24,),
    wrong=(24,),
)

q6 = Question(
    "q6",
    "In `flicker_reference`, remove the factor `T` of `U`. What happens to the height's swing?",
    Choice(
        "a",
        {
            "a": "it shrinks $T$ times: Eq. (5) divides by $XYT$, and each spatial frequency "
            "fills only one of the $T$ temporal bins",
            "b": "nothing: the inverse DFT is normalised",
            "c": "it grows $T$ times",
        },
        why={
            "b": "look at the $1/(XYT)$ in front of Eq. (5).",
            "c": "the factor multiplies; removing it divides.",
        },
    ),
    hints=["Count how many of the T bins of one spatial frequency are not zero."],
    solution="""
    The swing shrinks by a factor $T$. Eq. (5)'s inverse DFT divides by $XYT$, but
    $F_m$ puts each spatial frequency into a single bin of the $T$: a 2-D transform would
    divide by $XY$ only. The factor $T$ in `U` undoes the extra $1/T$ ("the $1/T$ is
    compensated"), so that the plane mapping gives Eq. (1) exactly.
    """,
    right=("a",),
    wrong=("b",),
)

q7 = Question(
    "q7",
    'With `noise_norm="peak"` the clip swings less. Why does one moment of the loop decide '
    "that (`why`), and which symbol of Eq. (10) makes every pixel share the same rhythm "
    "(`symbol`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "the field is divided by its largest value over the whole loop: the "
                "moment the random phases add up sets the scale of every other frame",
                "b": "the soft clip flattens the peaks",
                "c": "the noise has less power than the surface",
            },
            why={
                "b": '"peak" uses no soft clip: it divides.',
                "c": "the noise is scaled afterwards; its power is not the point.",
            },
        ),
        symbol=Choice(
            "phi",
            {
                "phi": "$\\phi(f_t)$, the random phase",
                "fc": "$f_c$",
                "df": "$\\Delta f$",
                "A": "$A$",
            },
            why={
                "fc": "$f_c$ differs between spatial frequencies.",
                "df": "$\\Delta f$ sets the strength, not a shared timing.",
                "A": "$A$ is the amplitude of every pixel, but the same at every moment.",
            },
        ),
    ),
    hints=["What does $\\phi$ depend on, and what does it not depend on?"],
    solution="""
    `"peak"` divides the noisy field by its peak over the whole loop: the rare moment
    when the random phases line up sets the scale, and every other frame is small next
    to it. The shared rhythm comes from $\\phi(f_t)$: it depends on $f_t$ only, so every
    pixel (every spatial frequency) gets the same random phases, and the whole region
    swells and calms together. The paper names this as its open problem; the beyond-
    the-paper `noise_regions` gives regions their own $\\phi$.
    """,
    right={"why": "a", "symbol": "phi"},
    wrong={"why": "a", "symbol": "fc"},
)

q8 = Question(
    "q8",
    "In a space-time slice ($x$ across, $t$ down), what would a stripe tilted to the right "
    "mean (`tilted`), and does any of the four mappings of section 8 tilt its stripes one "
    "way only (`one_way`, True or False)?",
    Parts(
        tilted=Choice(
            "a",
            {
                "a": "a pattern moving to the right as time goes on",
                "b": "a pattern getting brighter",
                "c": "a faster oscillation",
            },
            why={"b": "brightness is colour, not slope.", "c": "faster is closer stripes."},
        ),
        one_way=Truth(
            False,
            "the paper's surfaces are symmetric about the $f_t$ axis: every ripple has a "
            "twin running the other way.",
        ),
    ),
    hints=["A stripe is a feature; its slope is how far it moves per frame."],
    solution="""
    A stripe is one feature of the row followed in time; tilted to the right, it moves
    right as $t$ grows: a travelling wave. None of the four mappings tilts one way only:
    their surfaces are symmetric about the $f_t$ axis, so $\\nu$ and $-\\nu$ get the same
    $f_c$ and every ripple has a twin running the other way (standing waves, a
    criss-cross at most). Section 9's flow mapping is what tilts them one way.
    """,
    right={"tilted": "a", "one_way": False},
    wrong={"tilted": "a", "one_way": True},
)

q9 = Question(
    "q9",
    "Measure the lean of a streak of the first x-t slice of section 9 (pixels across per "
    "frame down: `lean`). Then think of a stroke twice as long: what happens to the finest "
    "ripples (`finest`)?",
    Parts(
        lean=Number(0.5, rtol=0.35, unit="px/frame"),
        finest=Choice(
            "b",
            {
                "a": "they move twice as fast, like the rest",
                "b": "a 2-pixel ripple now moves about half its wavelength a frame: the eye "
                "cannot tell which way it goes, and a little faster it would alias and run "
                "backwards (section 5's wheel)",
                "c": "they stop",
            },
            why={
                "a": "compare the distance per frame with the ripple's wavelength.",
                "c": "$f_c$ changes with $v$; nothing sets it to 0.",
            },
        ),
    ),
    hints=[
        "The stroke is $T/2$ pixels long and the loop $T$ frames.",
        "At 1 px/frame, how far does a ripple 2 px long move between two frames?",
    ],
    solution="""
    The stroke is $T/2$ px long for a loop of $T$ frames: $v = 0.5$ px/frame, the value
    printed, and the streaks lean by that. Twice as long, $v = 1$ px/frame: the finest
    ripples (2 px) move half their wavelength per frame, where forwards and backwards look
    the same ($f_c = f_0 - T v \\nu$ reaches $-T/2$ at $\\nu = 1/2$). Faster still they
    wrap round the temporal circle and seem to run back, which is why fluidnb refuses
    flows above `MAX_SPEED`.
    """,
    right={"lean": 0.5, "finest": "b"},
    wrong={"lean": 1.0, "finest": "b"},
)

q10 = Question(
    "q10",
    "The dominant frequency in hertz is set by three parameters. With `f0 = 4`, `T = 64`, "
    "`fps = 8`, what is it (`hz`), and which one would you lower to make a calm pond from a "
    "rushing stream, keeping the loop's length (`calm`)?",
    Parts(
        hz=Number(4 * 8 / 64, rtol=0.01, unit="Hz"),
        calm=Choice(
            "f0",
            {"f0": "`f0`", "fps": "`fps`", "T": "`T`", "kappa": "`kappa`"},
            why={
                "fps": "fewer frames a second also makes the loop last longer.",
                "T": "a shorter loop is shorter, and oscillates *faster*.",
                "kappa": "kappa spreads the rhythms; it does not slow the main one.",
            },
        ),
    ),
    hints=["`f0` oscillations in `T` frames shown at `fps` frames a second."],
    solution="""
    `f0 * fps / T` Hz: $4 \\cdot 8 / 64 = 0.5$ Hz. For a calm pond lower `f0` (fewer
    oscillations per loop): the loop keeps its length (`T / fps` seconds) and everything
    moves more slowly; a larger `beta` tames the noise too.
    """,
    right={"hz": 0.5, "calm": "f0"},
    wrong={"hz": 2.0, "calm": "f0"},
)

warm1 = Question(
    "warm1",
    "The paper's loop: $T = 64$ frames at 8 fps with $f_0 = 4$. How many seconds does the "
    "loop last (`seconds`), and how many seconds is one period of the plane's oscillation "
    "(`period`)?",
    Parts(seconds=Number(64 / 8, rtol=0.01, unit="s"), period=Number(64 / 4 / 8, rtol=0.01)),
    hints=["A period is $T/f_0$ frames."],
    solution="""
    $64 / 8 = 8$ s for the loop; a period is $T / f_0 = 16$ frames, $16 / 8 = 2$ s (0.5 Hz).
    """,
    right={"seconds": 8, "period": 2},
    wrong={"seconds": 8, "period": 0.5},
)


def _phase():
    from fluidnb.flicker import FlickerParams, initial_phase

    p = FlickerParams()
    return float(initial_phase(np.array([[0.75]]), p.A, p.C, "rising")[0, 0])


warm2 = Question(
    "warm2",
    "A pixel of brightness 0.75, with the paper's $A = C = 128/255$: what is its initial "
    "phase $\\alpha$ on the rising branch, Eq. (3), in radians? Work it out, then check "
    "with `initial_phase`.",
    Number(_phase, rtol=0.005, unit="rad"),
    hints=["$\\alpha = \\sin^{-1}((H_0 - C)/A)$."],
    solution="""
    $(0.75 - 0.502) / 0.502 = 0.494$, $\\sin^{-1} 0.494 = 0.517$ rad. On the falling branch
    it would be $\\pi - 0.517 = 2.625$ rad.
    """,
    right=(0.5168,),
    wrong=(2.6247,),
)

ex1 = Question(
    "ex1",
    "Set `mapping` to *plane* and `beta` to 0 and compare with the base method: what is the "
    "largest difference of their frames (`difference`, e.g. "
    "`np.abs(plane.frames - base.frames).max()`)? Then change `branch`: what changes "
    "(`branch`)?",
    Parts(
        difference=Number(0.0, atol=1e-4),
        branch=Choice(
            "a",
            {
                "a": "frame 0 and the rhythm stay; each pixel starts moving the other way",
                "b": "frame 0 changes",
                "c": "nothing",
            },
            why={
                "b": "both branches have $\\sin\\alpha = (H_0 - C)/A$: frame 0 is the photo.",
                "c": "compare frame 1 of both: they differ.",
            },
        ),
    ),
    hints=["`flicker(photo, params=params.replace(mapping='plane', beta=0.0))` and `base`."],
    solution="""
    Equal to float32 round-off (a few $10^{-7}$): the plane is the base method. With
    `branch="falling"` frame 0 is still the photo (same $\\sin\\alpha$) and the period the
    same, but each pixel starts on the falling half of the sine: the motion starts the
    other way (frame 1 differs by about 0.2).
    """,
    right={"difference": 2.4e-7, "branch": "a"},
    wrong={"difference": 0.2, "branch": "a"},
)

ex2 = Question(
    "ex2",
    "With the convex mapping, raise `kappa` above 1. What do you see in the preview?",
    Choice(
        "b",
        {
            "a": "the fine detail oscillates even faster",
            "b": "the finest detail passes $T/2$, wraps round and flickers backwards: fast, "
            "jittery sparkle instead of faster motion",
            "c": "the picture freezes",
        },
        why={
            "a": "faster than $T/2$ cannot be shown with $T$ frames per loop.",
            "c": "only the concave mapping can slow detail to 0.",
        },
    ),
    hints=["Section 5's question: 40 turns per 64 frames."],
    solution="""
    With $\\kappa > 1$ the finest spatial frequencies map above $T/2$ and alias: they
    appear at $f_c - T$, running backwards, fast. The fine texture sparkles and jitters
    rather than rippling faster.
    """,
    right=("b",),
    wrong=("a",),
)

ex3 = Question(
    "ex3",
    "Move `beta` from 4 down to 0.5: how does the motion change (`smaller`)? And why does "
    "$\\beta = 0$ look calmer than $\\beta = 0.1$ (`zero`)?",
    Parts(
        smaller=Choice(
            "a",
            {
                "a": "wilder: the noise spreads further from the surface in $f_t$",
                "b": "calmer",
                "c": "no change",
            },
            why={"b": "$1/\\Delta f^{\\beta/2}$ falls more slowly for small $\\beta$."},
        ),
        zero=Choice(
            "b",
            {
                "a": "$\\beta = 0$ is the strongest noise",
                "b": "$\\beta = 0$ switches the noise off; $\\beta = 0.1$ is nearly white "
                "noise in time: every temporal frequency almost equally strong",
                "c": "they look the same",
            },
            why={"a": "in fluidnb 0 means off (section 7).", "c": "play both."},
        ),
    ),
    hints=["Plot $1/\\Delta f^{\\beta/2}$ for $\\beta$ = 4, 0.5 and 0.1."],
    solution="""
    Smaller $\\beta$ flattens $1/\\Delta f^{\\beta/2}$: the mapped components spread over
    many temporal frequencies and the motion gets wilder, less regular. $\\beta = 0$ is
    fluidnb's switch for *no noise* (the clean tones of the mapping); $\\beta = 0.1$ is
    almost white noise in time, which jitters.
    """,
    right={"smaller": "a", "zero": "b"},
    wrong={"smaller": "b", "zero": "b"},
)

ex4 = Question(
    "ex4",
    'Try `data.sample("clouds")`: is the convex mapping still visible against the plane '
    "(the cell prints the difference of their frames, absolute and against the plane's "
    "own swing)?",
    Choice(
        "a",
        {
            "a": "yes: in absolute terms the clouds' clips differ less (a third to a half "
            "of the stream's), but so does all their motion; against the plane's own swing "
            "the difference is as large as on the stream, so a contrast-stretched "
            "difference image still shows it",
            "b": "hardly: the clouds have too few high spatial frequencies for the convex "
            "surface to change anything",
            "c": "no difference at all",
        },
        why={
            "b": "measure it: read the ratio the cell prints for both photos.",
            "c": "read the differences the cell prints.",
        },
    ),
    hints=[
        "Compare the ratios, not only the absolute differences.",
        "A smooth photo has less power at every frequency but the lowest: what does that do "
        "to the plane's swing?",
    ],
    solution="""
    Measured (the paper's $T = 64$, no noise): on the clouds the mean difference between
    the convex and the plane clip is a third to a half of the stream's, but the plane's
    own swing is smaller by as much (smooth photo, less power away from $\nu = 0$ in
    Eq. (4)'s spectrum), and the ratio is about 1 on both photos. So the convex mapping
    is still visible on the clouds once the difference is contrast-stretched (section 8);
    only in absolute terms is the whole clip calmer. The paper's "almost no difference"
    on its fire photo reads as the absolute view.
    """,
    right=("a",),
    wrong=("b",),
)

ex5 = Question(
    "ex5",
    "Halve `T` (64 to 32) and double `fps` (8 to 16): the loop lasts a quarter as long. "
    "Which `f0` keeps 0.5 Hz?",
    Number(0.5 * 32 / 16, atol=0.01),
    hints=["Hz = `f0 * fps / T`."],
    solution="""
    $f_0 = 0.5 \\cdot T / \\mathrm{fps} = 0.5 \\cdot 32 / 16 = 1$: one oscillation in the
    2-second loop (it was 4 in 8 s).
    """,
    right=(1,),
    wrong=(4,),
)
