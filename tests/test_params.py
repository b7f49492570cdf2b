import json
from dataclasses import FrozenInstanceError, dataclass

import pytest

from fluidnb import Params, param


@dataclass(frozen=True)
class Demo(Params):
    sigma: float = param(5.0, lo=0, lo_open=True, symbol=r"\sigma", eq="Eq. (6)", log=True)
    rth: float = param(0.0, lo=0, hi=1, symbol="r_{th}", doc="random threshold")
    T: int = param(64, lo=2, integer=True, unit="frames")
    f0: int = param(4, lo=1, integer=True)
    mapping: str = param("convex", choices=("plane", "convex", "concave"))
    shade: bool = param(True)

    def check(self):
        if self.f0 >= self.T / 2:
            raise ValueError(f"f0 must be < T / 2 = {self.T / 2:g}, got {self.f0}")


def test_defaults_and_specs():
    p = Demo()
    assert p.sigma == 5.0
    specs = Demo.specs()
    assert list(specs) == ["sigma", "rth", "T", "f0", "mapping", "shade"]
    assert specs["sigma"].log
    assert specs["sigma"].symbol == r"\sigma"
    assert specs["T"].kind == "int"
    assert specs["mapping"].kind == "choice"
    assert specs["shade"].kind == "bool"
    assert specs["rth"].kind == "float"
    assert "Eq. (6)" in specs["sigma"].describe()
    assert "[0, 1]" in specs["rth"].describe()


def test_validation_on_construction_and_replace():
    with pytest.raises(ValueError, match=r"rth must be in \[0, 1\], got 1.3"):
        Demo(rth=1.3)
    with pytest.raises(ValueError, match="sigma must be > 0"):
        Demo().replace(sigma=0)
    with pytest.raises(ValueError, match="mapping must be one of"):
        Demo(mapping="flat")
    with pytest.raises(ValueError, match="f0 must be < T / 2"):
        Demo(T=8, f0=4)
    with pytest.raises(ValueError, match="unknown parameter"):
        Demo().replace(lamda=1)
    with pytest.raises(ValueError, match="shade must be True or False"):
        Demo(shade="yes")


def test_integer_normalisation_and_immutability():
    p = Demo(T=32.0)
    assert p.T == 32
    assert type(p.T) is int
    with pytest.raises(FrozenInstanceError):
        p.T = 3


def test_json_round_trip():
    p = Demo(sigma=2.5, rth=0.4, mapping="plane", shade=False)
    assert Demo.from_json(p.to_json()) == p
    assert Demo.from_dict(json.loads(json.dumps(p.to_dict()))) == p
    with pytest.raises(ValueError, match="unknown parameter"):
        Demo.from_dict({"nope": 1})
    with pytest.raises(ValueError, match="not valid JSON"):
        Demo.from_json("{")


def test_specs_are_made_once_per_class_and_each_caller_gets_its_own_mapping():
    # The specs are built once per class (a slider's move makes ~1000 Params when the
    # panel probes the other sliders' ranges); a caller changing its mapping changes
    # no one else's.
    first = Demo.specs()
    first.pop(next(iter(first)))
    first["bogus"] = None
    again = Demo.specs()
    assert "bogus" not in again
    assert list(again) == [f for f in Demo.__dataclass_fields__]
    assert all(again[name] is spec for name, spec in Demo.specs().items())  # made once
    with pytest.raises(ValueError, match="bogus"):
        Demo().replace(bogus=1)
