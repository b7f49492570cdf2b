r"""Checks for ``07b_videodb_animation.ipynb``: the MRF assignment, built step by step.

The steps build the MRF of section 5 the way Barba's *12 steps* build a solver: the
energy first (Eq. 4), a two-node problem solved by hand, one sweep of ICM, then the exact
answer by brute force; each check runs the student's function on seeded random MRFs
against :mod:`fluidnb.videodb.assignment` (``energy``, ``brute_force``) and the
invariant the step must keep (an ICM sweep never raises the energy).

============  =================================================================
question      what it asks
============  =================================================================
``step1``     Eq. (4): the energy of a labelling (your function)
``step2``     two nodes by hand: the lambda where smoothness wins (closed)
``step3``     one ICM sweep (your function)
``step4``     brute force over every labelling (your function)
``q1``        why ICM never changes two neighbours at once, and gets stuck
``q2``        which way the water flows without a hint
``q3``        the paper's sigma = 100 on real videos: large or small
``q4``        why the new speed map is smoother than the painted one
``q5``        one global histogram match instead of one per cell
``q6``        travel = 3: why slower, and one single phase
``q7``        the app: lambda or sigma, which moves the map more (code route too)
``ex1``       looks alone: lam = 0
``ex2``       the DC decision: the power of the mean instead of the signed mean
``ex3``       sigma on water, up to 1e6
``ex4``       fewer and more candidates
``ex5``       brute force on 2 x 2 windows with 8 labels
``ex6``       where the looks match nothing: a leaf, a painting of flat blocks
``ex7``       your own video in the database
============  =================================================================
"""

import itertools

import numpy as np

from ._core import Choice, Code, Number, Parts, Question, Within

__all__ = [
    "ex1",
    "ex2",
    "ex3",
    "ex4",
    "ex5",
    "ex6",
    "ex7",
    "q1",
    "q2",
    "q3",
    "q4",
    "q5",
    "q6",
    "q7",
    "step1",
    "step2",
    "step3",
    "step4",
]


def _problem(seed, rows=2, cols=3, k=4):
    """A random MRF on a small grid: unary (P, K), pairwise (E, K, K), edges (E, 2)."""
    from fluidnb.videodb.assignment import grid_edges

    rng = np.random.default_rng(seed)
    _, edges, _ = grid_edges(np.ones((rows, cols), bool))
    unary = rng.random((rows * cols, k))
    pairwise = rng.random((len(edges), k, k)) * 2
    return unary, pairwise, edges, 0.7


def _energy(labels, unary, pairwise, edges, lam):
    from fluidnb.videodb.assignment import energy

    return energy(np.asarray(labels), unary, pairwise, edges, lam)


def _judge_energy(fn):
    for seed in range(3):
        unary, w, edges, lam = _problem(seed)
        labels = np.random.default_rng(seed + 10).integers(0, unary.shape[1], len(unary))
        got, want = float(fn(labels, unary, w, edges, lam)), _energy(labels, unary, w, edges, lam)
        if not np.isclose(got, want, rtol=1e-9, atol=1e-12):
            data = float(unary[np.arange(len(unary)), labels].sum())
            if np.isclose(got, data):
                return False, "that is the data term alone: add lam times the sum of W over edges."
            return False, f"E = {got:.6g}, the library's energy gives {want:.6g} (seed {seed})."
    return True, "Eq. (4), as the library computes it."


def _ref_icm_sweep(labels, unary, w, edges, lam):
    labels = np.array(labels)
    for p in range(len(unary)):
        cost = unary[p].copy()
        for e, (a, b) in enumerate(edges):
            if a == p:
                cost += lam * w[e, :, labels[b]]
            elif b == p:
                cost += lam * w[e, labels[a], :]
        labels[p] = int(np.argmin(cost))
    return labels


