"""Text -> motion for the studio: checked settings, a cancellable step loop, recorded attention.

Nothing here touches Panel; the session state runs :func:`run_generation` on a worker thread and
posts its progress to the page.
"""
from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from app.attention_record import AttentionRecord, plan_steps
from app.model_cache import SAMPLING_SLOT
from engine.analysis.followed import follow_generated
from engine.checkpoint import LoadedModel
from engine.methods.generate_options import DEFAULT_SEQUENCE, DEFAULT_TRIES, MAX_TRIES
from engine.methods.held_direction import held_plan, held_take, plan_of
from engine.methods.sequence import generate_sequence, plan, sampling_steps, sequence_clauses, timeline_frames
from engine.generate import Request, SampleConfig, finish, frames_for, sample_states
from engine.duration import resolve_seconds
from engine.representation import features_to_joints
from engine.text import PromptError, TokenizedPrompt, split_words
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE, DEFAULT_GUIDANCE_FROM


@dataclass(frozen=True)
class GenerationSettings:
    prompt: str
    seconds: float | None = None  # None: predicted from the prompt (engine.duration, `--seconds auto`)
    seed: int = 0
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    guidance_from: int = DEFAULT_GUIDANCE_FROM  # the guidance applies at timesteps t >= this
    eta: float = DEFAULT_ETA  # the fresh noise each sampling step adds (0: deterministic DDIM)
    record_steps: int = 10
    # a prompt of several actions in order: "clauses" (each clause as its own prompt, joined with DoubleTake; no
    # attention maps) or "whole" (one take, attention recorded) - engine.methods.sequence
    sequence: str = DEFAULT_SEQUENCE
    # tries from the seed on (seed, seed + 1, ...), keeping the first that follows every checked attribute
    # (engine.analysis.followed.best_try); the kept motion's settings say its own seed and 1 try
    tries: int = DEFAULT_TRIES
    # this take walks the prompt's gait along the corpus's path with the root control model
    # (engine.methods.held_direction): what the later tries of one walk, run or jog do (HOLD_FROM_TRY)
    held_path: bool = False

    def clauses(self) -> tuple[str, ...]:
        """The clauses this prompt is generated as, one each; () where it is one take of the whole prompt."""
        return sequence_clauses(self.prompt, self.sequence)


@dataclass
class Checked:
    """Settings that passed every check, ready to sample."""

    settings: GenerationSettings
    tokens: TokenizedPrompt
    frames: int
    config: SampleConfig
    intervals: list | None = None  # the clauses as DoubleTake intervals (engine.methods.sequence), or one take

    @property
    def total_steps(self) -> int:
        """Sampling steps the run makes: clause by clause, DoubleTake's first take and then its second."""
        return self.config.steps if self.intervals is None else sampling_steps(self.config.steps)


@dataclass(frozen=True, eq=False)
class Denoising:
    """The x̂0 motion after every sampling step: what "scrub the denoising steps" shows."""

    steps: tuple[int, ...]  # 1-based steps done (the last is the final motion)
    num_steps: int
    joints: np.ndarray  # (S, T, 22, 3) float16, S == len(steps)
    recorded: tuple[int, ...] = ()  # 1-based steps whose attention was recorded

    @staticmethod
    def collect(history: list[tuple[int, np.ndarray]], *, num_steps: int, recorded=()) -> "Denoising | None":
        """From (1-based step, (T, 22, 3) joints) pairs; at most MAX_DENOISING_STEPS of them, evenly spread,
        the last kept."""
        if not history:
            return None
        keep = np.unique(np.linspace(0, len(history) - 1, min(len(history), MAX_DENOISING_STEPS)).round().astype(int))
        picked = [history[i] for i in keep]
        return Denoising(steps=tuple(s for s, _ in picked), num_steps=num_steps,
                         joints=np.stack([j for _, j in picked]).astype(np.float16),
                         recorded=tuple(sorted(int(s) for s in recorded)))


MAX_DENOISING_STEPS = 50  # x̂0 motions kept per generated motion (a 10-s motion's are 1.3 MB in float16)
PREVIEW_SECONDS = 0.08  # live x̂0 previews are sent at most this often (the first step's always)


