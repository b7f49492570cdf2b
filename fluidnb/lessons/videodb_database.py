r"""Checks for ``07a_videodb_database.ipynb``: the video database and the search (Eq. 1).

============  =================================================================
question      what it asks
============  =================================================================
``warm1``     fragments per clip version: corners 24 px apart (closed)
``q1``        why 50 % and rotated versions give fewer fragments
``q2``        why difference frames without colour are what we copy
``warm2``     the pyramid histogram's total, 324 (closed)
``q3``        fragments of 16 x 16 and 256 x 256; ties in the ranking
``q4``        which term of Eq. (2) dominates at sigma = 100 here
``q5``        rank 1 of K, and a small K (the app, and in code)
``ex1``       a flipped query
``ex2``       your own video
============  =================================================================
"""

from ._core import Choice, Number, Parts, Question, Truth

__all__ = ["ex1", "ex2", "q1", "q2", "q3", "q4", "q5", "warm1", "warm2"]

q1 = Question(
    "q1",
    "The 50 % versions give far fewer fragments than the 100 % ones, and the rotated ones "
    "fewer than the upright ones. Why?",
    Choice(
        "a",
        {
            "a": "a half-size picture has a quarter of the area, so about a quarter of the "
            "48 x 48 fragments fit; a rotated picture has empty corners, and a fragment "
            "must lie wholly inside the picture",
            "b": "the smaller versions move less",
        },
        why={"b": "the motion is scaled, but the count comes from the area."},
    ),
    hints=["Count 48 x 48 squares in a picture half as wide and half as tall."],
    solution="""
    The fragments keep their size (48 x 48), so a picture scaled to 50 % holds about a
    quarter as many. Rotating leaves dark corners outside the picture; fragments that
    would reach into them are not cut.
    """,
    right=("a",),
    wrong=("b",),
)

