"""Corpus segments realising what a parsed prompt (engine.intent) asks for: the stated attributes as stated, the rest
drawn as the corpus draws them. Read by the length prediction (engine.duration) and the adherence checker."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from engine.intent import IntentSegment
from engine.synth.program import INTENSITIES, SPEEDS, Segment


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