def _judge_icm(fn):
    for seed in range(3):
        unary, w, edges, lam = _problem(seed)
        start = np.argmin(unary, axis=1)
        got = np.asarray(fn(start.copy(), unary, w, edges, lam))
        if got.shape != start.shape:
            return False, f"return one label per node: shape {start.shape}, got {got.shape}."
        want = _ref_icm_sweep(start, unary, w, edges, lam)
        e_got, e_start = (_energy(x, unary, w, edges, lam) for x in (got, start))
        if e_got > e_start + 1e-12:
            return False, f"the energy rose from {e_start:.4g} to {e_got:.4g}: ICM never does."
        if not np.array_equal(got, want):
            return False, (
                "a different labelling than one sweep in node order 0, 1, ..., P-1, each node "
                "taking the label that minimises V_p + lam * W with its neighbours' *current* "
                "labels (update as you go)."
            )
    return True, "one sweep of ICM; the energy can only fall."


def _judge_brute(fn):
    from fluidnb.videodb.assignment import brute_force

    for seed in range(2):
        unary, w, edges, lam = _problem(seed, rows=2, cols=2, k=3)
        got = fn(unary, w, edges, lam)
        if not (isinstance(got, tuple) and len(got) == 2):
            return False, "return `(labels, energy)`."
        labels, e = got
        _, best = brute_force(unary, w, edges, lam)
        if not np.isclose(float(e), best):
            return False, f"your minimum {float(e):.6g}, the exact one {best:.6g} (seed {seed})."
        if not np.isclose(_energy(labels, unary, w, edges, lam), best):
            return False, "the labels you return do not have the energy you return."
    return True, "the exact minimum, as the library's brute_force finds it."


step1 = Question(
    "step1",
    "Write Eq. (4) as a function `my_energy(labels, unary, W, edges, lam)`: the data term "
    "$\\sum_p V_p(l_p)$ (`unary[p, labels[p]]`) plus $\\lambda$ times the smoothness "
    "$\\sum_{(p, q)} W_{pq}(l_p, l_q)$ (`W[e, labels[p], labels[q]]` for edge `e = (p, q)`).",
    Code(_judge_energy, "my_energy(labels, unary, W, edges, lam) -> float"),
    hints=[
        "`unary[np.arange(len(labels)), labels].sum()` is the data term.",
        "`p, q = edges[:, 0], edges[:, 1]`; "
        "`W[np.arange(len(edges)), labels[p], labels[q]].sum()`.",
    ],
    solution="""
    ```python
    def my_energy(labels, unary, W, edges, lam):
        labels = np.asarray(labels)
        data = unary[np.arange(len(labels)), labels].sum()           # sum_p V_p(l_p)
        p, q = edges[:, 0], edges[:, 1]
        smooth = W[np.arange(len(edges)), labels[p], labels[q]].sum()  # sum W_pq
        return data + lam * smooth                                     # Eq. (4)
    ```
    """,
    right=(_energy,),
    wrong=(lambda labels, u, w, e, lam: float(u[np.arange(len(labels)), labels].sum()),),
)

step2 = Question(
    "step2",
    "Two neighbours $p, q$ with two labels each: $V_p = (0, 0.3)$, $V_q = (0.2, 0)$, and "
    "$W(l_p, l_q) = 0$ when $l_p = l_q$, 1 otherwise. For small $\\lambda$ the best "
    "labelling is each node's best-looking label, $(0, 1)$. Above which $\\lambda$ does a "
    "smooth labelling win?",
    Number(0.2, atol=1e-6),
    hints=["Write $E$ for (0, 1), (0, 0) and (1, 1) as functions of $\\lambda$."],
    solution="""
    $E(0, 1) = 0 + 0 + \\lambda$, $E(0, 0) = 0 + 0.2$, $E(1, 1) = 0.3 + 0$,
    $E(1, 0) = 0.5 + \\lambda$. The smooth $(0, 0)$ beats $(0, 1)$ when
    $0.2 < \\lambda$: above **0.2** neighbours agree, at the cost of $q$'s looks. That is
    what $\\lambda$ trades, fragment by fragment, on the whole photo.
    """,
    right=(0.2,),
    wrong=(0.3,),
)

