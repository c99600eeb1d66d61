"""The one sampling loop: DDIM (any steps, eta), DDPM (eta = 1 over every step) and DDIM inversion.

A denoiser is anything with the model's call signature ``G(x, t, cond, *, step, controller) -> x0_hat``
(the model itself, classifier-free guidance, DiffusionBlending ...). The loop yields a
``StepState`` per step; step-end hooks may return a changed state (inpainting, DoubleTake
handshakes, progress), and the controller's ``on_step_end`` sees every state.
"""
from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

import torch

from engine.attention.controller import AttentionController
from engine.diffusion.schedule import CosineSchedule
from engine.model.denoiser import Condition
from engine.units import MAX_FRAMES

CLEAN = -1  # the "timestep" of clean data


class DenoiserFn(Protocol):
    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond: Condition, *, step: int = 0,
                 controller: AttentionController | None = None) -> torch.Tensor: ...


@dataclass(frozen=True)
class StepState:
    step: int  # 0 = first (noisiest when sampling)
    num_steps: int
    t: int  # timestep the denoiser saw
    t_next: int  # timestep of x_prev (CLEAN = -1 at the end of sampling)
    x_t: torch.Tensor  # (B, T, D) input of this step
    x0_hat: torch.Tensor  # (B, T, D) the denoiser's prediction
    x_prev: torch.Tensor  # (B, T, D) the loop's next state


StepHook = Callable[[StepState], "StepState | None"]


class SlotNoise:
    """The noise a stochastic step (eta > 0) adds, one stream per slot, keyed by the slot's own starting noise.

    Slots that start from the same noise get the same noise at every step, wherever they sit in a batch and however
    long the batch is: an edit's ``ref`` slot retraces the motion the user generated alone from that seed, its ``out``
    slot differs from ``ref`` only by the edit, and a regenerated leader beside its followers is the leader. A
    stream is drawn at ``max(MAX_FRAMES, T)`` frames a step and cut to the batch's T, so padding changes nothing.
    """

    def __init__(self, start: torch.Tensor):  # start: (B, T, D), the loop's first x
        self.frames = max(MAX_FRAMES, start.shape[1])
        self.generators = [torch.Generator().manual_seed(self.key(row[0])) for row in start]

    @staticmethod
    def key(first_frame: torch.Tensor) -> int:
        """A 63-bit seed from a slot's first noise frame (D values: unique to the slot's start, padding-free)."""
        data = first_frame.detach().to("cpu", torch.float32).contiguous().numpy().tobytes()
        return int.from_bytes(hashlib.blake2b(data, digest_size=8).digest(), "little") >> 1

    def draw(self, like: torch.Tensor) -> torch.Tensor:  # like: (B, T, D) -> (B, T, D)
        _, frames, dim = like.shape
        noise = torch.stack([torch.randn(self.frames, dim, generator=g)[:frames] for g in self.generators])
        return noise.to(like.device, like.dtype)  # drawn on the CPU: the same stream on every device


class Cancelled(RuntimeError):
    """Raised by a hook (e.g. the app's cancel button) to stop sampling."""


