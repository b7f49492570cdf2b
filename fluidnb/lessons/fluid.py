r"""Checks for ``04_fluid_solver.ipynb``: Stable Fluids for flames, built step by step.

The steps (``step1`` ... ``step7``) build one solver step the way Barba's *12 steps to
Navier-Stokes* builds its solver: one term at a time, each a small closed task whose
check runs the student's function on a seeded case against the readable reference
(:mod:`fluidnb.fluid._reference`) and the invariant the term must keep (a convex
combination, a zero divergence, an exact cooling law).

============  =================================================================
question      what it asks
============  =================================================================
``q1``        Eq. (3) has no diffusion: what blurs a hot spot anyway
``q2``        the faces the bottom-right cell's divergence reads
``step1``     the semi-Lagrangian advection of one centred field (your function)
``step2``     its weights in 1-D: why it is stable for any time step (closed)
``q3``        a face near the open top that backtraces above the grid
``step3``     buoyancy, Eq. (4), on the faces (your function)
``q4``        where confinement pushes hardest, and what the unit N does
``step4``     the divergence on the staggered grid (your function)
``step5``     the projection: subtract the pressure's gradient (your function)
``q5``        the closed box's free constant in the pressure
``step6``     the cooling of Eq. (3) integrated exactly over a step (your function)
``step7``     the whole step, without the source, from your pieces (your function)
``q6``        why the temperature feels the pressure
``q7``        what bounds the enstrophy under confinement
``q8``        why not explicit Euler for the cooling
``q9``        the seed of a simulation
``q10``       smoke at the top of a closed box
``ex1``       buoyancy doubled and halved; keeping the height with C_r
``ex2``       confinement from 0 to 1.5
``ex3``       ten steps without the projection
``ex4``       the flame in a closed box
``ex5``       the hottest cell's drop in one step: 0.0192, not 0.02
``ex6``       four substeps a frame: what changes, and why
============  =================================================================
"""

import numpy as np

from ._core import Choice, Code, Number, Parts, Question, Truth, Within, close

__all__ = [
    "ex1",
    "ex2",
    "ex3",
    "ex4",
    "ex5",
    "ex6",
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
    "step1",
    "step2",
    "step3",
    "step4",
    "step5",
    "step6",
    "step7",
]


# ------------------------------------------------------------------ the test case


def _ref():
    """The readable solver, imported when a check first needs it."""
    from fluidnb.fluid import _reference

    return _reference


def _fluid():
    import fluidnb.fluid

    return fluidnb.fluid


def _ref_step(u, T, p):
    s = _ref().step(_fluid().FluidState(u, T, np.zeros_like(T)), p)
    return s.velocity, s.temperature


def _case(shape=(12, 16), seed=3, projected=True):
    """A seeded smooth velocity (px/frame) and temperature on a small grid."""
    from fluidnb.fluid import _reference as ref

    rng = np.random.default_rng(seed)
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w] / max(h, w)
    u = np.zeros((h, w, 2))
    u[..., 0] = 0.8 * np.sin(3 * xx + rng.uniform(0, 6)) * np.cos(2 * yy) - 0.4
    u[..., 1] = 0.7 * np.cos(2 * yy + rng.uniform(0, 6)) * np.sin(3 * xx)
    u[:, 0, 1] = 0.0
    if projected:
        u, _ = ref.project(u)
    T = np.exp(-((yy - 0.5) ** 2 + (xx - 0.4) ** 2) / 0.05) + 0.1 * rng.random(shape)
    return u, T


def _compare(got, want, what):
    got = np.asarray(got, dtype=float)
    if got.shape != want.shape:
        return False, f"it returned shape {got.shape}; {what} is {want.shape}."
    if close(got, want, rtol=1e-9, atol=1e-11):
        return True, ""
    err = np.abs(got - want)
    i = np.unravel_index(int(np.argmax(err)), err.shape)
    return False, (
        f"{what} differs from the reference by up to {err.max():.3g}, first at index "
        f"{tuple(int(k) for k in i)} (yours {got[i]:.4g}, the reference {want[i]:.4g})."
    )


# ------------------------------------------------------------------ section 1, 2

q1 = Question(
    "q1",
    "Eq. (3) has no diffusion term. What keeps a hot spot from staying sharp forever?",
    Choice(
        "b",
        {
            "a": "the cooling term: it blurs the hot spot",
            "b": "the advection: each step reads the field by bilinear interpolation "
            "between four cells, an average that smooths (numerical diffusion)",
            "c": "the projection: it smooths the temperature",
            "d": "nothing: a hot spot does stay sharp",
        },
        why={
            "a": "cooling acts on each cell alone; it lowers a peak but never mixes neighbours.",
            "c": "the projection changes the velocity only, never T.",
            "d": "look at the temperature after a few hundred steps: edges soften.",
        },
    ),
    hints=["Which move reads a cell's neighbours to set its new value?"],
    solution="""
    The semi-Lagrangian advection (section 3a): the new value is read between four old
    cells by bilinear interpolation, a weighted average. Averaging blurs, a little each
    step: **numerical diffusion**. Cooling works cell by cell and the projection does
    not touch $T$.
    """,
    right=("b",),
    wrong=("a",),
)

