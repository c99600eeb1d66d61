"""The session's own method: the Generate box (prompt, seconds, seed, steps, guidance, recorded steps) and its jobs,
``GenerateJob`` (text -> motion with recorded attention) and ``RerecordJob`` (a shown motion generated again from
its recipe to record its attention anew). They run through the one job runner like every tab's method.
``GenerateBox`` is one part of ``StudioState``.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
import param

from app.components.option_params import param_for
from app.generation import Checked, GenerationResult, GenerationSettings, PromptReading, check, prompt_analysis, \
    run_tries
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.session.viewer_rule import Preview
from engine.duration import resolve_seconds
from engine.methods.generate_options import GenerateOptions
from engine.sampling_options import SampleOptions
from engine.units import FPS, MAX_SECONDS, MIN_SECONDS


@dataclass
class GenerateJob:
    """Text -> motion with recorded attention: a new session motion, shown."""

    session: object  # StudioState
    settings: GenerationSettings
    on_preview: Callable[[int, int, np.ndarray, str], None] | None = None  # (done, total, x̂0 joints, title)
    checked: Checked | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot generate"

    def prepare(self, loaded) -> None:
        self.checked = check(loaded, self.settings)

    def describe(self) -> JobDescription:
        c = self.checked
        how = f" clause by clause ({len(c.intervals)} clauses)" if c.intervals else ""
        tries = int(c.settings.tries)
        how += f", up to {tries} tries" if tries > 1 else ""
        total = c.total_steps * tries
        return JobDescription(what="generation", status=f"generating {c.frames / FPS:.1f} s{how}: step 0 / "
                                                        f"{total}", verb="generating", total=total)

    def run(self, loaded, worker: Worker) -> GenerationResult:
        title = [f"{self.settings.prompt} · seed {self.settings.seed}"]  # the try's seed, while it runs

        def on_try(k: int, tries: int, seed: int) -> None:
            title[0] = f"{self.settings.prompt} · seed {seed} (try {k + 1} of up to {tries})"

        preview = None if self.on_preview is None else (
            lambda done, total, joints: self.on_preview(done, total, joints, title[0]))
        return run_tries(loaded, self.checked, on_step=worker.step, on_try=on_try, cancel=worker.cancel,
                         on_wait=worker.waiting, on_preview=preview)

    def deliver(self, result: GenerationResult) -> Delivery:
        s = result.settings
        item = MotionItem(name=self.session.unique_name(f"{s.prompt} · seed {s.seed}"), joints=result.joints,
                          source="generated", prompt=s.prompt, words=result.words, attention=result.attention,
                          features=result.features, settings=s, denoising=result.denoising, info=_info(result))
        auto = " (length from the prompt)" if s.seconds is None else ""
        return Delivery(items=[item], show=item.name,
                        status=f"{s.prompt!r}: {len(result.joints)} frames{auto} in {result.seconds_taken:.1f} s "
                               f"({s.steps} steps{tried_text(result)})")


@dataclass
class RerecordJob(GenerateJob):
    """A motion generated again with its own settings (same seed: the same motion): its attention goes to the motion
    it was asked for (shown again); if the model now makes another motion from the recipe, that one is added beside
    it, and said."""

    name: str = ""  # the motion re-recorded

    def deliver(self, result: GenerationResult) -> Delivery:
        name = self.name
        item = self.session.items.get(name)
        same = False
        if item is not None:
            try:
                old = item.joints
                same = old.shape == result.joints.shape and float(np.abs(old - result.joints).max()) <= 1e-3
            except ValueError:  # its joints are gone from the library: the new motion takes its place
                same = False
        if not same:
            delivery = super().deliver(result)
            if item is not None:
                delivery.notices.append(("warning", f"{name!r} was re-generated from its recipe, but this model makes "
                                                    f"another motion from it (another model, or changed weights): "
                                                    f"shown as a new motion, the kept one is unchanged"))
            return delivery
        item.joints = np.asarray(result.joints, dtype=np.float32)
        item.attention = result.attention
        item.denoising = result.denoising
        item.words = result.words
        item.features = result.features
        item.evicted = False
        item.from_library = False
        item.info = {**item.info, **_info(result)}
        return Delivery(show=name, renewed=name,
                        status=f"{name!r}: attention re-recorded in {result.seconds_taken:.1f} s "
                               f"({result.settings.steps} steps)")


def tried_text(result: GenerationResult) -> str:
    """"; tried seeds 2-3, kept seed 3" where several tries were made (and whether the kept one walked the corpus's
    path for its gait), else ""."""
    if len(result.tried) <= 1:
        return ""
    along = " (walked along the corpus's path)" if result.settings.held_path else ""
    return f"; tried seeds {result.tried[0]}-{result.tried[-1]}, kept seed {result.settings.seed}{along}"


def _info(result: GenerationResult) -> dict:
    return {"seconds_taken": result.seconds_taken, "followed": result.followed, "notes": tuple(result.notes),
            "tried": tuple(result.tried)}


class GenerateBox(param.Parameterized):
    """The Generate box's inputs (every tab samples with its seed, steps and guidance too), the prompt as the engine
    reads it, and Generate / Re-record. Uses the session's model, ``launch``, ``post`` and viewer rule."""

    prompt = param.String(default="a person jumps twice", doc="what to generate")
    seconds = param.Number(default=None, allow_None=True, step=0.5,
                           doc=f"duration in seconds ({MIN_SECONDS:g} to {MAX_SECONDS:g}); empty: predicted from the prompt (auto)")
    # the sampling settings every command shares, declared once (engine.sampling_options: `--seed`, `--steps`, ...)
    seed = param_for(SampleOptions, "seed")
    steps = param_for(SampleOptions, "steps")
    guidance = param_for(SampleOptions, "guidance")
    record_steps = param.Integer(default=10, bounds=(0, 1000), label="Recorded steps",
                                 doc="sampling steps whose attention is recorded (0 = none)")
    # a prompt of several actions in order: clause by clause (DoubleTake) or in one take (engine.methods.sequence)
    sequence = param_for(GenerateOptions, "sequence", label="Actions in order")
    # tries from the seed on, keeping the first motion that follows every checked attribute (engine.analysis.followed)
    tries = param_for(GenerateOptions, "tries", label="Tries")

    # ---- derived from the prompt
    prompt_words = param.List(default=[], doc="words of the prompt")
    reading = param.ClassSelector(class_=PromptReading, default=PromptReading(),
                                  doc="the prompt as the engine will read it (its notes, or why it refuses it)")

    def _analyse_prompt(self, *_):
        reading = prompt_analysis(self.tokenizer(), self.prompt)
        with param.parameterized.batch_call_watchers(self):
            self.prompt_words = list(reading.words)
            self.reading = reading

    def replace_word(self, old: str, new: str) -> None:
        """Swap a left-out word for a suggestion (whole words, case-insensitive); a '~adverb' suggestion moves to
        the end of the word's clause (engine.wordforms.rewrite)."""
        from engine.wordforms import rewrite

        self.prompt = rewrite(self.prompt, old, new)

    def settings(self) -> GenerationSettings:
        return GenerationSettings(prompt=self.prompt, seconds=self.seconds, seed=self.seed, steps=self.steps,
                                  guidance=self.guidance, record_steps=self.record_steps, sequence=self.sequence,
                                  tries=self.tries)

    def sample_config(self, **overrides):
        """How every tab samples: the box's seed, steps and guidance, the engine's defaults for the rest
        (``engine.generate.SampleConfig``; ``overrides`` win)."""
        from engine.generate import SampleConfig

        return SampleConfig(**{"steps": int(self.steps), "guidance": float(self.guidance), "seed": int(self.seed),
                               **overrides})

    def duration(self) -> float:
        """The Generate box's length in seconds: as typed, or predicted from the prompt when the box is empty."""
        return resolve_seconds(self.seconds, self.prompt, tempo=self.count_tempo())

    def count_tempo(self):
        """The model's count tempo (``engine.duration.Tempo``: what ``auto`` lengths read), () without a model."""
        return self.model.tempo if self.has_model else ()

    def generate(self) -> bool:
        """Check the inputs and start sampling on a worker thread; False (and a notification) if refused."""
        return self.launch(GenerateJob(session=self, settings=self.settings(), on_preview=self._preview))

    def rerecord(self) -> bool:
        """Generate the shown motion again with its own settings (same seed: the same motion) to record its
        attention anew, and show that motion with it; False (and a notification) when it has no settings to
        repeat."""
        item = self.item
        if item is None or item.settings is None:
            self.error("only a motion generated in the Generate box can be re-recorded")
            return False
        s = item.settings
        self.param.update(prompt=s.prompt, seconds=s.seconds, seed=s.seed, steps=s.steps, guidance=s.guidance,
                          record_steps=max(1, s.record_steps), sequence=s.sequence)
        # its own settings, those the box does not show included (the guidance's interval, eta): the same motion
        # one try: the motion's own seed (a kept try's settings say its seed)
        return self.launch(RerecordJob(session=self, settings=replace(s, record_steps=max(1, s.record_steps), tries=1),
                                       on_preview=self._preview, name=item.name))

    def _preview(self, done: int, total: int, joints: np.ndarray, title: str) -> None:
        """The running generation's x̂0 after ``done`` steps (from its worker): shown live by the viewer."""
        self.post(lambda: setattr(self, "preview", Preview(step=done, num_steps=total, joints=joints, title=title))
                  if self.running else None)
