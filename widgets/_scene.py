"""The scene app: one photo, a list of layers (water, clouds, flicker, fire, frost), one clip."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import ipywidgets as W
import numpy as np

from fluidnb import as_mask
from fluidnb.fields import resize
from fluidnb.scene import KINDS, Layer, Scene, default_params, load_scene, render, save_scene

from ._app import App, _in_kernel, _quick_mode
from ._canvas import DrawingCanvas
from ._common import hint, output_dir, row, shown_path
from ._flicker import GROUPS as FLICKER_GROUPS
from ._frost import GROUPS as FROST_GROUPS
from ._panel import ParamPanel
from ._photo import PhotoInput, load_photo
from ._videodb import _HIDDEN as VIDEODB_HIDDEN
from ._videodb import GROUPS as VIDEODB_GROUPS

__all__ = ["SceneApp"]

#: The bundled photos offered ("upload" joins them after an upload).
SAMPLES = ("lake", "stream", "clouds", "leaf")
#: The kinds in the order the menu offers them.
KIND_ORDER = ("water", "clouds", "flicker", "fire", "frost")
#: Each kind's panel: (groups, fields left out) -- its method's app's groups. The
#: fire layer takes :class:`fluidnb.fire.FireParams` alone (the flame is the bundled
#: exemplar's), so its groups are the synthesis's.
PANELS = {
    "water": (VIDEODB_GROUPS, VIDEODB_HIDDEN),
    "clouds": (VIDEODB_GROUPS, VIDEODB_HIDDEN),
    "flicker": (FLICKER_GROUPS, ()),
    "fire": (
        (
            ("synthesis (sec. 4)", ("weight", "interval", "overlap", "coherence", "cutoff")),
            (
                "sizes and playback",
                ("size", "n_random", "second_pass", "input_size", "output_size", "fps"),
            ),
        ),
        (),
    ),
    "frost": (FROST_GROUPS, ()),
}
#: Longest side of the live preview: the selected layer alone on the photo this small.
PREVIEW_SIZE = 128


@dataclass
class _Entry:
    """A layer as the app edits it: like :class:`fluidnb.scene.Layer`, its region may be empty."""

    name: str
    kind: str
    region: np.ndarray  # float32 (H, W) in [0, 1]; all zero until painted
    params: object = None  # None: the scene's defaults (default_params; frost fits gamma)
    strokes: tuple = ()
    starts: np.ndarray | None = None
    speed: np.ndarray | None = None
    exemplar: str = "fire"
    visible: bool = True
    seed: int = 0

    def layer(self):
        """The library's Layer (ValueError naming the layer when its region is empty)."""
        return Layer(
            self.kind,
            self.region,
            self.params,
            strokes=self.strokes if self.kind in ("water", "clouds") else (),
            speed=self.speed,
            starts=self.starts if self.kind == "frost" else None,
            exemplar=self.exemplar,
            name=self.name,
            visible=self.visible,
            seed=self.seed,
        )

    @classmethod
    def of(cls, layer):
        return cls(
            layer.name, layer.kind, layer.region, layer.params, tuple(layer.strokes),
            layer.starts, layer.speed, layer.exemplar, layer.visible, layer.seed,
        )  # fmt: skip


