"""The turbulence app: add a source's detail to a coarse flow, and time the searches."""

from __future__ import annotations

import html
import math

import ipywidgets as W
import numpy as np

from fluidnb import Progress
from fluidnb.turbulence import (
    PAPER_SHAPES,
    PAPER_TABLE1,
    Flow,
    Synthesis,
    TurbulenceParams,
    check_settings,
    compare,
    prepare,
    render,
    sample_flows,
    side_by_side,
    synthesize,
    table1,
    vorticity,
    vorticity_clip,
)

from ._app import App
from ._common import hint, row
from ._panel import ParamPanel
from ._player import FramePlayer

__all__ = ["TurbulenceApp"]

#: Size choices: (scale of the sample flows, default frames, label).
SIZES = {
    "quick": (2, 40, "quick — 12×8 → 96×64"),
    "paper": (1, 200, "paper — 24×16 → 192×128"),
}
#: Table 1's rows in the paper's order, then the two exact searches.
ROW_ORDER = (*PAPER_TABLE1, "exact-fft", "exact-bounds")
#: The three flows shown side by side, left to right.
PANELS = ("target (upsampled)", "source", "synthesised")
MAX_FRAMES = 400
#: The panel's groups: the search (the paper's subject) open, the energy's terms folded.
GROUPS = (
    ("the search (Table 1)", ("strategy", "m0", "interval", "B", "b")),
    ("the energy (Eq. 1-2) and pasting", ("alpha", "beta", "D_th", "blend")),
)

_ERR = "var(--jp-error-color1, #d32f2f)"


