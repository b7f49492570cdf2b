"""The scene app in JupyterLab at 1400 x 900: paint a layer's region with the mouse, run,
the composite plays beside the canvas (issue 38, item 4)."""

import pytest

from tests.browser.helpers import (
    ANOTHER_FRAME,
    at,
    drag_slider,
    img_rgba,
    inside,
    notebook_view,
    open_app,
    poll,
    shown_frame,
)

pytestmark = pytest.mark.browser

VIEWPORT = {"width": 1400, "height": 900}

APP = """\
from fluidnb.flicker import FlickerParams
from fluidnb.frost import FrostParams
from fluidnb.widgets import SceneApp

app = SceneApp(quick=True, display_size=384)
h, w = app.scene.shape
top_left = np.zeros((h, w), bool)
top_left[: int(0.4 * h), : int(0.3 * w)] = True
app.add_layer("frost", top_left, params=FrostParams(spacing=3.0, gamma=0.05, target=40,
                                                    max_frames=60))
app.add_layer("flicker", params=FlickerParams(T=12, fps=8.0))  # selected: painted below

def report_inputs(_=None):
    dump("inputs.json", {
        "selected": app.selected,
        "painted": {e.name: int((e.region > 0.5).sum()) for e in app.entries},
        "shape": list(app.scene.shape),
    })

def report_clip(change):
    clip = change["new"]
    if clip is None or clip.metadata.get("preview"):
        return
    photo = app.scene.photo
    regions = [e.region > 0.5 for e in app.entries]
    outside = ~(regions[0] | regions[1])
    moved = np.abs(clip.frames - photo).max(axis=-1)
    dump("clip.json", {
        "layers": [x["name"] for x in clip.metadata["layers"]],
        "rendered": [x["name"] for x in clip.metadata["layers"] if x["seconds"] != "cached"],
        "kappa": app.entries[1].params.kappa,
        "frames": len(clip),
        "outside": float(moved[:, outside].max()),
        "flicker": float(moved[:, regions[1]].max()),
        "frost_first": float(moved[0, regions[0]].mean()),
        "frost_last": float(moved[-1, regions[0]].mean()),
    })

app.canvas.observe(report_inputs, "version")
app.player.observe(report_clip, "clip")
report_inputs()
app
"""


def test_paint_a_layer_run_and_the_composite_plays_beside_the_canvas(notebook, page, shot):
    page.set_viewport_size(VIEWPORT)
    nb, app, _, box = open_app(notebook, page, [APP])
    assert nb.state("inputs.json")["selected"] == "flicker"

    # Paint the flicker layer's region over the lake with the mouse (the brush is on).
    for fy in (0.72, 0.85):
        page.mouse.move(*at(box, 0.05, fy))
        page.mouse.down()
        page.mouse.move(*at(box, 0.95, fy), steps=12)
        page.mouse.up()
    painted = nb.state("inputs.json", lambda s: s["painted"]["flicker"] > 400)["painted"]
    assert painted["frost"] > 0  # the other layer's region is untouched
    shot(page, "painted")

    # The layer list shows both layers, the top one first.
    options = page.locator(".fluidnb-scene-layers option").all_inner_texts()
    options = [o.replace("\xa0", " ").split(" (")[0] for o in options]  # (non-breaking)
    assert options == ["2. flicker", "1. frost"]

    page.locator(".fluidnb-app .fluidnb-run").click()
    result = nb.state("clip.json", timeout=180)
    assert result["layers"] == ["frost", "flicker"]
    assert result["rendered"] == ["frost", "flicker"]
    assert result["outside"] == 0.0, "a pixel outside every region changed"
    assert result["flicker"] > 0.02, "the painted water does not flicker"
    assert result["frost_last"] > result["frost_first"], "the frost did not grow"
    status = page.locator(".fluidnb-app .fluidnb-status")
    poll("the run's status", lambda: "done" in status.inner_text(), timeout=60)
    assert "rendered: frost, flicker" in status.inner_text()

    # The composite plays in the player beside the canvas.
    frame = page.locator(".fluidnb-app .fluidnb-player canvas.fluidnb-frame").first
    poll("the clip's first frame", lambda: img_rgba(frame) is not None)
    was = shown_frame(frame)
    page.wait_for_function(ANOTHER_FRAME, arg=[frame.element_handle(), was], timeout=10_000)

    # At 1400 x 900 the canvas, the player's picture, Run, the status line and the
    # first slider are in view together, without scrolling.
    app.evaluate("el => el.scrollIntoView({block: 'start'})")
    page.wait_for_timeout(300)
    view = notebook_view(page)
    assert view["width"] > 1200, view
    shot(page, "viewport")
    inside(frame.bounding_box(), view, "the player's picture")
    inside(page.locator(".fluidnb-app .fluidnb-canvas").bounding_box(), view, "the canvas")
    inside(page.locator(".fluidnb-app .fluidnb-run").bounding_box(), view, "Run")
    inside(status.bounding_box(), view, "the status line")
    inside(page.locator(".fluidnb-scene-layers").bounding_box(), view, "the layer list")
    first = page.locator(".fluidnb-app .fluidnb-panel .widget-slider").first
    inside(first.bounding_box(), view, "the first slider")
    # The canvas and the player side by side (not one under the other).
    cbox = page.locator(".fluidnb-app .fluidnb-canvas").bounding_box()
    assert frame.bounding_box()["x"] >= cbox["x"] + cbox["width"] - 1
    shot(app, "app")

    # The selected layer's slider: a preview of that layer alone follows, then (the
    # slider let go) the full scene by itself, with only that layer rendered again.
    kappa = drag_slider(page, page.locator(".fluidnb-param-kappa"), 0.85, steps=6)
    assert kappa > 1.0
    again = nb.state("clip.json", lambda s: abs(s["kappa"] - kappa) < 1e-3, timeout=120)
    assert again["rendered"] == ["flicker"], "an unchanged layer was rendered again"
    assert again["outside"] == 0.0
    poll("the status", lambda: "from the cache: 1" in status.inner_text(), timeout=30)
    shot(app, "after-slider")