step3 = Question(
    "step3",
    "Write one sweep of ICM, `icm_sweep(labels, unary, W, edges, lam)`: visit the nodes in "
    "order 0, 1, ..., P-1 and give each the label that minimises "
    "$V_p(l) + \\lambda \\sum_{q} W_{pq}(l, l_q)$ with its neighbours' labels as they are "
    "now (update as you go); return the labels.",
    Code(_judge_icm, "icm_sweep(labels, unary, W, edges, lam) -> labels"),
    hints=[
        "For node p, start from `cost = unary[p].copy()`; for every edge e = (a, b) with "
        "a == p add `lam * W[e, :, labels[b]]`, with b == p add `lam * W[e, labels[a], :]`.",
        "`labels[p] = np.argmin(cost)`, then the next node.",
    ],
    solution="""
    ```python
    def icm_sweep(labels, unary, W, edges, lam):
        labels = np.array(labels)
        for p in range(len(unary)):
            cost = unary[p].copy()
            for e, (a, b) in enumerate(edges):
                if a == p:
                    cost += lam * W[e, :, labels[b]]   # p's label varies, q's fixed
                elif b == p:
                    cost += lam * W[e, labels[a], :]
            labels[p] = np.argmin(cost)
        return labels
    ```
    Each visit can only lower $E$ (the old label is among the choices), so the energy
    never rises; it stops where no *single* change helps.
    """,
    right=(_ref_icm_sweep,),
    wrong=(lambda labels, u, w, e, lam: np.argmax(u, axis=1),),
)


def _ref_brute(unary, w, edges, lam):
    best = None
    for labels in itertools.product(range(unary.shape[1]), repeat=len(unary)):
        e = _energy(labels, unary, w, edges, lam)
        if best is None or e < best[1]:
            best = (np.array(labels), e)
    return best


step4 = Question(
    "step4",
    "Write the exact minimum by trying every labelling, `my_brute_force(unary, W, edges, "
    "lam) -> (labels, energy)`, with `itertools.product(range(K), repeat=P)` and your "
    "`my_energy`. How many labellings does a 2 x 3 window with 5 labels have?",
    Code(_judge_brute, "my_brute_force(unary, W, edges, lam) -> (labels, energy)"),
    hints=["Keep the labelling with the lowest energy so far."],
    solution="""
    ```python
    def my_brute_force(unary, W, edges, lam):
        best = None
        for labels in itertools.product(range(unary.shape[1]), repeat=len(unary)):
            e = my_energy(np.array(labels), unary, W, edges, lam)
            if best is None or e < best[1]:
                best = (np.array(labels), e)
        return best
    ```
    $K^P$ labellings: $5^6 = 15\\,625$ for a 2 x 3 window; the whole photo's
    $100^{300}$ is why the paper needs graph cuts.
    """,
    right=(_ref_brute,),
    wrong=(
        lambda u, w, e, lam: (np.argmin(u, axis=1), _energy(np.argmin(u, axis=1), u, w, e, lam)),
    ),
)

q1 = Question(
    "q1",
    "Why does a single ICM step never change two neighbours at once, and why can that leave "
    "it stuck where an expansion move is not?",
    Choice(
        "a",
        {
            "a": "it changes one node with all others fixed; if two neighbours must switch "
            "together to the same new label (each alone would disagree with the other), no "
            "single change helps, while an expansion lets any set of nodes switch to label "
            "alpha at once",
            "b": "ICM changes all nodes at once",
            "c": "ICM is stuck because the graph cut fails",
        },
        why={
            "b": "it visits one node at a time.",
            "c": "ICM uses no graph cut.",
        },
    ),
    hints=["Think of step2 with $\\lambda$ large, starting from (0, 1)."],
    solution="""
    An ICM step re-labels one node with its neighbours fixed. In step2's problem at
    $\\lambda = 1$, from $(0, 1)$: switching $p$ alone to 1 gives $E(1, 1) = 0.3$, an
    improvement, but with other tables a single switch can cost more than the pair
    switching together would save. An expansion move lets every node that benefits
    switch to label $\\alpha$ at once, found exactly by one minimum cut.
    """,
    right=("a",),
    wrong=("b",),
)

