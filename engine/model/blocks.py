"""Denoiser block: timestep-conditioned norm -> frame self-attention -> frame-to-word
cross-attention -> feed-forward. The timestep enters only through the norms (AdaLN) and never
mixes with the text."""
from __future__ import annotations

import torch
from torch import nn

from engine.attention.context import StepInfo
from engine.attention.controller import AttentionController
from engine.model.attention import Attention


class AdaNorm(nn.Module):
    """LayerNorm whose scale and shift come from the timestep embedding (B, width)."""

    def __init__(self, width: int):
        super().__init__()
        self.norm = nn.LayerNorm(width, elementwise_affine=False)
        self.to_scale_shift = nn.Linear(width, 2 * width)
        nn.init.zeros_(self.to_scale_shift.weight)
        nn.init.zeros_(self.to_scale_shift.bias)

    def forward(self, x: torch.Tensor, temb: torch.Tensor) -> torch.Tensor:
        scale, shift = self.to_scale_shift(temb)[:, None].chunk(2, dim=-1)
        return self.norm(x) * (1 + scale) + shift


class Block(nn.Module):
    def __init__(self, *, layer: int, width: int, heads: int, text_width: int, dropout: float = 0.1):
        super().__init__()
        self.layer = layer
        self.norm_self = AdaNorm(width)
        self.self_attn = Attention(layer=layer, kind="self", width=width, heads=heads)
        self.norm_cross = nn.LayerNorm(width)
        self.cross_attn = Attention(layer=layer, kind="cross", width=width, context_width=text_width, heads=heads)
        self.norm_ff = AdaNorm(width)
        self.ff = nn.Sequential(nn.Linear(width, 4 * width), nn.GELU(), nn.Dropout(dropout), nn.Linear(4 * width, width))
        self.dropout = nn.Dropout(dropout)

    def forward(
        self,
        h: torch.Tensor,  # (B, T, width)
        temb: torch.Tensor,  # (B, width)
        frame_mask: torch.Tensor,  # (B, T) bool
        text: torch.Tensor,  # (B, L, text_width)
        text_mask: torch.Tensor,  # (B, L) bool
        use_text: torch.Tensor,  # (B,) bool: False = unconditional, cross-attention skipped
        *,
        info: StepInfo | None,
        controller: AttentionController | None,
    ) -> torch.Tensor:
        x = self.norm_self(h, temb)
        h = h + self.dropout(self.self_attn(x, x, frame_mask, info=info, controller=controller))
        if bool(use_text.any()):
            cross = self.cross_attn(self.norm_cross(h), text, text_mask, info=info, controller=controller)
            # where, not a product: a text-less slot's cross-attention may be NaN, and NaN * 0 is NaN
            h = h + torch.where(use_text[:, None, None], self.dropout(cross), torch.zeros_like(cross))
        h = h + self.dropout(self.ff(self.norm_ff(h, temb)))
        return h
