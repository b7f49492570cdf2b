r"""Checks for ``06b_turbulence_appendix.ipynb``: exact searches that are also fast.

============  =================================================================
question      what it asks
============  =================================================================
``warm1``     the FFT size for n = 32, B = 16 (closed)
``q1``        why the kept positions never see the circular wrap-around
``q2``        which position the bounds search measures first, and why it matters
``q3``        why the bounds search's time depends on the data
``q4``        why the app still defaults to the adaptive search
``ex1``       the bound is never larger than the energy; smaller boxes
``ex2``       a 64 x 64 window: the fastest search, and the FFT's gain
============  =================================================================
"""

from ._core import Choice, Number, Parts, Question

__all__ = ["ex1", "ex2", "q1", "q2", "q3", "q4", "warm1"]

warm1 = Question(
    "warm1",
    "For $n = 32$ positions per axis and $B = 16$, what is the smallest FFT size "
    "$L = n + B - 1$ along an axis that keeps every position free of wrap-around?",
    Number(32 + 16 - 1, atol=0.01),
    hints=["The window region the correlation reads is n + B - 1 cells wide."],
    solution="$L = 32 + 16 - 1 = 47$ (an FFT would round it up to a fast size, 48).",
    right=(47,),
    wrong=(32,),
)

q1 = Question(
    "q1",
    "The FFT computes a *circular* correlation. Why do the $n \\times n$ positions we keep "
    "never see the wrap-around, as long as the FFT size is at least $n + B - 1$?",
    Choice(
        "a",
        {
            "a": "at a kept position the whole B x B patch lies inside the n + B - 1 region; "
            "only shifts past its edge wrap, and those are the positions we throw away "
            "(`mode='valid'`)",
            "b": "the FFT has no wrap-around",
            "c": "the patch is zero-padded to the window's size, which removes it",
        },
        why={
            "b": "a discrete Fourier transform is periodic: circular by nature.",
            "c": "padding makes room, but it is the choice of kept positions that avoids it.",
        },
    ),
    hints=["Which shifts of the patch reach past the region's edge?"],
    solution="""
    The region holds $n + B - 1$ cells per axis. A shift $q \\in [0, n)$ places the patch
    on cells $q \\dots q + B - 1 \\le n + B - 2$: inside. Only larger shifts wrap around,
    and those are not kept ("valid" correlation).
    """,
    right=("a",),
    wrong=("b",),
)

q2 = Question(
    "q2",
    "The search measures one position in full before the bounds can rule any other out. "
    "Why does it matter which one, and what if the first is the worst of the window?",
    Choice(
        "a",
        {
            "a": "its energy is the threshold: only positions whose bound is below it "
            "survive; the worst position's energy rules out almost nothing, so nearly all "
            "positions are measured",
            "b": "it does not matter: the result is exact anyway, and the cost the same",
        },
        why={"b": "the result is exact, but the cost depends on the threshold."},
    ),
    hints=["A position is skipped when its bound exceeds the best energy so far."],
    solution="""
    The first measured energy is the best-so-far $E$; a position is skipped when its
    lower bound exceeds $E$. A low first $E$ (last frame's choice, or the bound's
    minimum) rules out most of the window; the worst position's $E$ is above nearly
    every bound, so almost nothing is skipped. The answer stays exact; only the time
    suffers.
    """,
    right=("a",),
    wrong=("b",),
)

q3 = Question(
    "q3",
    "The time of `exact-bounds` depends on the data, that of the exhaustive and adaptive "
    "searches does not. Why, and on what kind of flow would it be slow?",
    Choice(
        "a",
        {
            "a": "how many positions its bounds rule out depends on the energies; on a flat "
            "landscape (a uniform, featureless flow, many near-equal positions) the bounds "
            "rule out little and most positions are measured",
            "b": "it uses random numbers",
        },
        why={"b": "it is deterministic; its work depends on the energies."},
    ),
    hints=["The other two visit a fixed set of positions."],
    solution="""
    Exhaustive and adaptive visit a fixed set of positions whatever the energies.
    `exact-bounds` measures only the positions its bounds cannot rule out, and that
    depends on the landscape: with one clear valley almost all are skipped; on a flat,
    featureless flow many positions are nearly equal and must be measured.
    """,
    right=("a",),
    wrong=("b",),
)

