r"""Checks for ``05_fire.ipynb``: fire by texture synthesis on a fluid simulation.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        why the matte alone would be a poor alpha :math:`a_a`
``q2``        which part of :math:`a_a` the plain temperature hardly reaches
``warm1``     the pixels of the upper L for k = 5, by hand (closed)
``q3``        why stopping a distance sum early never changes the winner
``q4``        why r is low but not zero at w = 0
``q5``        patch continuity against the neighbourhood error
``q6``        what advection cannot do: why new keyframes
``warm2``     the second keyframe's frame for N = 10, m = 5 (closed)
``q7``        a 50/50 blend of two textures: the contrast left
``q8``        ``cutoff = 0``: where the picture changes
``q9``        which parameters change what is copied, which when and how
``q10``       a photo that is not fire (the app, and in code)
``ex1``       weight 0.9 against 0.2: shape, texture, and one weight for both
``ex2``       overlap 0 and overlap = interval - 1
``ex3``       a long interval: the texture late in a segment
``ex4``       no coherence penalty: the source maps
``ex5``       n_random 64 against 16: worth it?
============  =================================================================
"""

from ._core import Choice, Number, Parts, Question

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


def _upper_pixels():
    from fluidnb.fire import neighbourhoods

    return len(neighbourhoods(5)[0])


def _second_keyframe():
    from fluidnb.fire import dissolve_weights

    return int(dissolve_weights(40, 10, 5)[0][1])


q1 = Question(
    "q1",
    "The matte alone is almost binary (flame or not). Why would it be a poor $a_a$?",
    Choice(
        "a",
        {
            "a": "every flame pixel would have $a_a \\approx 1$: the hottest gas would match "
            "the dim red edge as well as the white core, so the shape would not choose the "
            "colour",
            "b": "the matte has the wrong size",
            "c": "a binary image cannot be compared with SSD",
        },
        why={
            "b": "it is the photo's own alpha, the same size.",
            "c": "it can; it just says nothing about brightness.",
        },
    ),
    hints=["With $a_a \\in \\{0, 1\\}$, which flame pixels does a hot target prefer?"],
    solution="""
    A binary matte says only *flame or not*. The lower L compares the target's
    temperature with $a_a$: with $a_a = 1$ on the whole flame, the hottest gas matches
    the dim red fringe as well as the white core, and the colour no longer follows the
    temperature. The luminance grades the flame: brightest where hottest.
    """,
    right=("a",),
    wrong=("b",),
)

q2 = Question(
    "q2",
    "Compare the histograms. Without the rank match, which part of the photo's $a_a$ "
    "would the simulated flame hardly ever reach, and what colour is it?",
    Choice(
        "b",
        {
            "a": "the dim part: the dark red edges",
            "b": "the bright part ($a_a$ near 1): the white-yellow core",
            "c": "none: the histograms agree",
        },
        why={
            "a": "the normalised temperature is mostly low: it reaches the dim part easily.",
            "c": "compare where each histogram has its mass.",
        },
    ),
    hints=["Where does most of the temperature's histogram sit, and where the photo's?"],
    solution="""
    The normalised temperature is mostly low (cooled gas); only a small hot core
    approaches 1, while a good share of the photo's flame pixels are bright. Without
    the rank match the target would seldom ask for $a_a$ near 1: the white-yellow core
    of the photo would hardly be copied, and the fire would look dull and red.
    """,
    right=("b",),
    wrong=("a",),
)

warm1 = Question(
    "warm1",
    "For $k = 5$, how many pixels does the upper L $N_U(p)$ hold? Count by hand: the rows "
    "above $p$ in the $5 \\times 5$ square, and the pixels to its left.",
    Number(_upper_pixels, atol=0.1, unit="pixels"),
    hints=["Two full rows of 5 above, and 2 to the left of p."],
    solution="""
    Two rows of 5 above $p$ (10) and the 2 pixels to its left: **12**. The lower L holds
    the other 13, $p$ included (the cell prints both).
    """,
    right=(12,),
    wrong=(13,),
)

