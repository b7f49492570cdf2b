"""Every question and exercise of every lesson has a check that accepts and rejects (issue 40).

Each lesson module of :mod:`fluidnb.lessons` holds its questions with one answer the
check must accept and one it must refuse; these tests call each check with both, and
check that every question the notebook's text asks is followed by a cell that calls
its check, in the same order as the module lists them.
"""

import json
import re
from pathlib import Path

import pytest

from fluidnb import lessons
from fluidnb.lessons import LESSONS, Question, questions, show_solutions

ROOT = Path(__file__).resolve().parents[1]
ALL = [(nb, q) for nb in LESSONS for q in questions(nb)]


def call(q, answer):
    return q.check(**answer) if isinstance(answer, dict) else q.check(*answer)


@pytest.fixture(autouse=True)
def _solutions_follow_the_environment(monkeypatch):
    monkeypatch.delenv("FLUIDNB_SOLUTIONS", raising=False)
    show_solutions(None)
    yield
    show_solutions(None)


@pytest.mark.parametrize(("notebook", "q"), ALL, ids=[f"{LESSONS[n]}.{q.name}" for n, q in ALL])
def test_the_check_accepts_a_right_answer_and_refuses_a_wrong_one(notebook, q):
    assert q.right is not None, f"{q.name}: give a right answer"
    assert q.wrong is not None, f"{q.name}: give a wrong answer"
    right, wrong = call(q, q.right), call(q, q.wrong)
    assert right.correct, f"{q.name} refused its right answer: {right}"
    assert not wrong.correct, f"{q.name} accepted its wrong answer"
    assert wrong.status == "incorrect"
    assert wrong.text, f"{q.name}: say why it is wrong"
    assert q.check().status == "unanswered"
    assert q.name in q.check()._repr_markdown_()
    assert q.hint().text
    assert q.solution().status == "solution"
    assert "<details>" in q.solution()._repr_markdown_()


@pytest.mark.parametrize("notebook", LESSONS)
def test_every_question_in_the_text_is_followed_by_its_check(notebook):
    cells = json.loads((ROOT / "notebooks" / notebook).read_text())["cells"]
    module = LESSONS[notebook]
    code = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "code")
    assert f"from fluidnb.lessons import {module} as lesson" in code, notebook
    names = [q.name for q in questions(notebook)]
    called = re.findall(r"\blesson\.(\w+)\.check\(", code)
    assert called == names, f"{notebook}: checks called {called}, the module has {names}"
    # Every paragraph that asks (a bold "Question", "Try it", an exercise list) names its
    # check, and the next code cell calls it.
    for i, cell in enumerate(cells):
        text = "".join(cell["source"])
        if cell["cell_type"] != "markdown":
            continue
        asked = re.findall(r"\*\*(?:Question|Try it|Warm-up|Step|Exercise)[^*]*\((\w+)\)", text)
        bare = re.findall(r"\*\*(?:Question|Try it)[.:]?\*\*", text)
        assert bare == [], f"{notebook} cell {i}: a question without its check's name"
        for name in asked:
            later = "".join(
                "".join(c["source"]) for c in cells[i + 1 : i + 4] if c["cell_type"] == "code"
            )
            assert f"lesson.{name}.check(" in later, f"{notebook}: {name} has no check cell"


def test_solutions_can_be_turned_off_for_a_graded_session(monkeypatch):
    from fluidnb.lessons import drawing

    q = drawing.warm1
    assert "93" in str(q.check(93))
    assert q.solution().status == "solution"
    monkeypatch.setenv("FLUIDNB_SOLUTIONS", "0")
    hidden = q.solution()
    assert hidden.status == "hidden"
    assert "93" not in str(hidden)
    assert q.check(93).correct
    assert "93" not in str(q.check(93))
    assert not q.check(96).correct
    monkeypatch.delenv("FLUIDNB_SOLUTIONS")
    show_solutions(False)
    assert q.solution().status == "hidden"
    show_solutions(True)
    assert q.solution().status == "solution"
    with pytest.raises(ValueError, match="on must be"):
        show_solutions("no")


def test_feedback_reads_as_text_and_as_markdown():
    from fluidnb.lessons import drawing

    good, bad = drawing.q4.check("a"), drawing.q4.check("b")
    assert bool(good)
    assert not bool(bad)
    assert str(good).startswith("✔ Correct (q4)")
    assert "**" not in str(bad)
    assert bad._repr_markdown_().startswith("**✘ Not yet (q4):**")
    assert "does not depend on the speed" in str(bad)  # why b is wrong
    assert drawing.q4.check("z").status == "incorrect"  # not an option: says which are
    assert "a" in str(drawing.q4.check("z"))
    assert drawing.q4.check("(A)").correct  # letters as written in the options


