"""The video-database app in a real browser: JupyterLab end to end, and Voila.

JupyterLab at 1400 x 900, as a lecturer sees it: paint a matte, draw a stroke (its
arrow while dragging, then the quiver), paint speed, Run on the quick water starter
database (the progress bar with Cancel while it runs), and find the canvas, the
clip, the assignment map and the sigma slider on screen together; drag sigma and see
the map change and a preview frame while it moves, then the clip rendered when it
rests, without a new retrieval; save the strokes and export a GIF into the output
folder; reload the page and find the app as it was; the dark theme. The lesson 07a's
own cells: its databases show progress bars (no stderr box) and its app has the same
layout. An upload after another photo shows the upload. Voila: the app renders (its
canvases drawn for the new page) and a stroke drawn with the mouse reaches the kernel.
"""

import io
import json
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.browser import test_browser_voila as voila_tests
from tests.browser.helpers import (
    assert_visible,
    at,
    canvas_rgba,
    contrast,
    drag,
    drag_slider,
    img_rgba,
    inside,
    notebook_view,
    open_app,
    poll,
    read_json,
    to_image,
)

pytestmark = pytest.mark.browser

voila = voila_tests.voila  # the Voila server fixture, shared

ROOT = Path(__file__).resolve().parents[2]
VIEWPORT = {"width": 1400, "height": 900}
SHAPE = (150, 192)  # the stream photo at 192 pixels

APP = """\
os.environ["FLUIDNB_QUICK"] = "1"  # the quick starter database (built once, cached)
from fluidnb.widgets import VideoDBApp

app = VideoDBApp("stream", size=192, db="water", display_size=480)
app.panel.set("candidates", 30)

def report(_=None):
    s = app.state()
    s["previews"] = app.previews
    clip = app.result
    if clip is not None:
        frames = clip.frames
        inside = app.matte() > 0
        change = np.abs(np.diff(frames, axis=0)).max(axis=-1)
        s["inside_change"] = float(change[:, inside].mean())
        s["outside_change"] = float(change[:, ~inside].max())
        s["outside_is_photo"] = bool(np.array_equal(
            frames[:, ~inside], np.broadcast_to(app.photo[~inside], frames[:, ~inside].shape)
        ))
        s["clip_params"] = clip.metadata["params"]
    dump("state.json", s)

app.canvas.observe(report, "version")
app.observe(report, ["retrievals", "resolves", "renders", "status"])
report()
app
"""

_SIGNATURE = """el => {
  const d = el.getContext('2d').getImageData(0, 0, el.width, el.height).data;
  let h = 0;
  for (let i = 0; i < d.length; i += 1) h = (h * 31 + d[i]) % 1000000007;
  return h;
}"""

# What the player shows, as it happens: its caption (a preview's says so) and picture.
_WATCH_PLAYER = """() => {
  const log = window.__player = [];
  const player = document.querySelector('.fluidnb-app .fluidnb-player');
  new MutationObserver(() => log.push(player.textContent)).observe(
    player, {subtree: true, childList: true, characterData: true, attributes: true});
}"""

STDERR = '.jp-RenderedText[data-mime-type="application/vnd.jupyter.stderr"]'


def is_quiver(p):
    """The direction field's yellow."""
    return p[0] > 200 and p[1] > 160 and p[2] < 90


def is_stroke(p):
    """The flow strokes' cyan."""
    return p[2] - p[0] > 60 and p[1] > 120


def quiver_pixels(canvas, box):
    """How many quiver-yellow pixels lie in a grid of small windows over the matte band."""
    points = [at(box, fx, fy) for fx in np.linspace(0.1, 0.9, 9) for fy in (0.5, 0.57, 0.7)]
    return sum(is_quiver(p) for win in canvas_rgba(canvas, points, radius=6) for p in win)


class Region:
    """A part of the page to screenshot without scrolling (an element shot scrolls)."""

    def __init__(self, page, box):
        self.page, self.box = page, box

    def screenshot(self, path):
        self.page.screenshot(path=path, clip=self.box)


