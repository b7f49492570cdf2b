"""Parameter objects: frozen dataclasses whose fields carry the paper's symbols.

A method declares its parameters once::

    @dataclass(frozen=True)
    class FrostParams(Params):
        rth: float = param(
            0.0,
            lo=0,
            hi=1,
            symbol=r"r_{th}",
            eq="(1)",
            doc="random threshold of the constant addition",
        )

and gets validation on construction, ``replace``, JSON round-trips, and the
metadata (range, symbol, equation, log scale) from which the widgets build sliders
and the command line builds options.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import numbers
from dataclasses import dataclass
from typing import Any

from ._validation import check_choice, check_int, check_range

__all__ = ["ParamSpec", "Params", "param"]

_KEY = "fluidnb"


@dataclass(frozen=True)
class ParamSpec:
    r"""What a parameter field allows and means (read by widgets and the CLI).

    Attributes
    ----------
    name : str
        The field name (the paper's symbol spelled out: ``sigma``, ``lam``).
    default : object
        The paper's value.
    lo, hi : float or None
        Allowed range (inclusive unless ``lo_open``/``hi_open``).
    integer : bool
        Whole numbers only.
    choices : tuple or None
        Allowed values for a categorical parameter.
    symbol : str
        The paper's symbol in LaTeX (``r"\sigma"``).
    eq : str
        Where it appears in the paper (``"Eq. (6)"``).
    doc : str
        One line on what it does.
    log : bool
        Whether a slider should move on a log scale (sigma, lambda, rho).
    step : float or None
        Slider step.
    unit : str
        Unit shown next to the value (``"px"``, ``"frames"``).
    ui_range : tuple of float or None
        The range a slider offers when it is narrower than (or ``lo``/``hi`` leave
        open) the allowed range; the object itself still accepts the full range.
    """

    name: str
    default: Any
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    choices: tuple | None = None
    symbol: str = ""
    eq: str = ""
    doc: str = ""
    log: bool = False
    step: float | None = None
    unit: str = ""
    ui_range: tuple | None = None

    @property
    def kind(self):
        """``"choice"``, ``"bool"``, ``"int"`` or ``"float"``."""
        if self.choices is not None:
            return "choice"
        if isinstance(self.default, bool):
            return "bool"
        return "int" if self.integer else "float"

    def validate(self, value):
        """Return ``value`` normalised to the field's type, or raise ValueError."""
        kind = self.kind
        if kind == "choice":
            return check_choice(self.name, value, self.choices)
        if kind == "bool":
            if not isinstance(value, (bool, numbers.Integral)) or value not in (0, 1):
                raise ValueError(f"{self.name} must be True or False, got {value!r}")
            return bool(value)
        if kind == "int":
            return check_int(self.name, value, self.lo, self.hi)
        return check_range(
            self.name, value, self.lo, self.hi, lo_open=self.lo_open, hi_open=self.hi_open
        )

    def describe(self):
        """A one-line tooltip: symbol, equation, meaning, range."""
        parts = [f"{self.name}"]
        if self.symbol:
            parts.append(f"(${self.symbol}$)")
        if self.eq:
            parts.append(f"{self.eq}")
        text = " ".join(parts)
        if self.doc:
            text += f": {self.doc}"
        if self.choices is None and (self.lo is not None or self.hi is not None):
            lo = "-inf" if self.lo is None else f"{self.lo:g}"
            hi = "inf" if self.hi is None else f"{self.hi:g}"
            text += f" [{lo}, {hi}]"
        return text


def param(
    default,
    *,
    lo=None,
    hi=None,
    lo_open=False,
    hi_open=False,
    integer=False,
    choices=None,
    symbol="",
    eq="",
    doc="",
    log=False,
    step=None,
    unit="",
    ui_range=None,
):
    """Declare a parameter field with its paper default, range and meaning.

    Returns a :func:`dataclasses.field` whose metadata holds a :class:`ParamSpec`.
    See :class:`ParamSpec` for the arguments.
    """
    spec = ParamSpec(
        name="",
        default=default,
        lo=lo,
        hi=hi,
        lo_open=lo_open,
        hi_open=hi_open,
        integer=integer,
        choices=None if choices is None else tuple(choices),
        symbol=symbol,
        eq=eq,
        doc=doc,
        log=log,
        step=step,
        unit=unit,
        ui_range=None if ui_range is None else tuple(ui_range),
    )
    return dataclasses.field(default=default, metadata={_KEY: spec})


@dataclass(frozen=True)
class Params:
    """Base class of every method's parameter object.

    Subclasses are ``@dataclass(frozen=True)`` with fields made by :func:`param`.
    Construction validates every field (and the cross-field rules in
    :meth:`check`), so an invalid parameter object cannot exist.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Demo(Params):
    ...     rth: float = param(0.0, lo=0, hi=1, symbol="r_{th}")
    >>> Demo().replace(rth=0.8)
    Demo(rth=0.8)
    >>> Demo(rth=1.3)
    Traceback (most recent call last):
    ...
    ValueError: rth must be in [0, 1], got 1.3
    """

    def __post_init__(self):
        for spec in self.specs().values():
            # Normalise (e.g. 4.0 -> 4 for an integer field) on a frozen instance.
            object.__setattr__(self, spec.name, spec.validate(getattr(self, spec.name)))
        self.check()

    def check(self):
        """Cross-field rules; subclasses override and raise ValueError."""

    @classmethod
    def specs(cls):
        """Mapping of field name to :class:`ParamSpec`, in declaration order."""
        return dict(_specs_of(cls))

    def replace(self, **changes):
        """A new, validated object with some fields changed."""
        unknown = set(changes) - set(self.specs())
        if unknown:
            raise ValueError(self._unknown_message(unknown))
        return dataclasses.replace(self, **changes)

    def to_dict(self):
        """The fields as a plain dict (JSON-serialisable)."""
        return {name: getattr(self, name) for name in self.specs()}

    @classmethod
    def from_dict(cls, values):
        """Build from a dict such as :meth:`to_dict` made; unknown keys are refused."""
        unknown = set(values) - set(cls.specs())
        if unknown:
            raise ValueError(cls._unknown_message(unknown))
        return cls(**values)

    def to_json(self):
        """The fields as a JSON string."""
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text):
        """Inverse of :meth:`to_json`."""
        try:
            values = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"parameters are not valid JSON: {exc}") from None
        except RecursionError:
            raise ValueError("parameters are not valid JSON: nested too deeply") from None
        if not isinstance(values, dict):
            raise ValueError("parameters must be a JSON object of name: value")
        return cls.from_dict(values)

    @classmethod
    def _unknown_message(cls, unknown):
        names = ", ".join(sorted(unknown))
        return f"unknown parameter(s) {names} for {cls.__name__}; allowed: {', '.join(cls.specs())}"


@functools.cache
def _specs_of(cls):
    """:meth:`Params.specs` of ``cls``, made once per class (the specs are frozen).

    Every Params object validates its fields with them when it is made: a slider's
    move made ~1000 of them (the panel probes which values the other sliders accept),
    and building the specs was most of that (FireApp: 7.5 ms of the kernel's thread
    per move, beside the preview).
    """
    out = {}
    for f in dataclasses.fields(cls):
        spec = f.metadata.get(_KEY)
        if spec is None:
            spec = ParamSpec(name=f.name, default=f.default)
        out[f.name] = dataclasses.replace(spec, name=f.name)
    return out