q3 = Question(
    "q3",
    "The compiled scan stops summing a candidate's distance once it exceeds the best so "
    "far, with colours as 8-bit levels so every sum is an exact integer. Why can stopping "
    "early never change which candidate wins (`early`)? Why is the initial white noise "
    "never read (`noise`)?",
    Parts(
        early=Choice(
            "a",
            {
                "a": "every term is a square, $\\ge 0$: a partial sum above the best can "
                "only grow, so the full sum is above it too; exact integers leave no "
                "rounding to reorder ties",
                "b": "the first pixels count most",
                "c": "it can change the winner, rarely",
            },
            why={
                "b": "all pixels of an L count the same.",
                "c": "a sum of non-negative terms never falls: it cannot.",
            },
        ),
        noise=Choice(
            "a",
            {
                "a": "$N_U$ holds only already synthesised pixels, and $N_L$ compares the "
                "target with $a_a$, never $I_s$",
                "b": "it is overwritten before the scan",
            },
            why={"b": "look at which image each L reads."},
        ),
    ),
    hints=["Can a sum of squares decrease when you add a term?"],
    solution="""
    Each term is a squared difference, so partial sums only grow: once one exceeds the
    best distance, the full one does too, and the candidate cannot win. With integer
    levels the sums are exact, so the order of summation cannot create a different tie.
    The noise is never read: the upper L covers only pixels already synthesised in
    raster order, and the lower L compares $I_t$ with $a_a$.
    """,
    right={"early": "a", "noise": "a"},
    wrong={"early": "c", "noise": "a"},
)

q4 = Question(
    "q4",
    "$r$ is the correlation between the output's brightness and the target. Why is it low "
    "at $w = 0$ but not zero?",
    Choice(
        "a",
        {
            "a": "the photo's flame sits at the bottom centre like the simulated one, and "
            "copied patches continue in place, so bright texture still tends to land "
            "where the target is bright",
            "b": "w = 0 still uses the target a little",
            "c": "by chance",
        },
        why={
            "b": "at w = 0 the lower L gets weight 0.",
            "c": "the seed is fixed, and the effect is systematic.",
        },
    ),
    hints=["Where is the flame in the photo, and where is it in the simulation?"],
    solution="""
    At $w = 0$ only the texture counts. But the candidate search continues patches of the
    photo, and the photo's flame stands where the simulated one stands (bottom centre,
    rising): the output's bright parts overlap the target's by layout, not by design.
    """,
    right=("a",),
    wrong=("b",),
)

q5 = Question(
    "q5",
    "Why does a larger patch continuity look more like fire, even though the "
    "neighbourhood error goes *up*?",
    Choice(
        "a",
        {
            "a": "continuous patches carry the photo's real structure (tongues, gradients); "
            "the error is a per-pixel match of small Ls, blind to whether the picture "
            "is made of whole pieces or a mosaic",
            "b": "a larger error means sharper fire",
            "c": "it does not: the exhaustive search looks best",
        },
        why={
            "b": "the error measures mismatch, not sharpness.",
            "c": "compare the three pictures of section 4.",
        },
    ),
    hints=["What does the error measure: a whole tongue of flame, or a 5 x 5 patch?"],
    solution="""
    The neighbourhood error rewards each pixel's best local match, and the exhaustive
    search minimises it pixel by pixel: a mosaic of well-matching fragments. Copying
    whole runs keeps the photo's structure over many pixels, which the eye reads as
    fire, at the cost of a slightly worse local match here and there.
    """,
    right=("a",),
    wrong=("c",),
)

