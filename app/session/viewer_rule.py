"""The session core's viewer rule: what the viewer shows (the current motion, the one compared with it, more side by
side, their frame colours, the playhead, the live x̂0 preview) and the attention selection that goes with the shown
motion. ``ViewerRule`` is one part of ``StudioState``; the viewer (``app.viewer``) reads it, no tab drives the viewer
directly: a job's ``Delivery`` says what to show and the job runner shows it through :meth:`ViewerRule.show`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import param

from app.attention_record import AttentionRecord
from app.session.items import MotionItem


@dataclass(frozen=True, eq=False)
class Preview:
    """The running generation's current x̂0 motion (what the viewer shows live while sampling)."""

    step: int  # sampling steps done
    num_steps: int
    joints: np.ndarray  # (T, 22, 3)
    title: str


class ViewerRule(param.Parameterized):
    """What is shown: ``current``, then ``compare``, then ``also`` side by side; the playhead; the attention
    selection of the shown motion. Reads the motion list (``items``, ``_readable``) of the session it is part of."""

    current = param.String(default="", doc="name of the motion shown (and whose attention is explored)")
    compare = param.String(default="", doc="name of a second motion shown side by side ('' = none)")
    also = param.List(default=[], item_type=str, doc="more motions shown side by side after the compared one "
                                                       "(e.g. a transfer's output); cleared when another is shown")
    frame_colors = param.Dict(default={}, doc="motion name -> (T, 3) uint8 colour per frame (e.g. Q/K clusters)")
    color_notes = param.Dict(default={}, doc="motion name -> what its frame colours mean (the viewer's title while "
                                             "it is shown with them)")
    color_names = param.Dict(default={}, doc="'#rrggbb' -> what that frame colour stands for, set by the tab that "
                                             "paints it (the viewer's legend names its swatches by it)")
    preview = param.ClassSelector(class_=Preview, default=None, allow_None=True,
                                  doc="the running generation's x̂0 motion (None: no live preview)")
    frame = param.Integer(default=0, bounds=(0, None), doc="the playhead")
    cursor_ids = param.List(default=[], item_type=str,
                            doc="Bokeh models (frame cursors, e.g. a Span) whose location the page moves with the "
                                "playhead while it plays (see follow_playhead)")
    playing = param.Boolean(default=False, doc="the browser is playing the motion")

    # ---- viewer settings
    follow = param.Boolean(default=True, doc="camera follows the pelvis")
    show_path = param.Boolean(default=True, doc="draw the root path on the floor")

    # ---- attention selection (None = mean)
    layer = param.Integer(default=None, allow_None=True, doc="layer of the self-attention map (None = mean)")
    head = param.Integer(default=None, allow_None=True, doc="head (None = mean of heads)")
    att_step = param.Integer(default=None, allow_None=True, doc="recorded sampling step (None = mean)")
    word = param.Integer(default=None, allow_None=True, doc="highlighted word (token index)")
    color_by_word = param.Boolean(default=False, doc="colour the skeleton by the highlighted word's attention")

    def show(self, name: str) -> None:
        if name not in self.items:
            raise KeyError(f"no motion named {name!r}")
        item = self.items[name]
        if not self._readable(item):
            return
        with param.parameterized.batch_call_watchers(self):
            # another motion shown: nothing is compared with it until its job (or the user) says so
            if name != self.current or self.compare == name:
                self.compare = ""
            self.also = []
            self.frame = 0
            self.word = None
            if item.attention is not None:
                self.att_step = item.attention.steps[-1]
                if self.layer is not None and self.layer >= item.attention.n_layers:
                    self.layer = None
                if self.head is not None and self.head >= item.attention.n_heads:
                    self.head = None
                self.word = _content_word(item.words)
            self.current = name

    def _check_compared(self, *_):
        """A motion chosen for comparison is read now (a damaged one is said and not compared)."""
        for name in [self.compare, *self.also]:
            item = self.items.get(name)
            if item is not None and not self._readable(item):
                if self.compare == name:
                    self.compare = ""
                if name in self.also:
                    self.also = [n for n in self.also if n != name]

    @property
    def item(self) -> MotionItem | None:
        return self.items.get(self.current)

    @property
    def compare_item(self) -> MotionItem | None:
        return self.items.get(self.compare) if self.compare else None

    @property
    def joints(self) -> np.ndarray | None:
        item = self.item
        return None if item is None else item.joints

    @property
    def shown_items(self) -> list[MotionItem]:
        """The motions side by side in the viewer: the current one, the compared one, then ``also``."""
        item = self.item
        if item is None:
            return []
        names = [self.compare, *self.also] if self.compare else list(self.also)
        return [item, *(self.items[n] for n in dict.fromkeys(names) if n in self.items and n != item.name)]

    @property
    def n_frames(self) -> int:
        return max((it.n_frames for it in self.shown_items), default=0)

    @property
    def attention(self) -> AttentionRecord | None:
        item = self.item
        return None if item is None else item.attention

    def selection(self) -> dict:
        return {"step": self.att_step, "layer": self.layer, "head": self.head}

    def follow_playhead(self, cursor) -> None:
        """A view's frame cursor (a Bokeh model with a ``location``) follows playback in the page itself; the
        server's ``frame`` changes only when playback stops."""
        if cursor.id not in self.cursor_ids:
            self.cursor_ids = [*self.cursor_ids, cursor.id]

    def pick_frame(self, frame: int) -> None:
        """Move the playhead (from a click in an attention view)."""
        n = self.n_frames
        if n:
            self.frame = int(np.clip(frame, 0, n - 1))

    def word_values(self) -> np.ndarray | None:
        """Per-frame attention of the highlighted word for the current motion, or None."""
        record = self.attention
        if record is None or self.word is None or self.word >= len(record.words):
            return None
        sel = self.selection()
        sel["layer"] = None  # colouring uses the mean over layers (and the chosen step/head)
        return record.word_curve(self.word, **sel)


_FUNCTION_WORDS = {"a", "an", "the", "person", "man", "woman", "someone", "is", "and", "then", "while", "his",
                   "her", "their", "with", "in", "on", "of", "to", "at", "by", "like"}


def _content_word(words: tuple[str, ...]) -> int | None:
    """The first word that carries meaning (a verb, usually): the default highlighted word."""
    for i, w in enumerate(words):
        if w not in _FUNCTION_WORDS:
            return i
    return 0 if words else None
