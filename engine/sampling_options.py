"""The sampling settings every sampling command and the studio's Generate box share (the seed, the DDIM steps, the
guidance scale, the model folder), declared once. Torch-free and argparse-free: ``engine.cli.options`` makes every
command's ``--seed``/``--steps``/``--guidance``/``--model`` from :class:`SampleOptions`, the studio's Generate box
its seed, steps and guidance boxes (``app.components.option_params``)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from engine.options import option
from engine.paths import MODEL_DIR
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE, DEFAULT_GUIDANCE_FROM, DEFAULT_STEPS

SEED_LIMIT = 2**32  # seeds are 0 <= seed < 2**32: derived seeds (seed * 7919 + step, seed * 1009 + slot, seed + 17)
#                     must stay within torch.manual_seed's 64-bit range; numpy's default_rng takes them too


def parse_seed(text: str) -> int:
    """A seed from its text: a whole number 0 <= seed < 2**32 (SEED_LIMIT); a one-line ValueError otherwise."""
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f"a seed is a whole number, got {text[:40]!r}") from None
    if not 0 <= value < SEED_LIMIT:
        raise ValueError(f"seed {text[:40]} is out of range: a seed is a whole number from 0 to {SEED_LIMIT - 1}")
    return value


@dataclass(frozen=True, kw_only=True)
class SampleOptions:
    """What every sampling command shares: the seed, the DDIM steps, the guidance scale and the model folder."""

    seed: int = option(0, parse=parse_seed, soft=(0, math.inf), help="the random seed, 0 to 2**32 - 1")
    steps: int = option(DEFAULT_STEPS, bounds=(1, 1000), whole=True, help="sampling steps")
    guidance: float = option(DEFAULT_GUIDANCE, bounds=(0.0, 20.0), step=0.5,
                             help="classifier-free guidance scale (1: none)")
    guidance_from: int = option(DEFAULT_GUIDANCE_FROM, bounds=(0, 999), whole=True, cli=True,
                                help="the guidance applies at the noisier timesteps t >= this, of 1000 (0: at "
                                     "every step, classic classifier-free guidance)")
    eta: float = option(DEFAULT_ETA, bounds=(0.0, 1.0), step=0.25,
                        help="the fresh noise each sampling step adds (0: deterministic DDIM; 1: the DDPM "
                             "posterior's, which keeps motions lively). A seed still gives one motion")
    model: Path = option(MODEL_DIR, help="the model folder")
