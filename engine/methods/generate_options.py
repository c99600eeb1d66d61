"""`moattn generate`'s options, declared once (torch-free: the parser reads them without loading the model code).
The sampling settings every command shares (seed, steps, guidance, model) are engine.sampling_options.SampleOptions."""
from __future__ import annotations

from dataclasses import dataclass

from engine.duration import AUTO, seconds_argument
from engine.options import option, validate
from engine.units import MAX_SECONDS, MIN_SECONDS

SAMPLERS = ("ddim", "ddpm")
SEQUENCE_MODES = ("clauses", "whole")  # engine.methods.sequence: a prompt of several actions in order
DEFAULT_SEQUENCE = "clauses"  # what the CLI, the studio and the adherence bench do by default
DEFAULT_TRIES = 3  # tries per generation (engine.analysis.followed.best_try); the studio and the CLI share it
MAX_TRIES = 8
# from this try on (0-based: the second), a prompt of one walk, run or jog (straight, "to the left", "in a circle")
# walks the corpus's path for it with the root control model (engine.methods.held_direction); the first try is the
# model's own
HOLD_FROM_TRY = 1


def check_sequence(value: str) -> None:
    """A one-line ValueError unless ``value`` is one of :data:`SEQUENCE_MODES`."""
    if value not in SEQUENCE_MODES:
        raise ValueError(f"sequence must be one of {', '.join(SEQUENCE_MODES)}, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class GenerateOptions:
    """Text -> motion: the prompt, its length, the sampler, and what a .npy output holds."""

    prompt: str = option(positional=True, help='e.g. "a person jumps twice"')
    seconds: float | str = option(AUTO, parse=seconds_argument, help=f"length in seconds ({MIN_SECONDS:g} to "
                                  f"{MAX_SECONDS:g}), or auto: predicted from the prompt (default: auto)")
    sampler: str = option("ddim", choices=SAMPLERS, help="the sampler: DDIM (deterministic; the default) or DDPM (stochastic)")
    sequence: str = option(DEFAULT_SEQUENCE, choices=SEQUENCE_MODES,
                           help="a prompt of several actions in order ('waves, then kicks'): generated clause by "
                                "clause and joined with DoubleTake (clauses, the default: each action as if asked "
                                "alone), or in one take of the whole prompt (whole: the only way to record its "
                                "attention)")
    tries: int = option(DEFAULT_TRIES, bounds=(1, MAX_TRIES), whole=True,
                        help="generate up to this many motions, from the seed on (seed, seed + 1, ...), and keep the "
                             "first whose checked attributes all follow the prompt (what the detectors see: action, "
                             "count, side, direction, order), else the one that misses fewest (1: the one take); from the second "
                             "try on, one walk, run or jog (straight, 'to the left', 'in a circle') walks the "
                             "corpus's path for it (the root control model)")
    vecs: bool = option(False, help="write .npy outputs as 263-dim features instead of joints")

    def __post_init__(self) -> None:
        validate(self)  # every declared bound and choice, one line naming the option
