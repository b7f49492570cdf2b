"""Questions a student answers in code: ``q.check(answer)``, ``q.hint()``, ``q.solution()``.

In the manner of Kaggle Learn's learntools: every question and exercise of a lesson is a
:class:`Question` object in that lesson's module (``fluidnb.lessons.frost`` for
``03_frost.ipynb``, ...). The student writes their answer and calls ``check`` with it;
``hint`` gives a nudge, ``solution`` the worked answer, folded. The checks are built on
the same invariants the lessons compute (a mass balance, a divergence, an energy), so
an answer is judged by what the library gives, not by a stored string.

Answers come in a few forms, each with its checker here:

- :class:`Choice`: one letter of a few options (conceptual questions: think first, then
  pick the reason that matches yours);
- :class:`Number`: a number, within a tolerance of what the library computes;
- :class:`Within`: a number in a range (the open exercises: "how high is the flame?");
- :class:`Truth`: yes or no;
- :class:`Parts`: several named answers at once, ``q.check(row=..., col=...)``;
- :class:`Code`: a function the student wrote, run on a small case against the
  library's reference.

Solutions can be turned off for a graded session: set the environment variable
``FLUIDNB_SOLUTIONS=0`` before starting JupyterLab, or call
``fluidnb.lessons.show_solutions(False)`` in the notebook's first cell. Checks still
say right or wrong, but never show the expected value, and ``solution()`` says that it
is turned off. (The source of this package is open, so this hides the answers from the
notebook; it is not a lock.)

Nothing here imports Jupyter: a :class:`Feedback` displays itself through
``_repr_markdown_`` in a notebook and reads as plain text in a script.
"""

from __future__ import annotations

import math
import numbers
import os
import re
import textwrap
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BLANK",
    "Choice",
    "Code",
    "Feedback",
    "Number",
    "Parts",
    "Question",
    "Truth",
    "Within",
    "show_solutions",
    "solutions_shown",
]

#: The environment variable a lecturer sets to hide solutions ("0", "off", "no", "false").
ENV = "FLUIDNB_SOLUTIONS"
_OFF = {"0", "off", "no", "false", "hide", "hidden"}
_setting = {"solutions": None}  # None: follow the environment variable


class _Blank:
    """The answer not given yet (a cell run before the student filled it in)."""

    def __repr__(self):
        return "____"


#: How the lessons name their module (``from fluidnb.lessons import frost as lesson``).
PREFIX = "lesson."

#: Put this where the answer goes: ``q1.check(____)`` with ``____ = BLANK``.
BLANK = _Blank()


def solutions_shown():
    """Whether ``solution()`` shows solutions and feedback names expected values.

    Returns
    -------
    bool
        The setting of :func:`show_solutions` if one was made, else whether the
        environment variable ``FLUIDNB_SOLUTIONS`` is unset or not one of
        ``0, off, no, false, hide, hidden``.
    """
    if _setting["solutions"] is not None:
        return _setting["solutions"]
    return os.environ.get(ENV, "1").strip().lower() not in _OFF


def show_solutions(on=True):
    """Turn solutions on or off for this session (a graded class: ``False``).

    Parameters
    ----------
    on : bool or None
        ``True`` shows them, ``False`` hides them, ``None`` follows the environment
        variable ``FLUIDNB_SOLUTIONS`` again.

    Examples
    --------
    >>> show_solutions(False)
    >>> solutions_shown()
    False
    >>> show_solutions(None)
    """
    if on is not None and not isinstance(on, bool):
        raise ValueError(f"on must be True, False or None, got {on!r}")
    _setting["solutions"] = on


# ------------------------------------------------------------------ feedback


_MARK = {
    "correct": "✔ Correct",
    "incorrect": "✘ Not yet",
    "unanswered": "… Your turn",
    "hint": "Hint",
    "solution": "Solution",
    "hidden": "Solution",
    "question": "",
}


@dataclass(frozen=True)
class Feedback:
    """What a check, a hint or a solution says.

    ``bool(feedback)`` is whether the answer was right, so a test can write
    ``assert q.check(answer)``. In a notebook it shows as Markdown (a solution folded
    under a *Solution* summary); ``str`` gives plain text.

    Attributes
    ----------
    status : str
        ``"correct"``, ``"incorrect"``, ``"unanswered"``, ``"hint"``, ``"solution"``,
        ``"hidden"`` (solutions turned off) or ``"question"``.
    text : str
        The message, in Markdown.
    name : str
        The question's name (``"q3"``).
    """

    status: str
    text: str
    name: str = ""

    def __bool__(self):
        return self.status == "correct"

    @property
    def correct(self):
        """Whether the answer was right."""
        return self.status == "correct"

    def _head(self):
        mark = _MARK[self.status]
        return f"{mark} ({self.name})" if self.name and mark else mark

    def _repr_markdown_(self):
        if self.status == "solution":
            return (
                f"<details><summary><b>{self._head()}</b> (click to open)</summary>\n\n"
                f"{self.text}\n\n</details>"
            )
        head = self._head()
        return f"**{head}:** {self.text}" if head else self.text

    def __str__(self):
        head = self._head()
        return f"{head}: {_plain(self.text)}" if head else _plain(self.text)

    def __repr__(self):
        return str(self)


