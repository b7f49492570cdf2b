r"""Checks for ``06_turbulence.ipynb``: example-based turbulence and its adaptive search.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        why a source of a *different* scene is the useful case
``q2``        coarse content left in U_sh: what the coarse grid sees
``warm1``     a local patch in coarse cells, and the window n (closed)
``q3``        why the global patch must be larger than the local one
``q4``        skip the global search: count the positions
``q5``        adaptive never worse than interval 8; its positions at most
``q6``        why 4 x per halving of m, and the factor in 3-D
``q7``        the errors a viewer never sees
``q8``        which terms keep the smoke where the target puts it
``q9``        a very large beta
``q10``       which of alpha, beta, D_th to tune first
``ex1``       interval 16 on the time-error plot
``ex2``       m0 = 4 and 16: positions per patch
``ex3``       a second start: positions at most, never worse
``ex4``       blend = 4: the seams, and the picks through the temporal term
``ex5``       alpha = 0: smoke patches change their picks, clear air hardly
============  =================================================================
"""

from ._core import Choice, Number, Parts, Question, Truth, Within

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
]


def _positions(m0):
    from fluidnb.turbulence import window_positions

    return sum(len(r) for r in window_positions("adaptive", 32, m0=m0))


def _first_round(m0):
    from fluidnb.turbulence import window_positions

    return len(window_positions("adaptive", 32, m0=m0)[0])


q1 = Question(
    "q1",
    "The target and the source are simulations of two *different* scenes. Why is that the "
    "useful case for an artist?",
    Choice(
        "a",
        {
            "a": "one detailed source, computed once, serves every new coarse design: the "
            "artist never runs the slow fine simulation of their own scene",
            "b": "two scenes give more detail than one",
            "c": "it is not useful: the source should be the same scene",
        },
        why={
            "b": "the detail comes from one source either way.",
            "c": "then the fine simulation would have to be run anyway: nothing saved.",
        },
    ),
    hints=["If the source had to be the target's own scene, what would you have to run?"],
    solution="""
    If the source had to be the target's own scene at high resolution, you would run the
    expensive simulation anyway and could just use it. With any example as the source,
    one fine simulation, made once, gives detail to every cheap design the artist tries.
    """,
    right=("a",),
    wrong=("c",),
)

q2 = Question(
    "q2",
    "Suppose $U_{sh}$ still held some coarse content. What would the coarse grid see of "
    "$U = U_t + U_h$?",
    Choice(
        "a",
        {
            "a": "not $u_t$: the designed motion plus the leaked coarse part of the source's "
            "detail, so the user's design would be changed",
            "b": "exactly $u_t$",
            "c": "nothing: the coarse grid cannot see $U$",
        },
        why={
            "b": "only if down(U_h) = 0, which needs purely high-frequency detail.",
            "c": "downsampling U gives its coarse content.",
        },
    ),
    hints=["down(U_t + U_h) = down(U_t) + down(U_h)."],
    solution="""
    $\\mathrm{down}(U) = \\mathrm{down}(U_t) + \\mathrm{down}(U_h) = u_t +
    \\mathrm{down}(U_h)$. With leaked coarse content the second term is not zero: the
    pasted "detail" would shift the large-scale motion the artist designed.
    """,
    right=("a",),
    wrong=("b",),
)

warm1 = Question(
    "warm1",
    "With $B = 16$ fine cells, $r = 8$ fine cells per coarse cell and $b = 4$: how many "
    "coarse cells wide is a local patch (`local`), and how many positions per axis does "
    "the local window have, $n = b\\,\\Delta x/\\Delta X$ (`n`)?",
    Parts(local=Number(2, atol=0.01), n=Number(32, atol=0.01)),
    hints=["$B / r$ and $b \\cdot r$."],
    solution="$16 / 8 = 2$ coarse cells; $n = 4 \\cdot 8 = 32$ positions per axis.",
    right={"local": 2, "n": 32},
    wrong={"local": 16, "n": 32},
)