def check_layout(page, shot, suffix):
    """At 1400 x 900 with the app's top at the notebook's top, and no scrolling after:
    the canvas and the clip's picture in view, and the sigma slider with the map."""
    page.locator(".fluidnb-app").evaluate("el => el.scrollIntoView({block: 'start'})")
    page.wait_for_timeout(300)
    view = notebook_view(page)
    assert view["width"] > 1200, view  # the page really is 1400 wide
    shot(page, suffix)
    app = ".fluidnb-app "
    inside(page.locator(app + ".fluidnb-canvas").bounding_box(), view, "the canvas")
    inside(page.locator(app + ".fluidnb-frame").bounding_box(), view, "the clip's picture")
    inside(page.locator(app + ".fluidnb-param-sigma").bounding_box(), view, "the sigma slider")
    inside(page.locator(".fluidnb-vdb-map").bounding_box(), view, "the assignment map")
    inside(page.locator(app + ".fluidnb-run").bounding_box(), view, "Run")
    inside(page.locator(app + ".fluidnb-status").bounding_box(), view, "the status line")
    # Side by side: canvas | clip and map | panel (nothing wrapped under the canvas).
    canvas = page.locator(app + ".fluidnb-canvas").bounding_box()
    amap = page.locator(".fluidnb-vdb-map").bounding_box()
    sigma = page.locator(app + ".fluidnb-param-sigma").bounding_box()
    assert canvas["x"] + canvas["width"] <= amap["x"] < sigma["x"], (canvas, amap, sigma)


def whole_app(page, shot, suffix=""):
    """Screenshot the whole app: a page tall enough for it, scrolled to its title."""
    page.set_viewport_size({"width": 1400, "height": 2100})
    page.locator(".fluidnb-app h3").evaluate("el => el.scrollIntoView()")
    shot(page, suffix)
    page.set_viewport_size(VIEWPORT)


def reload_page(page, lab_server):
    """Save the notebook and reload the page, which joins the notebook's kernel again.

    The ``notebook`` fixture starts a session of its own before the page opens its
    one; a reload would attach to neither but a new kernel, so that spare session goes
    first (a lecturer's JupyterLab has just the page's).
    """
    kernel = "() => window.jupyterapp?.shell.currentWidget?.sessionContext?.session?.kernel?.id"
    mine = page.evaluate(kernel)
    path = page.evaluate("() => window.jupyterapp.shell.currentWidget.context.path")
    page.evaluate("() => window.jupyterapp.commands.execute('docmanager:save')")
    page.wait_for_function(
        "() => !window.jupyterapp.shell.currentWidget.context.model.dirty", timeout=30_000
    )
    for session in lab_server.api("GET", "sessions"):
        if session["path"] == path and session["kernel"]["id"] != mine:
            lab_server.api("DELETE", f"sessions/{session['id']}")
    page.goto(page.url.replace("?reset&", "?").replace("&reset", ""))
    page.wait_for_function(f"() => ({kernel})() === {mine!r}", timeout=60_000)


