"""Every slider of every app, one at a time from the defaults: Run stays enabled and runs.

Issue 36: setting each slider to its ends, its middle and the values next to its ends
disabled Run (FlickerApp T = 8; FrostApp beta = -5.55e-17, max_frames = 50; FireApp
weight = -1.1e-16, overlap = 19; TurbulenceApp m0 = 15) or let Run fail (B = 20 does
not divide the turbulence grid). A slider offers only values its app accepts: this
sets every value such a sweep reaches, as the browser would (on the control), and
runs the app at small sizes.
"""

import ipywidgets as W
import numpy as np
import pytest

from fluidnb import Clip, data
from fluidnb.frost import FrostParams
from fluidnb.videodb import starter_database
from fluidnb.widgets import FireApp, FlickerApp, FrostApp, TurbulenceApp, VideoDBApp


def sweep_values(control):
    """min, max, middle and the neighbours of the ends, as the slider offers them."""
    if isinstance(control, W.SelectionSlider):
        opts = list(control.options)
        picks = [opts[0], opts[-1], opts[len(opts) // 2], opts[min(1, len(opts) - 1)], opts[-2]]
        return list(dict.fromkeys(picks))
    lo, hi, step = control.min, control.max, control.step
    n = int(round((hi - lo) / step))
    picks = [0, n, n // 2, min(1, n), max(n - 1, 0)]
    if isinstance(control, W.FloatLogSlider):
        return list(dict.fromkeys(control.base ** (lo + k * step) for k in picks))
    values = [lo + k * step for k in picks]
    if isinstance(control, W.IntSlider):
        return list(dict.fromkeys(int(v) for v in values))
    # What the browser sends: the grid value rounded as the readout shows it is not
    # needed -- noUiSlider sends min + k * step, so do the same.
    return list(dict.fromkeys(values))


SLIDERS = (W.IntSlider, W.FloatSlider, W.FloatLogSlider, W.SelectionSlider)


def sweep(app, check=lambda app: "", run=True, timeout=120):
    panel = app.panel
    start = panel.params
    tried = 0
    for name, control in panel.controls.items():
        if not isinstance(control, SLIDERS) or control.layout.display == "none":
            continue
        panel.set_params(start)  # the values as the slider offers them from the defaults
        for value in sweep_values(panel.controls[name]):
            panel.set_params(start)
            control = panel.controls[name]
            control.value = value
            where = f"{type(app).__name__} {name} = {value!r}"
            assert panel.valid, f"{where}: {panel.message}"
            assert not app._run_button.disabled, where
            assert check(app) == "", f"{where}: {check(app)}"
            if run:
                clip = app.run(timeout=timeout)
                assert "done" in app.status or "rendered" in app.status, f"{where}: {app.status}"
                assert isinstance(clip, Clip), where
                made = clip.metadata["params"]  # (the fire's flame settings are not in it)
                if name in made:
                    assert made[name] == pytest.approx(getattr(panel.params, name)), where
            tried += 1
    panel.set_params(start)
    return tried


def test_every_flicker_slider():
    app = FlickerApp(quick=True)
    try:
        assert sweep(app) >= 5 * 12
    finally:
        app.close()


def test_every_frost_slider():
    # A small picture (the runs draw hundreds of frames each), a region large enough
    # for the largest spacing (a region with no lattice point is refused in words).
    # gamma 0.02: a few hundred frames a run rather than a thousand (the paper's 0.005
    # is swept like every value of the slider).
    app = FrostApp(data.sample("leaf", size=64), params=FrostParams(spacing=3.0, gamma=0.02))
    try:
        h, w = app.image.shape[:2]
        yy, xx = np.mgrid[:h, :w]
        app.set_region((yy - h / 2) ** 2 + (xx - w / 2) ** 2 < 24**2)
        app.set_starts([[h / 2, w / 2]])
        assert sweep(app) >= 5 * 8
    finally:
        app.close()


def test_every_fire_slider():
    app = FireApp(quick=True, n_frames=4)
    try:
        app.shape = (32, 32)  # the run's grid: a small flame is enough here
        assert sweep(app) >= 5 * 9
    finally:
        app.close()


def test_every_turbulence_slider():
    app = TurbulenceApp(n_frames=2)
    try:
        assert sweep(app, check=lambda a: a.check()) >= 5 * 7
        # Paper size: other grids, other patch sizes offered.
        app._size.value = "paper"
        app._frames.value = 2
        assert sweep(app, check=lambda a: a.check(), run=False) >= 5 * 7
    finally:
        app.close()


def test_every_videodb_slider():
    db = starter_database("water", quick=True)
    app = VideoDBApp("stream", size=96, db=db)
    try:
        h, w = app.photo.shape[:2]
        matte = np.zeros((h, w), bool)
        matte[h // 2 :] = True
        app.set_matte(matte)
        app.draw_stroke([[0.7 * h, 5], [0.7 * h, w - 5]])
        assert sweep(app) >= 5 * 8
    finally:
        app.close()


def test_the_slider_ends_are_exact_and_follow_the_fields_they_depend_on():
    frost = FrostApp(quick=True)
    fire = FireApp(quick=True)
    flicker = FlickerApp(quick=True)
    turbulence = TurbulenceApp(n_frames=2)
    try:
        assert frost.panel.controls["beta"].min == 0.0  # not -5.55e-17
        assert fire.panel.controls["weight"].min == 0.0  # not -1.1e-16
        # target <= max_frames: each slider ends at the other's value.
        frost.panel.controls["target"].value = 400
        assert frost.panel.controls["max_frames"].min == 400
        frost.panel.controls["max_frames"].value = 600
        assert frost.panel.controls["target"].max == 600
        # overlap < interval, f0 < T / 2.
        fire.panel.controls["interval"].value = 12
        assert fire.panel.controls["overlap"].max == 11
        flicker.panel.controls["f0"].value = 6
        assert flicker.panel.controls["T"].min == 13
        # Powers of two and divisors of the grid (96 x 64 here) only.
        assert list(turbulence.panel.controls["m0"].options) == [1, 2, 4, 8, 16]
        assert list(turbulence.panel.controls["B"].options) == [4, 8, 16]  # b = 4 > B / 8
        turbulence.panel.controls["b"].value = 8
        assert list(turbulence.panel.controls["B"].options) == [4, 8, 16, 32]
    finally:
        for app in (frost, fire, flicker, turbulence):
            app.close()