q2 = Question(
    "q2",
    "A cell's divergence is (bottom - top) + (right - left) of its faces. For the "
    "bottom-right cell (i, j) = (H-1, W-1), which stored values does it read, and which "
    "of its faces are zero?",
    Choice(
        "a",
        {
            "a": "`u[H-1, W-1, 0]` (top) and `u[H-1, W-1, 1]` (left); the bottom and right "
            "faces are walls and carry 0",
            "b": "`u[H-1, W-1, 0]`, `u[H-1, W-1, 1]`, `u[H, W-1, 0]` and `u[H-1, W, 1]`",
            "c": "all four faces are stored in `u[H-1, W-1]`",
        },
        why={
            "b": "row H and column W do not exist: an (H, W, 2) array stores only top and "
            "left faces.",
            "c": "each cell stores two of its faces, the top and the left.",
        },
    ),
    hints=["Each cell stores its top and its left face. Where are the other two stored?"],
    solution="""
    The bottom face of cell (i, j) is the top face of cell (i+1, j), and its right face
    is the left face of (i, j+1). For the bottom-right cell neither exists: they are the
    bottom and right walls, whose velocity is 0. So
    $\\nabla\\cdot u = (0 - u_{H-1,W-1,0}) + (0 - u_{H-1,W-1,1})$.
    """,
    right=("a",),
    wrong=("b",),
)


# ------------------------------------------------------------------ section 3a


def _judge_advect(fn):
    from fluidnb.fluid import _reference as ref

    u, T = _case()
    for dt in (1.0, 3.5):
        ok, note = _compare(fn(T, u, dt), ref.advect_scalar(T, u, dt), f"advect(T, u, {dt})")
        if not ok:
            if dt > 1 and _compare(fn(T, u, 1.0), ref.advect_scalar(T, u, 1.0), "")[0]:
                note += " It is right for dt = 1: does dt scale the backtrace?"
            return False, note
    return True, "your advection is the reference's, to round-off, for dt = 1 and 3.5."


step1 = Question(
    "step1",
    "Write the semi-Lagrangian step for one centred field, `advect(q, u, dt)`: the new "
    "value at cell (i, j) is q read at $(i - \\Delta t\\,u_y,\\; j - \\Delta t\\,u_x)$, "
    "with the velocity at the centres from `ref.centres(u)` and bilinear reading by "
    "`ref.sample(q, y, x)`.",
    Code(_judge_advect, "advect(q, u, dt) -> (H, W)"),
    hints=[
        "`cy, cx = ref.centres(u)` and `i, j = np.indices(q.shape)`.",
        "`return ref.sample(q, i - dt * cy, j - dt * cx)`",
    ],
    solution="""
    ```python
    def advect(q, u, dt):
        cy, cx = ref.centres(u)           # the velocity at the cell centres
        i, j = np.indices(q.shape)        # every cell's row and column
        return ref.sample(q, i - dt * cy, j - dt * cx)  # read where the air came from
    ```
    Three lines: backtrace each centre one step against the flow, read there.
    """,
    right=(lambda q, u, dt: _ref().advect_scalar(q, u, dt),),
    wrong=(lambda q, u, dt: _ref().advect_scalar(q, u, 1.0),),
)

step2 = Question(
    "step2",
    "In 1-D, with $u = 0.3$ px/frame everywhere and $\\Delta t = 1$, the backtrace from "
    "cell $i$ lands at $i - 0.3$, so $q^{new}_i = (1 - a)\\,q_i + a\\,q_{i-1}$. What is "
    "$a$ (`a`)? And why can this step not blow up for any $\\Delta t$ (`why`)?",
    Parts(
        a=Number(0.3, atol=1e-6),
        why=Choice(
            "b",
            {
                "a": "because $u\\,\\Delta t / \\Delta x \\le 1$ (the CFL condition)",
                "b": "the weights are $\\ge 0$ and add up to 1: every new value lies between "
                "two old ones, so the largest value can never grow, whatever $\\Delta t$",
                "c": "because the projection removes what grows",
            },
            why={
                "a": "the CFL condition binds explicit differences, which read a fixed "
                "neighbour; the backtrace reads wherever it lands, however far.",
                "c": "the projection acts on the velocity, and the scalar step stands alone.",
            },
        ),
    ),
    hints=[
        "Linear interpolation at $i - 0.3$ between $q_{i-1}$ and $q_i$: which weight has "
        "the nearer one?"
    ],
    solution="""
    $a = u\\,\\Delta t / \\Delta x = 0.3$: the point lies 0.3 of the way from $q_i$ to
    $q_{i-1}$. For $\\Delta t = 5$ it lands at $i - 1.5$, and reads
    $\\tfrac12 q_{i-1} + \\tfrac12 q_{i-2}$: still two non-negative weights adding to 1.
    A convex combination never leaves the range of the old values, so
    $\\max|q^{new}| \\le \\max|q|$ for any $\\Delta t$. An explicit upwind difference
    $q_i - c\\,(q_i - q_{i-1})$ with $c = u\\Delta t/\\Delta x > 1$ gives the weight
    $1 - c < 0$ and grows without bound: that is the CFL condition $c \\le 1$, which the
    semi-Lagrangian step does not need. Large steps still cost accuracy (more smoothing).
    """,
    right={"a": 0.3, "why": "b"},
    wrong={"a": 0.7, "why": "b"},
)

