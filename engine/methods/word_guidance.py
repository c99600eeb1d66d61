"""Emphasis by guidance (the "guide" and "intensity" modes of ``moattn edit emphasize``): denoiser wrappers with the
model's signature.

MotionCLR (de-)emphasises a word by re-weighting its cross-attention column. In this project's small denoiser the
response of the action to that weight is not monotone (session 38: "waves" barely answers it; some "jumps" draws
shrink). Erasing the word's column, by contrast, removes its action reliably ("a person jumps" with "jumps" erased
stands still). Guide mode uses that direction: on the edited slots

    x0 = x0 + w (x0 - x0 with the word's column erased)

so w > 0 pushes further along what the word adds, w < 0 towards the motion without it, and w = -1 is the word
erased. The erasure is a :class:`engine.methods.motionclr.Reweight` (x0 on the column) acting in the edit's step
window, layers and frames, so outside them the two predictions agree and nothing changes. Like classifier-free
guidance, but against one word instead of the whole prompt.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from engine.attention.controller import AttentionController
from engine.model.denoiser import Condition


def _plain_and_slots(guidance, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int,
                     controller: AttentionController | None) -> tuple[torch.Tensor, list[int]]:
    """A guidance wrapper's plain prediction (B, T, D) and the slots it guides at this step ([] where it does not:
    weight 0, no slot of its role, or a step outside its window)."""
    x0 = guidance.denoiser(x, t, cond, step=step, controller=controller)  # (B, T, D)
    slots = cond.roles.slots(guidance.role)
    if guidance.weight == 0.0 or (guidance.steps is not None and step not in guidance.steps):
        return x0, []
    return x0, list(slots)


@dataclass
class WordGuidance:
    """``denoiser`` guided away from its own prediction with ``erase`` acting (the word's column erased).

    The erased pass runs on ``role``'s slots alone (the others keep the plain prediction) and with ``erase`` alone: a
    recording controller of the call (the attention store) sees the guided call's own maps once, not the erased
    pass's.
    """

    denoiser: Callable
    erase: AttentionController
    weight: float
    role: str = "out"
    steps: frozenset[int] | None = None  # the sampling steps ``erase`` acts in (None: every step); elsewhere no guidance


    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int = 0,
                 controller: AttentionController | None = None) -> torch.Tensor:
        x0, slots = _plain_and_slots(self, x, t, cond, step=step, controller=controller)
        if not slots:
            return x0
        erased = self.denoiser(x[slots], t[slots], cond.take(slots), step=step, controller=self.erase)  # (S, T, D)
        out = x0.clone()
        out[slots] = x0[slots] + self.weight * (x0[slots] - erased)
        return out


@dataclass
class PromptGuidance:
    """``denoiser`` guided towards its prediction under another prompt on ``role``'s slots: x0 + w (x0 other - x0).

    Emphasis in "intensity" mode: the other prompt is the edited one said with the corpus's intensity word for the
    word's action ("a person jumps high", :mod:`engine.methods.intensity`), so w = 1 samples that prompt and w between
    0 and 1 goes part of the way. ``toward`` conditions the role's slots (one prompt per slot); ``steps`` and
    ``frames`` ([start, end)) keep the guidance to the edit's step window and frame span, elsewhere the plain
    prediction stands.
    """

    denoiser: Callable
    toward: Condition
    weight: float
    role: str = "out"
    steps: frozenset[int] | None = None
    frames: tuple[int, int] | None = None

    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int = 0,
                 controller: AttentionController | None = None) -> torch.Tensor:
        x0, slots = _plain_and_slots(self, x, t, cond, step=step, controller=controller)
        if not slots:
            return x0
        if len(slots) != self.toward.text_ids.shape[0]:
            raise ValueError(f"{len(slots)} {self.role!r} slots but {self.toward.text_ids.shape[0]} guiding prompts")
        other = self.denoiser(x[slots], t[slots], self.toward, step=step)  # (S, T, D)
        start, end = self.frames if self.frames is not None else (0, x0.shape[1])
        out = x0.clone()
        out[slots, start:end] = x0[slots, start:end] + self.weight * (other[:, start:end] - x0[slots, start:end])
        return out
