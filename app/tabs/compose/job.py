"""The Compose tab's job (DoubleTake, PriorMDM): checks of the timeline with user-facing messages, the job
(``ComposeJob``, launched on the session) and its result.

Nothing here touches Panel widgets. The engine does the work (``engine.methods.doubletake.compose``, the
function ``moattn compose`` calls); this module adds what only the studio needs: one progress bar across both
takes, and the long motion as a session motion whose skeleton is coloured per interval, with the handshake
(transition) frames highlighted. The timeline itself is ``ComposeSettings`` (``app.tabs.compose.settings``).
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from app.generation import Cancelled, sampling_slot
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.tabs.compose.settings import ComposeSettings
from engine.units import FPS

INTERVAL_COLORS = ("#3a6fd8", "#2f9e5a")  # intervals alternate between these
TRANSITION_COLOR = "#e8552e"  # handshake frames (where DoubleTake joins two intervals)
COLOR_NAMES = {**{c: "interval" for c in INTERVAL_COLORS}, TRANSITION_COLOR: "handshake (transition)"}  # legend


@dataclass
class ComposeSummary:
    """The last composition, for the timeline strip and the readout."""

    name: str  # the session motion
    prompts: list[str]
    starts: list[int]  # first frame of each interval on the timeline
    ends: list[int]  # one past its last frame
    transitions: list[tuple[int, int]]  # [start, end) of each handshake
    n_frames: int
    handshakes: list[int]  # frames, one per transition
    second_take: bool
    seconds_taken: float  # wall time
    second_take_text: bool = False  # the second take denoised each transition with "A, then B"
    planted_feet: bool = False  # the second take kept the feet on the floor still (engine.diffusion.feet)


@dataclass
class ComposePlan:
    """A checked composition, ready for the worker."""

    intervals: list  # engine Intervals
    config: object  # DoubleTakeConfig
    sample: object  # SampleConfig
    total_steps: int  # first take + second take
    description: str


def prepare(state, settings: ComposeSettings) -> ComposePlan:
    """Every check before any work starts; raises ValueError with a message for the user."""
    from engine.methods.doubletake import Interval, check_intervals, second_take_timesteps

    loaded = state.model
    rows = settings.intervals
    if not rows:
        raise ValueError("add at least one interval to the timeline")
    for i, row in enumerate(rows):
        if not row.prompt.strip():
            raise ValueError(f"interval {i + 1}: type what the person does")
        loaded.tokenizer.encode(row.prompt)  # unknown words: a PromptError (ValueError) naming them
    config = settings.config()
    take = config.second_take
    intervals = [Interval(row.prompt.strip(), float(row.seconds)) for row in rows]
    hs = config.handshakes(len(intervals))
    check_intervals(intervals, hs)
    limit = loaded.model.config.max_frames
    for i, row in enumerate(rows):
        n = int(round(row.seconds * FPS))
        if n > limit:
            raise ValueError(f"interval {i + 1} lasts {n} frames: this model handles at most {limit} "
                             f"({limit / FPS:.1f} s)")
    sample = state.sample_config()
    total = sample.steps
    if take is not None and any(hs):
        total += len(second_take_timesteps(take, sample.steps))
    description = f"compose {len(rows)} interval{'s' * (len(rows) != 1)}"
    return ComposePlan(intervals=intervals, config=config, sample=sample, total_steps=total, description=description)


def run_job(loaded, job: ComposePlan, *, on_step: Callable[[int, int], None], cancel: threading.Event,
            on_wait: Callable[[], None] | None = None):
    """Compose on the worker (holding the sampling slot); ``on_step(done, total)`` across both takes."""
    from engine.methods.doubletake import compose

    done = [0]

    def step(_state) -> None:
        if cancel.is_set():
            raise Cancelled()
        done[0] += 1
        on_step(min(done[0], job.total_steps), job.total_steps)

    with sampling_slot(cancel, on_wait):
        result = compose(loaded, job.intervals, job.config, sample=job.sample, on_step=step)
    if not np.isfinite(result.joints).all():
        raise ValueError("the model produced non-finite joints")
    return result


@dataclass
class ComposeJob:
    """One composition of the timeline: the long motion, coloured per interval, when done."""

    session: object  # StudioState
    settings: ComposeSettings
    plan: ComposePlan | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot compose"

    def prepare(self, loaded) -> None:
        self.plan = prepare(self.session, self.settings)

    def describe(self) -> JobDescription:
        p = self.plan
        return JobDescription(what="composition", status=f"{p.description}: step 0 / {p.total_steps}",
                              verb=p.description, total=p.total_steps)

    def run(self, loaded, worker: Worker):
        return run_job(loaded, self.plan, on_step=worker.step, cancel=worker.cancel, on_wait=worker.waiting)

    def deliver(self, result) -> Delivery:
        """The long motion becomes a session motion, coloured per interval with its transitions highlighted."""
        job = self.plan
        take = job.config.second_take
        n = len(result.joints)
        ends = [s + int(round(iv.seconds * FPS)) for s, iv in zip(result.starts, job.intervals)]
        title = f"compose · {' > '.join(_short(iv.prompt) for iv in job.intervals)} · seed {job.sample.seed}"
        summary = ComposeSummary(name="", prompts=[iv.prompt for iv in job.intervals], starts=list(result.starts),
                                 ends=[min(e, n) for e in ends], transitions=[tuple(t) for t in result.transitions],
                                 n_frames=n, handshakes=[b - a for a, b in result.transitions],
                                 second_take=take is not None, seconds_taken=result.seconds,
                                 second_take_text=take is not None and take.text,
                                 planted_feet=take is not None and take.planted_feet)
        item = MotionItem(name=self.session.unique_name(title), joints=np.asarray(result.joints, dtype=np.float32),
                          source="generated", prompt=" then ".join(iv.prompt for iv in job.intervals),
                          info={"compose": summary})
        summary.name = item.name
        return Delivery(items=[item], show=item.name, frame_colors={item.name: frame_colors(summary)},
                        color_names=COLOR_NAMES, readout=(self.settings, {"result": summary}),
                        status=f"{job.description}: {n} frames ({n / FPS:.1f} s of motion) in {result.seconds:.1f} s")


def frame_colors(summary: ComposeSummary) -> np.ndarray:
    """(T, 22, 3) uint8: each interval in its colour (alternating), the handshake frames in the transition colour."""
    from viz.colors import default_joint_colors

    out = np.zeros((summary.n_frames, 22, 3), dtype=np.uint8)
    for i, (a, b) in enumerate(zip(summary.starts, summary.ends)):
        out[a:b] = default_joint_colors(INTERVAL_COLORS[i % len(INTERVAL_COLORS)])
    for a, b in summary.transitions:
        out[a:b] = default_joint_colors(TRANSITION_COLOR)
    return out


def transition_at(summary: ComposeSummary, frame: int) -> int | None:
    """Which transition (0-based) a frame falls in, or None."""
    for k, (a, b) in enumerate(summary.transitions):
        if a <= frame < b:
            return k
    return None


def _short(prompt: str, n: int = 22) -> str:
    p = prompt.removeprefix("a person ").strip()
    return p if len(p) <= n else p[: n - 1] + "…"
