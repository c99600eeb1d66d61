"""The Edit tab (MotionCLR): pick an edit, click a word of the prompt, set weights and windows, run it off the UI
thread, see before / after side by side in the viewer; the counting readout with its peaks.

All settings live on ``state.edit`` (an ``app.tabs.edit.settings.EditSettings``); the widgets only mirror it. The
edit itself is an ``EditJob`` launched on the session (checks, then the shared worker with progress and cancel).
"""
from __future__ import annotations

import html

import numpy as np
import panel as pn
import param
from bokeh.models import ColumnDataSource, HoverTool, LinearColorMapper, Range1d
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

from app.components.guard import SyncGuard
from app.components.jobbar import WRAP_BUTTONS_CSS, JobBar, text_from_param
from app.session.state import StudioState
from app.tabs.edit.job import alignment, count_current, run_edit, swap_example, word_choice
from app.tabs.edit.settings import KIND_HELP, PROMPT_SOURCE
from engine.methods.edit_kinds import REGISTRY
from engine.methods.motionclr import WEIGHT_RANGES



class EditTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        s, e = self.state, self.state.edit
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
                                                           css_classes=["edit-mode"], width=220)
        lo, hi = WEIGHT_RANGES[e.mode]  # the mode's own range (the settings' bounds cover both modes)
        self.weight = pn.widgets.FloatSlider.from_param(e.param.weight, start=lo, end=hi, css_classes=["edit-weight"],
                                                        sizing_mode="stretch_width")
        self.frames = pn.widgets.IntRangeSlider(label="Frames", start=0, end=80, value=(0, 80), step=1,
                                                css_classes=["edit-frames"], sizing_mode="stretch_width")
        self.steps = pn.widgets.RangeSlider(label="Steps (fraction of the run)", start=0.0, end=1.0, step=0.05,
                                            value=(0.0, 1.0), css_classes=["edit-steps"], sizing_mode="stretch_width")
        self.layers = pn.widgets.MultiChoice(label="Layers (empty = the edit's default)", options={}, value=[],
                                             css_classes=["edit-layers"], sizing_mode="stretch_width")
        self.fraction = pn.widgets.FloatSlider.from_param(e.param.fraction, css_classes=["edit-fraction"],
                                                          sizing_mode="stretch_width")
        self.count = pn.widgets.IntSlider.from_param(e.param.count, css_classes=["edit-count"],
                                                     sizing_mode="stretch_width")
        self.edited = text_from_param(e.param.edited, placeholder="a person kicks twice", css_classes=["edit-edited"],
                                      sizing_mode="stretch_width")
        self.alignment = pn.pane.HTML("", css_classes=["edit-alignment"], margin=(0, 10), stylesheets=[_CSS])
        self.source = pn.widgets.Select(label="Content / example", options=[PROMPT_SOURCE], value=e.source,
                                        css_classes=["edit-source"], width=260)
        self.style_source = pn.widgets.Select(label="Style", options=[PROMPT_SOURCE], value=e.style_source,
                                              css_classes=["edit-style-source"], width=260)
        self.style_prompt = text_from_param(e.param.style_prompt, css_classes=["edit-style-prompt"], width=260)
        self.bar = JobBar(state=s, jobs=["edit", "counting"], label="Run edit", prefix="edit",
                          on_run=lambda: run_edit(self.state), blocked=self._misaligned)
        b = self.bar
        self.run, self.cancel, self.progress, self.status = b.run, b.cancel, b.progress, b.status
        self.result = pn.pane.Markdown("", css_classes=["edit-result"], margin=(0, 10))
        self.readout = pn.pane.HTML("", css_classes=["count-readout"], margin=(0, 10), stylesheets=[_CSS])
        self.count_button = pn.widgets.Button(label="Count this motion", css_classes=["count-button"], width=160)
        self._build_count_map()
        self.count_pane = pn.pane.Bokeh(self.count_map, margin=(0, 10))

        self.words.param.watch(self._on_word_button, "value")
        self.frames.param.watch(lambda ev: self._set("frames", tuple(ev.new)), "value")
        self.steps.param.watch(lambda ev: self._set("step_window", tuple(round(v, 4) for v in ev.new)), "value")
        self.layers.param.watch(lambda ev: self._set("layers", sorted(int(v) for v in ev.new)), "value")
        self.source.param.watch(lambda ev: self._set("source", ev.new), "value")
        self.style_source.param.watch(lambda ev: self._set("style_source", ev.new), "value")
        self.count_button.on_click(lambda _: count_current(self.state))

        e.param.watch(self._on_kind, "kind")
        e.param.watch(self._on_mode, "mode")
        e.param.watch(self._on_alignment, "edited")
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

    # ------------------------------------------------------------------ widgets -> state
    def _set(self, name: str, value) -> None:
        if self._syncing or value is None:
            return
        try:
            setattr(self.state.edit, name, value)
        except ValueError as exc:
            self.state.error(f"{name}: {exc}")

    def _on_word_button(self, event) -> None:
        if self._syncing or event.new is None:
            return
        self.pick_word(int(event.new))

    def pick_word(self, position: int) -> None:
        """What a click on the prompt's ``position``-th word does: the edit names that word (and which occurrence)."""
        word, occurrence = word_choice(self.state.prompt_words, position)
        self.state.edit.param.update(word=word, occurrence=occurrence)
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
        s, e = self.state, self.state.edit
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
        if self.state.edit.engine_kind in ("example", "style"):
            self._on_items()

    def _on_seconds(self, *_):
        self._reset_frames()

    def _reset_frames(self) -> None:
        n = self._frames_total()
        kind = self.state.edit.engine_kind
        value = (n // 2, n) if kind == "erase" else (0, n)

        def apply():
            self.frames.end = n
            self.frames.value = value
        self._sync(apply)
        self.state.edit.frames = value

    def _on_items(self, *_):
        names = list(self.state.items)
        e = self.state.edit
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

    def _on_kind(self, *_):
        from engine.methods.edit_options import default_window

        e = self.state.edit
        kind = e.engine_kind
        window = default_window(kind, self._model_config()) if kind != "count" else None
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
        entry = REGISTRY[kind]
        reads = entry.inputs  # the fields this kind reads, by the engine's registry
        is_edit = entry.is_edit
        self.words_label.visible = self.words.visible = "word" in reads
        self.mode.visible = "mode" in reads
        self.weight.visible = "weight" in reads
        self.frames.visible = "frames" in reads
        self.frames.label = "Frames (grounding mask)" if kind == "ground" else "Frames"
        self.steps.visible = self.layers.visible = is_edit
        self.fraction.visible = "fraction" in reads
        self.count.visible = "count" in reads
        self.edited.visible = self.alignment.visible = "edited" in reads
        self.source.visible = entry.source
        self.source.label = "Example" if kind == "example" else "Content"
        self.style_source.visible = self.style_prompt.visible = "style" in reads
        self.run.label = "Count this motion" if not is_edit else f"Run {e.kind}"
        self.help.object = KIND_HELP[kind] + ("" if not entry.source else
                                              " Sources: the prompt, or a session motion (a generated one is "
                                              "re-generated from its prompt, an imported one is DDIM-inverted).")
        if kind == "ground" and self.weight.value < 0:
            self.weight.value = abs(self.weight.value)
        if kind == "replace" and not e.edited:
            e.edited = " ".join(swap_example(list(self.state.prompt_words)))
        self.bar.refresh()  # Run waits for aligned prompts in replacement only

    def _on_mode(self, *_):
        e = self.state.edit
        start, end = WEIGHT_RANGES[e.mode]  # the range the method checks (engine.methods.motionclr)
        value = e.weight if start <= e.weight <= end else (2.0 if e.mode == "mul" else 0.3)

        self.weight.param.update(start=start, end=end, value=value)  # the widget writes the settings' weight
        e.weight = value

    def _alignment(self) -> tuple[bool, str]:
        try:
            tokenizer = self.state.model.tokenizer
        except Exception:
            tokenizer = None
        return alignment(tokenizer, self.state.prompt, self.state.edit.edited)

    def _on_alignment(self, *_):
        e = self.state.edit
        self.bar.refresh()
        if e.engine_kind != "replace" and not e.edited:
            self.alignment.object = ""
            return
        ok, message = self._alignment()
        cls = "align-ok" if ok else "align-bad"
        self.alignment.object = f'<div class="{cls}">{html.escape(message)}</div>'

    def _on_running(self, *_):
        self.count_button.disabled = self.state.running

    def _misaligned(self) -> bool:
        """Replacement needs prompts aligned word by word: Run waits until they are."""
        return self.state.edit.engine_kind == "replace" and not self._alignment()[0]

    def _on_last_edit(self, *_):
        last = self.state.edit.last_edit
        if last is None:
            self.result.object = ""
            return
        outs = ", ".join(f"*{html.escape(a)}*" for a in last.after)
        self.result.object = (f"**{html.escape(last.description)}** in {last.seconds_taken:.1f} s · "
                              f"before: *{html.escape(last.before)}* · after: {outs} · largest joint change "
                              f"{last.max_difference:.2f} m. Shown side by side in the viewer.")

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
            return
        n = readout.processed.shape[0] * readout.downsample
        self.count_src.data = dict(image=[readout.processed.astype(np.float32)], dw=[n], dh=[n])
        self.count_map.x_range.start, self.count_map.x_range.end = 0, n
        self.count_map.y_range.start, self.count_map.y_range.end = n, 0
        self.peak_src.data = dict(x=[c for _, c in readout.peaks], y=[r for r, _ in readout.peaks])
        period = f"{readout.period} frames ({readout.period / 20:.2f} s)" if readout.period else "none found"
        span = f"{readout.span[0]}–{readout.span[1]}" if readout.span else "–"
        self.readout.object = (
            f'<div class="count-box"><div class="count-title">Counting: {html.escape(readout.item)}</div>'
            f'<table><tr><td>attention count</td><td class="count-attention">{readout.count:.2f}</td></tr>'
            f'<tr><td>rounded</td><td class="count-rounded">{readout.rounded}</td></tr>'
            f'<tr><td>root-height baseline</td><td class="count-baseline">{readout.baseline}</td></tr>'
            f'<tr><td>period</td><td class="count-period">{period}</td></tr>'
            f'<tr><td>repeating frames</td><td class="count-span">{span}</td></tr>'
            f'<tr><td>peaks drawn</td><td class="count-peaks">{len(readout.peaks)}</td></tr></table>'
            f'<div class="count-source">{html.escape(readout.source)}</div></div>')

    def __panel__(self):
        settings = pn.Column(
            self.words_label, self.words, pn.Row(self.mode), self.weight, self.frames, self.fraction, self.count,
            self.edited, self.alignment, pn.Row(self.source, self.style_source), self.style_prompt,
            self.steps, self.layers, sizing_mode="stretch_width")
        counting = pn.Column("#### Counting", pn.Row(pn.Column(self.readout, self.count_button, width=250),
                                                     self.count_pane), sizing_mode="stretch_width")
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
"""
