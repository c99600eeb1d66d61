"""The Transfer tab (MoMo, "Monkey See, Monkey Do"): a leader (what and when) and a follower (how), each a prompt
or an imported motion; layer and step windows; run off the UI thread with progress and cancel; then leader /
follower / out side by side in the viewer and the analysis views (``app.tabs.transfer.plots``).

All settings live on the tab's ``settings`` (the session's ``app.tabs.transfer.settings.TransferSettings``, handed over
by the page); the widgets only mirror it. The transfer itself is a ``TransferJob`` launched on the session (checks,
then the shared worker).
"""
from __future__ import annotations

import html

import panel as pn
import param

from app.components.jobbar import JobBar, text_from_param
from app.components.number_box import FloatBox
from app.components.words import WORD_CSS, word_chips
from app.session.state import StudioState
from app.tabs.transfer.job import TransferJob, describe_inversion, own_description, show_roles
from app.tabs.transfer.plots import TransferPlots
from app.tabs.transfer.settings import SourceSettings, TransferSettings

NO_MOTION = "(import a motion)"


def _md(text: str) -> str:
    """A user's text inside Markdown, shown as typed (quoted, its markup characters escaped)."""
    return "“" + "".join("\\" + ch if ch in "\\`*_{}[]()#+-.!|~" else ch for ch in html.escape(text)) + "”"


HELP = {"leader": "**Leader**: what and when (outline, timing).", "follower": "**Follower**: how (motifs)."}


class SourcePicker(pn.viewable.Viewer):
    """One source: a prompt (read as the engine reads it, with its notes) with its seconds, or an imported motion (+ an optional
    description) that is DDIM-inverted when the transfer runs."""

    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=TransferSettings, doc="the session's Transfer settings (its last result)")
    source = param.ClassSelector(class_=SourceSettings)

    def __init__(self, **params):
        super().__init__(**params)
        src = self.source
        self.kind = pn.widgets.RadioButtonGroup.from_param(src.param.kind, color="primary", variant="outline",
                                                           css_classes=["source-kind"])
        self.prompt = text_from_param(src.param.prompt, css_classes=["source-prompt"], sizing_mode="stretch_width")
        self.words = pn.pane.HTML("", css_classes=["source-words"], margin=(0, 10), stylesheets=[WORD_CSS])
        self.seconds = FloatBox.from_param(src.param.seconds, width=90, css_classes=["source-seconds"])
        self.motion = pn.widgets.Select(label="Imported motion", options=[NO_MOTION], css_classes=["source-motion"],
                                        sizing_mode="stretch_width")
        self.upload = pn.widgets.FileInput(accept=".bvh,.npy", multiple=False, css_classes=["source-upload"],
                                           sizing_mode="stretch_width")
        self.info = pn.pane.Markdown("", css_classes=["source-info"], margin=(0, 10),
                                     styles={"font-size": "12px", "color": "#444"})
        self.motion.param.watch(lambda e: setattr(src, "motion", "" if e.new == NO_MOTION else e.new), "value")
        self.upload.param.watch(self._on_upload, ["value", "filename"])
        self._typed = src.prompt if src.kind == "prompt" else ""  # the prompt typed in prompt mode (back when chosen)
        src.param.watch(self._on_source, ["kind", "motion"])  # (before _on_kind: the widgets follow)
        src.param.watch(self._on_kind, ["kind", "motion"])
        src.param.watch(self._on_words, ["reading", "kind"])
        src.param.watch(self._on_info, "prompt")
        self.state.param.watch(self._on_items, "items")
        self.settings.param.watch(self._on_info, "result")
        self._on_items()
        self._on_kind()
        self._on_words()

    def _on_upload(self, *events) -> None:
        """A picked file becomes this role's imported motion, or a one-line message about it by the user's file
        name; an empty file (the browser sends its name and no content) is refused by name, never ignored."""
        from app.uploads import display_name, import_bytes

        data, filename = self.upload.value, self.upload.filename
        if not filename and data is None:
            return  # the field was cleared
        name = display_name(filename)
        if not data:
            self.state.error(f"Could not import {name}: it is empty (0 bytes)")
            return
        if "value" not in {e.name for e in events}:
            return  # a new name only: its content follows
        try:
            item = self.state.show_motion(import_bytes(data, name), title=f"imported: {name}")
        except Exception as exc:  # the user's file, not a crash
            self.state.error(f"Could not import {name}: {exc}")
            return
        self.source.param.update(kind="motion", motion=item.name)

    def _on_items(self, *_):
        names = [n for n, it in self.state.items.items() if it.source == "imported"]
        self.motion.options = names or [NO_MOTION]
        picked = self.source.motion
        self.motion.value = picked if picked in names else (names[-1] if names else NO_MOTION)

    def _on_source(self, *events) -> None:
        """A new imported motion as the source: its description is that motion's own prompt (its recipe) or none,
        never the prompt typed before; back to a prompt, the typed prompt returns."""
        src = self.source
        changed = {e.name: e for e in events}
        if "kind" in changed and changed["kind"].old == "prompt":
            self._typed = src.prompt
        if src.kind == "prompt":
            if "kind" in changed:
                src.prompt = self._typed
            return
        src.prompt = own_description(self.state, src.motion)

    def _on_kind(self, *_):
        src = self.source
        is_prompt = src.kind == "prompt"
        if src.motion and src.motion in self.motion.options and self.motion.value != src.motion:
            self.motion.value = src.motion
        self.prompt.label = "Prompt" if is_prompt else "Description (optional, guides the inversion; empty = read without text)"
        self.prompt.placeholder = "a person walks forward" if is_prompt else "e.g. a person walks"
        self.seconds.visible = is_prompt
        self.motion.visible = self.upload.visible = not is_prompt
        self._on_info()

    def _on_words(self, *_):
        src = self.source
        self.words.object = word_chips(src.reading) if src.reading.words or src.kind == "prompt" else ""

    def _on_info(self, *_):
        src, view = self.source, self.settings.result
        if src.kind == "prompt":
            self.info.object = ""
            return
        item = self.state.items.get(src.motion)
        text = "Import a BVH or .npy motion here or in the sidebar." if item is None else (
            f"{item.n_frames} frames ({item.n_frames / 20:.1f} s), DDIM-inverted when the transfer runs "
            + (f"with the description **{_md(src.prompt.strip())}**." if src.prompt.strip() else
               "**without a description** (read without text)."))
        if view is not None and item is not None and view.inversion.get(src.role):
            text += f" Last run: **{describe_inversion(view.inversion[src.role])}**."
        self.info.object = text

    def __panel__(self):
        return pn.Column(HELP[self.source.role], self.kind, self.prompt, self.words, self.seconds, self.motion,
                         self.upload, self.info, css_classes=[f"transfer-{self.source.role}"], width=285)


