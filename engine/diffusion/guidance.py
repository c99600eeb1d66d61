"""Denoiser wrappers with the model's signature: classifier-free guidance."""
from __future__ import annotations

from dataclasses import dataclass

import torch

from engine.attention.controller import AttentionController
from engine.model.denoiser import Condition


@dataclass
class ClassifierFreeGuidance:
    """x0 = x0_uncond + scale * (x0_cond - x0_uncond), both halves in one batch.

    The batch seen by the inner denoiser (and by attention controllers) is the conditional slots
    followed by their unconditional copies (roles flagged ``uncond``).
    """

    denoiser: object
    scale: float = 2.5
    # the timesteps [low, high) where the scale applies; elsewhere the conditional prediction alone (guidance in a
    # limited interval, Kynkäänniemi et al. 2024). The default covers every timestep.
    interval: tuple[int, int] = (0, 1_000_000)

    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int = 0,
                 controller: AttentionController | None = None) -> torch.Tensor:
        low, high = self.interval
        if self.scale == 1.0 or not bool(((t >= low) & (t < high)).any()):
            return self.denoiser(x, t, cond, step=step, controller=controller)
        both = self.denoiser(torch.cat([x, x]), torch.cat([t, t]), cond.with_uncond(), step=step, controller=controller)
        x0_cond, x0_uncond = both.chunk(2)
        return x0_uncond + self.scale * (x0_cond - x0_uncond)