def _plain(markdown):
    r"""Markdown as plain text: no backticks, bold or HTML tags.

    Only real tags go (``<details>``, ``</summary>``: a letter or ``/`` after the ``<``),
    not the text between a "less than" and a "greater than" of the maths
    (``$\beta < 0.35$ ... $T > 130$``).
    """
    text = re.sub(r"</?[A-Za-z][^<>]*>", "", markdown)
    return re.sub(r"\*\*|`", "", text)


# ------------------------------------------------------------------ checkers


def _is_blank(value):
    return value is BLANK or value is Ellipsis or value is None


def _fmt(x):
    if isinstance(x, numbers.Integral):
        return f"{int(x)}"
    return f"{float(x):.4g}"


class _Lazy:
    """A value computed from the library the first time a check needs it, then kept."""

    def __init__(self, value):
        self._value = value
        self._done = not callable(value)

    def get(self):
        if not self._done:
            self._value = self._value()
            self._done = True
        return self._value


class Choice:
    """One letter of a few options; each wrong option can say why it is wrong.

    Parameters
    ----------
    answer : str or set of str
        The right letter(s).
    options : dict
        Letter -> the option's text (Markdown).
    why : dict, optional
        Letter -> why that option is wrong (shown when it is picked).

    Examples
    --------
    >>> c = Choice("b", {"a": "red", "b": "blue"}, why={"a": "look again"})
    >>> c("B")[0], c("a")
    (True, (False, 'look again'))
    """

    kind = "choice"

    def __init__(self, answer, options, why=None):
        self.answer = {answer} if isinstance(answer, str) else set(answer)
        self.options = dict(options)
        self.why = dict(why or {})
        missing = self.answer - set(self.options)
        if missing:
            raise ValueError(f"answer must be among the options {sorted(self.options)}")

    def letter(self, value):
        """The option a value names: a letter, ``"(b)"``, or the option's text."""
        if isinstance(value, str):
            text = value.strip().strip("().").strip().lower()
            for key in self.options:
                if text == key.lower():
                    return key
            for key, option in self.options.items():
                if text and text == _plain(option).strip().lower():
                    return key
        return None

    def __call__(self, value):
        key = self.letter(value)
        if key is None:
            keys = ", ".join(f'"{k}"' for k in self.options)
            return False, f"Answer with one of {keys} (as a string)."
        if key in self.answer:
            return True, ""
        return False, self.why.get(key, "That is not the best of the options: think again.")

    def describe(self):
        """The options as a Markdown list."""
        return "\n".join(f"- **({k})** {v}" for k, v in self.options.items())


class Truth:
    """Yes or no (``True``/``False``, or the words ``"yes"``/``"no"``).

    Parameters
    ----------
    answer : bool
        The right one.
    why : str
        What a wrong answer is told.

    Examples
    --------
    >>> Truth(True)("yes")[0], Truth(True)(False)[0]
    (True, False)
    """

    kind = "truth"

    def __init__(self, answer, why=""):
        self.answer = bool(answer)
        self.why = why

    def __call__(self, value):
        if isinstance(value, str):
            word = value.strip().lower()
            if word not in {"yes", "no", "true", "false"}:
                return False, 'Answer with True or False (or "yes" / "no").'
            value = word in {"yes", "true"}
        if not isinstance(value, (bool, np.bool_)):
            return False, 'Answer with True or False (or "yes" / "no").'
        if bool(value) == self.answer:
            return True, ""
        return False, self.why or "The other way round: think again."


def _as_number(value):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.ndarray)):
        return None
    value = np.asarray(value, dtype=float)
    if value.size != 1 or not np.isfinite(value).all():
        return None
    return float(value.reshape(()))


