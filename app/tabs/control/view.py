"""The Control tab (PriorMDM control, DiffusionBlending): draw a root path top-down and / or a wrist path in front
view, set the prompt, the duration and the blend weights, pick the method, Generate; the motion in the viewer with
the target paths drawn in 3-D, and the measured error.

The settings live on the session (``state.control``, a ``ControlSettings``); the widgets are made from them and the
canvases (``app.tabs.control.canvas``) draw them.
"""
from __future__ import annotations

import html

import panel as pn
import param

from app.components.jobbar import JobBar, table_rows, text_from_param
from app.components.words import WORD_CSS, prompt_notes
from app.components.number_box import FloatBox
from app.session.state import StudioState
from app.tabs.control.canvas import FrontCanvas, TopDownCanvas
from app.tabs.control.job import ControlJob, describe
from app.tabs.control.paths import LABELS, path_length
from app.tabs.control.settings import METHOD_LABELS
from engine.methods.paths import MAX_ROOT_SPEED

HELP = ("Draw the **root path** on the floor (top-down, metres; drag to draw, or pick the point tool to add and "
        "drag points): the person starts at its first point (green) and walks along it at constant speed. A "
        "**wrist path** is drawn in front view on a plane in front of the body. Seed, steps and guidance come "
        "from the sidebar.")


class ControlTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        self.settings = k = self.state.control
        self.prompt = text_from_param(k.param.prompt, css_classes=["control-prompt"], sizing_mode="stretch_width")
        self.seconds = FloatBox.from_param(k.param.seconds, width=90, css_classes=["control-seconds"])
        self.flag = pn.pane.HTML("", margin=(0, 10), stylesheets=[WORD_CSS], css_classes=["control-flag"])
        # one line when control runs on the control models' own base model, not the loaded one (issue #32)
        self.base_note = pn.pane.HTML("", margin=(0, 10), stylesheets=[_CSS], css_classes=["control-base-note"])
        self.use_root = pn.widgets.Checkbox.from_param(k.param.use_root, css_classes=["control-use-root"])
        self.top = TopDownCanvas(settings=k)
        self.root_info = pn.pane.HTML("", css_classes=["control-root-info"], margin=(0, 10), stylesheets=[_CSS])
        self.clear_root = pn.widgets.Button(label="Clear path", width=100, css_classes=["control-clear-root"])
        self.example_root = pn.widgets.Button(label="Example S", width=100, css_classes=["control-example-root"])
        self.wrist = pn.widgets.RadioButtonGroup.from_param(k.param.wrist, color="primary", variant="outline",
                                                            css_classes=["control-wrist"])
        self.front = FrontCanvas(settings=k)
        self.clear_wrist = pn.widgets.Button(label="Clear wrist path", width=130, css_classes=["control-clear-wrist"])
        self.depth = pn.widgets.FloatSlider.from_param(k.param.wrist_depth, css_classes=["control-depth"],
                                                       sizing_mode="stretch_width")
        self.method = pn.widgets.RadioButtonGroup.from_param(k.param.method, color="primary", variant="outline",
                                                             css_classes=["control-method"])
        self.method_note = pn.pane.HTML("", css_classes=["control-method-note"], margin=(0, 10), stylesheets=[_CSS])
        self.weights = {n: pn.widgets.FloatSlider(label=f"weight: {LABELS[n]}", start=0.0, end=1.0, step=0.05,
                                                  value=float(k.weights.get(n, 1.0)), css_classes=[f"control-weight-{n}"],
                                                  sizing_mode="stretch_width") for n in LABELS}
        self.shares = pn.pane.HTML("", css_classes=["control-shares"], margin=(0, 10), stylesheets=[_CSS])
        self.bar = JobBar(state=self.state, jobs=["controlled generation"], label="Generate with control",
                          prefix="control", on_run=self.generate,
                          blocked=lambda: self.settings.reading.blocked)
        self.readout = pn.pane.HTML("", css_classes=["control-readout"], margin=(0, 10), stylesheets=[_CSS])
        self.wrist_box = pn.Column(self.front.view, pn.Row(self.clear_wrist, self.depth, sizing_mode="stretch_width"),
                                   sizing_mode="stretch_width")

        self.clear_root.on_click(lambda _: setattr(k, "root_points", []))
        self.example_root.on_click(lambda _: self.top.example())
        self.clear_wrist.on_click(lambda _: setattr(k, "wrist_points", []))
        for name, slider in self.weights.items():
            slider.param.watch(lambda e, name=name: self._set_weight(name, e.new), "value")
        k.param.watch(self._on_reading, "reading")
        k.param.watch(self._on_root_info, ["root_points", "seconds", "use_root"])
        k.param.watch(self._on_active, ["use_root", "wrist", "method", "weights", "available"])
        k.param.watch(self._on_result, "result")
        k.param.watch(self._on_base_note, "base_note")
        self._on_base_note()
        self._on_reading()
        self._on_root_info()
        self._on_active()
        self._on_result()

    # ------------------------------------------------------------------ widgets -> settings
    def generate(self) -> bool:
        return self.state.launch(ControlJob(session=self.state, settings=self.settings))

    def _set_weight(self, name: str, value: float) -> None:
        self.settings.weights = {**self.settings.weights, name: float(value)}

    # ------------------------------------------------------------------ settings -> widgets
    def _on_reading(self, *_):
        """The engine's notes on the prompt (read by meaning, typo read as, left out) or its refusal."""
        self.flag.object = prompt_notes(self.settings.reading)
        self.flag.visible = bool(self.flag.object)
        self.bar.refresh()

    def _on_base_note(self, *_):
        note = self.settings.base_note
        self.base_note.object = f'<span class="warn">{html.escape(note)}</span>' if note else ""
        self.base_note.visible = bool(note)

    def _on_root_info(self, *_):
        k = self.settings
        pts = k.root_points
        if len(pts) < 2:
            self.root_info.object = '<span class="bad">no root path: draw one on the canvas</span>'
            return
        length = path_length(pts)
        speed = length / max(float(k.seconds), 1e-6)
        cls = "bad" if speed > MAX_ROOT_SPEED else "ok"
        note = " — too fast: draw a shorter path or give more seconds" if speed > MAX_ROOT_SPEED else ""
        (x0, z0), (x1, z1) = pts[0], pts[-1]
        self.root_info.object = (f'<span class="{cls}">root path: {len(pts)} points, {length:.1f} m from '
                                 f'({x0:.1f}, {z0:.1f}) to ({x1:.1f}, {z1:.1f}), {speed:.1f} m/s over '
                                 f'{k.seconds:g} s{note}</span>')

    def _on_active(self, *_):
        k = self.settings
        blending_ok = bool(k.available)
        options = METHOD_LABELS if blending_ok else {"inpainting (base model)": "inpainting"}
        if self.method.options != options:
            self.method.options = options
        if not blending_ok:
            note = f"Only inpainting is offered: {html.escape(k.problem)}."
        elif k.problem:
            note = (f"Fine-tuned control models for: {html.escape(', '.join(LABELS[n] for n in k.available))}; "
                    f"{html.escape(k.problem)}.")
        else:
            names = ", ".join(LABELS[n] for n in k.available)
            note = (f"Fine-tuned control models found for: {html.escape(names)}. Blending mixes their predictions "
                    "with the weights below (DiffusionBlending); inpainting overwrites the controls on the base "
                    "model's predictions.")
        self.method_note.object = f'<span class="note">{note}</span>'
        active = k.active
        blending = k.method == "blending"
        for name, slider in self.weights.items():
            slider.visible = blending and name in active
        self.wrist_box.visible = k.wrist != "none"
        shares = k.normalized_weights()
        if not active:
            text = '<span class="bad">no control is on: follow the root path or pick a wrist</span>'
        elif not blending:
            text = '<span class="note">blend weights apply to fine-tuned models only (not to inpainting)</span>'
        else:
            text = "blend: " + " + ".join(f"{shares[n]:.2f} × {LABELS[n]}" for n in active) + " (normalised to 1)"
        self.shares.object = text

    def _on_result(self, *_):
        r = self.settings.result
        if r is None:
            self.readout.object = '<div class="note">No controlled motion yet.</div>'
            return
        rows = table_rows(describe(r))
        guides = "; ".join(filter(None, [
            "red tube: the root path" if r.root_error is not None else "",
            "purple tube: the wrist target" if r.wrist_error is not None else ""]))
        self.readout.object = (
            f'<div class="control-box"><b>{html.escape(r.name)}</b><br>{html.escape(r.method)} · '
            f'{r.seconds_taken:.1f} s<table class="control-error">{rows}</table>'
            + (f'<div class="warn">{html.escape(r.base_note)}</div>' if r.base_note else "") +
            f'<div class="note">In the viewer: {guides} (the "root path" checkbox hides them).</div></div>')

    def __panel__(self):
        root = pn.Column(pn.Row(self.use_root, self.clear_root, self.example_root), self.top.view, self.root_info,
                         sizing_mode="stretch_width")
        wrist = pn.Column(self.wrist, self.wrist_box, sizing_mode="stretch_width")
        return pn.Column(
            pn.pane.Markdown(HELP, styles={"font-size": "12px", "color": "#444"}, margin=(0, 10)),
            self.base_note, pn.Row(self.prompt, self.seconds, sizing_mode="stretch_width"), self.flag,
            "#### Root path (top-down)", root, "#### Wrist path (front view)", wrist,
            "#### Method", self.method, self.method_note, *self.weights.values(), self.shares,
            self.bar, self.readout, css_classes=["control-tab"], sizing_mode="stretch_width")


_CSS = """
.ok { color: #11672b; font-size: 12px; }
.bad { color: #a00; font-size: 12px; }
.note { color: #555; font-size: 12px; }
.warn { color: #8a5a00; font-size: 12px; }
.control-box { font-size: 13px; }
.control-error { border-collapse: collapse; margin: 4px 0; }
.control-error td { padding: 1px 12px 1px 0; }
.control-error td.value { font-weight: 600; font-family: monospace; }
"""
