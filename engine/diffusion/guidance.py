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
    # the scale applies at the noisier timesteps t >= this; below it the conditional prediction alone (guidance in a
    # limited interval, Kynkäänniemi et al. 2024). 0: at every timestep.
    from_t: int = 0

    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int = 0,
                 controller: AttentionController | None = None) -> torch.Tensor:
        if self.scale == 1.0 or not bool((t >= self.from_t).any()):
            return self.denoiser(x, t, cond, step=step, controller=controller)
        both = self.denoiser(torch.cat([x, x]), torch.cat([t, t]), cond.with_uncond(), step=step, controller=controller)
        x0_cond, x0_uncond = both.chunk(2)
        return x0_uncond + self.scale * (x0_cond - x0_uncond)