q3 = Question(
    "q3",
    "`sample` clamps the backtraced position to the grid. What value does a face near the "
    "open top read when the air there came from above the grid, and is that physical?",
    Choice(
        "a",
        {
            "a": "the value of the top row (the edge repeated): an assumption that the air "
            "above looks like the top row, not a law of physics",
            "b": "zero: the air above is at rest",
            "c": "the value from the bottom row: the grid wraps around",
        },
        why={
            "b": "clamping repeats the edge; it does not insert zeros.",
            "c": "the solver does not wrap; `np.clip` holds the position at the edge.",
        },
    ),
    hints=["`np.clip(y, 0, h - 1)`: where does y = -2.5 end up?"],
    solution="""
    The position is clamped to row 0, so it reads the top row's value: the edge repeated
    (a zero-gradient boundary). Physically the air above an open top is whatever is
    there, unknown to us; repeating the edge is a convenient guess that lets the gas
    leave without a wall reflecting it.
    """,
    right=("a",),
    wrong=("b",),
)


# ------------------------------------------------------------------ section 3b


def _judge_buoyancy(fn):
    from fluidnb.fluid import _reference as ref

    _, T = _case()
    want = ref.buoyancy(T, 0.15, 0.1)
    got = np.asarray(fn(T, 0.15, 0.1), dtype=float)
    if got.shape == want.shape and close(got, -want):
        return False, "the sign: up is dy < 0, so hot air is pushed towards smaller rows."
    if got.shape == want.shape and close(got[..., 0], 0.15 * (T - 0.1) * -1):
        return False, "the force is at the centres: average it to the top faces."
    ok, note = _compare(got, want, "buoyancy(T, 0.15, 0.1)")
    return ok, note or "Eq. (4) on the top faces, up is dy < 0."


step3 = Question(
    "step3",
    "Write Eq. (4) on the faces, `buoyancy(T, kappa_b, T_amb) -> (H, W, 2)`: "
    "$-\\kappa_b (T - T_{amb})$ in the dy component (up is dy < 0), averaged to the top "
    "faces with `ref.to_y_faces`; the dx component 0.",
    Code(_judge_buoyancy, "buoyancy(T, kappa_b, T_amb) -> (H, W, 2)"),
    hints=[
        "`f = np.zeros((*T.shape, 2))`, then fill `f[..., 0]`.",
        "`f[..., 0] = -kappa_b * ref.to_y_faces(T - T_amb)`",
    ],
    solution="""
    ```python
    def buoyancy(T, kappa_b, T_amb):
        f = np.zeros((*T.shape, 2))
        f[..., 0] = -kappa_b * ref.to_y_faces(T - T_amb)  # up is dy < 0
        return f
    ```
    The temperature lives at the centres, the vertical velocity on the top faces: the
    face between two cells gets the mean of their excess temperatures.
    """,
    right=(lambda T, k, a: _ref().buoyancy(T, k, a),),
    wrong=(lambda T, k, a: -_ref().buoyancy(T, k, a),),
)

q4 = Question(
    "q4",
    "Where is the confinement force largest: in the middle of a swirl or at its edge "
    "(`where`)? Why does $N$, a unit vector, make the force independent of how steep "
    "$|\\omega|$ is (`unit`)?",
    Parts(
        where=Choice(
            "edge",
            {
                "middle": "in the middle, where $|\\omega|$ peaks",
                "edge": "around the swirl's core, where $|\\omega|$ is large and changes: the "
                "force is $\\epsilon|\\omega|$ pushing along the edge",
            },
            why={
                "middle": "at the peak $\\nabla|\\omega| = 0$: N has no direction there "
                "and the force vanishes.",
            },
        ),
        unit=Choice(
            "a",
            {
                "a": "$N$ only gives the direction (towards more vorticity); the size is "
                "$\\epsilon|\\omega|$, whatever $|\\nabla|\\omega||$",
                "b": "it does not: a steeper $|\\omega|$ gives a larger force",
            },
            why={"b": "divide a vector by its length: what is left of the steepness?"},
        ),
    ),
    hints=["$|N \\times \\omega| = |\\omega|$ when $|N| = 1$. Where is $N$ undefined?"],
    solution="""
    $|f_{conf}| = \\epsilon\\,|N|\\,|\\omega| = \\epsilon|\\omega|$ wherever $N$ is
    defined. At the very centre of a swirl $|\\omega|$ has its maximum,
    $\\nabla|\\omega| = 0$, and there is no direction (the code sets $N = 0$); the force
    is largest in the ring around the core, where $|\\omega|$ is large and falls off,
    and it pushes along that ring, spinning the swirl up. Normalising $N$ throws the
    steepness away: a gently and a sharply peaked swirl of the same $|\\omega|$ get the
    same push.
    """,
    right={"where": "edge", "unit": "a"},
    wrong={"where": "middle", "unit": "a"},
)


