"""The denoiser's training loss, shared by the base trainer (engine.train) and the duet block's (engine.methods.duet_losses)."""
from __future__ import annotations

import torch


def masked_losses(x0_hat: torch.Tensor, x0: torch.Tensor, mask: torch.Tensor,
                  weights: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean squared error over real frames, and of the frame-to-frame differences; ``weights`` (B,) weigh each
    sample's frames (per-timestep loss weights)."""
    m = mask[..., None].float()  # (B, T, 1)
    mv = m[:, 1:] * m[:, :-1]  # (B, T-1, 1): both frames real
    if weights is not None:  # each sample's weight counts once in either term
        w = weights.to(m.device, m.dtype)[:, None, None]
        m, mv = m * w, mv * w
    mse = ((x0_hat - x0) ** 2 * m).sum() / (m.sum() * x0.shape[-1]).clamp_min(1)
    dv = (x0_hat[:, 1:] - x0_hat[:, :-1]) - (x0[:, 1:] - x0[:, :-1])
    vel = (dv**2 * mv).sum() / (mv.sum() * x0.shape[-1]).clamp_min(1)
    return mse, vel
