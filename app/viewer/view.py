"""The skeleton viewer: a 3-D view drawn in the browser (orbit, pan, zoom, playback), live denoising, compare."""
from __future__ import annotations

import panel as pn
import param

from app.components.skeleton_view import SkeletonView
from app.viewer.legend import scene_legend
from app.viewer.scene import SceneSpec, preview_message, scene_message
from app.session.duets import is_duet
from app.session.state import StudioState

NONE = "(none)"


class SkeletonViewer(pn.viewable.Viewer):
    """Play / pause / scrub the session's motion, orbit around it; compare with a second one side by side.

    The server sends the browser one scene per change of what is shown (``scene_message``); every frame,
    camera move and colour lookup happens in the page. While a generation samples, its x̂0 motion is shown
    live (``state.preview``); afterwards the denoising steps can be scrubbed like the frames.
    """

    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        s = self.state
        self.player = SkeletonView(sizing_mode="stretch_width", min_height=420, css_classes=["skeleton-view"],
                                   follow=s.follow, show_path=s.show_path, cursor_ids=list(s.cursor_ids))
        self._spec: SceneSpec | None = None
        self.motion_key = 0
        self._preview_key = 0  # the key of the live preview shown, 0: none
        self._syncing = False

        self.show_select = pn.widgets.Select(label="Motion", options=[], width=215, css_classes=["motion-select"])
        self.compare_select = pn.widgets.Select(label="Compare with", options=[NONE], width=215,
                                                css_classes=["compare-select"])
        self.follow = pn.widgets.Checkbox.from_param(s.param.follow, label="camera follows")
        self.path = pn.widgets.Checkbox.from_param(s.param.show_path, label="root path")
        self.color = pn.widgets.Checkbox.from_param(s.param.color_by_word, label="colour by word attention")
        # the Motion list reads the motion library (when the session has one): search, kind, pin, delete
        self.search = pn.widgets.TextInput.from_param(s.param.motion_search, name="", placeholder="search prompts",
                                                      width=150, css_classes=["motion-search"])
        self.kind = pn.widgets.Select.from_param(s.param.motion_kind, name="", width=120,
                                                 css_classes=["motion-kind"])
        self.pin = pn.widgets.Checkbox(label="pinned", value=False, css_classes=["motion-pin"], align="center",
                                       visible=s.library is not None)
        self.delete = pn.widgets.Button(label="Delete", width=80, css_classes=["motion-delete"],
                                        description="delete the shown motion (from the library too)")
        self.library_line = pn.pane.Str(s.library_status, css_classes=["library-status"], sizing_mode="stretch_width",
                                        styles={"font-size": "11px", "color": "#666"}, visible=s.library is not None,
                                        stylesheets=["pre { white-space: pre-wrap; overflow-wrap: anywhere; "
                                                     "margin: 0; }"])  # a long workspace path wraps
        self.pin.param.watch(self._on_pin, "value")
        self.delete.on_click(lambda _: self.state.current and self.state.delete_motion(self.state.current))
        s.param.watch(lambda e: setattr(self.library_line, "object", e.new), "library_status")
        s.param.watch(self._on_items, ["motion_search", "motion_kind"])
        self.show_select.param.watch(self._on_show_select, "value")
        self.compare_select.param.watch(self._on_compare_select, "value")
        self.player.param.watch(self._on_player_frame, "frame")
        self.player.param.watch(lambda e: setattr(self.state, "playing", e.new), "playing")

        s.param.watch(self._on_items, "items")
        s.param.watch(self._on_current, ["current", "compare", "also"])
        s.param.watch(self._refresh, "frame_colors")
        s.param.watch(self._on_frame, "frame")
        s.param.watch(lambda e: setattr(self.player, e.name, e.new), ["follow", "show_path"])
        s.param.watch(self._refresh, "color_by_word")
        s.param.watch(self._on_word_selection, ["word", "att_step", "head"])
        s.param.watch(self._on_preview, "preview")
        s.param.watch(lambda e: setattr(self.player, "cursor_ids", list(e.new)), "cursor_ids")
        self._on_items()
        self._on_current()

    def spec(self) -> SceneSpec | None:
        s = self.state
        shown = s.shown_items
        if not shown:
            return None
        item = shown[0]
        motions, colors, guides, notes = [], [], [], []
        for it in shown:
            role = _role(it.name, avoid=[r for r, _ in motions])
            motions.append((role, it.joints))
            guides += [(role, color, points) for color, points in it.info.get("guides", ())]
            if it.name in s.frame_colors:
                colors.append((role, s.frame_colors[it.name]))
                notes += [s.color_notes[it.name]] if it.name in s.color_notes else []
        values = s.word_values() if s.color_by_word else None
        title = item.name if len(shown) == 1 else ""
        if values is not None and s.word is not None and item.attention is not None:
            title = f'{item.name}  —  colour: "{item.attention.words[s.word]}"'
        if notes:
            title = notes[0]
        legend = self._legend(item, motions, colors, notes, values)
        return SceneSpec(motions=tuple(motions), frame_values=values,
                         role_colors=tuple(colors), title=title, guides=tuple(guides), together=is_duet(shown),
                         denoising=item.denoising if len(shown) == 1 else None, legend=legend)

    def _legend(self, item, motions, colors, notes, values) -> dict:
        """What the colours of this scene mean (every colour mode has its legend; app.viewer.legend)."""
        s = self.state
        word, why = None, ""
        if values is not None and s.word is not None and item.attention is not None:
            word = item.attention.words[s.word]
        elif s.color_by_word:
            why = "no recorded attention" if item.attention is None else "pick a word (Attention tab)"
        return scene_legend(roles=[r for r, _ in motions], role_colors=tuple(colors), note=notes[0] if notes else "",
                            names=s.color_names,
                            word=word, values=values if word is not None else None, word_wanted=s.color_by_word,
                            why_no_word=why)

    def _refresh(self, *_):
        spec = self.spec()
        if spec is None or not spec.same_motions(self._spec):
            self.motion_key += 1
        self._spec = spec
        frame = 0 if spec is None else min(self.state.frame, spec.n_frames - 1)
        with param.parameterized.batch_call_watchers(self.player):
            self.player.frame = frame
            self.player.scene = scene_message(spec, key=self.motion_key, job=self.state.last_job)

    # ------------------------------------------------------------------ events
    def _on_preview(self, event) -> None:
        p = event.new
        if p is None:
            if self._preview_key > self.motion_key:  # no result took its place (cancelled, failed)
                self.player.end_preview()
            self._preview_key = 0
            return
        # the preview's key is the next scene's: a result shown later supersedes it, a late preview is dropped
        self._preview_key = self.motion_key + 1
        self.player.preview(preview_message(p.joints, key=self._preview_key, step=p.step, num_steps=p.num_steps,
                                            title=p.title))

    def _on_items(self, *_):
        names = self.state.listed_names()
        self.show_select.options = names
        self.compare_select.options = [NONE, *names]
        self._sync_selects()

    def _sync_selects(self):
        s = self.state
        self._syncing = True
        try:
            if s.current in self.show_select.options:
                self.show_select.value = s.current
            self.compare_select.value = s.compare if s.compare in self.compare_select.options else NONE
            item = s.item
            self.pin.value = bool(item is not None and item.pinned)
            self.pin.disabled = item is None or not item.library_id
            self.delete.disabled = item is None
        finally:
            self._syncing = False

    def _on_pin(self, event):
        if not self._syncing and self.state.current:
            if not self.state.pin_motion(self.state.current, event.new):
                self._sync_selects()

    def _on_show_select(self, event):
        if not self._syncing and event.new and event.new != self.state.current:
            self.state.show(event.new)

    def _on_compare_select(self, event):
        if self._syncing:
            return
        value = "" if event.new in (None, NONE) or event.new == self.state.current else event.new
        self.state.compare = value
        if event.new == self.state.current:
            self._sync_selects()

    def _on_current(self, *_):
        s = self.state
        if s.motion_search or s.motion_kind or (s.current and s.current not in self.show_select.options):
            self._on_items()  # the list filtered: the motion shown is always listed, the one left is not
        self._sync_selects()
        self._refresh()

    def _on_word_selection(self, *_):
        if self.state.color_by_word:
            self._refresh()

    def _on_frame(self, event):
        if self.player.frame != event.new:
            self.player.frame = event.new
        else:
            self.player.param.trigger("frame")  # player.frame was stale: push it anyway

    def _on_player_frame(self, event):
        if event.new != self.state.frame:
            self.state.pick_frame(event.new)

    def close(self) -> None:
        self.player.closed = True

    def __panel__(self):
        controls = pn.Row(self.follow, self.path, self.color, align="center")
        selects = pn.Row(self.show_select, self.compare_select)
        library = pn.Row(self.search, self.kind, self.pin, self.delete, css_classes=["motion-library"])
        return pn.Column(selects, library, self.library_line, self.player, controls, sizing_mode="stretch_width",
                         css_classes=["viewer"])


def _role(name: str, avoid: list[str] | tuple[str, ...] = ()) -> str:
    base = name if len(name) <= 40 else name[:39] + "…"
    role, k = base, 2
    while role in avoid:
        role, k = f"{base} ({k})", k + 1
    return role
