"""Attention explorer: cross-attention curves per word and the self-attention heatmap, linked to the viewer.

Both figures are built once per session and updated in place (new data on the same
``ColumnDataSource``), so switching layer, head or step costs a slice of the recorded arrays and
one small data message. Clicking either figure picks a frame (the viewer jumps to that pose and the
heatmap row is outlined); clicking a word (button or curve) highlights it.
"""
from __future__ import annotations

import html
import time

import numpy as np
import panel as pn
import param
from bokeh.events import Tap
from bokeh.models import (BoxAnnotation, ColorBar, ColumnDataSource, HoverTool, LinearColorMapper, PrintfTickFormatter,
                          Range1d, Span)
from bokeh.palettes import Category10_10, Viridis256
from bokeh.plotting import figure

from app.components.bokeh_writes import sends_bokeh
from app.components.how_to_read import reading_caption
from app.components.jobbar import WRAP_BUTTONS_CSS
from app.session.items import MAX_ITEMS_WITH_ATTENTION
from app.session.state import StudioState

MEAN = -1
WIDTH = 560
LEGEND_COLUMNS = 6  # words per row of the word curves' legend


def _label_options(n: int, what: str, mean_label: str) -> dict[str, int]:
    return {mean_label: MEAN, **{f"{what} {i}": i for i in range(n)}}


def word_labels(words) -> list[str]:
    """The words as the word buttons and the curves' legend name them: a repeated word with its position."""
    words = list(words)
    return [w if words.count(w) == 1 else f"{w} ({i})" for i, w in enumerate(words)]


def curve_range(cross: np.ndarray, *, snap: float = 0.05) -> tuple[float, float]:
    """The word curves' y range: from the lowest to the highest value, both ends snapped outwards to ``snap``."""
    finite = cross[np.isfinite(cross)]
    if not finite.size:
        return 0.0, 1.0
    lo = max(0.0, np.floor(float(finite.min()) / snap - 1e-6) * snap)
    hi = min(1.0, np.ceil(float(finite.max()) / snap + 1e-6) * snap)
    return round(lo, 4), round(max(hi, lo + snap), 4)


def _no_heat() -> dict:
    """The heatmap's data before any map (one blank cell)."""
    empty = np.zeros((1, 1), np.float32)
    return dict(image=[empty], shown=[empty], dw=[1], dh=[1])


