"""The Duet tab's job (ComMDM, PriorMDM): two people from one prompt, or the completion of a two-person prefix
(``DuetJob``, launched on the session).

Nothing here touches Panel widgets. The engine does the work (``engine.methods.duet``, what ``moattn duet``
calls); this module adds what only the studio needs: checks against the duet's vocabulary, the prefix's joints
(a held-out example, an upload, a duet of the session), and the result as two session motions shown in one
scene.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from app.generation import Cancelled, sampling_slot
from app.session.duets import DuetPair
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.tabs.duet.models import EXAMPLE, duet_model, example
from app.tabs.duet.settings import DuetSettings
from engine.io import seconds_number
from engine.units import FPS

PREFIX_COLOR = "#9a9a9a"  # the given prefix frames of a completion

@dataclass
class DuetSummary:
    """The last duet, for the readout."""

    names: tuple[str, str]  # the two session motions
    mode: str
    prompt: str
    communicate: bool
    placement: object  # Pose: person b seen from person a
    contacts: str  # what contact guidance did, in words
    distance_m: float
    facing_each_other: bool
    prefix_frames: int
    n_frames: int
    seconds_taken: float
    spacing: str = ""  # the start's torso distance against the rule, and whether person b was moved (in words)


@dataclass
class DuetPlan:
    """A checked duet, ready for the worker."""

    mode: str
    prompt: str | None
    seconds: float
    prefix: tuple[np.ndarray, np.ndarray] | None
    prefix_seconds: float
    communicate: bool
    sample: object  # SampleConfig
    description: str
    contact: bool = False  # contact guidance (text only)


def prepare(state, settings: DuetSettings) -> DuetPlan:
    """Every check before any work starts; raises ValueError with a message for the user."""
    from engine.generate import MAX_SECONDS, MIN_SECONDS

    loaded = state.model
    model, problem = duet_model(settings.duet_dir, loaded)
    if model is None:
        raise ValueError(problem)
    prompt = settings.prompt.strip()
    seconds = seconds_number(settings.seconds, "the length")
    if settings.mode == "text":
        if not prompt:
            raise ValueError("type what the two people do, e.g. 'two people shake hands'")
        model.tokenizer.encode(prompt)  # unknown words: a PromptError naming them
        if not MIN_SECONDS <= seconds <= MAX_SECONDS:
            raise ValueError(f"the length must be between {MIN_SECONDS:g} and {MAX_SECONDS:g} s")
        sample = state.sample_config()
        return DuetPlan(mode="text", prompt=prompt, seconds=seconds, prefix=None, prefix_seconds=0.0,
                       communicate=settings.communicate, sample=sample, description="duet", contact=settings.contact)
    given = seconds_number(settings.prefix_seconds, "the prefix")
    if prompt:
        model.tokenizer.encode(prompt)
    a, b = prefix_joints(state, settings)
    need = int(round(given * FPS)) + 1
    if len(a) < need:
        raise ValueError(f"the prefix {settings.prefix!r} has {len(a)} frames; {given:g} s needs {need}")
    total = given + seconds
    limit = loaded.model.config.max_frames / FPS
    if given < 0.1 or seconds < MIN_SECONDS or total > limit:
        raise ValueError(f"prefix ({given:g} s) + completion ({seconds:g} s) must fit in {limit:g} s, "
                         f"with at least {MIN_SECONDS:g} s completed")
    unconditional = {} if prompt else {"guidance": 1.0}  # a completion without a prompt: no guidance
    sample = state.sample_config(**unconditional)
    return DuetPlan(mode="prefix", prompt=prompt or None, seconds=seconds, prefix=(a, b), prefix_seconds=given,
                   communicate=settings.communicate, sample=sample, description="duet completion")


def prefix_joints(state, settings: DuetSettings) -> tuple[np.ndarray, np.ndarray]:
    name = settings.prefix
    if name.startswith(EXAMPLE):
        s = example(name)
        return s.joints_a, s.joints_b
    if name in settings.uploads:
        j = settings.uploads[name]
        return j[0], j[1]
    item = state.items.get(name)
    if item is not None and isinstance(item.info.get("duet"), DuetPair):
        j = item.info["duet"].joints
        return j[0], j[1]
    raise ValueError(f"no duet named {name!r} (pick an example, upload a duet .npy, or make a duet first)")


def run_job(loaded, job: DuetPlan, *, duet_dir, on_step: Callable[[int, int], None], cancel: threading.Event,
            on_wait: Callable[[], None] | None = None):
    """Sample on the worker (holding the sampling slot)."""
    from engine.methods.duet import complete, text_to_duet
    from engine.methods.duet_contact import ContactConfig

    model, problem = duet_model(duet_dir, loaded)
    if model is None:
        raise ValueError(problem)
    done = [0]

    def step(_state) -> None:
        if cancel.is_set():
            raise Cancelled()
        done[0] += 1
        on_step(min(done[0], job.sample.steps), job.sample.steps)

    t0 = time.perf_counter()
    with sampling_slot(cancel, on_wait):
        if job.mode == "text":
            duet = text_to_duet(model, job.prompt, seconds=job.seconds, sample=job.sample,
                                communicate=job.communicate, contact=ContactConfig() if job.contact else None,
                                on_step=step)
        else:
            duet = complete(model, *job.prefix, prefix_seconds=job.prefix_seconds, seconds=job.seconds,
                            prompt=job.prompt, sample=job.sample, communicate=job.communicate, on_step=step)
    if not np.isfinite(duet.joints).all():
        raise ValueError("the model produced non-finite joints")
    return duet, time.perf_counter() - t0


@dataclass
class DuetJob:
    """One duet (from a prompt, or the completion of a prefix): two session motions in one scene when done."""

    session: object  # StudioState
    settings: DuetSettings
    plan: DuetPlan | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot make a duet"

    def prepare(self, loaded) -> None:
        self.plan = prepare(self.session, self.settings)

    def describe(self) -> JobDescription:
        p = self.plan
        return JobDescription(what="duet", status=f"{p.description}: step 0 / {p.sample.steps}", verb=p.description,
                              total=p.sample.steps)

    def run(self, loaded, worker: Worker):
        return run_job(loaded, self.plan, duet_dir=self.settings.duet_dir, on_step=worker.step, cancel=worker.cancel,
                       on_wait=worker.waiting)

    def deliver(self, result) -> Delivery:
        """The two people become two session motions shown together in one scene."""
        from engine.analysis.duet_pose import face_each_other
        from viz.colors import ROLE_PALETTE, default_joint_colors

        duet, seconds_taken = result
        job = self.plan
        what = job.prompt or "completion"
        base = f"duet · {what[:40]} · seed {job.sample.seed}" + ("" if job.communicate else " · no block")
        first = self.session.unique_name(base + " · a")
        second = self.session.unique_name(base + " · b")
        pair = DuetPair(first=first, second=second, joints=duet.joints)
        items = [MotionItem(name=n, joints=duet.joints[k], source="generated", prompt=job.prompt or "",
                            info={"duet": pair}) for k, n in enumerate((first, second))]
        given = int(round(job.prefix_seconds * FPS)) if job.mode == "prefix" else 0
        p = duet.placement
        summary = DuetSummary(names=(first, second), mode=job.mode, prompt=job.prompt or "",
                              communicate=job.communicate, placement=p, contacts=contact_words(job, duet),
                              distance_m=float(np.hypot(p.x, p.z)), facing_each_other=face_each_other(duet.joints),
                              prefix_frames=given, n_frames=duet.frames, seconds_taken=seconds_taken,
                              spacing=spacing_words(duet))
        colors = {}
        if given:
            for k, it in enumerate(items):
                rgb = np.broadcast_to(default_joint_colors(ROLE_PALETTE[k]), (duet.frames, 22, 3)).copy()
                rgb[:given] = default_joint_colors(PREFIX_COLOR)
                colors[it.name] = rgb
        return Delivery(items=items, show=first, also=[second], frame_colors=colors,
                        color_names={PREFIX_COLOR.lower(): "given prefix"} if colors else {},
                        readout=(self.settings, {"result": summary}),
                        status=f"{job.description}: {duet.frames} frames in {seconds_taken:.1f} s")


def contact_words(job: DuetPlan, duet) -> str:
    """The readout's line on contact guidance."""
    if job.mode != "text":
        return "none (completion)"
    if not job.contact:
        return "off"
    if duet.interaction is None:
        return "none: the prompt reads as no trained interaction"
    if not duet.contacts:
        return f"none: a {duet.interaction.replace('_', ' ')} has no contact"
    spans = ", ".join(f"{c.kind.replace('_', ' ')} {100 * c.start:.0f}–{100 * c.end:.0f} %" for c in duet.contacts)
    return f"{duet.interaction.replace('_', ' ')}: {spans} of the clip"