class Number:
    """A number, close to what the library computes.

    Parameters
    ----------
    expected : float or callable
        The right value, or a function computing it (called once, when first needed).
    rtol, atol : float
        Relative and absolute tolerance; an answer passes within either.
    unit : str
        Named in the feedback ("frames", "px/frame").

    Examples
    --------
    >>> n = Number(lambda: 0.0192, rtol=0.02)
    >>> n(0.0193)[0], n(0.02)[0]
    (True, False)
    """

    kind = "number"

    def __init__(self, expected, rtol=0.05, atol=0.0, unit=""):
        self._expected = _Lazy(expected)
        self.rtol, self.atol, self.unit = float(rtol), float(atol), unit

    @property
    def expected(self):
        """The right value."""
        return float(self._expected.get())

    def __call__(self, value):
        x = _as_number(value)
        if x is None:
            return False, "Answer with one number."
        want = self.expected
        if abs(x - want) <= max(self.atol, self.rtol * abs(want)):
            if not solutions_shown():
                return True, ""
            return True, f"the library gives {_fmt(want)}{' ' + self.unit if self.unit else ''}."
        side = "too large" if x > want else "too small"
        if self.unit == "rad" and abs(x - np.degrees(want)) <= max(
            1e-9, self.rtol * abs(np.degrees(want))
        ):
            # The commonest slip with an angle: the right value, in degrees.
            return False, f"{_fmt(x)} is the right angle in degrees: the answer is in radians."
        return False, f"{_fmt(x)} is {side}."


class Within:
    """A number in a range: the open exercises' expected answers.

    Parameters
    ----------
    lo, hi : float or callable
        The range (either end may be computed when first needed; ``None``: unbounded).
    unit : str
        Named in the feedback.
    why_low, why_high : str
        What an answer below or above the range is told.

    Examples
    --------
    >>> Within(2, 5)(3)[0], Within(2, 5)(6)[0]
    (True, False)
    """

    kind = "within"

    def __init__(self, lo, hi, unit="", why_low="", why_high=""):
        self._lo, self._hi = _Lazy(lo), _Lazy(hi)
        self.unit, self.why_low, self.why_high = unit, why_low, why_high

    @property
    def range(self):
        """(lo, hi), either end may be None."""
        return self._lo.get(), self._hi.get()

    def __call__(self, value):
        x = _as_number(value)
        if x is None:
            return False, "Answer with one number."
        lo, hi = self.range
        if lo is not None and x < lo:
            return False, self.why_low or f"{_fmt(x)} is too small."
        if hi is not None and x > hi:
            return False, self.why_high or f"{_fmt(x)} is too large."
        return True, ""


class Parts:
    """Several named answers, each with its own checker: ``q.check(a=..., b=...)``.

    Parameters
    ----------
    **checkers
        Name -> checker.

    Examples
    --------
    >>> p = Parts(row=Number(3), col=Number(4))
    >>> p(row=3, col=4)[0], p(row=3, col=5)[0]
    (True, False)
    """

    kind = "parts"

    def __init__(self, **checkers):
        self.checkers = checkers

    def __call__(self, **named):
        unknown = set(named) - set(self.checkers)
        missing = [k for k in self.checkers if k not in named or _is_blank(named[k])]
        if unknown:
            return False, f"Unknown part(s) {sorted(unknown)}: the parts are {list(self.checkers)}."
        if missing:
            return False, f"Give every part: {', '.join(f'{k}=...' for k in missing)}."
        notes = []
        for key, checker in self.checkers.items():
            ok, note = checker(named[key])
            if not ok:
                notes.append(f"`{key}`: {note}")
        if notes:
            return False, " ".join(notes)
        return True, ""


class Code:
    """A function the student wrote, judged by running it.

    Parameters
    ----------
    judge : callable
        ``judge(function) -> (ok, message)``: runs the student's function on a small
        case and compares with the library's reference.
    signature : str
        How the function is called, shown when the answer is not a function.

    Examples
    --------
    >>> c = Code(lambda f: (f(2) == 4, "f(2) should be 4"), "f(x)")
    >>> c(lambda x: x * 2)[0], c(lambda x: x + 3)
    (True, (False, 'f(2) should be 4'))
    """

    kind = "code"

    def __init__(self, judge, signature):
        self.judge, self.signature = judge, signature

    def __call__(self, value):
        if not callable(value):
            return False, f"Pass your function itself: `{self.signature}`."
        try:
            return self.judge(value)
        except Exception as exc:  # the student's code failed: say how, do not crash the cell
            return False, f"your function raised {type(exc).__name__}: {exc}"


# ------------------------------------------------------------------ question