q2 = Question(
    "q2",
    "Without any hint from the user, which way does the water flow in the assignment?",
    Choice(
        "b",
        {
            "a": "down the stream, as it should: the looks give the direction",
            "b": "not consistently down: calm water looks alike whichever way it flows, so "
            "the looks leave the direction open, as the paper warns",
            "c": "not at all: every fragment stands still",
        },
        why={
            "a": "look at the arrows of the assignment figure: they do not all point down.",
            "c": "the arrows show motion.",
        },
    ),
    hints=["The arrows in section 6's left picture."],
    solution="""
    The arrows do not agree on *down the stream*: a texture of ripples looks the same
    flowing either way (the database holds flipped and rotated copies), so the looks
    alone leave the direction ambiguous, as the paper says of calm water. A stroke
    (section 8) settles it.
    """,
    right=("b",),
    wrong=("a",),
)

q3 = Question(
    "q3",
    "The paper's videos are real: splashes and spray have power at every frequency. Would "
    "its $\\sigma = 100$ be large or small there (`size`)? How would you measure it on your "
    "own database (`measure`)?",
    Parts(
        size=Choice(
            "smaller",
            {
                "smaller": "smaller than on our synthetic water: the other frequencies weigh "
                "more in the tables, so the crossover dc/rest is lower",
                "larger": "larger",
            },
            why={"larger": "more power in the changes makes `rest` larger: dc/rest falls."},
        ),
        measure=Choice(
            "a",
            {
                "a": "the medians of the DC and the other-frequency tables: they are equal at "
                "sigma = dc / rest (section 7's last cell)",
                "b": "count the fragments",
            },
            why={"b": "the crossover is a ratio of the two parts of Eq. (2)."},
        ),
    ),
    hints=["Section 7's last cell printed where the two parts of Eq. (2) are equal."],
    solution="""
    With real splashes the other frequencies carry much more power, so `rest` is larger
    and the crossover $\\sigma = \\mathrm{dc}/\\mathrm{rest}$ lower: the paper's 100 sits
    nearer it than on our steady synthetic water. Measure it as section 7 does: the
    medians of the two tables of your database's assignment.
    """,
    right={"size": "smaller", "measure": "a"},
    wrong={"size": "larger", "measure": "a"},
)

q4 = Question(
    "q4",
    "Why is the new result's speed map smoother than the one we painted?",
    Choice(
        "a",
        {
            "a": "the speed is compared per fragment (48 x 48, the painted map averaged over "
            "it) and only within a factor `max_speed_ratio`; and the assigned motions are "
            "blended over the overlapping fragments' weights",
            "b": "the painted map is blurred before painting",
            "c": "the MRF ignores the speed",
        },
        why={
            "b": "paint_disk paints a sharp disc.",
            "c": "it filters candidates by speed (section 8).",
        },
    ),
    hints=["At what resolution does the assignment see the speed?"],
    solution="""
    Two reasons: each fragment's candidates are filtered by the *mean* painted speed
    over its 48 x 48 area, within a factor 2, so the painted edge is averaged; and the
    result's speed map blends the chosen fragments' mean motions with the overlapping
    bumps of the rendering, which smooths again.
    """,
    right=("a",),
    wrong=("c",),
)

