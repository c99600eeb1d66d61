"""`moattn duet`'s options (ComMDM), declared once: torch-free, so the command line's parser reads them without
loading the model code (engine.methods.duet). The lengths' defaults are engine.units's."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from engine.options import option, validate
from engine.paths import DUET_DIR
from engine.units import (DEFAULT_GUIDANCE, DUET_COMPLETE_SECONDS, DUET_PREFIX_SECONDS, DUET_SECONDS, MAX_SECONDS,
                          MIN_SECONDS)


@dataclass(frozen=True, kw_only=True)
class DuetOptions:
    """Two people from one prompt (``prompt``), or the completion of a two-person prefix (``prefix``)."""

    prompt: str | None = option(None, positional=True, nargs="?", label="Prompt (both people)",
                                help="what the two people do (both read it; optional when completing a prefix)")
    # soft: the lengths a box offers (the engine's frames_for checks the length a duet is made with)
    seconds: float | None = option(None, soft=(MIN_SECONDS, MAX_SECONDS), step=0.5, label="Seconds",
                                   help=f"length in seconds from a prompt (default {DUET_SECONDS:g}), or the seconds "
                                        f"completed after a prefix (default {DUET_COMPLETE_SECONDS:g})")
    prefix: tuple[Path, ...] | None = option(
        None, nargs="+", metavar="FILE",
        help="a duet .npy (2, T, 22, 3), or two motions (.bvh/.npy), person a then person b")
    prefix_seconds: float | None = option(None, soft=(0.1, 5.0), step=0.5, label="Given (s)",
                                          help=f"seconds of the prefix kept (default {DUET_PREFIX_SECONDS:g})")
    communication: bool = option(True, flag="--no-communication",
                                 label="communication block (ComMDM); off: the base model twice",
                                 help="the baseline: the prior run twice without the block (fixed placement)")
    contact: bool = option(True, flag="--no-contact",
                           label="contact guidance: hands touch when the training examples do",
                           help="no contact guidance (by default, a prompt read as a trained interaction with "
                                "contacts, e.g. a handshake, has the hands guided to touch when the training "
                                "examples do)")
    spacing: bool = option(True, flag="--no-spacing",
                           help="no spacing rule (by default, in a duet from a prompt, person b is moved apart where "
                                "the two would start inside each other or come closer than the training duets ever "
                                "do: engine/methods/duet_spacing.py)")
    guidance: float | None = option(None, help=f"classifier-free guidance scale (default {DEFAULT_GUIDANCE:g}; 1.0 "
                                    "with --prefix and no prompt)")
    duet_model: Path = option(DUET_DIR, help="the ComMDM block trained on that prior")

    def __post_init__(self) -> None:
        validate(self)  # every declared bound and choice, one line naming the option

    def guidance_used(self) -> float:
        """The guidance scale: the one given, else none (1.0) for a completion without text, else the default."""
        if self.guidance is not None:
            return self.guidance
        return 1.0 if self.prompt is None else DEFAULT_GUIDANCE
