"""The attention extension point: controllers and their stack.

A controller is a plain object passed to a sampling call. The model's one attention module calls
``on_qkv`` (may replace Q/K/V), then ``on_key_mask`` (may replace which keys each slot may attend
to: a slot that borrows another slot's K and V must also borrow its padding mask) and, when any controller ``needs_maps``, ``on_probs`` (may replace
the softmax map); the sampling loop calls ``on_step_end``. Returning None means "unchanged".
"""
from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol, runtime_checkable

import torch

from engine.attention.context import AttnCtx


@runtime_checkable
class AttentionController(Protocol):
    needs_maps: bool

    def on_qkv(self, q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, ctx: AttnCtx) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None: ...

    def on_key_mask(self, key_mask: torch.Tensor, ctx: AttnCtx) -> torch.Tensor | None: ...

    def on_probs(self, probs: torch.Tensor, ctx: AttnCtx) -> torch.Tensor | None: ...

    def on_step_end(self, state) -> None: ...


class Controller:
    """Convenience base: does nothing, needs no maps. Override what you use.

    Shapes: q (B, H, N, dh), k and v (B, H, M, dh), key_mask (B, M) bool, probs (B, H, N, M);
    N frames, M frames or words.
    """

    needs_maps: bool = False

    def on_qkv(self, q, k, v, ctx: AttnCtx):
        return None

    def on_key_mask(self, key_mask, ctx: AttnCtx):
        return None

    def on_probs(self, probs, ctx: AttnCtx):
        return None

    def on_step_end(self, state) -> None:
        return None


class ControllerStack(Controller):
    """Applies controllers in order; each sees the previous one's output."""

    def __init__(self, controllers: Iterable[AttentionController]):
        self.controllers = [c for c in controllers if c is not None]

    @property
    def needs_maps(self) -> bool:  # type: ignore[override]
        return any(c.needs_maps for c in self.controllers)

    def on_qkv(self, q, k, v, ctx):
        changed = False
        for c in self.controllers:
            out = c.on_qkv(q, k, v, ctx)
            if out is not None:
                q, k, v = out
                changed = True
        return (q, k, v) if changed else None

    def on_key_mask(self, key_mask, ctx):
        changed = False
        for c in self.controllers:
            out = c.on_key_mask(key_mask, ctx)
            if out is not None:
                key_mask = out
                changed = True
        return key_mask if changed else None

    def on_probs(self, probs, ctx):
        changed = False
        for c in self.controllers:
            if not c.needs_maps:
                continue
            out = c.on_probs(probs, ctx)
            if out is not None:
                probs = out
                changed = True
        return probs if changed else None

    def on_step_end(self, state) -> None:
        for c in self.controllers:
            c.on_step_end(state)


def stack(*controllers: AttentionController | None) -> AttentionController | None:
    """None if nothing to do, the controller itself if one, else a ControllerStack."""
    present = [c for c in controllers if c is not None]
    if not present:
        return None
    if len(present) == 1:
        return present[0]
    return ControllerStack(present)