class Question:
    """One question or exercise of a lesson.

    Parameters
    ----------
    name : str
        How the lesson calls it (``"q3"``, ``"ex2"``, ``"step4"``).
    prompt : str
        The question in one or two sentences and how to answer (Markdown).
    checker : Choice, Truth, Number, Within, Parts or Code
        Judges the answer.
    hints : sequence of str
        Nudges, the first one gentle.
    solution : str
        The worked answer (Markdown); shown folded.
    right, wrong : tuple or dict
        An answer the check accepts and one it refuses (positional arguments as a
        tuple, named parts as a dict): the tests call ``check`` with both.

    Examples
    --------
    >>> q = Question(
    ...     "q1",
    ...     "Which way is up?",
    ...     Choice("a", {"a": "dy < 0", "b": "dy > 0"}),
    ...     hints=["Rows grow downwards."],
    ...     solution="Rows grow downwards, so up is dy < 0.",
    ...     right=("a",),
    ...     wrong=("b",),
    ... )
    >>> bool(q.check("a")), bool(q.check("b"))
    (True, False)
    >>> q.check().status
    'unanswered'
    """

    def __init__(self, name, prompt, checker, *, hints=(), solution="", right=None, wrong=None):
        self.name = name
        self.prompt = textwrap.dedent(prompt).strip()
        self.checker = checker
        self.hints = [textwrap.dedent(h).strip() for h in hints]
        self._solution = textwrap.dedent(solution).strip()
        self.right, self.wrong = right, wrong

    def _call(self, answer, named):
        if isinstance(self.checker, Parts):
            if answer:
                return False, "Give the parts by name: " + ", ".join(
                    f"{k}=..." for k in self.checker.checkers
                )
            return self.checker(**named)
        if named:
            return False, "This question takes one answer, not named parts."
        if len(answer) != 1:
            return False, "Give one answer."
        return self.checker(answer[0])

    def check(self, *answer, **named):
        """Judge an answer.

        Parameters
        ----------
        *answer
            The answer (one value: a letter, a number, True/False or a function).
        **named
            The named parts, for a question with several.

        Returns
        -------
        Feedback
            Truthy when correct.
        """
        blank_parts = bool(named) and all(_is_blank(v) for v in named.values())
        if (
            (not answer and not named)
            or (len(answer) == 1 and _is_blank(answer[0]))
            or (blank_parts and not answer)
        ):
            return Feedback("unanswered", self._how(), self.name)
        ok, note = self._call(answer, named)
        if ok:
            return Feedback("correct", note or "well done.", self.name)
        return Feedback("incorrect", note, self.name)

    def hint(self, n=None):
        """A nudge: the first hint, or hint ``n`` (1-based); all of them with ``n=0``.

        Returns
        -------
        Feedback
        """
        if not self.hints:
            return Feedback("hint", "No hint for this one: re-read the section above.", self.name)
        if n == 0:
            return Feedback("hint", "\n\n".join(self.hints), self.name)
        k = 1 if n is None else int(n)
        if not 1 <= k <= len(self.hints):
            raise ValueError(f"n must be in 1..{len(self.hints)} (or 0 for all), got {n!r}")
        more = f" (more: `{PREFIX}{self.name}.hint({k + 1})`)" if k < len(self.hints) else ""
        return Feedback("hint", self.hints[k - 1] + more, self.name)

    def solution(self):
        """The worked answer, folded; a notice instead when solutions are turned off.

        Returns
        -------
        Feedback
        """
        if not solutions_shown():
            return Feedback(
                "hidden",
                f"solutions are turned off for this session ({ENV}=0 or "
                "`fluidnb.lessons.show_solutions(False)`). The check still says right or wrong.",
                self.name,
            )
        return Feedback("solution", self._solution, self.name)

    def _how(self):
        checker, call = self.checker, f"{PREFIX}{self.name}.check"
        if isinstance(checker, Choice):
            how = f"call `{call}(...)` with the letter of one option (a string):\n\n"
            how += checker.describe()
        elif isinstance(checker, Truth):
            how = f"call `{call}(True)` or `{call}(False)`."
        elif isinstance(checker, Parts):
            how = f"call `{call}({', '.join(f'{k}=...' for k in checker.checkers)})`."
            for key, part in checker.checkers.items():
                if isinstance(part, Choice):
                    how += f"\n\n`{key}`, one of:\n\n" + part.describe()
        elif isinstance(checker, Code):
            how = f"write the function `{checker.signature}` and call `{call}(your_function)`."
        else:
            unit = f" (in {checker.unit})" if getattr(checker, "unit", "") else ""
            how = f"call `{call}(your_number)`{unit}."
        return f"{self.prompt}\n\nTo answer, {how}"

    def _repr_markdown_(self):
        return Feedback("question", f"**{self.name}.** " + self._how()).text

    def __repr__(self):
        return f"<Question {self.name}: {_plain(self.prompt)[:60]}>"


def close(a, b, rtol=1e-9, atol=1e-12):
    """Whether two arrays agree to round-off (a helper for :class:`Code` judges).

    Returns
    -------
    bool
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=rtol, atol=atol))


def isclose(a, b, rel=1e-9):
    """Two numbers equal to round-off.

    Returns
    -------
    bool
    """
    return math.isclose(float(a), float(b), rel_tol=rel, abs_tol=1e-12)
