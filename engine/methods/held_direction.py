"""A gait held by a root path: "walks to the left" or "an old man walks slowly" walked along the corpus's own path
for it.

The base model often walks straight where a prompt asks for a turn to one side ("a woman walks quickly to the
right": the right turn in 1 of 4 draws), and stands where a styled walk is slow or sneaky ("an old man walks
slowly": a walk in 1 of 4 draws, the others at 0.03-0.15 m/s). The root control model (PriorMDM,
``assets/control/root``) follows a path on the floor. The path is the one the corpus itself walks for the prompt: the
prompt's intent realised as a corpus program (:func:`engine.synth.intents.program_for_intent`) at the generation's
length, its pelvis on the floor. `moattn generate`'s and the studio's later tries take it where the prompt is one
walk, run or jog, straight ahead or turning (left, right, a circle), and the report says so (:func:`held_note`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from engine.intent import Intent, IntentSegment, parse_intent
from engine.methods.generate_options import HOLD_FROM_TRY
from engine.units import FPS

if TYPE_CHECKING:  # imported lazily: engine.methods.control loads torch and the model code
    from engine.methods.control import ControlPlan

GAITS = ("walk", "run", "jog")
# the directions of a gait a path holds: none said (straight ahead), forward and the turns (backward is its own action)
HELD = (None, "forward", "left", "right", "circle", "circle_left", "circle_right")


def held_segment(intent: Intent | str) -> IntentSegment | None:
    """The prompt's one gait, straight ahead or turning (a path can hold it), or None: a prompt of several actions
    in order, a gait backwards, an action that does not travel."""
    if isinstance(intent, str):
        intent = parse_intent(intent)
    if len(intent.segments) != 1:
        return None
    seg = intent.segments[0]
    return seg if seg.action in GAITS and seg.direction in HELD else None


def held_take(intent: Intent | str, *, try_index: int, one_take: bool = True) -> bool:
    """Whether the try ``try_index`` (0-based) of ``intent`` walks its gait along the corpus's path: a later try
    (:data:`~engine.methods.generate_options.HOLD_FROM_TRY` on) of a prompt generated in one take (not clause by
    clause) of one gait. What `moattn generate`'s, the studio's and the adherence bench's tries share."""
    return one_take and try_index >= HOLD_FROM_TRY and held_segment(intent) is not None


def corpus_path(intent: Intent, *, frames: int, seed: int) -> np.ndarray:
    """The pelvis on the floor, (frames + 1, 2) x/z metres, of the corpus's realisation of ``intent`` lasting
    ``frames`` frames (the corpus's speed for the gait and its words, its turn for the direction). A gait whose
    prompt says no direction walks straight ahead: the corpus would draw a turn or a circle for it in 4 of 10 draws."""
    from engine.synth.intents import program_for_intent
    from engine.synth.corpus import make_sample

    straight = [replace(seg, direction="forward") if seg.action in GAITS and seg.direction is None else seg
                for seg in intent.segments]
    intent = replace(intent, segments=tuple(straight))
    rng = np.random.default_rng([seed, 11])
    last: Exception | None = None
    for _ in range(6):  # a drawn person or count that does not fit: draw again
        program = program_for_intent(intent, rng)
        seg = program.segments[0]
        seg = replace(seg, frames=frames, overlay=None if seg.overlay is None else replace(seg.overlay, frames=frames))
        try:
            joints = make_sample(replace(program, segments=(seg,)), captions=[intent.text], with_features=False).joints
        except ValueError as exc:
            last = exc
            continue
        xz = joints[:, 0, [0, 2]].astype(np.float64)
        t = np.arange(frames + 1) / FPS
        return np.stack([np.interp(t, np.arange(len(xz)) / FPS, xz[:, d]) for d in range(2)], -1)
    raise ValueError(f"the corpus cannot walk {intent.text!r} in {frames} frames: {last}")


def held_control(intent: Intent, *, frames: int, seed: int):
    """The root :class:`~engine.methods.control.Control` along :func:`corpus_path` (its values start at the origin
    facing +Z, as a generated motion does)."""
    from engine.methods.control import Control
    from engine.methods.paths import RootPath, root_controls

    xz = corpus_path(intent, frames=frames, seed=seed)
    values, _frame = root_controls(RootPath(points=tuple(map(tuple, xz)), times=tuple(np.arange(len(xz)) / FPS)),
                                   frames / FPS)
    return Control("root", values)


@lru_cache(maxsize=2)
def _root_model(folder: str, runtime):
    from engine.methods.control import load_controls

    return load_controls(folder, runtime=runtime).get("root")


def root_model(base, folder: Path | None = None):
    """The root control model that blends with ``base`` (``assets/control/root``), on ``base``'s device, or None where
    there is none (loaded once per folder and device)."""
    from engine.methods.control import same_base
    from engine.paths import CONTROL_DIR

    model = _root_model(str(folder or CONTROL_DIR), base.runtime)
    return model if model is not None and same_base(base, model) else None


def held_note(seg: IntentSegment) -> str:
    """The line a report carries when the take walked a held path."""
    direction = seg.direction or "forward"
    turn = direction.partition("_")[2]  # a circle's own turn, if the prompt said one
    way = (f"in a circle{f' to the {turn}' if turn else ''}" if direction.startswith("circle")
           else "forward" if direction == "forward" else f"to the {direction}")
    return f"{seg.action} {way} held by a root path (the corpus's, the root control model)"


@dataclass(frozen=True)
class Held:
    """A take's gait held by a path: how to sample it and the line its report carries."""

    plan: ControlPlan  # the noise, denoiser and hook of the root path
    note: str


def plan_of(held: Held | None) -> ControlPlan:
    """What a take samples with: the held path's plan, or the plain one (:data:`PLAIN_PLAN`)."""
    from engine.methods.control import PLAIN_PLAN

    return PLAIN_PLAN if held is None else held.plan


def held_plan(loaded, prompt: str, *, frames: int, sample, controls: Path | None = None) -> Held | None:
    """The :class:`Held` plan that walks ``prompt``'s gait along the corpus's path in a take of ``frames`` frames,
    or None where no path holds it: the prompt is not one gait, there is no root control model for
    ``loaded`` (in ``controls``, default ``assets/control``), or the corpus cannot walk it in that time."""
    from engine.methods.control import control_plan

    intent = parse_intent(prompt, loaded.tokenizer.encode(prompt))  # as the model reads it (typos, words left out)
    seg = held_segment(intent)
    model = root_model(loaded, controls) if seg is not None else None
    if model is None:
        return None
    try:
        control = held_control(intent, frames=frames, seed=sample.seed)
    except ValueError:
        return None
    return Held(plan=control_plan(loaded, [control], frames=frames, models={"root": model}, sample=sample),
                note=held_note(seg))
