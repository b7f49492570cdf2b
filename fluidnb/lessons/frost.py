r"""Checks for ``03_frost.ipynb``: Reiter's frost, the random threshold, the optimisation.

============  =================================================================
question      what it asks
============  =================================================================
``q1``        a square lattice: four or eight arms
``q2``        where a receptive cell's diffused vapour comes from
``q3``        why the vapour is float64 for exact symmetry
``q4``        which parameter sets the shape, which the speed; alpha near 0
``q5``        the slow tail at r_th = 0.8: which cells, why
``warm1``     the 7-cell region's end frame by hand (closed)
``warm2``     the mass-balance bound at the paper's values (closed)
``q6``        a target of 1 frame: what the optimiser answers
``q7``        how many cells the paper's region could have had
``q8``        why 100 % coverage makes T_sim jumpier
``q9``        why the direction fit damps its Newton steps
``q10``       ``FrostLook(ridges=0)``: a cone; which look fits a window pane
``ex1``       an off-centre start: which symmetry survives
``ex2``       the smallest finite-difference h that still converges
``ex3``       the eta that converges in one step on the reference region
``ex4``       the 7-cell region: T_sim = (1 - beta)/gamma, and the beta for 130
``ex5``       the other reading: a frontier cell whose vapour diffuses into ice
``q11``       a second painted blob without a start point (the app, and in code)
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
    "q11",
    "warm1",
    "warm2",
]


def _paper():
    from fluidnb.frost import FrostParams

    return FrostParams()


q1 = Question(
    "q1",
    "Why would a square lattice give frost with four (or eight) arms instead of six?",
    Choice(
        "a",
        {
            "a": "the arms grow along the lattice's neighbour directions: a square lattice "
            "has four (eight with diagonals), a hexagonal one six",
            "b": "because squares are larger than hexagons",
            "c": "it would not: the arms come from the physics, whatever the lattice",
        },
        why={
            "b": "the spacing sets the size, not the number of arms.",
            "c": "the automaton knows only its neighbours: its symmetry is the lattice's.",
        },
    ),
    hints=["In which directions can ice spread from one cell in one step?"],
    solution="""
    Ice spreads from a cell to its neighbours, and diffusion runs along the same links,
    so the crystal inherits the lattice's symmetry: six-fold on a hexagonal lattice (as
    ice's own), four-fold on a square one (eight-fold with diagonal neighbours, and
    then unequal distances along the axes and the diagonals).
    """,
    right=("a",),
    wrong=("c",),
)

q2 = Question(
    "q2",
    "A receptive cell's own $b$ is 0, yet it gains vapour from diffusion. Where does that "
    "vapour come from (`source`)? And what does an ice cell whose six neighbours are all "
    "receptive gain in a step (`enclosed`)?",
    Parts(
        source=Choice(
            "a",
            {
                "a": "from its non-receptive neighbours: the sum over nn(p) of their $b$",
                "b": "from its own vapour $u$",
                "c": "from the boundary ring only",
            },
            why={
                "b": "its own $u$ stays in $a$; its $b$ is 0.",
                "c": "any non-receptive neighbour contributes, the ring among them.",
            },
        ),
        enclosed=Choice(
            "gamma",
            {"gamma": "exactly $\\gamma$", "more": "$\\gamma$ plus what diffuses in", "none": "0"},
            why={
                "more": "all six neighbours have $b = 0$: nothing diffuses in.",
                "none": "ice always receives $\\gamma$.",
            },
        ),
    ),
    hints=["Write $D_t(p)$ for a cell with $b(p) = 0$: only the sum is left."],
    solution="""
    With $b(p) = 0$ the diffusion gives $\\frac{\\alpha}{12}\\sum_{q} b(q)$: vapour from
    the neighbours that are not receptive. If all six neighbours are receptive, every
    $b(q) = 0$, nothing comes in, and the cell gains only $\\gamma$. That is why frozen
    ice thickens by exactly $\\gamma$ a step (section 10's ice mass).
    """,
    right={"source": "a", "enclosed": "gamma"},
    wrong={"source": "a", "enclosed": "more"},
)

q3 = Question(
    "q3",
    "The symmetry test is exact equality of freeze frames. Why does the library keep the "
    "vapour in float64 rather than float32?",
    Choice(
        "b",
        {
            "a": "float64 is faster",
            "b": "mirror cells add their six neighbours in different orders; float32's "
            "rounding would now and then put one just below 1 and its mirror just above, "
            "freezing one a frame before the other",
            "c": "float32 cannot store 0.35",
        },
        why={
            "a": "float32 is faster (half the memory traffic): a price paid on purpose.",
            "c": "neither can float64 exactly; the question is where the rounding lands.",
        },
    ),
    hints=["Floating-point addition is not associative. Where does a freeze decision fall?"],
    solution="""
    Symmetric cells compute the same sum in different orders, so their results differ in
    the last bits. A cell freezes when $u \\ge 1$: a difference of one rounding can put
    one cell at $0.99999997$ and its mirror at $1.00000003$. In float64 the rounding is
    $10^{-16}$ and such near-ties practically never fall between the two; in float32
    ($10^{-7}$) they do, now and then, and the crystal loses its exact symmetry.
    """,
    right=("b",),
    wrong=("a",),
)

q4 = Question(
    "q4",
    "Which parameter changes the *shape*, thin dendrites against plates (`shape`), and "
    "which mostly the *speed* (`speed`)? With $\\alpha$ close to 0, is there still a "
    "crystal (`alpha0`)?",
    Parts(
        shape=Choice(
            "beta",
            {"beta": "beta", "gamma": "gamma", "alpha": "alpha"},
            why={
                "gamma": "compare the gamma row: the same arms, reached sooner or later.",
                "alpha": "alpha changes both; look at the beta row first.",
            },
        ),
        speed=Choice(
            "gamma",
            {"beta": "beta", "gamma": "gamma", "alpha": "alpha"},
            why={"beta": "beta thickens the arms into plates: that is shape."},
        ),
        alpha0=Choice(
            "a",
            {
                "a": "hardly: vapour no longer moves, the frontier lives on $\\gamma$ alone and "
                "grows a small compact plate, very slowly",
                "b": "yes, the same six arms",
                "c": "the region freezes at once",
            },
            why={
                "b": "the arms come from diffusion feeding the tips; without it there are none.",
                "c": "with beta below 1 nothing freezes without vapour arriving.",
            },
        ),
    ),
    hints=["Look at each row of the gallery; then run `grow` with `alpha=0.01`."],
    solution="""
    $\\beta$ sets the shape: little vapour gives thin dendrites, much vapour thick arms
    and plates. $\\gamma$ sets mostly the speed (the same arms sooner). With $\\alpha \\to
    0$ vapour does not diffuse: no tip is fed more than its neighbours, the frontier
    freezes on $\\gamma$ alone, ring by ring, into a small compact plate, very slowly
    (the cell prints how little has frozen at `alpha=0.01`).
    """,
    right={"shape": "beta", "speed": "gamma", "alpha0": "a"},
    wrong={"shape": "gamma", "speed": "beta", "alpha0": "a"},
)

q5 = Question(
    "q5",
    "The coverage curve at $r_{th} = 0.8$ ends in a long slow tail. Which cells are still "
    "unfrozen in it, and why does the random threshold slow them most?",
    Choice(
        "a",
        {
            "a": "cells enclosed by ice (pockets between arms): their neighbours are all "
            "receptive, so no vapour flows in; they live on $\\gamma$ alone, which they get "
            "one step in five",
            "b": "cells at the far edge of the region: they are far from the start",
            "c": "cells next to the boundary ring: the ring takes their vapour",
        },
        why={
            "b": "the arms reach the edge early; what remains is enclosed.",
            "c": "the ring gives its receptive neighbours exactly what it takes.",
        },
    ),
    hints=["Draw the last frames' unfrozen cells: where are they?"],
    solution="""
    The last cells are pockets surrounded by ice. All their neighbours are receptive
    ($b = 0$), so diffusion brings them nothing, and they rise only by $\\gamma$, which at
    $r_{th} = 0.8$ they receive one step in five: five times slower than at $r_{th} = 0$.
    """,
    right=("a",),
    wrong=("b",),
)

warm1 = Question(
    "warm1",
    "The smallest region, a start point and its six neighbours (`HexLattice.hexagon(1)`), "
    "at the paper's $\\beta = 0.35$, $\\gamma = 0.005$: at which frame does it end? Work it "
    "out by hand.",
    Number(lambda: (1 - _paper().beta) / _paper().gamma, atol=1.01, unit="frames"),
    hints=[
        "All six neighbours are frontier cells from the first step; no vapour flows between "
        "receptive cells. Each gets $\\gamma$ a step, starting from $\\beta$."
    ],
    solution="""
    The six neighbours are frontier cells from the start, their neighbours are the start
    (ice) and the ring, which takes the mean of their diffused values: 0. So nothing
    diffuses; each rises by $\\gamma$ a step from $\\beta$ and freezes at
    $(1 - \\beta)/\\gamma = 0.65/0.005 = 130$ frames (section 6's table: "run 130").
    """,
    right=(130,),
    wrong=(150,),
)

warm2 = Question(
    "warm2",
    "The mass-balance bound of section 6 at $\\beta = 0.25$, $\\gamma = 0.005$: no run "
    "ends before how many frames?",
    Number(lambda: (0.9 - 0.25) / _paper().gamma, atol=1.01, unit="frames"),
    hints=["$(0.9 - \\beta)/\\gamma$"],
    solution="""
    $(0.9 - 0.25)/0.005 = 130$ frames: the total must grow from $0.25N$ to $0.9N$ by at
    most $\\gamma N$ a step.
    """,
    right=(130,),
    wrong=(180,),
)

q6 = Question(
    "q6",
    "No $\\beta < 1$ ends before `est.fastest`. What does the optimiser answer for a "
    "target of 1 frame (`answer`; code route: `optimise_beta(lat_ref, starts_ref, 1, "
    "p_ref)` in the cell below), and what would converging to $\\beta \\approx 1$ with end "
    "frame 0 have meant (`meant`)?",
    Parts(
        answer=Choice(
            "a",
            {
                "a": "a ValueError: the target must be at least the fastest possible end "
                "frame (ice spreads at most a cell a frame)",
                "b": "it converges to beta = 1",
                "c": "it returns the closest beta it found",
            },
            why={
                "b": "it checks the target against the region first.",
                "c": "that is the secant solver's answer near a jump, not here.",
            },
        ),
        meant=Choice(
            "a",
            {
                "a": "the whole region frozen at frame 0: no animation at all",
                "b": "a very fast animation",
            },
            why={"b": "end frame 0 is the first frame: nothing grows."},
        ),
    ),
    hints=["Run it; read the error's message."],
    solution="""
    The optimiser refuses: `target must be >= 10 frames for this region ...: ice spreads
    at most one cell a frame` (10 for the reference region). Converging to
    $\\beta \\approx 1$ would have frozen everything at once, end frame 0: a still
    picture, not frost growing.
    """,
    right={"answer": "a", "meant": "a"},
    wrong={"answer": "b", "meant": "a"},
)

q7 = Question(
    "q7",
    "Using the rings-of-cells estimate ($\\tau = m/\\gamma$ a ring), roughly how many "
    "cells could the paper's region have had, if $\\beta = 0.25$ ended at 160 frames at "
    "$\\gamma = 0.005$?",
    Within(
        1,
        40,
        unit="cells",
        why_high="one ring alone takes about $0.75/0.005 = 150$ frames at these values: "
        "160 frames is about one ring.",
    ),
    hints=["How many frames does one ring take at $\\beta = 0.25$, $\\gamma = 0.005$?"],
    solution="""
    One ring takes about $\\tau \\approx (1 - 0.25)/0.005 = 150$ frames, so 160 frames
    are about one ring: the start point and its six neighbours, a handful of cells
    (7, up to perhaps 19 with part of a second ring). A painted region of hundreds of
    cells would take thousands of frames.
    """,
    right=(7,),
    wrong=(331,),
)

q8 = Question(
    "q8",
    "The paper ends at 90 % of the cells because its descent failed with 100 %. Why do the "
    "last few cells make $T_{sim}$ jumpier?",
    Choice(
        "a",
        {
            "a": "the last cells are isolated pockets that freeze late, each at its own "
            "time, and small changes of beta reorder them: the end frame jumps by many "
            "frames at once",
            "b": "100 % needs more frames, and more frames make the curve smoother",
            "c": "the boundary ring never freezes",
        },
        why={
            "b": "longer, yes; smoother, no: look at the tail of the coverage curve.",
            "c": "the ring is not counted among the cells.",
        },
    ),
    hints=["Look at the coverage curve's tail in section 5."],
    solution="""
    Near 100 % the end waits for the slowest pockets, enclosed cells that live on
    $\\gamma$ alone. When a small change of $\\beta$ lets one of them freeze a step
    sooner or later, or encloses a different pocket, the end frame moves by tens of
    frames at once: bigger flat steps and bigger jumps, so the finite difference is
    zero or huge even more often.
    """,
    right=("a",),
    wrong=("b",),
)

q9 = Question(
    "q9",
    "The sectors interact: raising $\\beta$ in one direction also speeds up its "
    "neighbours. Why does that make `direction_beta` take only part of each Newton step "
    "(it is damped)?",
    Choice(
        "a",
        {
            "a": "each sector's step is computed as if it moved alone; all move at once and "
            "help each other, so full steps overshoot and oscillate",
            "b": "to save time",
            "c": "because Newton's method never converges",
        },
        why={
            "b": "a damped step needs more rounds, not fewer.",
            "c": "it converges fast when the slopes are right; here they are not.",
        },
    ),
    hints=["The slope of each sector is measured with the others held."],
    solution="""
    A Newton step for sector $k$ uses the slope measured when only the uniform
    $\\beta$ changed. When all sectors move together, a sector also gains from its
    neighbours' extra ice, so it moves further than its own step predicted: full steps
    overshoot and the arrivals oscillate. Taking part of the step (and bounding it)
    trades a round or two for stability.
    """,
    right=("a",),
    wrong=("b",),
)

q10 = Question(
    "q10",
    "With `FrostLook(ridges=0)` the ice is a cone, thickest at the start points. Why "
    "(`why`), and which look matches frost on a window pane better (`better`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "the mass $1 + \\gamma(t - f(p))$ grows with the ice's age, and the "
                "oldest ice is at the start points",
                "b": "the start points get more vapour",
            },
            why={"b": "every frozen cell gains exactly gamma a step."},
        ),
        better=Choice(
            "ridges",
            {"ridges": "with ridges (the default)", "cone": "the cone (`ridges=0`)"},
            why={"cone": "frost on glass shows bright branching ridges, not a smooth mound."},
        ),
    ),
    hints=["Section 10's ice mass: which cells froze first?"],
    solution="""
    The thickness follows the ice's age, $m_t(p) = 1 + \\gamma(t - f(p))$: smallest
    freeze frame, thickest ice, and the start points froze first. That is a cone
    around each start. Frost on a pane is a pattern of bright branching needles: the
    default look, which lifts the dendrite arms as ridges, matches it better.
    """,
    right={"why": "a", "better": "ridges"},
    wrong={"why": "a", "better": "cone"},
)

ex1 = Question(
    "ex1",
    "Put the start point off-centre (on a line from the centre to a corner) in a hexagonal "
    "region with $r_{th} = 0$. Does the 60-degree rotation survive (`rotation`)? Does "
    "the mirror across the line through the start point and the centre (`mirror`)?",
    Parts(
        rotation=Truth(False, "the rotation moves the start point: the cell is elsewhere."),
        mirror=Truth(True, "the mirror keeps the start point and the hexagon: check it."),
    ),
    hints=["A symmetry survives when it maps both the region and the start point to themselves."],
    solution="""
    Only the symmetries that fix both the hexagon and the start point survive: no
    rotation, but the mirror across the line through the centre and the start point
    (the cell below checks both with the freeze frames).
    """,
    right={"rotation": False, "mirror": True},
    wrong={"rotation": True, "mirror": True},
)

ex2 = Question(
    "ex2",
    "Run `optimise_beta(..., method='steepest', h=1e-4)` on `reference_setup(0.0)` and read "
    "the message. Which $h$ is the smallest that still converges (try a few between "
    "1e-4 and 0.02)?",
    Within(
        0.0021,
        0.005,
        why_low="at that h T_sim is flat on both sides of beta = 0.25: the descent stalls.",
        why_high="smaller ones converge too: try a few between 0.002 and 0.005.",
    ),
    hints=["Halve h until the message says 'stalled'."],
    solution="""
    On the reference region with seed 0, h = 0.002 stalls (T_sim is flat over
    beta +- 0.002) and h = 0.003 converges: the finite difference must span at least one
    of $T_{sim}$'s steps, which are a few thousandths of $\\beta$ wide here.
    """,
    right=(0.003,),
    wrong=(0.001,),
)


ex3 = Question(
    "ex3",
    "On `reference_setup(0.0)`, measure $dT_{sim}/d\\beta$ (end frames at $\\beta$ = 0.28 "
    "and 0.32) and predict the $\\eta$ that lands on the target in one step, "
    "$2\\eta\\,(dT_{sim}/d\\beta)^2 \\approx 1$. Answer with your $\\eta$.",
    Within(
        2e-6,
        6e-6,
        why_low="too small: check $dT_{sim}/d\\beta$ (a few hundred frames per unit beta).",
        why_high="too large: check $dT_{sim}/d\\beta$ (a few hundred frames per unit beta).",
    ),
    hints=["`grow(lat_ref, starts_ref, p_ref.replace(beta=0.28), seed=0).end_frame`"],
    solution="""
    The end frames are 147 and 132: $dT_{sim}/d\\beta \\approx -375$ frames per unit,
    so $\\eta \\approx 1/(2 \\cdot 375^2) \\approx 3.6 \\times 10^{-6}$. With
    `eta=3e-6` the steepest descent converges in one step (section 7's table).
    """,
    right=(3.6e-6,),
    wrong=(1e-6,),
)

ex4 = Question(
    "ex4",
    "For `HexLattice.hexagon(1)`, $T_{sim} = (1 - \\beta)/\\gamma$ exactly (warm1). At "
    "$\\gamma = 0.005$, which $\\beta$ ends at frame 130 (`beta`)? And why can no "
    "$\\beta < 0.35$ end at 130 (`why`)?",
    Parts(
        beta=Number(lambda: 1 - 130 * _paper().gamma, atol=0.005),
        why=Choice(
            "a",
            {
                "a": "less vapour at the start needs more steps of $\\gamma$: "
                "$(1 - \\beta)/\\gamma > 130$ for every $\\beta < 0.35$",
                "b": "the optimiser cannot go below 0.35",
            },
            why={"b": "it can; the region cannot end sooner with less vapour."},
        ),
    ),
    hints=["Solve $(1 - \\beta)/0.005 = 130$."],
    solution="""
    $\\beta = 1 - 130 \\cdot 0.005 = 0.35$: the paper's $\\beta$. Every frontier cell
    rises by exactly $\\gamma$ a step from $\\beta$; less vapour at the start needs more
    steps, so every $\\beta < 0.35$ ends after 130.
    """,
    right={"beta": 0.35, "why": "a"},
    wrong={"beta": 0.25, "why": "a"},
)

ex5 = Question(
    "ex5",
    "The other reading of Eq. (1) (section 2's first decision): a frontier cell with "
    "$r_t(p) \\le r_{th}$ is treated as not receptive, and its vapour diffuses, also into "
    "the ice. Sketch a frontier cell surrounded by ice. What happens to it?",
    Choice(
        "a",
        {
            "a": "on the steps it misses $\\gamma$ it loses about half its vapour to the ice "
            "around it; at $r_{th} = 0.8$ that is four steps in five, so it never reaches "
            "1 and growth stalls",
            "b": "it freezes sooner: diffusion brings it vapour",
            "c": "nothing changes",
        },
        why={
            "b": "its neighbours are ice, whose b counts 0: diffusion only takes.",
            "c": "the diffusion now drains it into the ice.",
        },
    ),
    hints=["Its six neighbours count 0 in the diffusion; it keeps $1 - \\alpha/2$ of its own."],
    solution="""
    With $\\alpha = 1$ a diffusing cell keeps $1 - \\alpha/2 = 1/2$ of its vapour and
    receives $\\frac{\\alpha}{12}\\sum b(q) = 0$ from its ice neighbours: it halves every
    time it misses $\\gamma$, which at $r_{th} = 0.8$ is four steps in five. It never
    reaches 1: the pockets never freeze and growth stalls near $r_{th} = 0.8$. Hence the
    decision to keep such cells receptive.
    """,
    right=("a",),
    wrong=("b",),
)

q11 = Question(
    "q11",
    "Paint a second, separate blob without a start point (code route: the cell below, "
    "`estimate_end_frame` and `gamma_for_target` on such a region, the calls the app "
    "makes). What does it say (`says`), and why can no $\\gamma$ or $\\beta$ help (`why`)?",
    Parts(
        says=Choice(
            "a",
            {
                "a": "the run never ends (when the blob holds more than a tenth of the "
                "cells): no vapour reaches enough of the region; add a start point in every "
                "piece",
                "b": "it ends later",
            },
            why={"b": "read the estimate: it is infinite."},
        ),
        why=Choice(
            "a",
            {
                "a": "ice grows only from ice, cell to neighbouring cell; the blob is not "
                "connected to any start point, so it never freezes and 90 % is out of reach",
                "b": "the blob has too little vapour",
            },
            why={"b": "more vapour would not help: nothing can start the ice there."},
        ),
    ),
    hints=["Can ice cross unpainted pixels?"],
    solution="""
    `estimate_end_frame` says it never ends (no vapour reaches enough of the region)
    and `gamma_for_target` refuses: the start points cannot reach enough of the region,
    add a start point in every piece. Ice spreads only from ice to neighbouring cells;
    a blob with no start point and no path to one never freezes, and if it holds more
    than a tenth of the cells, 90 % can never be reached. No $\\gamma$ or $\\beta$
    changes connectivity.
    """,
    right={"says": "a", "why": "a"},
    wrong={"says": "b", "why": "a"},
)
