"""The Compose tab (DoubleTake): a timeline of intervals (prompt + seconds, add / remove / move) with a handshake
length between each two (one widget per transition), the second take, Generate with progress and cancel; the long
motion in the viewer, coloured per interval with the transitions highlighted, and a timeline strip of the result
(click it to move the viewer there).

The settings live on the session (a ``ComposeSettings``, handed to the tab by the page); the widgets are made from
them.
"""
from __future__ import annotations

import html
import inspect

import panel as pn
import param
from bokeh.events import Tap
from bokeh.models import ColumnDataSource, LabelSet, Range1d, Span
from bokeh.plotting import figure

from app.components.bokeh_writes import sends_bokeh
from app.components.jobbar import JobBar, on_text
from app.components.number_box import FloatBox, IntBox
from app.components.words import WORD_CSS, prompt_notes
from app.session.state import StudioState
from app.tabs.compose.job import FPS, INTERVAL_COLORS, TRANSITION_COLOR, ComposeJob, transition_at
from app.tabs.compose.settings import HANDSHAKE, ComposeSettings
from engine.units import MAX_SECONDS

# what an emptied interval length becomes (a new row's length)
DEFAULT_SECONDS = float(inspect.signature(ComposeSettings.add).parameters["seconds"].default)

HELP = ("Each interval is generated as its own clip; consecutive clips share a **handshake** (the end of one is the "
        "start of the next; its length is set per transition, between the rows), so the long motion lasts the sum of "
        "the intervals minus the handshakes. The **second take** re-denoises every transition with the neighbouring "
        "intervals around it, through soft masks (the handshake may change a lot, the intervals little), without "
        "text as in the authors' code, or *with text* (\"A, then B\"), and keeps a foot on the floor still there "
        "(*keep planted feet still*; off: the paper's second take). Seed, steps and guidance come from the "
        "sidebar. **Timeline from a sentence**: actions in order (\"walks forward, then jumps\"), one row per clause, "
        "each as long as the Generate box makes it.")


class IntervalRowView:
    """The widgets of one timeline row (index i of the settings' intervals)."""

    def __init__(self, tab: "ComposeTab", index: int):
        row = tab.settings.intervals[index]
        self.index = index
        self.prompt = pn.widgets.TextInput(value=row.prompt, placeholder="a person walks forward",
                                           css_classes=["compose-prompt"], sizing_mode="stretch_width")
        self.seconds = FloatBox(value=row.seconds, start=0.5, end=MAX_SECONDS, step=0.5, width=70,
                                empty=DEFAULT_SECONDS, css_classes=["compose-seconds"])  # emptied: the default
        self.up = pn.widgets.Button(label="↑", width=34, css_classes=["compose-up"])
        self.down = pn.widgets.Button(label="↓", width=34, css_classes=["compose-down"])
        self.remove = pn.widgets.Button(label="✕", width=34, css_classes=["compose-remove"])
        self.flag = pn.pane.HTML("", margin=(0, 10), stylesheets=[WORD_CSS], css_classes=["compose-flag"])
        on_text(self.prompt, lambda text: tab.edit_row(self.index, prompt=text))
        self.seconds.param.watch(lambda e: tab.edit_row(self.index, seconds=e.new), "value")
        self.up.on_click(lambda _: tab.settings.move(self.index, -1))
        self.down.on_click(lambda _: tab.settings.move(self.index, +1))
        self.remove.on_click(lambda _: tab.remove_row(self.index))
        self.label = pn.pane.Markdown(f"**{index + 1}**", width=22, margin=(12, 2))
        self.view = pn.Column(pn.Row(self.label, self.prompt, self.seconds, self.up, self.down, self.remove,
                                     sizing_mode="stretch_width"), self.flag,
                              css_classes=["compose-row"], sizing_mode="stretch_width", margin=0)