def spacing_words(duet) -> str:
    """The readout's line on the spacing rule (engine.methods.duet_spacing): how far apart the torsos start, the
    least the corpus's own duets of that interaction keep, and whether person b was moved to keep it."""
    from engine.analysis.duet_pose import torso_distance
    from engine.methods.duet_spacing import START_SECONDS

    start = float(torso_distance(duet.joints)[: max(1, int(round(START_SECONDS * FPS)))].min())
    rule = duet.spacing.rule if duet.spacing is not None else None
    if rule is None:
        return f"torsos at least {start:.2f} m apart in the first {START_SECONDS:g} s (as sampled: no rule applied)"
    what = f"a {rule.interaction.replace('_', ' ')}" if rule.interaction else "two people"
    moved = (f"person b moved up to {float(duet.spacing.push.max()):.2f} m to keep it" if duet.spacing.moved
             else "nothing moved")
    return (f"torsos at least {start:.2f} m apart in the first {START_SECONDS:g} s (the corpus keeps "
            f"{max(rule.start, rule.anywhere):.2f} m for {what}); {moved}")


def describe(summary: DuetSummary) -> list[tuple[str, str]]:
    p = summary.placement
    rows = [("method", "ComMDM" if summary.communicate else "prior twice (no block)"),
            ("person b from person a", f"{summary.distance_m:.2f} m, facing {np.degrees(p.yaw):+.0f}°"),
            ("face each other (mid-clip)", "yes" if summary.facing_each_other else "no"),
            *([("spacing", summary.spacing)] if summary.spacing else []),
            ("contact guidance", summary.contacts),
            ("frames", f"{summary.n_frames} ({summary.n_frames / FPS:.1f} s)"
             + (f", first {summary.prefix_frames} given" if summary.prefix_frames else "")),
            ("time", f"{summary.seconds_taken:.1f} s")]
    return rows