# ------------------------------------------------------------------ section 3c


def _judge_divergence(fn):
    from fluidnb.fluid import divergence

    u, _ = _case(projected=False)
    return _compare(fn(u), divergence(u), "div(u)")


step4 = Question(
    "step4",
    "Write the divergence on the staggered grid, `div(u) -> (H, W)`: per cell "
    "(bottom - top) + (right - left), where the bottom face of cell (i, j) is the top "
    "face of (i+1, j) and the walls (below the last row, right of the last column) carry 0.",
    Code(_judge_divergence, "div(u) -> (H, W)"),
    hints=[
        "Pad `u[..., 0]` with a row of zeros below: "
        "`below = np.vstack([uy[1:], np.zeros((1, W))])`.",
        "Likewise `right = np.hstack([ux[:, 1:], np.zeros((H, 1))])`; then "
        "`below - uy + right - ux`.",
    ],
    solution="""
    ```python
    def div(u):
        uy, ux = u[..., 0], u[..., 1]
        H, W = uy.shape
        below = np.vstack([uy[1:], np.zeros((1, W))])   # bottom wall: 0
        right = np.hstack([ux[:, 1:], np.zeros((H, 1))])  # right wall: 0
        return (below - uy) + (right - ux)
    ```
    Dy > 0 points down, so (bottom - top) is the flow out through bottom and top.
    """,
    right=(lambda u: _fluid().divergence(u),),
    wrong=(lambda u: np.gradient(u[..., 0], axis=0) + np.gradient(u[..., 1], axis=1),),
)


def _judge_project(fn):
    from fluidnb.fluid import _reference as ref
    from fluidnb.fluid import divergence

    u, _ = _case(projected=False)
    got = np.asarray(fn(u.copy()), dtype=float)
    if got.shape != u.shape:
        return False, f"it returned shape {got.shape}; a velocity is {u.shape}."
    d = float(np.abs(divergence(got)).max())
    want, _ = ref.project(u)
    if d > 1e-9:
        return False, (
            f"the largest |divergence| afterwards is {d:.2g}, not round-off: check the "
            "signs (u_y -= p - p_above, u_x -= p - p_left) and the left wall (u_x = 0)."
        )
    ok, note = _compare(got, want, "project(u)")
    return ok, note or f"divergence afterwards {d:.1e}: incompressible, Eq. (2)."


step5 = Question(
    "step5",
    "Write the projection `project(u) -> u` for the open top: zero the left wall "
    "(`u[:, 0, 1] = 0`), solve `p = ref.pressure(div(u))`, then subtract the gradient of "
    "p on every face: $u_y \\mathrel{-}= p_{i,j} - p_{i-1,j}$ (with $p = 0$ above the "
    "grid) and $u_x \\mathrel{-}= p_{i,j} - p_{i,j-1}$ (not on the left wall). The check "
    "measures the divergence of what you return.",
    Code(_judge_project, "project(u) -> (H, W, 2)"),
    hints=[
        "`above = np.vstack([np.zeros((1, W)), p[:-1]])` is the pressure of the cell above.",
        "`u[..., 0] -= p - above`; `u[:, 1:, 1] -= p[:, 1:] - p[:, :-1]`.",
    ],
    solution="""
    ```python
    def project(u):
        u = u.copy()
        u[:, 0, 1] = 0.0                                   # the left wall
        p = ref.pressure(div(u))                           # solves lap p = div u
        above = np.vstack([np.zeros((1, p.shape[1])), p[:-1]])  # p = 0 over the open top
        u[..., 0] -= p - above
        u[:, 1:, 1] -= p[:, 1:] - p[:, :-1]
        return u
    ```
    Take the divergence of $u - \\nabla p$: $\\nabla\\cdot u - \\nabla^2 p = 0$ exactly
    when $p$ solves the Poisson equation with the same discrete operators.
    """,
    right=(lambda u: _ref().project(u)[0],),
    wrong=(lambda u: u,),
)

q5 = Question(
    "q5",
    "In a closed box the pressure is only known up to a constant. Which line of "
    "`ref.pressure` deals with that (`line`), and why does the velocity not care (`why`)?",
    Parts(
        line=Choice(
            "a",
            {
                "a": "`p -= p[0, 0]` (after fixing $\\hat p$ of mode k = 0 at row 0): "
                "p = 0 in cell (0, 0)",
                "b": "`diag_y[-1] = 1.0`",
                "c": "`lam = 2.0 - 2.0 * np.cos(...)`",
            },
            why={
                "b": "that is the bottom wall's Neumann condition, there in both boundaries.",
                "c": "those are the cosine modes' eigenvalues; the constant mode has lam = 0.",
            },
        ),
        why=Choice(
            "a",
            {
                "a": "only differences of p enter the velocity; a constant cancels",
                "b": "the constant is always 0",
            },
            why={"b": "any constant solves the closed box's equations: it must be chosen."},
        ),
    ),
    hints=["Search `ref.pressure`'s source for `closed`."],
    solution="""
    For `boundary="closed"` and the x-mode $k = 0$ the tridiagonal system is singular
    (a constant solves it with zero right-hand side); the code fixes $\\hat p_0 = 0$ in
    row 0 and then shifts, `p -= p[0, 0]`. The velocity takes $p_{i,j} - p_{i-1,j}$ and
    $p_{i,j} - p_{i,j-1}$: a constant added to $p$ cancels in every difference.
    """,
    right={"line": "a", "why": "a"},
    wrong={"line": "b", "why": "a"},
)


