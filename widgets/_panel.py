"""A parameter panel generated from a method's parameter dataclass."""

from __future__ import annotations

import functools
import html
import math
import re

import ipywidgets as W
from traitlets import Any, Bool, Unicode

from fluidnb import Params

from ._common import math_html, math_text

__all__ = ["ParamPanel"]


class ParamPanel(W.VBox):
    """One control per field of a :class:`fluidnb.Params` subclass.

    Sliders start at the paper's defaults, span the field's range (log scale where
    the field asks for it: sigma, lambda, rho), and carry a tooltip with the paper's
    symbol and equation. They offer only values the method accepts: their ends are
    exact (no -5.55e-17 from float arithmetic); an integer whose accepted values
    are not a run (powers of two, divisors of a grid) gets a slider over those
    values alone; and the range of an integer that another field bounds
    (``f0 < T / 2``, ``overlap < interval``) follows that field as it moves. Each
    label shows the field's name and the paper's symbol in plain HTML (σ, r_th as r
    with a subscript): it reads the same in JupyterLab and in Voila with no network
    for MathJax. :attr:`params` always holds a valid parameter object; an
    invalid combination is shown in the panel (and :attr:`valid` turns False) instead
    of raising.

    The controls come in *groups*: the first is always shown, the others are folded
    in an accordion under it (the rarely touched ones), so the panel stays short
    beside the canvas and the result.

    Parameters
    ----------
    params : Params subclass or instance
        The parameter class (defaults) or a starting object.
    exclude : sequence of str
        Fields to leave out of the panel (they keep their values).
    continuous_update : bool
        Whether sliders report while dragging (apps throttle their previews).
    groups : sequence of (str, sequence of str), optional
        ``(title, field names)`` pairs in the order shown; the first group is open,
        the rest folded. Fields no group names join a last group, "more". Default:
        every field in one group.
    width : str
        CSS width of each control.
    check : callable, optional
        ``check(params)``, raising ValueError for settings the app refuses beyond the
        parameter class's own rules (a patch size that must divide the app's grid,
        say); the sliders offer only values it accepts (see :meth:`follow`).

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> from fluidnb import Params, param
    >>> @dataclass(frozen=True)
    ... class P(Params):
    ...     rth: float = param(0.0, lo=0, hi=1, symbol="r_{th}")
    >>> panel = ParamPanel(P)
    >>> panel.set("rth", 0.4)
    >>> panel.params
    P(rth=0.4)
    """

    #: The current, valid parameter object.
    params = Any()
    #: False while the controls hold an invalid combination (see :attr:`message`).
    valid = Bool(True)
    #: What is wrong with the controls, in plain words ("" when valid).
    message = Unicode("")

    def __init__(
        self,
        params,
        *,
        exclude=(),
        continuous_update=True,
        groups=None,
        width="330px",
        check=None,
    ):
        if isinstance(params, type) and issubclass(params, Params):
            params = params()
        if not isinstance(params, Params):
            raise ValueError(f"params must be a fluidnb.Params class or object, got {params!r}")
        self._cls = type(params)
        self._check = check
        self._specs = {n: s for n, s in self._cls.specs().items() if n not in set(exclude)}
        self.controls = {
            name: _control(spec, getattr(params, name), continuous_update, width)
            for name, spec in self._specs.items()
        }
        # An integer whose accepted values around the default are not a run becomes a
        # slider over those values alone (powers of two, divisors).
        self._grids = {}  # name -> every value the slider's range offers
        for name, control in list(self.controls.items()):
            if isinstance(control, W.IntSlider):
                grid = list(range(control.min, control.max + 1, control.step))
                self._grids[name] = grid
                if len(grid) <= _PROBE_ALL:
                    ok = [v for v in grid if self._accepts(params, name, v)]
                    if ok and ok != grid[grid.index(ok[0]) : grid.index(ok[-1]) + 1]:
                        self.controls[name] = _selection(control, ok, params, name)
        #: The groups as shown: ``{title: [field names]}``, the first one open.
        self.groups = _groups(groups, list(self.controls))
        self._quiet = False
        for name, control in self.controls.items():
            control.add_class(f"fluidnb-param-{name}")
            control.observe(self._control_changed, "value")
        self._reset = W.Button(
            description="Paper defaults",
            icon="refresh",
            tooltip="Reset every field to the paper's value",
        )
        self._reset.add_class("fluidnb-reset")
        self._reset.on_click(lambda _: self.reset())
        self._reset.layout.width = "auto"
        self._msg = W.HTML()
        self._msg.add_class("fluidnb-param-message")
        boxes = [W.VBox([self.controls[n] for n in names]) for names in self.groups.values()]
        folded = []
        if len(boxes) > 1:
            #: The folded groups (None when every control is in the first).
            self.accordion = W.Accordion(children=boxes[1:], titles=tuple(self.groups)[1:])
            self.accordion.selected_index = None
            # As wide as the panel (it stuck out by its padding and was cut off at the
            # right edge of a page 1400 px wide): its controls are narrower instead.
            self.accordion.layout.width = width
            for names in list(self.groups.values())[1:]:
                for n in names:
                    self.controls[n].layout.width = f"calc({width} - 30px)"
            self.accordion.add_class("fluidnb-param-groups")
            folded = [self.accordion]
        else:
            self.accordion = None
        super().__init__([*boxes[:1], *folded, self._reset, self._msg])
        self.add_class("fluidnb-panel")
        self.params = params
        self.follow()

    # ------------------------------------------------------------------ ranges
    def _accepts(self, params, name, value):
        """Whether ``params`` with ``name`` = ``value`` is accepted (class and app)."""
        try:
            new = params.replace(**{name: value})
            if self._check is not None:
                self._check(new)
        except ValueError:
            return False
        return True

    def set_check(self, check):
        """Replace the app's extra check (the app's grid changed, say), then :meth:`follow`."""
        self._check = check
        self.follow()

    def follow(self):
        """Narrow each integer slider to the values accepted with the others as they are.

        A slider whose range runs into another field's bound (``T`` above ``2 f0``,
        ``overlap`` below ``interval``) ends where that bound is; a slider over
        chosen values offers those accepted now. The current value always stays.
        """
        params = self.params
        if params is None or not self.valid:
            return
        self._quiet = True
        try:
            for name, grid in self._grids.items():
                control = self.controls[name]
                value = getattr(params, name)
                if isinstance(control, W.SelectionSlider):
                    ok = [v for v in grid if v == value or self._accepts(params, name, v)]
                    if list(control.options) != ok:
                        # (Not under hold_trait_notifications: it validates the value
                        # against the old options.)
                        control.options = ok
                        control.value = value
                    continue
                if value not in grid:
                    continue
                i = grid.index(value)
                accepts = functools.partial(self._accepts, params, name)
                lo = _edge(grid, i, 0, accepts)
                hi = _edge(grid, i, len(grid) - 1, accepts)
                with control.hold_trait_notifications():
                    if lo > control.max:
                        control.max = hi
                        control.min = lo
                    else:
                        control.min = lo
                        control.max = hi
        finally:
            self._quiet = False

    def toggle(self, name, button_width="64px"):
        """A field's choices as toggle buttons to place elsewhere (its control hides).

        The buttons and the panel's control stay bound: :attr:`params` follows either.
        """
        control = self.controls[name]
        if not isinstance(control, W.Dropdown):
            raise ValueError(f"{name} is not a choice; only choices become toggle buttons")
        buttons = W.ToggleButtons(
            options=list(control.options),
            value=control.value,
            tooltip=control.tooltip,
            style={"button_width": button_width},
            layout=W.Layout(width="auto"),
        )
        W.link((buttons, "value"), (control, "value"))
        control.layout.display = "none"
        return buttons

    def show_group(self, title):
        """Unfold the group ``title`` (as a click on its heading does)."""
        titles = list(self.groups)
        if title not in titles:
            raise ValueError(f"no group {title!r}; the panel has {', '.join(titles)}")
        if titles.index(title) > 0:
            self.accordion.selected_index = titles.index(title) - 1

    def _gather(self):
        values = self.params.to_dict() if self.params is not None else {}
        values.update({name: c.value for name, c in self.controls.items()})
        return values

    def _control_changed(self, change):
        if self._quiet:
            return
        self._apply(self._gather())

    def _apply(self, values):
        try:
            new = self._cls(**values)
        except ValueError as exc:
            self.message = str(exc)
            self.valid = False
            self._msg.value = (
                "<span style='color:var(--jp-error-color1, #d32f2f)'>"
                f"&#9888; {html.escape(str(exc))}</span>"
            )
            return False
        self.message = ""
        self.valid = True
        self._msg.value = ""
        if new != self.params:
            self.params = new
            self.follow()
        return True

    def set(self, name, value):
        """Set one field as a user would; a refused value raises ValueError.

        The message is shown in the panel too, and the control goes back to the last
        valid value.
        """
        if name not in self.controls:
            raise ValueError(f"no parameter {name!r}; the panel has {', '.join(self.controls)}")
        spec = self._specs[name]
        try:
            value = spec.validate(value)
        except ValueError as exc:
            self._msg.value = (
                "<span style='color:var(--jp-error-color1, #d32f2f)'>"
                f"&#9888; {html.escape(str(exc))}</span>"
            )
            self.message = str(exc)
            raise
        control = self.controls[name]
        if name in self._grids and value in self._grids[name]:
            # Beyond the values the other fields allow now: widen the slider (quietly),
            # so the panel says why the value is refused.
            self._quiet = True
            try:
                if isinstance(control, W.IntSlider):
                    control.min, control.max = min(control.min, value), max(control.max, value)
                elif isinstance(control, W.SelectionSlider) and value not in control.options:
                    control.options = self._grids[name]
                    control.value = getattr(self.params, name)
            finally:
                self._quiet = False
        control.value = value
        if not self.valid:
            raise ValueError(self.message)

    def set_params(self, params):
        """Load a whole parameter object into the controls."""
        if not isinstance(params, self._cls):
            raise ValueError(f"params must be a {self._cls.__name__}, got {type(params).__name__}")
        self._quiet = True
        try:
            for name, control in self.controls.items():
                value = getattr(params, name)
                grid = self._grids.get(name)
                if grid is not None and isinstance(control, W.IntSlider) and value in grid:
                    # The ranges followed the old values: open them for the new ones.
                    control.min, control.max = min(grid[0], value), max(grid[-1], value)
                elif isinstance(control, W.SelectionSlider) and value not in control.options:
                    control.options = self._grids[name]
                control.value = value
        finally:
            self._quiet = False
        self._apply(params.to_dict())
        self.follow()

    def reset(self):
        """Back to the paper's defaults."""
        self.set_params(self._cls())