HD_APP = """\
import resource, time
import imageio_ffmpeg
from fluidnb.data import sample
from fluidnb.fields import resize
from fluidnb.flicker import FlickerParams
from fluidnb.widgets import SceneApp

# A large photo: the stream enlarged to 1920 px (1504 x 1920), as a camera gives.
photo = np.clip(resize(sample("stream"), (1504, 1920), order=3), 0, 1).astype(np.float32)
app = SceneApp(photo)
app.add_layer("flicker", params=FlickerParams(T=24, fps=12.0))
app._export_path.value = "hd.mp4"
cpu = [time.process_time()]

def report_inputs(_=None):
    e = app.entries[0]
    dump("inputs.json", {"painted": int((e.region > 0.5).sum()), "shape": list(e.region.shape)})

def report_status(change):
    if not change["new"].startswith("exported"):
        return
    meta = next(imageio_ffmpeg.read_frames("hd.mp4"))
    dump("export.json", {
        "status": change["new"], "size": list(meta["size"]),
        "frames": imageio_ffmpeg.count_frames_and_secs("hd.mp4")[0],
        "cpu": time.process_time() - cpu[0],
        "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    })

def report_clip(change):
    clip = change["new"]
    if clip is not None and not clip.metadata.get("preview"):
        cpu[0] = time.process_time()
        dump("clip.json", {"shape": list(clip.frames.shape), "status": app.status})

app.canvas.observe(report_inputs, "version")
app.observe(report_status, "status")
app.player.observe(report_clip, "clip")
report_inputs()
app
"""


def test_a_large_photo_is_painted_and_run_on_a_proxy_and_exported_full_size(notebook, page, shot):
    # Issue 39: a 1920-px photo. The canvas keeps the regions at full size, Run and the
    # preview work at 480 px, and Export full size streams the 1920-px scene to a file.
    page.set_viewport_size(VIEWPORT)
    nb, app, _, box = open_app(notebook, page, [HD_APP])
    status = page.locator(".fluidnb-app .fluidnb-status")
    sizes = page.locator(".fluidnb-scene-sizes").inner_text()
    assert "preview at 480 x 376 of 1920 x 1504; Export renders full size" in sizes
    page.mouse.move(*at(box, 0.1, 0.8))
    page.mouse.down()
    page.mouse.move(*at(box, 0.9, 0.75), steps=12)
    page.mouse.up()
    painted = nb.state("inputs.json", lambda s: s["painted"] > 20000)
    assert painted["shape"] == [1504, 1920]  # painted at full size
    shot(page, "painted")
    page.locator(".fluidnb-app .fluidnb-run").click()
    run = nb.state("clip.json", timeout=180)
    assert run["shape"][1:3] == [376, 480]  # Run renders the proxy
    poll("the run's status", lambda: "done" in status.inner_text(), timeout=60)
    assert "preview at 480 x 376 of 1920 x 1504; Export renders full size" in status.inner_text()
    app.evaluate("el => el.scrollIntoView({block: 'start'})")
    page.wait_for_timeout(300)
    export = page.locator(".fluidnb-scene-export")
    inside(export.bounding_box(), notebook_view(page), "Export full size")
    shot(page, "run")
    export.click()
    poll("the export's status", lambda: "exporting at full size" in status.inner_text(), 10)
    shot(page, "exporting")
    done = nb.state("export.json", timeout=300)
    assert done["size"] == [1920, 1504]  # (width, height) of the video: full size
    assert done["frames"] == run["shape"][0]
    assert "1920 x 1504 (full size)" in done["status"]
    poll("the status", lambda: "exported" in status.inner_text(), timeout=30)
    shot(page, "exported")
    print(f"export: {done}")
