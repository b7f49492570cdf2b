"""Voila smoke test: a canvas's drawing set before display shows up in the page.

In Voila, ipycanvas drawing commands sent while the notebook executes on the server
are lost; DrawingCanvas redraws in ``on_client_ready``. This checks that the
preloaded mask and stroke are really painted on the canvas the user sees.
"""

import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from tests.browser.helpers import (
    assert_visible,
    canvas_rgba,
    free_port,
    isolated_env,
    node_slug,
    poll,
    stop,
    wait_http,
)

pytestmark = pytest.mark.browser

NOTEBOOK = """\
import numpy as np
from fluidnb.widgets import DrawingCanvas

c = DrawingCanvas(np.full((96, 128), 0.5), strokes=["flow"], masks=["region"])
mask = np.zeros((96, 128), bool)
mask[20:50, 70:110] = True
c.set_mask(mask)
c.set_strokes([[[70, 10], [70, 60]]])
c
"""


@pytest.fixture
def voila(tmp_path, request):
    """Serve notebooks with Voila: ``serve(source, markdown=None) -> url`` for a notebook
    of one code cell (and a Markdown cell), ``serve.file(path) -> url`` for a copy of a
    notebook file."""
    procs = []

    def start(path):
        port = free_port()
        log = tmp_path / "voila.log"
        cmd = [
            sys.executable, "-m", "voila", str(path),
            "--no-browser", f"--port={port}", "--Voila.ip=127.0.0.1", "--Voila.port_retries=0",
        ]  # fmt: skip
        with log.open("w") as out:
            proc = subprocess.Popen(
                cmd,
                env=isolated_env(tmp_path / "jupyter"),
                cwd=tmp_path,
                stdout=out,
                stderr=subprocess.STDOUT,
            )
        procs.append(proc)
        url = f"http://127.0.0.1:{port}/"
        # Any answer means the server is up (the page itself starts a kernel).
        wait_http(url + "favicon.ico", proc, log, any_status=True)
        return url

    def serve(source, markdown=None):
        nb = nbformat.v4.new_notebook()
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3"}
        nb.cells = [nbformat.v4.new_code_cell(source)]
        if markdown is not None:
            nb.cells.insert(0, nbformat.v4.new_markdown_cell(markdown))
        path = tmp_path / f"{node_slug(request)}.ipynb"
        nbformat.write(nb, path)
        return start(path)

    def serve_file(source):
        path = tmp_path / Path(source).name
        shutil.copy(source, path)
        return start(path)

    serve.file = serve_file
    yield serve
    for proc in procs:
        stop(proc)


def test_voila_shows_the_preloaded_drawing(voila, page, shot):
    url = voila(NOTEBOOK)
    page.set_default_timeout(60_000)
    page.goto(url)
    canvas = page.locator(".fluidnb-canvas")
    canvas.wait_for()
    canvas.scroll_into_view_if_needed()
    box = canvas.bounding_box()
    assert_visible(box)

    def point(row, col):  # image (row, col) -> viewport (x, y)
        return (
            box["x"] + (col + 0.5) / 128 * box["width"],
            box["y"] + (row + 0.5) / 96 * box["height"],
        )

    probes = {"mask": point(35, 90), "stroke": point(70, 35), "image": point(10, 10)}

    def drawn():
        (mr, _, mb, ma), (sr, _, sb, sa), (ir, ig, ib, ia) = canvas_rgba(
            canvas, list(probes.values())
        )
        ok = (
            ma == 255 and mr - mb > 60  # orange paint over grey
            and sa == 255 and sb - sr > 60  # cyan stroke
            and ia == 255 and abs(ir - 128) < 8 and ir == ig == ib  # plain grey image
        )  # fmt: skip
        return ok or None

    try:
        poll("the preloaded drawing on the Voila canvas", drawn, timeout=30)
    finally:
        shot(page)


APP = """\
from fluidnb.widgets import FrostApp
app = FrostApp(quick=True)
app
"""
LESSON_TEXT = r"""
## The parameters

$\beta$ is the initial vapour, $\gamma$ the vapour added each step, and
$$f(\beta) = \big(T - T_{sim}(\beta)\big)^2$$
"""


