"""DDIM inversion's settings, declared once (torch-free: `moattn invert`'s flags are generated from them; the
method is engine.methods.inversion, which re-exports :class:`InversionConfig`)."""
from __future__ import annotations

from dataclasses import dataclass

from engine.options import option, validate
from engine.units import DEFAULT_STEPS


@dataclass(frozen=True)
class InversionConfig:
    """``prompt`` describes the motion ("" = unconditional); guidance 1.0 keeps DDIM invertible."""

    prompt: str = option("", help="a caption of the motion (default: unconditional)")
    steps: int = option(DEFAULT_STEPS, bounds=(1, 1000), whole=True, help="DDIM steps of the inversion")
    refine: int = option(4, help="fixed-point iterations per inversion step (0 = plain DDIM)")
    landing: int = option(4, bounds=(0, 50), whole=True,
                          help="fixed-point iterations of the first step, clean -> the cleanest timestep, so the "
                               "rebuild's last step lands on the motion (0 = take the motion as that latent)")
    guidance: float = 1.0

    def __post_init__(self) -> None:
        validate(self)  # every declared bound and choice, one line naming the option
