"""The session's own job: sample its settings (the Generate box, and Re-record of a shown motion)."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from app.generation import Checked, GenerationResult, GenerationSettings, check, run_generation
from app.session.jobs import JobDescription, Worker
from engine.units import FPS


@dataclass
class GenerateJob:
    """Text -> motion with recorded attention; ``deliver`` takes the result on the session's thread."""

    settings: GenerationSettings
    deliver: Callable[[GenerationResult], None]
    on_preview: Callable[[int, int, np.ndarray, str], None] | None = None  # (done, total, x̂0 joints, title)
    checked: Checked | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot generate"

    def prepare(self, loaded) -> None:
        self.checked = check(loaded, self.settings)

    def describe(self) -> JobDescription:
        c = self.checked
        return JobDescription(what="generation", status=f"generating {c.frames / FPS:.1f} s: step 0 / {c.config.steps}",
                              verb="generating", total=c.config.steps)

    def run(self, loaded, worker: Worker) -> GenerationResult:
        title = f"{self.settings.prompt} · seed {self.settings.seed}"
        preview = None if self.on_preview is None else (
            lambda done, total, joints: self.on_preview(done, total, joints, title))
        return run_generation(loaded, self.checked, on_step=worker.step, cancel=worker.cancel, on_wait=worker.waiting,
                              on_preview=preview)

    def finish(self, result: GenerationResult) -> None:
        self.deliver(result)
