"""AttentionStore: a controller that records attention maps and Q/K/V within a memory budget."""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import torch

from engine.attention.context import AttnCtx
from engine.attention.controller import Controller

Site = tuple[int, int, str]  # (step, layer, kind)


@dataclass
class StoreConfig:
    """What to record. None means "all"."""

    kinds: tuple[str, ...] = ("self", "cross")
    layers: frozenset[int] | None = None
    steps: frozenset[int] | None = None
    record_probs: bool = True
    record_qkv: bool = False
    conditional_only: bool = True  # skip the unconditional half of CFG
    budget_bytes: int = 256 * 1024 * 1024
    dtype: torch.dtype = torch.float16


@dataclass
class Record:
    probs: torch.Tensor | None = None  # (B, H, N, M)
    q: torch.Tensor | None = None  # (B, H, N, dh)
    k: torch.Tensor | None = None
    v: torch.Tensor | None = None
    slots: tuple[int, ...] = ()
    roles: tuple[str, ...] = ()

    def nbytes(self) -> int:
        return sum(t.numel() * t.element_size() for t in (self.probs, self.q, self.k, self.v) if t is not None)


class AttentionStore(Controller):
    """Records per (step, layer, kind). Never changes the computation.

    ``needs_maps`` follows the config: recording probabilities forces the explicit softmax path.
    """

    def __init__(self, config: StoreConfig | None = None, **overrides):
        self.config = config or StoreConfig(**overrides)
        self.records: dict[Site, Record] = {}
        self.used_bytes = 0
        self.skipped_sites: list[Site] = []
        self.needs_maps = self.config.record_probs

    # -- selection ------------------------------------------------------------
    def _wanted(self, ctx: AttnCtx) -> bool:
        c = self.config
        return (
            ctx.kind in c.kinds
            and (c.layers is None or ctx.layer in c.layers)
            and (c.steps is None or ctx.step in c.steps)
        )

    def _slots(self, ctx: AttnCtx) -> list[int]:
        if not self.config.conditional_only:
            return list(range(len(ctx.roles)))
        return [i for i, u in enumerate(ctx.roles.uncond) if not u]

    def _take(self, tensor: torch.Tensor, slots: list[int]) -> torch.Tensor:
        return tensor[slots].detach().to("cpu", self.config.dtype)

    def _record(self, ctx: AttnCtx, **tensors: torch.Tensor) -> None:
        site = (ctx.step, ctx.layer, ctx.kind)
        slots = self._slots(ctx)
        taken = {name: self._take(t, slots) for name, t in tensors.items()}
        size = sum(t.numel() * t.element_size() for t in taken.values())
        if self.used_bytes + size > self.config.budget_bytes:
            self.skipped_sites.append(site)
            return
        rec = self.records.setdefault(site, Record(slots=tuple(slots), roles=tuple(ctx.roles.names[i] for i in slots)))
        for name, t in taken.items():
            setattr(rec, name, t)
        self.used_bytes += size

    # -- controller hooks -----------------------------------------------------
    def on_qkv(self, q, k, v, ctx):
        if self.config.record_qkv and self._wanted(ctx):
            self._record(ctx, q=q, k=k, v=v)
        return None

    def on_probs(self, probs, ctx):
        if self.config.record_probs and self._wanted(ctx):
            self._record(ctx, probs=probs)
        return None

    # -- reading --------------------------------------------------------------
    def sites(self, *, kind: str | None = None) -> list[Site]:
        return sorted(s for s in self.records if kind is None or s[2] == kind)

    @property
    def steps(self) -> list[int]:
        return sorted({s[0] for s in self.records})

    @property
    def layers(self) -> list[int]:
        return sorted({s[1] for s in self.records})

    def get(self, *, step: int, layer: int, kind: str) -> Record:
        try:
            return self.records[(step, layer, kind)]
        except KeyError:
            raise KeyError(f"nothing recorded at step {step}, layer {layer}, {kind}-attention; recorded steps {self.steps}, layers {self.layers}") from None

    def map(self, *, step: int, layer: int, kind: str, slot: int = 0, head: int | None = None) -> torch.Tensor:
        """One attention map (N, M) in float32: a head or the mean over heads."""
        probs = self.get(step=step, layer=layer, kind=kind).probs
        if probs is None:
            raise KeyError("probabilities were not recorded (record_probs=False)")
        m = probs[slot].float()
        return m.mean(0) if head is None else m[head]

    def mean_map(self, *, kind: str, slot: int = 0, steps: Iterable[int] | None = None,
                 layers: Iterable[int] | None = None) -> torch.Tensor:
        """Average map over heads and the chosen steps and layers (all recorded by default)."""
        steps = set(self.steps if steps is None else steps)
        layers = set(self.layers if layers is None else layers)
        maps = [self.map(step=s, layer=l, kind=k, slot=slot) for (s, l, k) in self.sites(kind=kind)
                if s in steps and l in layers]
        if not maps:
            raise KeyError(f"no {kind}-attention maps recorded for those steps/layers")
        return torch.stack(maps).mean(0)

    def clear(self) -> None:
        self.records.clear()
        self.used_bytes = 0
        self.skipped_sites.clear()
