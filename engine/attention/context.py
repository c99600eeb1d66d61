"""What every attention call knows about itself: layer, kind, step, timestep, batch roles, words."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

AttnKind = Literal["self", "cross"]


@dataclass(frozen=True)
class BatchRoles:
    """Names for batch slots ("leader", "follower", "out", "ref", "edit", ...).

    ``names[i]`` is the role of slot i; ``uncond[i]`` marks slots that are the unconditional half
    of classifier-free guidance (their cross-attention is skipped by the model).
    """

    names: tuple[str, ...]
    uncond: tuple[bool, ...] = ()

    def __post_init__(self) -> None:
        if not self.uncond:
            object.__setattr__(self, "uncond", (False,) * len(self.names))
        if len(self.uncond) != len(self.names):
            raise ValueError("roles and uncond flags differ in length")

    @classmethod
    def single(cls, role: str = "out", *, size: int = 1) -> "BatchRoles":
        return cls(names=(role,) * size)

    @classmethod
    def of(cls, *names: str) -> "BatchRoles":
        return cls(names=tuple(names))

    def __len__(self) -> int:
        return len(self.names)

    def slots(self, role: str, *, cond: bool | None = True) -> list[int]:
        """Batch indices holding ``role``; cond=True only conditional slots, False only unconditional, None both."""
        return [
            i for i, (n, u) in enumerate(zip(self.names, self.uncond))
            if n == role and (cond is None or u != cond)
        ]

    def slot(self, role: str, *, cond: bool = True) -> int:
        found = self.slots(role, cond=cond)
        if len(found) != 1:
            raise KeyError(f"expected exactly one {'conditional' if cond else 'unconditional'} slot for role {role!r}, found {found} in {self.names}")
        return found[0]

    def with_uncond(self) -> "BatchRoles":
        """These roles followed by an unconditional copy of each (the CFG batch layout)."""
        return BatchRoles(names=self.names + self.names, uncond=tuple(self.uncond) + (True,) * len(self.names))


@dataclass(frozen=True)
class WordIndex:
    """Per batch slot, the words of its prompt in token order (token i = word i)."""

    words: tuple[tuple[str, ...], ...] = field(default_factory=tuple)

    def index(self, slot: int, word: str, occurrence: int = 0) -> int:
        hits = [i for i, w in enumerate(self.words[slot]) if w == word.lower()]
        if len(hits) <= occurrence:
            raise KeyError(f"word {word!r} not in slot {slot}'s prompt {' '.join(self.words[slot])!r}")
        return hits[occurrence]

    def with_uncond(self) -> "WordIndex":
        return WordIndex(words=self.words + tuple(() for _ in self.words))


@dataclass(frozen=True)
class AttnCtx:
    """The explicit context of one attention call."""

    layer: int  # 0-based block index
    kind: AttnKind
    step: int  # index in the sampling loop, 0 = noisiest
    t: int  # diffusion timestep
    roles: BatchRoles
    words: WordIndex | None = None


@dataclass(frozen=True)
class StepInfo:
    """What the sampler tells the model about the current call (everything but layer and kind)."""

    step: int
    t: int
    roles: BatchRoles
    words: WordIndex | None = None

    def ctx(self, *, layer: int, kind: AttnKind) -> AttnCtx:
        return AttnCtx(layer=layer, kind=kind, step=self.step, t=self.t, roles=self.roles, words=self.words)
