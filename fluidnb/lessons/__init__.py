"""Checks for the lessons' questions and exercises: ``q3.check(answer)``, hints, solutions.

One module per lesson notebook, each holding that lesson's questions as
:class:`Question` objects, in the order the lesson asks them: ``q1, q2, ...`` for the
questions in the text, ``warm1, ...`` for the closed warm-up exercises, ``step1, ...``
for the exercises that build a method step by step, and ``ex1, ...`` for the exercises
at the end. A lesson imports its module once,

>>> from fluidnb.lessons import frost as lesson  # doctest: +SKIP

and after each question a cell calls ``lesson.q3.check()``: without an answer it shows
how to answer (the options, the unit); with one (``lesson.q3.check("b")``,
``lesson.ex5.check(0.0192)``, ``lesson.step1.check(my_advect)``) it says whether the
answer is right and why not. ``lesson.q3.hint()`` nudges, ``lesson.q3.solution()`` shows
the worked answer, folded.

For a graded session a lecturer turns the solutions off: ``FLUIDNB_SOLUTIONS=0`` in the
environment of the Jupyter server, or :func:`show_solutions` ``(False)`` in a cell.

=============================  =====================================
notebook                       module
=============================  =====================================
00_overview.ipynb              :mod:`fluidnb.lessons.overview`
01_drawing_tools.ipynb         :mod:`fluidnb.lessons.drawing`
02_flicker.ipynb               :mod:`fluidnb.lessons.flicker`
03_frost.ipynb                 :mod:`fluidnb.lessons.frost`
04_fluid_solver.ipynb          :mod:`fluidnb.lessons.fluid`
05_fire.ipynb                  :mod:`fluidnb.lessons.fire`
06_turbulence.ipynb            :mod:`fluidnb.lessons.turbulence`
06b_turbulence_appendix.ipynb  :mod:`fluidnb.lessons.turbulence_exact`
07a_videodb_database.ipynb     :mod:`fluidnb.lessons.videodb_database`
07b_videodb_animation.ipynb    :mod:`fluidnb.lessons.videodb_animation`
08_scene.ipynb                 :mod:`fluidnb.lessons.scene`
=============================  =====================================

The library never imports Jupyter, and neither does this: feedback shows itself as
Markdown in a notebook and as text in a script.
"""

import importlib

from ._core import (
    BLANK,
    Choice,
    Code,
    Feedback,
    Number,
    Parts,
    Question,
    Truth,
    Within,
    show_solutions,
    solutions_shown,
)

__all__ = [
    "BLANK",
    "LESSONS",
    "Choice",
    "Code",
    "Feedback",
    "Number",
    "Parts",
    "Question",
    "Truth",
    "Within",
    "questions",
    "show_solutions",
    "solutions_shown",
]

#: Notebook file name -> the module holding its questions.
LESSONS = {
    "00_overview.ipynb": "overview",
    "01_drawing_tools.ipynb": "drawing",
    "02_flicker.ipynb": "flicker",
    "03_frost.ipynb": "frost",
    "04_fluid_solver.ipynb": "fluid",
    "05_fire.ipynb": "fire",
    "06_turbulence.ipynb": "turbulence",
    "06b_turbulence_appendix.ipynb": "turbulence_exact",
    "07a_videodb_database.ipynb": "videodb_database",
    "07b_videodb_animation.ipynb": "videodb_animation",
    "08_scene.ipynb": "scene",
}


def questions(lesson):
    """A lesson's questions in the order it asks them.

    Parameters
    ----------
    lesson : str
        A module name (``"frost"``) or a notebook's file name (``"03_frost.ipynb"``).

    Returns
    -------
    list of Question

    Examples
    --------
    >>> [q.name for q in questions("drawing")][:2]
    ['q1', 'q2']
    """
    name = LESSONS.get(lesson, lesson)
    if name not in LESSONS.values():
        raise ValueError(f"lesson must be one of {sorted(LESSONS.values())}, got {lesson!r}")
    module = importlib.import_module(f"{__name__}.{name}")
    found = [v for v in vars(module).values() if isinstance(v, Question)]  # as defined
    if sorted(q.name for q in found) != sorted(module.__all__):
        raise RuntimeError(f"{module.__name__}: __all__ and its questions differ")
    return found