class AttentionExplorer(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        s = self.state
        self.timings: list[float] = []  # seconds per map update (layer/head/step switch)
        self._syncing = False
        self.info = pn.pane.Markdown("Generate a motion to see its attention.", css_classes=["attention-info"],
                                     margin=(0, 10))
        self.rerecord = pn.widgets.Button(label="Re-record its attention", visible=False, width=200,
                                          css_classes=["rerecord-button"], margin=(0, 10))
        self.rerecord.on_click(lambda _: self.state.rerecord())
        self.words = pn.widgets.RadioButtonGroup(label="Word", options={}, color="primary", variant="outline",
                                                 css_classes=["word-buttons"], margin=(4, 10), sizing_mode="stretch_width",
                                                 stylesheets=[WRAP_BUTTONS_CSS])
        self.layer = pn.widgets.Select(label="Layer", options={"mean of layers": MEAN}, width=130,
                                       css_classes=["layer-select"])
        self.head = pn.widgets.Select(label="Head", options={"mean of heads": MEAN}, width=130,
                                      css_classes=["head-select"])
        self.step = pn.widgets.Select(label="Step", options={"mean of steps": MEAN}, width=170,
                                      css_classes=["step-select"])
        for widget, name in ((self.layer, "layer"), (self.head, "head"), (self.step, "att_step")):
            widget.param.watch(lambda e, name=name: self._on_select(name, e.new), "value")
        self.words.param.watch(self._on_word_button, "value")

        self._build_curves()
        self._build_heatmap()
        self.curves_pane = pn.pane.Bokeh(self.curves, margin=(0, 10))
        self.heatmap_pane = pn.pane.Bokeh(self.heatmap, margin=(0, 10))
        self.row_pane = pn.pane.Bokeh(self.row_fig, margin=(0, 10))
        self.selects = pn.Row(self.layer, self.head, self.step)
        # what is shown only for a motion with attention: hidden (never another motion's axes or cursor) otherwise
        self.plots = pn.Column(self.words, self.curves_pane, reading_caption("word_curves", width=WIDTH), self.selects,
                               self.heatmap_pane, reading_caption("self_attention", width=WIDTH - 60), self.row_pane,
                               reading_caption("attention_row", width=WIDTH - 60), margin=0,
                               css_classes=["attention-plots"])

        # the maps are rebuilt after the change that caused them has reached the page (served: the next tick), so
        # a new motion's scene is not held back behind them; several changes in one tick rebuild once
        self._pending: set[str] = set()
        s.param.watch(lambda *_: self._later("current"), "current")
        s.param.watch(lambda *_: self._later("maps"), ["layer", "head", "att_step"])
        s.param.watch(lambda *_: self._later("word"), "word")
        s.param.watch(self._on_frame, ["frame", "playing"])
        s.param.watch(self._on_peaks, "count_result")
        self._on_current()

    # ------------------------------------------------------------------ figures
    def _build_curves(self) -> None:
        self.curve_src = ColumnDataSource(dict(xs=[], ys=[], color=[], width=[], alpha=[], word=[], label=[]))
        fig = figure(height=260, width=WIDTH, tools="tap,xwheel_zoom,xpan,reset", toolbar_location="right",
                     x_axis_label="frame", y_axis_label="attention on word", title="Cross-attention per word",
                     css_classes=["cross-curves"])
        # the legend names each curve's word in its colour (below the plot, in rows: a long prompt adds rows)
        lines = fig.multi_line("xs", "ys", source=self.curve_src, line_color="color", line_width="width",
                               line_alpha="alpha", legend_field="label")
        legend = fig.legend[0]
        legend.update(orientation="horizontal", ncols=LEGEND_COLUMNS, label_text_font_size="10px", glyph_width=16,
                      label_standoff=3, spacing=2, padding=2, margin=4, border_line_alpha=0, background_fill_alpha=0,
                      css_classes=["word-legend"])
        fig.add_layout(legend, "below")
        lines.selection_glyph = None
        lines.nonselection_glyph = None
        fig.add_tools(HoverTool(renderers=[lines], tooltips=[("word", "@word")], line_policy="nearest"))
        self.curve_cursor = Span(location=0, dimension="height", line_color="#d62728", line_width=2,
                                 line_dash="dashed", level="overlay")
        fig.add_layout(self.curve_cursor)
        self.state.follow_playhead(self.curve_cursor)
        self.curve_src.selected.on_change("indices", self._on_curve_selected)
        fig.on_event(Tap, self._on_curve_tap)
        fig.x_range = Range1d(0, 1)
        # the range spans the curves, its ends snapped to 0.05 (see _write_curves): the curves fill the plot, so a
        # word's rise and fall over the frames shows (from 0, a jump's few hundredths were a flat line), and
        # switching between layers or steps of similar scale redraws the lines without re-ranging the axis
        fig.y_range = Range1d(0, 1.0)
        fig.yaxis.formatter = PrintfTickFormatter(format="%.2f")
        self.curves = fig

    def _build_heatmap(self) -> None:
        # "image": the attention values (hover, the row plot); "shown": the same divided by the map's 99.5th
        # percentile, drawn through a fixed 0..1 colour mapper (re-ranging a mapper per map redraws the colour bar
        # and costs a layer switch about a third of its time in the browser)
        self.heat_src = ColumnDataSource(_no_heat())
        self.mapper = LinearColorMapper(palette=Viridis256, low=0.0, high=1.0)
        fig = figure(height=380, width=WIDTH - 60, tools="tap,wheel_zoom,pan,reset", toolbar_location="right",
                     x_axis_label="key frame", y_axis_label="query frame (row)", title="Self-attention",
                     x_range=Range1d(0, 1), y_range=Range1d(1, 0), match_aspect=False, css_classes=["self-heatmap"])
        img = fig.image(image="shown", x=0, y=0, dw="dw", dh="dh", source=self.heat_src, color_mapper=self.mapper)
        fig.add_tools(HoverTool(renderers=[img], tooltips=[("query frame", "$y{0}"), ("key frame", "$x{0}"),
                                                           ("attention", "@image{0.0000}")]))
        fig.add_layout(ColorBar(color_mapper=self.mapper, width=10, title="÷ 99.5th pct", title_standoff=4), "right")
        self.row_box = BoxAnnotation(bottom=0, top=1, fill_color="#ff2d2d", fill_alpha=0.25, line_color="#ff2d2d",
                                     line_width=2, line_alpha=1.0)
        fig.add_layout(self.row_box)
        # the counting peaks (Edit tab's readout) of the shown motion, in frame units
        self.peak_src = ColumnDataSource(dict(x=[], y=[]))
        peaks = fig.scatter("x", "y", source=self.peak_src, size=6, marker="circle", fill_color="#ff2d2d",
                            fill_alpha=0.9, line_color="white", line_width=1.2, legend_label="counting peaks")
        peaks.selection_glyph = peaks.nonselection_glyph = None  # a click picks a frame; no peak fades
        fig.legend.location = "bottom_left"
        fig.legend.label_text_font_size = "10px"
        fig.legend.background_fill_alpha = 0.6
        fig.legend.padding = 2
        fig.on_event(Tap, self._on_heat_tap)
        self.heatmap = fig

        self.row_src = ColumnDataSource(dict(x=[], y=[]))
        row = figure(height=130, width=WIDTH - 60, tools="", toolbar_location=None, x_range=fig.x_range,
                     x_axis_label="key frame", title="Row of the picked frame", css_classes=["row-profile"])
        row.line("x", "y", source=self.row_src, line_width=2, color="#d62728")
        row.yaxis.ticker.desired_num_ticks = 3
        row.yaxis.formatter = PrintfTickFormatter(format="%.3f")
        self.row_fig = row

    # ------------------------------------------------------------------ state -> views
    def _later(self, what: str) -> None:
        first = not self._pending
        self._pending.add(what)
        if first:
            self.state.post(self._flush)  # no server: at once

    def _flush(self) -> None:
        pending, self._pending = self._pending, set()
        if "current" in pending:
            self._on_current()  # maps, word and frame included
            return
        if "maps" in pending:
            self._on_map_selection()
        if "word" in pending:
            self._on_word()

    @sends_bokeh
    def _on_current(self, *_):
        record = self.state.attention
        item = self.state.item
        self._syncing = True
        try:
            composed = bool(item is not None and item.settings is not None and item.settings.clauses())
            self.rerecord.visible = bool(item is not None and (item.evicted or item.from_library)
                                         and item.settings is not None)
            if record is None:
                self.words.options = {}
                if item is None:
                    self.info.object = "Generate a motion to see its attention."
                elif item.from_library and item.source != "imported":
                    self.info.object = ("This motion was kept in the motion library, which stores motions and their "
                                        "recipes but not attention maps. "
                                        + ("Re-record its attention: its recipe (the same settings and seed) gives "
                                           "the same motion." if item.settings is not None else
                                           "Only a motion generated in the Generate box can be re-recorded; run "
                                           "its job again to see its attention."))
                elif item.evicted:
                    self.info.object = (f"This motion's attention was dropped to keep memory bounded: only the "
                                        f"{MAX_ITEMS_WITH_ATTENTION} latest generated motions keep theirs. "
                                        + ("Re-record it: the same settings and seed give the same motion."
                                           if item.settings is not None else "Run its job again to see it."))
                elif item.settings is not None:
                    self.info.object = "This motion was generated with attention recording off (Recorded steps 0)."
                elif item.source == "generated":
                    self.info.object = "This motion has no recorded attention: its job does not record it."
                else:
                    self.info.object = "This motion has no recorded attention: it was imported."
                if item is not None:  # said as what it is: the plots are not available, and why
                    self.info.object = (f"**Attention plots not available** for *{html.escape(item.name)}* "
                                        f"({item.n_frames} frames). {self.info.object}")
                self._clear_plots(item.n_frames if item is not None else 0)
                return
            self.words.options = {label: i for i, label in enumerate(word_labels(record.words))}
            self.layer.options = _label_options(record.n_layers, "layer", "mean of layers")
            self.head.options = _label_options(record.n_heads, "head", "mean of heads")
            steps = {f"step {s + 1}/{record.num_steps}" + (f" (t={t})" if t >= 0 else ""): s
                     for s, t in zip(record.steps, record.timesteps)}
            self.step.options = {**steps, "mean of steps": MEAN}
            self._show_plots(True)
            n = record.n_frames
            self.curves.x_range.start, self.curves.x_range.end = 0, n - 1
            self.heatmap.x_range.start, self.heatmap.x_range.end = 0, n
            self.heatmap.y_range.start, self.heatmap.y_range.end = n, 0
            self._sync_widgets()
            self.info.object = (f"**{self.state.item.prompt}** · {record.n_frames} frames · "
                                f"{record.n_layers} layers × {record.n_heads} heads · {len(record.steps)} recorded "
                                f"steps of {record.num_steps} · {record.nbytes / 1e6:.1f} MB")
            if composed:  # one record laid over the clauses: say how to read it
                self.info.object += (" · generated clause by clause (" + " → ".join(
                    f"'{html.escape(c)}'" for c in item.settings.clauses()) + "): each clause's words attend over its "
                    "own frames, and a clause's frames over each other (the blocks); recorded in DoubleTake's first "
                    "take, before the transitions are redrawn")
        finally:
            self._syncing = False
        self._update_maps()
        self._on_word()
        self._on_frame()

    def _show_plots(self, visible: bool) -> None:
        if self.plots.visible != visible:
            self.plots.visible = visible

    @sends_bokeh
    def _clear_plots(self, n_frames: int) -> None:
        """No attention for the shown motion: no data, the axes and cursors on its own frames, the plots hidden (the
        info line says why); nothing of the motion shown before stays."""
        n = max(int(n_frames), 1)
        with pn.io.hold():
            self._cross = None
            self.curve_src.data = dict(xs=[], ys=[], color=[], width=[], alpha=[], word=[], label=[])
            self.heat_src.data = _no_heat()
            self.row_src.data = dict(x=[], y=[])
            self.peak_src.data = dict(x=[], y=[])
            self.curves.x_range.update(start=0, end=max(n - 1, 1))
            self.curves.y_range.update(start=0.0, end=1.0)
            self.heatmap.x_range.update(start=0, end=n)
            self.heatmap.y_range.update(start=n, end=0)
            frame = min(self.state.frame, n - 1)
            self.curve_cursor.location = frame
            self.row_box.bottom, self.row_box.top = frame, frame + 1
            self.row_fig.title.text = "Row of the picked frame"
            self._show_plots(False)

    @sends_bokeh
    def _on_peaks(self, *_):
        readout = self.state.count_result
        if readout is None or readout.item != self.state.current or self.state.attention is None:
            self.peak_src.data = dict(x=[], y=[])
        else:
            self.peak_src.data = dict(x=[c + 0.5 for _, c in readout.peaks], y=[r + 0.5 for r, _ in readout.peaks])

    def _sync_widgets(self):
        s = self.state
        was, self._syncing = self._syncing, True
        try:
            self.layer.value = MEAN if s.layer is None else s.layer
            self.head.value = MEAN if s.head is None else s.head
            self.step.value = MEAN if s.att_step is None else s.att_step
            if s.word is not None and s.word in self.words.options.values():
                self.words.value = s.word
        finally:
            self._syncing = was

    def _on_map_selection(self, *_):
        self._sync_widgets()
        with pn.io.hold():
            self._update_maps()
            self._on_frame()

    @sends_bokeh
    def _update_maps(self) -> None:
        record = self.state.attention
        if record is None:
            return
        t0 = time.perf_counter()
        sel = self.state.selection()
        heat = record.self_map(**sel)
        cross = record.cross_map(**sel)
        n = heat.shape[0]
        with pn.io.hold():  # one message to the page, no relayout (titles and text stay put)
            scale = float(np.quantile(heat, 0.995)) or 1.0
            self.heat_src.data = dict(image=[heat], shown=[(heat / scale).astype(np.float32)], dw=[n], dh=[n])
            self._cross = cross
            self._write_curves()
        self.timings.append(time.perf_counter() - t0)
        del self.timings[:-50]

    @sends_bokeh
    def _write_curves(self) -> None:
        record = self.state.attention
        cross = getattr(self, "_cross", None)
        if record is None or cross is None or cross.shape[1] != len(record.words):
            return  # the maps of the previous motion (a word change arrived before the motion change)
        n, w = cross.shape
        chosen = self.state.word
        x = np.arange(n)
        lo, hi = curve_range(cross)
        if (self.curves.y_range.start, self.curves.y_range.end) != (lo, hi):
            self.curves.y_range.update(start=lo, end=hi)
        self.curve_src.data = dict(
            xs=[x] * w,
            ys=[cross[:, i] for i in range(w)],
            color=[Category10_10[i % 10] for i in range(w)],
            width=[4.5 if i == chosen else 1.8 for i in range(w)],
            alpha=[1.0 if chosen is None or i == chosen else 0.35 for i in range(w)],
            word=list(record.words),
            label=word_labels(record.words),  # as the word buttons name them ("a (3)" for a repeated word)
        )

    def _on_word(self, *_):
        self._sync_widgets()
        self._write_curves()

    @sends_bokeh
    def _on_frame(self, *_):
        record = self.state.attention
        frame = self.state.frame
        self.curve_cursor.location = frame
        if record is None or self.state.playing:
            return  # while playing only the cursor moves; the row follows when playback stops
        row = min(frame, record.n_frames - 1)
        self.row_box.bottom, self.row_box.top = row, row + 1
        heat = self.heat_src.data["image"][0]
        if heat.shape[0] == record.n_frames:
            self.row_src.data = dict(x=np.arange(heat.shape[1]) + 0.5, y=heat[row])
            self.row_fig.title.text = f"Row of frame {row}: where it attends"

    # ------------------------------------------------------------------ views -> state
    def _on_select(self, name: str, value) -> None:
        if self._syncing or value is None:
            return
        setattr(self.state, name, None if value == MEAN else int(value))

    def _on_word_button(self, event):
        if not self._syncing and event.new is not None:
            self.state.word = int(event.new)

    def _on_curve_selected(self, attr, old, new):
        if new:
            self.state.word = int(new[0])
            self.curve_src.selected.indices = []

    def _on_curve_tap(self, event):
        if event.x is not None:
            self.state.pick_frame(int(round(event.x)))

    def _on_heat_tap(self, event):
        if event.y is not None:
            self.state.pick_frame(int(np.floor(event.y)))

    def pick_cell(self, query_frame: int, key_frame: int = 0) -> None:
        """What a click on heatmap cell (row ``query_frame``) does (used by tests)."""
        self._on_heat_tap(Tap(self.heatmap, x=key_frame + 0.5, y=query_frame + 0.5))

    def __panel__(self):
        return pn.Column(self.info, self.rerecord, self.plots, css_classes=["attention-explorer"])
