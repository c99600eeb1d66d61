"""MotionCLR edits as functions the CLI, the app and the benchmark share.

Each runs one batch with named roles and shared noise, so "before" and "after" differ only by
the edit. Sources for example-based generation and style transfer are a prompt (generated) or
a real motion (DDIM-inverted, then reconstructed in the batch without text).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch

from engine.analysis.counting import CountingConfig, CountResult, count_from_attention, count_from_root_height
from engine.attention import AttentionStore, StoreConfig, stack
from engine.checkpoint import LoadedModel
from engine.diffusion import StepState
from engine.generate import Generation, Request, SampleConfig, build_condition, denoiser_for, generate
from engine.methods.hooks import PinTrajectory
from engine.methods.inversion import InversionConfig, invert
from engine.methods.motionclr import (
    ExampleBased, ExampleConfig, Ground, GroundingConfig, Replace, ReplaceConfig, Reweight, ReweightConfig, Shift,
    ShiftConfig, StyleTransfer, StyleTransferConfig, erased,
)
from engine.methods.word_alignment import WordAlignment, align_words
from engine.methods.intensity import with_intensity
from engine.methods.word_guidance import PromptGuidance, WordGuidance

Source = str | np.ndarray  # a prompt, or joints (T, 22, 3) of a real motion
OnStep = Callable[[StepState], None] | None  # called after every sampling step (progress, cancel by raising)


@dataclass
class EditOutput:
    generation: Generation
    before_role: str
    after_role: str
    store: AttentionStore | None = None
    extra: dict = field(default_factory=dict)

    def joints(self, role: str, index: int = 0) -> np.ndarray:
        slots = [i for i, r in enumerate(self.generation.roles.names) if r == role]
        if index >= len(slots):
            raise KeyError(f"no slot {index} for role {role!r} in {self.generation.roles.names}")
        return self.generation.joints[slots[index]]

    @property
    def before(self) -> np.ndarray:
        return self.joints(self.before_role)

    @property
    def after(self) -> np.ndarray:
        return self.joints(self.after_role)


def _noise(loaded: LoadedModel, slots: int, frames: int, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.randn(1, frames, loaded.model.config.feature_dim, generator=g).expand(slots, -1, -1).clone()


def _store(record: bool) -> AttentionStore | None:
    return AttentionStore(StoreConfig(budget_bytes=512 * 1024 * 1024)) if record else None


def _pair_edit(loaded, prompt: str, controller, *, frames: int, sample: SampleConfig, record: bool,
               roles=("ref", "out"), prompts=None, on_step: OnStep = None, denoiser=None) -> EditOutput:
    store = _store(record)
    request = Request(prompts=list(prompts or [prompt, prompt]), frames=[frames] * len(roles), roles=list(roles),
                      noise=_noise(loaded, len(roles), frames, sample.seed))
    gen = generate(loaded, request, sample, controller=stack(controller, store), on_step=on_step, denoiser=denoiser)
    return EditOutput(generation=gen, before_role=roles[0], after_role=roles[1], store=store)


def reweight(loaded: LoadedModel, prompt: str, config: ReweightConfig, *, frames: int,
             sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """(De-)emphasis or erasing of ``config.word``: "ref" is the unedited motion, "out" the edited one. Guide mode
    samples through :class:`WordGuidance` (the word's column erased in the other pass) instead of a controller."""
    loaded.tokenizer.encode(prompt).word_index(config.word, config.occurrence)  # a clear error for a missing word
    if config.mode == "intensity":
        return _intensity_edit(loaded, prompt, config, frames=frames, sample=sample, record=record, on_step=on_step)
    if config.mode == "guide":
        erase = Reweight(erased(config), num_steps=sample.steps)
        guided = WordGuidance(denoiser_for(loaded, sample), erase=erase, weight=config.weight, role=config.role,
                              steps=erase.window.steps)
        return _pair_edit(loaded, prompt, None, frames=frames, sample=sample, record=record, on_step=on_step,
                          denoiser=guided)
    return _pair_edit(loaded, prompt, Reweight(config, num_steps=sample.steps), frames=frames, sample=sample, record=record,
                      on_step=on_step)


def _intensity_edit(loaded: LoadedModel, prompt: str, config: ReweightConfig, *, frames: int, sample: SampleConfig,
                    record: bool, on_step: OnStep) -> EditOutput:
    """Emphasis in "intensity" mode: "out" guided towards the prompt said with the action's intensity word ("high"
    for a positive weight, "a little" for a negative one, by |weight|); ``extra["toward"]`` is that prompt."""
    level = "high" if config.weight >= 0 else "a little"
    toward = with_intensity(prompt, config.word, level=level, occurrence=config.occurrence)
    cond, _ = build_condition(loaded, Request(prompts=[toward], frames=[frames]))
    span = config.frames
    guided = PromptGuidance(denoiser_for(loaded, sample), toward=cond, weight=abs(config.weight), role=config.role,
                            steps=config.window.bind(sample.steps).steps,
                            frames=(max(0, span[0]), min(frames, span[1])) if span is not None else None)
    out = _pair_edit(loaded, prompt, None, frames=frames, sample=sample, record=record, on_step=on_step,
                     denoiser=guided)
    out.extra["toward"] = toward
    return out


def ground(loaded: LoadedModel, prompt: str, config: GroundingConfig, *, frames: int,
           sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """Grounded generation: ``config.word`` emphasised inside its mask's span(s), de-emphasised outside; "ref" is the
    unedited motion, "out" the grounded one (``extra["spans"]``: the mask's spans)."""
    loaded.tokenizer.encode(prompt).word_index(config.word)
    if len(config.mask) != frames:
        raise ValueError(f"the grounding mask covers {len(config.mask)} frames but the motion has {frames}")
    out = _pair_edit(loaded, prompt, Ground(config, num_steps=sample.steps), frames=frames, sample=sample,
                     record=record, on_step=on_step)
    out.extra["spans"] = config.spans
    return out


def replace(loaded: LoadedModel, reference: str, edited: str, config: ReplaceConfig = ReplaceConfig(), *, frames: int,
            sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """In-place replacement: the edited prompt's action lands in the reference's time slots.

    The prompts' words (as the model reads them) are aligned as prompt-to-prompt aligns them; the alignment is in
    ``extra["alignment"]`` (an :class:`engine.methods.word_alignment.WordAlignment`)."""
    out = replace_alignment(loaded, reference, edited)
    result = _pair_edit(loaded, reference, Replace(config, num_steps=sample.steps), frames=frames, sample=sample,
                        record=record, roles=(config.source, config.target), prompts=[reference, edited],
                        on_step=on_step)
    result.extra["alignment"] = out
    return result


def replace_alignment(loaded: LoadedModel, reference: str, edited: str) -> WordAlignment:
    """The words of both prompts as the model reads them, aligned as the replacement will align them."""
    return align_words(loaded.tokenizer.encode(reference).words, loaded.tokenizer.encode(edited).words)


def shift(loaded: LoadedModel, prompt: str, config: ShiftConfig = ShiftConfig(), *, frames: int,
          sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """Sequence shifting: the edited motion is the reference with its first ``fraction`` moved to the end."""
    return _pair_edit(loaded, prompt, Shift(config, num_steps=sample.steps, frames=frames), frames=frames,
                      sample=sample, record=record, roles=(config.source, config.target), on_step=on_step)


def _resolve(loaded: LoadedModel, source: Source, frames: int, seed: int,
             steps: int) -> tuple[str | None, torch.Tensor, int, dict | None]:
    """(prompt or None, initial noise (1, T, D), frames, pinned path or None) for a generated or a real source. A
    real source's slot follows its inversion path (``PinTrajectory``, as MoMo's real leaders do): it is that motion
    at every step, whatever the sampler's eta."""
    if isinstance(source, str):
        loaded.tokenizer.encode(source)
        g = torch.Generator().manual_seed(seed)
        return source, torch.randn(1, frames, loaded.model.config.feature_dim, generator=g), frames, None
    inverted = invert(loaded, np.asarray(source), InversionConfig(prompt="", steps=steps))
    return None, inverted.noise, inverted.noise.shape[1], inverted.trajectory


def _pins(paths: dict[int, dict | None], frames: int) -> list[PinTrajectory]:
    """The hook pinning each real-source slot to its inversion path, cut to ``frames``; [] without one."""
    pinned = {slot: {t: z[:, :frames] for t, z in path.items()} for slot, path in paths.items() if path is not None}
    return [PinTrajectory(pinned)] if pinned else []


def example_based(loaded: LoadedModel, example: Source, config: ExampleConfig = ExampleConfig(), *, count: int = 4,
                  frames: int, sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """``count`` diverse motions whose self-attention queries are the example's, shuffled in chunks of
    ``config.chunk_frames`` frames."""
    if not 1 <= count <= 16:
        raise ValueError("count must be between 1 and 16")
    prompt, example_noise, frames, path = _resolve(loaded, example, frames, sample.seed, sample.steps)
    g = torch.Generator().manual_seed(sample.seed + 1)
    outs = torch.randn(count, frames, example_noise.shape[-1], generator=g)
    roles = [config.example] + [config.target] * count
    request = Request(prompts=[prompt] * (count + 1), frames=[frames] * (count + 1), roles=roles,
                      noise=torch.cat([example_noise, outs]))
    store = _store(record)
    gen = generate(loaded, request, sample, hooks=_pins({0: path}, frames),
                   controller=stack(ExampleBased(config, num_steps=sample.steps, frames=frames), store), on_step=on_step)
    return EditOutput(generation=gen, before_role=config.example, after_role=config.target, store=store)


def style_transfer(loaded: LoadedModel, *, style: Source, content: Source,
                   config: StyleTransferConfig = StyleTransferConfig(), frames: int,
                   sample: SampleConfig = SampleConfig(), record: bool = False, on_step: OnStep = None) -> EditOutput:
    """The output starts from the content's noise and prompt; its Q comes from the style motion."""
    style_prompt, style_noise, style_frames, style_path = _resolve(loaded, style, frames, sample.seed, sample.steps)
    content_prompt, content_noise, content_frames, content_path = _resolve(loaded, content, frames, sample.seed + 7,
                                                                           sample.steps)
    n = min(style_frames, content_frames)
    noise = torch.cat([style_noise[:, :n], content_noise[:, :n], content_noise[:, :n]])
    request = Request(prompts=[style_prompt, content_prompt, content_prompt], frames=[n] * 3,
                      roles=[config.style, config.content, config.target], noise=noise)
    store = _store(record)
    gen = generate(loaded, request, sample, controller=stack(StyleTransfer(config, num_steps=sample.steps), store),
                   hooks=_pins({0: style_path, 1: content_path}, n), on_step=on_step)
    return EditOutput(generation=gen, before_role=config.content, after_role=config.target, store=store)


@dataclass(frozen=True)
class CountingRun:
    """Where the self-attention map for counting comes from: mean over heads, these layers and steps.

    ``layers`` None: every layer but the first ``skip_layers`` fraction of them (rounded; at least one is
    kept). The first layers attend mostly to neighbouring frames, which blurs the stripes a repetition
    draws; on 300 training-split corpus motions, skipping the first third (layers 2–5 of 6) counted 92 %
    exactly against 89 % with every layer (``moattn bench --edits`` reports the held-out figure).
    """

    layers: tuple[int, ...] | None = None
    skip_layers: float = 1 / 3
    steps: tuple[float, float] = (0.5, 1.0)  # fraction window of the sampling run
    counting: CountingConfig = CountingConfig()

    def __post_init__(self) -> None:
        if not 0.0 <= self.skip_layers < 1.0:
            raise ValueError(f"skip_layers must be a fraction in [0, 1), got {self.skip_layers}")
        if not 0.0 <= self.steps[0] < self.steps[1] <= 1.0:
            raise ValueError(f"steps must be a window 0 <= start < end <= 1, got {self.steps}")

    def chosen_layers(self, available: list[int]) -> list[int]:
        """The layers (of those recorded, in order) whose maps are averaged."""
        if self.layers is not None:
            missing = sorted(set(self.layers) - set(available))
            if missing:
                raise ValueError(f"counting layers {missing} were not recorded (recorded: {available})")
            return [l for l in available if l in self.layers]
        skip = min(len(available) - 1, int(round(self.skip_layers * len(available))))
        return list(available)[skip:]

    def chosen_steps(self, recorded: list[int], num_steps: int) -> list[int]:
        """The recorded steps inside the step window (all recorded ones when none falls inside)."""
        lo, hi = int(self.steps[0] * num_steps), int(self.steps[1] * num_steps)
        return [s for s in recorded if lo <= s < hi] or list(recorded)


@dataclass
class Count:
    attention: CountResult
    baseline: int
    self_map: np.ndarray


def count_actions(store: AttentionStore, joints: np.ndarray, *, frames: int, num_steps: int, slot: int = 0,
                  run: CountingRun = CountingRun()) -> Count:
    """Count repetitions from recorded self-attention (MotionCLR) beside root-height peaks."""
    steps = run.chosen_steps(store.steps, num_steps)
    layers = run.chosen_layers(store.layers)
    attn = store.mean_map(kind="self", slot=slot, steps=steps, layers=layers).numpy()[:frames, :frames]
    return Count(attention=count_from_attention(attn, run.counting),
                 baseline=count_from_root_height(joints[:, 0, 1]), self_map=attn)


def count_generated(loaded: LoadedModel, prompt: str, *, frames: int, sample: SampleConfig = SampleConfig(),
                    run: CountingRun = CountingRun()) -> tuple[Count, Generation]:
    store = AttentionStore(StoreConfig(kinds=("self",)))
    gen = generate(loaded, Request(prompts=[prompt], frames=[frames]), sample, controller=store)
    return count_actions(store, gen.joints[0], frames=frames, num_steps=sample.steps, run=run), gen


def count_motion(loaded: LoadedModel, joints: np.ndarray, *, prompt: str = "", steps: int = 20,
                 run: CountingRun = CountingRun()) -> Count:
    """Count on a given (real or corpus) motion: invert it, then record self-attention while it is rebuilt."""
    inverted = invert(loaded, joints, InversionConfig(prompt=prompt, steps=steps, refine=1))
    frames = inverted.noise.shape[1]
    store = AttentionStore(StoreConfig(kinds=("self",)))
    request = Request(prompts=[prompt or None], frames=[frames], noise=inverted.noise)
    generate(loaded, request, SampleConfig(steps=steps, guidance=1.0), controller=store,
             hooks=_pins({0: inverted.trajectory}, frames))  # the motion itself at every step
    return count_actions(store, np.asarray(joints), frames=frames, num_steps=steps, run=run)
