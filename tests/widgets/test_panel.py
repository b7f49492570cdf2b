from dataclasses import dataclass

import ipywidgets as W
import numpy as np
import pytest

from fluidnb import Params, param
from fluidnb.widgets import ParamPanel


@dataclass(frozen=True)
class Demo(Params):
    sigma: float = param(
        5.0, lo=0, lo_open=True, symbol=r"\sigma", eq="Eq. (6)", log=True, ui_range=(0.1, 100)
    )
    lam: float = param(1.0, lo=0, hi=10, symbol=r"\lambda", eq="Eq. (6)")
    rth: float = param(0.0, lo=0, hi=1, symbol="r_{th}", doc="random threshold")
    T: int = param(64, lo=2, hi=256, integer=True)
    f0: int = param(4, lo=1, hi=64, integer=True)
    mapping: str = param("convex", choices=("plane", "convex", "concave"))
    shade: bool = param(True)

    def check(self):
        if self.f0 >= self.T / 2:
            raise ValueError(f"f0 must be < T / 2 = {self.T / 2:g}, got {self.f0}")


def test_one_control_per_field_with_paper_defaults_and_tooltips():
    panel = ParamPanel(Demo)
    assert list(panel.controls) == list(Demo.specs())
    assert isinstance(panel.controls["sigma"], W.FloatLogSlider)
    assert isinstance(panel.controls["lam"], W.FloatSlider)
    assert isinstance(panel.controls["T"], W.IntSlider)
    assert isinstance(panel.controls["mapping"], W.Dropdown)
    assert isinstance(panel.controls["shade"], W.Checkbox)
    for name, control in panel.controls.items():
        assert control.value == getattr(Demo(), name)
    assert "Eq. (6)" in panel.controls["sigma"].tooltip
    # The paper's symbols as HTML and Unicode, never LaTeX: Voila with no network has
    # no MathJax to typeset "$\sigma$" (issue 22, point 9).
    assert panel.controls["sigma"].description == "<b>σ</b>"
    assert panel.controls["lam"].description == "<b>λ</b>"
    assert panel.controls["rth"].description == (
        "<b>r<span style='vertical-align:sub;font-size:75%'>th</span></b>"
    )
    assert panel.controls["T"].description == "T"
    assert panel.controls["sigma"].description_allow_html
    assert panel.controls["sigma"].tooltip.startswith("sigma (σ) Eq. (6)")
    for control in panel.controls.values():
        assert "$" not in control.description
        assert "$" not in control.tooltip
    # Within the ui_range (0.1, 100) and as wide as the grid through the default allows.
    assert -1 <= panel.controls["sigma"].min < -1 + 0.01
    assert 2 - 0.01 < panel.controls["sigma"].max <= 2
    assert panel.controls["rth"].max == 1


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("sigma", 20.0),
        ("lam", 3.5),
        ("rth", 0.8),
        ("T", 100),
        ("f0", 10),
        ("mapping", "plane"),
        ("shade", False),
    ],
)
def test_every_field_round_trips(name, value):
    panel = ParamPanel(Demo)
    panel.set(name, value)
    assert (
        getattr(panel.params, name) == pytest.approx(value)
        if isinstance(value, float)
        else (getattr(panel.params, name) == value)
    )
    assert isinstance(panel.params, Demo)
    panel.controls[name].value = getattr(Demo(), name)
    assert panel.params == Demo()


def test_out_of_range_is_refused_with_message_and_control_unchanged():
    panel = ParamPanel(Demo)
    with pytest.raises(ValueError, match=r"rth must be in \[0, 1\], got 1.3"):
        panel.set("rth", 1.3)
    assert panel.controls["rth"].value == 0
    assert "rth must be in [0, 1]" in panel._msg.value
    assert panel.params == Demo()


def test_invalid_combination_is_shown_not_raised():
    panel = ParamPanel(Demo)
    seen = []
    panel.observe(lambda c: seen.append(c["new"]), "params")
    # The T slider does not go below 2 f0 + 1 = 9 (issue 36); set from code, the
    # refused value is shown in the panel.
    assert panel.controls["T"].min == 9
    with pytest.raises(ValueError, match="f0 must be < T / 2"):
        panel.set("T", 6)  # f0 = 4 >= 3: invalid, shown in the panel
    assert not panel.valid
    assert "f0 must be < T / 2" in panel.message
    assert "f0 must be" in panel._msg.value
    assert panel.params.T == 64  # still the last valid object
    panel.controls["f0"].value = 2
    assert panel.valid
    assert panel.params == Demo(T=6, f0=2)
    assert seen == [Demo(T=6, f0=2)]


