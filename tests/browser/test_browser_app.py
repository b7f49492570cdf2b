"""App in JupyterLab: a parameter slider drives the live preview; the dark theme."""

import pytest

from tests.browser.helpers import (
    assert_visible,
    contrast,
    drag_slider,
    img_rgba,
    poll,
    shown_frame,
)

pytestmark = pytest.mark.browser

# The preview is a flat grey clip of the parameter's level: what the player shows
# tells which parameter value the kernel used.
APP = """\
from dataclasses import dataclass

import fluidnb.data
from fluidnb import Clip, Params, param
from fluidnb.widgets import App, DrawingCanvas, ParamPanel

@dataclass(frozen=True)
class Probe(Params):
    level: float = param(0.2, lo=0.0, hi=1.0, symbol="L", doc="grey level of the preview")

def preview(p):
    return Clip(np.full((3, 24, 64), p.level, np.float32), fps=8, metadata={"method": "probe"})

def run(p, progress):
    return preview(p)

canvas = DrawingCanvas(
    fluidnb.data.sample("checker", size=128), strokes=["flow"], display_size=320
)
canvas.draw_stroke([[20, 20], [60, 90]])
panel = ParamPanel(Probe)
app = App(panel=panel, run=run, preview=preview, canvas=canvas, title="Probe app",
          run_on_rest=False)  # the preview alone here (the runs at rest: test_browser_live)
panel.observe(lambda ch: dump("params.json", {"level": ch["new"].level}), "params")
app.player.observe(
    lambda ch: dump("player.json", {"level": float(ch["new"].frames[0, 0, 0])}), "clip"
)
app
"""


def shown_level(page):
    rgba = img_rgba(page.locator(".fluidnb-app .fluidnb-frame"))
    return None if rgba is None else rgba[0] / 255


def wait_level(page, level, what):
    poll(
        what,
        lambda: (lambda lv: lv is not None and abs(lv - level) <= 2 / 255)(shown_level(page)),
        timeout=15,
    )


def test_slider_changes_the_previewed_frame(notebook, page, shot):
    nb = notebook([APP])
    app = page.locator(".fluidnb-app")
    app.wait_for()
    wait_level(page, 0.2, "the preview at the default level 0.2")
    src0 = shown_frame(page.locator(".fluidnb-app .fluidnb-frame"))

    slider = page.locator(".fluidnb-param-level")
    shown = drag_slider(page, slider, 0.8, steps=10)
    # continuous_update sends intermediate values: wait for the slider's final one.
    # (The readout shows 3 significant digits; the handle's aria-valuenow only 1 decimal.)
    assert 0.7 < shown < 0.9, shown
    final = nb.state("params.json", lambda s: abs(s["level"] - shown) < 5e-4)["level"]
    nb.state("player.json", lambda s: abs(s["level"] - final) < 1e-6)
    wait_level(page, final, f"the preview at the slider's level {final}")
    assert shown_frame(page.locator(".fluidnb-app .fluidnb-frame")) != src0
    assert page.locator(".fluidnb-status").inner_text().startswith("preview (")
    shot(app)


def test_dark_theme_app_is_readable(notebook, page, shot):
    notebook([APP])
    app = page.locator(".fluidnb-app")
    app.wait_for()
    wait_level(page, 0.2, "the first preview")
    set_theme = "t => window.jupyterapp.commands.execute('apputils:change-theme', {theme: t})"
    page.evaluate(set_theme, "JupyterLab Dark")
    try:
        page.wait_for_function(
            "() => document.body.dataset.jpThemeName === 'JupyterLab Dark'"
            " && document.body.dataset.jpThemeLight === 'false'"
        )
        # Wait until the dark theme's CSS really applies to the notebook.
        page.wait_for_function(
            """() => {
              const c = getComputedStyle(document.querySelector('.jp-Notebook')).backgroundColor;
              const v = (c.match(/[0-9.]+/g) || []).map(Number);
              return v.length >= 3 && v[0] + v[1] + v[2] < 3 * 80;
            }"""
        )
        app.scroll_into_view_if_needed()
        assert_visible(page.locator(".fluidnb-app .fluidnb-canvas").bounding_box())
        assert_visible(page.locator(".fluidnb-app .fluidnb-frame").bounding_box(), 100, 50)
        texts = {
            "status": page.locator(".fluidnb-app .fluidnb-status span").first,
            "slider label": page.locator(".fluidnb-param-level .widget-label"),
            "slider readout": page.locator(".fluidnb-param-level .widget-readout"),
            "tool button": page.locator(".fluidnb-tools button").first,
            "canvas status": page.locator(".fluidnb-drawing > .widget-html span").first,
            "player info": page.locator(".fluidnb-player .widget-html-content span").first,
            "title": page.locator(".fluidnb-app h3"),
        }
        poll("the status text", lambda: texts["status"].inner_text().startswith("preview ("))
        low = {}
        for name, loc in texts.items():
            c = contrast(loc)
            if c["ratio"] < 3:
                low[name] = c
        shot(app)
        assert not low, f"text hard to read in the dark theme: {low}"
    finally:
        page.evaluate(set_theme, "JupyterLab Light")
        page.wait_for_function("() => document.body.dataset.jpThemeLight === 'true'")