def test_draw_run_drag_sigma_and_export_in_jupyterlab(notebook, page, shot, lab_server):
    started = time.monotonic()
    page.set_viewport_size(VIEWPORT)
    nb, _app, canvas, box = open_app(notebook, page, [APP])
    state = nb.state("state.json")
    assert state["matte_pixels"] == 0

    # The matte: three brush passes across the stream (the default tool and layer).
    for fy in (0.52, 0.62, 0.72):
        drag(page, at(box, 0.05, fy), at(box, 0.95, fy), steps=12)
    state = nb.state("state.json", lambda s: s["matte_pixels"] > 5000)
    assert not quiver_pixels(canvas, box), "a quiver before any stroke"

    # A stroke, left to right: while the button is still down, its arrow head shows.
    page.locator(".fluidnb-tools button", has_text="stroke").click()
    start, end = at(box, 0.1, 0.62), at(box, 0.85, 0.62)
    page.mouse.move(*start)
    page.mouse.down()
    page.mouse.move(*end, steps=20)
    k = box["width"] / 480  # screen pixels per canvas pixel
    barbs = [(end[0] - 6.3 * k, end[1] + s * 3.0 * k) for s in (-1, 1)]

    def arrow_drawn():
        wins = canvas_rgba(canvas, barbs, radius=1)
        return all(any(is_stroke(p) for p in win) for win in wins) or None

    poll("the arrow head on the stroke being dragged", arrow_drawn, timeout=15)
    shot(Region(page, page.locator(".fluidnb-drawing").bounding_box()), "dragging")
    page.mouse.up()
    state = nb.state("state.json", lambda s: len(s["strokes"]) == 1)
    stroke = np.array(state["strokes"][0])
    np.testing.assert_allclose(stroke[0], to_image(box, start, SHAPE), atol=1.5)
    np.testing.assert_allclose(stroke[-1], to_image(box, end, SHAPE), atol=1.5)
    assert state["quiver_segments"] > 10
    # The interpolated direction field appears as a yellow quiver over the matte.
    poll("the quiver overlay", lambda: quiver_pixels(canvas, box) > 20, timeout=15)

    # Speed: the brush on the speed layer paints 2 px/frame, shown as a light veil.
    page.locator(".fluidnb-tools button", has_text="brush").click()
    page.locator(".fluidnb-app .fluidnb-layer select").select_option("speed")
    speed = page.locator(".fluidnb-vdb-speed")
    speed.wait_for()
    assert float(speed.locator(".widget-readout").inner_text()) == 2.0
    probe = at(box, 0.45, 0.72)
    before = np.mean([p[:3] for p in canvas_rgba(canvas, [probe], radius=3)[0]])
    drag(page, at(box, 0.3, 0.72), at(box, 0.6, 0.72), steps=10)
    state = nb.state("state.json", lambda s: s["speed_pixels"] > 100)
    assert state["speed_max"] == 2.0
    poll(
        "the speed overlay",
        lambda: np.mean([p[:3] for p in canvas_rgba(canvas, [probe], radius=3)[0]]) > before + 15,
        timeout=15,
    )

    # The strokes, saved: into the output folder, and the status line says so.
    page.locator(".fluidnb-vdb-save-strokes").click()
    status = page.locator(".fluidnb-app .fluidnb-status")
    status.locator("text=saved 1 stroke to fluidnb-output/strokes.json").wait_for()
    assert (nb.folder / "fluidnb-output" / "strokes.json").exists()
    assert not (nb.folder / "strokes.json").exists()
    drawn = time.monotonic()

    # Run: the progress bar moves with Cancel offered, then the frames move inside the
    # matte and are the photo outside.
    page.locator(".fluidnb-app .fluidnb-run").click()
    page.locator(".fluidnb-app .fluidnb-cancel:not([disabled])").wait_for(timeout=10_000)
    state = nb.state("state.json", lambda s: s["frames"] and s["retrievals"] == 1, timeout=240)
    ran = time.monotonic()
    # The flow rendering (default since issue 24): whole repeats of the N - loop = 24.
    assert state["frames"] % 24 == 0
    assert state["inside_change"] > 2e-3, state["inside_change"]
    assert state["outside_change"] == 0.0
    assert state["outside_is_photo"]
    status.locator("text=done in").wait_for(timeout=30_000)
    assert page.locator(".fluidnb-app .fluidnb-progress .progress-bar-success").count() == 1
    frame = page.locator(".fluidnb-app .fluidnb-player .fluidnb-frame")
    poll("the first frame to show", lambda: img_rgba(frame) is not None)
    # The assignment map is drawn in the clips' colours, with a legend naming them.
    amap = page.locator(".fluidnb-vdb-map")
    page.locator(".fluidnb-vdb-legend .fluidnb-vdb-clip").first.wait_for()
    assert "water-" in page.locator(".fluidnb-vdb-legend").inner_text()
    energy = page.locator(".fluidnb-vdb-energy-plot")
    energy.wait_for()
    assert page.locator(STDERR).count() == 0, page.locator(STDERR).all_inner_texts()
    # Issue 22, point 3: canvas, clip, map and sigma all in view at 1400 x 900.
    check_layout(page, shot, "after-run")

    # sigma, dragged: re-solved from the kept tables while it moves (the map changes, a
    # preview frame shows in the player), then the clip of the last value is rendered
    # once it rests -- no Render press, no new retrieval.
    tables, labels, renders = state["tables"], state["labels"], state["renders"]
    map_before = amap.evaluate(_SIGNATURE)
    energies_before = energy.get_attribute("data-energies")
    page.evaluate(_WATCH_PLAYER)
    sigma = drag_slider(page, page.locator(".fluidnb-param-sigma"), 0.9, steps=16)
    assert sigma > 1e4
    state = nb.state(
        "state.json",
        lambda s: (
            s["renders"] > renders
            and abs(s["clip_params"]["sigma"] - sigma) < 0.01 * sigma
            and s["status"].startswith("rendered in")
        ),
        timeout=60,
    )
    assert state["retrievals"] == 1, "moving sigma made a new retrieval"
    assert state["resolves"] >= 1
    assert state["previews"] >= 1
    assert state["tables"] == tables
    assert state["labels"] != labels
    poll("the map to change", lambda: amap.evaluate(_SIGNATURE) != map_before, timeout=15)
    poll(
        "the energy plot to change",
        lambda: energy.get_attribute("data-energies") != energies_before,
        timeout=15,
    )
    shown = page.evaluate("() => window.__player")
    assert any("preview: σ" in text for text in shown), shown[-3:]
    info = page.locator(".fluidnb-app .fluidnb-app-player .fluidnb-player-info")
    poll("the clip in the player", lambda: " frames, " in info.inner_text())
    assert page.locator(".fluidnb-vdb-retrievals").inner_text() == "1"
    resolved = time.monotonic()

    # Render still renders on demand; export the clip as a GIF into the output folder.
    page.locator(".fluidnb-vdb-render").click()
    nb.state("state.json", lambda s: s["renders"] > state["renders"], timeout=60)
    page.locator(".fluidnb-app .fluidnb-export-gif").click()
    link = page.locator(".fluidnb-app .fluidnb-export-link a")
    link.wait_for(timeout=60_000)
    name = link.inner_text()
    assert name.startswith("fluidnb-output/")
    assert name.endswith(".gif")
    status.locator(f"text=saved {name}").wait_for()
    path = nb.folder / name
    poll("the GIF file", lambda: path.exists() and path.stat().st_size > 0)
    with Image.open(path) as gif:
        assert gif.size == (SHAPE[1], SHAPE[0])
        assert gif.n_frames % 24 == 0  # whole repeats of N - loop (the flow rendering)
    exported = time.monotonic()

    # A click on the map shows the database fragment that animates that place.
    amap.scroll_into_view_if_needed()
    page.mouse.click(*at(amap.bounding_box(), 0.5, 0.62))
    page.locator(".fluidnb-vdb-fragment", has_text="water-").wait_for()
    strip = page.locator(".fluidnb-vdb-fragment-frames")
    poll("the fragment's mean image and frames", lambda: img_rgba(strip) is not None)
    assert_visible(strip.bounding_box(), min_width=250, min_height=50)
    whole_app(page, shot)

    # The dark theme: the app's own texts stay readable.
    set_theme = "t => window.jupyterapp.commands.execute('apputils:change-theme', {theme: t})"
    page.evaluate(set_theme, "JupyterLab Dark")
    try:
        page.wait_for_function(
            """() => {
              const c = getComputedStyle(document.querySelector('.jp-Notebook')).backgroundColor;
              const v = (c.match(/[0-9.]+/g) || []).map(Number);
              return v.length >= 3 && v[0] + v[1] + v[2] < 3 * 80;
            }"""
        )
        texts = {
            "N": page.locator(".fluidnb-vdb-N span").first,
            "status": page.locator(".fluidnb-app .fluidnb-status span").first,
            "energy": page.locator(".fluidnb-vdb-energy div").first,
            "energy plot": page.locator(".fluidnb-vdb-energy-plot"),
            "counters": page.locator(".fluidnb-vdb-stats div").first,
            "legend": page.locator(".fluidnb-vdb-legend .fluidnb-vdb-clip").first,
            "fragment": page.locator(".fluidnb-vdb-fragment div").first,
        }
        low = {name: c for name, loc in texts.items() if (c := contrast(loc))["ratio"] < 3}
        whole_app(page, shot, "dark")
        assert not low, f"text hard to read in the dark theme: {low}"
    finally:
        page.evaluate(set_theme, "JupyterLab Light")
        page.wait_for_function("() => document.body.dataset.jpThemeLight === 'true'")

    # A page reload (after a save, as JupyterLab's autosave does): the kernel keeps the
    # app, the page draws it again -- the photo on the canvas, the map in its colours,
    # the clip's picture, the counters.
    reload_page(page, lab_server)
    canvas = page.locator(".fluidnb-app .fluidnb-canvas")
    canvas.wait_for(timeout=60_000)
    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()

    def photo_shown():
        top = canvas_rgba(canvas, [at(box, 0.5, 0.1)])[0]
        return top[3] == 255 and sum(top[:3]) > 30

    poll("the photo on the canvas after a reload", photo_shown, timeout=30)
    amap = page.locator(".fluidnb-vdb-map")
    poll(
        "the map's picture after a reload",
        lambda: canvas_rgba(amap, [at(amap.bounding_box(), 0.5, 0.62)])[0][3] == 255,
        timeout=30,
    )
    poll("the clip's picture after a reload", lambda: img_rgba(frame) is not None, timeout=30)
    assert page.locator(".fluidnb-vdb-retrievals").inner_text() == "1"
    shot(page, "reloaded")
    print(
        f"\ntimings (no asserts; under load): open+draw {drawn - started:.1f} s, run "
        f"{ran - drawn:.1f} s, drag + re-solves + render {resolved - ran:.1f} s, render + "
        f"export {exported - resolved:.1f} s, map click + dark theme + reload "
        f"{time.monotonic() - exported:.1f} s"
    )