q4 = Question(
    "q4",
    "Both exact searches have zero error and `exact-bounds` is the fastest here. Why is the "
    "app's default still the paper's adaptive search?",
    Choice(
        "a",
        {
            "a": "the app teaches the paper: its default reproduces the paper's method and "
            "Table 1; for a production render, where exactness and data-independent speed "
            "matter less than the result, you would switch to exact-bounds",
            "b": "exact-bounds is wrong sometimes",
        },
        why={"b": "it returns the exhaustive positions bit for bit."},
    ),
    hints=["What is the app for?"],
    solution="""
    The app is the paper's method, to be compared with its Table 1 and figures; a class
    wants that. For a production render switch to `exact-bounds`: the exhaustive answer,
    faster (its time depends on the data, though).
    """,
    right=("a",),
    wrong=("b",),
)

ex1 = Question(
    "ex1",
    "The lower bound of section 2 is never larger than the energy (Cauchy-Schwarz). May the "
    "boxes leave part of the patch uncovered (`uncovered`), and do smaller boxes give a "
    "tighter bound (`smaller`)?",
    Parts(
        uncovered=Choice(
            "yes",
            {
                "yes": "yes: the energy is a sum of non-negative terms; dropping some only "
                "lowers the bound",
                "no": "no",
            },
            why={"no": "leaving out non-negative terms keeps a lower bound a lower bound."},
        ),
        smaller=Choice(
            "yes",
            {"yes": "yes: each box's bound loses less (a box of one cell is exact)", "no": "no"},
            why={"no": "a 1-cell box gives the exact term: smaller boxes lose less."},
        ),
    ),
    hints=["$|\\Sigma(x - z)| \\le \\sqrt{k}\\,\\|x - z\\|$, summed over boxes."],
    solution="""
    Per box, $(\\Sigma x - \\Sigma z)^2/k \\le \\|x - z\\|^2_{box}$ by Cauchy-Schwarz with
    the vector of ones. The energy sums non-negative terms over all cells, so summing the
    bounds over any set of disjoint boxes, covering all or part of the patch, stays below
    it. Smaller boxes lose less of each box's variation; a box of one cell is exact.
    """,
    right={"uncovered": "yes", "smaller": "yes"},
    wrong={"uncovered": "no", "smaller": "yes"},
)

ex2 = Question(
    "ex2",
    "With `b = 8` the window grows (64 x 64 in full mode). Which search is the fastest "
    "(`fastest`)? Does `exact-fft` gain on the exhaustive search as the window grows, and "
    "why (`fft`)?",
    Parts(
        fastest=Choice(
            "bounds",
            {"bounds": "exact-bounds", "fft": "exact-fft", "exhaustive": "exhaustive"},
            why={
                "fft": "read the times the cell prints: the FFT still computes every "
                "position's correlation.",
                "exhaustive": "read the times the cell prints.",
            },
        ),
        fft=Choice(
            "a",
            {
                "a": "yes: the direct sums cost $n^2 B^2$ per patch, the FFT about "
                "$L^2 \\log L$ with $L = n + B - 1$, which grows more slowly with $n$; in "
                "full mode it is slower than the exhaustive search at `b = 4` and faster "
                "at `b = 8` (quick mode's 49 x 49 window, and a busy machine, can hide it)",
                "b": "no: both grow alike",
                "c": "it is the fastest search at `b = 8`",
            },
            why={
                "b": "compare the speed-ups at b = 4 and b = 8, and how the two costs "
                "grow with n at fixed B.",
                "c": "read the times: exact-bounds measures only a few positions in full.",
            },
        ),
    ),
    hints=[
        "Read the speed-ups the cell prints; run it twice (times vary).",
        "Compare how $n^2 B^2$ and $L^2 \\log L$ grow with $n$ at fixed $B = 16$.",
    ],
    solution="""
    `exact-bounds` is the fastest by far: its bounds rule out almost every position, so
    most patches measure a handful in full, however large the window (a few, with many
    nearly equal positions, measure a thousand; measured, full mode: 2.8 ms
    against 237 ms exhaustive and 188 ms `exact-fft`, under a load of about 7). The FFT
    gains on the exhaustive search as the window grows: the direct sums cost $n^2 B^2$
    per patch, the correlation about $L^2 \\log L$ with $L = n + B - 1$; from `b = 4`
    to `b = 8` its speed against the exhaustive search went from about 0.6 x to 1.3 x
    (full mode, one run under a load of about 7; in quick mode's 49 x 49 window two runs
    gave 0.5 x -> 0.9 x and 0.9 x -> 0.6 x: too close, and too noisy on a busy machine,
    to tell). It pays off for still larger windows and patches, where the bounds may
    also rule out less.
    """,
    right={"fastest": "bounds", "fft": "a"},
    wrong={"fastest": "fft", "fft": "a"},
)
