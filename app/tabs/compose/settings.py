"""The Compose tab's settings (DoubleTake): the timeline of intervals, the handshake and the second take."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import param

from app.generation import prompt_analysis
from engine.methods.doubletake import DoubleTakeConfig, SecondTake
from engine.units import FPS

DEFAULT_INTERVALS = (("a person walks forward", 4.0), ("a person jumps", 3.0))
_ENGINE = DoubleTakeConfig()  # the engine's defaults (``moattn compose`` runs the same)


@dataclass(frozen=True)
class IntervalRow:
    """One row of the timeline: what to do and for how long."""

    prompt: str
    seconds: float


class ComposeSettings(param.Parameterized):
    """The Compose tab's settings (one per session, on ``StudioState.compose``) and its last composition.

    Defaults are the engine's (``DoubleTakeConfig``, ``SecondTake``: what ``moattn compose`` runs)."""

    intervals = param.List(default=[], item_type=IntervalRow, doc="the timeline, in order")
    handshake = param.Number(default=_ENGINE.handshake / FPS, bounds=(0.0, 2.0), step=0.25, label="Handshake (s)",
                             doc="handshake (shared frames) in seconds")
    second_take = param.Boolean(default=_ENGINE.second_take is not None,
                                label="second take (re-denoise the transitions)",
                                doc="re-denoise each transition with soft masks (the second take)")
    second_take_text = param.Boolean(default=SecondTake().text, label="with text ('A, then B')",
                                     doc="the second take denoises each transition with 'A, then B' (default: "
                                         "without text, as the authors' code)")
    result = param.Parameter(default=None, doc="ComposeSummary of the last composition")

    @classmethod
    def for_session(cls, session) -> "ComposeSettings":
        return cls(tokenizer=session.tokenizer)

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, **params):
        super().__init__(**params)
        self.tokenizer = tokenizer or (lambda: None)
        if not self.intervals:
            self.intervals = [IntervalRow(p, s) for p, s in DEFAULT_INTERVALS]

    # ------------------------------------------------------------------ editing the timeline
    def add(self, *, prompt: str = "a person walks forward", seconds: float = 3.0) -> None:
        self.intervals = [*self.intervals, IntervalRow(prompt, float(seconds))]

    def remove(self, index: int) -> None:
        if len(self.intervals) <= 1:
            raise ValueError("the timeline needs at least one interval")
        rows = list(self.intervals)
        del rows[index]
        self.intervals = rows

    def move(self, index: int, delta: int) -> None:
        """Swap an interval with its neighbour (delta -1: up, +1: down); nothing past either end."""
        j = index + delta
        if not 0 <= j < len(self.intervals):
            return
        rows = list(self.intervals)
        rows[index], rows[j] = rows[j], rows[index]
        self.intervals = rows

    def edit(self, index: int, *, prompt: str | None = None, seconds: float | None = None) -> None:
        row = self.intervals[index]
        new = IntervalRow(row.prompt if prompt is None else prompt, row.seconds if seconds is None else float(seconds))
        if new != row:
            rows = list(self.intervals)
            rows[index] = new
            self.intervals = rows

    # ------------------------------------------------------------------ derived
    @property
    def handshake_frames(self) -> int:
        return int(round(self.handshake * FPS))

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
        return sum(lengths) - self.handshake_frames * max(0, len(lengths) - 1)
