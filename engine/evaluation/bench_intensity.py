"""`moattn bench --intensity`: does the model follow the words that scale an action ("jumps high", "waves gently")?

The corpus scales an action's size by its intensity words (``engine.synth.grammar.INTENSITY_WORDS``: a "high" jump
has 1.5-1.7x a normal one's intensity, "a little" 0.5-0.6x). For each action that has such words and a size measure
(``engine.analysis.action_size.MEASURES``), a plain prompt is sampled beside the same prompt with each of the first
``words`` "high" and "a little" words appended. Every variant of a seed starts from the same noise, at the plain
prompt's own length (``--seconds auto``, as a user gets it), and is sampled as the studio samples.

Per action: the mean size of each variant, and the share of draws in which a "high" variant is bigger than the plain
one ("grows"), a "little" variant smaller ("shrinks"), and both ("in order": each pair of a high and a little word
with the plain draw between them). Session 40 found "a person jumps high" no higher than "a person jumps" while kicks
and waves follow their words; this bench is where that shows.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from engine.analysis.action_size import MEASURES, amplitude
from engine.generate import Request, SampleConfig, frames_for, generate
from engine.units import DEFAULT_STEPS, FPS

#: action -> (plain prompt, the word whose size is measured); the intensity words are the corpus grammar's
CASES: dict[str, tuple[str, str]] = {
    "jump": ("a person jumps", "jumps"),
    "kick": ("a person kicks with the right leg", "kicks"),
    "wave": ("a person waves the right hand", "waves"),
}


@dataclass(frozen=True)
class IntensityBenchConfig:
    actions: tuple[str, ...] = tuple(CASES)
    words: int = 2  # "high" and "a little" words per action, the grammar's first
    seeds: int = 12  # a share over 24 draws per action: about ±0.1; the overall in-order share about ±0.06
    steps: int = DEFAULT_STEPS
    seed: int = 0

    def __post_init__(self) -> None:
        unknown = [a for a in self.actions if a not in CASES]
        if unknown:
            raise ValueError(f"no intensity case for {', '.join(unknown)} (known: {', '.join(CASES)})")
        if self.words < 1 or self.seeds < 1:
            raise ValueError("words and seeds must be at least 1")

    @classmethod
    def quick(cls) -> "IntensityBenchConfig":
        return cls(words=1, seeds=2)


def variants(action: str, words: int) -> tuple[list[str], list[str]]:
    """The first ``words`` "high" and "a little" words of ``action`` in the corpus grammar."""
    from engine.synth.grammar import INTENSITY_WORDS

    table = INTENSITY_WORDS[action]
    return list(table["high"][:words]), list(table["a little"][:words])


def bench_intensity(loaded, config: IntensityBenchConfig = IntensityBenchConfig(), *,
                    log: Callable[[str], None] = lambda s: None) -> dict:
    from engine.duration import auto_seconds

    rows = []
    for action in config.actions:
        prompt, verb = CASES[action]
        high, little = variants(action, config.words)
        prompts = [prompt] + [f"{prompt} {w}" for w in high + little]
        frames = frames_for(auto_seconds(prompt, loaded.tempo))
        sizes = []  # (seeds, 1 + highs + littles)
        for s in range(config.seeds):
            seed = config.seed + s
            noise = torch.randn((1, frames, loaded.model.config.feature_dim),
                                generator=torch.Generator().manual_seed(seed)).repeat(len(prompts), 1, 1)
            gen = generate(loaded, Request(prompts=prompts, frames=[frames] * len(prompts), noise=noise),
                           SampleConfig(steps=config.steps, seed=seed))
            sizes.append([amplitude(joints, verb) for joints in gen.joints])
        sizes = np.asarray(sizes)
        plain, up, down = sizes[:, 0], sizes[:, 1:1 + len(high)], sizes[:, 1 + len(high):]
        grows, shrinks = up > plain[:, None], down < plain[:, None]
        row = {"action": action, "prompt": prompt, "measure": MEASURES[action], "seconds": frames / FPS,
               "plain_m": float(plain.mean()),
               "high": {w: float(up[:, i].mean()) for i, w in enumerate(high)},
               "a_little": {w: float(down[:, i].mean()) for i, w in enumerate(little)},
               "grows": float(grows.mean()), "shrinks": float(shrinks.mean()),
               "in_order": float((grows[:, :, None] & shrinks[:, None, :]).mean())}
        log(f"{action}: plain {row['plain_m']:.3f} m, grows {row['grows']:.2f}, shrinks {row['shrinks']:.2f}")
        rows.append(row)
    return {"rows": rows, "seeds": config.seeds, "words": config.words, "steps": config.steps,
            "in_order": float(np.mean([r["in_order"] for r in rows]))}


def format_table(result: dict) -> str:
    lines = [f"intensity words: each action plain and with the corpus's words, {result['seeds']} seeds, the same "
             f"noise per seed, the plain prompt's own length, {result['steps']} steps",
             f"{'action':<7}{'s':>5}{'plain m':>9}  {'high words (m)':<38}{'a little words (m)':<38}"
             f"{'grows':>6}{'shrinks':>8}{'in order':>9}"]
    for r in result["rows"]:
        high = ", ".join(f"{w} {v:.3f}" for w, v in r["high"].items())
        little = ", ".join(f"{w} {v:.3f}" for w, v in r["a_little"].items())
        lines.append(f"{r['action']:<7}{r['seconds']:>5.1f}{r['plain_m']:>9.3f}  {high:<38}{little:<38}"
                     f"{r['grows']:>6.2f}{r['shrinks']:>8.2f}{r['in_order']:>9.2f}")
    lines.append(f"in order (a high word bigger and a little word smaller than the plain draw): {result['in_order']:.2f}")
    lines.append("sizes: " + "; ".join(f"{r['action']}: {r['measure']}" for r in result["rows"]))
    return "\n".join(lines)