class TurbulenceApp(App):
    """Example-based turbulence synthesis with adaptive patch search (Watanabe et al.).

    A coarse *target* flow (the motion a user designed) gets the turbulent detail
    of a fine *source* flow, patch by patch: a global search on the coarse grid
    (Eq. 1), then a local search on the fine grid (Eq. 2) whose strategy is the
    paper's subject (Table 1). The sliders set the patch sizes ``B`` and ``b``, the
    weights ``alpha`` and ``beta``, the mask threshold ``D_th``, the search strategy
    and its intervals ``m0`` and ``m``. **Run** synthesises with the chosen strategy
    (progress, Cancel) and adds its row to the table -- time per frame and the
    errors against the exhaustive search --; **Compare all strategies** fills the
    whole table, Table 1 with the paper's figures beside ours. The players show a
    dye carried by the upsampled target, the source and the synthesised flow, and
    their vorticity, side by side (they follow each other's frame).

    Parameters
    ----------
    target, source : fluidnb.turbulence.Flow, optional
        Your own pair (see :func:`fluidnb.turbulence.prepare` for what must match);
        by default the sample pair of :func:`fluidnb.turbulence.sample_flows`.
    size : {"quick", "paper"}
        The sample pair's size: ``"quick"`` halves both grids (12 x 8 and 96 x 64,
        40 frames: a run takes seconds); ``"paper"`` is the paper's setting
        (24 x 16 and 192 x 128, 200 frames). Ignored with your own flows.
    n_frames : int, optional
        Frames to synthesise (default: the size's; all of your flows').
    display_width : int
        Width on screen of each player (three flows side by side).
    export_dir : str or Path, optional
        Where the export buttons write (default: the apps' output folder, see
        :class:`FramePlayer`).

    Examples
    --------
    >>> app = TurbulenceApp(n_frames=4)
    >>> app.panel.set("strategy", "exhaustive")
    >>> clip = app.run(timeout=300)
    >>> clip.n_frames, app.rows["exhaustive"]["relative_error"]
    (4, 0.0)
    >>> app.close()
    """

    def __init__(
        self,
        target=None,
        source=None,
        *,
        size="quick",
        n_frames=None,
        display_width=432,
        export_dir=None,
    ):
        if (target is None) != (source is None):
            raise ValueError("give both target and source flows, or neither (the sample pair)")
        for name, flow in (("target", target), ("source", source)):
            if flow is not None and not isinstance(flow, Flow):
                raise ValueError(
                    f"{name} must be a fluidnb.turbulence.Flow, got {type(flow).__name__}"
                )
        self._given = None if target is None else (target, source)
        sizes = {k: v[2] for k, v in SIZES.items()}
        if self._given is not None:
            (th, tw), (sh, sw) = target.shape, source.shape
            sizes = {"yours": f"your flows — {th}×{tw} → {sh}×{sw}"}
            size = "yours"
        elif size not in SIZES:
            raise ValueError(f"size must be one of {', '.join(SIZES)}, got {size!r}")

        self.synthesis = None  #: The last run's Synthesis (the one shown).
        self.rows = {}  #: Table rows: strategy label -> Synthesis.summary() of our run.
        self._rows_key = None  # the settings the table's rows were made with
        self._table_note = ""
        self._latest = None  # label of the row updated last
        self._flows_cache = {}  # (size, frames) -> (target, source)
        self._prep_cache = {}  # "run" / "preview" -> (key, Prepared, target, source)
        self._preview_pair = None  # (key, one frame of the target, of the source)
        self._check_error = ""  # what the live check of the settings found

        self._size = W.Dropdown(
            options=[(label, key) for key, label in sizes.items()],
            value=size,
            description="size",
            style={"description_width": "50px"},
            layout=W.Layout(width="260px"),
        )
        # The sliders offer only settings these grids accept (B divides the source
        # grid, b > B dX/dx...): the library's own check, as a Run would do it.
        panel = ParamPanel(TurbulenceParams, groups=GROUPS, check=self._grid_check)
        self._frames = W.BoundedIntText(
            value=self._default_frames(size) if n_frames is None else n_frames,
            min=2,
            max=self._max_frames(size),
            description="frames",
            style={"description_width": "50px"},
            layout=W.Layout(width="150px"),
        )
        self._compare_button = W.Button(
            description="Compare all strategies",
            icon="table",
            tooltip="Run every search of Table 1 (and the exact ones) on the same flows",
            layout=W.Layout(width="210px"),
        )
        self.table = W.HTML()
        # Two players side by side (a shorter frame slider each, to fit a laptop's
        # page), the vorticity following the dye's frame.
        # The vorticity shows the dye's frame: one group in the page while they play,
        # and the paused frame and play/pause linked here.
        group = f"fluidnb-turbulence-{id(self):x}"
        dye = FramePlayer(
            display_width=display_width,
            export_dir=export_dir,
            label="turbulence",
            slider_width="200px",
            group=group,
        )
        self.vorticity = FramePlayer(
            display_width=display_width,
            export_dir=export_dir,
            label="vorticity",
            slider_width="200px",
            group=group,
        )
        W.link((dye, "frame"), (self.vorticity, "frame"))
        W.link((dye.view, "playing"), (self.vorticity.view, "playing"))
        for wid, cls in [
            (self._size, "fluidnb-size"),
            (self._frames, "fluidnb-frames"),
            (self._compare_button, "fluidnb-compare"),
            (self.table, "fluidnb-table"),
            (dye, "fluidnb-dye"),
            (self.vorticity, "fluidnb-vorticity"),
        ]:
            wid.add_class(cls)
        self._size.observe(self._size_changed, "value")
        self._frames.observe(lambda _: self._flows_changed(), "value")
        self._compare_button.on_click(lambda _: self.start_compare())
        note = hint(
            "Run synthesises with the chosen search and adds its row to the table; errors "
            "are measured against the exhaustive search."
        )
        self._headers = [W.HTML(_header(None, display_width)) for _ in range(2)]
        dye_view, vorticity_view = (
            self.titled(text, header, player, margin="0 1em 0 0")
            for text, header, player in zip(
                ("Dye carried by each flow", "Vorticity — red clockwise, blue anticlockwise"),
                self._headers,
                (dye, self.vorticity),
            )
        )
        # The size above the sliders, the two players beside them, Table 1 underneath.
        super().__init__(
            panel=panel,
            run=self._run_task,
            preview=self._preview,
            title="Example-based turbulence with adaptive search — Watanabe et al.",
            inputs=[row(self._size, self._frames)],
            controls=[self._compare_button, note],
            aside=[
                W.HTML("<b>Table 1 — time per frame and error of each search</b>"),
                self.table,
            ],
            views=[dye_view, vorticity_view],
            player=dye,
        )
        self.add_class("fluidnb-turbulence")
        # The preview (one frame's vorticity) goes to the vorticity player.
        self.player.remove_class("fluidnb-preview-player")
        self.preview_player = self.vorticity
        self.vorticity.add_class("fluidnb-preview-player")
        panel.observe(lambda _: self._check_settings(), "params")
        self._render_table()
        self._check_settings()

    # ------------------------------------------------------------------ the inputs
    @staticmethod
    def _default_frames(size):
        return SIZES[size][1] if size in SIZES else MAX_FRAMES

    def _max_frames(self, size):
        if size in SIZES:
            return MAX_FRAMES
        return self._given[0].n_frames

    def _size_changed(self, change):
        size = change["new"]
        with self.hold_trait_notifications():
            self._frames.max = self._max_frames(size)
            self._frames.value = min(self._default_frames(size), self._frames.max)
        self._flows_changed()

    def _flows_changed(self):
        self.panel.follow()  # the sliders offer what this size's grids accept
        self._check_settings()
        self.request_preview()

    def flows(self, size=None, n_frames=None, progress=None):
        """The (target, source) pair a run uses (the sample pair is simulated once, cached)."""
        size = self._size.value if size is None else size
        n = int(self._frames.value if n_frames is None else n_frames)
        key = (size, n)
        if key not in self._flows_cache:
            if self._given is not None:
                target, source = (f.frames(0, n) for f in self._given)
            else:
                target, source = sample_flows(n, scale=SIZES[size][0], progress=progress)
            self._flows_cache = {key: (target, source)}  # keep one pair in memory
        return self._flows_cache[key]

    def _grids(self, size):
        """(target shape, source shape, dx ratio) of a size, without loading its flows."""
        if self._given is not None:
            target, source = self._given
            return target.shape, source.shape, target.dx / source.dx
        scale = SIZES[size][0]
        th, tw = (s // scale for s in PAPER_SHAPES["target"])
        sh, sw = (s // scale for s in PAPER_SHAPES["source"])
        return (th, tw), (sh, sw), sw / tw

    def _grid_check(self, params):
        """Raise the library's ValueError for settings this size's grids refuse."""
        target_shape, source_shape, ratio = self._grids(self._size.value)
        check_settings(params, target_shape, source_shape, ratio=ratio)

    def check(self, params=None, size=None):
        """What is wrong with these settings for this size's grids ("" when nothing).

        The library's check of settings against grid shapes
        (:func:`fluidnb.turbulence.check_settings`, which
        :func:`fluidnb.turbulence.prepare` also runs), so a bad slider is reported
        at once, before any run.
        """
        params = self.panel.params if params is None else params
        target_shape, source_shape, ratio = self._grids(self._size.value if size is None else size)
        try:
            check_settings(params, target_shape, source_shape, ratio=ratio)
        except ValueError as exc:
            return str(exc)
        return ""

    def _check_settings(self):
        if not self.panel.valid:
            return  # the panel says why
        message = self.check()
        if message:
            self._check_error = message
            if not self.running:
                self.say(message, "error")
        elif self._check_error:
            self._check_error = ""
            if not self.running:
                self.say("")

    # ------------------------------------------------------------------ the runs
    def start(self):
        """Synthesise with the panel's settings in the worker (what Run does)."""
        return self._start(self._run_task, self._ran, "synthesising…")

    def start_compare(self):
        """Run every strategy of Table 1 in the worker (what the Compare button does)."""
        return self._start(self._compare_task, self._compared, "comparing every search…")

    def compare_all(self, timeout=None):
        """Press Compare all strategies and wait (headless driving); returns the rows."""
        self.start_compare()
        self.wait(timeout)
        return self.rows

    def _start(self, task, done, message):
        if self.running:
            return False
        if self.panel.valid:
            problem = self.check()
            if problem:
                self.say(problem, "error")
                return False
        size, n = self._size.value, int(self._frames.value)
        return self.start_task(
            lambda p, progress: task(p, progress, size, n),
            done,
            message=message,
            busy=(self._compare_button,),
        )

    def _prepared(self, target, source, params, slot="run"):
        """The preparation for these flows and (B, b, alpha, D_th), reused across runs."""
        key = (id(target), id(source), params.B, params.b, params.alpha, params.D_th)
        kept = self._prep_cache.get(slot)
        if kept is None or kept[0] != key:
            self._prep_cache.pop(slot, None)  # free the old one first
            kept = self._prep_cache[slot] = (key, prepare(target, source, params), target, source)
        return kept[1]

    def _preview(self, params):
        """The last frame alone, synthesised without its history: the three vorticities.

        What the sliders change, in ~50 ms (the clip and the table's row come when
        they rest).
        """
        problem = self.check(params)
        if problem:
            raise ValueError(problem)
        size, n = self._size.value, int(self._frames.value)
        target, source = self.flows(size, n)
        key = (id(target), id(source), n - 1)
        if self._preview_pair is None or self._preview_pair[0] != key:
            self._preview_pair = (key, target.frames(n - 1, n), source.frames(n - 1, n))
        _, one_target, one_source = self._preview_pair
        prep = self._prepared(one_target, one_source, params, slot="preview")
        result = synthesize(one_target, one_source, params, prepared=prep)
        top = float(np.percentile(np.abs(vorticity(result.velocity)), 99)) or 1.0
        maps = [vorticity_clip(v, fps=12, vmax=top) for v in (prep.U_t, prep.U_s, result.velocity)]
        meta = {"method": "turbulence", "preview": True, "what": "vorticity"}
        return side_by_side(maps, meta).with_metadata(
            note=f"vorticity of frame {n - 1} alone (target | source | synthesised)",
            caption="preview: the last frame's vorticity — target | source | synthesised",
        )

    def rest_task(self):
        """The run (its clip and its table row) once the sliders rest."""
        if self.check():
            return None
        size, n = self._size.value, int(self._frames.value)
        return (
            (lambda p, progress: self._run_task(p, progress, size, n)),
            self._ran,
            "synthesising…",
        )

    def _run_task(self, params, progress, size=None, n_frames=None):
        load, work, show = Progress(progress).split(0.1, 0.85)
        target, source = self.flows(size, n_frames, progress=load)
        work(0.0, "preparing")
        prep = self._prepared(target, source, params)
        result = synthesize(target, source, params, reference=True, progress=work, prepared=prep)
        show(0.0, "rendering")
        clip = self._show(result)
        row = result.summary()
        self._add_rows({row["strategy"]: row}, self._settings_key(params, size, n_frames))
        return clip

    def _compare_task(self, params, progress, size=None, n_frames=None):
        load, work, show = Progress(progress).split(0.05, 0.92)
        target, source = self.flows(size, n_frames, progress=load)
        # Keep whole only the run to show (the others' flows would cost ~80 MB each).
        results = compare(
            target,
            source,
            params=params,
            progress=work,
            keep=lambda p: p.strategy in (params.strategy, "adaptive"),
        )
        runs = [r for r in results.values() if isinstance(r, Synthesis)]
        shown = next((r for r in runs if r.params == params), None)
        if shown is None:
            shown = next(
                (r for r in runs if r.params.strategy == params.strategy),
                next(r for r in runs if r.params.strategy == "adaptive"),
            )
        show(0.0, "rendering")
        clip = self._show(shown)
        rows = {
            label: r.summary() if isinstance(r, Synthesis) else r for label, r in results.items()
        }
        del results, runs
        self.rows = {}
        self._add_rows(rows, self._settings_key(params, size, n_frames))
        return clip

    def _ran(self, clip, seconds):
        self._show_clip(clip, seconds)
        row = self.synthesis.summary()
        return (
            f"{row['strategy']}: {1000 * row['seconds_per_frame']:.2f} ms of search per frame, "
            f"relative error {row['relative_error']:.4f}, absolute error "
            f"{row['absolute_error']:.4f} — done in {seconds:.1f} s ({len(clip)} frames)"
        )

    def _compared(self, clip, seconds):
        self._show_clip(clip, seconds)
        text = f"compared {len(self.rows)} searches in {seconds:.1f} s"
        ours = {r["strategy"]: r for r in self.table_rows()}
        adaptive = ours.get("adaptive")
        if adaptive is not None and "speedup" in adaptive:
            text += (
                f"; adaptive: {adaptive['speedup']:.1f}× faster than exhaustive, "
                f"relative error {adaptive['relative_error']:.4f}"
            )
        return text

    @staticmethod
    def _settings_key(params, size, n_frames):
        """What makes two rows comparable: everything but the search itself."""
        common = params.to_dict()
        for name in ("strategy", "m0", "interval"):
            common.pop(name)
        return (size, n_frames, tuple(sorted(common.items())))

    # ------------------------------------------------------------------ the pictures
    def _show(self, result):
        """Set the players to the dye renders and the vorticity of a Synthesis.

        Returns the dye clip (the run's result); the vorticity goes to
        :attr:`vorticity`.
        """
        dyes = render(result, fps=12)
        prep = result.prepared
        label = result.summary()["strategy"]
        meta = {
            "method": "turbulence",
            "params": result.params.to_dict(),
            "panels": [*PANELS[:2], f"synthesised ({label})"],
            "timings": dict(result.timings),
        }
        dye = side_by_side([dyes[k] for k in ("target", "source", "synthesised")], meta)
        # One colour scale for the three maps: the synthesised flow's.
        top = float(np.percentile(np.abs(vorticity(result.velocity)), 99)) or 1.0
        maps = [vorticity_clip(v, fps=12, vmax=top) for v in (prep.U_t, prep.U_s, result.velocity)]
        self.synthesis = result
        self.vorticity.clip = side_by_side(maps, {**meta, "what": "vorticity"})
        for header in self._headers:
            header.value = _header(label, self.player.display_width)
        return dye

    def save_flow(self, path):
        """Write the last synthesised flow (:meth:`Synthesis.to_flow`) as an ``.npz``."""
        if self.synthesis is None:
            raise ValueError("there is no synthesised flow yet: press Run first")
        return self.synthesis.to_flow().save(path)

    def close(self):
        """Stop the workers, close the widgets and drop the flows held in memory."""
        self._flows_cache, self._prep_cache, self._preview_pair = {}, {}, None
        if hasattr(self, "vorticity"):  # not if the arguments were refused
            self.vorticity.close()
        super().close()

    # ------------------------------------------------------------------ the table
    def _add_rows(self, rows, key):
        if key != self._rows_key:
            restart = bool(self.rows)
            self.rows = {}
            self._rows_key = key
            self._table_note = "The settings changed: the table restarted." if restart else ""
        else:
            self._table_note = ""
        self.rows.update(rows)
        self._latest = next(iter(rows)) if len(rows) == 1 else None
        self._render_table()

    def table_rows(self):
        """Our rows as :func:`fluidnb.turbulence.table1` gives them (the paper's beside)."""
        order = {label: i for i, label in enumerate(ROW_ORDER)}
        labels = sorted(self.rows, key=lambda s: (order.get(s, len(order)), s))
        return table1({label: self.rows[label] for label in labels})

    def _render_table(self):
        ours = {r["strategy"]: r for r in self.table_rows()}
        labels = [*ROW_ORDER, *(label for label in ours if label not in ROW_ORDER)]
        exhaustive = PAPER_TABLE1["exhaustive"][2]
        body = []
        for label in labels:
            r = ours.get(label, {})
            rel, ab, sec = PAPER_TABLE1.get(label, (None, None, None))
            cells = [
                _cell(r.get("seconds_per_frame"), ".2f", scale=1000),
                _cell(r.get("speedup"), ".1f", suffix="×"),
                _cell(r.get("relative_error"), ".4f"),
                _cell(r.get("absolute_error"), ".4f"),
                _cell(r.get("evaluations_per_patch"), ".0f"),
                _cell(sec, ".1f", scale=1000, paper=True),
                _cell(None if sec is None else exhaustive / sec, ".1f", suffix="×", paper=True),
                _cell(rel, ".4f", paper=True),
                _cell(ab, ".4f", paper=True),
            ]
            cls = " class='fluidnb-latest'" if label == self._latest else ""
            body.append(
                f"<tr data-strategy='{html.escape(label)}'{cls}>"
                f"<th>{html.escape(label)}</th>{''.join(cells)}</tr>"
            )
        caption = "Press Run (one search) or Compare all strategies (every row)."
        if self._rows_key is not None:
            size, n_frames, common = self._rows_key
            grid = SIZES[size][2].split("— ")[-1] if size in SIZES else "your flows"
            settings = ", ".join(
                f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in common
            )
            caption = f"ours: {grid}, {n_frames} frames, {settings}"
        note = f" <b>{html.escape(self._table_note)}</b>" if self._table_note else ""
        self.table.value = (
            f"{_TABLE_STYLE}<table class='fluidnb-t1'><thead>"
            "<tr><th rowspan='2'>search</th><th colspan='5'>ours</th>"
            "<th colspan='4' class='paper'>paper (Core i7-2600K)</th></tr><tr>"
            "<th title='mean local-search time per frame'>ms/frame</th>"
            "<th title='exhaustive time / this time'>speedup</th>"
            "<th title='mean over patches of (E - E*) / E*, E* the exhaustive minimum'>"
            "rel. err.</th>"
            "<th title='mean over patches of E - E*, E* the exhaustive minimum'>abs. err.</th>"
            "<th title='patch energies computed per local search'>evals</th>"
            "<th class='paper'>ms/frame</th><th class='paper'>speedup</th>"
            "<th class='paper'>rel. err.</th><th class='paper'>abs. err.</th>"
            f"</tr></thead><tbody>{''.join(body)}</tbody></table>"
            f"<div class='fluidnb-t1-caption'>{html.escape(caption)}{note}</div>"
        )


def _header(label, width):
    """Column titles over a player of ``width`` pixels showing the three flows."""
    names = [*PANELS[:2], "synthesised" if label is None else f"synthesised ({label})"]
    cells = "".join(
        f"<div style='flex:1;text-align:center;line-height:1.2'>{html.escape(n)}</div>"
        for n in names
    )
    return f"<div style='display:flex;width:{int(width)}px;font-size:12px'>{cells}</div>"


def _cell(value, fmt, *, scale=1, suffix="", paper=False):
    cls = " class='paper'" if paper else ""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return f"<td{cls}>—</td>"
    return f"<td{cls}>{format(value * scale, fmt)}{suffix}</td>"


_TABLE_STYLE = """<style>
.fluidnb-t1 { border-collapse: collapse; font-size: 12px; font-variant-numeric: tabular-nums; }
.fluidnb-t1 th, .fluidnb-t1 td { padding: 2px 7px; text-align: right;
  border-bottom: 1px solid var(--jp-border-color2, #ddd); }
.fluidnb-t1 thead th { text-align: center; font-weight: 600; }
.fluidnb-t1 tbody th { text-align: left; font-weight: 600; white-space: nowrap; }
.fluidnb-t1 .paper { opacity: 0.75; }
.fluidnb-t1 td.paper { border-left: 0; }
.fluidnb-t1 tr.fluidnb-latest { background: var(--jp-brand-color3, #bbdefb); }
.fluidnb-t1 tr.fluidnb-latest td, .fluidnb-t1 tr.fluidnb-latest th {
  color: var(--jp-ui-font-color0, #000); }
.fluidnb-t1-caption { font-size: 11px; opacity: 0.8; margin-top: 4px; max-width: 640px; }
</style>"""
