"""Step and layer windows shared by every method's config."""
from __future__ import annotations

from dataclasses import dataclass

from engine.attention.context import AttnCtx


@dataclass(frozen=True)
class Window:
    """Which sampling steps (fractions of the run, [start, end)) and layers a manipulation touches.

    ``layers`` None = every layer. Resolved against the run's number of steps with :meth:`bind`.
    """

    start: float = 0.0
    end: float = 1.0
    layers: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.start <= self.end <= 1.0:
            raise ValueError(f"a step window needs 0 <= start <= end <= 1, got ({self.start}, {self.end})")

    def check_layers(self, n_layers: int) -> "Window":
        """This window, after checking that its layers exist in a model of ``n_layers`` layers (a ValueError if not)."""
        bad = [layer for layer in self.layers or () if not 0 <= layer < n_layers]
        if bad:
            raise ValueError(f"layers {bad} do not exist: the model has layers 0..{n_layers - 1}")
        return self

    def bind(self, num_steps: int) -> "BoundWindow":
        if num_steps < 1:
            raise ValueError("num_steps must be >= 1")
        first = int(round(self.start * num_steps))
        last = int(round(self.end * num_steps))
        return BoundWindow(steps=frozenset(range(first, last)), layers=None if self.layers is None else frozenset(self.layers))


@dataclass(frozen=True)
class BoundWindow:
    steps: frozenset[int]
    layers: frozenset[int] | None

    def covers(self, ctx: AttnCtx) -> bool:
        return ctx.step in self.steps and (self.layers is None or ctx.layer in self.layers)