@dataclass
class GenerationResult:
    settings: GenerationSettings
    words: tuple[str, ...]
    joints: np.ndarray  # (T, 22, 3)
    features: np.ndarray  # (T, 263) de-normalised
    attention: AttentionRecord | None
    seconds_taken: float
    denoising: Denoising | None = None
    # what the motion followed of its prompt (engine.analysis.followed), or why it could not be read; the tokenized
    # prompt's notes ("left out: stiffly"): what the Generate box shows under the result
    followed: object = None  # FollowReport | str | None
    notes: tuple[str, ...] = ()
    tried: tuple[int, ...] = ()  # the seeds tried (several tries), the kept one among them; () for one take


class Cancelled(Exception):
    """The user pressed Cancel."""


@contextlib.contextmanager
def sampling_slot(cancel: threading.Event | None = None,
                  on_wait: Callable[[int], None] | None = None) -> Iterator[None]:
    """Hold the process-wide sampling slot (one sampling run at a time; other sessions queue, first come first
    served).

    ``on_wait(place)`` is called while queued, whenever the number of runs ahead changes; raises
    :class:`Cancelled` if ``cancel`` is set while waiting (a closed session's job leaves the queue at once).
    """
    cancel = cancel or threading.Event()
    if not SAMPLING_SLOT.acquire(cancelled=cancel.is_set, on_place=on_wait):
        raise Cancelled()
    try:
        yield
    finally:
        SAMPLING_SLOT.release()


@dataclass(frozen=True)
class PromptReading:
    """A prompt as the engine will read it (``Tokenizer.encode``: one rule, in the engine), for a prompt box to show
    before running: the typed words, the engine's reading (``tokens``) and its notes ("read 'guy' as 'man'",
    "left out: over"), or why the engine refuses the prompt (``error``, one line: empty, too long, nothing that
    says a motion). Without a tokenizer (no model loaded) nothing is read, noted or refused."""

    words: tuple[str, ...] = ()
    tokens: TokenizedPrompt | None = None
    error: str = ""
    refused: tuple[str, ...] = ()  # the words the refusal names (the engine's PromptError.unknown)

    @property
    def blocked(self) -> bool:
        """The engine would refuse this prompt: a run button waits."""
        return bool(self.error)

    @property
    def left_out(self) -> tuple[str, ...]:
        """Typed words the model gets no token for (or, refused, the words the refusal names)."""
        return self.tokens.left_out if self.tokens is not None else self.refused

    @property
    def read_as(self) -> dict[str, str]:
        """Typed word -> the vocabulary word it is read as (by form, meaning or spelling)."""
        return dict(self.tokens.read_as) if self.tokens is not None else {}

    @property
    def read_by(self) -> dict[str, str]:
        return dict(self.tokens.read_by) if self.tokens is not None else {}

    @property
    def suggestions(self) -> dict[str, tuple[str, ...]]:
        """Replacements the engine offers for left-out words (meanings, or close spellings of a true typo)."""
        return dict(self.tokens.suggestions) if self.tokens is not None else {}

    @property
    def notes(self) -> list[str]:
        """The engine's notes (``TokenizedPrompt.notes``): what it will do with words it does not know."""
        return self.tokens.notes() if self.tokens is not None else []


def prompt_analysis(tokenizer, text: str) -> PromptReading:
    """How the engine will read ``text`` (:class:`PromptReading`), from ``tokenizer.encode`` alone."""
    words = tuple(split_words(text))
    if tokenizer is None:
        return PromptReading(words=words)
    try:
        return PromptReading(words=words, tokens=tokenizer.encode(text))
    except PromptError as exc:
        return PromptReading(words=words, error=str(exc), refused=tuple(exc.unknown))


def checked_frames(loaded: LoadedModel, seconds) -> int:
    """Frames for a duration typed in the UI; a ValueError with a user-facing message otherwise."""
    try:
        seconds = float(seconds)
    except (TypeError, ValueError):
        raise ValueError("the duration must be a number of seconds") from None
    frames = frames_for(seconds)
    if frames > loaded.model.config.max_frames:
        raise ValueError(f"this model handles at most {loaded.model.config.max_frames} frames "
                         f"({loaded.model.config.max_frames / 20:.1f} s)")
    return frames


