"""DoubleTake (PriorMDM): long motions from the short-clip prior, no training.

Each interval (prompt, seconds) is one slot of the batch; consecutive slots share a handshake of ``h_k``
frames (the end of one is the start of the next; one length per transition), so the timeline advances by
L_i - h_i per interval. First take: after every step both copies of each handshake become
(1 - α)·end of the earlier + α·start of the later, α_j = j/h. Second take (the paper's): every transition
"sandwich" (S_k, τ_k, S_k+1) of the unfolded first take - the interval before with its own frames (back to its
previous handshake), the handshake, the interval after (up to its next handshake), cropped around the handshake
to the frames the model takes - is re-noised to T' and denoised again with a soft mask on x̂0 that lets the
handshake change a lot (M_hard), the intervals little (M_soft), with a b-frame linear ramp between. The sandwiches
are then unfolded back onto the timeline: each frame takes its sandwich's refined value, and where two sandwiches
share an interval's frames they cross-fade linearly between their handshakes (no seam anywhere). Not the paper's:
by default the second take's prediction also goes through :class:`~engine.diffusion.feet.PlantedFeet` (a foot on
the floor stops sliding), as controlled generation does; ``SecondTake(planted_feet=False)`` is the paper's second
take. Everything is a step-end hook or a denoiser wrapper around the one sampling loop.

The options (bounds, defaults, help) are declared once in :mod:`engine.methods.doubletake_config`.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from engine.checkpoint import LoadedModel
from engine.diffusion import CosineSchedule, StepState, run_loop
from engine.diffusion.feet import PlantedFeet
from engine.generate import FPS, MAX_SECONDS, Request, SampleConfig, build_condition, denoiser_for, sample_states
from engine.methods.doubletake_config import DoubleTakeConfig, SecondTake  # noqa: F401 (re-exported)
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


def per_transition(h: int | Sequence[int], intervals: int) -> tuple[int, ...]:
    """One handshake length per transition of ``intervals`` intervals: an int applies to all, a sequence is checked."""
    if isinstance(h, (int, np.integer)):
        return (int(h),) * max(intervals - 1, 0)
    if intervals <= 1 and len(h) == 0:
        return ()
    return DoubleTakeConfig(handshake=tuple(int(v) for v in h)).handshakes(intervals)


@dataclass
class Handshake:
    """Step-end hook (first take): the shared frames of consecutive slots are blended with a ramp.

    ``h``: one length for every transition, or one per transition (slots i and i + 1 share ``h[i]`` frames)."""

    lengths: Sequence[int]
    h: int | Sequence[int]

    def __call__(self, state: StepState) -> StepState:
        hs = per_transition(self.h, len(self.lengths))
        if not any(hs):
            return state
        x = state.x_prev.clone()
        for i, h in enumerate(hs, start=1):
            if h == 0:
                continue
            alpha = (torch.arange(h, dtype=x.dtype) / h)[:, None]  # α_j = j / h
            end = self.lengths[i - 1]
            tau = (1 - alpha) * x[i - 1, end - h : end] + alpha * x[i, :h]
            x[i - 1, end - h : end] = tau
            x[i, :h] = tau
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


def offsets(lengths: Sequence[int], h: int | Sequence[int]) -> list[int]:
    """Where each interval starts on the unfolded timeline (``h``: one handshake length, or one per transition)."""
    hs = per_transition(h, len(lengths))
    out = [0]
    for n, k in zip(lengths[:-1], hs):
        out.append(out[-1] + n - k)
    return out


def unfold(x: torch.Tensor, lengths: Sequence[int], h: int | Sequence[int]) -> torch.Tensor:
    """(N, T, D) slots -> (total, D): the first slot whole, then each next one without its handshake."""
    hs = per_transition(h, len(lengths))
    parts = [x[0, : lengths[0]]] + [x[i, hs[i - 1] : lengths[i]] for i in range(1, len(lengths))]
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
    transitions: list[tuple[int, int]]  # [start, end) frames of each handshake on the timeline (empty: a cut)
    first_take: np.ndarray  # (total, 263) de-normalised features before the second take
    seconds: float  # wall time
    words: list[tuple[str, ...]] = field(default_factory=list)  # each interval's prompt as the model read it

    @property
    def lengths(self) -> list[int]:
        """Frames of each interval: its slot in the first take (as :func:`check_intervals` counts them)."""
        return [int(round(iv.seconds * FPS)) for iv in self.intervals]


def check_intervals(intervals: Sequence[Interval], h: int | Sequence[int]) -> list[int]:
    """Each interval's frames; ValueError (one line) where one is too long, too short for its handshakes, or the
    handshakes do not match the intervals (``h``: one length for every transition, or one per transition)."""
    if not intervals:
        raise ValueError("give at least one interval")
    hs = per_transition(h, len(intervals))
    lengths = []
    for i, iv in enumerate(intervals):
        if not np.isfinite(iv.seconds) or iv.seconds <= 0 or iv.seconds > MAX_SECONDS:
            raise ValueError(f"interval {i + 1} ({iv.prompt!r}): its length must be in (0, {MAX_SECONDS}] s, got {iv.seconds:g}")
        n = int(round(iv.seconds * FPS))
        mine = [k for k in (hs[i - 1] if i > 0 else 0, hs[i] if i < len(hs) else 0) if k]
        if n < sum(mine) + MIN_OWN_FRAMES:
            said = " and ".join(str(k) for k in mine) if mine else "0"
            raise ValueError(f"interval {i + 1} ({iv.prompt!r}) lasts {n} frames: with handshakes of {said} frames it "
                             f"needs at least {(sum(mine) + MIN_OWN_FRAMES) / FPS:.1f} s")
        lengths.append(n)
    return lengths


def compose(loaded: LoadedModel, intervals: Sequence[Interval], config: DoubleTakeConfig = DoubleTakeConfig(), *,
            sample: SampleConfig = SampleConfig(), on_step: Callable[[StepState], None] | None = None,
            controller=None) -> Composed:
    """The intervals joined on one timeline. ``controller`` (an attention controller, e.g. an ``AttentionStore``)
    acts in the first take only, where each interval is one batch slot of its own prompt."""
    t0 = time.perf_counter()
    if not intervals:
        raise ValueError("give at least one interval")
    hs = config.handshakes(len(intervals))
    lengths = check_intervals(intervals, hs)
    limit = loaded.model.config.max_frames
    for i, n in enumerate(lengths):
        if n > limit:
            raise ValueError(f"interval {i + 1} lasts {n} frames: this model handles at most {limit} "
                             f"({limit / FPS:.1f} s)")
    request = Request(prompts=[iv.prompt for iv in intervals], frames=lengths)
    states, _, tokens, _ = sample_states(loaded, request, sample, hooks=[Handshake(lengths, hs)], controller=controller)
    last = None
    for last in states:
        if on_step is not None:
            on_step(last)
    first = unfold(last.x_prev, lengths, hs)  # (total, D) normalised
    starts = offsets(lengths, hs)
    transitions = [(s, s + h) for s, h in zip(starts[1:], hs)]  # one per transition (empty where h = 0: a cut)
    result = first
    if config.second_take is not None and any(hs):
        prompts = transition_prompts(intervals) if config.second_take.text else None
        result = second_take(loaded, first, transitions, config.second_take, sample=sample, on_step=on_step,
                             prompts=prompts)
    feats = loaded.normalizer.denormalize(result.numpy())
    return Composed(features=feats, joints=features_to_joints(feats), intervals=list(intervals), starts=starts,
                    transitions=transitions, first_take=loaded.normalizer.denormalize(first.numpy()),
                    seconds=time.perf_counter() - t0, words=[tuple(t.words) for t in tokens])


@dataclass(frozen=True)
class Sandwich:
    """One transition's sandwich on the timeline: frames [lo, hi), its handshake at [a, b)."""

    lo: int
    hi: int
    a: int
    b: int

    @property
    def frames(self) -> int:
        return self.hi - self.lo

    @property
    def handshake(self) -> slice:
        """The handshake's frames within the sandwich."""
        return slice(self.a - self.lo, self.b - self.lo)


