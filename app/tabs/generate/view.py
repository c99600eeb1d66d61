"""Sidebar: prompt (read as the engine will read it, its notes and suggestions shown as you type), settings, Generate,
progress, Cancel."""
from __future__ import annotations

import html

import panel as pn
import param

from app.attention_record import estimate_bytes
from app.components.number_box import FloatBox, IntBox
from app.components.words import WORD_CSS, intent_line, word_chips
from app.session.state import StudioState
from app.tabs.generate.followed import FOLLOWED_CSS, item_followed_html
from engine.clauses import clause_prompts
from engine.duration import auto_seconds
from engine.methods.sequence import plan, timeline_frames
from engine.units import FPS, MAX_SECONDS, MIN_SECONDS


SEQUENCE_LABELS = {"clause by clause": "clauses", "whole prompt": "whole"}  # engine.methods.generate_options


class GenerateControls(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        s = self.state
        self.prompt = pn.widgets.TextInput(label="Prompt", value=s.prompt, placeholder="a person jumps twice",
                                           css_classes=["prompt-input"], sizing_mode="stretch_width")
        self.prompt.param.watch(self._on_typed, "value_input")
        self.prompt.param.watch(self._on_typed, "value")
        self.prompt.param.watch(lambda _: self.state.generate(), "enter_pressed")
        self.words = pn.pane.HTML("", css_classes=["prompt-words"], sizing_mode="stretch_width", margin=(0, 10),
                                 stylesheets=[WORD_CSS])
        self.suggestion_row = pn.FlexBox(css_classes=["suggestions"], sizing_mode="stretch_width")
        # what the prompt asks for, as the adherence benchmark reads it (engine.intent)
        self.intent = pn.pane.HTML("", css_classes=["prompt-intent"], sizing_mode="stretch_width", margin=(0, 10),
                                   stylesheets=[WORD_CSS])
        # the session's sampling settings (every tab samples with them), linked both ways: settings the session
        # changes itself (Re-record) show in the boxes
        # number boxes never show "NaN": an emptied Seconds is auto (its placeholder says the length, "auto 2.3"),
        # any other emptied box shows its default again (app.components.number_box)
        self.seconds = FloatBox.from_param(s.param.seconds, width=90, placeholder="auto",
                                           css_classes=["seconds-input"])
        self.seed = IntBox.from_param(s.param.seed, width=90, css_classes=["seed-input"])
        self.steps = IntBox.from_param(s.param.steps, width=90, css_classes=["steps-input"])
        self.guidance = FloatBox.from_param(s.param.guidance, width=90, css_classes=["guidance-input"])
        self.tries = IntBox.from_param(s.param.tries, width=90, css_classes=["tries-input"])
        self.record = IntBox.from_param(s.param.record_steps, width=120, css_classes=["record-input"])
        self.memory = pn.pane.Markdown("", css_classes=["record-memory"], margin=(0, 10))
        # a prompt of several actions in order: how it is generated, shown only for such a prompt
        self.sequence = pn.widgets.RadioButtonGroup(options=SEQUENCE_LABELS, value=s.sequence, color="primary",
                                                    variant="outline",
                                                    css_classes=["sequence-mode"], margin=(0, 10),
                                                    description=s.param.sequence.doc)
        self.sequence.param.watch(lambda e: setattr(self.state, "sequence", e.new), "value")
        self.clauses = pn.pane.HTML("", css_classes=["sequence-clauses"], sizing_mode="stretch_width",
                                    margin=(0, 10), styles={"font-size": "12px", "color": "#555"})
        self.generate = pn.widgets.Button(label="Generate", color="primary", sizing_mode="stretch_width",
                                          css_classes=["generate-button"])
        self.cancel = pn.widgets.Button(label="Cancel", color="warning", disabled=True, width=90,
                                        css_classes=["cancel-button"])
        self.generate.on_click(lambda _: self.state.generate())
        self.cancel.on_click(lambda _: self.state.cancel())
        self.progress = pn.indicators.Progress(value=0, max=1, sizing_mode="stretch_width", bar_color="primary",
                                               css_classes=["generation-progress"], height=14)
        self.status = pn.pane.Markdown("", css_classes=["generation-status"], margin=(0, 10))
        # what the shown motion followed of its prompt: its own report, cleared for any other motion (never stale)
        self.followed = pn.pane.HTML("", css_classes=["followed-report"], sizing_mode="stretch_width", margin=(0, 10),
                                     stylesheets=[FOLLOWED_CSS])
        self.model_info = pn.pane.Markdown("", css_classes=["model-info"], margin=(0, 10),
                                           styles={"font-size": "12px", "color": "#555"})
        self.vocab = pn.pane.Markdown("", styles={"font-size": "12px"})

        s.param.watch(self._on_analysis, ["prompt_words", "reading"])
        s.param.watch(self._on_prompt, "prompt")
        s.param.watch(self._on_progress, ["running", "progress", "progress_total", "status"])
        s.param.watch(self._on_memory, ["steps", "record_steps", "seconds", "prompt_words", "sequence"])
        s.param.watch(self._on_sequence, ["prompt", "sequence"])
        s.param.watch(self._on_followed, ["current", "items", "preview", "running"])
        self._on_analysis()
        self._on_followed()
        self._on_progress()
        self._on_memory()
        self._on_sequence()
        self._describe_model()

    def _on_typed(self, event):
        if event.new is not None and event.new != self.state.prompt:
            self.state.prompt = event.new

    def _on_prompt(self, event):
        if self.prompt.value_input != event.new:
            self.prompt.value = event.new

    def _on_analysis(self, *_):
        s = self.state
        reading = s.reading
        # the button state goes first so that it is never behind the shown notes: only a prompt the engine refuses
        # (empty, too long, nothing that says a motion) waits; unknown words are read by meaning or left out
        self.generate.disabled = reading.blocked or s.running
        self.words.object = word_chips(reading)
        self.intent.object = intent_line(s.prompt, reading.left_out)
        buttons = []
        for word in reading.left_out:
            for suggestion in reading.suggestions.get(word, ())[:3]:
                shown = f"… {suggestion[1:]}" if suggestion.startswith("~") else suggestion
                b = pn.widgets.Button(label=f"{word} → {shown}", color="light", height=30,
                                      css_classes=["suggestion"], margin=(2, 4))
                b.on_click(lambda _, w=word, sug=suggestion: self.state.replace_word(w, sug))
                buttons.append(b)
        self.suggestion_row.objects = buttons

    def _on_progress(self, *_):
        s = self.state
        with pn.io.hold():  # one message to the page per step, not one per widget
            self.progress.max = max(1, s.progress_total)
            # the bar shows running work only: empty when idle (the status line says what finished)
            self.progress.value = min(s.progress, self.progress.max) if s.running else 0
            self.generate.disabled = s.running or s.reading.blocked
            self.generate.label = "Generating…" if s.running else "Generate"
            self.cancel.disabled = not s.running
            self.status.object = html.escape(s.status)

    def _on_followed(self, *_):
        s = self.state
        generating = s.preview is not None or (s.running and s.job == "generation")  # the viewer shows the new one
        text = "" if generating else item_followed_html(s.item)
        if self.followed.object != text:
            self.followed.object = text
        self.followed.visible = bool(text)

    def _on_sequence(self, *_):
        s = self.state
        clauses = clause_prompts(s.prompt)
        several = len(clauses) > 1
        if self.sequence.value != s.sequence:
            self.sequence.value = s.sequence
        self.sequence.visible = self.clauses.visible = several
        if not several:
            return
        if s.sequence == "clauses":
            text = (f"{len(clauses)} actions in order, generated clause by clause and joined (DoubleTake): "
                    + " → ".join(f"‘{html.escape(c)}’" for c in clauses) + ". Attention is recorded clause by "
                    "clause; choose <i>whole prompt</i> for one take of the whole sentence.")
        else:
            text = f"{len(clauses)} actions in order, generated in one take of the whole prompt (attention recorded)."
        self.clauses.object = text

    def _on_memory(self, *_):
        s = self.state
        try:
            config = s.model.config["model"]
            layers, heads = config["layers"], config["heads"]
        except Exception:
            layers, heads = 6, 4
        tempo = s.count_tempo()
        intervals = plan(s.prompt, sequence=s.sequence, tempo=tempo)  # actions in order: clause by clause, each its own length
        auto = auto_seconds(s.prompt, tempo) if intervals is None else timeline_frames(intervals) / FPS
        placeholder = f"auto {auto:.1f}"  # an empty box: the length predicted from the prompt
        if self.seconds.placeholder != placeholder:
            self.seconds.placeholder = placeholder
        if intervals is not None:  # the clauses' maps laid over the joined timeline (app.attention_record)
            frames = timeline_frames(intervals) if s.seconds is None else int(round(s.seconds * FPS))
        else:
            seconds = s.seconds if s.seconds is not None else auto
            frames = int(round(min(max(seconds, MIN_SECONDS), MAX_SECONDS) * FPS))
        words = max(1, len(s.prompt_words))
        size = estimate_bytes(num_steps=max(1, s.steps), record_steps=s.record_steps, layers=layers, heads=heads,
                              frames=frames, words=words) if s.record_steps else 0
        self.memory.object = (f"attention kept: {size / 1e6:.1f} MB (all layers and heads, "
                              f"{min(s.record_steps, s.steps)} of {s.steps} steps)")

    def _describe_model(self):
        s = self.state
        try:
            loaded = s.model
        except Exception as exc:
            self.model_info.object = f"**No model**: {html.escape(str(exc))}"
            self.generate.disabled = True
            return
        m = loaded.config["model"]
        self.model_info.object = (f"model `{loaded.folder.name}`: {m['layers']} layers × {m['heads']} heads, "
                                  f"width {m['width']}, {len(loaded.tokenizer) - 1} words")
        self.vocab.object = ", ".join(loaded.tokenizer.words[1:])

    def __panel__(self):
        settings = pn.GridBox(self.seconds, self.seed, self.steps, self.guidance, self.tries, ncols=2)
        advanced = pn.Card(self.record, self.memory, title="Attention recording", collapsed=True,
                           sizing_mode="stretch_width")
        vocab = pn.Card(self.vocab, title="Vocabulary", collapsed=True, sizing_mode="stretch_width")
        return pn.Column(
            self.prompt, self.words, self.intent, self.suggestion_row, self.sequence, self.clauses, settings,
            advanced,
            pn.Row(self.generate, self.cancel, sizing_mode="stretch_width"),
            self.progress, self.status, self.followed, self.model_info, vocab,
            sizing_mode="stretch_width", css_classes=["generate-controls"],
        )
