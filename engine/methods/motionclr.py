"""MotionCLR's training-free edits as attention controllers.

Every edit = a typed config (every field used) + a controller built for a run of ``num_steps``.
Batch slots are found by role name; words by word (never by raw token index).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import torch

from engine.attention.context import AttnCtx
from engine.attention.controller import Controller
from engine.methods.edit_options import WEIGHT_RANGES, option_spec, weight_range_text  # noqa: F401 (re-exported)
from engine.methods.emphasis_modes import GUIDED_MODES, MODES
from engine.methods.mixing import MixConfig, MixedAttention
from engine.methods.spans import Span, mask_spans, spans_mask
from engine.methods.windows import BoundWindow, Window
from engine.methods.word_alignment import SWAPPED, SWAPPED_DEFAULT, WORD_BY_WORD, WordAlignment, align_words


def _frame_slice(frames: tuple[int, int] | None, n: int) -> slice:
    if frames is None:
        return slice(0, n)
    start, end = frames
    if not 0 <= start < end:
        raise ValueError(f"frame window must satisfy 0 <= start < end, got {frames}")
    return slice(min(start, n), min(end, n))


def halves(ctx: AttnCtx, *roles: str) -> list[tuple[int, ...]]:
    """One slot per role for the conditional half and, under CFG, the unconditional half.

    Self-attention edits must reach both halves, or guidance would pull the edit back.
    """
    out = []
    for cond in (True, False):
        found = [ctx.roles.slots(r, cond=cond) for r in roles]
        if all(len(f) == 1 for f in found):
            out.append(tuple(f[0] for f in found))
        elif any(len(f) > 1 for f in found):
            raise KeyError(f"roles {roles} must each name one slot; the batch has {ctx.roles.names}")
    if not out:
        raise KeyError(f"the batch has no slots for roles {roles}: its roles are {ctx.roles.names}")
    return out


# ----------------------------------------------------------------------------- (de-)emphasis, erasing
@dataclass(frozen=True)
class ReweightConfig:
    """(De-)emphasise a word: its cross-attention column gets +weight ("add") or ×weight ("mul"); or "guide": the
    column is left as it is and the prediction moves away from the one with the column erased
    (:class:`engine.methods.word_guidance.WordGuidance`, built by :func:`engine.methods.edits.reweight`); or
    "intensity": the prediction moves towards the prompt said with the corpus's intensity word for the word's action,
    "high" for w > 0 and "a little" for w < 0, by |w| (:class:`engine.methods.word_guidance.PromptGuidance`).

    ``frames`` limits the change to a frame interval [start, end) (None = all frames);
    ``role`` names the batch slots edited; ``occurrence`` picks a repeated word.
    """

    word: str
    weight: float = 0.3
    mode: str = "add"  # a name of engine.methods.emphasis_modes.MODES
    window: Window = field(default_factory=Window)
    frames: tuple[int, int] | None = None
    role: str = "out"
    occurrence: int = 0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        MODES[self.mode].check(self.weight)


class Reweight(Controller):
    needs_maps = True

    def __init__(self, config: ReweightConfig, *, num_steps: int):
        self.config = config
        self.window: BoundWindow = config.window.bind(num_steps)
        # guide and intensity edit no map (their denoiser wrappers do the work): a no-op here
        self.needs_maps = config.mode not in GUIDED_MODES

    def on_probs(self, probs, ctx: AttnCtx):
        c = self.config
        if ctx.kind != "cross" or not self.window.covers(ctx) or ctx.words is None:
            return None
        slots = ctx.roles.slots(c.role)
        if not slots:
            return None
        probs = probs.clone()
        rows = _frame_slice(c.frames, probs.shape[2])
        for slot in slots:
            col = ctx.words.index(slot, c.word, c.occurrence)
            if c.mode == "add":
                probs[slot, :, rows, col] += c.weight
            elif c.mode == "mul":  # guided modes edit no map (needs_maps is False: never called)
                probs[slot, :, rows, col] *= c.weight
        return probs


def erased(config: ReweightConfig) -> ReweightConfig:
    """The same word, occurrence, window, frames and role with its column erased (x0): guide mode's other pass."""
    return replace(config, weight=0.0, mode="mul")


def erase_config(word: str, *, frames: tuple[int, int] | None = None, factor: float = 0.1,
                 window: Window = Window(), role: str = "out") -> ReweightConfig:
    """Erasing = strong multiplicative de-emphasis (MotionCLR's code: ×0.1 inside a time window)."""
    return ReweightConfig(word=word, weight=factor, mode="mul", window=window, frames=frames, role=role)