def run_loop(
    denoiser: DenoiserFn,
    x: torch.Tensor,
    cond: Condition,
    *,
    schedule: CosineSchedule,
    timesteps: Sequence[int],
    eta: float = 0.0,
    controller: AttentionController | None = None,
    hooks: Sequence[StepHook] = (),
) -> Iterator[StepState]:
    """Walk x along ``timesteps`` (descending: sampling; ascending: inversion).

    Each step predicts x0_hat at t and moves to the next timestep with the DDIM update
    (eta = 0 deterministic, eta = 1 the DDPM posterior, its noise from :class:`SlotNoise`); after the last timestep
    a descending walk lands on clean data (x_prev = x0_hat).
    """
    ts = list(timesteps)
    descending = len(ts) < 2 or ts[0] > ts[-1]
    targets = ts[1:] + ([CLEAN] if descending else [])
    pairs = list(zip(ts, targets))
    if not descending and eta != 0.0:
        raise ValueError("DDIM inversion is deterministic: eta must be 0")
    b = x.shape[0]
    slot_noise = SlotNoise(x) if eta > 0 else None
    for i, (t, t_next) in enumerate(pairs):
        t_batch = torch.full((b,), t, dtype=torch.long)
        with torch.no_grad():
            x0_hat = denoiser(x, t_batch, cond, step=i, controller=controller)
        ab = schedule.alpha_bar(torch.tensor(t)).item()
        ab_next = schedule.alpha_bar(torch.tensor(t_next)).item()
        eps = (x - ab**0.5 * x0_hat) / max(1 - ab, 1e-12) ** 0.5
        sigma = 0.0
        if eta > 0 and t_next != CLEAN:
            sigma = eta * ((1 - ab_next) / (1 - ab) * (1 - ab / ab_next)) ** 0.5
        x_prev = ab_next**0.5 * x0_hat + max(1 - ab_next - sigma**2, 0.0) ** 0.5 * eps
        if sigma > 0:
            x_prev = x_prev + sigma * slot_noise.draw(x)
        state = StepState(step=i, num_steps=len(pairs), t=t, t_next=t_next, x_t=x, x0_hat=x0_hat, x_prev=x_prev)
        for hook in hooks:
            changed = hook(state)
            if changed is not None:
                state = changed
        if controller is not None:
            controller.on_step_end(state)
        yield state
        x = state.x_prev


def final(states: Iterator[StepState]) -> StepState:
    last = None
    for last in states:
        pass
    if last is None:
        raise ValueError("the loop ran no steps")
    return last


def ddim(denoiser: DenoiserFn, noise: torch.Tensor, cond: Condition, *, schedule: CosineSchedule,
         num_steps: int = 50, eta: float = 0.0, **kwargs) -> Iterator[StepState]:
    return run_loop(denoiser, noise, cond, schedule=schedule, timesteps=schedule.timesteps(num_steps), eta=eta, **kwargs)


def ddpm(denoiser: DenoiserFn, noise: torch.Tensor, cond: Condition, *, schedule: CosineSchedule,
         num_steps: int | None = None, **kwargs) -> Iterator[StepState]:
    return run_loop(denoiser, noise, cond, schedule=schedule,
                    timesteps=schedule.timesteps(num_steps or schedule.steps), eta=1.0, **kwargs)


@dataclass
class FixedPointInversion:
    """Step-end hook that makes DDIM inversion (nearly) exactly invertible by the sampler.

    Plain inversion reuses the prediction at t for the step to t_next (first-order error). This
    hook corrects x_next so that the deterministic DDIM sampling step from (x_next, t_next) lands
    on x_t, by residual iteration: x_next += x_t - ddim_step(x_next, t_next -> t). The residual
    form is well conditioned where 1 - alpha_bar_t is tiny (the first step), unlike solving
    for x_next through eps. Each item keeps its best iterate, so a step where the iteration does
    not contract (a rough model, an out-of-distribution motion) falls back to plain DDIM's.
    """

    denoiser: DenoiserFn
    cond: Condition
    schedule: CosineSchedule
    iterations: int = 3
    controller: AttentionController | None = None

    def __call__(self, state: StepState) -> StepState:
        if state.t_next == CLEAN or self.iterations <= 0:
            return state
        ab = self.schedule.alpha_bar(torch.tensor(state.t)).item()
        ab_next = self.schedule.alpha_bar(torch.tensor(state.t_next)).item()
        t_batch = torch.full((state.x_t.shape[0],), state.t_next, dtype=torch.long)
        x_next = state.x_prev
        best, best_norm = x_next, None
        for i in range(self.iterations + 1):
            with torch.no_grad():
                x0 = self.denoiser(x_next, t_batch, self.cond, step=state.step, controller=self.controller)
            eps = (x_next - ab_next**0.5 * x0) / max(1 - ab_next, 1e-12) ** 0.5
            residual = state.x_t - (ab**0.5 * x0 + (1 - ab) ** 0.5 * eps)
            # keep, per batch item, the iterate whose sampling step lands closest to x_t:
            # the iteration is only a contraction where the model is smooth enough
            best, best_norm, better = _keep_best(x_next, residual, best, best_norm)
            if i == self.iterations or not better.any():
                break
            x_next = x_next + residual
        x_next = best
        return replace(state, x_prev=x_next)