warm1 = Question(
    "warm1",
    "Fragments are 48 x 48 pixels with corners 24 pixels apart. How many fit, wholly inside, "
    "in a 240 x 144 picture (columns x rows)?",
    Number(((240 - 48) // 24 + 1) * ((144 - 48) // 24 + 1), atol=0.01, unit="fragments"),
    hints=["Along an axis of length L: (L - 48) // 24 + 1 corners."],
    solution="$((240 - 48)/24 + 1) \\times ((144 - 48)/24 + 1) = 9 \\times 5 = 45$.",
    right=(45,),
    wrong=(60,),
)

q2 = Question(
    "q2",
    "The difference frames carry no colour, only how the brightness changes. Why is that "
    "exactly what we copy onto a photo of *another* scene?",
    Choice(
        "a",
        {
            "a": "the photo keeps its own colours and appearance; only the motion, the "
            "changes, come from the video, which was filmed elsewhere",
            "b": "colour would be too expensive",
        },
        why={"b": "it is about whose colours the result has, not cost."},
    ),
    hints=["Whose colours should the animated photo have?"],
    solution="""
    The video's mean image $A$ has the video's colours, another river's. Adding only
    $D_i = F_i - A$ to (a blurred version of) the photo moves the photo's own colours:
    the motion comes from the video, the look from the photo.
    """,
    right=("a",),
    wrong=("b",),
)

warm2 = Question(
    "warm2",
    "A 9 x 9 word map, counted in a spatial pyramid with levels 0, 1, 2 weighted 1, 1, 2: "
    "what is the total of every histogram (the 324 of Eq. 1)?",
    Number(81 * (1 + 1 + 2), atol=0.01),
    hints=["Each level counts all 81 words once, times its weight."],
    solution="Each level counts all $9 \\times 9 = 81$ words: $81 (1 + 1 + 2) = 324$.",
    right=(324,),
    wrong=(81,),
)

q3 = Question(
    "q3",
    "What would be lost with fragments of 16 x 16 pixels (`small`), and with 256 x 256 (`large`)?",
    Parts(
        small=Choice(
            "a",
            {
                "a": "too little to describe: a 16 x 16 patch holds few gradients, SIFT and "
                "the motion say little, and many unrelated pieces match",
                "b": "nothing",
            },
            why={"b": "a 9 x 9 SIFT grid needs room."},
        ),
        large=Choice(
            "a",
            {
                "a": "reuse: a large fragment must match a large part of the photo, so a few "
                "videos no longer go far, and its motion cannot vary across it",
                "b": "nothing",
            },
            why={"b": "the point of small fragments is reuse."},
        ),
    ),
    hints=["Small: what can be described? Large: what can be matched?"],
    solution="""
    Tiny fragments hold too little structure for SIFT and the spectra: matches become
    arbitrary. Huge ones must match the photo over a large area, so few database
    fragments fit anywhere and the motion is one piece. (For ties, rank by a second key
    that does not depend on the order, e.g. the score then the fragment's id, or a
    fixed random tie-break.)
    """,
    right={"small": "a", "large": "a"},
    wrong={"small": "b", "large": "a"},
)

q4 = Question(
    "q4",
    "In the spectra plot the DC diamond is far above the other bins. With $\\sigma = 100$, "
    "which term of Eq. (2) do you expect to dominate for our databases?",
    Choice(
        "dc",
        {
            "dc": "the DC term (the mean motion), unless sigma is very large",
            "rest": "the other frequencies",
        },
        why={"rest": "compare the sizes: DC is orders of magnitude above; 07b measures it."},
    ),
    hints=["07b, section 7, prints the two parts' medians and where they are equal."],
    solution="""
    The DC term: our synthetic water moves with almost nothing but a mean, so the other
    bins are tiny, and even $\\sigma = 100$ leaves the mean motion in charge (in 07b the
    two parts are equal only at $\\sigma$ of a few hundred, quick, or a few dozen, full;
    smoke has less power outside DC still).
    """,
    right=("dc",),
    wrong=("rest",),
)

q5 = Question(
    "q5",
    "How many fragments got their best-looking candidate, rank 1 of $K$ (in the app: click; "
    "in code: the cell, `a.labels == 0`): all of them (`all_rank1`, True or False)? Why "
    "would the MRF ever take one that looks worse (`why`)? What does a small $K$ take away "
    "(`small_k`)?",
    Parts(
        all_rank1=Truth(
            False,
            why="the cell prints the share at rank 1: well under 100 % for both K, the MRF "
            "gives up some looks for neighbours that move alike.",
        ),
        why=Choice(
            "a",
            {
                "a": "a slightly worse-looking candidate that moves like its neighbours lowers "
                "the smoothness term more than it raises the data term",
                "b": "by mistake",
            },
            why={"b": "the MRF minimises looks plus smoothness together."},
        ),
        small_k=Choice(
            "a",
            {
                "a": "choice: the chosen fragments rank higher only because there are fewer; "
                "the MRF has fewer candidates among which to trade looks for agreement",
                "b": "nothing",
            },
            why={"b": "fewer labels, fewer ways to agree."},
        ),
    ),
    hints=["Eq. (4): V_p plus lambda times W."],
    solution="""
    Only a few of the fragments keep rank 1: the MRF trades a little of $V_p$ for
    neighbours that move alike ($\\lambda W$). With $K = 10$ more of the chosen ones rank
    1 (there is less to choose from), but the MRF has fewer ways to make neighbours agree:
    the cell prints the coherence for both, and with the full databases it falls by almost
    half on the stream (with quick mode's small databases it barely changes: there the
    few candidates are much the same for both $K$).
    """,
    right={"all_rank1": False, "why": "a", "small_k": "a"},
    wrong={"all_rank1": True, "why": "a", "small_k": "a"},
)

ex1 = Question(
    "ex1",
    "Flip a fragment's mean image left-right and search with it (the cell prints the best "
    "$I$). Does it find a fragment with $I = 1$?",
    Choice(
        "b",
        {
            "a": "always: the database holds every clip flipped",
            "b": "usually not: the flipped version is cut on its own 24-pixel grid from the "
            "flipped picture's left edge, which lands on the mirror image of this fragment "
            "only when the picture's width allows; the best match is a near one",
        },
        why={
            "a": "read the printed I: the flipped clip is there, the exact mirrored cut "
            "usually is not."
        },
    ),
    hints=["Where are the flipped version's fragments cut, and where is the mirror image?"],
    solution="""
    The flipped clip is in the database, but its fragments start at its own left edge,
    every 24 pixels. The mirror image of a fragment at column $c$ sits at
    $W - 48 - c$, on that grid only if $W - 48 - c$ is a multiple of 24. Usually it is
    not, and the best match scores well below 1 (yet the flipped versions still give
    the search and the MRF mirrored motions to choose from).
    """,
    right=("b",),
    wrong=("a",),
)

ex2 = Question(
    "ex2",
    "Add a few seconds of your own running water (fixed camera) to a copy of the database "
    "and search with the stream's fragments. What decides whether they find it?",
    Choice(
        "a",
        {
            "a": "its looks (Eq. 1): fragments of your video must share visual words with the "
            "photo's; a fixed camera and a mean flow make it useful later for the MRF",
            "b": "its length only",
        },
        why={"b": "the search ranks by looks."},
    ),
    hints=["The search is Eq. (1)."],
    solution="""
    The search ranks by histogram intersection of visual words: your clip's fragments are
    found where they look like the photo's. The paper's conditions (fixed camera, the
    fluid as the subject, a mean flow) decide whether its motion is then worth copying.
    """,
    right=("a",),
    wrong=("b",),
)