# ----------------------------------------------------------------------------- grounded generation
@dataclass(frozen=True)
class GroundingConfig:
    """Ground a word in time: +weight on its column inside ``mask`` frames, -weight outside.

    The mask may hold several separate spans (:meth:`from_spans`): the paper's "a person jumps four times" grounded
    to four chosen spans gives four jumps where the plain prompt gave seven.
    """

    word: str
    mask: tuple[bool, ...]  # per frame
    weight: float = 0.3
    window: Window = field(default_factory=Window)
    role: str = "out"

    def __post_init__(self) -> None:
        if not any(self.mask):
            raise ValueError("the grounding mask selects no frame")
        if not 0.0 < self.weight <= 1.0:
            raise ValueError("the grounding weight must be in (0, 1]")

    @classmethod
    def from_spans(cls, word: str, spans: tuple[Span, ...] | list[Span], *, frames: int, weight: float = 0.3,
                   window: Window = Window(), role: str = "out") -> "GroundingConfig":
        """The mask of one or several [start, end) spans of a ``frames``-frame motion (checked: in range, sorted,
        not overlapping)."""
        return cls(word=word, mask=spans_mask(spans, frames), weight=weight, window=window, role=role)

    @property
    def spans(self) -> tuple[Span, ...]:
        """The mask's runs as [start, end) spans."""
        return mask_spans(self.mask)


class Ground(Controller):
    needs_maps = True

    def __init__(self, config: GroundingConfig, *, num_steps: int):
        self.config = config
        self.window = config.window.bind(num_steps)
        self.mask = torch.tensor(config.mask, dtype=torch.bool)

    def on_probs(self, probs, ctx: AttnCtx):
        c = self.config
        if ctx.kind != "cross" or not self.window.covers(ctx) or ctx.words is None:
            return None
        n = probs.shape[2]
        mask = torch.zeros(n, dtype=torch.bool)
        mask[: min(n, len(self.mask))] = self.mask[:n]
        delta = torch.where(mask, c.weight, -c.weight).to(probs.device, probs.dtype)
        probs = probs.clone()
        for slot in ctx.roles.slots(c.role):
            col = ctx.words.index(slot, c.word)
            probs[slot, :, :, col] = (probs[slot, :, :, col] + delta[None, :]).clamp_min(0.0)
        return probs


# ----------------------------------------------------------------------------- in-place replacement
@dataclass(frozen=True)
class ReplaceConfig:
    """The edited prompt's cross-attention maps ← the reference's for the first steps.

    Reference ("ref") and edited ("edit") prompts share the noise. Their words are aligned as prompt-to-prompt
    aligns them (:mod:`engine.methods.word_alignment`): word by word when both have as many words, otherwise the
    shared words are matched and the swapped ones take the attention of the words they replace, while words only
    the edited prompt has keep their own maps.

    ``swapped``: what a *swapped* word (one the edited prompt puts in another word's place, "jumps" → "kicks")
    attends with. ``"reference"``: the replaced word's column, so the whole map is the reference's (the paper).
    ``"own"`` (default): its own column from the edited prompt, every other word the reference's, each frame's
    weights scaled back to sum 1. On base v10 (`moattn bench --edits`, 42 draws, the same noises) the paper's form
    held the motion to the reference's action: 0.69 of the edited motions were nearer the edited prompt than the
    reference's (0.95 for the edited prompt alone), timing IoU 0.87 (0.83 without replacement); keeping the swapped
    word's own column gave 0.88 and IoU 0.89 (`runs/s38/repl_variants.py`). The shared words' maps carry the timing;
    the new verb's own column lets its action be read.

    ``self_attention`` also copies the self-attention maps, as the authors' code does (the paper replaces the
    cross-attention maps). Off by default: on base v9 copying them kept the walk's timing a little closer (IoU 0.92
    against 0.87) but held the motion to the reference's action (0.57 nearer the edited prompt against 0.69).
    """

    window: Window = field(default_factory=lambda: Window(0.0, 0.5))
    self_attention: bool = False
    swapped: Literal["own", "reference"] = SWAPPED_DEFAULT
    source: str = "ref"
    target: str = "edit"

    def __post_init__(self) -> None:
        if self.swapped not in SWAPPED:
            raise ValueError(f"swapped must be one of {', '.join(SWAPPED)}, got {self.swapped!r}")


class Replace(Controller):
    needs_maps = True

    def __init__(self, config: ReplaceConfig, *, num_steps: int):
        self.config = config
        self.window = config.window.bind(num_steps)
        self._alignments: dict[tuple[tuple[str, ...], tuple[str, ...]], WordAlignment] = {}

    def alignment(self, source: tuple[str, ...], target: tuple[str, ...]) -> WordAlignment:
        key = (tuple(source), tuple(target))
        if key not in self._alignments:
            self._alignments[key] = align_words(*key)
        return self._alignments[key]

    def _cross(self, src_probs: torch.Tensor, dst_probs: torch.Tensor, alignment: WordAlignment) -> torch.Tensor:
        """(H, F, L) maps of the edited slot: each word's column from the reference's words it is linked to, or its
        own (an inserted word; the padding past its words; with ``swapped="own"`` a swapped word). Where a column
        kept its own, each frame's weights are scaled back to their sum."""
        width = dst_probs.shape[-1]
        links = torch.zeros(src_probs.shape[-1], width, dtype=dst_probs.dtype, device=dst_probs.device)
        taken = torch.zeros(width, dtype=torch.bool, device=dst_probs.device)
        own = self.config.swapped == "own"
        swaps = alignment.swaps
        for j, link in enumerate(alignment.links):
            if own and j in swaps:
                continue  # a swapped word keeps its own column
            for i, w in link:
                links[i, j] = w
                taken[j] = True
        mapped = torch.where(taken, torch.einsum("hfw,wn->hfn", src_probs, links), dst_probs)
        if not own:
            return mapped
        total = dst_probs.sum(-1, keepdim=True)  # (H, F, 1): 1 on a softmax row
        return mapped * (total / mapped.sum(-1, keepdim=True).clamp_min(1e-12))

    def on_probs(self, probs, ctx: AttnCtx):
        c = self.config
        if not self.window.covers(ctx) or (ctx.kind == "self" and not c.self_attention):
            return None
        probs = probs.clone()
        for src, dst in halves(ctx, c.source, c.target):
            if ctx.kind == "cross" and ctx.roles.uncond[dst]:
                continue  # the unconditional pass has no cross-attention
            if ctx.kind == "cross" and ctx.words is not None:
                alignment = self.alignment(ctx.words.words[src], ctx.words.words[dst])
                if alignment.mode != WORD_BY_WORD or (c.swapped == "own" and alignment.changed):
                    probs[dst] = self._cross(probs[src], probs[dst], alignment)
                    continue
            probs[dst] = probs[src]
        return probs