def _bounds(spec, default):
    lo, hi = spec.ui_range if spec.ui_range is not None else (spec.lo, spec.hi)
    if lo is None:
        lo = 0.0 if default >= 0 else default * 10
    if hi is None:
        hi = max(default * 10, lo + 1) if default > 0 else lo + 10
    return lo, hi


def _groups(groups, names):
    """``{title: [names]}`` from ``groups``; every name once, the leftovers in "more"."""
    if groups is None:
        return {"parameters": names}
    out, seen = {}, set()
    for title, fields in groups.items() if isinstance(groups, dict) else groups:
        fields = [f for f in fields if f in names]  # an excluded field is left out
        unknown = seen.intersection(fields)
        if unknown:
            raise ValueError(f"groups name {', '.join(sorted(unknown))} twice")
        seen.update(fields)
        if fields:
            out[str(title)] = fields
    rest = [n for n in names if n not in seen]
    if rest:
        out.setdefault("more", []).extend(rest)
    return out


def label_html(spec):
    """A control's label: the paper's symbol, after the field's name where that differs.

    A name that only spells the symbol out (``sigma``, ``rth``, ``kappa_b``, ``lam``)
    shows the symbol alone (σ, r_th, κ_b, λ, subscripts as subscripts); the tooltip
    names the field.
    """
    if not spec.symbol or math_html(spec.symbol) == html.escape(spec.name):
        return html.escape(spec.name)
    symbol = f"<b>{math_html(spec.symbol)}</b>"
    spelled = re.sub(r"[\\_{}\s]", "", spec.symbol)
    name = spec.name.replace("_", "")
    if name == spelled or (len(name) >= 3 and spelled.startswith(name)):
        return symbol
    return f"{html.escape(spec.name)} {symbol}"