q5 = Question(
    "q5",
    "The histogram matching is done per cell of 48 x 48 pixels. What would a single, "
    "global match do to the dark pools and the white cascades?",
    Choice(
        "a",
        {
            "a": "it would match the whole water's brightness at once: dark pools could take "
            "bright values and cascades dark ones, wherever the animation's own brightness "
            "ranks them; per cell each part keeps its own range",
            "b": "nothing different",
            "c": "it would make everything grey",
        },
        why={
            "b": "a global match fixes only the overall distribution, not where it goes.",
            "c": "a histogram match keeps the photo's range.",
        },
    ),
    hints=["A global match preserves the overall histogram. Does it preserve where?"],
    solution="""
    One global match maps ranks over the whole water: the overall distribution is the
    photo's, but a pool whose animated pixels happen to rank high turns bright, and a
    cascade can darken. Matching per cell keeps each area's own distribution: pools
    stay dark, cascades white.
    """,
    right=("a",),
    wrong=("b",),
)

q6 = Question(
    "q6",
    "With `travel=3` (the cell measures it), why is the measured speed lower, although "
    "every phase still moves at $v$ (`why`)? What would go wrong with one single phase "
    "advected for the whole clip (`single`)?",
    Parts(
        why=Choice(
            "a",
            {
                "a": "the phases restart every few frames, and each cross-fade hands over from "
                "the phase ahead to the one behind: seen as a jump backwards that cancels part "
                "of the forward motion",
                "b": "the phases move at a lower speed",
            },
            why={"b": "each phase moves at v; measure the handovers."},
        ),
        single=Choice(
            "a",
            {
                "a": "it stretches and smears more and more, and the clip cannot loop",
                "b": "nothing: it would be better",
            },
            why={"b": "advected for seconds, a texture is sheared beyond recognition."},
        ),
    ),
    hints=["How often does a phase restart with travel = 3 at about 1 px/frame?"],
    solution="""
    Each phase carries the photo at most `travel` pixels before it restarts. With 3 px
    the restarts come every few frames, and each cross-fade from the phase ahead to the
    one behind looks like a step backwards, which the eye and the optical flow average
    with the forward motion: the measured speed drops. A single phase advected for the
    whole clip never restarts: the photo is sheared and stretched without end, and the
    last frame cannot join the first.
    """,
    right={"why": "a", "single": "a"},
    wrong={"why": "b", "single": "a"},
)

q7 = Question(
    "q7",
    "In the app move $\\lambda$ from 0.001 to 10, then $\\sigma$ from 1 to 1000 (code route: "
    "the cell re-solves the stream's assignment, `a.resolve`, as the app does). Which "
    "changes the map more (`more`)? Does that agree with the paper's *lambda matters "
    "little* on our stream (`paper`)?",
    Parts(
        more=Choice(
            "sigma",
            {"lam": "lambda", "sigma": "sigma"},
            why={"lam": "compare the printed fractions of changed fragments."},
        ),
        paper=Choice(
            "b",
            {
                "a": "yes, lambda changes nothing on the stream",
                "b": "partly: sigma changes more, but lambda still changes a share of the "
                "stream's fragments (printed): how little lambda matters depends on the photo "
                "and the database (section 7)",
            },
            why={"a": "read the fractions printed for lambda on the stream."},
        ),
    ),
    hints=["Read the two printed lines: lambda's and sigma's changed fractions."],
    solution="""
    $\\sigma$ changes the map more (it decides whether the mean motion counts at all).
    But $\\lambda$ is not negligible on our stream: above the paper's 0.01 a share of
    the fragments still changes. How large a share depends on the photo and the
    database: with the quick starter databases far more of the stream's fragments change
    than of the clouds' (none), with the full ones few of either, the clouds' a few more
    (section 7's last cell prints both). The paper's *lambda matters little* is a
    statement about its videos, not a law.
    """,
    right={"more": "sigma", "paper": "b"},
    wrong={"more": "lam", "paper": "b"},
)