q3 = Question(
    "q3",
    "Why must the global patch be larger than the local one ($b > B\\,\\Delta X/\\Delta x$)?",
    Choice(
        "a",
        {
            "a": "it must see the flow *around* the patch, its context; one the size of the "
            "local patch sees only the patch itself, and many unrelated places look alike",
            "b": "to make the search faster",
            "c": "it need not: the sizes could be equal",
        },
        why={
            "b": "a larger patch costs more per position.",
            "c": "the paper requires it for the context.",
        },
    ),
    hints=["What does the global search choose, and from what?"],
    solution="""
    The global search picks the region of the source whose *surroundings* flow like the
    target's around the patch. A global patch no larger than the local one sees 2 x 2
    coarse cells: almost any smooth place matches, and the context is lost.
    """,
    right=("a",),
    wrong=("c",),
)

q4 = Question(
    "q4",
    "Why not skip the global search and search the whole fine source with Eq. (2)? In the "
    "paper's setting (source 128 x 192, B = 16), how many positions would one patch's "
    "search visit, against $n^2 = 1024$ in the window?",
    Number((128 - 16 + 1) * (192 - 16 + 1), rtol=0.05, unit="positions"),
    hints=["Positions of a 16 x 16 patch in a 128 x 192 grid: (128 - 16 + 1)(192 - 16 + 1)."],
    solution="""
    $(128 - 16 + 1)(192 - 16 + 1) = 113 \\cdot 177 = 20\\,001$ positions of 256 cells
    each, about 20 times the window's 1024 for every patch of every frame; the global
    search on a few hundred coarse positions of 16 cells narrows it for almost nothing.
    """,
    right=(20001,),
    wrong=(1024,),
)

q5 = Question(
    "q5",
    "Why can the adaptive search never find a worse position than interval 8 (with "
    "$m_0 = 8$) (`why`)? How many positions does it measure at most for $n = 32$ "
    "(`positions`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "its first round *is* interval 8, and every later round only replaces "
                "the best by a lower energy",
                "b": "it measures more positions",
            },
            why={"b": "fewer or more is not the reason; look at its first round."},
        ),
        positions=Number(lambda: _positions(8), atol=0.01),
    ),
    hints=["$(32/8)^2$ first, then 24 new positions in each of $\\log_2 8$ rounds."],
    solution="""
    Round one measures the 16 positions of interval 8 and keeps the best; the later
    rounds keep it unless they find lower. So it ends at or below interval 8's energy.
    At most $16 + 3 \\cdot 24 = 88$ positions.
    """,
    right={"why": "a", "positions": 88},
    wrong={"why": "a", "positions": 1024},
)

q6 = Question(
    "q6",
    "Each halving of the interval $m$ makes the search about 4 x slower. Why 4 (`why`)? "
    "What would the factor be for a 3-D flow (`factor_3d`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "the positions are $(n/m)^2$: halving $m$ doubles them along each of "
                "the two axes",
                "b": "the energy has four terms",
            },
            why={"b": "Eq. (2) has three terms; count the positions."},
        ),
        factor_3d=Number(8, atol=0.01),
    ),
    hints=["Count $(n/m)^d$ for $d$ axes."],
    solution="$(n/m)^2$ in 2-D: $2^2 = 4$. In 3-D $(n/m)^3$: $2^3 = $ **8**.",
    right={"why": "a", "factor_3d": 8},
    wrong={"why": "a", "factor_3d": 4},
)

q7 = Question(
    "q7",
    "Which patches' errors would a viewer never see, and why might they still matter a few "
    "frames later?",
    Choice(
        "a",
        {
            "a": "patches without smoke (the detail there is invisible); but the smoke moves "
            "into them, and the temporal term carries their detail forward, so a bad patch "
            "now can be seen later",
            "b": "the smoke patches; they never matter",
        },
        why={"b": "smoke patches are exactly the visible ones."},
    ),
    hints=["Where is the pasted detail invisible, and what happens to it next frame?"],
    solution="""
    Detail pasted into empty air is not seen. But smoke moves, and the temporal term
    carries each frame's detail on along the flow: a poor choice in the air can drift
    into the smoke a few frames later and be seen there.
    """,
    right=("a",),
    wrong=("b",),
)