def tooltip(spec):
    """The spec's one-line description, its symbol in Unicode (tooltips show no LaTeX)."""
    text = spec.describe()
    if spec.symbol:
        text = text.replace(f"(${spec.symbol}$)", f"({math_text(spec.symbol)})", 1)
    return text


def _control(spec, value, continuous_update, width="310px"):
    kind = spec.kind
    common = {
        "description": label_html(spec),
        "description_allow_html": True,
        "tooltip": tooltip(spec),
        "style": {"description_width": "96px"},
        "layout": W.Layout(width=width),
    }
    if kind == "choice":
        return W.Dropdown(options=list(spec.choices), value=value, **common)
    if kind == "bool":
        return W.Checkbox(value=value, indent=False, **common)
    lo, hi = _bounds(spec, spec.default)
    if kind == "int":
        step = int(spec.step or 1)
        lo, hi = _on_grid(int(spec.default), int(lo), int(hi), step)
        return W.IntSlider(
            value=value,
            min=int(lo),
            max=int(hi),
            step=step,
            continuous_update=continuous_update,
            **common,
        )
    if spec.log:
        lo = lo if lo > 0 else (spec.default / 100 if spec.default > 0 else 1e-3)
        step = spec.step or 0.01
        emin, emax = _on_grid(math.log10(spec.default), math.log10(lo), math.log10(hi), step)
        return W.FloatLogSlider(
            value=value,
            base=10,
            min=emin,
            max=emax,
            step=step,
            readout_format=".3g",
            continuous_update=continuous_update,
            **common,
        )
    step = spec.step or _nice_step(hi - lo)
    lo, hi = _on_grid(spec.default, lo, hi, step)
    return W.FloatSlider(
        value=value,
        min=lo,
        max=hi,
        step=step,
        readout_format=".3g",
        continuous_update=continuous_update,
        **common,
    )


