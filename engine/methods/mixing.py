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
    ``keys_per_target``: each target attends over the K and V of this many consecutive ``keys`` slots,
    concatenated along the frames (each with its own padding mask): MoMo's direction trick, where an output
    reads several copies of its follower (other seeds, or turned) and each leader frame finds the copy whose
    direction matches its own. The ``keys`` slots are taken in batch order, ``keys_per_target`` per target.
    """

    queries: str
    keys: str
    target: str = "out"
    window: Window = field(default_factory=Window)
    hard: bool = False
    keys_per_target: int = 1

    def __post_init__(self) -> None:
        if isinstance(self.keys_per_target, bool) or not isinstance(self.keys_per_target, int) \
                or self.keys_per_target < 1:
            raise ValueError(f"keys_per_target must be a whole number >= 1, got {self.keys_per_target!r}")


def mix_slots(ctx: AttnCtx, config: MixConfig) -> list[tuple[int, int, int]]:
    """(queries slot, keys slot, target slot) triples for both CFG halves present in the batch (one keys slot per
    target; see :func:`mix_groups` for several)."""
    if config.keys_per_target != 1:
        raise ValueError("mix_slots pairs one keys slot per target: use mix_groups")
    return [(q, ks[0], t) for q, ks, t in mix_groups(ctx, config)]


def mix_groups(ctx: AttnCtx, config: MixConfig) -> list[tuple[int, tuple[int, ...], int]]:
    """(queries slot, keys slots, target slot) for both CFG halves present in the batch: ``keys_per_target`` keys
    slots per target, in batch order."""
    out = []
    per = config.keys_per_target
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
        if len(k_slots) == per:
            k_slots = k_slots * len(targets)
        if len(k_slots) != per * len(targets):
            raise KeyError(f"{len(targets)} {config.target!r} slots but {len(k_slots)} {config.keys!r} slots: "
                           + ("give one keys slot, or one per target" if per == 1 else
                              f"give {per} keys slots, or {per} per target"))
        out.extend((q_slots[0], tuple(k_slots[i * per:(i + 1) * per]), t) for i, t in enumerate(targets))
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
        per = self.config.keys_per_target
        groups = mix_groups(ctx, self.config)
        m = k.shape[2]
        own_k, own_v = k, v
        q = q.clone()
        # with several keys slots per target every slot's keys grow to per x M frames: a target's are its group's
        # (concatenated), the others' are their own followed by masked padding
        k, v = (_widen(k, per), _widen(v, per)) if per > 1 else (k.clone(), v.clone())
        for src_q, src_kv, dst in groups:
            q[dst] = q[src_q]
            for j, src in enumerate(src_kv):
                k[dst, :, j * m:(j + 1) * m] = own_k[src]
                v[dst, :, j * m:(j + 1) * m] = own_v[src]
        return q, k, v

    def on_key_mask(self, key_mask, ctx: AttnCtx):
        if not self._active(ctx):
            return None
        per = self.config.keys_per_target
        own = key_mask
        key_mask = _widen(key_mask[:, None], per)[:, 0] if per > 1 else key_mask.clone()
        for _, src_kv, dst in mix_groups(ctx, self.config):
            key_mask[dst] = torch.cat([own[src] for src in src_kv])
        return key_mask

    def on_probs(self, probs, ctx: AttnCtx):
        if not self.config.hard or not self._active(ctx):
            return None
        probs = probs.clone()
        for _, _, dst in mix_groups(ctx, self.config):
            # probs (H, N, M) of the target -> one-hot at each query's best key
            best = probs[dst].argmax(-1, keepdim=True)
            probs[dst] = torch.zeros_like(probs[dst]).scatter_(-1, best, 1.0)
        return probs


def _widen(x: torch.Tensor, per: int) -> torch.Tensor:
    """(B, H, M, ...) -> (B, H, per * M, ...): each slot's own M frames first, then zeros (False for masks)."""
    pad = torch.zeros((x.shape[0], x.shape[1], (per - 1) * x.shape[2], *x.shape[3:]), dtype=x.dtype, device=x.device)
    return torch.cat([x, pad], dim=2)