q6 = Question(
    "q6",
    "Advection moves colours but never creates new detail. Even composed, what happens to "
    "the flame after many frames, and why are new keyframes still needed?",
    Choice(
        "a",
        {
            "a": "the texture is stretched and sheared by the flow and drifts away from the "
            "flame's current shape (new hot gas has no texture of its own): a new keyframe "
            "paints the present temperature again",
            "b": "nothing: composed advection keeps it forever",
            "c": "it fades to black",
        },
        why={
            "b": "composing avoids re-interpolation, not the flow's stretching.",
            "c": "colours are moved, not dimmed.",
        },
    ),
    hints=["Look at the last columns of section 5: what does the flow do to a patch?"],
    solution="""
    Composing the backtraces keeps the keyframe sharp, but the flow still stretches and
    shears it, and the flame changes shape: gas that was cold in the keyframe is hot
    now, and the texture carried there does not match it. A new keyframe synthesises
    the present target again; the cross-dissolve hides the switch.
    """,
    right=("a",),
    wrong=("b",),
)

warm2 = Question(
    "warm2",
    "With $N = 10$ and $m = 5$ (the plot above), at which frame is the second keyframe made?",
    Number(_second_keyframe, atol=0.1, unit="frames"),
    hints=["The next keyframe comes $N - m$ frames later."],
    solution="$N - m = 10 - 5 = $ **5**: keyframes at 0, 5, 10, ...",
    right=(5,),
    wrong=(10,),
)

q7 = Question(
    "q7",
    "Halfway through an overlap two unrelated textures are averaged 50/50. By what factor "
    "does the contrast (standard deviation) of fine detail drop there, for two independent "
    "textures of equal contrast (`factor`)? How does a larger $m$ change how often that "
    "happens (`larger_m`)?",
    Parts(
        factor=Number(0.5**0.5, rtol=0.03),
        larger_m=Choice(
            "more",
            {
                "more": "more frames are blends: the dip is longer but shallower on average",
                "less": "fewer frames are blends",
            },
            why={"less": "the overlap is the number of blended frames."},
        ),
    ),
    hints=[
        "$\\mathrm{Var}(\\tfrac12 A + \\tfrac12 B) = \\tfrac14 \\mathrm{Var} A + \\tfrac14 "
        "\\mathrm{Var} B$ for independent A, B."
    ],
    solution="""
    $\\mathrm{Var}(\\tfrac12 A + \\tfrac12 B) = \\tfrac12 \\sigma^2$, so the standard
    deviation drops to $\\sqrt{1/2} \\approx 0.71$ of each texture's: fine detail loses
    about 30 % of its contrast at the midpoint. A larger $m$ blends over more frames:
    more frames are averages, though each crossfade is gentler.
    """,
    right={"factor": 0.71, "larger_m": "more"},
    wrong={"factor": 0.5, "larger_m": "more"},
)

q8 = Question(
    "q8",
    "Run the pipeline with `cutoff=0.0` (the check cell does it). Where does the picture "
    "change (`where`), and which looks more like a flame in air (`better`)?",
    Parts(
        where=Choice(
            "a",
            {
                "a": "above and around the flame: the cooled plume is now painted as dim fire",
                "b": "in the core of the flame",
                "c": "nowhere",
            },
            why={
                "b": "the core is hot: above any cut-off, unchanged in rank.",
                "c": "compare the two rows of pictures.",
            },
        ),
        better=Choice(
            "cutoff",
            {"cutoff": "the default cut-off 0.2", "zero": "cutoff = 0"},
            why={"zero": "a flame in air ends in dark air, not in a glowing plume."},
        ),
    ),
    hints=["Which gas has a temperature below 0.2 of the range?"],
    solution="""
    Without the cut-off the warm plume above the flame (and the gas around it) gets a
    small positive target and is painted with the photo's dim red pixels: the flame
    sits in a glowing cloud. With the cut-off that gas is black, and the flame ends in
    dark air as a real one does.
    """,
    right={"where": "a", "better": "cutoff"},
    wrong={"where": "b", "better": "cutoff"},
)