def sandwiches(transitions: Sequence[tuple[int, int]], total: int, take: SecondTake, limit: int) -> list[Sandwich]:
    """The paper's (S_k, τ_k, S_k+1) per non-empty transition: from the end of the previous handshake (or the start)
    to the start of the next one (or the end), ``take.context`` frames at most on each side when set, and cropped
    around the handshake to ``limit`` frames (the model's longest motion), as evenly as the two sides allow."""
    out = []
    for k, (a, b) in enumerate(transitions):
        if b <= a:
            continue
        lo = transitions[k - 1][1] if k > 0 else 0
        hi = transitions[k + 1][0] if k + 1 < len(transitions) else total
        if take.context is not None:
            lo, hi = max(lo, a - take.context), min(hi, b + take.context)
        room = limit - (b - a)
        if room < 0:
            raise ValueError(f"a handshake of {b - a} frames exceeds the model's {limit}")
        left, right = a - lo, hi - b
        if left + right > room:
            left = min(left, room // 2)
            right = min(right, room - left)
            left = min(a - lo, room - right)
        out.append(Sandwich(lo=a - left, hi=b + right, a=a, b=b))
    return out


def unfold_weights(windows: Sequence[Sandwich], ramp: int, total: int) -> torch.Tensor:
    """(K, total): how much of each sandwich's refined frames the unfolded motion takes.

    1 on a sandwich's core (its handshake and the b ramp frames each side); where two sandwiches share an interval,
    a linear cross-fade from one core to the next (the two weights sum to 1); at an end no other sandwich covers,
    a linear fall to 0 just outside the sandwich (the first take takes over there). No frame jumps from one take
    to another.
    """
    k = len(windows)
    cores = [(max(s.lo, s.a - ramp), min(s.hi, s.b + ramp)) for s in windows]
    f = torch.arange(total, dtype=torch.float32)
    out = torch.zeros(k, total)
    for i, s in enumerate(windows):
        c0, c1 = cores[i]
        if i > 0 and windows[i - 1].hi > s.lo:  # shares frames with the sandwich before: cross-fade between cores
            p1 = cores[i - 1][1]
            full_from, zero_at = max(c0, p1), min(c0, p1) - 1
        else:
            full_from, zero_at = c0, s.lo - 1
        if i + 1 < k and windows[i + 1].lo < s.hi:  # ... and with the one after
            n0 = cores[i + 1][0]
            full_to, zero_to = min(c1, n0), max(c1, n0)
        else:
            full_to, zero_to = c1, s.hi
        zero_at, zero_to = max(zero_at, s.lo - 1), min(zero_to, s.hi)
        rise = (f - zero_at) / (full_from - zero_at)  # 0 at zero_at, 1 from full_from
        fall = (zero_to - f) / (zero_to - full_to + 1)  # 1 up to full_to - 1, 0 at zero_to
        out[i, s.lo : s.hi] = torch.clamp(torch.minimum(rise, fall), 0.0, 1.0)[s.lo : s.hi]
    return out / torch.clamp(out.sum(0, keepdim=True), min=1.0)


def unfold_sandwiches(first: torch.Tensor, windows: Sequence[Sandwich], refined: torch.Tensor,
                      ramp: int) -> torch.Tensor:
    """The refined sandwiches back on the timeline: per frame (1 - Σw)·first take + Σ w_k·sandwich k, with the
    weights of :func:`unfold_weights` (the sum never exceeds 1)."""
    weights = unfold_weights(windows, ramp, first.shape[0])
    out = (1 - weights.sum(0))[:, None] * first
    for i, s in enumerate(windows):
        out[s.lo : s.hi] += weights[i, s.lo : s.hi, None] * refined[i, : s.frames]
    return out


def second_take_timesteps(take: SecondTake, steps: int, schedule: CosineSchedule | None = None) -> list[int]:
    """The timesteps the second take denoises through: those of ``take.steps`` (else the first take's ``steps``)
    sampling steps at or below T' = ``take.renoise`` of the schedule."""
    schedule = schedule or CosineSchedule()
    return [t for t in schedule.timesteps(take.steps or steps) if t <= take.renoise * (schedule.steps - 1)]


def second_take(loaded: LoadedModel, first: torch.Tensor, transitions: Sequence[tuple[int, int]], take: SecondTake, *,
                sample: SampleConfig, on_step=None, prompts: Sequence[str | None] | None = None) -> torch.Tensor:
    """Re-noise each transition sandwich of the unfolded first take, denoise it with soft masks, unfold it back.

    ``prompts``: one per transition, used (with the sample's guidance) when ``take.text``; otherwise unconditional.
    Empty transitions (a handshake of 0 frames: a cut) have no sandwich and stay as the first take made them.
    """
    if take.text and (prompts is None or len(prompts) != len(transitions)):
        raise ValueError(f"a second take with text needs one prompt per transition ({len(transitions)})")
    windows = sandwiches(transitions, first.shape[0], take, loaded.model.config.max_frames)
    if not windows:
        return first
    n = max(s.frames for s in windows)
    known = torch.zeros(len(windows), n, first.shape[1])
    keep = torch.ones(len(windows), n)
    for i, s in enumerate(windows):
        known[i, : s.frames] = first[s.lo : s.hi]
        keep[i, : s.frames] = 1 - allowance(s.frames, s.handshake, take)
    texts = [p for p, (a, b) in zip(prompts, transitions) if b > a] if take.text else [None] * len(windows)
    request = Request(prompts=texts, frames=[s.frames for s in windows])
    cond, _ = build_condition(loaded, request)
    schedule = CosineSchedule()
    timesteps = second_take_timesteps(take, sample.steps, schedule)
    if not timesteps:
        return first
    g = torch.Generator().manual_seed(sample.seed + 17)
    ab = schedule.alpha_bar(torch.tensor(timesteps[0])).item()
    x = ab**0.5 * known + (1 - ab) ** 0.5 * torch.randn(known.shape, generator=g)
    base = denoiser_for(loaded, sample) if take.text else loaded.model
    denoiser = SoftInpaint(base, known=known, keep=keep)
    if take.planted_feet:  # after the soft mask: the blended prediction is what the next step and the user see
        denoiser = PlantedFeet(denoiser, loaded.normalizer)
    last = None
    for last in run_loop(denoiser, x, cond, schedule=schedule, timesteps=timesteps, eta=take.eta):
        if on_step is not None:
            on_step(last)
    return unfold_sandwiches(first, windows, last.x_prev, take.ramp)
