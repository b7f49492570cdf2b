"""Small pieces the apps share: a safe drop-down, the output folder, counted nouns."""

from __future__ import annotations

import html
import io
import os
import re
from pathlib import Path

import ipywidgets as W
from PIL import Image

from fluidnb import to_uint8

__all__ = [
    "Choice",
    "hint",
    "jpeg",
    "math_html",
    "math_text",
    "output_dir",
    "plural",
    "row",
    "shown_path",
]

# LaTeX names of the Greek letters the papers use, as Unicode.
_GREEK = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "varepsilon": "ε",
    "zeta": "ζ", "eta": "η", "theta": "θ", "kappa": "κ", "lambda": "λ", "mu": "μ", "nu": "ν",
    "xi": "ξ", "pi": "π", "rho": "ρ", "sigma": "σ", "tau": "τ", "phi": "φ", "chi": "χ",
    "psi": "ψ", "omega": "ω", "Delta": "Δ", "Gamma": "Γ", "Lambda": "Λ", "Sigma": "Σ",
    "Phi": "Φ", "Omega": "Ω",
}  # fmt: skip
# Sub- and superscripts as styled spans: a widget's label keeps only a few tags (b, i,
# span...; no sub or sup) but keeps style attributes.
_SCRIPT_STYLE = {
    "sub": "vertical-align:sub;font-size:75%",
    "super": "vertical-align:super;font-size:75%",
}
_SCRIPT = re.compile(r"([_^])(\{([^{}]*)\}|\\[A-Za-z]+|.)")

#: The folder exports go to, beside the notebook, unless ``$FLUIDNB_OUTPUT_DIR`` says.
OUTPUT_DIR = "fluidnb-output"


class Choice(W.Dropdown):
    """A drop-down whose options and value change together, as one pick.

    Assigning a plain Dropdown's ``options`` resets its value to the first option and
    tells every observer of ``value``: a photo picker would load its first photo
    while the app was only adding "upload" to the list. Here :meth:`set_options`
    changes both at once, and the callbacks registered with :meth:`on_pick` see only
    picks -- the user's, :attr:`value` set from code, or the outcome of
    :meth:`set_options` when it differs from the value before -- never the
    passing reset.

    Examples
    --------
    >>> picks = []
    >>> c = Choice(options=["stream", "clouds"], value="clouds")
    >>> c.on_pick(picks.append)
    >>> c.set_options(["stream", "clouds", "upload"], "upload")
    >>> c.value, picks
    ('upload', ['upload'])
    >>> c.set_options(["stream", "clouds", "upload"], "upload")  # nothing changed
    >>> picks
    ['upload']
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._callbacks = []
        self._holding = False
        self.observe(self._on_value, "value")

    def on_pick(self, callback):
        """Call ``callback(value)`` after each pick (not while options change)."""
        self._callbacks.append(callback)

    def _on_value(self, change):
        if not self._holding:
            self._picked(change["new"])

    def _picked(self, value):
        for callback in list(self._callbacks):
            callback(value)

    def set_options(self, options, value=None):
        """New ``options`` and ``value`` at once (default: keep the value if it stays).

        A value not among the options is a ValueError, and the drop-down keeps its
        old options and value.
        """
        options = list(options)
        values = [o[1] if isinstance(o, tuple) else o for o in options]
        if value is None:
            value = self.value if self.value in values else (values[0] if values else None)
        elif value not in values:
            raise ValueError(f"value {value!r} is not among the options {values}")
        old = self.value
        self._holding = True
        try:
            with self.hold_sync():
                self.options = options
                self.value = value
        finally:
            self._holding = False
        if self.value != old:
            self._picked(self.value)


def output_dir(create=True):
    """The folder the apps write their files to (exports, saved strokes).

    ``$FLUIDNB_OUTPUT_DIR`` if set, else ``fluidnb-output/`` in the working directory
    (a notebook's own folder), which the repository's ``.gitignore`` ignores: a
    class leaves no file among the notebooks.
    """
    path = Path(os.environ.get("FLUIDNB_OUTPUT_DIR") or OUTPUT_DIR)
    if create:
        path.mkdir(parents=True, exist_ok=True)
    return path


def shown_path(path):
    """``path`` as a person finds it: relative to the working directory when inside it."""
    path = Path(path)
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def jpeg(picture, quality=95):
    """An RGB float picture in [0, 1] as JPEG bytes, for a player's ``W.Image(format="jpeg")``.

    What the apps show while they play or preview: about 1.3 ms and 125 KB for a 480 x 376
    frame, where a PNG takes 15 ms and 370 KB (at 24 frames a second, a third of a core
    and 9 MB/s through the notebook's socket). Quality 95 without colour subsampling:
    no visible loss on the apps' pictures (the exports are made from the frames, not
    from these). Live previews use a lower ``quality`` (the player's).
    """
    buf = io.BytesIO()
    Image.fromarray(to_uint8(picture)).save(buf, format="jpeg", quality=quality, subsampling=0)
    return buf.getvalue()


def plural(n, noun, nouns=None):
    """``"1 stroke"``, ``"3 strokes"``: a count with its noun.

    >>> plural(1, "stroke"), plural(0, "stroke"), plural(2, "fragment"), plural(5, "is", "are")
    ('1 stroke', '0 strokes', '2 fragments', '5 are')
    """
    return f"{n} {noun if n == 1 else (nouns or noun + 's')}"


def math_html(tex):
    r"""A short LaTeX formula as plain HTML: Greek letters in Unicode, scripts as spans.

    For labels and widget text, which must read right without MathJax (Voila on a
    laptop with no network shows ``$\sigma$`` raw); Markdown cells keep their LaTeX.

    >>> math_html(r"\sigma"), math_html(r"\mathrm{d}t")
    ('σ', 'dt')
    >>> math_html("r_{th}")
    "r<span style='vertical-align:sub;font-size:75%'>th</span>"
    >>> math_html("D_i = F_i - A").count("vertical-align:sub"), math_html("f^{-2}")[-10:]
    (2, '>-2</span>')
    """
    text = re.sub(r"\\(?:mathrm|text|mathit|operatorname)\{([^{}]*)\}", r"\1", tex)
    text = html.escape(text, quote=False)

    def script(match):
        where = "sub" if match.group(1) == "_" else "super"
        body = match.group(3) if match.group(3) is not None else match.group(2)
        return f"<span style='{_SCRIPT_STYLE[where]}'>{body}</span>"

    text = _SCRIPT.sub(script, text)
    return re.sub(r"\\([A-Za-z]+)", lambda m: _GREEK.get(m.group(1), m.group(1)), text)


def math_text(tex):
    r"""A short LaTeX formula as plain text (tooltips): ``\kappa_b`` -> ``κ_b``.

    >>> math_text(r"\kappa_b"), math_text("r_{th}"), math_text(r"f^{-2}")
    ('κ_b', 'r_th', 'f^-2')
    """
    text = re.sub(r"<span style='vertical-align:sub[^']*'>(.*?)</span>", r"_\1", math_html(tex))
    text = re.sub(r"<span style='vertical-align:super[^']*'>(.*?)</span>", r"^\1", text)
    return html.unescape(text)


def row(*widgets):
    """Widgets side by side, wrapping onto a new line where the column is narrow."""
    return W.HBox(list(widgets), layout=W.Layout(flex_flow="row wrap", align_items="center"))


def hint(text, max_width="440px"):
    """A muted line of help under an app's controls (``text`` is HTML)."""
    return W.HTML(
        f"<div style='opacity:0.75;font-size:12px;line-height:1.4;max-width:{max_width}'>"
        f"{text}</div>"
    )