# ------------------------------------------------------------------ section 3d


def _judge_cool(fn):
    from fluidnb.fluid import _reference as ref

    _, T = _case()
    for C_r, dt in ((0.05, 1.0), (50.0, 1.0)):
        want = ref.cool(T.copy(), C_r, 0.1, dt, float(T.max()))
        ok, note = _compare(fn(T.copy(), C_r, 0.1, dt, float(T.max())), want, "cool(...)")
        if not ok:
            return False, f"with C_r = {C_r:g}: {note}"
    return True, "exact for any step: even C_r = 50 leaves every cell above ambient."


step6 = Question(
    "step6",
    "Write the cooling of Eq. (3) integrated exactly over one step with $T_{max}$ held: "
    "`cool(T, C_r, T_amb, dt, T_max)`. With $x = (T - T_{amb})/(T_{max} - T_{amb})$ the "
    "equation is $dx/dt = -c\\,x^4$, $c = C_r/(T_{max} - T_{amb})$; solve it (separate "
    "the variables) and apply it to the cells above ambient; leave the others.",
    Code(_judge_cool, "cool(T, C_r, T_amb, dt, T_max) -> (H, W)"),
    hints=[
        "$\\int x^{-4}dx = -\\tfrac13 x^{-3}$, so $x^{-3}$ grows by $3c\\,\\Delta t$ in a step.",
        "$x_{new} = x / (1 + 3c\\,\\Delta t\\,x^3)^{1/3}$; `np.cbrt` takes the cube root.",
    ],
    solution="""
    $dx/x^4 = -c\\,dt \\Rightarrow x^{-3}(t) = x^{-3}(0) + 3ct$, so
    $x_{new} = x/(1 + 3c\\,\\Delta t\\,x^3)^{1/3}$.
    ```python
    def cool(T, C_r, T_amb, dt, T_max):
        span = T_max - T_amb
        x = (T - T_amb) / span
        hot = x > 0
        new = x.copy()
        new[hot] = x[hot] / np.cbrt(1 + 3 * C_r / span * dt * x[hot] ** 3)
        return np.where(hot, T_amb + span * new, T)
    ```
    It stays positive for any $\\Delta t$: the cell never cools below ambient.
    """,
    right=(lambda T, c, a, dt, m: _ref().cool(T, c, a, dt, m),),
    wrong=(lambda T, c, a, dt, m: T - dt * c * np.clip((T - a) / (m - a), 0, None) ** 4,),
)


def _judge_step(fn):
    from fluidnb.fluid import FluidParams, FluidState
    from fluidnb.fluid import _reference as ref

    u, T = _case()
    p = FluidParams(source_radius=0.0, kappa_b=0.1, epsilon=0.3, C_r=0.05)
    want = ref.step(FluidState(u, T, np.zeros_like(T)), p)
    got = fn(u.copy(), T.copy(), p)
    if not (isinstance(got, tuple) and len(got) == 2):
        return False, "return the pair `(u, T)`."
    ok, note = _compare(got[0], want.velocity, "the velocity")
    if not ok:
        return False, note + " Order: advect u, add dt * (buoyancy + confinement), project."
    ok, note = _compare(got[1], want.temperature, "the temperature")
    if not ok:
        return False, note + " T is advected with the *projected* u, then cooled (T_max now)."
    return True, "your step is the solver's step (without the source), to round-off."


step7 = Question(
    "step7",
    "Put your pieces together into `my_step(u, T, params) -> (u, T)`, one step without "
    "the heat source, in the order of `step`: advect u (`ref.advect_velocity`), add "
    "`dt * (buoyancy + confinement)` (`ref.vorticity_confinement`), project, advect T "
    "with the new u, cool with `T_max = T.max()`.",
    Code(_judge_step, "my_step(u, T, params) -> (u, T)"),
    hints=[
        "`u = ref.advect_velocity(u, p.dt)`, then "
        "`u = u + p.dt * (buoyancy(T, p.kappa_b, p.T_amb) + "
        "ref.vorticity_confinement(u, p.epsilon))`.",
        "Then `u = project(u)`, `T = advect(T, u, p.dt)`, "
        "`T = cool(T, p.C_r, p.T_amb, p.dt, T.max())`.",
    ],
    solution="""
    ```python
    def my_step(u, T, p):
        u = ref.advect_velocity(u, p.dt)                       # 1. -(u . grad) u
        f = buoyancy(T, p.kappa_b, p.T_amb) + ref.vorticity_confinement(u, p.epsilon)
        u = project(u + p.dt * f)                              # 2. + f, 3. - grad p
        T = advect(T, u, p.dt)                                 # 4. -(u . grad) T
        T = cool(T, p.C_r, p.T_amb, p.dt, T.max())             # 5. cooling, Eq. (3)
        return u, T
    ```
    The confinement reads the advected velocity; the temperature moves with the projected
    one, so it is carried by a divergence-free flow.
    """,
    right=(_ref_step,),
    wrong=(lambda u, T, p: (u, T),),
)

