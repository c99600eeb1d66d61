"""`--seconds auto`: a motion's length predicted from what its prompt asks for.

The prompt's parsed intent (engine.intent) is realised as corpus segments many times, with what the prompt
leaves open drawn as the corpus draws it, and each segment's length taken from the corpus's own rule
(engine.synth.splits.natural_seconds: e.g. a jump 0.95 s a count plus a crouch, a walk 2.5-5.5 s). The sum of the
segments' mean lengths is the duration, kept inside what the model supports. "jumps twice" gets room for two
jumps and no more; a prompt with no recognised action gets the default. An explicit length always wins.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from engine.units import MAX_SECONDS, MIN_SECONDS

AUTO = "auto"
DEFAULT_SECONDS = 4.0  # a prompt whose actions the intent parser does not know
DRAWS = 64  # realisations averaged per segment (the estimate moves by under 0.05 s beyond this)


@lru_cache(maxsize=512)
def auto_seconds(prompt: str) -> float:
    """The predicted length of ``prompt``'s motion in seconds (0.1 s steps, within the model's 1-9.8 s)."""
    from engine.intent import parse_intent
    from engine.synth.intents import realise_segment
    from engine.synth.splits import natural_seconds

    intent = parse_intent(prompt)
    if not intent.segments:
        return DEFAULT_SECONDS
    rng = np.random.default_rng(0)
    total = 0.0
    for want in intent.segments:
        draws = []
        for _ in range(DRAWS):
            seg = realise_segment(want, rng)
            secs = natural_seconds(seg, rng)
            if want.overlay is not None:  # a gesture while moving needs room for its count
                overlay = realise_segment(want.overlay, rng)
                secs = max(secs, overlay.count * 0.6 + 1.2)
            draws.append(secs)
        total += float(np.mean(draws))
    return float(np.clip(round(total, 1), MIN_SECONDS, MAX_SECONDS))


def resolve_seconds(seconds: float | str | None, prompt: str) -> float:
    """An explicit length as given; ``"auto"`` or None: :func:`auto_seconds` of the prompt."""
    if seconds is None or (isinstance(seconds, str) and seconds.strip().lower() == AUTO):
        return auto_seconds(prompt)
    try:
        return float(seconds)
    except (TypeError, ValueError):
        raise ValueError(f"the duration must be a number of seconds or 'auto', got {seconds!r}") from None


def seconds_argument(text: str) -> float | str:
    """argparse type for ``--seconds``: a number or ``auto``."""
    if text.strip().lower() == AUTO:
        return AUTO
    try:
        return float(text)
    except ValueError:
        import argparse

        raise argparse.ArgumentTypeError(f"expected a number of seconds or 'auto', got {text!r}") from None
