"""``JobBar``: a tab's Run button, Cancel, progress bar and status line for the session's shared worker.

The bar shows progress only for its own jobs (``jobs``: the ``what`` names of their ``JobDescription``);
any running job disables Run (one job per session) and enables Cancel.
"""
from __future__ import annotations

import html
from collections.abc import Callable

import panel as pn
import param

from app.session.state import StudioState


class JobBar(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    jobs = param.List(default=[], item_type=str, doc="the job names this bar reports on")
    label = param.String(default="Generate")
    prefix = param.String(default="job", doc="css class prefix: <prefix>-run, -cancel, -progress, -status")
    busy_label = param.String(default="", doc="Run's label while this bar's job runs ('' = unchanged)")

    def __init__(self, *, on_run: Callable[[], object], blocked: Callable[[], bool] | None = None, **params):
        """``blocked()``: True while the tab's input cannot run (e.g. a prompt the engine refuses); call :meth:`refresh`
        when what it reads changes."""
        super().__init__(**params)
        self._blocked = blocked
        p = self.prefix
        self.run = pn.widgets.Button(label=self.label, color="primary", css_classes=[f"{p}-run"],
                                     sizing_mode="stretch_width")
        self.cancel = pn.widgets.Button(label="Cancel", color="warning", disabled=True, width=90,
                                        css_classes=[f"{p}-cancel"])
        self.progress = pn.indicators.Progress(value=0, max=1, bar_color="primary", height=12,
                                               sizing_mode="stretch_width", css_classes=[f"{p}-progress"])
        self.status = pn.pane.Markdown("", css_classes=[f"{p}-status"], margin=(0, 10))
        self.run.on_click(lambda _: on_run())
        self.cancel.on_click(lambda _: self.state.cancel())
        self.state.param.watch(self.refresh, ["running", "progress", "progress_total", "status", "job"])
        self.refresh()

    def clear(self) -> None:
        """The tab's mode changed: its finished job's status line goes (running work keeps its own)."""
        s = self.state
        if not s.running and s.job in self.jobs:
            s.status = ""

    def refresh(self, *_):
        s = self.state
        mine = s.job in self.jobs
        with pn.io.hold():  # one message to the page, not one per widget
            self.progress.max = max(1, s.progress_total)
            self.progress.value = min(s.progress, self.progress.max) if mine and s.running else 0  # empty when idle
            self.status.object = html.escape(s.status) if mine else ""
            self.cancel.disabled = not s.running
            self.run.disabled = s.running or (self._blocked is not None and bool(self._blocked()))
            if self.busy_label:
                self.run.label = self.busy_label if s.running and mine else self.label

    def __panel__(self):
        return pn.Column(pn.Row(self.run, self.cancel, sizing_mode="stretch_width"), self.progress, self.status,
                         sizing_mode="stretch_width")


def on_text(widget, fn: Callable[[str], object]) -> None:
    """Call ``fn(text)`` as a text input changes, key by key and on Enter. Param hands a watcher of two
    parameters every event of a batch at once (the browser may send ``value_input`` and ``value`` together):
    the newest text wins."""
    widget.param.watch(lambda *events: fn(events[-1].new or ""), ["value", "value_input"])


def text_from_param(parameter: param.Parameter, *, widget_type=pn.widgets.TextInput, **params):
    """A text input (``widget_type``) made from a String parameter (``from_param``: linked both ways) that also
    writes it key by key, as the text is typed (``value_input``)."""
    widget = widget_type.from_param(parameter, **params)
    owner, name = parameter.owner, parameter.name
    on_text(widget, lambda text: setattr(owner, name, text))
    return widget


def table_rows(rows) -> str:
    """HTML rows of (label, value) pairs for a tab's readout table (values in the ``value`` class)."""
    return "".join(f'<tr><td>{html.escape(a)}</td><td class="value">{html.escape(b)}</td></tr>' for a, b in rows)


# a row of word buttons wraps inside its tab instead of running off its right edge
WRAP_BUTTONS_CSS = """
.bk-btn-group { flex-wrap: wrap; row-gap: 4px; }
.bk-btn-group > .bk-btn { flex: 0 0 auto; }
"""