def _on_grid(default, lo, hi, step):
    """Slider ends inside [lo, hi] whose grid (min + n * step) passes through ``default``.

    The browser's slider snaps values to that grid: were the paper's default off it,
    merely showing the panel would change the parameter (gamma = 0.005 would read
    0.00501 on a log slider).
    """
    below = math.floor((default - lo) / step + 1e-9)
    above = math.floor((hi - default) / step + 1e-9)
    return _exact(default - below * step, lo, step), _exact(default + above * step, hi, step)


def _exact(end, bound, step):
    """A slider end as the user reads it: ``bound`` itself when the grid lands on it.

    Float arithmetic put beta's 0 at -5.55e-17, which the method refuses; an end off
    the bound is rounded to the step's decimals.
    """
    if abs(end - bound) <= 1e-9 * max(abs(step), 1e-12):
        return type(end)(bound) if isinstance(end, int) else float(bound)
    if isinstance(end, int):
        return end
    digits = max(0, 12 - int(math.floor(math.log10(abs(step))))) if step else 12
    return round(end, min(digits, 15))


#: Integer sliders with at most this many values are probed value by value (to find
#: non-run sets of accepted values); longer ones only at the ends of their run.
_PROBE_ALL = 64


def _selection(slider, options, params, name):
    """A slider over ``options`` alone, with ``slider``'s label, tooltip and width."""
    control = W.SelectionSlider(
        options=options,
        value=getattr(params, name),
        description=slider.description,
        description_allow_html=True,
        tooltip=slider.tooltip,
        style={"description_width": slider.style.description_width},
        layout=W.Layout(width=slider.layout.width),
        continuous_update=slider.continuous_update,
    )
    slider.close()
    return control


def _edge(grid, i, end, ok):
    """The farthest index from ``i`` towards ``end`` whose value ``ok`` accepts.

    The accepted values around ``grid[i]`` (accepted) are taken to be a run: a
    bisection finds where it ends, so a long slider costs a few probes.
    """
    if ok(grid[end]):
        return grid[end]
    good, bad = i, end  # grid[good] accepted, grid[bad] refused
    while abs(bad - good) > 1:
        mid = (good + bad) // 2
        if ok(grid[mid]):
            good = mid
        else:
            bad = mid
    return grid[good]


def _nice_step(span):
    raw = span / 200.0
    mag = 10 ** math.floor(math.log10(raw)) if raw > 0 else 0.01
    for m in (1, 2, 5, 10):
        if raw <= m * mag:
            return m * mag
    return 10 * mag
