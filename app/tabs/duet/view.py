"""The Duet tab (ComMDM, PriorMDM): two people from one prompt, or complete a two-person prefix (an example
interaction, an uploaded duet .npy, or a duet made in this session); the communication block on or off (the
prior run twice). Both people play in the viewer in one scene, in two colours, with the viewer's playback and
export (exports hold both people).

The settings live on ``DuetSettings`` (``app.tabs.duet.job``); the widgets only mirror it.
"""
from __future__ import annotations

import html

import panel as pn
import param

from app.tabs.duet.job import MODES, DuetSettings, describe, duet_model, start_duet
from app.session.state import StudioState
from app.components.jobbar import UNKNOWN_CSS, JobBar, flag_unknown, on_text, table_rows
from engine.units import MAX_SECONDS, MIN_SECONDS

HELP = ("Two copies of the base model, one per person, exchange what they are doing through a small trained "
        "**communication block** (ComMDM), which also places the two people. Turn it off to see the base model run "
        "twice, side by side at a fixed placement. **Contact guidance** brings the hands together when the training "
        "examples of the interaction the prompt reads as touch (a handshake, a high five, a hug, a push). Seed, steps and guidance come from the sidebar; a completion "
        "without a prompt is unconditional, as in the paper.")
MODE_LABELS = {label: key for key, label in MODES.items()}


class DuetTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, *, duet_dir=None, **params):
        super().__init__(**params)
        extra = {} if duet_dir is None else {"duet_dir": duet_dir}
        self.settings = d = DuetSettings(tokenizer=self.state.tokenizer, **extra)
        self.mode = pn.widgets.RadioButtonGroup(options=MODE_LABELS, value=d.mode, color="primary",
                                                variant="outline", css_classes=["duet-mode"])
        self.prompt = pn.widgets.TextInput(label="Prompt (both people)", value=d.prompt, css_classes=["duet-prompt"],
                                           sizing_mode="stretch_width")
        self.seconds = pn.widgets.FloatInput(label="Seconds", value=d.seconds, start=MIN_SECONDS, end=MAX_SECONDS, step=0.5, width=90,
                                             css_classes=["duet-seconds"])
        self.flag = pn.pane.HTML("", margin=(0, 10), stylesheets=[UNKNOWN_CSS], css_classes=["duet-flag"])
        self.prefix = pn.widgets.Select(label="Prefix (both people)", options=[d.prefix], value=d.prefix,
                                        css_classes=["duet-prefix"], sizing_mode="stretch_width")
        self.prefix_seconds = pn.widgets.FloatInput(label="Given (s)", value=d.prefix_seconds, start=0.1, end=5.0,
                                                    step=0.5, width=90, css_classes=["duet-prefix-seconds"])
        self.upload = pn.widgets.FileInput(accept=".npy", multiple=False, css_classes=["duet-upload"],
                                           sizing_mode="stretch_width")
        self.prefix_box = pn.Column(pn.Row(self.prefix, self.prefix_seconds, sizing_mode="stretch_width"),
                                    pn.pane.Markdown("or upload a duet .npy (2, T, 22, 3), as `moattn duet` writes:",
                                                     margin=(0, 10), styles={"font-size": "12px"}),
                                    self.upload, sizing_mode="stretch_width")
        self.communicate = pn.widgets.Checkbox(label="communication block (ComMDM); off: the base model twice",
                                               value=d.communicate, css_classes=["duet-communicate"])
        self.contact = pn.widgets.Checkbox(label="contact guidance: hands touch when the training examples do",
                                           value=d.contact, css_classes=["duet-contact"])
        self.model_note = pn.pane.HTML("", margin=(0, 10), css_classes=["duet-model-note"], stylesheets=[_CSS])
        self.bar = JobBar(state=self.state, jobs=["duet"], label="Make the duet", prefix="duet",
                          on_run=lambda: start_duet(self.state, self.settings),
                          blocked=lambda: bool(self.settings.unknown_words) and self.settings.mode == "text")
        self.readout = pn.pane.HTML("", css_classes=["duet-readout"], stylesheets=[_CSS], sizing_mode="stretch_width")

        self.mode.param.watch(lambda e: setattr(d, "mode", e.new), "value")
        on_text(self.prompt, lambda text: setattr(d, "prompt", text))
        self.seconds.param.watch(lambda e: setattr(d, "seconds", e.new if e.new is not None else d.seconds), "value")
        self.prefix.param.watch(lambda e: setattr(d, "prefix", e.new) if e.new else None, "value")
        self.prefix_seconds.param.watch(
            lambda e: setattr(d, "prefix_seconds", e.new if e.new is not None else d.prefix_seconds), "value")
        self.communicate.param.watch(lambda e: setattr(d, "communicate", bool(e.new)), "value")
        self.contact.param.watch(lambda e: setattr(d, "contact", bool(e.new)), "value")
        self.upload.param.watch(self._on_upload, "value")
        d.param.watch(self._on_words, ["unknown_words", "mode"])
        d.param.watch(self._on_mode, "mode")
        d.param.watch(self._on_prefixes, ["uploads", "prefix"])
        d.param.watch(self._on_result, "result")
        self.state.param.watch(self._on_prefixes, "items")
        self._on_words()
        self._on_mode()
        self._on_prefixes()
        self._on_result()
        self._on_model()

    # ------------------------------------------------------------------ mirrors of the settings
    def _on_words(self, *_):
        d = self.settings
        self.flag.object = flag_unknown(d.unknown_words, d.suggestions)
        self.bar.refresh()

    def _on_mode(self, *_):
        self.bar.clear()
        prefix = self.settings.mode == "prefix"
        self.prefix_box.visible = prefix
        self.contact.visible = not prefix  # completion has no contact guidance
        self.seconds.label = "Completed (s)" if prefix else "Seconds"
        # each mode's default length (the paper completes 3 s); a length the user typed is kept
        defaults = {True: 3.0, False: 5.0}
        if self.settings.seconds == defaults[not prefix]:
            self.seconds.value = defaults[prefix]
        self.prompt.placeholder = "optional: leave empty for an unconditional completion" if prefix else ""

    def _on_prefixes(self, *_):
        d = self.settings
        options = d.prefix_options(self.state.items)
        if d.prefix not in options:
            d.prefix = options[0]
            return
        self.prefix.options = options
        self.prefix.value = d.prefix

    def _on_upload(self, event):
        if not event.new:
            return
        name = self.upload.filename or "duet.npy"
        try:
            added = self.settings.add_upload(event.new, name)
        except Exception as exc:  # a bad file is the user's, not a crash
            self.state.error(f"Could not use {name} as a prefix: {exc}")
            return
        self.state.info(f"{added}: {len(self.settings.uploads[added][0])} frames of two people")

    def _on_model(self):
        """Say which duet model is used, or why none is (loading it once per server)."""
        s = self.state
        if not s.has_model:
            self.model_note.object = '<span class="bad">no base model is loaded</span>'
            return
        model, problem = duet_model(self.settings.duet_dir, s.model)
        if model is None:
            self.model_note.object = f'<span class="bad">{html.escape(problem)}</span>'
            return
        c = model.config
        own = (f' It runs on the base model it was trained on (step {c.get("prior_step", "?")}, shipped with it), '
               f'not on the studio\'s.' if model.prior is not s.model else "")
        self.model_note.object = (f'<span class="note">ComMDM block after layer {model.denoiser.after} of '
                                  f'{model.prior.model.num_layers}, trained {c.get("step", "?")} steps on '
                                  f'{c.get("samples", "?")} two-person samples.{html.escape(own)}</span>')

    def _on_result(self, *_):
        r = self.settings.result
        if r is None:
            self.readout.object = '<div class="note">No duet yet.</div>'
            return
        rows = table_rows(describe(r))
        given = " Grey frames: the given prefix." if r.prefix_frames else ""
        self.readout.object = (f'<div class="duet-box"><b>{html.escape(r.prompt or "completion")}</b>'
                               f'<table class="duet-table">{rows}</table><div class="note">In the viewer: person a '
                               f'blue, person b orange, one scene.{given}</div></div>')

    def __panel__(self):
        return pn.Column(
            pn.pane.Markdown(HELP, styles={"font-size": "12px", "color": "#444"}, margin=(0, 10)),
            self.mode, pn.Row(self.prompt, self.seconds, sizing_mode="stretch_width"), self.flag, self.prefix_box,
            self.communicate, self.contact, self.model_note, self.bar, self.readout, css_classes=["duet-tab"],
            sizing_mode="stretch_width")


_CSS = """
.bad { color: #a00; font-size: 12px; }
.note { color: #555; font-size: 12px; }
.duet-box { font-size: 13px; }
.duet-table { border-collapse: collapse; margin: 4px 0; }
.duet-table td { padding: 1px 12px 1px 0; }
.duet-table td.value { font-weight: 600; font-family: monospace; }
"""