q9 = Question(
    "q9",
    "Which of the parameters change *what* is copied, and which only *when* and *how* it moves?",
    Choice(
        "a",
        {
            "a": "what: `weight`, `size`, `n_random`, `coherence`, `second_pass`, `cutoff` "
            "(and the sizes); when and how: `interval`, `overlap`, `fps`",
            "b": "what: `interval`, `overlap`; when and how: `weight`, `size`, `cutoff`",
            "c": "all of them change what is copied",
        },
        why={
            "b": "the other way round: interval and overlap schedule keyframes.",
            "c": "`overlap` only changes how segments are blended, not a keyframe's pixels.",
        },
    ),
    hints=["Which ones enter the distance $D$ or the target $I_t$?"],
    solution="""
    The synthesis of one keyframe depends on `weight`, `size`, `n_random`, `coherence`,
    `second_pass` and the target's `cutoff` (and the input/output sizes). `interval`
    sets when keyframes are made, `overlap` how segments are blended, `fps` how many
    frames are advected in between: when and how things move, not what is copied.
    """,
    right=("a",),
    wrong=("b",),
)

q10 = Question(
    "q10",
    "Use a photo that is not fire, a leaf (in the app: upload it; in code: the check "
    "cell). What does the method still do right (`right`), and what gives it away "
    "(`gives_away`)?",
    Parts(
        right=Choice(
            "a",
            {
                "a": "the shape and the motion: the picture follows the simulated flame",
                "b": "the colours",
            },
            why={"b": "the colours are the leaf's."},
        ),
        gives_away=Choice(
            "a",
            {
                "a": "the texture and colours are a leaf's, and its brightness does not mean "
                "heat, so bright leaf spots land in the hot core whatever they depict",
                "b": "nothing: it looks like fire",
            },
            why={"b": "look at the result."},
        ),
    ),
    hints=["Which part of the method comes from the simulation, which from the photo?"],
    solution="""
    The shape and motion come from the simulation and the target: the leaf texture
    still forms a flame-shaped, rising, moving thing. The look comes from the photo:
    green, veined, and $a_a$ (its luminance) puts whatever is bright on the leaf into
    the hot core. The method transfers appearance; it cannot make a leaf look hot.
    """,
    right={"right": "a", "gives_away": "a"},
    wrong={"right": "b", "gives_away": "a"},
)

ex1 = Question(
    "ex1",
    "Set `weight` to 0.9 and then 0.2 (the check cell synthesises a keyframe at 0.2, 0.6, "
    "0.9 and prints $r$ and the patch continuity). Which follows the simulation better "
    "(`follows`), which keeps more of the photo's patches (`patches`), and does a weight "
    "do both (`both`)?",
    Parts(
        follows=Choice("0.9", {"0.9": "w = 0.9", "0.2": "w = 0.2"}, why={"0.2": "compare r."}),
        patches=Choice(
            "0.2", {"0.9": "w = 0.9", "0.2": "w = 0.2"}, why={"0.9": "compare the continuity."}
        ),
        both=Choice(
            "a",
            {
                "a": "nearly: around the default 0.6 r is about as high as at 0.9 and more "
                "patches survive; below it the shape goes",
                "b": "no: they trade off linearly",
                "c": "yes, w = 0",
            },
            why={
                "b": "look at 0.6 against 0.9: r barely changes.",
                "c": "w = 0 ignores the target.",
            },
        ),
    ),
    hints=["Read the printed table row by row."],
    solution="""
    $w = 0.9$ follows the target (high $r$) and breaks the photo into small pieces;
    $w = 0.2$ keeps long patches but follows the shape less. $r$ saturates: at the
    default $w = 0.6$ it is about as high as at 0.9 while more patches survive. That is
    why the default sits there.
    """,
    right={"follows": "0.9", "patches": "0.2", "both": "a"},
    wrong={"follows": "0.2", "patches": "0.9", "both": "a"},
)