ex1 = Question(
    "ex1",
    "Re-solve without the smoothness term (`a.resolve(lam=0)`, the cell does it). What "
    "happens to the motion's coherence?",
    Choice(
        "falls",
        {
            "falls": "it falls: each fragment takes its best-looking candidate, neighbours "
            "move every which way, which is why the paper needs the smoothness term",
            "same": "nothing changes",
        },
        why={"same": "compare the printed coherences."},
    ),
    hints=["`motion_coherence()` of both."],
    solution="""
    With $\\lambda = 0$ each fragment takes the argmin of $V_p$: the best-looking
    candidate, whatever its motion. The coherence falls: the water moves every which
    way. Looks alone cannot make neighbours flow together: the smoothness term does.
    """,
    right=("falls",),
    wrong=("same",),
)

ex2 = Question(
    "ex2",
    "The DC decision: with the *power* of the mean motion instead of the signed mean in "
    "Eq. (2)'s DC term, for which neighbours would the paper's version go wrong?",
    Choice(
        "a",
        {
            "a": "neighbours flowing in opposite directions at the same speed (east and "
            "west): the power is the same, the DC term 0, so they look perfectly smooth",
            "b": "neighbours flowing the same way",
            "c": "none",
        },
        why={
            "b": "those are rightly smooth in both versions.",
            "c": "compute it for `east` and `west`.",
        },
    ),
    hints=["$|{\\bar u}|^2$ of east and of west: equal?"],
    solution="""
    The power $|\\bar u|^2$ forgets the sign: a fragment flowing east and one flowing west
    at the same speed have equal power, so their DC difference is 0 and the MRF sees
    them as a perfect match. With the signed mean the difference is $|2\\bar u|^2$:
    opposite flows are penalised, as they should be.
    """,
    right=("a",),
    wrong=("c",),
)

ex3 = Question(
    "ex3",
    "Repeat section 7's $\\sigma$ sweep on the stream with the water database, up to "
    "$\\sigma = 10^6$ (the cell does it, and prints each $\\sigma$ against the crossover "
    "$\\mathrm{dc}/\\mathrm{rest}$ of section 7). From which $\\sigma$ on does the "
    "coherence fall below 0.6? Answer with $\\log_{10}(\\sigma / \\mathrm{crossover})$ "
    "(the printed power of ten).",
    Within(
        0.0,
        2.5,
        why_low="below the crossover the mean motion still rules: the coherence holds.",
        why_high="look again: it falls sooner.",
    ),
    hints=["The first printed line whose coherence is below 0.6; read its power of ten."],
    solution="""
    The coherence holds while $\\sigma\\,\\mathrm{rest}$ is small against $\\mathrm{dc}$,
    and falls once $\\sigma$ passes the crossover by a decade or so: then the changes of
    the motion rule and the mean motion is ignored, the paper's "random motion". (Below
    the paper's 100 fragments change too, but among candidates that still flow
    together.)
    """,
    right=(1.3,),
    wrong=(-2.0,),
)

ex4 = Question(
    "ex4",
    "Assign the stream with `candidates=10`, then more (the cell runs 10, $K$ and 200, or "
    "the quick database's size). How does the energy change with more candidates?",
    Choice(
        "a",
        {
            "a": "it falls: the labels for fewer candidates are among those for more, so "
            "there are more choices; and the tables take longer ($K^2$ pairs per edge)",
            "b": "the energy rises with more candidates",
        },
        why={
            "b": "read the energies the cell prints: the labels for K = 10 are among the others'."
        },
    ),
    hints=["The labels for K = 10 are among those for K = 200."],
    solution="""
    With more candidates the label sets grow (the top 10 are among the top 200), so the
    exact optimum can only fall, and the solver finds lower energies (measured in quick
    mode on the stream: E = 1156, 440, 368 for K = 10, 40, 100). The tables grow as
    $K^2$ per edge, 100 times more pairs from 10 to 100: a fraction of a second to about
    a second here, against the paper's half hour for 100.
    """,
    right=("a",),
    wrong=("b",),
)

