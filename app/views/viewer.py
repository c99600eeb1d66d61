"""The skeleton viewer: server-rendered pyvista frames played in the browser, compare, camera controls."""
from __future__ import annotations

import panel as pn
import param

from app.components.player import FramePlayer
from app.session.duets import is_duet
from app.frames import FrameBatch, FrameRenderer, SceneSpec
from app.session.state import StudioState

NONE = "(none)"


class SkeletonViewer(pn.viewable.Viewer):
    """Play / pause / scrub the session's motion; compare with a second one side by side.

    One ``SkeletonScene`` per session lives on the renderer's thread; it is rebuilt only when the
    motions change, and follow / path / colours / camera are updated in place (then frames re-render).
    """

    state = param.ClassSelector(class_=StudioState)

    def __init__(self, **params):
        super().__init__(**params)
        s = self.state
        self.player = FramePlayer(sizing_mode="stretch_width", min_height=400, css_classes=["skeleton-view"])
        self.player.on_hello = self._resend
        self.player.on_need = lambda k: self.renderer.prioritize(k)
        self.player.on_frame = self._on_playhead
        self._playhead = None  # frame reported by the playing page (player.frame is then stale)
        self.renderer = FrameRenderer(on_frames=self._on_frames)
        self._azimuth = 0.0
        self._camera_serial = 0
        self._syncing = False

        self.show_select = pn.widgets.Select(label="Motion", options=[], width=215, css_classes=["motion-select"])
        self.compare_select = pn.widgets.Select(label="Compare with", options=[NONE], width=215,
                                                css_classes=["compare-select"])
        self.follow = pn.widgets.Checkbox.from_param(s.param.follow, label="camera follows")
        self.path = pn.widgets.Checkbox.from_param(s.param.show_path, label="root path")
        self.color = pn.widgets.Checkbox.from_param(s.param.color_by_word, label="colour by word attention")
        self.reset = pn.widgets.Button(label="Reset camera", width=110, css_classes=["reset-camera"])
        self.left = pn.widgets.Button(label="⟲ 45°", width=64, css_classes=["orbit-left"])
        self.right = pn.widgets.Button(label="⟳ 45°", width=64, css_classes=["orbit-right"])
        self.reset.on_click(lambda _: self._camera(reset=True))
        self.left.on_click(lambda _: self._camera(delta=-45.0))
        self.right.on_click(lambda _: self._camera(delta=45.0))
        self.show_select.param.watch(self._on_show_select, "value")
        self.compare_select.param.watch(self._on_compare_select, "value")
        self.player.param.watch(self._on_player_frame, "frame")
        self.player.param.watch(lambda e: setattr(self.state, "playing", e.new), "playing")

        s.param.watch(self._on_items, "items")
        s.param.watch(self._on_current, ["current", "compare", "also"])
        s.param.watch(self._refresh, "frame_colors")
        s.param.watch(self._on_frame, "frame")
        s.param.watch(self._refresh, ["follow", "show_path", "color_by_word"])
        s.param.watch(self._on_word_selection, ["word", "att_step", "head"])
        self._on_items()
        self._on_current()

    # ------------------------------------------------------------------ renderer plumbing
    def _on_frames(self, batch: FrameBatch) -> None:
        self.player.push(batch)

    def _resend(self) -> None:
        snap = self.renderer.snapshot()
        if snap.frames:
            self.player.push(snap)

    def spec(self) -> SceneSpec | None:
        s = self.state
        shown = s.shown_items
        if not shown:
            return None
        item = shown[0]
        motions, colors, guides = [], [], []
        for it in shown:
            role = _role(it.name, avoid=[r for r, _ in motions])
            motions.append((role, it.joints))
            guides += [(role, color, points) for color, points in it.info.get("guides", ())]
            if it.name in s.frame_colors:
                colors.append((role, s.frame_colors[it.name]))
        values = s.word_values() if s.color_by_word else None
        title = item.name if len(shown) == 1 else ""
        if values is not None and s.word is not None and item.attention is not None:
            title = f'{item.name}  —  colour: "{item.attention.words[s.word]}"'
        if colors and s.transfer.color_by != "roles":
            title = f"colour: {s.transfer.color_by} (legend in the Transfer tab)"
        return SceneSpec(motions=tuple(motions), follow=s.follow, show_path=s.show_path, frame_values=values,
                         role_colors=tuple(colors), azimuth_offset=self._azimuth, camera_serial=self._camera_serial,
                         title=_fit(title), guides=self._same_guides(tuple(guides)), together=is_duet(shown))

    def _same_guides(self, guides: tuple) -> tuple:
        """The previous tuple when the guides did not change (the renderer redraws them on a new object only)."""
        old = getattr(self, "_guides", ())
        same = len(old) == len(guides) and all(a[0] == b[0] and a[2] is b[2] for a, b in zip(old, guides))
        self._guides = old if same else guides
        return self._guides

    def _refresh(self, *_):
        spec = self.spec()
        self.player.n_frames = 0 if spec is None else spec.n_frames
        key = self.renderer.motion_key
        self.renderer.show(spec, frame=self.state.frame)
        if spec is not None and self.renderer.motion_key != key:
            self.player.announce(motion_key=self.renderer.motion_key, version=self.renderer.version,
                                 n_frames=spec.n_frames, title=spec.title or " | ".join(r for r, _ in spec.motions))

    # ------------------------------------------------------------------ events
    def _camera(self, *, reset: bool = False, delta: float = 0.0) -> None:
        if reset:
            self._azimuth = 0.0
        self._azimuth += delta
        self._camera_serial += 1
        self._refresh()

    def _on_items(self, *_):
        names = list(self.state.items)
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
        finally:
            self._syncing = False

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
        self._sync_selects()
        self._refresh()

    def _on_word_selection(self, *_):
        if self.state.color_by_word:
            self._refresh()

    def _on_playhead(self, frame: int) -> None:
        # a custom message from the page arrives outside the document's lock: the change is scheduled on the
        # session's document (changing it here raised "_pending_writes should be non-None" during playback)
        def apply() -> None:
            self._playhead = frame
            self.state.pick_frame(frame)

        self.state.post(apply)

    def _on_frame(self, event):
        self.renderer.prioritize(event.new)
        if self._playhead is not None and self._playhead == event.new:
            return  # the page told us: nothing to send back
        self._playhead = None
        if self.player.frame != event.new:
            self.player.frame = event.new
        else:
            self.player.param.trigger("frame")  # player.frame was stale: push it anyway

    def _on_player_frame(self, event):
        if event.new != self.state.frame:
            self.state.pick_frame(event.new)

    def close(self) -> None:
        self.player.closed = True
        self.renderer.close()

    def __panel__(self):
        controls = pn.Row(self.follow, self.path, self.reset, self.left, self.right, align="center")
        selects = pn.Row(self.show_select, self.compare_select)
        return pn.Column(selects, self.player, controls, self.color, sizing_mode="stretch_width",
                         css_classes=["viewer"])


TITLE_CHARS = 42  # what fits left of the "frame N / M" label on the 480-px picture


def _fit(title: str) -> str:
    return title if len(title) <= TITLE_CHARS else title[: TITLE_CHARS - 1] + "…"


def _role(name: str, avoid: list[str] | tuple[str, ...] = ()) -> str:
    base = name if len(name) <= 40 else name[:39] + "…"
    role, k = base, 2
    while role in avoid:
        role, k = f"{base} ({k})", k + 1
    return role