class TransitionView:
    """The handshake widget of transition k (between timeline rows k and k + 1), in frames."""

    def __init__(self, tab: "ComposeTab", index: int):
        self.index = index
        lo, hi = HANDSHAKE.bounds
        self.frames = IntBox(value=tab.settings.handshake_frames()[index], start=int(lo), end=int(hi), step=5,
                             width=80, empty=int(HANDSHAKE.default), css_classes=["compose-handshake"])
        self.label = pn.pane.Markdown("", css_classes=["compose-handshake-label"], margin=(8, 6))
        self.frames.param.watch(lambda e: tab.edit_handshake(self.index, e.new, e.old), "value")
        self.view = pn.Row(pn.pane.Markdown(f"⇅ handshake {index + 1}", margin=(8, 6, 8, 30), width=120),
                           self.frames, self.label, css_classes=["compose-transition"], sizing_mode="stretch_width",
                           margin=0)
        self.show(self.frames.value)

    def show(self, frames: int) -> None:
        self.label.object = f"frames ({frames / FPS:.2f} s)" + (" — a plain cut" if frames == 0 else "")


class ComposeTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=ComposeSettings, doc="the session's Compose settings")

    def __init__(self, **params):
        super().__init__(**params)
        c = self.settings
        self._syncing = False
        self.rows: list[IntervalRowView] = []
        self.transitions: list[TransitionView] = []
        self.rows_box = pn.Column(sizing_mode="stretch_width", css_classes=["compose-rows"])
        self.add = pn.widgets.Button(label="+ Add interval", width=140, css_classes=["compose-add"])
        self.add.on_click(lambda _: c.add())
        # a sentence of actions in order as the timeline: one interval per clause (what the Generate box joins)
        self.sentence = pn.widgets.TextInput(placeholder="a person walks forward, then jumps, then claps",
                                             css_classes=["compose-sentence"], sizing_mode="stretch_width")
        self.fill = pn.widgets.Button(label="Timeline from a sentence", width=190, css_classes=["compose-fill"])
        self.fill.on_click(lambda _: self.from_sentence(self.sentence.value_input or self.sentence.value))
        self.sentence.param.watch(lambda _: self.from_sentence(self.sentence.value), "enter_pressed")
        self.second_take = pn.widgets.Checkbox.from_param(c.param.second_take, css_classes=["compose-second-take"])
        self.second_take_text = pn.widgets.Checkbox.from_param(c.param.second_take_text, disabled=not c.second_take,
                                                               css_classes=["compose-second-take-text"])
        self.planted_feet = pn.widgets.Checkbox.from_param(c.param.second_take_planted_feet, disabled=not c.second_take,
                                                           css_classes=["compose-planted-feet"])
        for box in (self.second_take_text, self.planted_feet):  # the second take's own options, greyed out without it
            c.param.watch(lambda e, box=box: setattr(box, "disabled", not e.new), "second_take")
        self.length = pn.pane.Markdown("", css_classes=["compose-length"], margin=(0, 10))
        self.bar = JobBar(state=self.state, jobs=["composition"], label="Generate long motion", prefix="compose",
                          on_run=self.generate, blocked=c.refused)
        self.result = pn.pane.HTML("", css_classes=["compose-result"], margin=(0, 10), stylesheets=[_CSS])
        self.jumps = pn.Row(css_classes=["compose-jumps"], sizing_mode="stretch_width")
        self._build_strip()
        self.strip_pane = pn.pane.Bokeh(self.strip, margin=(0, 10), css_classes=["compose-strip"])
        c.param.watch(self._on_intervals, ["intervals", "handshakes"])
        c.param.watch(self._on_length, ["intervals", "handshakes"])
        c.param.watch(self._on_result, "result")
        self.state.param.watch(self._on_frame, ["frame", "current"])
        self.state.param.watch(self._on_length, "prompt_words")  # a model loaded late: unknown words change
        self._on_intervals()
        self._on_length()
        self._on_result()

    # ------------------------------------------------------------------ widgets -> settings
    def generate(self) -> bool:
        return self.state.launch(ComposeJob(session=self.state, settings=self.settings))

    def from_sentence(self, text: str) -> None:
        try:
            self.settings.from_sentence(text or "", tempo=self.state.count_tempo())
        except ValueError as exc:
            self.state.error(str(exc))

    def edit_row(self, index: int, *, prompt: str | None = None, seconds: float | None = None) -> None:
        if self._syncing or index >= len(self.settings.intervals):
            return
        if seconds is None and prompt is None:
            return
        self.settings.edit(index, prompt=prompt, seconds=seconds)

    def edit_handshake(self, index: int, frames, old=None) -> None:
        """A transition's widget changed: into the settings, or the error shown and the widget put back."""
        if self._syncing or index >= len(self.settings.handshakes):
            return
        try:
            self.settings.set_handshake(index, frames)
        except ValueError as exc:
            self.state.error(str(exc))
            self._syncing = True
            try:
                self.transitions[index].frames.value = self.settings.handshake_frames()[index]
            finally:
                self._syncing = False

    def remove_row(self, index: int) -> None:
        try:
            self.settings.remove(index)
        except ValueError as exc:
            self.state.error(str(exc))

    # ------------------------------------------------------------------ settings -> widgets
    def _on_intervals(self, *_):
        rows = self.settings.intervals
        hs = self.settings.handshake_frames()
        if len(rows) != len(self.rows):
            self._syncing = True
            try:
                self.rows = [IntervalRowView(self, i) for i in range(len(rows))]
                self.transitions = [TransitionView(self, k) for k in range(len(hs))]
            finally:
                self._syncing = False
            views = [self.rows[0].view]
            for t, r in zip(self.transitions, self.rows[1:]):
                views += [t.view, r.view]
            self.rows_box.objects = views
        self._syncing = True
        try:
            for view, frames in zip(self.transitions, hs):
                if view.frames.value != frames:
                    view.frames.value = frames
                view.show(frames)
            for view, row in zip(self.rows, rows):
                if view.prompt.value != row.prompt:
                    view.prompt.value = row.prompt
                if view.seconds.value != row.seconds:
                    view.seconds.value = row.seconds
                view.up.disabled = view.index == 0
                view.down.disabled = view.index == len(rows) - 1
                view.remove.disabled = len(rows) == 1
        finally:
            self._syncing = False
        for view, reading in zip(self.rows, self.settings.readings()):
            view.flag.object = prompt_notes(reading)  # what the engine will do with the words it does not know
            view.flag.visible = bool(view.flag.object)
        self.bar.refresh()

    def _on_length(self, *_):
        c = self.settings
        n = c.expected_frames()
        k = max(0, len(c.intervals) - 1)
        total = sum(r.seconds for r in c.intervals)
        hs = c.handshake_frames()
        said = (f"{hs[0]} frames" if len(set(hs)) == 1 else " + ".join(map(str, hs)) + " frames") if hs else "0 frames"
        self.length.object = (f"Long motion: **{n} frames ({n / FPS:.1f} s)** = {total:g} s of intervals − {k} "
                              f"handshake{'s' * (k != 1)} of {said}")

    @sends_bokeh
    def _on_result(self, *_):
        r = self.settings.result
        if r is None:
            self.result.object = '<div class="compose-empty">No long motion yet: build the timeline and press ' \
                                 '<i>Generate long motion</i>.</div>'
            self.strip_src.data, self.hand_src.data = _empty_intervals(), _empty_transitions()
            self.jumps.objects = []
            return
        said = [w for w, on in (("with text", r.second_take_text), ("planted feet", r.planted_feet)) if on]
        take = ("first + second take" + (f" ({', '.join(said)})" if said else "")) if r.second_take \
            else "first take only"
        spans = ", ".join(f"{a}–{b - 1}" if b > a else f"a cut at {a}" for a, b in r.transitions) or "none"
        lengths = sorted(set(r.handshakes), key=r.handshakes.index)
        hand = (f"handshake {lengths[0]} frames" if len(lengths) == 1 else
                f"handshakes {', '.join(map(str, r.handshakes))} frames") if lengths else "no handshake"
        self.result.object = (
            f'<div class="compose-box"><b>{html.escape(r.name)}</b><br>'
            f'<span class="compose-frames">{r.n_frames} frames ({r.n_frames / FPS:.1f} s of motion)</span> · '
            f'<span class="compose-wall">wall time {r.seconds_taken:.1f} s</span> · {take}<br>'
            f'<span class="compose-transitions">transitions ({hand}): {spans}</span>'
            f'<div class="compose-legend"><span style="color:{INTERVAL_COLORS[0]}">■</span>'
            f'<span style="color:{INTERVAL_COLORS[1]}">■</span> intervals · '
            f'<span style="color:{TRANSITION_COLOR}">■</span> transitions (skeleton and strip)</div></div>')
        self.strip_src.data = dict(left=r.starts, right=r.ends, color=[INTERVAL_COLORS[i % 2] for i in range(len(r.starts))],
                                   label=[f"{i + 1}. {p}" for i, p in enumerate(r.prompts)],
                                   middle=[(a + b) / 2 for a, b in zip(r.starts, r.ends)],
                                   y=[0.62 if i % 2 == 0 else 0.18 for i in range(len(r.starts))])
        self.hand_src.data = dict(left=[a for a, _ in r.transitions], right=[b for _, b in r.transitions])
        self.strip.x_range.start, self.strip.x_range.end = 0, max(1, r.n_frames)
        buttons = []
        for k, (a, b) in enumerate(r.transitions):
            button = pn.widgets.Button(label=f"▶ transition {k + 1} ({a}–{b - 1})" if b > a else
                                       f"▶ cut {k + 1} ({a})", width=170,
                                       css_classes=["compose-jump"])
            button.on_click(lambda _, a=a: self.jump(a))
            buttons.append(button)
        self.jumps.objects = buttons
        self._on_frame()

    @sends_bokeh
    def _on_frame(self, *_):
        r = self.settings.result
        mine = r is not None and self.state.current == r.name
        self.playhead.visible = mine
        if mine:
            self.playhead.location = self.state.frame
            k = transition_at(r, self.state.frame)
            self.strip.title.text = (f"frame {self.state.frame}" + (f" — in transition {k + 1}" if k is not None
                                                                     else "") + " (click to move the viewer)")

    # ------------------------------------------------------------------ the timeline strip
    def _build_strip(self) -> None:
        self.strip_src = ColumnDataSource(_empty_intervals())
        self.hand_src = ColumnDataSource(_empty_transitions())
        fig = figure(height=120, width=560, tools="", toolbar_location=None, x_range=Range1d(0, 1),
                     y_range=Range1d(-0.1, 1.1), title="Timeline (click to move the viewer)", x_axis_label="frame",
                     css_classes=["compose-timeline"])
        fig.quad(left="left", right="right", bottom=0.05, top=0.95, color="color", alpha=0.35, source=self.strip_src)
        fig.quad(left="left", right="right", bottom=-0.05, top=1.05, color=TRANSITION_COLOR, alpha=0.55,
                 hatch_pattern="/", hatch_color="white", source=self.hand_src)
        fig.add_layout(LabelSet(x="left", y="y", text="label", x_offset=4, source=self.strip_src,
                                text_font_size="11px", text_color="#223"))
        self.playhead = Span(location=0, dimension="height", line_color="#111", line_width=2, visible=False,
                             level="overlay")
        fig.add_layout(self.playhead)
        self.state.follow_playhead(self.playhead)
        fig.yaxis.visible = False
        fig.ygrid.visible = False
        fig.title.text_font_size = "11px"
        fig.on_event(Tap, lambda event: self.jump(event.x))
        self.strip = fig

    def jump(self, frame) -> None:
        """Show the long motion at ``frame`` (a click on the strip or a transition button)."""
        r = self.settings.result
        if r is None or frame is None:
            return
        if r.name not in self.state.items:
            self.state.error("the long motion is no longer in the session: generate it again")
            return
        if self.state.current != r.name:
            self.state.show(r.name)
        self.state.pick_frame(int(round(float(frame))))

    def __panel__(self):
        return pn.Column(
            pn.pane.Markdown(HELP, styles={"font-size": "12px", "color": "#444"}, margin=(0, 10)),
            "#### Timeline", pn.Row(self.sentence, self.fill, sizing_mode="stretch_width"), self.rows_box, self.add,
            self.length,
            pn.Row(self.second_take, self.second_take_text, self.planted_feet, sizing_mode="stretch_width"),
            self.bar, self.result, self.strip_pane, self.jumps,
            css_classes=["compose-tab"], sizing_mode="stretch_width")


def _empty_intervals() -> dict:
    return dict(left=[], right=[], color=[], label=[], middle=[], y=[])


def _empty_transitions() -> dict:
    return dict(left=[], right=[])


_CSS = """
.compose-box { font-size: 13px; line-height: 1.5; }
.compose-empty, .compose-legend { color: #555; font-size: 12px; }
"""