ex5 = Question(
    "ex5",
    "Repeat the tiny problems of section 5 with 2 x 2 windows and 8 labels (the cell does "
    "it). Is `solve` (the better of the expansions from two starts) ever worse than "
    "alpha-expansion alone?",
    Choice(
        "no",
        {"no": "no: it keeps the lower energy of both", "yes": "yes, sometimes"},
        why={"yes": "it returns the lower of the two runs' energies."},
    ),
    hints=["What does `solve` keep?"],
    solution="""
    Never: `solve` runs ICM, expands from both the argmin and ICM's result, and keeps the
    lower energy, so it is at least as good as either run.
    """,
    right=("no",),
    wrong=("yes",),
)

ex6 = Question(
    "ex6",
    "Where the looks match nothing: the cell assigns the stream, the leaf (not water) and "
    "a painting of flat blocks with the water database, and prints each one's mean "
    "$V_p$ of the best candidates and the share of fragments that share their candidate "
    "list. What do the numbers show?",
    Choice(
        "a",
        {
            "a": "the leaf's best candidates are as close as the stream's (Eq. (1) compares "
            "the texture of the gradients, not whether the picture shows water, so nothing "
            "warns you); in the painting's flat blocks most fragments get the very same "
            "candidate list, so the looks cannot tell those places apart",
            "b": "the leaf and the painting get clearly worse candidates (a larger $V_p$) "
            "than the stream: the distances show where the looks match nothing",
            "c": "every fragment of all three gets a candidate list of its own, as on the stream",
        },
        why={
            "b": "compare the printed $V_p$ of the leaf with the stream's.",
            "c": "read the painting's printed share.",
        },
    ),
    hints=[
        "Eq. (1) ranks by histograms of visual words, words of dense SIFT: of gradients.",
        "What are the visual words of a fragment that lies inside one flat block?",
    ],
    solution="""
    Eq. (1) always returns $K$ candidates, and what it compares is the texture of the
    gradients (visual words of dense SIFT), not what the picture shows: the leaf finds
    database fragments as close as the stream's water does, so $V_p$ does not warn you
    that a picture is not water. In a painting, the flat areas are where the looks say
    nothing: a fragment inside a flat block has no gradients, so its words, its
    candidates and its $V_p$ are those of every other fragment there; which video moves
    which place is left to the smoothness term (and your strokes), and one motion,
    whichever, spreads over the flat area (the map: parallel arrows). The painting's
    $V_p$ rises too on the small quick database, but the leaf shows that a low $V_p$
    does not mean the picture is water.

    The paper's worst result, Fig. 11-d (an abstract oil painting of smoke with large
    flat areas), failed, its authors say, for the first reason: the candidates could
    not be chosen well in the flat areas; and its chosen fragments moved randomly at
    small scale although the direction and speed maps set the overall flow. Here the
    MRF keeps the painting's motion coherent instead (compare the printed coherence
    with the stream's): the same missing information, another symptom, a motion that
    nothing in the picture chose.
    """,
    right=("a",),
    wrong=("b", "c"),
)

ex7 = Question(
    "ex7",
    "Animate the stream with the database that holds your own video (after 07a's exercise "
    "2). Does the MRF keep fragments of your video where they are chosen by their looks?",
    Choice(
        "a",
        {
            "a": "only where their motion also agrees with the neighbours': isolated "
            "good-looking fragments are replaced when the smoothness term outweighs the looks",
            "b": "always",
        },
        why={"b": "the smoothness term can overrule the looks."},
    ),
    hints=["Compare `a.resolve(lam=0)` with the default."],
    solution="""
    Where your video's fragments look best and move like their neighbours, the MRF keeps
    them. An isolated fragment that moves differently from its neighbours is replaced
    when $\\lambda W$ outweighs its advantage in looks.
    """,
    right=("a",),
    wrong=("b",),
)