def test_plain_text_keeps_the_comparisons_of_the_maths():
    # 03_frost's ex4 read "why can no $\\beta  130$ for every ...": the plain text took
    # "< 0.35$ ... >" for an HTML tag and cut it out.
    from fluidnb.lessons import frost

    text = str(frost.ex4.check())
    assert "$\\beta < 0.35$ end at 130" in text
    assert "> 130$ for every $\\beta < 0.35$" in text
    assert "<details>" not in str(frost.ex4.solution())


def test_an_angle_in_degrees_is_named_as_such():
    # 02's warm2 wants radians; 29.6 (the right angle in degrees) was told only "too large".
    import numpy as np

    from fluidnb.lessons import flicker

    fb = flicker.warm2.check(float(np.degrees(0.5168)))
    assert not fb.correct
    assert "in degrees" in str(fb)
    assert "radians" in str(fb)
    assert "in degrees" not in str(flicker.warm2.check(40.0))  # merely too large
    assert flicker.warm2.check(0.5168).correct


def test_a_students_function_that_fails_is_reported_not_raised():
    from fluidnb.lessons import drawing

    def broken(direction, region, speed_map, speed):
        raise IndexError("oops")

    fb = drawing.ex1.check(broken)
    assert fb.status == "incorrect"
    assert "IndexError: oops" in str(fb)
    assert "Pass your function" in str(drawing.ex1.check(3))


def test_hints_are_numbered():
    from fluidnb.lessons import drawing

    q = drawing.ex1
    assert "more:" in str(q.hint())
    assert "more:" not in str(q.hint(2))
    assert str(q.hint(0)).count("\n") >= 1
    with pytest.raises(ValueError, match=r"n must be in 1\.\.2"):
        q.hint(3)


def test_questions_names_the_lessons():
    names = [q.name for q in questions("01_drawing_tools.ipynb")]
    assert names[:2] == ["q1", "q2"]
    assert sorted(names) == lessons.drawing.__all__
    assert all(isinstance(q, Question) for q in questions("drawing"))
    with pytest.raises(ValueError, match="lesson must be one of"):
        questions("nope")


def test_a_parts_question_with_every_part_blank_is_unanswered():
    from fluidnb.lessons import BLANK, fluid

    assert fluid.ex6.check(taller=BLANK, why=BLANK).status == "unanswered"
    half = fluid.ex6.check(taller=True, why=BLANK)
    assert half.status == "incorrect"
    assert "why=..." in str(half)


@pytest.mark.parametrize("notebook", sorted(p.name for p in (ROOT / "notebooks").glob("*.ipynb")))
def test_no_lesson_needs_a_private_name(notebook):
    # Issue 40: everything an exercise needs is public and documented. The readable
    # numpy versions are public as fluidnb.<method>.reference.
    cells = json.loads((ROOT / "notebooks" / notebook).read_text())["cells"]
    code = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "code")
    private = re.findall(
        r"fluidnb(?:\.\w+)*\._[A-Za-z]\w*|from fluidnb[\w.]* import [^\n]*?(?<!\w)_[A-Za-z]\w*",
        code,
    )
    assert not private, f"{notebook} uses private names: {private}"


def test_every_ref_name_the_fluid_lesson_asks_for_is_public():
    # 04's step3 told the student to use `ref.to_y_faces`, which the public
    # fluidnb.fluid.reference did not export (its check ran the private module, so it
    # passed): a student got an AttributeError. Every `ref.NAME` in the notebook's text
    # and code and in the checks' prompts, hints and solutions must exist.
    from fluidnb.fluid import reference
    from fluidnb.lessons import fluid

    cells = json.loads((ROOT / "notebooks" / "04_fluid_solver.ipynb").read_text())["cells"]
    texts = ["".join(c["source"]) for c in cells]
    for q in questions("fluid"):
        texts += [q.prompt, q._solution, *q.hints]
    names = set(re.findall(r"\bref\.(\w+)", "\n".join(texts)))
    assert "to_y_faces" in names, "the test no longer reads step3"
    missing = sorted(n for n in names if not hasattr(reference, n))
    assert missing == [], f"fluidnb.fluid.reference lacks {missing}"
    assert fluid.step3.right is not None