q8 = Question(
    "q8",
    "The synthesised smoke rises where the *target* puts it. Which terms make sure of that?",
    Choice(
        "a",
        {
            "a": "$U = U_t + U_h$ keeps the target's motion (the detail has no coarse "
            "content), and the $\\alpha$ mask terms of Eq. (1) and (2) pick source detail "
            "where the target has smoke",
            "b": "the temporal term $\\beta$",
            "c": "the source's own mask",
        },
        why={
            "b": "beta keeps detail coherent in time, not in place.",
            "c": "the source's mask is matched against the target's: it serves the target.",
        },
    ),
    hints=["Where does the large-scale motion of $U$ come from? And the mask terms?"],
    solution="""
    The sum $U_t + U_h$ keeps the target's large-scale motion (section 2 made sure the
    detail adds none), so the smoke goes where the target sends it; and the mask terms
    $\\alpha\\|x_d - z_d\\|^2$, $\\alpha\\|X_d - Z_d\\|^2$ choose source detail from places
    whose smoke matches the target's.
    """,
    right=("a",),
    wrong=("b",),
)

q9 = Question(
    "q9",
    "With a very large $\\beta$, say 100: which term of Eq. (2) decides the patch (`term`), "
    "and how does the first frame compare with the rest (`first`)?",
    Parts(
        term=Choice(
            "temporal",
            {"temporal": "the temporal term", "velocity": "the velocity term"},
            why={"velocity": "multiply one term by 100: which one dominates the sum?"},
        ),
        first=Choice(
            "a",
            {
                "a": "the first frame has no previous detail, so it is chosen by the target; "
                "the rest mostly continue it, following their history more than the target",
                "b": "all frames alike",
            },
            why={"b": "frame 0 has no temporal term."},
        ),
    ),
    hints=["Frame 0 has no $U_h(i - 1)$."],
    solution="""
    The temporal term dominates: each patch continues last frame's advected detail,
    whatever the target's shape. The first frame, with no history, is matched to the
    target; after it the detail follows its own past, and the velocity and mask terms
    lose their say.
    """,
    right={"term": "temporal", "first": "a"},
    wrong={"term": "velocity", "first": "a"},
)

q10 = Question(
    "q10",
    "$\\alpha$, $\\beta$ and $D_{th}$ have no values in the paper. Which would you tune "
    "first for a new source flow, and what would you look at?",
    Choice(
        "a",
        {
            "a": "$D_{th}$ first: it decides what counts as smoke in both masks; look at the "
            "masks $d_t$, $D_s$ against the density, then $\\alpha$ (the renders at the "
            "smoke's edge) and $\\beta$ (flicker along the flow, section 9)",
            "b": "$\\beta$ first: it is the most important",
        },
        why={"b": "beta acts on detail the other two have chosen: tune the masks first."},
    ),
    hints=["Which parameter do the other two depend on?"],
    solution="""
    The threshold $D_{th}$ sets the masks the $\\alpha$ terms compare, so tune it first,
    by looking at the masks against the densities. Then $\\alpha$, by the renders at the
    smoke's edge, and last $\\beta$, by the flicker measured along the flow (section 9).
    (A judgement: other orders can be argued; this one follows the dependencies.)
    """,
    right=("a",),
    wrong=("b",),
)

ex1 = Question(
    "ex1",
    "Add `{'strategy': 'interval', 'interval': 16}` to `compare`. Where does it land on "
    "section 6's time-error plot?",
    Choice(
        "a",
        {
            "a": "further along the uniform curve: a quarter of interval 8's work (4 "
            "positions instead of 16) and less accurate, far above the adaptive search's "
            "error (quick mode's times are a fraction of a millisecond, so one run's "
            "timing can put it either side of interval 8: count the positions)",
            "b": "next to the adaptive search",
        },
        why={"b": "uniform sampling stays on its own curve."},
    ),
    hints=["$(32/16)^2 = 4$ positions per patch."],
    solution="""
    Interval 16 measures $(32/16)^2 = 4$ positions: faster again, and its error grows
    further along the uniform sampling's curve; the adaptive search stays apart from
    that curve.
    """,
    right=("a",),
    wrong=("b",),
)