q6 = Question(
    "q6",
    "The projection changed the velocity, but not the temperature. Why does the "
    "temperature still feel the pressure?",
    Choice(
        "a",
        {
            "a": "T is advected with the projected velocity: the pressure steers the flow "
            "that carries T",
            "b": "T is added to the pressure",
            "c": "it does not: T and p are independent",
        },
        why={
            "b": "no line adds T to p; look at the order of `ref.step`.",
            "c": "run a step with the projection skipped (exercise 3): T moves differently.",
        },
    ),
    hints=["Which velocity does `ref.step` hand to `advect_scalar`?"],
    solution="""
    Step 4 of `ref.step` advects $T$ with the velocity after the projection. The pressure
    turns the flow around obstacles and keeps it from piling up, and the temperature
    goes where that flow takes it; the temperature in turn feeds back through buoyancy.
    """,
    right=("a",),
    wrong=("c",),
)


# ------------------------------------------------------------------ sections 4-7

q7 = Question(
    "q7",
    "The enstrophy with confinement does not grow for ever. What limits it?",
    Choice(
        "b",
        {
            "a": "the projection removes vorticity",
            "b": "a balance: the advection's numerical diffusion smooths swirls faster the "
            "smaller and stronger they are, and the open top carries them away; for "
            "`epsilon * dt` above about 2 confinement wins and the flow diverges",
            "c": "the cooling: cold gas cannot swirl",
        },
        why={
            "a": "the projection removes divergence; a divergence-free flow can swirl freely.",
            "c": "cooling acts on T, and confinement does not read T at all.",
        },
    ),
    hints=["Confinement multiplies the swirl by about 1 + epsilon dt a step. What takes away?"],
    solution="""
    Confinement adds about $\\epsilon\\,\\Delta t\\,|\\omega|$ a step; the interpolation of
    the advection removes swirl faster the sharper it is, and the gas leaves through the
    open top. Their balance is the plateau. `FluidParams` refuses `epsilon * dt` above 2
    because beyond it the growth outruns the smoothing (measured: 3 diverges).
    """,
    right=("b",),
    wrong=("a",),
)

q8 = Question(
    "q8",
    "Why does the solver not use the explicit Euler step $T \\leftarrow T - \\Delta t\\,C_r "
    "x^4$? Give the hottest cell's temperature after one such step with $T = T_{max} = 1$, "
    "$T_{amb} = 0$, `C_r = 50`, `dt = 1` (`euler`), and after the exact step (`exact`).",
    Parts(
        euler=Number(-49.0, atol=1e-6),
        exact=Number(lambda: float(np.cbrt(1.0 / 151.0)), rtol=0.005),
    ),
    hints=["Euler: $1 - 1 \\cdot 50 \\cdot 1^4$. Exact: $x/(1 + 3c\\Delta t x^3)^{1/3}$."],
    solution="""
    Euler: $1 - 50 = -49$, far below ambient, and hotter than ambient on the next step's
    other side: it oscillates and blows up for $C_r\\Delta t$ above about 1. The exact
    step gives $1/151^{1/3} \\approx 0.188$: cooled a lot, never below ambient, for any
    step.
    """,
    right={"euler": -49, "exact": 0.188},
    wrong={"euler": 0.0, "exact": 0.188},
)

q9 = Question(
    "q9",
    "Run `simulate` twice with `seed=sim.seed`. Are the clips equal (`equal`)? Why is "
    "recording the seed worth it (`why`)?",
    Parts(
        equal=Truth(True, "the flicker is the only randomness, and the seed fixes it."),
        why=Choice(
            "a",
            {
                "a": "anyone can rerun exactly the flame you saw (a bug report, a figure)",
                "b": "it makes the simulation faster",
            },
            why={"b": "the seed fixes the random numbers, not the speed."},
        ),
    ),
    hints=["`np.array_equal(a.temperature, b.temperature)`"],
    solution="""
    Equal, bit for bit: the source's flicker is drawn from a generator seeded with
    `sim.seed`, and everything else is deterministic. Recorded in the saved `.npz`, the
    seed lets anyone reproduce the exact clip: a figure, a bug, a comparison.
    """,
    right={"equal": True, "why": "a"},
    wrong={"equal": False, "why": "a"},
)

q10 = Question(
    "q10",
    "In a closed box, where does the smoke go once it reaches the top?",
    Choice(
        "b",
        {
            "a": "out of the top, as the flame's hot gas does",
            "b": "it spreads sideways under the lid, then down the walls: it cannot leave, "
            "so it fills the box from the top",
            "c": "it stops and stays in a ball at the top centre",
        },
        why={
            "a": "`boundary='closed'`: no flow through the top face.",
            "c": "the projection turns the rising flow aside: it cannot stop at the lid.",
        },
    ),
    hints=["`divergence(u) = 0` and the top face is 0: where must the rising air go?"],
    solution="""
    The lid carries no flow, and the projection keeps every cell's in- and outflow
    equal, so the rising column turns sideways, runs along the lid and down the walls
    (two rolls). The smoke, never removed, accumulates from the top down. The open-top
    flame's gas leaves instead.
    """,
    right=("b",),
    wrong=("a",),
)


