"""Text -> motion with the shipped (or any) model: the function the CLI, the app and methods share."""
from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch

from engine.attention.context import BatchRoles, WordIndex
from engine.attention.controller import AttentionController
from engine.checkpoint import LoadedModel
from engine.diffusion import ClassifierFreeGuidance, CosineSchedule, StepState, ddim, ddpm
from engine.diffusion.sampler import StepHook
from engine.model.denoiser import Condition
from engine.representation import features_to_joints
from engine.text import TokenizedPrompt
from engine.units import (DEFAULT_ETA, DEFAULT_GUIDANCE, DEFAULT_GUIDANCE_FROM, DEFAULT_STEPS, FPS,  # noqa: F401
                          MAX_SECONDS, MIN_SECONDS)  # (re-exported)



@dataclass(frozen=True)
class SampleConfig:
    """How to sample. ``guidance`` 1.0 = no classifier-free guidance; MotionCLR uses 2.5. ``guidance_from``: the
    guidance applies only at timesteps t >= this (0: at every step, classic classifier-free guidance). ``eta``: the
    fresh noise each DDIM step adds (0: deterministic; 1: the DDPM posterior's), drawn per slot from the slot's own
    starting noise (``engine.diffusion.sampler.SlotNoise``), so a seed still gives one motion."""

    steps: int = DEFAULT_STEPS
    guidance: float = DEFAULT_GUIDANCE
    guidance_from: int = DEFAULT_GUIDANCE_FROM
    eta: float = DEFAULT_ETA
    sampler: str = "ddim"  # "ddim" | "ddpm"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.sampler not in ("ddim", "ddpm"):
            raise ValueError(f"sampler must be 'ddim' or 'ddpm', got {self.sampler!r}")
        if not 1 <= self.steps <= 1000:
            raise ValueError(f"steps must be between 1 and 1000, got {self.steps}")
        if not 0.0 <= self.guidance <= 20.0:
            raise ValueError(f"guidance must be between 0 and 20, got {self.guidance}")
        if not 0.0 <= self.eta <= 1.0:
            raise ValueError(f"eta must be between 0 and 1, got {self.eta}")
        if not 0 <= self.guidance_from < 1000:
            raise ValueError(f"guidance_from must be a timestep from 0 to 999, got {self.guidance_from}")

    def guided(self, denoiser):
        """``denoiser`` wrapped in this config's classifier-free guidance (itself when there is none)."""
        if self.guidance == 1.0:
            return denoiser
        return ClassifierFreeGuidance(denoiser, scale=self.guidance, from_t=self.guidance_from)


def frames_for(seconds: float) -> int:
    """Number of feature frames for a duration; clear errors outside what the model supports."""
    if not np.isfinite(seconds):
        raise ValueError("the duration must be a number of seconds")
    if not MIN_SECONDS <= seconds <= MAX_SECONDS:
        raise ValueError(f"the duration must be between {MIN_SECONDS} and {MAX_SECONDS} s, got {seconds:g} s")
    return int(round(seconds * FPS))


@dataclass
class Request:
    """A batch to sample: one prompt, length and role per slot (a None prompt = unconditional slot)."""

    prompts: Sequence[str | None]
    frames: Sequence[int]
    roles: Sequence[str] = ()
    noise: torch.Tensor | None = None  # (B, T, 263), else drawn from the seed
    extras: dict = field(default_factory=dict)


@dataclass
class Generation:
    features: np.ndarray  # (B, T, 263) de-normalised
    joints: list[np.ndarray]  # per slot (T_i + ... , 22, 3) trimmed to its length
    tokens: list[TokenizedPrompt]
    roles: BatchRoles
    noise: torch.Tensor
    x0: torch.Tensor  # (B, T, 263) normalised result


def build_condition(loaded: LoadedModel, request: Request) -> tuple[Condition, list[TokenizedPrompt]]:
    if len(request.prompts) != len(request.frames):
        raise ValueError("one length per prompt is needed")
    tokens = [TokenizedPrompt(prompt="", words=(), ids=()) if p is None else loaded.tokenizer.encode(p)
              for p in request.prompts]
    ids, mask = loaded.tokenizer.batch(tokens)
    length = max(request.frames)
    frame_mask = torch.zeros(len(tokens), length, dtype=torch.bool)
    for i, n in enumerate(request.frames):
        frame_mask[i, :n] = True
    roles = BatchRoles(names=tuple(request.roles) if request.roles else ("out",) * len(tokens))
    cond = Condition(text_ids=ids, text_mask=mask, frame_mask=frame_mask,
                     use_text=torch.tensor([p is not None for p in request.prompts]), roles=roles,
                     words=WordIndex(words=tuple(t.words for t in tokens)), extras=dict(request.extras))
    return cond, tokens


def denoiser_for(loaded: LoadedModel, config: SampleConfig):
    return config.guided(loaded.model)


def sample_states(
    loaded: LoadedModel,
    request: Request,
    config: SampleConfig,
    *,
    controller: AttentionController | None = None,
    hooks: Sequence[StepHook] = (),
    denoiser=None,
) -> tuple[Iterator[StepState], Condition, list[TokenizedPrompt], torch.Tensor]:
    """The step-state stream for a request (the app iterates it to show progress)."""
    cond, tokens = build_condition(loaded, request)
    shape = (len(tokens), max(request.frames), loaded.model.config.feature_dim)
    generator = torch.Generator().manual_seed(config.seed)
    noise = request.noise if request.noise is not None else torch.randn(shape, generator=generator)
    if tuple(noise.shape) != shape:
        raise ValueError(f"noise has shape {tuple(noise.shape)}, expected {shape}")
    denoiser = denoiser or denoiser_for(loaded, config)
    schedule = CosineSchedule()
    if config.sampler == "ddpm":
        states = ddpm(denoiser, noise, cond, schedule=schedule, num_steps=config.steps, controller=controller,
                      hooks=hooks)
    else:
        states = ddim(denoiser, noise, cond, schedule=schedule, num_steps=config.steps, eta=config.eta,
                      controller=controller, hooks=hooks)
    return states, cond, tokens, noise


def finish(loaded: LoadedModel, x0: torch.Tensor, request: Request, tokens, roles: BatchRoles, noise) -> Generation:
    features = loaded.normalizer.denormalize(x0.detach().cpu().numpy())
    joints = [features_to_joints(features[i, :n]) for i, n in enumerate(request.frames)]
    return Generation(features=features, joints=joints, tokens=tokens, roles=roles, noise=noise, x0=x0)


def generate(
    loaded: LoadedModel,
    request: Request,
    config: SampleConfig = SampleConfig(),
    *,
    controller: AttentionController | None = None,
    hooks: Sequence[StepHook] = (),
    on_step: Callable[[StepState], None] | None = None,
    denoiser=None,
) -> Generation:
    states, cond, tokens, noise = sample_states(loaded, request, config, controller=controller, hooks=hooks,
                                                denoiser=denoiser)
    last = None
    for last in states:
        if on_step is not None:
            on_step(last)
    return finish(loaded, last.x_prev, request, tokens, cond.roles, noise)