ex2 = Question(
    "ex2",
    "With `window_positions('adaptive', 32, m0=...)`, how many positions does the adaptive "
    "search visit for $m_0 = 4$ (`m0_4`) and $m_0 = 16$ (`m0_16`)? Count by hand first.",
    Parts(
        m0_4=Number(lambda: _positions(4), atol=0.01),
        m0_16=Within(
            lambda: _positions(16),
            100,
            why_high="at most $4 + 4 \\cdot 24 = 100$.",
            why_low="count again: 4 first, then 4 rounds.",
        ),
    ),
    hints=["$(32/m_0)^2$ first, then 24 new positions in each of $\\log_2 m_0$ rounds."],
    solution="""
    $m_0 = 4$: $64 + 2 \\cdot 24 = 112$. $m_0 = 16$: $4 + 4 \\cdot 24 = 100$ at most; with
    the first best at the window's centre one round around it falls partly outside the
    window, and `window_positions` counts 91.
    """,
    right={"m0_4": 112, "m0_16": 100},
    wrong={"m0_4": 88, "m0_16": 100},
)

ex3 = Question(
    "ex3",
    "Run the adaptive search from the best and from the second-best sample of its first "
    "round and keep the better end. How many positions does it measure at most for "
    "$n = 32$, $m_0 = 8$ (`at_most`)? Can its end be worse than one start's (`worse`)?",
    Parts(
        at_most=Number(lambda: 2 * _positions(8) - _first_round(8), atol=0.01),
        worse=Truth(
            False,
            why="the two-start search keeps the better of two ends, one of which is the "
            "one-start search's end.",
        ),
    ),
    hints=[
        "The first round (16 positions) is shared; the three refining rounds (24 each) run "
        "once per start.",
        "The better of two ends, one of them the library's: can that be worse?",
    ],
    solution="""
    At most $16 + 2 \\cdot 3 \\cdot 24 = 160$ positions (fewer near the window's edge,
    and where the two starts' rounds overlap), still far below 1024. It is never worse:
    one of its two ends is the one-start search's. It finds the minimum when the
    minimum's narrow valley lies next to the second-best first sample, which is how the
    failure of section 7 happens (full mode has such patches; quick mode may have none).
    """,
    right={"at_most": 160, "worse": False},
    wrong={"at_most": 176, "worse": False},
)

ex4 = Question(
    "ex4",
    "Synthesise with `blend=4`. Are the tile seams gone (`seams`)? Does the search pick "
    "the same patches as without blending (`picks`)?",
    Parts(
        seams=Choice(
            "gone",
            {"gone": "gone (feathered)", "same": "still there"},
            why={"same": "read the seam ratio the cell prints, and the two maps."},
        ),
        picks=Choice(
            "a",
            {
                "a": "the same in frame 0; from frame 1 on some differ: the temporal term "
                "compares with last frame's pasted detail, which blending changed",
                "b": "all the same: blend changes only the paste",
                "c": "most of them differ from frame 0 on",
            },
            why={
                "b": "read the cell's count of patches picked differently, then the third "
                "term of Eq. (2).",
                "c": "frame 0 has no previous detail: what could change its search?",
            },
        ),
    ),
    hints=[
        "Which step does `blend` change: the search, or the paste?",
        "What does the temporal term of Eq. (2) compare a candidate with?",
    ],
    solution="""
    Feathering overlaps the tiles and fades them into each other: the straight seams in
    the vorticity disappear (the seam ratio drops from about 1.8 to 1). Frame 0's search
    is untouched, so its picks are the same. But the temporal term compares each
    candidate with last frame's *pasted* detail, advected, and that detail is now
    feathered: from frame 1 on some patches pick differently (measured: 9 % of the
    picks in quick mode, 20 % in full mode).
    """,
    right={"seams": "gone", "picks": "a"},
    wrong={"seams": "gone", "picks": "b"},
)

ex5 = Question(
    "ex5",
    "Set `alpha = 0`: the search matches velocity only. Where does the detail change?",
    Choice(
        "a",
        {
            "a": "in the patches holding smoke: most of them pick another source position, "
            "while the clear air's patches hardly change",
            "b": "nowhere",
            "c": "mostly in the clear air",
        },
        why={
            "b": "read the cell's count: the mask terms choose patches by where the smoke is.",
            "c": "read the cell's count, split by the smoke mask.",
        },
    ),
    hints=["Where do the masks of the target and of the candidates differ?"],
    solution="""
    Without the mask terms a smoke patch may take detail from anywhere the velocity
    matches, also from the source's clear air, whose swirls differ from those inside
    smoke: most smoke patches pick another position, while the clear air's patches
    hardly change (their best velocity match already lay in clear air). The smoke is what
    the eye sees, so the renders change where it matters.
    """,
    right=("a",),
    wrong=("c",),
)
