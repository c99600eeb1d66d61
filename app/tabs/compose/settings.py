"""The Compose tab's settings (DoubleTake): the timeline of intervals, a handshake length per transition and the
second take. Bounds, defaults and help come from the engine's declaration (``engine.methods.doubletake_config``),
which ``moattn compose`` reads too."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import param

from app.components.option_params import param_for
from app.generation import prompt_analysis
from engine.methods.doubletake_config import DoubleTakeConfig, SecondTake, option_info
from engine.units import FPS

DEFAULT_INTERVALS = (("a person walks forward", 4.0), ("a person jumps", 3.0))
_ENGINE = DoubleTakeConfig()  # the engine's defaults (``moattn compose`` runs the same)
HANDSHAKE = option_info(DoubleTakeConfig, "handshake")  # default, bounds (frames) and help of one handshake


@dataclass(frozen=True)
class IntervalRow:
    """One row of the timeline: what to do and for how long."""

    prompt: str
    seconds: float


class ComposeSettings(param.Parameterized):
    """The Compose tab's settings (one per session, in ``StudioState.tab_settings["compose"]``) and its last
    composition.

    Defaults are the engine's (``DoubleTakeConfig``, ``SecondTake``: what ``moattn compose`` runs)."""

    intervals = param.List(default=[], item_type=IntervalRow, doc="the timeline, in order")
    handshakes = param.List(default=[], item_type=int, doc="handshake length in frames of each transition (between "
                            "interval k and k + 1), " + HANDSHAKE.help)
    second_take = param.Boolean(default=_ENGINE.second_take is not None,
                                label="second take (re-denoise the transitions)",
                                doc="re-denoise each transition with soft masks (the second take)")
    second_take_text = param_for(SecondTake, "text")
    second_take_planted_feet = param_for(SecondTake, "planted_feet")
    result = param.Parameter(default=None, doc="ComposeSummary of the last composition")

    @classmethod
    def for_session(cls, session) -> "ComposeSettings":
        return cls(tokenizer=session.tokenizer)

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, **params):
        super().__init__(**params)
        self.tokenizer = tokenizer or (lambda: None)
        if not self.intervals:
            self.intervals = [IntervalRow(p, s) for p, s in DEFAULT_INTERVALS]
        self._fit_handshakes()
        self.param.watch(lambda _: self._fit_handshakes(), "intervals")

    def _fit_handshakes(self) -> None:
        """One handshake per transition: new transitions get the default, extra ones go (from the end)."""
        n = max(len(self.intervals) - 1, 0)
        if len(self.handshakes) != n:
            hs = list(self.handshakes)[:n]
            self.handshakes = hs + [HANDSHAKE.default] * (n - len(hs))

    # ------------------------------------------------------------------ editing the timeline
    def add(self, *, prompt: str = "a person walks forward", seconds: float = 3.0) -> None:
        self.intervals = [*self.intervals, IntervalRow(prompt, float(seconds))]

    def remove(self, index: int) -> None:
        """Remove an interval; the transition it shared with the one before goes too (its next one for the first)."""
        if len(self.intervals) <= 1:
            raise ValueError("the timeline needs at least one interval")
        rows = list(self.intervals)
        del rows[index]
        hs = list(self.handshakes)
        if hs:
            del hs[max(index - 1, 0)]
        self.param.update(handshakes=hs, intervals=rows)

    def move(self, index: int, delta: int) -> None:
        """Swap an interval with its neighbour (delta -1: up, +1: down); nothing past either end. The handshakes
        stay where they are on the timeline (transition k joins whatever intervals are k-th and k+1-th)."""
        j = index + delta
        if not 0 <= j < len(self.intervals):
            return
        rows = list(self.intervals)
        rows[index], rows[j] = rows[j], rows[index]
        self.intervals = rows

    def from_sentence(self, text: str, *, tempo=()) -> None:
        """The timeline of a prompt of several actions in order ("a person walks forward, then jumps"): one interval
        per clause, as long as the Generate box would make it (``engine.methods.sequence.plan``), with the Generate
        box's handshakes (shorter than a long motion's default: a counted clause keeps its count); ``tempo``: the
        model's count tempo. A one-line ValueError for a prompt that is not actions in order."""
        from engine.methods.sequence import HANDSHAKE as CLAUSE_HANDSHAKE
        from engine.methods.sequence import plan

        intervals = plan(" ".join(str(text).split()), tempo=tempo)
        if intervals is None:
            raise ValueError(f"{text.strip()!r} is not actions in order: write them with 'then' or commas, e.g. "
                             f"'a person walks forward, then jumps'")
        self.param.update(handshakes=[CLAUSE_HANDSHAKE] * (len(intervals) - 1),
                          intervals=[IntervalRow(iv.prompt, iv.seconds) for iv in intervals])

    def set_handshake(self, transition: int, frames: int) -> None:
        """The handshake of transition ``transition`` (0-based), in frames; out of range: a one-line ValueError."""
        from engine.methods.doubletake_config import check_option

        n = len(self.handshakes)
        if not 0 <= transition < n:
            raise ValueError(f"there is no transition {transition + 1} ({n} on the timeline)")
        if isinstance(frames, float) and frames == int(frames):
            frames = int(frames)
        if isinstance(frames, float):
            raise ValueError(f"transition {transition + 1}: a handshake is a whole number of frames, got {frames:g}")
        check_option(DoubleTakeConfig, "handshake", frames, what=f"transition {transition + 1}'s handshake")
        if self.handshakes[transition] != frames:
            hs = list(self.handshakes)
            hs[transition] = int(frames)
            self.handshakes = hs

    def edit(self, index: int, *, prompt: str | None = None, seconds: float | None = None) -> None:
        row = self.intervals[index]
        new = IntervalRow(row.prompt if prompt is None else prompt, row.seconds if seconds is None else float(seconds))
        if new != row:
            rows = list(self.intervals)
            rows[index] = new
            self.intervals = rows

    # ------------------------------------------------------------------ derived
    def handshake_frames(self) -> tuple[int, ...]:
        """One handshake length (frames) per transition, in order."""
        n = max(len(self.intervals) - 1, 0)
        hs = list(self.handshakes)[:n]
        return tuple(hs + [HANDSHAKE.default] * (n - len(hs)))

    def config(self) -> DoubleTakeConfig:
        """The engine config these settings run (what ``moattn compose --handshake h1,h2,...`` runs)."""
        take = SecondTake(text=self.second_take_text, planted_feet=self.second_take_planted_feet) \
            if self.second_take else None
        hs = self.handshake_frames()
        return DoubleTakeConfig(handshake=hs if hs else HANDSHAKE.default, second_take=take)

    def readings(self) -> list:
        """Per interval: its prompt as the engine will read it (``app.generation.PromptReading``: notes or refusal)."""
        tokenizer = self.tokenizer()
        return [prompt_analysis(tokenizer, row.prompt) for row in self.intervals]

    def refused(self) -> bool:
        """The engine would refuse an interval's prompt: Generate waits."""
        return any(r.blocked for r in self.readings())

    def expected_frames(self) -> int:
        """Length of the long motion: the intervals' frames minus one handshake per transition."""
        lengths = [int(round(row.seconds * FPS)) for row in self.intervals]
        return sum(lengths) - sum(self.handshake_frames())