# ----------------------------------------------------------------------------- sequence shifting
@dataclass(frozen=True)
class ShiftConfig:
    """Q, K, V of the edited slot ← the reference's, rolled in time: the first ``fraction`` moves to the end."""

    fraction: float = 0.5
    window: Window = field(default_factory=lambda: Window(0.0, 0.4))
    source: str = "ref"
    target: str = "edit"

    def __post_init__(self) -> None:
        if not 0.0 < self.fraction < 1.0:
            raise ValueError("the shift fraction must be in (0, 1)")


class Shift(Controller):
    def __init__(self, config: ShiftConfig, *, num_steps: int, frames: int):
        self.config = config
        self.window = config.window.bind(num_steps)
        self.frames = frames  # real length of the motion (padding stays in place)

    def on_qkv(self, q, k, v, ctx: AttnCtx):
        c = self.config
        if ctx.kind != "self" or not self.window.covers(ctx):
            return None
        n = self.frames
        shift = -int(round(c.fraction * n))
        q, k, v = q.clone(), k.clone(), v.clone()
        for src, dst in halves(ctx, c.source, c.target):
            for t in (q, k, v):
                t[dst, :, :n] = torch.roll(t[src, :, :n], shifts=shift, dims=1)
        return q, k, v


# ----------------------------------------------------------------------------- example-based generation
@dataclass(frozen=True)
class ExampleConfig:
    """Each "out" slot takes the example's Q with its chunks of ``chunk_frames`` frames shuffled (per-slot seed).

    The chunk size's default, bounds and help are the ``chunk_frames`` edit option's (``moattn edit example
    --chunk-frames``, the Edit tab's slider): paper 1 s = 20 frames.
    """

    chunk_frames: int = option_spec("chunk_frames").default
    window: Window = field(default_factory=lambda: Window(0.0, 0.6))
    seed: int = 0
    example: str = "ref"
    target: str = "out"

    def __post_init__(self) -> None:
        option_spec("chunk_frames").check(self.chunk_frames)


class ExampleBased(Controller):
    def __init__(self, config: ExampleConfig, *, num_steps: int, frames: int):
        self.config = config
        self.window = config.window.bind(num_steps)
        self.frames = frames
        self._orders: dict[int, np.ndarray] = {}

    def order(self, slot: int) -> np.ndarray:
        """Frame permutation for a slot: whole chunks shuffled, the same at every step and layer."""
        if slot not in self._orders:
            n, size = self.frames, self.config.chunk_frames
            chunks = [np.arange(s, min(s + size, n)) for s in range(0, n, size)]
            rng = np.random.default_rng(self.config.seed * 1009 + slot)
            self._orders[slot] = np.concatenate([chunks[i] for i in rng.permutation(len(chunks))])
        return self._orders[slot]

    def on_qkv(self, q, k, v, ctx: AttnCtx):
        c = self.config
        if ctx.kind != "self" or not self.window.covers(ctx):
            return None
        q = q.clone()
        for cond in (True, False):
            examples = ctx.roles.slots(c.example, cond=cond)
            if len(examples) != 1:
                continue
            # the k-th target slot gets the k-th permutation in both halves
            for k_th, slot in enumerate(ctx.roles.slots(c.target, cond=cond)):
                q[slot, :, : self.frames] = q[examples[0], :, torch.as_tensor(self.order(k_th))]
        return q, k, v


# ----------------------------------------------------------------------------- style transfer
@dataclass(frozen=True)
class StyleTransferConfig:
    """The output's self-attention uses Q from the style motion and K, V from the content motion."""

    window: Window = field(default_factory=lambda: Window(0.0, 0.5))
    style: str = "style"
    content: str = "content"
    target: str = "out"


class StyleTransfer(MixedAttention):
    def __init__(self, config: StyleTransferConfig, *, num_steps: int):
        super().__init__(MixConfig(queries=config.style, keys=config.content, target=config.target,
                                   window=config.window), num_steps=num_steps)
        self.style_config = config
