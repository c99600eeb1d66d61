"""A model's count tempo, measured (``moattn bench --tempo [--quick] [--write]``): #32's "durations fitted to counts".

``--seconds auto`` gives a counted action the corpus's own length for that count (:mod:`engine.duration`). A model
need not repeat at the corpus's pace: base v9 makes 2 claps where 3 were asked in the corpus's 2.6 s, and 3 in
1.15-1.3 times that, while its jumps and kicks are exact at the corpus's length and too many when given more. So
the length a counted segment gets is scaled per action, by the factor measured here for this model: for each
counted action, calibration prompts ("the person claps three times", and with a side where people name one: "the
person hops on the left leg twice"; none is a prompt of the adherence bench's default or dev sets) are generated at
several scales of their predicted length, as a user samples them, and the repetitions are counted by the adherence
bench's detectors. Of the scales within half ``min_gain`` of the most exact counts, the one nearest 1 wins where it
beats the corpus's length (scale 1) by at least ``min_gain``; otherwise the action keeps scale 1. The factors go into
the model's ``config.json`` ("durations": {"count_scale": {...}, "calibration": {...}}), where every ``--seconds
auto`` (the CLI, the studio's Generate box, the benches) reads them through :func:`engine.duration.model_tempo`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.checkpoint import LoadedModel, read_config, write_config_json
from engine.generate import SampleConfig
from engine.intent import COUNTED_ACTIONS
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE, MAX_SECONDS

#: the calibration's own phrases per action: the grammar's plain verb, and for an action people name a side for, that
#: verb with each side as people type it (a model's pace differs between them: base v11 hops far more often when the
#: leg is named, so the plain verb alone measured mostly missing hops); "the person" is a subject no bench prompt uses
VERB_PHRASES: dict[str, tuple[str, ...]] = {
    "jump": ("jumps",), "jump_forward": ("jumps forward",),
    "hop": ("hops", "hops on the left leg", "hops on the right foot"), "jumping_jacks": ("does jumping jacks",),
    "squat": ("squats",), "kick": ("kicks", "kicks with the right leg", "kicks with the left foot"),
    "punch": ("punches", "punches with the left hand", "punches with the right hand"),
    "wave": ("waves", "waves the right hand", "waves with the left hand"), "clap": ("claps",),
    "raise_arms": ("raises the arms", "raises the left arm"), "bow": ("bows",)}
COUNT_PHRASES = {2: "twice", 3: "three times", 4: "four times", 5: "five times"}


def calibration_prompt(action: str, count: int, phrasing: int = 0) -> str:
    """The ``phrasing``-th of the action's phrases (cycled), asking for ``count``."""
    phrases = VERB_PHRASES[action]
    return f"the person {phrases[phrasing % len(phrases)]} {COUNT_PHRASES[count]}"


@dataclass(frozen=True)
class TempoConfig:
    actions: tuple[str, ...] = COUNTED_ACTIONS
    counts: tuple[int, ...] = (2, 3, 4)
    scales: tuple[float, ...] = (0.9, 1.0, 1.15, 1.3, 1.45)
    seeds: int = 6
    #: a scale must beat scale 1's share of exact counts by this much (noise: 18 draws per cell move it by ~0.1)
    min_gain: float = 0.12
    #: sample as the studio and `moattn generate` do
    steps: int = SampleConfig().steps
    guidance: float = DEFAULT_GUIDANCE
    eta: float = DEFAULT_ETA
    seed: int = 0

    def __post_init__(self) -> None:
        unknown = [a for a in self.actions if a not in VERB_PHRASES]
        if unknown:
            raise ValueError(f"no calibration phrase for {unknown}")
        if 1.0 not in self.scales:
            raise ValueError("the scales must include 1 (the corpus's length)")

    @classmethod
    def quick(cls) -> "TempoConfig":
        """About a fifth of the work: counts 2 and 3, four seeds, three scales."""
        return cls(counts=(2, 3), scales=(1.0, 1.15, 1.3), seeds=4)