def lesson_cells(name, needles):
    """Code cells of a lesson, each the first holding one of ``needles``.

    The test runs the lesson's own code; found by what the cells hold, not by
    position, so questions added between them do not shift it.
    """
    cells = json.loads((ROOT / "notebooks" / name).read_text())["cells"]
    code = ["".join(c["source"]) for c in cells if c["cell_type"] == "code"]
    return [next(src for src in code if needle in src) for needle in needles]


def test_the_lessons_databases_show_bars_and_its_app_the_one_layout(notebook, page, shot):
    # Issue 22, point 4: progress in a notebook is a widget bar, never text (a pink
    # stderr box, or a text bar); point 3: the lesson's own app at 1400 x 900.
    page.set_viewport_size(VIEWPORT)
    # The first cell builds the water database, the smoke one where it is first needed.
    cells = lesson_cells(
        "07a_videodb_database.ipynb",
        ["progress_bar(", 'smoke = starter_database("smoke"', "VideoDBApp("],
    )
    assert "progress_bar(" in cells[0]
    assert 'starter_database("smoke"' in cells[1]
    assert "VideoDBApp(" in cells[2]
    cells[1] = cells[1].split("\n")[0]  # the database, not its figure
    notebook(['import os\nos.environ["FLUIDNB_QUICK"] = "1"\n', *cells])
    bars = page.locator(".fluidnb-progressbar")
    poll("the databases' bars", lambda: bars.count() == 2, timeout=30)
    for i, kind in enumerate(("water", "smoke")):
        assert f"{kind} database" in bars.nth(i).inner_text()
        bars.nth(i).locator(".fluidnb-progress-text", has_text="done in").wait_for()
    assert page.locator(STDERR).count() == 0, page.locator(STDERR).all_inner_texts()
    # No text bar either ("[####....]  50% ..."), on stdout or stderr.
    texts = page.locator(".jp-OutputArea-output pre").all_inner_texts()
    assert not any("[#" in t or "%" in t for t in texts), texts
    shot(bars.first, "bars")
    page.locator(".fluidnb-app .fluidnb-run").click()
    status = page.locator(".fluidnb-app .fluidnb-status")
    status.locator("text=done in").wait_for(timeout=240_000)
    frame = page.locator(".fluidnb-app .fluidnb-player .fluidnb-frame")
    poll("the clip's first frame", lambda: img_rgba(frame) is not None)
    check_layout(page, shot, "lesson-07a")
    # At 1280 px too the three columns stay side by side (the canvas narrows).
    page.set_viewport_size({"width": 1280, "height": 900})
    page.wait_for_timeout(500)
    app = ".fluidnb-app "
    canvas = page.locator(app + ".fluidnb-canvas").bounding_box()
    amap = page.locator(".fluidnb-vdb-map").bounding_box()
    sigma = page.locator(app + ".fluidnb-param-sigma").bounding_box()
    assert canvas["x"] + canvas["width"] <= amap["x"] < sigma["x"], (canvas, amap, sigma)
    assert sigma["y"] < canvas["y"] + canvas["height"], "the panel wrapped under the canvas"
    assert canvas["width"] >= 360
    shot(page, "lesson-07a-1280")