def test_reset_to_paper_defaults_and_set_params():
    panel = ParamPanel(Demo(sigma=50, rth=0.5))
    assert panel.controls["sigma"].value == pytest.approx(50)
    panel._reset.click()
    assert panel.params == Demo()
    panel.set_params(Demo(lam=2))
    assert panel.params.lam == 2
    with pytest.raises(ValueError, match="params must be a Demo"):
        panel.set_params(object())


def test_exclude_and_bad_arguments():
    panel = ParamPanel(Demo, exclude=["shade"])
    assert "shade" not in panel.controls
    assert panel.params.shade is True
    with pytest.raises(ValueError, match="no parameter 'nope'"):
        panel.set("nope", 1)
    with pytest.raises(ValueError, match=r"params must be a fluidnb\.Params"):
        ParamPanel(dict)


@pytest.mark.parametrize("name", list(Demo.specs()))
def test_paper_defaults_lie_on_the_slider_grid(name):
    # The browser snaps a slider's value to min + n * step: a default off that grid
    # would be changed just by showing the panel.
    control = ParamPanel(Demo).controls[name]
    if not hasattr(control, "step"):
        return
    default = getattr(Demo(), name)
    position = np.log10(default) if isinstance(control, W.FloatLogSlider) else default
    n = (position - control.min) / control.step
    assert n == pytest.approx(round(n), abs=1e-6)
    assert control.min <= position <= control.max


def test_log_slider_keeps_an_awkward_default_exactly():
    @dataclass(frozen=True)
    class G(Params):
        gamma: float = param(0.005, lo=1e-4, hi=0.5, log=True)

    control = ParamPanel(G).controls["gamma"]
    assert 10 ** (
        control.min + round((np.log10(0.005) - control.min) / control.step) * control.step
    ) == pytest.approx(0.005, rel=1e-9)


def test_groups_show_the_first_and_fold_the_rest():
    # Issue 22, point 3: a compact panel, the rarely touched parameters folded.
    panel = ParamPanel(Demo, groups=[("main", ["sigma", "lam"]), ("loop", ["T", "f0"])])
    assert list(panel.groups) == ["main", "loop", "more"]
    assert panel.groups["more"] == ["rth", "mapping", "shade"]  # nothing left out
    first, accordion = panel.children[:2]
    assert first.children == (panel.controls["sigma"], panel.controls["lam"])
    assert isinstance(accordion, W.Accordion)
    assert accordion.titles == ("loop", "more")
    assert accordion.selected_index is None  # folded
    panel.show_group("more")
    assert accordion.selected_index == 1
    # A folded control still drives the parameters.
    panel.set("rth", 0.5)
    assert panel.params.rth == 0.5
    with pytest.raises(ValueError, match="no group 'nope'"):
        panel.show_group("nope")
    with pytest.raises(ValueError, match="groups name lam twice"):
        ParamPanel(Demo, groups=[("a", ["lam"]), ("b", ["lam"])])
    plain = ParamPanel(Demo)
    assert plain.accordion is None
    assert list(plain.groups) == ["parameters"]


def test_the_apps_group_their_panels_with_the_open_group_first():
    from fluidnb.widgets import _fire, _flicker, _frost, _turbulence

    for module in (_fire, _flicker, _frost, _turbulence):
        names = [n for _, fields in module.GROUPS for n in fields]
        assert len(names) == len(set(names)), module.__name__
        assert len(module.GROUPS[0][1]) <= 5  # the open group stays short


def test_a_log_slider_spans_decades_on_a_grid_through_the_default():
    panel = ParamPanel(Demo)
    sigma = panel.controls["sigma"]
    assert isinstance(sigma, W.FloatLogSlider)
    # Three decades, ends within one step (0.01 of a decade) of the ui_range (0.1, 100).
    assert -1 <= sigma.min < -1 + sigma.step
    assert 2 - sigma.step < sigma.max <= 2
    for value in (0.2, 1.0, 10.0, 90.0):
        panel.set("sigma", value)
        assert panel.params.sigma == pytest.approx(value)
