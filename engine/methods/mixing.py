"""Mixed self-attention: a slot attends with another slot's queries over a third slot's keys and values.

The one mechanism behind MoMo's transfer (Q from the leader, K and V from the follower) and
MotionCLR's style transfer (Q from the style motion, K and V from the content motion). The
target keeps its own residual stream; only the attention inside the window is borrowed, and
the key padding mask travels with the keys (the two sources may have different lengths).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import torch

from engine.attention.context import AttnCtx
from engine.attention.controller import Controller
from engine.methods.windows import Window


@dataclass(frozen=True)
class MixConfig:
    """Each ``target`` slot's self-attention uses Q from ``queries`` and K, V from ``keys``.

    ``queries`` must name one slot (per CFG half); ``keys`` one slot (shared by every target) or
    one slot per target (paired in batch order: the k-th target takes the k-th keys slot).
    ``hard`` replaces the softmax by the arg-max key of each query (the "nearest neighbour in
    latent space" baseline of MoMo).
    """

    queries: str
    keys: str
    target: str = "out"
    window: Window = field(default_factory=Window)
    hard: bool = False


def mix_slots(ctx: AttnCtx, config: MixConfig) -> list[tuple[int, int, int]]:
    """(queries slot, keys slot, target slot) triples for both CFG halves present in the batch."""
    out = []
    for cond in (True, False):
        q_slots = ctx.roles.slots(config.queries, cond=cond)
        k_slots = ctx.roles.slots(config.keys, cond=cond)
        targets = ctx.roles.slots(config.target, cond=cond)
        if not targets and not q_slots and not k_slots:
            continue
        if len(q_slots) != 1:
            raise KeyError(f"mixed attention needs exactly one {config.queries!r} slot, the batch has {ctx.roles.names}")
        if not targets:
            raise KeyError(f"mixed attention found no {config.target!r} slot in {ctx.roles.names}")
        if len(k_slots) == 1:
            k_slots = k_slots * len(targets)
        if len(k_slots) != len(targets):
            raise KeyError(f"{len(targets)} {config.target!r} slots but {len(k_slots)} {config.keys!r} slots: "
                           "give one keys slot, or one per target")
        out.extend((q_slots[0], k, t) for k, t in zip(k_slots, targets))
    return out


class MixedAttention(Controller):
    def __init__(self, config: MixConfig, *, num_steps: int):
        self.config = config
        self.window = config.window.bind(num_steps)
        self.needs_maps = config.hard

    def _active(self, ctx: AttnCtx) -> bool:
        return ctx.kind == "self" and self.window.covers(ctx)

    def on_qkv(self, q, k, v, ctx: AttnCtx):
        if not self._active(ctx):
            return None
        q, k, v = q.clone(), k.clone(), v.clone()
        for src_q, src_kv, dst in mix_slots(ctx, self.config):
            q[dst], k[dst], v[dst] = q[src_q], k[src_kv], v[src_kv]
        return q, k, v

    def on_key_mask(self, key_mask, ctx: AttnCtx):
        if not self._active(ctx):
            return None
        key_mask = key_mask.clone()
        for _, src_kv, dst in mix_slots(ctx, self.config):
            key_mask[dst] = key_mask[src_kv]
        return key_mask

    def on_probs(self, probs, ctx: AttnCtx):
        if not self.config.hard or not self._active(ctx):
            return None
        probs = probs.clone()
        for _, _, dst in mix_slots(ctx, self.config):
            # probs (H, N, M) of the target -> one-hot at each query's best key
            best = probs[dst].argmax(-1, keepdim=True)
            probs[dst] = torch.zeros_like(probs[dst]).scatter_(-1, best, 1.0)
        return probs