PHOTOS = """\
os.environ["FLUIDNB_QUICK"] = "1"
from fluidnb.widgets import VideoDBApp

app = VideoDBApp("stream", size=160)

def report(_=None):
    dump("photo.json", {"name": app.photo_name, "shape": list(app.photo.shape),
                        "menu": app._photo_pick.value, "db": app._db_pick.value,
                        "status": app.status})

app.observe(report, "status")
report()
app
"""


def png(rgb):
    image = np.zeros((96, 128, 3), np.uint8)
    image[...] = rgb
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="png")
    return buf.getvalue()


def test_an_upload_after_the_clouds_shows_the_upload(notebook, page, shot):
    # Issue 22, point 1: after picking the clouds, an upload brought the stream back
    # (and the water database) while the status line said the upload was loaded.
    page.set_viewport_size(VIEWPORT)
    nb = notebook([PHOTOS])
    menu = page.locator(".fluidnb-app .fluidnb-photo select")
    menu.select_option("clouds")
    state = nb.state("photo.json", lambda s: s["name"] == "clouds")
    assert state["db"] == "smoke"
    with page.expect_file_chooser() as chooser:
        page.locator(".fluidnb-app .fluidnb-upload").click()
    chooser.value.set_files(
        files=[{"name": "green.png", "mimeType": "image/png", "buffer": png((30, 210, 40))}]
    )
    state = nb.state("photo.json", lambda s: s["name"] != "clouds", timeout=30)
    assert state["name"] == "upload", state
    assert state["shape"] == [96, 128, 3]
    assert state["menu"] == "upload"
    assert state["db"] == "smoke", "the upload switched the database"
    assert "your upload" in state["status"]
    poll("the menu to read upload", lambda: menu.input_value() == "upload")
    canvas = page.locator(".fluidnb-app .fluidnb-canvas")
    canvas.scroll_into_view_if_needed()

    def shows_green():
        box = canvas.bounding_box()
        points = [at(box, fx, fy) for fx in (0.1, 0.5, 0.9) for fy in (0.1, 0.5, 0.9)]
        return all(g > 150 and r < 90 and b < 90 for r, g, b, _ in canvas_rgba(canvas, points))

    poll("the uploaded green photo on the canvas", shows_green)
    amap = page.locator(".fluidnb-vdb-map")
    poll(
        "the map over the upload",
        lambda: (lambda p: p[1] > p[0] and p[1] > p[2])(
            canvas_rgba(amap, [at(amap.bounding_box(), 0.5, 0.5)])[0]
        ),
    )
    shot(page, "upload")
    # And the clouds are one pick away again.
    menu.select_option("clouds")
    nb.state("photo.json", lambda s: s["name"] == "clouds")


