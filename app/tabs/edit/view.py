"""The Edit tab (MotionCLR): pick an edit, click a word of the prompt, set weights and windows, run it off the UI
thread, see before / after side by side in the viewer; the counting readout with its peaks.

All settings live on the tab's ``settings`` (an ``app.tabs.edit.settings.EditSettings``, the session's, handed over by
the page); the widgets only mirror it. What each kind reads and shows is the engine's registry entry (``entry``). The
edit itself is an ``EditJob`` launched on the session (checks, then the shared worker with progress and cancel).
"""
from __future__ import annotations

import html

import numpy as np
import panel as pn
import param
from bokeh.events import SelectionGeometry
from bokeh.models import BoxSelectTool, ColumnDataSource, HoverTool, LinearColorMapper, Range1d, Tooltip
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

from app.components.bokeh_writes import sends_bokeh
from app.components.guard import SyncGuard
from app.components.how_to_read import reading_caption
from app.components.jobbar import WRAP_BUTTONS_CSS, JobBar, text_from_param
from app.session.state import StudioState
from app.tabs.edit.job import alignment, count_current, run_edit, swap_example, word_choice
from app.tabs.edit.settings import KIND_HELP, PLAIN_INPUTS, PROMPT_SOURCE, EditSettings
from engine.analysis.counting import COUNTING_METHODS
from engine.methods.edit_options import DEFAULT_WEIGHTS, WEIGHT_RANGES, acts_in_layers, default_mode, option_spec
from engine.methods.spans import check_spans, parse_spans, spans_text



class EditTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=EditSettings, doc="the session's Edit settings")

    def __init__(self, **params):
        super().__init__(**params)
        s, e = self.state, self.settings
        self._syncing = SyncGuard()
        self.kind = pn.widgets.RadioButtonGroup.from_param(e.param.kind, color="primary", variant="outline",
                                                           css_classes=["edit-kind"], sizing_mode="stretch_width")
        self.help = pn.pane.Markdown("", css_classes=["edit-help"], margin=(0, 10),
                                     styles={"font-size": "12px", "color": "#444"})
        self.words_label = pn.pane.Markdown("**Word** (click it in the prompt)", margin=(0, 10))
        self.words = pn.widgets.RadioButtonGroup(label="Word", options={}, value=None, color="primary",
                                                 variant="outline", css_classes=["edit-words"], margin=(2, 10),
                                                 sizing_mode="stretch_width", stylesheets=[WRAP_BUTTONS_CSS])
        self.mode = pn.widgets.RadioButtonGroup.from_param(e.param.mode, color="primary", variant="outline",
                                                           css_classes=["edit-mode"], width=360)
        for widget in (self.kind, self.mode):  # their tooltip below them: on the right it ran off the screen; its
            if isinstance(widget.description, str):  # text wrapped, not one line as wide as it is long
                widget.description = Tooltip(content=widget.description, position="bottom",
                                             stylesheets=[":host { max-width: 460px; white-space: normal; }"])
        lo, hi = WEIGHT_RANGES[e.mode]  # the mode's own range (the settings' bounds cover both modes)
        self.weight = pn.widgets.FloatSlider.from_param(e.param.weight, start=lo, end=hi, css_classes=["edit-weight"],
                                                        sizing_mode="stretch_width")
        self.frames = pn.widgets.IntRangeSlider(label="Frames", start=0, end=80, value=(0, 80), step=1,
                                                css_classes=["edit-frames"], sizing_mode="stretch_width")
        self.steps = pn.widgets.RangeSlider(label="Steps (fraction of the run)", start=0.0, end=1.0, step=0.05,
                                            value=(0.0, 1.0), css_classes=["edit-steps"], sizing_mode="stretch_width")
        self.layers = pn.widgets.MultiChoice(label="Layers (empty = the edit's default)", options={}, value=[],
                                             css_classes=["edit-layers"], sizing_mode="stretch_width")
        # the plain inputs (fraction, count, chunk_frames, ...): the widget pn.Param makes of each declared option,
        # its declared help under it (the widget shows the range); shown when the kind reads it
        self.plain = {name: pn.Param.widget_type(e.param[name]).from_param(
                          e.param[name], css_classes=[f"edit-{name.replace('_', '-')}"], sizing_mode="stretch_width")
                      for name in PLAIN_INPUTS}
        self.plain_help = {name: pn.pane.Markdown(option_spec(name).help, margin=(0, 10),
                                                  styles={"font-size": "11px", "color": "#555"})
                           for name in PLAIN_INPUTS}
        self._build_spans()
        self.edited = text_from_param(e.param.edited, placeholder="a person kicks twice", css_classes=["edit-edited"],
                                      sizing_mode="stretch_width")
        self.alignment = pn.pane.HTML("", css_classes=["edit-alignment"], margin=(0, 10), stylesheets=[_CSS])
        self.source = pn.widgets.Select(label="Content / example", options=[PROMPT_SOURCE], value=e.source,
                                        css_classes=["edit-source"], width=260)
        self.style_source = pn.widgets.Select(label="Style", options=[PROMPT_SOURCE], value=e.style_source,
                                              css_classes=["edit-style-source"], width=260)
        self.style_prompt = text_from_param(e.param.style_prompt, css_classes=["edit-style-prompt"], width=260)
        self.bar = JobBar(state=s, jobs=["edit", "counting"], label="Run edit", prefix="edit",
                          on_run=lambda: run_edit(self.state, self.settings), blocked=self._misaligned)
        b = self.bar
        self.run, self.cancel, self.progress, self.status = b.run, b.cancel, b.progress, b.status
        self.result = pn.pane.Markdown("", css_classes=["edit-result"], margin=(0, 10))
        self.readout = pn.pane.HTML("", css_classes=["count-readout"], margin=(0, 10), stylesheets=[_CSS])
        self.count_button = pn.widgets.Button(label="Count this motion", css_classes=["count-button"], width=160)
        self.count_method = pn.widgets.Select.from_param(s.param.count_method, css_classes=["count-method"],
                                                         width=230)
        self._build_count_map()
        self.count_pane = pn.pane.Bokeh(self.count_map, margin=(0, 10))
        # the map with its caption, hidden while there is no count to draw (a Bokeh pane's own ``visible`` is tied to
        # its figure's and does not come back once set False)
        self.count_map_box = pn.Column(self.count_pane, reading_caption("counting", width=320), margin=0)

        self.words.param.watch(self._on_word_button, "value")
        self.frames.param.watch(lambda ev: self._set("frames", tuple(ev.new)), "value")
        self.steps.param.watch(lambda ev: self._set("step_window", tuple(round(v, 4) for v in ev.new)), "value")
        self.layers.param.watch(lambda ev: self._set("layers", sorted(int(v) for v in ev.new)), "value")
        self.source.param.watch(lambda ev: self._set("source", ev.new), "value")
        self.style_source.param.watch(lambda ev: self._set("style_source", ev.new), "value")
        self.count_button.on_click(lambda _: count_current(self.state))

        self.spans_text.param.watch(lambda ev: self._on_spans_typed(ev.new), "value")
        self.clear_spans.on_click(lambda _: self.set_spans([]))
        e.param.watch(self._on_spans, "spans")
        e.param.watch(self._post_span_curve, ["word", "occurrence"])
        s.param.watch(self._post_span_curve, "current")
        e.param.watch(self._on_kind, "kind")
        e.param.watch(self._on_mode, "mode")
        e.param.watch(self._on_alignment, ["edited", "swapped"])
        e.param.watch(self._on_last_edit, "last_edit")
        s.param.watch(self._on_prompt, ["prompt_words", "reading"])
        s.param.watch(self._on_prompt_text, "prompt")
        s.param.watch(self._on_seconds, "seconds")
        s.param.watch(self._on_items, "items")
        s.param.watch(self._on_running, "running")
        s.param.watch(self._on_count, ["current", "count_result"])
        self._describe_model()
        self._on_prompt()
        self._on_items()
        self._on_kind()
        self._on_mode()
        self._on_alignment()
        self._on_running()
        self._on_count()
        self._on_spans()
        self._write_span_curve()

    # ------------------------------------------------------------------ grounding spans
    def _build_spans(self) -> None:
        """Grounding spans: the picked word's attention curve (of the shown motion, when recorded) on which a drag
        across frames adds a span; the spans as text (editable), listed, and a button clearing them."""
        self.span_curve_src = ColumnDataSource(dict(x=[], y=[]))
        self.span_src = ColumnDataSource(dict(x0=[], x1=[]))
        select = BoxSelectTool(dimensions="width", description="Drag across frames to add a grounding span")
        fig = figure(height=170, width=520, tools=[select], toolbar_location="right", x_range=Range1d(0, 80),
                     y_range=Range1d(0, 1), x_axis_label="frame", y_axis_label="attention on the word",
                     title="Drag across the frames to add a span", css_classes=["span-curve"])
        fig.toolbar.active_drag = select
        fig.vstrip(x0="x0", x1="x1", source=self.span_src, fill_color="#2ca02c", fill_alpha=0.25,
                   line_color="#2ca02c", line_alpha=0.8)
        line = fig.line("x", "y", source=self.span_curve_src, line_width=2, color="#1f77b4")
        line.selection_glyph = line.nonselection_glyph = None  # a drag adds a span; it selects nothing
        fig.title.text_font_size = "11px"
        fig.on_event(SelectionGeometry, self._on_span_drawn)
        self.span_fig = fig
        self.span_pane = pn.pane.Bokeh(fig, margin=(0, 10))
        self.spans_text = pn.widgets.TextInput(label="Grounding spans (START:END, comma-separated; empty = the "
                                                    "whole motion)", placeholder="10:30,50:70,90:110,130:150",
                                               css_classes=["edit-spans"], sizing_mode="stretch_width")
        self.clear_spans = pn.widgets.Button(label="Clear spans", css_classes=["edit-clear-spans"], width=120,
                                             align="end")
        self.spans_list = pn.pane.HTML("", css_classes=["edit-span-list"], margin=(0, 10), stylesheets=[_CSS])
        self.spans_box = pn.Column(self.span_pane, pn.Row(self.spans_text, self.clear_spans), self.spans_list,
                                   css_classes=["edit-spans-box"], sizing_mode="stretch_width")

    def set_spans(self, spans) -> bool:
        """Replace the grounding spans (checked: whole frames inside the motion, none overlapping); False and an
        error notification if refused."""
        try:
            checked = check_spans(list(spans), frames=self._frames_total())
        except ValueError as exc:
            self.state.error(f"grounding spans: {exc}")
            self._on_spans()  # the text shows the spans kept
            return False
        self.settings.spans = [tuple(sp) for sp in checked]
        return True

    def add_span(self, start: float, end: float) -> bool:
        """What a drag across the curve does: the span [start, end) (rounded outwards to whole frames, clipped to
        the motion) joins the grounding spans; one overlapping a span already there is refused with a message."""
        n = self._frames_total()
        lo, hi = sorted((float(start), float(end)))
        lo, hi = max(0, int(np.floor(lo))), min(n, int(np.ceil(hi)))
        if hi <= lo:
            self.state.error(f"grounding spans: the span {start:.0f}–{end:.0f} is outside the motion (0–{n})")
            return False
        return self.set_spans([*self.settings.spans, (lo, hi)])

    def _on_span_drawn(self, event) -> None:
        geometry = getattr(event, "geometry", None) or {}
        if not getattr(event, "final", True) or geometry.get("type") != "rect":
            return
        self.add_span(geometry["x0"], geometry["x1"])

    def _on_spans_typed(self, text: str) -> None:
        if self._syncing:
            return
        text = (text or "").strip()
        if not text:
            self.set_spans([])
            return
        try:
            spans = parse_spans(text)
        except ValueError as exc:
            self.state.error(f"grounding spans: {exc}")
            return
        self.set_spans(spans)

    @sends_bokeh
    def _on_spans(self, *_):
        spans = [tuple(sp) for sp in self.settings.spans]
        self.span_src.data = dict(x0=[a for a, _ in spans], x1=[b for _, b in spans])
        self._sync(lambda: setattr(self.spans_text, "value", spans_text(spans)))
        n = self._frames_total()
        if not spans:
            self.spans_list.object = (f'<div class="span-none">No span: the word is grounded to the whole motion '
                                      f"(0–{n}). Drag across the curve to add spans.</div>")
        else:
            items = "".join(f"<li>{a}–{b} ({(b - a) / 20:.2f} s)</li>" for a, b in spans)
            self.spans_list.object = (f'<div class="span-count">{len(spans)} span{"s" if len(spans) > 1 else ""} in '
                                      f"{n} frames:</div><ol>{items}</ol>")

    def _span_curve(self) -> tuple[np.ndarray | None, str]:
        """The picked word's cross-attention per frame in the shown motion (mean of the recorded steps, layers and
        heads) and the figure's title; None when the shown motion has no recorded attention on that word."""
        e, item = self.settings, self.state.item
        if not e.word:
            return None, "Pick a word, then drag across the frames to add a span"
        if item is None or item.attention is None:
            return None, f"'{e.word}': no recorded attention to show. Drag across the frames to add a span"
        hits = [i for i, w in enumerate(item.attention.words) if w == e.word]
        if len(hits) <= e.occurrence:
            return None, (f"'{e.word}' is not in the shown motion's prompt (no curve). Drag across the frames to add "
                          "a span")
        curve = item.attention.word_curve(hits[e.occurrence])
        return curve, f"'{e.word}' in {item.name}: drag across the frames to add a span"

    def _post_span_curve(self, *_) -> None:
        """Posted: the shown motion and the word may change on a job's thread, and Bokeh models are written on the
        page's (a write outside the document lock was a Traceback in the server log)."""
        self.state.post(self._write_span_curve)

    @sends_bokeh
    def _write_span_curve(self) -> None:
        n = self._frames_total()
        curve, title = self._span_curve()
        self.span_fig.x_range.start, self.span_fig.x_range.end = 0, n
        if curve is None:
            self.span_curve_src.data = dict(x=[], y=[])
            self.span_fig.y_range.start, self.span_fig.y_range.end = 0, 1
        else:
            curve = np.asarray(curve, dtype=np.float32)
            self.span_curve_src.data = dict(x=list(range(len(curve))), y=curve.tolist())
            top = float(curve.max()) if len(curve) else 1.0
            self.span_fig.y_range.start, self.span_fig.y_range.end = 0, max(top * 1.1, 1e-3)
        self.span_fig.title.text = title

    # ------------------------------------------------------------------ widgets -> state
    def _set(self, name: str, value) -> None:
        if self._syncing or value is None:
            return
        try:
            setattr(self.settings, name, value)
        except ValueError as exc:
            self.state.error(f"{name}: {exc}")

    def _on_word_button(self, event) -> None:
        if self._syncing or event.new is None:
            return
        self.pick_word(int(event.new))

    def pick_word(self, position: int) -> None:
        """What a click on the prompt's ``position``-th word does: the edit names that word (and which occurrence)."""
        word, occurrence = word_choice(self.state.prompt_words, position)
        e = self.settings
        mode = e.mode
        if e.entry.calibrated and "mode" in e.entry.inputs:  # the calibrated mode, for this word: intensity has a
            config = self._model_config()  # fallback for words the corpus does not scale ("punches")
            if e.mode in (default_mode(e.entry.name, config), default_mode(e.entry.name, config, word=e.word)):
                mode = default_mode(e.entry.name, config, word=word)
        e.param.update(word=word, occurrence=occurrence)
        if mode != e.mode:
            e.mode = mode  # its watcher sets that mode's weight and layers
        self._sync(lambda: setattr(self.words, "value", position))

    # ------------------------------------------------------------------ state -> widgets
    def _sync(self, fn) -> None:
        self._syncing.run(fn)

    def _frames_total(self) -> int:
        from engine.generate import frames_for

        try:
            return frames_for(self.state.duration())
        except Exception:
            return 80

    def _model_config(self) -> dict | None:
        try:
            return self.state.model.config
        except Exception:
            return None

    def _describe_model(self) -> None:
        config = self._model_config()
        layers = int(config["model"]["layers"]) if config else 0
        self.layers.options = {f"layer {i}": i for i in range(layers)}

    def _on_prompt(self, *_):
        s, e = self.state, self.settings
        words = list(s.prompt_words)
        left_out = set(s.reading.left_out)  # no token: picking one is refused with the engine's message
        options = {}
        for i, w in enumerate(words):
            label = w if words.count(w) == 1 else f"{w} ({words[:i].count(w) + 1})"
            options[f"{label} (left out)" if w in left_out else label] = i
        picked = None
        if e.word and words.count(e.word) > e.occurrence:
            picked = [i for i, w in enumerate(words) if w == e.word][e.occurrence]
        elif e.word:
            e.param.update(word="", occurrence=0)

        def apply():
            self.words.options = options
            self.words.value = picked
        self._sync(apply)
        self._on_alignment()

    def _on_prompt_text(self, *_):
        if self.settings.entry.source:
            self._on_items()

    def _on_seconds(self, *_):
        self._reset_frames()
        self._write_span_curve()
        self._on_spans()

    def _reset_frames(self) -> None:
        n = self._frames_total()
        value = self.settings.entry.default_frames(n)

        def apply():
            self.frames.end = n
            self.frames.value = value
        self._sync(apply)
        self.settings.frames = value

    def _on_items(self, *_):
        names = list(self.state.items)
        e = self.settings
        prompt_label = PROMPT_SOURCE

        def apply():
            self.source.options = [prompt_label, *names]
            self.style_source.options = [prompt_label, *names]
            self.source.value = e.source if e.source in names else prompt_label
            self.style_source.value = e.style_source if e.style_source in names else prompt_label
        self._sync(apply)
        if e.source not in names:
            e.source = PROMPT_SOURCE
        if e.style_source not in names:
            e.style_source = PROMPT_SOURCE

    def _on_kind(self, *changed):
        from engine.methods.edit_options import default_window

        e = self.settings
        entry = e.entry
        window = default_window(entry.name, self._model_config(), word=e.word) if entry.is_edit else None
        if window is not None:
            e.step_window = (window.start, window.end)
            e.layers = sorted(window.layers or [])  # the calibrated emphasis layers, shown so they can be changed
            self._sync(lambda: setattr(self.steps, "value", (window.start, window.end)))
            self._sync(lambda: setattr(self.layers, "value", list(e.layers)))
        self._reset_frames()
        # a finished edit's lines belong to its kind: switching clears them (running work keeps its status)
        if not self.state.running:
            self.result.object = ""
        self.bar.clear()
        reads = entry.inputs  # the fields this kind reads, by the engine's registry
        is_edit = entry.is_edit
        if changed and "weight" in reads:  # each weighted kind opens on its own mode (ground adds, in (0, 1]; emphasis
            mode = default_mode(entry.name, self._model_config())  # the calibrated one): a x2 is no grounding weight
            if e.mode != mode:
                e.mode = mode  # its watcher sets that mode's default weight
        self.words_label.visible = self.words.visible = "word" in reads
        self.mode.visible = "mode" in reads
        self.weight.visible = "weight" in reads
        self.frames.visible = "frames" in reads and not entry.spans
        self.spans_box.visible = "frames" in reads and entry.spans  # several spans, dragged on the curve
        self.steps.visible = is_edit
        self._show_layers()
        for name in PLAIN_INPUTS:
            self.plain[name].visible = self.plain_help[name].visible = name in reads
        self.edited.visible = self.alignment.visible = "edited" in reads
        self.source.visible = entry.source
        self.source.label = entry.source_label
        self.style_source.visible = self.style_prompt.visible = "style" in reads
        self.run.label = "Count this motion" if not is_edit else f"Run {e.kind}"
        self.count_button.visible = is_edit  # one "Count this motion" button at a time: the Run button in count mode
        self.help.object = KIND_HELP[entry.name] + ("" if not entry.source else
                                                    " Sources: the prompt, or a session motion (a generated one is "
                                                    "re-generated from its prompt, an imported one is DDIM-inverted).")
        if entry.positive_weight and self.weight.value < 0:
            self.weight.value = abs(self.weight.value)
        if entry.spans:
            self._write_span_curve()
        if "edited" in reads and not e.edited:
            e.edited = " ".join(swap_example(list(self.state.prompt_words)))
        self.bar.refresh()  # Run waits for aligned prompts in replacement only

    def _show_layers(self) -> None:
        """The Layers box, for edits that act in layers: intensity mode guides through another prompt and has none."""
        self.layers.visible = acts_in_layers(self.settings.entry.name, self.settings.mode)

    def _on_mode(self, *changed):
        """The weight slider follows the mode: its range, and on a switch the new mode's default weight (+0.3 added
        and x0.3 multiplied are opposite edits); on opening, the settings' weight where it is in range."""
        e = self.settings
        start, end = WEIGHT_RANGES[e.mode]  # the range the method checks (declared in engine.methods.edit_options)
        value = e.weight if not changed and start <= e.weight <= end else DEFAULT_WEIGHTS[e.mode]

        self.weight.param.update(start=start, end=end, value=value)  # the widget writes the settings' weight
        e.weight = value
        self._show_layers()
        if changed and e.entry.calibrated:  # each mode has its own calibrated layers: follow the switch
            from engine.methods.edit_options import default_window

            e.layers = sorted(default_window(e.entry.name, self._model_config(), e.mode, word=e.word).layers or [])
            self._sync(lambda: setattr(self.layers, "value", list(e.layers)))

    def _alignment(self) -> tuple[bool, str]:
        try:
            tokenizer = self.state.model.tokenizer
        except Exception:
            tokenizer = None
        return alignment(tokenizer, self.state.prompt, self.settings.edited, swapped=self.settings.swapped)

    def _on_alignment(self, *_):
        e = self.settings
        self.bar.refresh()
        if "edited" not in e.entry.inputs and not e.edited:
            self.alignment.object = ""
            return
        ok, message = self._alignment()
        cls = "align-ok" if ok else "align-bad"
        self.alignment.object = f'<div class="{cls}">{html.escape(message)}</div>'

    def _on_running(self, *_):
        self.count_button.disabled = self.state.running

    def _misaligned(self) -> bool:
        """Replacement needs an edited prompt that changes something the model reads: Run waits until it does."""
        return "edited" in self.settings.entry.inputs and not self._alignment()[0]

    def _on_last_edit(self, *_):
        last = self.settings.last_edit
        if last is None:
            self.result.object = ""
            return
        outs = ", ".join(f"*{html.escape(a)}*" for a in last.after)
        self.result.object = (f"**{html.escape(last.description)}** in {last.seconds_taken:.1f} s · "
                              f"before: *{html.escape(last.before)}* · after: {outs} · largest joint change "
                              f"{last.max_difference:.2f} m" + (f" · action size {html.escape(last.size)}"
                                                                 if last.size else "")
                              + ". Shown side by side in the viewer.")

    # ------------------------------------------------------------------ counting
    def _build_count_map(self) -> None:
        self.count_src = ColumnDataSource(dict(image=[np.zeros((1, 1), np.float32)], dw=[1], dh=[1]))
        self.peak_src = ColumnDataSource(dict(x=[], y=[]))
        mapper = LinearColorMapper(palette=Viridis256, low=0.0, high=1.0)
        fig = figure(height=305, width=320, tools="hover,reset", toolbar_location=None, x_range=Range1d(0, 1),
                     y_range=Range1d(1, 0), title="Counting map (÷4, normalised) + peaks",
                     x_axis_label="key frame", y_axis_label="query frame", css_classes=["count-map"])
        fig.image(image="image", x=0, y=0, dw="dw", dh="dh", source=self.count_src, color_mapper=mapper)
        fig.scatter("x", "y", source=self.peak_src, size=7, marker="circle", fill_color="#ff2d2d",
                    line_color="white", line_width=1.5)
        fig.select_one(HoverTool).tooltips = [("query frame", "$y{0}"), ("key frame", "$x{0}")]
        fig.title.text_font_size = "11px"
        self.count_map = fig

    @sends_bokeh
    def _on_count(self, *_):
        s = self.state
        readout = s.count_result
        item = s.item
        if readout is None or item is None or readout.item != item.name:
            if item is None:
                text = "Generate or import a motion to count its repetitions."
            elif item.attention is None:
                text = (f"<b>{html.escape(item.name)}</b> has no recorded attention: press <i>Count this motion</i> "
                        "to invert it and count from the rebuilt self-attention.")
            else:
                text = "No count for this motion."
            self.readout.object = f'<div class="count-empty">{text}</div>'
            self.count_src.data = dict(image=[np.zeros((1, 1), np.float32)], dw=[1], dh=[1])
            self.peak_src.data = dict(x=[], y=[])
            self.count_map_box.visible = False  # no map to read: the text above says why (an empty square said nothing)
            return
        self.count_map_box.visible = True
        n = readout.processed.shape[0] * readout.downsample
        self.count_src.data = dict(image=[readout.processed.astype(np.float32)], dw=[n], dh=[n])
        self.count_map.x_range.start, self.count_map.x_range.end = 0, n
        self.count_map.y_range.start, self.count_map.y_range.end = n, 0
        self.peak_src.data = dict(x=[c for _, c in readout.peaks], y=[r for r, _ in readout.peaks])
        period = f"{readout.period} frames ({readout.period / 20:.2f} s)" if readout.period else "none found"
        span = f"{readout.span[0]}–{readout.span[1]}" if readout.span else "–"
        self.readout.object = (
            f'<div class="count-box"><div class="count-title">Counting: {html.escape(readout.item)}</div>'
            f'<table><tr><td>method</td><td class="count-method-used">{html.escape(readout.method)}</td></tr>'
            f'<tr><td>attention count</td><td class="count-attention">{readout.count:.2f}</td></tr>'
            f'<tr><td>rounded</td><td class="count-rounded">{readout.rounded}</td></tr>'
            f'<tr><td>root-height baseline</td><td class="count-baseline">{readout.baseline}</td></tr>'
            f'<tr><td>period</td><td class="count-period">{period}</td></tr>'
            f'<tr><td>repeating frames</td><td class="count-span">{span}</td></tr>'
            f'<tr><td>peaks drawn</td><td class="count-peaks">{len(readout.peaks)}</td></tr></table>'
            f'<div class="count-source">{html.escape(readout.source)}</div>'
            f'<div class="count-source">{html.escape(COUNTING_METHODS[readout.method])}</div></div>')

    def __panel__(self):
        settings = pn.Column(
            self.words_label, self.words, pn.Row(self.mode), self.weight, self.frames, self.spans_box,
            *(w for name in PLAIN_INPUTS for w in (self.plain[name], self.plain_help[name])), self.edited, self.alignment,
            pn.Row(self.source, self.style_source), self.style_prompt, self.steps, self.layers,
            sizing_mode="stretch_width")
        counting = pn.Column("#### Counting", pn.Row(pn.Column(self.count_method, self.readout, self.count_button,
                                                               width=250),
                                                     self.count_map_box),
                             sizing_mode="stretch_width")
        return pn.Column(self.kind, self.help, settings, self.bar, self.result, pn.layout.Divider(), counting,
                         css_classes=["edit-tab"], sizing_mode="stretch_width")


_CSS = """
.align-ok { color: #11672b; font-size: 12px; }
.align-bad { color: #a00; background: #ffecec; border: 1px solid #f3b3b3; padding: 3px 6px; border-radius: 4px;
  font-size: 12px; }
.count-box { font-size: 13px; }
.count-box table { border-collapse: collapse; margin: 4px 0; }
.count-box td { padding: 1px 10px 1px 0; }
.count-box td:last-child { font-weight: 600; font-family: monospace; }
.count-title { font-weight: 600; }
.count-source, .count-empty { color: #555; font-size: 12px; }
.span-none, .span-count { color: #444; font-size: 12px; }
.edit-span-list ol { margin: 2px 0 4px 18px; padding: 0; font-size: 12px; font-family: monospace; }
"""
