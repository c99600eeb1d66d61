"""`--seconds auto`: a motion's length predicted from what its prompt asks for.

The prompt's parsed intent (engine.intent) is realised as corpus segments many times, with what the prompt
leaves open drawn as the corpus draws it, and each segment's length taken from the corpus's own rule
(engine.synth.splits.natural_seconds: e.g. a jump 0.95 s a count plus a crouch, a walk 2.5-5.5 s). The sum of the
segments' mean lengths is the duration, kept inside what the model supports. "jumps twice" gets room for two
jumps and no more; a prompt with no recognised action gets the default. An explicit length always wins.

A counted action's length ignores a speed word ("quickly", "slowly"): the model repeats at its own pace whatever it
says. A model need not repeat at the corpus's pace either: its count tempo (:func:`model_tempo`, measured by ``moattn bench
--tempo``) scales each counted segment of an action, so "claps three times" gets the time this model takes for three.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from functools import lru_cache

import numpy as np

from engine.units import MAX_SECONDS, MIN_SECONDS

AUTO = "auto"
DEFAULT_SECONDS = 4.0  # a prompt whose actions the intent parser does not know
DRAWS = 64  # realisations averaged per segment (the estimate moves by under 0.05 s beyond this)

#: a model's count tempo: (action, scale) pairs, sorted; a counted segment of that action gets ``scale`` times the
#: corpus's length, the pace at which this model makes the count asked for (measured by ``moattn bench --tempo``,
#: kept in the model's config.json, read by :func:`model_tempo`). () = the corpus's lengths.
Tempo = tuple[tuple[str, float], ...]


def model_tempo(config: Mapping | None) -> Tempo:
    """The count tempo a model's ``config.json`` holds ("durations": {"count_scale": {action: scale}}), or ()."""
    table = ((config or {}).get("durations") or {}).get("count_scale") or {}
    return tuple(sorted((str(a), float(s)) for a, s in table.items()))


@lru_cache(maxsize=512)
def auto_seconds(prompt: str, tempo: Tempo = ()) -> float:
    """The predicted length of ``prompt``'s motion in seconds (0.1 s steps, within the model's 1-9.8 s); ``tempo``:
    the model's count tempo (:data:`Tempo`), scaling each counted segment of its actions."""
    from engine.intent import parse_intent
    from engine.synth.intents import realise_segment
    from engine.synth.splits import natural_seconds

    intent = parse_intent(prompt)
    if not intent.segments:
        return DEFAULT_SECONDS
    rng = np.random.default_rng(0)
    scale = dict(tempo)
    total = 0.0
    for want in intent.segments:
        if want.count is not None and want.speed is not None:
            # a counted action at the model's own pace whatever the speed word: given the corpus's shorter length for
            # "jumps quickly three times" the shipped model made two jumps in 8 of 8 seeds (three at the plain
            # length, 8 of 8), "jumps slowly three times" four, "claps quickly three times" 0-1 (session 33)
            want = replace(want, speed=None)
        draws = []
        for _ in range(DRAWS):
            seg = realise_segment(want, rng)
            secs = natural_seconds(seg, rng)
            if want.overlay is not None:  # a gesture while moving needs room for its count
                overlay = realise_segment(want.overlay, rng)
                secs = max(secs, overlay.count * 0.6 + 1.2)
            draws.append(secs)
        total += float(np.mean(draws)) * (scale.get(want.action, 1.0) if want.count is not None else 1.0)
    return float(np.clip(round(total, 1), MIN_SECONDS, MAX_SECONDS))


def resolve_seconds(seconds: float | str | None, prompt: str, *, tempo: Tempo = ()) -> float:
    """An explicit length as given; ``"auto"`` or None: :func:`auto_seconds` of the prompt (at the model's
    ``tempo``)."""
    if seconds is None or (isinstance(seconds, str) and seconds.strip().lower() == AUTO):
        return auto_seconds(prompt, tempo)
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