ex2 = Question(
    "ex2",
    "Set `overlap` to 0 (the check cell measures the frame-to-frame change). Are there hard "
    "cuts at the keyframes (`cuts`)? And with `overlap = interval - 1` (`most`)?",
    Parts(
        cuts=Choice(
            "yes",
            {"yes": "yes: the change jumps at every keyframe", "no": "no"},
            why={"no": "compare the printed change at keyframes with the others."},
        ),
        most=Choice(
            "a",
            {
                "a": "a keyframe every frame: no cuts, but N times the synthesis, and every "
                "frame a blend of N segments, its fine detail averaged away",
                "b": "the same as the default",
            },
            why={"b": "N - m = 1: a new keyframe each frame."},
        ),
    ),
    hints=["`dissolve_weights(40, 10, 9)`: how many segments cover each frame?"],
    solution="""
    With no overlap each segment starts abruptly: the frame-to-frame change spikes at
    every keyframe, a visible cut. With $m = N - 1$ a keyframe is made every frame and
    each frame blends $N$ segments: smooth, $N$ times the work, and the averaging of
    unrelated textures washes out the fine detail.
    """,
    right={"cuts": "yes", "most": "a"},
    wrong={"cuts": "no", "most": "a"},
)

ex3 = Question(
    "ex3",
    "Make `interval` large (30). What happens to the texture late in each segment, and why?",
    Choice(
        "a",
        {
            "a": "it is stretched along the flow and no longer matches the flame's shape: "
            "advection moves old colour and makes no new detail (section 5)",
            "b": "it gets sharper",
            "c": "nothing: the advection keeps it",
        },
        why={"b": "nothing adds detail between keyframes.", "c": "see section 5's last frames."},
    ),
    hints=["Section 5 followed a keyframe for 16 frames. What about 30?"],
    solution="""
    The further from its keyframe, the more the texture is stretched and sheared by
    the flow, and the more the flame's shape has moved on: late in a long segment the
    fire looks smeared and detached from the temperature, until the next keyframe
    fades in.
    """,
    right=("a",),
    wrong=("c",),
)

ex4 = Question(
    "ex4",
    "Drop the coherence penalty, `FireParams(coherence=0.0)` (`synthesize_reference`, the "
    "numpy version, takes the same params), and compare the source maps of section 4.",
    Choice(
        "a",
        {
            "a": "random candidates win by a hair more often: the source map breaks into "
            "small pieces and the patch continuity falls: a grainier keyframe",
            "b": "the source map gets smoother",
            "c": "no change",
        },
        why={
            "b": "the penalty is what keeps random candidates from winning.",
            "c": "section 4 printed kappa = 0 and kappa = 1: compare them.",
        },
    ),
    hints=["Section 4 printed both: compare the patch continuity."],
    solution="""
    Without the penalty a random candidate wins whenever it is even slightly better, so
    new patches start everywhere: the source map is a fine mosaic, the continuity drops,
    and the keyframe looks grainy. The penalty lets one win only when it is clearly
    better.
    """,
    right=("a",),
    wrong=("b",),
)

ex5 = Question(
    "ex5",
    "Raise `n_random` to 64 and compare the neighbourhood error, the patch continuity and "
    "the time with the default 16 (the check cell prints them). Is it worth it?",
    Choice(
        "b",
        {
            "a": "yes: the error falls, so the fire looks better",
            "b": "no: the error falls a little, but the patch continuity falls too (more "
            "random winners, a grainier keyframe), and every pixel compares four times as "
            "many random candidates",
            "c": "no difference at all",
        },
        why={
            "a": "a lower error is not a better look (question q5), and it costs time.",
            "c": "read the printed numbers.",
        },
    ),
    hints=["Three numbers: which way does each go?"],
    solution="""
    More random candidates find slightly better local matches (the error drops by a
    fifth or so), but more of them win, so patches are shorter, and each pixel compares
    four times as many random positions: more work for a grainier keyframe. Not worth it
    for fire.
    """,
    right=("b",),
    wrong=("a",),
)