def check(loaded: LoadedModel, settings: GenerationSettings) -> Checked:
    """Validate everything before any work starts; raises ValueError (PromptError) with a user-facing message."""
    tokens = loaded.tokenizer.encode(settings.prompt)
    intervals = plan(settings.prompt, seconds=settings.seconds, sequence=settings.sequence, tempo=loaded.tempo)
    if intervals is None:
        frames = checked_frames(loaded, resolve_seconds(settings.seconds, settings.prompt, tempo=loaded.tempo))
    else:  # clause by clause: each clause within the model's length (plan), the joined motion as long as they make it
        frames = timeline_frames(intervals)
    if int(settings.seed) < 0:
        raise ValueError("the seed must be >= 0")
    config = SampleConfig(steps=int(settings.steps), guidance=float(settings.guidance),
                          guidance_from=int(settings.guidance_from), eta=float(settings.eta), seed=int(settings.seed))
    if settings.record_steps < 0:
        raise ValueError("record_steps must be >= 0")
    if not 1 <= int(settings.tries) <= MAX_TRIES:
        raise ValueError(f"tries must be 1 to {MAX_TRIES}, got {settings.tries}")
    return Checked(settings=settings, tokens=tokens, frames=frames, config=config, intervals=intervals)


def run_tries(loaded: LoadedModel, checked: Checked, *, on_step: Callable[[int, int], None] | None = None,
              on_try: Callable[[int, int, int], None] | None = None, **hooks) -> GenerationResult:
    """:func:`run_generation` from the seed on, up to ``settings.tries`` times (seed, seed + 1, ...), until a motion
    follows every checked attribute of its prompt; the kept one (:func:`engine.analysis.followed.best_try`) carries
    its own seed and ``tried``. ``on_step(done, total)`` counts every try's steps against all tries' (a run that
    stops early jumps to its end); ``on_try(k, tries, seed)`` before each of several tries; ``hooks``:
    run_generation's ``cancel``, ``on_wait`` and ``on_preview``."""
    from engine.analysis.followed import take_tries

    tries = int(checked.settings.tries)
    if tries <= 1:
        return run_generation(loaded, checked, on_step=on_step, **hooks)
    first, total = int(checked.settings.seed), checked.total_steps * tries

    def one_take(seed: int) -> GenerationResult:
        k = seed - first
        held = held_take(checked.settings.prompt, try_index=k, one_take=checked.intervals is None)
        one = replace(checked, settings=replace(checked.settings, seed=seed, tries=1, held_path=held),
                      config=replace(checked.config, seed=seed))
        step = None if on_step is None else (lambda done, _n: on_step(k * checked.total_steps + done, total))
        if on_try is not None:
            on_try(k, tries, seed)
        return run_generation(loaded, one, on_step=step, **hooks)

    index, results = take_tries(one_take, seed=first, tries=tries, report=lambda r: r.followed)
    if on_step is not None:
        on_step(total, total)
    return replace(results[index], tried=tuple(r.settings.seed for r in results),
                   seconds_taken=sum(r.seconds_taken for r in results))


def run_generation(
    loaded: LoadedModel,
    checked: Checked,
    *,
    on_step: Callable[[int, int], None] | None = None,
    cancel: threading.Event | None = None,
    on_wait: Callable[[], None] | None = None,
    on_preview: Callable[[int, int, np.ndarray], None] | None = None,
) -> GenerationResult:
    """Sample one motion, recording attention; ``on_step(done, total)`` after every step.

    Every step's x̂0 motion is kept (``result.denoising``, to scrub the denoising afterwards) and, at most
    every ``PREVIEW_SECONDS``, handed to ``on_preview(done, total, joints)`` while sampling (the first step's
    always): what the viewer shows live.

    Raises :class:`Cancelled` when ``cancel`` is set (checked between steps). Waits for the
    process-wide sampling slot first (``on_wait`` is called if it has to).
    """
    cancel = cancel or threading.Event()
    if checked.intervals is not None:
        return _run_sequence(loaded, checked, on_step=on_step, cancel=cancel, on_wait=on_wait)
    with sampling_slot(cancel, on_wait):
        start = time.perf_counter()
        settings, config = checked.settings, checked.config
        held = held_plan(loaded, settings.prompt, frames=checked.frames, sample=config) if settings.held_path else None
        if held is None and settings.held_path:  # no root control model, or no corpus path for it: the model's own
            settings = replace(settings, held_path=False)
        path = plan_of(held)
        request = Request(prompts=[settings.prompt], frames=[checked.frames], roles=["out"], noise=path.noise)
        store = _recording_store(settings, config, slots=1)
        states, cond, tokens, noise = sample_states(loaded, request, config, controller=store, hooks=path.hooks,
                                                    denoiser=path.denoiser)
        last = None
        timesteps: dict[int, int] = {}
        history: list[tuple[int, np.ndarray]] = []
        last_preview = -1.0
        for last in states:
            timesteps[last.step] = int(last.t)
            if cancel.is_set():
                raise Cancelled()
            done = last.step + 1
            x0 = loaded.normalizer.denormalize(last.x0_hat[0, : checked.frames].detach().cpu().numpy())
            history.append((done, features_to_joints(x0).astype(np.float16)))
            now = time.perf_counter()
            if on_preview is not None and done < last.num_steps and now - last_preview >= PREVIEW_SECONDS:
                last_preview = now
                on_preview(done, last.num_steps, history[-1][1].astype(np.float32))
            if on_step is not None:
                on_step(done, last.num_steps)
        generation = finish(loaded, last.x_prev, request, tokens, cond.roles, noise)
        joints = np.asarray(generation.joints[0], dtype=np.float32)
        if not np.isfinite(joints).all():
            raise ValueError("the model produced non-finite joints")
        record = None
        if store is not None:
            record = AttentionRecord.from_store(store, words=tokens[0].words, num_steps=config.steps,
                                                timesteps=timesteps)
        features = np.asarray(generation.features[0, : checked.frames], dtype=np.float32)
        recorded = [] if store is None else [s + 1 for s in plan_steps(config.steps, settings.record_steps)]
        history[-1] = (history[-1][0], joints.astype(np.float16))  # the final step is the result itself
        seconds_taken = time.perf_counter() - start
    follow, notes = follow_generated(settings.prompt, joints, tokens[0])  # outside the slot: others may sample
    notes = notes + (() if held is None else (held.note,))
    return GenerationResult(settings=settings, words=tokens[0].words, joints=joints, features=features,
                            attention=record, seconds_taken=seconds_taken,
                            denoising=Denoising.collect(history, num_steps=config.steps, recorded=recorded),
                            followed=follow, notes=notes)


