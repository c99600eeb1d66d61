"""The one attention module: every self- and cross-attention call of the model goes through here."""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from einops import rearrange
from torch import nn

from engine.attention.context import AttnKind, StepInfo
from engine.attention.controller import AttentionController


class Attention(nn.Module):
    """Multi-head attention with an explicit context and an optional controller.

    With no controller, or one that needs no maps, it runs ``scaled_dot_product_attention``;
    otherwise the explicit softmax path, so controllers can read and edit the maps.
    """

    def __init__(self, *, layer: int, kind: AttnKind, width: int, context_width: int | None = None, heads: int = 4):
        super().__init__()
        if width % heads:
            raise ValueError(f"width {width} is not divisible by {heads} heads")
        self.layer, self.kind, self.heads = layer, kind, heads
        context_width = context_width or width
        self.to_q = nn.Linear(width, width)
        self.to_k = nn.Linear(context_width, width)
        self.to_v = nn.Linear(context_width, width)
        self.to_out = nn.Linear(width, width)

    def forward(
        self,
        x: torch.Tensor,  # (B, N, width) frames
        context: torch.Tensor,  # (B, M, context_width): frames (self) or words (cross)
        key_mask: torch.Tensor,  # (B, M) bool, True = attend
        *,
        info: StepInfo | None = None,
        controller: AttentionController | None = None,
    ) -> torch.Tensor:
        q = rearrange(self.to_q(x), "b n (h d) -> b h n d", h=self.heads)
        k = rearrange(self.to_k(context), "b m (h d) -> b h m d", h=self.heads)
        v = rearrange(self.to_v(context), "b m (h d) -> b h m d", h=self.heads)
        ctx = info.ctx(layer=self.layer, kind=self.kind) if (controller is not None and info is not None) else None
        if ctx is not None:
            replaced = controller.on_qkv(q, k, v, ctx)
            if replaced is not None:
                q, k, v = replaced
            borrowed = controller.on_key_mask(key_mask, ctx)
            if borrowed is not None:
                key_mask = borrowed
        # fully masked rows (e.g. no words) attend to nothing: guard against NaN
        safe_mask = key_mask.clone()
        safe_mask[~key_mask.any(-1), 0] = True
        wants_maps = ctx is not None and controller.needs_maps
        if self.training and torch.is_grad_enabled() and not wants_maps:
            # training takes an explicit path of its own: on the CPU its backward is about twice as fast as SDPA's
            out = torch.matmul(training_probs(q, k, safe_mask), v)
        elif wants_maps:
            scores = torch.matmul(q, k.transpose(-1, -2)) / math.sqrt(q.shape[-1])
            scores = scores.masked_fill(~safe_mask[:, None, None, :], float("-inf"))
            probs = scores.softmax(dim=-1)
            edited = controller.on_probs(probs, ctx)
            if edited is not None:
                probs = edited
            out = torch.matmul(probs, v)
        else:
            out = F.scaled_dot_product_attention(q, k, v, attn_mask=safe_mask[:, None, None, :])
        return self.to_out(rearrange(out, "b h n d -> b n (h d)"))


def training_probs(q: torch.Tensor, k: torch.Tensor, key_mask: torch.Tensor) -> torch.Tensor:
    """softmax(q k^T / sqrt(d)) over the keys ``key_mask`` (B, M) keeps, as training computes it: (B, H, N, M) from
    q (B, H, N, d) and k (B, H, M, d), in q's dtype.

    The mask is an additive bias of the scaled product, all in one ``baddbmm``, and under autocast the softmax
    stays in bf16 (its kernel accumulates in fp32) instead of a round trip through fp32
    copies. On the CPU this makes a bf16 training step about 1.15x faster (`moattn bench --train`). Generation
    never takes this path, so sampling is unchanged."""
    b, h, n, d = q.shape
    m = k.shape[2]
    bias = torch.zeros(b, 1, 1, m, dtype=q.dtype, device=q.device)
    bias.masked_fill_(~key_mask[:, None, None, :], float("-inf"))
    scores = torch.baddbmm(bias.expand(b, h, 1, m).reshape(b * h, 1, m), q.reshape(b * h, n, d),
                           k.reshape(b * h, m, d).transpose(1, 2), alpha=1 / math.sqrt(d))  # (B*H, N, M)
    scores = scores.reshape(b, h, n, m)
    if scores.dtype != torch.bfloat16:  # fp32, or fp16 (whose softmax autocast keeps in fp32)
        return scores.softmax(dim=-1)
    with torch.autocast(q.device.type, enabled=False):
        return scores.softmax(dim=-1)
