"""An upload shows the upload (issue 22, point 1) and long work in a cell shows a bar,
not a pink stderr box (point 4)."""

import io

import numpy as np
import pytest
from PIL import Image

from tests.browser.helpers import canvas_rgba, poll

pytestmark = pytest.mark.browser

FIRE = """\
from fluidnb.widgets import FireApp

app = FireApp(quick=True)

statuses = []

def report(_=None):
    statuses.append(app.status)  # (a live preview's status may follow at once)
    dump("photo.json", {"name": app.photo_name, "shape": list(app.photo.shape),
                        "menu": app._sample.value, "status": app.status,
                        "statuses": statuses})

app.observe(report, "status")
report()
app
"""


def green_png():
    image = np.zeros((48, 64, 3), np.uint8)
    image[..., 1] = 220
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="png")
    return buf.getvalue()


def test_an_upload_after_another_sample_shows_the_upload(notebook, page, shot):
    nb = notebook([FIRE])
    menu = page.locator(".fluidnb-app .fluidnb-photo select")
    menu.select_option("flame")
    nb.state("photo.json", lambda s: s["name"] == "flame")
    with page.expect_file_chooser() as chooser:
        page.locator(".fluidnb-app .fluidnb-upload").click()
    chooser.value.set_files(
        files=[{"name": "green.png", "mimeType": "image/png", "buffer": green_png()}]
    )
    state = nb.state("photo.json", lambda s: s["name"] != "flame", timeout=30)
    assert state["name"] == "upload", state
    assert state["shape"] == [48, 64, 3]
    assert any("upload" in text for text in state["statuses"]), state["statuses"]
    poll("the menu to read upload", lambda: menu.input_value() == "upload")
    canvas = page.locator(".fluidnb-app .fluidnb-canvas")
    canvas.scroll_into_view_if_needed()

    def shows_green():
        box = canvas.bounding_box()
        r, g, b, _ = canvas_rgba(canvas, [(box["x"] + box["width"] / 2, box["y"] + 5)])[0]
        return g > 150 and r < 60 and b < 60

    poll("the uploaded green photo on the canvas", shows_green)
    shot(page.locator(".fluidnb-app"), "upload")
    # And a sample is one pick away again.
    menu.select_option("flame")
    nb.state("photo.json", lambda s: s["name"] == "flame")


PROGRESS = """\
import fluidnb
import fluidnb.widgets  # in a notebook: progress as a bar
from fluidnb.fluid import flame_preset, simulate

sim = simulate(flame_preset().params, 40, shape=(48, 48), seed=0,
               progress=fluidnb.progress_bar("simulating a flame"))
print("frames:", sim.n_frames)
"""


def test_long_work_in_a_cell_shows_a_bar_and_no_stderr_box(notebook, page, shot):
    notebook([PROGRESS])
    bar = page.locator(".fluidnb-progressbar")
    bar.wait_for()
    text = page.locator(".fluidnb-progressbar .fluidnb-progress-text")
    poll("the bar to end", lambda: "done in" in text.inner_text())
    assert "simulating a flame" in bar.inner_text()
    stderr = page.locator('.jp-RenderedText[data-mime-type="application/vnd.jupyter.stderr"]')
    assert stderr.count() == 0, stderr.all_inner_texts()
    shot(bar, "bar")