def _offline(page):
    """Abort every request that leaves this machine; returns the list of those blocked."""
    blocked = []

    def route(r):
        host = r.request.url.split("/")[2].split(":")[0]
        if host in ("127.0.0.1", "localhost"):
            return r.continue_()
        blocked.append(r.request.url)
        return r.abort()

    page.route("**/*", route)
    return blocked


def test_voila_offline_shows_no_raw_latex(voila, page, shot):
    # Issue 22, point 9: a lecture hall's laptop often has no network; Voila showed
    # "sigma $\sigma$" on the sliders. Block every request that leaves this machine.
    url = voila(APP, markdown=LESSON_TEXT)
    _offline(page)
    page.set_default_timeout(120_000)
    page.goto(url)
    page.locator(".fluidnb-param-beta").wait_for()
    page.locator(".fluidnb-param-gamma .widget-label").wait_for()
    # MathJax (bundled with Voila, like JupyterLab's) typesets the Markdown.
    poll(
        "the Markdown's math to be typeset",
        lambda: "$" not in page.locator(".jp-MarkdownOutput").first.inner_text() or None,
        timeout=30,
    )
    try:
        text = page.evaluate("() => document.body.innerText")
        assert "$\\" not in text, [line for line in text.splitlines() if "$" in line][:5]
        # (A label still in LaTeX: Voila's MathJax fails on it, "Math input error".)
        assert "Math input error" not in text
        labels = page.locator(".fluidnb-panel .widget-label").all_inner_texts()
        assert "β" in labels
        assert "γ" in labels
        assert any(label.startswith("rth") or label.startswith("r") for label in labels)
    finally:
        shot(page, "offline")


# ---------------------------------------------------------------- the frost lesson, offline

LESSON = Path(__file__).resolve().parents[2] / "notebooks" / "03_frost.ipynb"


def _lesson_math_is_typeset(page, shot, suffix):
    """Wait until every Markdown cell is shown, typeset, with no raw ``$`` left."""
    n_markdown = sum(c.cell_type == "markdown" for c in nbformat.read(LESSON, as_version=4).cells)
    markdown = page.locator(".jp-MarkdownOutput")

    def typeset():
        texts = markdown.all_inner_texts()
        raw = [t for t in texts if "$" in t]
        if len(texts) < n_markdown or raw:
            return None
        return page.locator("mjx-container").count() or None

    try:
        poll("the frost lesson's math, typeset offline", typeset, timeout=240, interval=0.5)
        text = page.evaluate("() => document.body.innerText")
        assert "Math input error" not in text
        assert "$\\" not in text, [line for line in text.splitlines() if "$" in line][:5]
    finally:
        shot(page, suffix)


def test_the_frost_lesson_in_jupyterlabs_voila_route_typesets_math_offline(lab_server, page, shot):
    # Issue 37, point 6: /voila/render/ in a running JupyterLab (and on Binder) asked a
    # CDN for MathJax and showed 133 raw LaTeX snippets offline; standalone Voila did not.
    from tests.browser.conftest import TOKEN

    folder = lab_server.root / "voila-route"
    folder.mkdir()
    shutil.copy(LESSON, folder / LESSON.name)
    blocked = _offline(page)
    page.set_default_timeout(240_000)
    page.goto(f"{lab_server.url}/voila/render/voila-route/{LESSON.name}?token={TOKEN}")
    try:
        _lesson_math_is_typeset(page, shot, "render-route")
        assert not [u for u in blocked if "mathjax" in u.lower()], blocked
    finally:
        lab_server.delete_sessions("voila-route")


def test_the_frost_lesson_in_standalone_voila_typesets_math_offline(voila, page, shot):
    url = voila.file(LESSON)
    blocked = _offline(page)
    page.set_default_timeout(240_000)
    page.goto(url)
    _lesson_math_is_typeset(page, shot, "standalone")
    assert not [u for u in blocked if "mathjax" in u.lower()], blocked
