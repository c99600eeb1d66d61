"""DoubleTake (PriorMDM): long motions from the short-clip prior, no training.

Each interval (prompt, seconds) is one slot of the batch; consecutive slots share a handshake of
``h`` frames (the end of one is the start of the next), so the timeline advances by L_i - h per
interval. First take: after every step both copies of each handshake become
(1 - α)·end of the earlier + α·start of the later, α_j = j/h. Second take: every transition
"sandwich" (context, handshake, context) of the unfolded first take is re-noised to T' and
denoised again with a soft mask on x̂0 that lets the handshake change a lot (M_hard), the
context little (M_soft), with a b-frame ramp between; the handshake and ramp frames are written
back. Everything is a step-end hook or a denoiser wrapper around the one sampling loop.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from engine.checkpoint import LoadedModel
from engine.diffusion import CosineSchedule, StepState, run_loop
from engine.generate import FPS, MAX_SECONDS, Request, SampleConfig, build_condition, denoiser_for, sample_states
from engine.representation import features_to_joints

MIN_OWN_FRAMES = 10  # frames of an interval outside its handshakes


@dataclass(frozen=True)
class Interval:
    prompt: str
    seconds: float

    @classmethod
    def parse(cls, text: str) -> "Interval":
        """"PROMPT:SECONDS" (the CLI's form), e.g. "a person walks forward:4"."""
        prompt, sep, seconds = text.rpartition(":")
        if not sep or not prompt.strip():
            raise ValueError(f"expected PROMPT:SECONDS, got {text!r}")
        try:
            value = float(seconds)
        except ValueError:
            raise ValueError(f"{seconds!r} in {text!r} is not a number of seconds") from None
        return cls(prompt=prompt.strip(), seconds=value)


@dataclass(frozen=True)
class SecondTake:
    """Paper values: T' = 700 of 1000, M_hard = 0.85, M_soft = 0.1, b = 10; ``context`` frames each side."""

    renoise: float = 0.7  # T' as a fraction of the diffusion timesteps
    hard: float = 0.85  # how much the handshake frames may change
    soft: float = 0.1  # how much the context frames may change
    ramp: int = 10  # b: frames of linear ramp between hard and soft
    context: int = 30
    # the authors' code denoises sandwiches without text; True: each with "A, then B" (:func:`transition_prompts`)
    text: bool = False

    def __post_init__(self) -> None:
        if not 0.0 < self.renoise <= 1.0:
            raise ValueError("renoise must be in (0, 1]")
        if not 0.0 <= self.soft <= self.hard <= 1.0:
            raise ValueError("need 0 <= soft <= hard <= 1")
        if self.ramp < 0 or self.context < 1:
            raise ValueError("ramp must be >= 0 and context >= 1")


@dataclass(frozen=True)
class DoubleTakeConfig:
    handshake: int = 20  # h frames (1 s)
    second_take: SecondTake | None = field(default_factory=SecondTake)

    def __post_init__(self) -> None:
        if self.handshake < 0:
            raise ValueError("the handshake must be >= 0 frames")


@dataclass
class Handshake:
    """Step-end hook (first take): the shared frames of consecutive slots are blended with a ramp."""

    lengths: Sequence[int]
    h: int

    def __call__(self, state: StepState) -> StepState:
        if self.h == 0 or len(self.lengths) < 2:
            return state
        x = state.x_prev.clone()
        alpha = (torch.arange(self.h, dtype=x.dtype) / self.h)[:, None]  # α_j = j / h
        for i in range(1, len(self.lengths)):
            end = self.lengths[i - 1]
            tau = (1 - alpha) * x[i - 1, end - self.h : end] + alpha * x[i, : self.h]
            x[i - 1, end - self.h : end] = tau
            x[i, : self.h] = tau
        return replace(state, x_prev=x)


@dataclass
class SoftInpaint:
    """Denoiser wrapper: x̂0 <- keep·known + (1 - keep)·x̂0 (keep per slot and frame, 1 = keep known)."""

    denoiser: Callable
    known: torch.Tensor  # (B, T, D)
    keep: torch.Tensor  # (B, T)

    def __call__(self, x, t, cond, *, step: int = 0, controller=None):
        x0 = self.denoiser(x, t, cond, step=step, controller=controller)
        k = self.keep[..., None].to(x0.dtype)
        return k * self.known + (1 - k) * x0


TRANSITION_JOIN = ", then "


def transition_prompts(intervals: Sequence[Interval]) -> list[str]:
    """The text of each transition's sandwich when the second take uses text: "A, then B" (the corpus's own join)."""
    return [f"{a.prompt.strip().rstrip('.')}{TRANSITION_JOIN}{b.prompt.strip()}" for a, b in zip(intervals, intervals[1:])]


def offsets(lengths: Sequence[int], h: int) -> list[int]:
    """Where each interval starts on the unfolded timeline."""
    out = [0]
    for n in lengths[:-1]:
        out.append(out[-1] + n - h)
    return out


def unfold(x: torch.Tensor, lengths: Sequence[int], h: int) -> torch.Tensor:
    """(N, T, D) slots -> (total, D): the first slot whole, then each next one without its handshake."""
    parts = [x[0, : lengths[0]]] + [x[i, h : lengths[i]] for i in range(1, len(lengths))]
    return torch.cat(parts)


def allowance(length: int, handshake: slice, take: SecondTake) -> torch.Tensor:
    """Per sandwich frame: how much it may change (hard on the handshake, soft far away, a ramp between)."""
    idx = torch.arange(length, dtype=torch.float32)
    dist = torch.clamp(torch.maximum(handshake.start - idx, idx - (handshake.stop - 1)), min=0)
    if take.ramp == 0:
        return torch.where(dist == 0, take.hard, take.soft)
    frac = torch.clamp(dist / (take.ramp + 1), max=1.0)
    return take.hard + (take.soft - take.hard) * frac


@dataclass
class Composed:
    features: np.ndarray  # (total, 263) de-normalised, unfolded
    joints: np.ndarray  # (total, 22, 3)
    intervals: list[Interval]
    starts: list[int]  # first frame of each interval on the timeline
    transitions: list[tuple[int, int]]  # [start, end) frames of each handshake on the timeline
    first_take: np.ndarray  # (total, 263) de-normalised features before the second take
    seconds: float  # wall time


def check_intervals(intervals: Sequence[Interval], h: int) -> list[int]:
    if not intervals:
        raise ValueError("give at least one interval")
    lengths = []
    for i, iv in enumerate(intervals):
        if not np.isfinite(iv.seconds) or iv.seconds <= 0 or iv.seconds > MAX_SECONDS:
            raise ValueError(f"interval {i + 1} ({iv.prompt!r}): its length must be in (0, {MAX_SECONDS}] s, got {iv.seconds:g}")
        n = int(round(iv.seconds * FPS))
        shared = h * ((i > 0) + (i < len(intervals) - 1))
        if n < shared + MIN_OWN_FRAMES:
            raise ValueError(f"interval {i + 1} ({iv.prompt!r}) lasts {n} frames: with handshakes of {h} frames it "
                             f"needs at least {(shared + MIN_OWN_FRAMES) / FPS:.1f} s")
        lengths.append(n)
    return lengths


def compose(loaded: LoadedModel, intervals: Sequence[Interval], config: DoubleTakeConfig = DoubleTakeConfig(), *,
            sample: SampleConfig = SampleConfig(), on_step: Callable[[StepState], None] | None = None) -> Composed:
    t0 = time.perf_counter()
    h = config.handshake
    lengths = check_intervals(intervals, h)
    request = Request(prompts=[iv.prompt for iv in intervals], frames=lengths)
    states, *_ = sample_states(loaded, request, sample, hooks=[Handshake(lengths, h)])
    last = None
    for last in states:
        if on_step is not None:
            on_step(last)
    first = unfold(last.x_prev, lengths, h)  # (total, D) normalised
    starts = offsets(lengths, h)
    transitions = [(s, s + h) for s in starts[1:]] if h > 0 else []
    result = first
    if config.second_take is not None and transitions:
        prompts = transition_prompts(intervals) if config.second_take.text else None
        result = second_take(loaded, first, transitions, config.second_take, sample=sample, on_step=on_step,
                             prompts=prompts)
    feats = loaded.normalizer.denormalize(result.numpy())
    return Composed(features=feats, joints=features_to_joints(feats), intervals=list(intervals), starts=starts,
                    transitions=transitions, first_take=loaded.normalizer.denormalize(first.numpy()),
                    seconds=time.perf_counter() - t0)


def second_take(loaded: LoadedModel, first: torch.Tensor, transitions: Sequence[tuple[int, int]], take: SecondTake, *,
                sample: SampleConfig, on_step=None, prompts: Sequence[str | None] | None = None) -> torch.Tensor:
    """Re-noise each transition sandwich of the unfolded first take and denoise it with soft masks.

    ``prompts``: one per transition, used (with the sample's guidance) when ``take.text``; otherwise unconditional.
    """
    if take.text and (prompts is None or len(prompts) != len(transitions)):
        raise ValueError(f"a second take with text needs one prompt per transition ({len(transitions)})")
    total = first.shape[0]
    limit = loaded.model.config.max_frames
    windows = []
    for a, b in transitions:
        lo, hi = max(0, a - take.context), min(total, b + take.context)
        if hi - lo > limit:
            raise ValueError(f"a sandwich of {hi - lo} frames exceeds the model's {limit}: lower the context")
        windows.append((lo, hi, slice(a - lo, b - lo)))
    n = max(hi - lo for lo, hi, _ in windows)
    known = torch.zeros(len(windows), n, first.shape[1])
    keep = torch.ones(len(windows), n)
    allow = []
    for i, (lo, hi, hs) in enumerate(windows):
        known[i, : hi - lo] = first[lo:hi]
        m = allowance(hi - lo, hs, take)
        keep[i, : hi - lo] = 1 - m
        allow.append(m)
    texts = list(prompts) if take.text else [None] * len(windows)
    request = Request(prompts=texts, frames=[hi - lo for lo, hi, _ in windows])
    cond, _ = build_condition(loaded, request)
    schedule = CosineSchedule()
    timesteps = [t for t in schedule.timesteps(sample.steps) if t <= take.renoise * (schedule.steps - 1)]
    if not timesteps:
        return first
    g = torch.Generator().manual_seed(sample.seed + 17)
    ab = schedule.alpha_bar(torch.tensor(timesteps[0])).item()
    x = ab**0.5 * known + (1 - ab) ** 0.5 * torch.randn(known.shape, generator=g)
    base = denoiser_for(loaded, sample) if take.text else loaded.model
    denoiser = SoftInpaint(base, known=known, keep=keep)
    last = None
    for last in run_loop(denoiser, x, cond, schedule=schedule, timesteps=timesteps):
        if on_step is not None:
            on_step(last)
    out = first.clone()
    for i, (lo, hi, _) in enumerate(windows):
        write = allow[i] > take.soft + 1e-6  # the handshake and its ramps
        out[lo:hi][write] = last.x_prev[i, : hi - lo][write]
    return out