# ------------------------------------------------------------------ exercises


ex1 = Question(
    "ex1",
    "Double `kappa_b` and halve it. Does the flame get taller or shorter with more "
    "buoyancy (`double`)? Can a larger `C_r` bring the doubled flame back to its height "
    "(`keep`)?",
    Parts(
        double=Choice(
            "taller",
            {"taller": "taller and faster", "shorter": "shorter", "same": "about the same"},
            why={
                "shorter": "more buoyancy pushes the hot gas up faster: look at the heights.",
                "same": "look at the printed heights.",
            },
        ),
        keep=Choice(
            "hardly",
            {
                "yes": "yes: twice the `C_r` undoes twice the `kappa_b`",
                "hardly": "hardly: even several times `C_r` lowers it only a little, because "
                "the $x^4$ law cools the hottest gas and barely touches the lukewarm gas at "
                "the flame's top",
            },
            why={"yes": "look at the printed heights: twice C_r moves it by a percent or two."},
        ),
    ),
    hints=[
        "Compare the printed heights; then try `C_r` four and eight times as large.",
        "How fast does gas at 30 % of $T_{max}$ cool, compared with the hottest? ($x^4$)",
    ],
    solution="""
    Faster-rising gas gets higher before it cools: doubling $\\kappa_b$ makes the flame
    taller and faster, halving it shorter and slower. Raising $C_r$ hardly helps: the
    cooling rate is $C_r x^4$, so gas at 30 % of $T_{max}$ cools $0.3^4 \\approx 1/120$ as
    fast as the hottest. $C_r$ sharpens the flame's core; the height of the lukewarm
    plume is set by buoyancy (and by the flicker of the source). To shorten the flame,
    lower `kappa_b` or `source_T`.
    """,
    right={"double": "taller", "keep": "hardly"},
    wrong={"double": "taller", "keep": "yes"},
)

ex2 = Question(
    "ex2",
    "Try `epsilon` = 0, 0.2, 0.8, 1.5 (code route: the cell below measures each run's "
    "enstrophy). How does the enstrophy change with epsilon (`trend`), and from which "
    "epsilon on does the flame look like noise to you (`noise`)?",
    Parts(
        trend=Choice(
            "grows",
            {"grows": "it grows with epsilon", "falls": "it falls", "flat": "it stays the same"},
            why={
                "falls": "confinement adds swirl: look at the printed numbers.",
                "flat": "look at the printed numbers.",
            },
        ),
        noise=Within(
            0.5,
            2.0,
            why_low="at that epsilon the flame still has one body with licks; look again.",
            why_high="FluidParams refuses epsilon * dt above 2.",
        ),
    ),
    hints=["The eye's judgement is open; most people answer 0.8 to 1.5."],
    solution="""
    The enstrophy grows with $\\epsilon$. At 0 the plume is smooth, at 0.2-0.4 it curls
    and licks like fire, at 0.8 the body breaks into many small swirls, and at 1.5 it is
    a turbulent cloud of noise with no flame shape. Anything from 0.5 to 2 is a fair
    answer; the library's 0.4 is chosen below it.
    """,
    right={"trend": "grows", "noise": 1.0},
    wrong={"trend": "grows", "noise": 0.1},
)

ex3 = Question(
    "ex3",
    "Use your `my_step` without the projection for ten steps (the cell below does it). "
    "What happens to the divergence (`divergence`), and to the picture (`picture`)?",
    Parts(
        divergence=Choice(
            "grows",
            {
                "grows": "it jumps from round-off to order 1 in the first step and stays "
                "there: nothing removes it",
                "zero": "it stays at round-off",
            },
            why={"zero": "nothing removes it now: print `np.abs(divergence(u)).max()`."},
        ),
        picture=Choice(
            "a",
            {
                "a": "the plume smears into a dull blob: the flow spreads out where it "
                "diverges, the heat with it, and the mushroom's shape is lost",
                "b": "nothing changes",
            },
            why={"b": "compare the two rows of pictures."},
        ),
    ),
    hints=["`divergence(u)` after each step; `temperature_to_rgb(T)` at the end."],
    solution="""
    Without the projection nothing removes what the advection and the forces add to
    $\\nabla\\cdot u$: it jumps from $10^{-15}$ to order 1 in the first step and stays. The
    buoyant column no longer has to pull air in below and push it aside above: it
    swells where the flow diverges, the heat spreads with it, and the plume smears into
    a dull blob. Eq. (2) is what makes the gas behave like air.
    """,
    right={"divergence": "grows", "picture": "a"},
    wrong={"divergence": "zero", "picture": "a"},
)

