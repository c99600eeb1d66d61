"""Corpus segments realising what a parsed prompt (engine.intent) asks for: the stated attributes as stated, the rest
drawn as the corpus draws them. Read by the length prediction (engine.duration) and the adherence checker."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from engine.intent import Intent, IntentSegment
from engine.synth.program import FPS, INTENSITIES, MAX_FRAMES, SPEEDS, Program, Segment


def realise_segment(want: IntentSegment, rng: np.random.Generator) -> Segment:
    """A corpus segment for an intended action: what the prompt states, the rest drawn as the corpus draws it."""
    from engine.synth.splits import random_segment  # splits imports the corpus tables: loaded on first use

    seg = random_segment(rng, want.action)
    fields: dict = {}
    if want.count is not None:
        fields["count"] = int(want.count)
    if want.side is not None:
        fields["side"] = want.side
    if want.speed is not None:
        fields["speed"], fields["speed_word"] = SPEEDS[want.speed], want.speed
    if want.intensity is not None:  # "jumps high": the corpus's high jump, its own spread kept
        fields["intensity"] = INTENSITIES[want.intensity] * seg.intensity / INTENSITIES[seg.intensity_word]
        fields["intensity_word"] = want.intensity
    if want.direction is not None:
        if want.action == "turn":
            fields["turn"] = {"around": np.pi, "left": np.pi / 2, "right": -np.pi / 2}[want.direction]
            fields["direction"] = want.direction
        elif want.action in ("walk", "run", "jog"):
            d = want.direction
            fields["direction"] = ("circle_left" if rng.random() < 0.5 else "circle_right") if d == "circle" else d
        elif want.action == "side_step" and want.direction in ("left", "right"):
            fields["direction"] = want.direction
    return replace(seg, **fields)


def program_for_intent(intent: Intent, rng: np.random.Generator) -> Program:
    """A corpus program realising an intent: stated attributes as stated, the rest drawn as the
    corpus draws them (an unstated side is either side), durations that fit the counts."""
    from engine.synth.splits import natural_seconds, random_person
    from engine.synth.styles import STYLES

    segments = []
    for want in intent.segments:
        seg = realise_segment(want, rng)
        if want.overlay is not None:
            seg = replace(seg, overlay=realise_segment(want.overlay, rng))
        segments.append(seg)
    secs = [natural_seconds(s, rng) for s in segments]
    if any(s.overlay is not None for s in segments):
        secs = [max(x, (s.overlay.count * 0.6 + 1.2) if s.overlay is not None else x) for x, s in zip(secs, segments)]
    scale = min(1.0, (MAX_FRAMES - 1) / FPS / sum(secs))
    frames = [max(int(round(x * scale * FPS)), 12) for x in secs]
    segments = [replace(s, frames=f, overlay=replace(s.overlay, frames=f) if s.overlay is not None else None)
                for s, f in zip(segments, frames)]
    style = intent.style if intent.style in STYLES else "none"
    return Program(segments=tuple(segments), style=style, person=random_person(rng),
                   blend=int(rng.integers(6, 11)), seed=int(rng.integers(2**31)))