def _keep_best(x: torch.Tensor, residual: torch.Tensor, best: torch.Tensor,
               best_norm: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per batch item, keep the iterate with the smallest finite residual: (best, best_norm, which improved)."""
    dims = tuple(range(1, residual.dim()))
    norm = residual.pow(2).sum(dims).sqrt()
    if best_norm is None:
        better = torch.isfinite(norm)
        best_norm = torch.full_like(norm, float("inf"))
    else:
        better = torch.isfinite(norm) & (norm < best_norm)
    best_norm = torch.where(better, norm, best_norm)
    best = torch.where(better.view(-1, *[1] * len(dims)), x, best)
    return best, best_norm, better


def land(denoiser: DenoiserFn, x0: torch.Tensor, cond: Condition, *, schedule: CosineSchedule, t: int,
         iterations: int, controller: AttentionController | None = None) -> torch.Tensor:
    """The inversion's first step, clean -> ``t`` (the sampler's cleanest timestep): the latent x_t whose last
    sampling step lands on the clean motion, i.e. x0_hat(x_t, t) = x0 (B, T, D).

    Classic DDIM inversion takes x0 itself as x_t, so the rebuild's last step returns x0_hat(x0, t), which is x0
    only where the model reproduces its input (a motion like its corpus). Residual iteration x_t += sqrt(ab) ·
    (x0 - x0_hat(x_t)) solves it where the prediction follows its input near t = 0 (a model with a skip, for a
    condition that keeps its input); each item keeps its best iterate, so a model whose prediction ignores its
    input at t keeps x0, as classic inversion does.
    """
    ab = schedule.alpha_bar(torch.tensor(t)).item()
    t_batch = torch.full((x0.shape[0],), t, dtype=torch.long)
    x, best, best_norm = x0, x0, None
    for i in range(iterations + 1):
        with torch.no_grad():
            residual = x0 - denoiser(x, t_batch, cond, step=0, controller=controller)
        best, best_norm, better = _keep_best(x, residual, best, best_norm)
        if i == iterations or not better.any():
            break
        x = x + ab**0.5 * residual
    return best


def ddim_invert(denoiser: DenoiserFn, x0: torch.Tensor, cond: Condition, *, schedule: CosineSchedule,
                num_steps: int = 50, refine: int = 2, landing: int = 0, hooks: Sequence[StepHook] = (),
                **kwargs) -> Iterator[StepState]:
    """Clean motion -> noise that DDIM with the same steps maps back to it (x_prev of the last state).

    ``refine`` fixed-point iterations per step (each one more denoiser call) make the round trip
    nearly exact; 0 gives classic DDIM inversion. ``landing`` iterations solve the first step, clean -> the
    cleanest timestep (:func:`land`); 0 takes the clean motion as that latent, as classic inversion does. The
    first state's ``x_t`` is the latent at the cleanest timestep.
    """
    ascending = list(reversed(schedule.timesteps(num_steps)))
    controller = kwargs.get("controller")
    if landing > 0:
        x0 = land(denoiser, x0, cond, schedule=schedule, t=ascending[0], iterations=landing, controller=controller)
    exact = FixedPointInversion(denoiser, cond, schedule, iterations=refine, controller=controller)
    return run_loop(denoiser, x0, cond, schedule=schedule, timesteps=ascending, eta=0.0,
                    hooks=[exact, *hooks], **kwargs)