VOILA = """\
import json, os
os.environ["FLUIDNB_QUICK"] = "1"
import numpy as np
from fluidnb.widgets import VideoDBApp

app = VideoDBApp("stream", size=192, db="water", display_size=480)
matte = np.zeros((150, 192), bool)
matte[60:120, :] = True
app.set_matte(matte)

def report(_=None):
    with open({state!r} + ".tmp", "w") as f:
        json.dump({{"strokes": [s.tolist() for s in app.strokes()],
                   "quiver": app.quiver_segments}}, f)
    os.replace({state!r} + ".tmp", {state!r})

app.canvas.observe(report, "version")
report()
app
"""


def test_voila_renders_the_app_and_a_stroke_reaches_the_kernel(voila, page, shot, tmp_path):
    state_file = tmp_path / "state.json"
    url = voila(VOILA.format(state=str(state_file)))
    page.set_default_timeout(60_000)
    page.goto(url)
    canvas = page.locator(".fluidnb-canvas")
    canvas.wait_for()
    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()
    assert_visible(box)

    # Drawn for this page (ipycanvas drawing sent during execution is lost in Voila):
    # the photo with the preloaded matte's orange over its lower band.
    def photo_and_matte():
        top, band = canvas_rgba(canvas, [at(box, 0.5, 0.2), at(box, 0.5, 0.6)])
        return (top[3] == 255 and sum(top[:3]) > 30 and band[0] - band[2] > 40) or None

    poll("the photo and matte on the Voila canvas", photo_and_matte, timeout=30)
    amap = page.locator(".fluidnb-vdb-map")
    amap.scroll_into_view_if_needed()
    poll(
        "the assignment map's picture",
        lambda: canvas_rgba(amap, [at(amap.bounding_box(), 0.5, 0.5)])[0][3] == 255 or None,
    )

    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()
    page.locator(".fluidnb-tools button", has_text="stroke").click()
    start, end = at(box, 0.15, 0.6), at(box, 0.8, 0.6)
    drag(page, start, end, steps=15)

    def received():
        data = read_json(state_file)
        return data if data and len(data["strokes"]) == 1 else None

    data = poll("the stroke in the kernel", received, timeout=30)
    stroke = np.array(data["strokes"][0])
    np.testing.assert_allclose(stroke[0], to_image(box, start, SHAPE), atol=1.5)
    np.testing.assert_allclose(stroke[-1], to_image(box, end, SHAPE), atol=1.5)
    assert data["quiver"] > 10
    poll("the quiver in Voila", lambda: quiver_pixels(canvas, box) > 20, timeout=15)
    shot(page)