STORE_BUDGET_PER_SLOT = 512 * 1024 * 1024  # bytes of recorded maps per batch slot (a prompt, or a clause)


def _recording_store(settings: GenerationSettings, config: SampleConfig, *, slots: int):
    """The attention store of a generation (both kinds, every layer and head, the conditional slots, at the planned
    steps), or None where recording is off."""
    from engine.attention import AttentionStore, StoreConfig

    if settings.record_steps <= 0:
        return None
    return AttentionStore(StoreConfig(kinds=("self", "cross"),
                                      steps=frozenset(plan_steps(config.steps, settings.record_steps)),
                                      conditional_only=True, budget_bytes=slots * STORE_BUDGET_PER_SLOT))


def _run_sequence(loaded: LoadedModel, checked: Checked, *, on_step, cancel: threading.Event, on_wait) -> GenerationResult:
    """A prompt of several actions in order, clause by clause (``checked.intervals``), joined with DoubleTake: both
    takes' steps are counted in ``on_step``. Attention is recorded in the first take, where each clause is a batch slot
    of its own prompt, and laid on the joined timeline (``AttentionRecord.from_timeline``: each clause's words attend
    over its own frames)."""
    settings, config = checked.settings, checked.config
    total, done = checked.total_steps, 0
    timesteps: dict[int, int] = {}
    store = _recording_store(settings, config, slots=len(checked.intervals))

    def step(state) -> None:
        nonlocal done
        if cancel.is_set():
            raise Cancelled()
        done += 1
        if done <= config.steps:  # the first take's steps: those the attention was recorded at
            timesteps[state.step] = int(state.t)
        if on_step is not None:
            on_step(min(done, total), total)

    with sampling_slot(cancel, on_wait):
        start = time.perf_counter()
        composed = generate_sequence(loaded, checked.intervals, config, on_step=step, controller=store)
        joints = np.asarray(composed.joints, dtype=np.float32)
        if not np.isfinite(joints).all():
            raise ValueError("the model produced non-finite joints")
        record = None
        if store is not None:
            record = AttentionRecord.from_timeline(store, words=composed.words, lengths=composed.lengths,
                                                   starts=composed.starts, num_steps=config.steps, timesteps=timesteps)
        seconds_taken = time.perf_counter() - start
    follow, notes = follow_generated(settings.prompt, joints, checked.tokens)
    clauses = " → ".join(repr(iv.prompt) for iv in checked.intervals)
    words = record.words if record is not None else checked.tokens.words
    return GenerationResult(settings=settings, words=words, joints=joints,
                            features=np.asarray(composed.features, dtype=np.float32), attention=record,
                            seconds_taken=seconds_taken, followed=follow,
                            notes=(f"generated clause by clause: {clauses}", *notes))
