"""The Duet tab (ComMDM, PriorMDM): two people from one prompt, or complete a two-person prefix (an example
interaction, an uploaded duet .npy, or a duet made in this session); the communication block on or off (the
prior run twice). Both people play in the viewer in one scene, in two colours, with the viewer's playback and
export (exports hold both people).

The settings live on the session (a ``DuetSettings``, handed to the tab by the page); the widgets are made from
them.
"""
from __future__ import annotations

import html

import panel as pn
import param

from app.components.jobbar import JobBar, table_rows, text_from_param
from app.components.words import WORD_CSS, prompt_notes
from app.components.number_box import FloatBox
from app.session.state import StudioState
from app.tabs.duet.job import DuetJob, describe
from app.tabs.duet.models import duet_model, model_line
from app.tabs.duet.settings import DuetSettings

HELP = ("Two copies of the base model, one per person, exchange what they are doing through a small trained "
        "**communication block** (ComMDM), which also places the two people. Turn it off to see the base model run "
        "twice, side by side at a fixed placement. **Contact guidance** brings the hands together when the training "
        "examples of the interaction the prompt reads as touch (a handshake, a high five, a hug, a push). Seed, steps and guidance come from the sidebar; a completion "
        "without a prompt is unconditional, as in the paper.")


class DuetTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=DuetSettings, doc="the session's Duet settings")

    def __init__(self, **params):
        super().__init__(**params)
        d = self.settings
        self.mode = pn.widgets.RadioButtonGroup.from_param(d.param.mode, name="", color="primary", variant="outline",
                                                           css_classes=["duet-mode"])
        self.prompt = text_from_param(d.param.prompt, css_classes=["duet-prompt"], sizing_mode="stretch_width")
        self.seconds = FloatBox.from_param(d.param.seconds, width=90, css_classes=["duet-seconds"])
        self.flag = pn.pane.HTML("", margin=(0, 10), stylesheets=[WORD_CSS], css_classes=["duet-flag"])
        self.prefix = pn.widgets.Select.from_param(d.param.prefix, css_classes=["duet-prefix"],
                                                   sizing_mode="stretch_width")
        self.prefix_seconds = FloatBox.from_param(d.param.prefix_seconds, width=90, css_classes=["duet-prefix-seconds"])
        self.upload = pn.widgets.FileInput(accept=".npy", multiple=False, css_classes=["duet-upload"],
                                           sizing_mode="stretch_width")
        self.prefix_box = pn.Column(pn.Row(self.prefix, self.prefix_seconds, sizing_mode="stretch_width"),
                                    pn.pane.Markdown("or upload a duet .npy (2, T, 22, 3), as `moattn duet` writes:",
                                                     margin=(0, 10), styles={"font-size": "12px"}),
                                    self.upload, sizing_mode="stretch_width")
        self.communicate = pn.widgets.Checkbox.from_param(d.param.communicate, css_classes=["duet-communicate"])
        self.contact = pn.widgets.Checkbox.from_param(d.param.contact, css_classes=["duet-contact"])
        self.model_note = pn.pane.HTML("", margin=(0, 10), css_classes=["duet-model-note"], stylesheets=[_CSS])
        self.bar = JobBar(state=self.state, jobs=["duet"], label="Make the duet", prefix="duet",
                          on_run=lambda: self.state.launch(DuetJob(session=self.state, settings=self.settings)),
                          blocked=lambda: self.settings.blocked)
        self.readout = pn.pane.HTML("", css_classes=["duet-readout"], stylesheets=[_CSS], sizing_mode="stretch_width")

        self.upload.param.watch(self._on_upload, "value")
        d.param.watch(self._on_words, ["reading", "mode"])
        d.param.watch(self._on_mode, "mode")
        d.param.watch(self._on_result, "result")
        self._on_words()
        self._on_mode()
        self._on_result()
        self._on_model()

    # ------------------------------------------------------------------ mirrors of the settings
    def _on_words(self, *_):
        d = self.settings
        # prefix mode with an empty prompt: an unconditional completion, nothing refused
        self.flag.object = "" if d.mode == "prefix" and not d.reading.words else prompt_notes(d.reading)
        self.bar.refresh()

    def _on_mode(self, *_):
        self.bar.clear()
        prefix = self.settings.mode == "prefix"
        self.prefix_box.visible = prefix
        self.contact.visible = not prefix  # completion has no contact guidance
        self.seconds.label = "Completed (s)" if prefix else "Seconds"
        self.prompt.placeholder = "optional: leave empty for an unconditional completion" if prefix else ""

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
        self.model_note.object = f'<span class="note">{html.escape(model_line(model, s.model))}</span>'

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
