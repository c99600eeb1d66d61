"""The Control tab (PriorMDM control, DiffusionBlending): draw a root path top-down and / or both wrists' paths in
front view (any of them at once), set the prompt, the duration and a blend weight per control, pick the method,
Generate; the motion in the viewer with the target paths drawn in 3-D, and the measured errors. The tab opens on
blending only when the control bench has it ahead of inpainting, and says which one the bench has ahead.

The settings live on the session (a ``ControlSettings``, handed to the tab by the page); the widgets are made from
them and the canvases (``app.tabs.control.canvas``) draw them.
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
from app.tabs.control.paths import COLOR_NAMES, LABELS, WRISTS, path_length
from app.tabs.control.settings import METHOD_LABELS, ControlSettings
from engine.methods.control_options import ControlOptions, option_info
from engine.methods.paths import MAX_ROOT_SPEED

HELP = ("Draw the **root path** on the floor (top-down, metres; drag to draw, or pick the point tool to add and "
        "drag points): the person starts at its first point (green) and walks along it at constant speed. The "
        "**left and right wrist paths** are drawn in front view on a plane in front of the body (pick which wrist "
        "you draw). Any of the three can be followed at once; blending mixes their control models with the "
        "weights. Seed, steps and guidance come from the sidebar.")


class ControlTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=ControlSettings, doc="the session's Control settings")

    def __init__(self, **params):
        super().__init__(**params)
        k = self.settings
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
        self.use_wrists = {w: pn.widgets.Checkbox.from_param(getattr(k.param, f"use_{w}"),
                                                             css_classes=[f"control-use-{w.replace('_', '-')}"])
                           for w in WRISTS}
        self.drawing = pn.widgets.RadioButtonGroup.from_param(k.param.drawing, color="primary", variant="outline",
                                                              css_classes=["control-drawing"])
        self.front = FrontCanvas(settings=k)
        self.wrist_info = pn.pane.HTML("", css_classes=["control-wrist-info"], margin=(0, 10), stylesheets=[_CSS])
        self.clear_wrist = pn.widgets.Button(label="Clear this wrist's path", width=170,
                                             css_classes=["control-clear-wrist"])
        self.example_wrists = pn.widgets.Button(label="Example letters", width=130,
                                                css_classes=["control-example-wrists"])
        self.depth = pn.widgets.FloatSlider.from_param(k.param.wrist_depth, css_classes=["control-depth"],
                                                       sizing_mode="stretch_width")
        self.method = pn.widgets.RadioButtonGroup.from_param(k.param.method, color="primary", variant="outline",
                                                             css_classes=["control-method"])
        self.method_note = pn.pane.HTML("", css_classes=["control-method-note"], margin=(0, 10), stylesheets=[_CSS])
        # which method the control bench has ahead (what the tab opened on, and why)
        self.bench_note = pn.pane.HTML("", css_classes=["control-bench-note"], margin=(0, 10), stylesheets=[_CSS])
        self.planted_feet = pn.widgets.Checkbox.from_param(k.param.planted_feet, css_classes=["control-planted-feet"])
        self.weights = {n: self._weight_slider(n) for n in LABELS}
        self.shares = pn.pane.HTML("", css_classes=["control-shares"], margin=(0, 10), stylesheets=[_CSS])
        self.bar = JobBar(state=self.state, jobs=["controlled generation"], label="Generate with control",
                          prefix="control", on_run=self.generate,
                          blocked=lambda: self.settings.reading.blocked)
        self.readout = pn.pane.HTML("", css_classes=["control-readout"], margin=(0, 10), stylesheets=[_CSS])
        self.wrist_box = pn.Column(self.drawing, self.front.view, self.wrist_info,
                                   pn.Row(self.clear_wrist, self.example_wrists, self.depth, sizing_mode="stretch_width"),
                                   sizing_mode="stretch_width")

        self.clear_root.on_click(lambda _: setattr(k, "root_points", []))
        self.example_root.on_click(lambda _: self.top.example())
        self.clear_wrist.on_click(lambda _: setattr(k, f"{k.drawing}_points", []))
        self.example_wrists.on_click(lambda _: self.front.example())
        for name, slider in self.weights.items():
            slider.param.watch(lambda e, name=name: self._set_weight(name, e.new), "value")
        k.param.watch(self._on_reading, "reading")
        k.param.watch(self._on_root_info, ["root_points", "seconds", "use_root"])
        k.param.watch(self._on_wrist_info, ["left_wrist_points", "right_wrist_points", "use_left_wrist",
                                            "use_right_wrist", "drawing"])
        k.param.watch(self._on_active, ["use_root", "use_left_wrist", "use_right_wrist", "method", "weights",
                                        "available", "verdict"])
        k.param.watch(self._on_weights, "weights")
        k.param.watch(self._on_result, "result")
        k.param.watch(self._on_base_note, "base_note")
        self._on_base_note()
        self._on_reading()
        self._on_root_info()
        self._on_wrist_info()
        self._on_active()
        self._on_result()

    def _weight_slider(self, name: str) -> pn.widgets.FloatSlider:
        """A blend weight's slider, its range and step as the engine's ControlOptions declares them."""
        info = option_info(ControlOptions, ControlOptions.weight_field(name))
        start, end = info.soft
        return pn.widgets.FloatSlider(label=f"weight: {LABELS[name]}", start=start, end=end, step=info.step,
                                      value=float(self.settings.weights.get(name, info.default)),
                                      css_classes=[f"control-weight-{name}"], sizing_mode="stretch_width")

    # ------------------------------------------------------------------ widgets -> settings
    def generate(self) -> bool:
        return self.state.launch(ControlJob(session=self.state, settings=self.settings))

    def _set_weight(self, name: str, value: float) -> None:
        if self.settings.weights.get(name) != value:
            self.settings.weights = {**self.settings.weights, name: float(value)}

    def _on_weights(self, *_):
        """A weight set elsewhere (not by its slider) moves the slider when the slider can show it; the value itself
        is never clamped here (the engine judges it)."""
        for name, slider in self.weights.items():
            value = self.settings.weights.get(name)
            if isinstance(value, (int, float)) and slider.start <= value <= slider.end and slider.value != value:
                slider.value = float(value)

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

    def _on_wrist_info(self, *_):
        k = self.settings
        parts = []
        for name in WRISTS:
            pts = k.wrist_points(name)
            state = "on" if name in k.active else "off"
            drawn = f"{len(pts)} points, {path_length(pts):.2f} m" if len(pts) >= 2 else "not drawn"
            cls = "bad" if state == "on" and len(pts) < 2 else "ok" if state == "on" else "note"
            mark = " (drawing)" if name == k.drawing else ""
            parts.append(f'<span class="{cls}">{LABELS[name]} ({COLOR_NAMES[name]}){mark}: {drawn}, {state}</span>')
        self.wrist_info.object = "<br>".join(parts)

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
        self._on_bench()
        active = k.active
        blending = k.method == "blending"
        for name, slider in self.weights.items():
            slider.visible = blending and name in active
        if not active:
            text = '<span class="bad">no control is on: follow the root path or a wrist path</span>'
        elif not blending:
            text = '<span class="note">blend weights apply to fine-tuned models only (not to inpainting)</span>'
        else:
            try:
                shares = k.shares()  # the engine's rule
            except ValueError as exc:  # its one-line message, as Generate would give it
                text = f'<span class="bad">{html.escape(str(exc))}</span>'
            else:
                text = ("blend: " + " + ".join(f"{shares[n]:.2f} × {LABELS[n]}" for n in active)
                        + " (scaled to sum 1)")
        self.shares.object = text

    def _on_bench(self) -> None:
        """Which method the control bench has ahead, and so which one the tab opened on."""
        k = self.settings
        verdict = k.verdict
        if verdict is None:
            self.bench_note.object = ""
            return
        opened = verdict.opening_method(blending_offered=bool(k.available))
        why = ("the bench has blending ahead" if opened == "blending" else
               "the bench does not have blending ahead of inpainting" if k.available else "no control models to blend")
        self.bench_note.object = (f'<span class="note">{html.escape(verdict.message)} The tab opens on '
                                  f'{html.escape(opened)}: {html.escape(why)}.</span>')

    def _on_result(self, *_):
        r = self.settings.result
        if r is None:
            self.readout.object = '<div class="note">No controlled motion yet.</div>'
            return
        rows = table_rows(describe(r))
        guides = "; ".join(filter(None, [
            "red tube: the root path" if r.root_error is not None else "",
            *(f"{COLOR_NAMES[n]} tube: the {LABELS[n]} target" for n in r.wrist_errors)]))
        self.readout.object = (
            f'<div class="control-box"><b>{html.escape(r.name)}</b><br>{html.escape(r.method)} · '
            f'{r.seconds_taken:.1f} s<table class="control-error">{rows}</table>'
            + (f'<div class="warn">{html.escape(r.base_note)}</div>' if r.base_note else "") +
            f'<div class="note">In the viewer: {guides} (the "root path" checkbox hides them).</div></div>')

    def __panel__(self):
        root = pn.Column(pn.Row(self.use_root, self.clear_root, self.example_root), self.top.view, self.root_info,
                         sizing_mode="stretch_width")
        wrist = pn.Column(pn.Row(*self.use_wrists.values()), self.wrist_box, sizing_mode="stretch_width")
        return pn.Column(
            pn.pane.Markdown(HELP, styles={"font-size": "12px", "color": "#444"}, margin=(0, 10)),
            self.base_note, pn.Row(self.prompt, self.seconds, sizing_mode="stretch_width"), self.flag,
            "#### Root path (top-down)", root, "#### Wrist paths (front view)", wrist,
            "#### Method", self.method, self.bench_note, self.method_note, *self.weights.values(), self.shares,
            self.planted_feet, self.bar, self.readout, css_classes=["control-tab"], sizing_mode="stretch_width")


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