class TransferTab(pn.viewable.Viewer):
    state = param.ClassSelector(class_=StudioState)
    settings = param.ClassSelector(class_=TransferSettings, doc="the session's Transfer settings")

    def __init__(self, **params):
        super().__init__(**params)
        s, t = self.state, self.settings
        self.leader = SourcePicker(state=s, settings=t, source=t.leader)
        self.follower = SourcePicker(state=s, settings=t, source=t.follower)
        self.more = text_from_param(t.param.more_followers, widget_type=pn.widgets.TextAreaInput, rows=3,
                                    placeholder="a person runs like a zombie\na person walks and waves",
                                    css_classes=["transfer-more"], sizing_mode="stretch_width")
        layers = self._n_layers()
        default = (min(1, layers - 1), layers - 1)
        self.layers = pn.widgets.IntRangeSlider(label="Layers that mix (0-based)", start=0, end=max(layers - 1, 1),
                                                value=default if t.layers is None else t.layers,
                                                css_classes=["transfer-layers"], sizing_mode="stretch_width")
        self.steps = pn.widgets.RangeSlider.from_param(t.param.steps, css_classes=["transfer-steps"],
                                                       sizing_mode="stretch_width")
        self.root = pn.widgets.RadioButtonGroup.from_param(t.param.root, color="primary", variant="outline",
                                                           css_classes=["transfer-root"])
        self.feet = pn.widgets.Checkbox.from_param(t.param.feet, css_classes=["transfer-feet"])
        self.flights = pn.widgets.Checkbox.from_param(t.param.flights, css_classes=["transfer-flights"])
        self.directions = pn.widgets.IntSlider.from_param(t.param.directions, css_classes=["transfer-directions"],
                                                          sizing_mode="stretch_width")
        self.root_help = pn.pane.Markdown(self._root_help(), css_classes=["transfer-root-help"], margin=(0, 10),
                                          styles={"font-size": "12px", "color": "#444"})
        t.param.watch(lambda *_: setattr(self.root_help, "object", self._root_help()), ["root", "directions"])
        self.bar = JobBar(state=s, jobs=["transfer"], label="Run transfer", busy_label="Running…", prefix="transfer",
                          on_run=lambda: self.state.launch(TransferJob(session=self.state, settings=self.settings)),
                          blocked=self._refused)
        self.run, self.cancel, self.progress, self.status = self.bar.run, self.bar.cancel, self.bar.progress, self.bar.status
        self.result = pn.pane.HTML("", css_classes=["transfer-result"], margin=(0, 10))
        self.show = pn.widgets.Button(label="Show leader / follower / out", css_classes=["transfer-show"],
                                      width=230, disabled=True)
        self.color = pn.widgets.RadioButtonGroup.from_param(t.param.color_by, color="primary", variant="outline",
                                                            css_classes=["transfer-color"])
        self.analysed = pn.widgets.RadioButtonGroup(options={"follower 1": 1}, value=t.analysed, color="primary",
                                                    variant="outline", css_classes=["transfer-analysed"])
        self.analysed_row = pn.Row(pn.pane.Markdown("Analysis of", margin=(8, 10)), self.analysed, visible=False)
        self.plots = TransferPlots(state=s, settings=t)

        self.layers.param.watch(lambda e: self._set("layers", tuple(int(v) for v in e.new)), "value")
        self.analysed.param.watch(lambda e: self._set("analysed", int(e.new)), "value")
        self.show.on_click(lambda _: show_roles(self.state, self.settings))
        for src in (t.leader, t.follower):
            src.param.watch(self.bar.refresh, ["reading", "kind"])
        t.param.watch(self._on_result, "result")
        self._on_result()

    def _root_help(self) -> str:
        """What the chosen root mode and direction count do (their declared help)."""
        from engine.methods.transfer_config import ROOT_CHOICES

        t = self.settings
        text = ROOT_CHOICES[t.root][1]
        if t.directions > 1:
            text += (f". Each out reads {t.directions} copies of its follower (a prompt: other seeds; an imported "
                     "motion: turned copies, each inverted)")
        return text[0].upper() + text[1:] + "."

    def _n_layers(self) -> int:
        try:
            return int(self.state.model.config["model"]["layers"])
        except Exception:
            return 2

    def _set(self, name: str, value) -> None:
        try:
            setattr(self.settings, name, value)
        except ValueError as exc:
            self.state.error(f"{name}: {exc}")

    def _refused(self) -> bool:
        """Run waits while the engine would refuse a source's prompt (words it does not know never block)."""
        t = self.settings
        return any(src.blocked for src in (t.leader, t.follower))

    def _on_result(self, *_):
        view = self.settings.result
        self.show.disabled = view is None
        n = 1 if view is None else view.followers
        self.analysed.options = {f"follower {k}": k for k in range(1, n + 1)}
        self.analysed.value = min(self.settings.analysed, n)
        self.analysed_row.visible = n > 1
        if view is None:
            self.result.object = ""
            return
        parts = [f"<b>{html.escape(view.description)}</b> in {view.seconds_taken:.1f} s"]
        for role in view.frames:
            inv = describe_inversion(view.inversion.get(role))
            extra = f" · <span class='inversion-error'>{html.escape(inv)}</span>" if inv else ""
            parts.append(f"{role}: {view.frames[role]} frames{extra}")
        self.result.object = "<br>".join(parts) + "<br><i>Shown side by side in the viewer.</i>"

    def __panel__(self):
        sources = pn.Row(self.leader, self.follower)
        settings = pn.Column(self.more, self.layers, self.steps, pn.pane.Markdown("Root of the out", margin=(0, 10)),
                             self.root, self.root_help, self.directions, self.feet, self.flights,
                             sizing_mode="stretch_width")
        colours = pn.Row(pn.pane.Markdown("Skeleton colours", margin=(8, 10)), self.color)
        return pn.Column(sources, settings, self.bar, self.result, pn.Row(self.show), colours, self.analysed_row,
                         pn.layout.Divider(), self.plots, css_classes=["transfer-tab"], sizing_mode="stretch_width")