def _exact_shares(loaded: LoadedModel, action: str, config: TempoConfig, log) -> dict[float, float]:
    """Per scale: the share of draws (counts x seeds) whose detected repetitions equal the count asked for."""
    from engine.duration import auto_seconds
    from engine.evaluation.adherence import check_segments
    from engine.generate import Request, frames_for, generate
    from engine.intent import parse_intent

    # one draw per count and seed, the seeds taking the action's phrasings in turn
    prompts = [calibration_prompt(action, c, seed) for c in config.counts for seed in range(config.seeds)]
    intents = [parse_intent(p) for p in prompts]
    for p, intent in zip(prompts, intents):
        if len(intent.segments) != 1 or intent.segments[0].action != action or intent.segments[0].count is None:
            raise ValueError(f"calibration prompt {p!r} does not parse as one counted {action}")
    shares = {}
    for scale in config.scales:
        frames = [min(frames_for(min(auto_seconds(p) * scale, MAX_SECONDS)), loaded.model.config.max_frames)
                  for p in prompts]
        request = Request(prompts=prompts, frames=frames)
        sample = SampleConfig(steps=config.steps, guidance=config.guidance, eta=config.eta, seed=config.seed)
        joints = generate(loaded, request, sample).joints
        hits, got = [], []
        for j, intent in zip(joints, intents):
            check = check_segments(j, intent)[0]
            got.append(len(check.events))
            hits.append(bool(check.result["count"]))
        shares[scale] = float(np.mean(hits))
        log(f"tempo {action} x{scale:.2f}: exact {shares[scale]:.2f}, counted {got} (asked "
            f"{[c for c in config.counts for _ in range(config.seeds)]})")
    return shares


def choose(shares: dict[float, float], min_gain: float) -> float:
    """The scale nearest 1 among those within half ``min_gain`` of the most exact counts (the draws cannot tell them
    apart, and a smaller change of length is the safer one), where it beats scale 1 by ``min_gain``; else 1."""
    best = max(shares.values())
    near = min((s for s, v in shares.items() if v >= best - max(min_gain, 0.0) / 2), key=lambda s: (abs(s - 1.0), s))
    return float(near) if shares[near] - shares[1.0] >= min_gain else 1.0


def calibrate_tempo(loaded: LoadedModel, config: TempoConfig = TempoConfig(), *, log=lambda line: None) -> dict:
    """Per counted action: the exact-count share at each scale and the scale chosen (see the module docstring)."""
    t0 = time.monotonic()
    per_action, chosen = {}, {}
    for action in config.actions:
        shares = _exact_shares(loaded, action, config, log)
        per_action[action] = {f"{s:g}": round(v, 3) for s, v in shares.items()}
        chosen[action] = choose(shares, config.min_gain)
        log(f"tempo {action}: scale {chosen[action]:g}")
    before = float(np.mean([per_action[a]["1"] for a in config.actions]))
    after = float(np.mean([per_action[a][f"{chosen[a]:g}"] for a in config.actions]))
    return {"count_scale": chosen, "per_action": per_action, "exact_at_scale_1": round(before, 3),
            "exact_chosen": round(after, 3), "counts": list(config.counts), "seeds": config.seeds,
            "steps": config.steps, "seconds": round(time.monotonic() - t0, 1)}


def write_tempo(folder: Path, result: dict) -> None:
    """Store the chosen scales in the model folder's config.json (actions at scale 1 are left out)."""
    data = read_config(folder)
    data["durations"] = {"count_scale": {a: s for a, s in result["count_scale"].items() if s != 1.0},
                         "calibration": {k: v for k, v in result.items() if k != "count_scale"}}
    write_config_json(folder, data)


def format_table(result: dict) -> str:
    scales = list(next(iter(result["per_action"].values())))
    lines = [f"exact count share per duration scale ({result['seeds']} seeds x counts {result['counts']}, "
             f"{result['steps']} steps; the calibration's own prompts):",
             f"{'action':16}" + "".join(f"{'x' + s:>8}" for s in scales) + f"{'chosen':>9}"]
    for action, shares in result["per_action"].items():
        lines.append(f"{action:16}" + "".join(f"{shares[s]:>8.2f}" for s in scales)
                     + f"{result['count_scale'][action]:>9g}")
    lines.append(f"mean exact: {result['exact_at_scale_1']:.3f} at the corpus's lengths, {result['exact_chosen']:.3f} "
                 f"with the chosen scales ({result['seconds']:.0f} s)")
    return "\n".join(lines)
