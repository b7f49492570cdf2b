"""The numbers a lesson asks the reader to set can be set with its app's sliders.

A question like "move λ from 1 to 10" is useless when the slider stops at 1
(issue 22, point 5). This test reads each lesson's Markdown for the settings it asks
for -- "set `azimuth` to 315", "set γ back to the paper's 0.005", "move X from A to
B", "press Run with 120 frames" -- and checks every number lies on the slider of the
app the lesson ends with. A lesson whose app is added here is checked too.
"""

import html
import json
import math
import re
from pathlib import Path

import pytest

from fluidnb.widgets import ParamPanel
from fluidnb.widgets._common import math_text

ROOT = Path(__file__).resolve().parents[1]
NUMBER = r"(-?\d[\d,]*(?:\.\d+)?(?:e-?\d+)?)"


def drift_params():
    """The drawing-tools lesson's own parameter class, from its app cell."""
    cells = json.loads((ROOT / "notebooks/01_drawing_tools.ipynb").read_text())["cells"]
    sources = ["".join(c["source"]) for c in cells]
    source = next(s for s in sources if "class DriftParams" in s)
    scope = {"QUICK": False}
    exec(source.split("def drift")[0], scope)  # the imports and the dataclass only
    return scope["DriftParams"]


def app_params(name):
    from fluidnb.flicker import FlickerParams
    from fluidnb.frost import FrostParams
    from fluidnb.turbulence import TurbulenceParams
    from fluidnb.videodb import AnimateParams
    from fluidnb.widgets._fire import FireAppParams

    return {
        "01_drawing_tools.ipynb": drift_params,
        "02_flicker.ipynb": lambda: FlickerParams,
        "03_frost.ipynb": lambda: FrostParams,
        "05_fire.ipynb": lambda: FireAppParams,
        "06_turbulence.ipynb": lambda: TurbulenceParams,
        "07a_videodb_database.ipynb": lambda: AnimateParams,
        "07b_videodb_animation.ipynb": lambda: AnimateParams,
    }[name]()


#: Lesson -> the settings its questions must find (a test that finds nothing is no test).
LESSONS = {
    "01_drawing_tools.ipynb": {("frames", 120.0)},
    "02_flicker.ipynb": {("azimuth", 315.0), ("beta", 4.0), ("beta", 0.0), ("kappa", 1.0)},
    "03_frost.ipynb": {("gamma", 0.005)},
    "05_fire.ipynb": {("weight", 0.9), ("overlap", 0.0)},
    "06_turbulence.ipynb": {("alpha", 0.0)},
    "07a_videodb_database.ipynb": {("candidates", 10.0)},
    "07b_videodb_animation.ipynb": {
        ("lam", 0.001),
        ("lam", 10.0),
        ("sigma", 1.0),
        ("sigma", 1000.0),
    },
}


def plain(markdown):
    """Markdown as the reader reads it: math in Unicode, no backticks or emphasis."""
    text = re.sub(r"\$\$?([^$]+)\$\$?", lambda m: math_text(m.group(1)), markdown)
    return html.unescape(re.sub(r"[`*_]{1,2}(?=\S)|(?<=\S)[`*_]{1,2}", "", text))


def asked(markdown, specs):
    """(field, number) pairs for every setting the text asks for."""
    names = {}
    for field, spec in specs.items():
        names[field] = field
        names[field.replace("_", " ")] = field
        if spec.symbol:
            names[math_text(spec.symbol)] = field
            names[math_text(spec.symbol).replace("_", "")] = field
    names["lambda"] = names.get("lam") or names.get("lambda")
    pattern = "|".join(sorted((re.escape(n) for n in names if n), key=len, reverse=True))
    name = rf"(?<![\w])({pattern})(?![\w])"
    verbs = r"(?:set|move|put|change|drag|raise|lower|turn|try|and)"
    text = plain(markdown)
    found = []
    # "set `azimuth` to 315", "and `beta` to 0", "set γ back to the paper's 0.005",
    # "raise `kappa` above 1", "set `alpha = 0`"
    for m in re.finditer(
        rf"{verbs}\s+(?:the\s+)?{name}(?:\s+slider)?\s*"
        rf"(?:(?:back\s+|down\s+|up\s+)?to|above|below|=)\s+(?:the paper's\s+)?{NUMBER}",
        text,
        re.IGNORECASE,
    ):
        found.append((names[m.group(1)], m.group(2)))
    # "move λ from 1 to 10", "move `beta` from 4 down to 0"
    for m in re.finditer(
        rf"{name}(?:\s+slider)?\s+from\s+{NUMBER}\s+(?:down\s+|up\s+)?to\s+{NUMBER}", text
    ):
        found += [(names[m.group(1)], m.group(2)), (names[m.group(1)], m.group(3))]
    # "press Run with 120 frames"
    for m in re.finditer(rf"\bwith\s+{NUMBER}\s+{name}", text):
        found.append((names[m.group(2)], m.group(1)))
    return {(field, float(value.replace(",", ""))) for field, value in found if field}


def slider_range(control):
    if type(control).__name__ == "FloatLogSlider":
        return 10**control.min, 10**control.max, control.step
    return control.min, control.max, control.step


def on_grid(control, value):
    """Whether the slider can show ``value``: the browser snaps it to min + n * step.

    A log slider's grid is in the exponent; a value within 1 % of a grid point reads
    the same in its 3-digit readout.
    """
    if type(control).__name__ == "FloatLogSlider":
        if value <= 0:
            return False
        n = round((math.log10(value) - control.min) / control.step)
        return abs(10 ** (control.min + n * control.step) / value - 1) < 0.01
    n = (value - control.min) / control.step
    return abs(n - round(n)) < 1e-6


@pytest.mark.parametrize("lesson", LESSONS)
def test_every_setting_a_lesson_asks_for_is_on_its_apps_sliders(lesson):
    cells = json.loads((ROOT / "notebooks" / lesson).read_text())["cells"]
    markdown = "\n\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
    params = app_params(lesson)
    panel = ParamPanel(params)
    settings = asked(markdown, params.specs())
    assert LESSONS[lesson] <= settings, f"{lesson}: the test no longer finds {LESSONS[lesson]}"
    off = []
    for field, value in sorted(settings):
        control = panel.controls[field]
        if not hasattr(control, "min"):
            continue  # a choice
        lo, hi, step = slider_range(control)
        slack = step if type(control).__name__ != "FloatLogSlider" else 0
        if not (lo - slack - 1e-12 <= value <= hi + slack + 1e-12) or math.isnan(value):
            off.append(f"{field} = {value:g} (the slider spans {lo:g}..{hi:g})")
        elif not on_grid(control, value):
            off.append(f"{field} = {value:g} (off the slider's grid: min + n * {step:g})")
    assert off == [], f"{lesson} asks for settings its app cannot make: {off}"