class SceneApp(App):
    """Several methods on one photo (:mod:`fluidnb.scene`), interactively.

    Add a layer and pick its method (water and clouds by the video database of Okabe
    et al., flicker, fire, frost), paint its region on the photo with the brush (a
    water or clouds layer also takes flow strokes, a frost layer start points), and
    move its own parameters -- the same panel as its method's app: a preview of that
    layer alone, on the photo shrunk to 128 pixels, follows. The list orders the
    layers (the top one first: it covers the ones under it), hides and removes them.
    **Run** renders the scene (:func:`fluidnb.scene.render`: each layer by its own
    method, cached, so a change to one layer re-renders only that one) and composites
    it; the player plays it and exports GIF or MP4. **Save** and **Load** keep the
    scene in a folder (:func:`fluidnb.scene.save_scene`).

    A large photo (a 1920-px upload) is worked on through a proxy: the canvas holds
    the photo and every layer's region, strokes and points at full size (what is
    painted is never shrunk), while the preview and **Run** render the scene with
    its photo shrunk to ``size`` (the library's ``Scene(photo, size=...)``, each
    layer scaled to it). **Export full size** renders the scene at the photo's full
    size (:meth:`fluidnb.scene.Scene.resized`) streamed to a file
    (``render(scene, stream=True)``, as ``fluidnb scene`` does): a few frames in
    memory, not the clip. The status line says both sizes.

    Parameters
    ----------
    photo : str, array_like, path or PIL image
        One of the bundled photos (``"lake"`` by default) or an image.
    layers : sequence of Layer, optional
        Layers to start with (regions are resized to the photo).
    size : int, optional
        Longest side the preview and Run render the scene at -- the proxy (default
        480; 96 with ``quick``). A bundled photo is read at this size.
    full_size : int, optional
        Longest side Export renders at: a larger photo is shrunk to it (default: the
        photo's own size).
    quick : bool
        Small sizes and the small starter databases (a quick look, tests, CI).
    display_size : int
        Longest side of the canvas on screen, in pixels.

    Examples
    --------
    >>> import numpy as np
    >>> from fluidnb.flicker import FlickerParams
    >>> app = SceneApp(quick=True)
    >>> app.add_layer("flicker")
    'flicker'
    >>> app.paint_region([[40, 5], [40, 90]], radius=6)
    >>> app.panel.set_params(FlickerParams(T=12, fps=8.0))
    >>> clip = app.run(timeout=120)
    >>> clip.metadata["method"], [x["name"] for x in clip.metadata["layers"]]
    ('scene', ['flicker'])
    >>> app.close()
    """

    def __init__(
        self, photo="lake", *, layers=(), size=None, full_size=None, quick=False,
        display_size=420,
    ):  # fmt: skip
        self.quick = bool(quick)
        self.size = int(size or (96 if quick else 480))
        if self.size < 8:
            raise ValueError(f"size must be >= 8 pixels, got {size}")
        if full_size is not None and int(full_size) < self.size:
            raise ValueError(
                f"full_size must be >= size ({self.size}): the export is never smaller "
                f"than the preview, got {full_size}"
            )
        self.full_size = None if full_size is None else int(full_size)
        self.entries = []  #: The layers as edited, bottom first (:class:`_Entry`).
        self.exported = None  #: The path of the last full-size export, or None.
        self.selected = None  #: The selected layer's name, or None.
        self._syncing = False  # the app itself loads a layer into the canvas and panel
        self._panels = {}
        self._preview_scene = None
        self._photo_name = photo if isinstance(photo, str) else "upload"
        image = self._read_photo(photo)
        #: The scene Run renders: the photo shrunk to ``size`` (the proxy; its cache
        #: keeps each layer's clip); ``scene.source`` is the full-size photo.
        self.scene = Scene(image, size=self.size)
        self.photo_input = PhotoInput(
            SAMPLES,
            self._photo_name,
            on_photo=lambda p: self._act(lambda: self.set_photo(p)),
            say=lambda t, k: self.say(t, k),
        )
        self._display_size = display_size
        canvas = self._new_canvas(image)
        self._kind = W.Dropdown(
            options=list(KIND_ORDER), value="water", description="method",
            style={"description_width": "52px"}, layout=W.Layout(width="170px"),
        )  # fmt: skip
        self._add = _button("Add layer", "plus", "fluidnb-scene-add", "110px")
        self._list = W.Select(options=[], rows=5, layout=W.Layout(width="320px"))
        # Four buttons in the 330-px column, none cut off.
        self._up = _button("Up", "arrow-up", "fluidnb-scene-up", "60px")
        self._down = _button("Down", "arrow-down", "fluidnb-scene-down", "76px")
        self._hide = _button("Hide", "eye-slash", "fluidnb-scene-hide", "72px")
        self._remove = _button("Remove", "trash", "fluidnb-scene-remove", "92px")
        self._folder = W.Text(
            value=str(shown_path(output_dir(create=False) / "scene")),
            description="folder", style={"description_width": "44px"},
            layout=W.Layout(width="320px"),
        )  # fmt: skip
        self._save = _button("Save scene", "save", "fluidnb-scene-save", "120px")
        self._load = _button("Load scene", "folder-open", "fluidnb-scene-load", "120px")
        self._export_path = W.Text(
            value=str(shown_path(output_dir(create=False) / "scene.mp4")),
            description="file", style={"description_width": "44px"},
            layout=W.Layout(width="320px"),
        )  # fmt: skip
        self._export = _button("Export full size", "film", "fluidnb-scene-export", "160px")
        self._sizes = W.HTML()
        self._export_path.add_class("fluidnb-scene-export-path")
        self._sizes.add_class("fluidnb-scene-sizes")
        self._export.on_click(lambda _: self._act(lambda: self.export(block=False)))
        self._list.add_class("fluidnb-scene-layers")
        self._kind.add_class("fluidnb-scene-kind")
        self._folder.add_class("fluidnb-scene-folder")
        self._add.on_click(lambda _: self._act(lambda: self.add_layer(self._kind.value)))
        self._up.on_click(lambda _: self._act(lambda: self.move_layer(self.selected, +1)))
        self._down.on_click(lambda _: self._act(lambda: self.move_layer(self.selected, -1)))
        self._hide.on_click(lambda _: self._act(lambda: self.toggle_layer(self.selected)))
        self._remove.on_click(lambda _: self._act(lambda: self.remove_layer(self.selected)))
        self._save.on_click(lambda _: self._act(lambda: self.save(self._folder.value)))
        self._load.on_click(lambda _: self._act(lambda: self.load(self._folder.value)))
        self._list.observe(self._list_picked, "value")
        super().__init__(
            panel=self._panel_for("water"),
            run=self._run,
            preview=self._preview,
            canvas=canvas,
            title="Scene — several methods on one photo",
        )
        self.inputs = (
            self.photo_input,
            row(self._kind, self._add),
            self._list,
            row(self._up, self._down, self._hide, self._remove),
        )
        self.controls = (
            self._sizes,
            self._export_path,
            self._export,
            self._folder,
            row(self._save, self._load),
            hint(
                "Add a layer, paint its region with the brush (water and clouds: strokes "
                "along the flow; frost: start points, else its innermost point). The list "
                "shows the top layer first (it covers those under it). The preview shows "
                "the selected layer alone, small; Run renders only the layers that changed."
            ),
        )
        full = Scene(image, size=None)
        for layer in layers:
            full.add(layer)  # resized to the full photo, names checked
            self.entries.append(_Entry.of(full.layers[-1]))
        self._refresh_list()
        self._show_sizes()
        self.say(self.sizes())
        if self.entries:
            self.select_layer(self.entries[-1].name)

    def _read_photo(self, photo):
        """The photo at full size: an image as given (or ``full_size``), a sample at ``size``."""
        image, _ = load_photo(
            photo, samples=SAMPLES, size=self.full_size, sample_size=self.size, min_side=8
        )
        return image

    @property
    def full_shape(self):
        """(H, W) of the photo at full size: the regions' and the export's."""
        return self.scene.full_shape

    def sizes(self):
        """What the status line says of the sizes: the preview's and the export's."""
        (h, w), (fh, fw) = self.scene.shape, self.full_shape
        if (h, w) == (fh, fw):
            return f"preview and Run at the photo's full size, {w} x {h}"
        return f"preview at {w} x {h} of {fw} x {fh}; Export renders full size"

    def _show_sizes(self):
        # As a hint is drawn (one line height when it wraps in the 330-px column).
        self._sizes.value = hint(self.sizes()).value

    # ------------------------------------------------------------------ widgets
    def _new_canvas(self, image):
        canvas = DrawingCanvas(
            image, masks=["region"], strokes=["flow"], points=["starts"],
            display_size=self._display_size,
        )  # fmt: skip
        canvas.brush_radius = max(2.0, max(image.shape[:2]) / 24)
        canvas.select("brush", "region")
        return canvas

    def _panel_for(self, kind):
        """The panel of ``kind``'s parameter class (one per kind, made once)."""
        if kind not in self._panels:
            groups, exclude = PANELS[kind]
            self._panels[kind] = ParamPanel(default_params(kind), groups=groups, exclude=exclude)
        return self._panels[kind]

    def _use_panel(self, panel):
        """Show ``panel`` as the app's (the selected layer's kind's)."""
        if panel is self.panel:
            return
        self.panel.unobserve(self._params_changed, "params")
        self.panel.unobserve(self._validity_changed, "valid")
        self.panel = panel
        panel.observe(self._params_changed, "params")
        panel.observe(self._validity_changed, "valid")
        self._run_button.disabled = not panel.valid or self.running
        self._layout()

    def _act(self, fn):
        """A button's action: its ValueError goes to the status line (nothing changes)."""
        try:
            fn()
        except ValueError as exc:
            self.say(str(exc), "error")

    def _refresh_list(self):
        # The top layer first, as in a paint program.
        options = [
            (f"{i + 1}. {e.name} ({e.kind}){'' if e.visible else ' — hidden'}"
             f"{'' if (e.region > 0.5).any() else ' — not painted'}", e.name)
            for i, e in reversed(list(enumerate(self.entries)))
        ]  # fmt: skip
        self._syncing = True
        try:
            self._list.options = options  # (its value passes by the first option: ignored)
            self._list.value = self.selected
        finally:
            self._syncing = False
        entry = self._entry(self.selected) if self.selected else None
        self._hide.description = "Show" if entry is not None and not entry.visible else "Hide"
        for b in (self._up, self._down, self._hide, self._remove):
            b.disabled = entry is None

    def _list_picked(self, change):
        if not self._syncing and change["new"] is not None and change["new"] != self.selected:
            self.select_layer(change["new"])

    # ------------------------------------------------------------------ layers
    def _entry(self, name):
        for e in self.entries:
            if e.name == name:
                return e
        raise ValueError(f"no layer named {name!r}; the scene has {[e.name for e in self.entries]}")

    def add_layer(self, kind, region=None, *, name=None, params=None):
        """Add a layer of ``kind`` on top and select it; returns its name.

        Parameters
        ----------
        kind : str
            One of ``water``, ``clouds``, ``flicker``, ``fire``, ``frost``.
        region : array_like of bool, optional
            Its region (the photo's size); default: paint it afterwards (what is
            painted while no layer is selected becomes the first layer's region).
        name : str, optional
            Default: the kind, numbered if taken (``fire 2``).
        params : Params, optional
            Its method's parameters (default: the scene's defaults for the kind).
        """
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {list(KIND_ORDER)}, got {kind!r}")
        taken = {e.name for e in self.entries}
        if name is None:
            name, i = kind, 2
            while name in taken:
                name, i = f"{kind} {i}", i + 1
        elif name in taken:
            raise ValueError(f"name {name!r} is taken; the scene has {sorted(taken)}")
        shape = self.full_shape
        if region is not None:
            region = as_mask(region, shape, name="region").astype(np.float32)
        elif self.selected is None:  # a drawing made before any layer is kept
            region = self.canvas.get_mask("region").astype(np.float32)
        else:
            region = np.zeros(shape, np.float32)
        if params is not None and not isinstance(params, type(default_params(kind))):
            raise ValueError(
                f"params of a {kind} layer must be a {type(default_params(kind)).__name__}, "
                f"got {type(params).__name__}"
            )
        self.entries.append(_Entry(name, kind, region, params))
        self.select_layer(name)
        return name

    def select_layer(self, name):
        """Select a layer: its region, strokes and points on the canvas, its panel shown."""
        entry = self._entry(name)
        self.selected = name
        self._syncing = True
        try:
            c = self.canvas
            c.set_mask(entry.region > 0.5, "region")
            c.set_strokes(list(entry.strokes), "flow")
            c.set_points(np.zeros((0, 2)) if entry.starts is None else entry.starts, "starts")
            c.history = type(c.history)()  # Undo stays within this layer's own drawing
            for layer in c.layers.values():
                layer.history = c.history
            c.select("brush", "region")
            panel = self._panel_for(entry.kind)
            self._use_panel(panel)
            panel.set_params(self._shown_params(entry))
        finally:
            self._syncing = False
        self._refresh_list()
        proxy = "" if self.scene.shape == self.full_shape else f"; {self.sizes()}"
        self.say(f"layer {name!r} ({entry.kind}, {KINDS[entry.kind][0]}): paint its region{proxy}")
        self.request_preview()

    def _shown_params(self, entry):
        """The values the layer's panel shows: its own, else those its last run used.

        A layer without parameters of its own runs with the scene's defaults, and a
        frost layer's γ is then fitted to its target at the run
        (:func:`fluidnb.scene.default_params`): once it ran, the panel shows that γ,
        so a slider moved afterwards starts from it, not from the paper's.
        """
        if entry.params is not None:
            return entry.params
        shown = default_params(entry.kind)
        try:
            # The run's layer: the region shrunk to the proxy as Run shrinks it.
            key = self.scene.fit(entry.layer()).key(self.scene.photo_key, self.scene.shape)
        except ValueError:  # not painted yet
            return shown
        made = self.scene.cache.get(key)
        used = None if made is None else made.clip.metadata.get("params")
        try:
            return type(shown).from_dict(used) if isinstance(used, dict) else shown
        except (TypeError, ValueError):  # a method whose clip records other values
            return shown

    def remove_layer(self, name):
        """Remove a layer (the next one down, or the top, is selected)."""
        entry = self._entry(name)
        i = self.entries.index(entry)
        self.entries.remove(entry)
        self.selected = None
        if self.entries:
            self.select_layer(self.entries[max(0, i - 1)].name)
        else:
            self._syncing = True
            try:
                self.canvas.clear("region")
            finally:
                self._syncing = False
            self._refresh_list()
            self.preview_player.clip = None

    def move_layer(self, name, step):
        """Move a layer ``step`` places up (+) or down (-) the list (bottom first)."""
        entry = self._entry(name)
        i = self.entries.index(entry)
        j = min(max(i + int(step), 0), len(self.entries) - 1)
        self.entries.insert(j, self.entries.pop(i))
        self._refresh_list()

    def toggle_layer(self, name, visible=None):
        """Hide or show a layer (a hidden layer is kept but not rendered)."""
        entry = self._entry(name)
        entry.visible = (not entry.visible) if visible is None else bool(visible)
        self._refresh_list()

    def paint_region(self, points, radius=None, *, erase=False):
        """Paint (or erase) the selected layer's region along ``points`` (row, col)."""
        if self.selected is None:
            raise ValueError("no layer is selected: add one first")
        self.canvas.paint(points, radius=radius, layer="region", erase=erase)

    def set_region(self, mask):
        """Replace the selected layer's region (a mask or soft matte of the photo's size)."""
        if self.selected is None:
            raise ValueError("no layer is selected: add one first")
        region = np.asarray(mask)
        if region.dtype.kind not in "buif":
            raise ValueError(f"region must be a mask or a matte, got dtype {region.dtype}")
        region = region.astype(np.float32)
        if region.shape != self.full_shape or region.min() < 0 or region.max() > 1:
            raise ValueError(
                f"region must be a mask or a matte in [0, 1] of the photo's size "
                f"{self.full_shape}, got shape {region.shape}"
            )
        entry = self._entry(self.selected)
        entry.region = region
        self._syncing = True
        try:
            self.canvas.set_mask(region > 0.5, "region")
        finally:
            self._syncing = False
        self._refresh_list()
        self.request_preview()

    def _drawing_changed(self, change):
        if self._syncing:
            return
        if self.selected is not None:
            entry = self._entry(self.selected)
            mask = self.canvas.get_mask("region")
            if not np.array_equal(mask, entry.region > 0.5):  # a soft matte is kept as is
                entry.region = mask.astype(np.float32)
            entry.strokes = tuple(s for s in self.canvas.get_strokes("flow") if len(s) >= 2)
            points = self.canvas.get_points("starts")
            entry.starts = points if len(points) else None
            self._refresh_list()
        super()._drawing_changed(change)

    def _params_changed(self, change):
        if self._syncing or self.selected is None:
            return
        self._entry(self.selected).params = change["new"]
        super()._params_changed(change)

    # ------------------------------------------------------------------ photo
    def set_photo(self, photo):
        """Work on another photo (a sample's name or an image); the layers' regions follow.

        Regions, strokes and start points are scaled to the new photo; nothing is lost.
        """
        if self.running:
            raise ValueError("wait for the run (or Cancel it) before changing the photo")
        image = self._read_photo(photo)
        old = self.full_shape
        scene = Scene(image, size=self.size, fps=self.scene.fps, duration=self.scene.duration)
        new = scene.full_shape
        f = np.array([new[0] / old[0], new[1] / old[1]], np.float32)
        for e in self.entries:
            e.region = np.clip(resize(e.region, new), 0, 1).astype(np.float32)
            e.strokes = tuple(s * f for s in e.strokes)
            e.starts = None if e.starts is None else e.starts * f
            e.speed = None if e.speed is None else resize(e.speed, new, order=0) * f.mean()
        self.scene = scene
        self._show_sizes()
        self._preview_scene = None
        self.canvas = self._new_canvas(image)
        self._photo_name = photo if isinstance(photo, str) else "upload"
        self.photo_input.shown(self._photo_name)
        if self.selected is not None:
            self.select_layer(self.selected)

    # ------------------------------------------------------------------ library calls
    def _layers(self):
        """The library's layers (ValueError naming a visible layer with no region)."""
        layers = [e.layer() for e in self.entries if e.visible or (e.region > 0.5).any()]
        if not any(layer.visible for layer in layers):
            raise ValueError("the scene has no visible layer: add one (or show a hidden one)")
        return layers

    def _preview(self, params):
        if self.selected is None:
            return None
        entry = replace(self._entry(self.selected), visible=True)
        layer = entry.layer()  # ValueError: paint its region
        if self._preview_scene is None:
            self._preview_scene = Scene(self.scene.photo, size=PREVIEW_SIZE)
        small = self._preview_scene
        small.layers = []
        small.add(layer)  # the region shrinks with the photo
        started = time.perf_counter()
        clip = render(small, quick=self.quick)
        took = time.perf_counter() - started
        cached = clip.metadata["layers"][0]["seconds"] == "cached"
        return clip.with_metadata(
            preview=True,
            smooth=True,
            note=f"{entry.name} alone at {max(small.shape)} px"
            + (" (cached)" if cached else f", {took:.1f} s"),
        )

    def _proxy_scene(self):
        """The scene Run renders: every layer shrunk to the proxy (the full ones kept)."""
        self.scene.layers = []
        for layer in self._layers():
            self.scene.add(layer)  # its region at full size, shrunk; resized() has it back
        return self.scene

    def _run(self, params, progress):
        return render(self._proxy_scene(), quick=self.quick, progress=progress)

    def full_scene(self):
        """The scene at the photo's full size, as Export renders it (plain data).

        The proxy's scene made at full size by :meth:`fluidnb.scene.Scene.resized`:
        each layer's region, strokes and points as painted (at full size).
        """
        return self._proxy_scene().resized(None)

    def export(self, path=None, timeout=None, *, block=None):
        """Render the scene at full size, streamed to ``path`` (Export full size).

        The layers' methods run on the full-size photo and the frames are written as
        they are composited (``render(scene, stream=True)``): memory holds a few
        frames of each layer, not the clip. Like :meth:`run`, it waits (and returns
        the file's path) outside a live notebook, else works in the background with
        the progress bar and Cancel.

        Parameters
        ----------
        path : str or Path, optional
            ``.mp4``, ``.gif``, ``.npz`` or a folder of PNG frames (default: the
            file box, ``scene.mp4`` in the output folder).
        timeout : float, optional
            Longest wait in seconds when waiting (TimeoutError after it).
        block : bool, optional
            Wait (True) or not (False); by default as :meth:`run`.
        """
        from pathlib import Path

        from fluidnb._media import as_path

        path = self._export_path.value if path is None else path
        if not str(path).strip():
            raise ValueError("path must name the file to export to (.mp4, .gif, .npz)")
        out = as_path(path)
        if out.suffix.lower() not in (".mp4", ".gif", ".npz", ""):
            raise ValueError(
                f"path must end in .mp4, .gif or .npz (or name a folder of PNG frames), "
                f"got {Path(path).name!r}"
            )
        if self.running:
            raise ValueError("wait for the run (or Cancel it) before exporting")
        scene = self.full_scene()  # ValueError: a visible layer not painted
        self.exported = None
        self._export_path.value = str(path)
        (h, w) = scene.shape
        done_info = {}

        def task(params, progress):
            frames = render(scene, quick=self.quick, stream=True, progress=progress)
            done_info["frames"] = len(frames)
            done_info["fps"] = frames.fps
            return frames.save(out)

        def done(written, seconds):
            self.exported = written
            return (
                f"exported {shown_path(written)}: {done_info['frames']} frames at "
                f"{w} x {h} (full size), {done_info['fps']:g} fps, in {seconds:.1f} s"
            )

        started = self.start_task(
            task, done, message=f"exporting at full size, {w} x {h}…", busy=(self._export,)
        )
        if not started:
            return None
        if block is None:
            block = _quick_mode() or not _in_kernel()
        if not block:
            return None
        self.wait(timeout)
        return self.exported

    def _show_clip(self, clip, seconds):
        super()._show_clip(clip, seconds)
        if self.selected is not None and self._entry(self.selected).params is None:
            self._syncing = True  # the values the run used (a frost's fitted γ)
            try:
                self.panel.set_params(self._shown_params(self._entry(self.selected)))
            finally:
                self._syncing = False
        made = [x["name"] for x in clip.metadata["layers"] if x["seconds"] != "cached"]
        kept = len(clip.metadata["layers"]) - len(made)
        redone = ", ".join(made) if made else "none"
        return (
            f"done in {seconds:.1f} s: {len(clip)} frames at {clip.fps:g} fps; rendered: "
            f"{redone}; from the cache: {kept}; {self.sizes()}"
        )

    # ------------------------------------------------------------------ files
    def save(self, folder=None):
        """Save the scene (photo, every painted layer) to ``folder``; returns its path.

        A layer not painted yet has no region to save: it is left out (and said).
        """
        folder = self._folder.value if folder is None else folder
        painted = [e.layer() for e in self.entries if (e.region > 0.5).any()]
        scene = Scene(self.scene.source, painted, size=None, fps=self.scene.fps,
                      duration=self.scene.duration)  # fmt: skip
        path = save_scene(scene, folder)
        self._folder.value = str(folder)
        left = [e.name for e in self.entries if not (e.region > 0.5).any()]
        left = f"; not painted, left out: {', '.join(left)}" if left else ""
        self.say(f"saved the scene ({len(painted)} layers{left}) to {shown_path(path)}", "ok")
        return path

    def load(self, folder=None):
        """Load a scene folder: its photo and layers replace the app's (not on error)."""
        if self.running:
            raise ValueError("wait for the run (or Cancel it) before loading a scene")
        folder = self._folder.value if folder is None else folder
        scene = load_scene(folder)  # a bad folder raises here: nothing changed
        entries = [_Entry.of(layer) for layer in scene.layers]
        if scene.shape != self.full_shape:
            self.canvas = self._new_canvas(scene.photo)
        else:
            self.canvas.set_image(scene.photo)
        # Saved at full size; Run works on its proxy.
        proxy = Scene(scene.photo, size=self.size, fps=scene.fps, duration=scene.duration)
        self.scene, self._preview_scene = proxy, None
        self._show_sizes()
        self.entries, self.selected = entries, None
        self._photo_name = "upload"
        self.photo_input.shown("upload")
        self._folder.value = str(folder)
        if entries:
            self.select_layer(entries[-1].name)
        else:
            self._refresh_list()
        self.say(f"loaded {len(entries)} layers from {shown_path(folder)}", "ok")
        return scene

    def state(self):
        """What the app shows, as plain data (for tests and scripts)."""
        return {
            "photo": self._photo_name,
            "shape": tuple(self.scene.shape),
            "full_shape": tuple(self.full_shape),
            "selected": self.selected,
            "layers": [
                {
                    "name": e.name,
                    "kind": e.kind,
                    "visible": e.visible,
                    "painted": int((e.region > 0.5).sum()),
                    "strokes": len(e.strokes),
                    "starts": 0 if e.starts is None else len(e.starts),
                    "params": None if e.params is None else e.params.to_dict(),
                }
                for e in self.entries
            ],
            "renders": self.scene.renders,
            "status": self.status,
        }


def _button(description, icon, cls, width="76px"):
    b = W.Button(description=description, icon=icon, layout=W.Layout(width=width))
    b.add_class(cls)
    return b