ex4 = Question(
    "ex4",
    "Run the flame with `boundary='closed'`. Where does the hot gas go (`where`), and why "
    "does the flame lose its shape (`why`)?",
    Parts(
        where=Choice(
            "a",
            {
                "a": "it spreads under the lid and accumulates there: the box warms from the "
                "top down",
                "b": "out of the top",
                "c": "it stays near the source",
            },
            why={"b": "the lid is solid now.", "c": "buoyancy still lifts it."},
        ),
        why=Choice(
            "a",
            {
                "a": "the gas cannot leave: it turns at the lid and comes down the walls, "
                "and these rolls and the warm layer push the flame around",
                "b": "the solver becomes unstable",
            },
            why={"b": "the divergence is still at round-off; it is the physics of a box."},
        ),
    ),
    hints=["Look at the last frame's temperature: where is it warm?"],
    solution="""
    The hot gas cannot leave: it runs along the lid, then down the walls, and the box
    fills with warm gas from the top. The two rolls it drives bend the plume, and the
    flame no longer rises into cold clean air: its shape is lost.
    """,
    right={"where": "a", "why": "a"},
    wrong={"where": "b", "why": "a"},
)


def _hottest_drop():
    """The hottest cell's drop in one step at C_r = 0.02, dt = 1, from fluidnb.fluid.cool."""
    from fluidnb.fluid import FluidParams, cool

    p = FluidParams(C_r=0.02, kappa_b=0.0, epsilon=0.0, source_radius=0.0)
    T = np.array([[1.0, 0.5], [0.25, 0.0]])
    return float(1.0 - cool(T, p)[0, 0])


ex5 = Question(
    "ex5",
    "Eq. (3) says the hottest cell cools at exactly $C_r$ per frame at each instant. In the "
    "section-5 plot (`C_r = 0.02`), by how much does the hottest cell drop in the solver's "
    "first step (`drop`)? And why is it not 0.02 (`why`)?",
    Parts(
        drop=Number(_hottest_drop, rtol=0.01),
        why=Choice(
            "a",
            {
                "a": "the step holds $T_{max}$ at the start's value and integrates exactly: "
                "as the cell cools its $x$ falls below 1 and its rate below $C_r$, so "
                "$1 - (1 + 3 C_r)^{-1/3}$",
                "b": "round-off",
                "c": "the advection blurs the hottest cell",
            },
            why={
                "b": "round-off is 1e-16, the gap is 8e-4.",
                "c": "nothing moves in section 5 (`kappa_b = 0`).",
            },
        ),
    ),
    hints=[
        "`history[0, 0] - history[1, 0]` in section 5's cell; or by hand from step 6: "
        "$x = 1$, $c = C_r$."
    ],
    solution="""
    At $t = 0$ the hottest cell has $x = 1$ and cools at $C_r$. But within the step
    $T_{max}$ is held at its start value, so as the cell cools its $x$ drops below 1 and
    so does its rate: $x(1) = (1 + 3C_r)^{-1/3} = 1.06^{-1/3} = 0.9808$, a drop of
    **0.0192**. (Eq. (3) re-measures $T_{max}$ continuously; then the hottest cell is
    always at $x = 1$ and falls at exactly $C_r$: $T_{max}(t) = T_{max}(0) - C_r t$,
    the line in the plot. The dots drift above it by that first-order gap.)
    """,
    right={"drop": 0.0192, "why": "a"},
    wrong={"drop": 0.02, "why": "a"},
)

ex6 = Question(
    "ex6",
    "Run `simulate(..., substeps=4)` (the cell below measures both). Is the flame taller "
    "(`taller`)? Which part of the step does not scale with the step size and causes "
    "most of it (`why`)?",
    Parts(
        taller=Truth(True, "compare the printed heights and the source's temperature."),
        why=Choice(
            "source",
            {
                "advect": "the advection: smaller steps smooth less",
                "source": "the heat source: each step pulls its disc back up to the target "
                "temperature whatever dt is, so four steps a frame refill it four times (more "
                "heat a frame), and with the flicker (heat, never cool) the disc keeps the "
                "hottest of four random draws",
                "cool": "the cooling: smaller steps cool less",
            },
            why={
                "advect": "the advection converges as dt shrinks; smaller steps take more "
                "interpolations, which smooth more, not less.",
                "cool": "the cooling is exact for any dt; only T_max's re-measuring changes, "
                "a small first-order effect.",
            },
        ),
    ),
    hints=[
        "Look at `heat_source` in `ref.step`'s source: which of its lines contains `dt`?",
    ],
    solution="""
    Taller and hotter. Advection, forces and cooling are rates times `dt`: with
    `dt / 4` four times, they converge to the same motion (with a little more smoothing).
    The heat source is not a rate: each step sets the disc to at least the target
    temperature (`T + max(target - T, 0) * mask`). Four steps a frame refill the disc
    four times, injecting more heat a frame; with `source_flicker`, the disc keeps the
    hottest of four random targets, so its mean temperature rises (the notebook prints
    both). A solver whose source were a rate, `dt * (target - T) / tau`, would converge.
    """,
    right={"taller": True, "why": "source"},
    wrong={"taller": True, "why": "advect"},
)
