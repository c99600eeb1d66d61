"""DoubleTake's options (PriorMDM), declared once: fields, bounds, defaults and help, read by the method
(:mod:`engine.methods.doubletake`), ``moattn compose``'s flags and the studio's Compose tab. Torch-free, so a
command line's parser can read it without loading torch.

Each option is a dataclass field whose metadata holds its ``bounds`` (inclusive), ``help`` and ``unit``;
:func:`option_info` reads them back, :func:`check_option` is the one range check (a one-line ValueError).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

from engine.options import option as declared
from engine.units import FPS


def option(default, *, bounds: tuple[float, float], help: str, unit: str = "", flag: str | None = None,  # noqa: A002
           none: str = ""):
    """A config field with its bounds (inclusive), help, unit, command-line flag (default: its name) and what a
    None default means (``none``)."""
    return field(default=default, metadata={"bounds": bounds, "help": help, "unit": unit, "flag": flag, "none": none})


@dataclass(frozen=True)
class OptionInfo:
    name: str
    default: Any
    bounds: tuple[float, float]
    help: str
    unit: str
    flag: str  # the command-line flag, without the dashes
    none: str  # what the default None means

    def default_text(self) -> str:
        return self.none if self.default is None else f"{self.default:g}"


def option_info(cls, name: str) -> OptionInfo:
    """The declared default, bounds, help and unit of one option of ``cls`` (SecondTake or DoubleTakeConfig)."""
    for f in fields(cls):
        if f.name == name and f.metadata.get("bounds") is not None:
            m = f.metadata
            return OptionInfo(name, f.default, m["bounds"], m["help"], m["unit"], m["flag"] or name.replace("_", "-"),
                              m["none"])
    raise KeyError(f"{cls.__name__} has no option {name!r}")


def options(cls) -> list[OptionInfo]:
    """Every declared option of ``cls``, in declaration order."""
    return [option_info(cls, f.name) for f in fields(cls) if f.metadata.get("bounds") is not None]


def check_option(cls, name: str, value, *, what: str | None = None) -> None:
    """ValueError (one line) unless ``value`` is a finite number within the declared bounds of ``cls.name``."""
    info = option_info(cls, name)
    lo, hi = info.bounds
    label = what or name
    unit = f" {info.unit}" if info.unit else ""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
        raise ValueError(f"{label} must be a number, got {value!r}")
    if not lo <= value <= hi:
        raise ValueError(f"{label} must be between {lo:g} and {hi:g}{unit}, got {value:g}")


@dataclass(frozen=True)
class SecondTake:
    """The second take: every transition "sandwich" (the end of the interval before, the handshake, the start of the
    interval after) of the first take is re-noised to T' and denoised again with a soft mask saying per frame how
    much it may change: ``hard`` on the handshake, ``soft`` on the intervals' frames, a ``ramp`` of b frames between.

    Paper values: T' = 700 of 1000, M_hard = 0.85, M_soft = 0.1, b = 10; the sandwich holds the neighbouring
    intervals whole (``context`` None), cropped around the handshake to the frames the model takes.

    Defaults: the paper's masks, with T' = 1 (the sandwich re-noised all the way) and b = 20, chosen by
    ``moattn bench --compose``. The paper's T' = 700 is 700 stochastic DDPM steps; here the sampler is DDIM with
    the first take's 20-50 steps, which (deterministic and nearly invertible) brings a sandwich re-noised to 0.7
    back to almost the first take: the paper's values changed the transition jerk by 1-4 % (a DDPM posterior,
    ``eta`` 1, did not help either). Re-noised fully, the first take reaches the sandwich only through the soft
    mask on x̂0, as the paper's masks intend.
    """

    renoise: float = option(1.0, bounds=(0.01, 1.0), help="T': how far each sandwich is re-noised, as a fraction "
                            "of the diffusion timesteps (paper 0.7 of 1000 DDPM steps; 1: all the way)")
    hard: float = option(0.85, bounds=(0.0, 1.0), help="M_hard: how much the handshake frames may change (paper 0.85)")
    soft: float = option(0.1, bounds=(0.0, 1.0), help="M_soft: how much the neighbouring intervals' frames may "
                         "change (paper 0.1; at most M_hard)")
    ramp: int = option(20, bounds=(0, 60), help="b: frames of linear ramp from M_hard to M_soft on each side of the "
                       "handshake (paper 10)", unit="frames")
    eta: float = option(0.0, bounds=(0.0, 1.0), flag="second-take-eta",
                        help="DDIM eta of the second take's steps (0: deterministic; 1: the DDPM posterior, fresh "
                        "noise every step as in the paper's 1000-step DDPM)")
    steps: int | None = option(None, bounds=(1, 1000), flag="second-take-steps", none="the first take's steps",
                               help="sampling steps over the whole schedule, of which the second take runs those at "
                               "or below T'")
    context: int | None = option(None, bounds=(1, 196), unit="frames", none="the whole interval",
                                 help="frames of each neighbouring interval in the sandwich at most (the whole "
                                 "interval up to its other handshake, as in the paper, cropped to the model's "
                                 "frames; the code before the paper's sandwich used 30)")
    # the authors' code denoises sandwiches without text; True: each with "A, then B" (doubletake.transition_prompts)
    text: bool = declared(False, flag="--second-take-text", label="with text ('A, then B')",
                          help="denoise each transition with 'A, then B' (default: without text, as the authors' code)")
    # not the paper's: the second take's prediction goes through engine.diffusion.feet.PlantedFeet (the legs moved so
    # a foot on the floor stops sliding, at the last denoising steps), as controlled generation does. On by default,
    # as `moattn bench --compose` chose: the transitions slide half as often as with the paper's second take (its
    # dt_paper row), with about the same jerk
    planted_feet: bool = declared(True, flag="--no-second-take-planted-feet", label="keep planted feet still",
                                  help="keep a foot on the floor still in the transitions (not the paper's; off: the "
                                  "paper's second take)")

    def __post_init__(self) -> None:
        for name in ("renoise", "hard", "soft", "ramp", "eta"):
            check_option(SecondTake, name, getattr(self, name))
        if self.soft > self.hard:
            raise ValueError(f"soft ({self.soft:g}) must not exceed hard ({self.hard:g})")
        if self.ramp != int(self.ramp):
            raise ValueError(f"ramp is a number of frames, got {self.ramp!r}")
        for name in ("steps", "context"):
            value = getattr(self, name)
            if value is not None:
                if isinstance(value, bool) or not isinstance(value, int):
                    raise ValueError(f"{name} is a whole number, got {value!r}")
                check_option(SecondTake, name, value)


HANDSHAKE = option(20, bounds=(0, 60), help="handshake length h: the frames two consecutive intervals share "
                   "(paper 1 s = 20 frames; 0: plain concatenation)", unit="frames")


@dataclass(frozen=True)
class DoubleTakeConfig:
    """``handshake``: h frames shared by consecutive intervals, one for every transition or a tuple with one per
    transition (interval i and i + 1 share ``handshake[i]``); ``second_take``: None = first take only."""

    handshake: int | tuple[int, ...] = HANDSHAKE
    second_take: SecondTake | None = field(default_factory=SecondTake)

    def __post_init__(self) -> None:
        values = self.handshake if isinstance(self.handshake, tuple) else (self.handshake,)
        if isinstance(self.handshake, tuple) and not values:
            raise ValueError("give at least one handshake length")
        for i, h in enumerate(values):
            what = "the handshake" if not isinstance(self.handshake, tuple) else f"handshake {i + 1}"
            if isinstance(h, bool) or not isinstance(h, int):
                raise ValueError(f"{what} is a whole number of frames, got {h!r}")
            check_option(DoubleTakeConfig, "handshake", h, what=what)

    def handshakes(self, intervals: int) -> tuple[int, ...]:
        """One handshake length per transition of ``intervals`` intervals (a single value applies to all)."""
        n = max(intervals - 1, 0)
        if not isinstance(self.handshake, tuple):
            return (self.handshake,) * n
        if len(self.handshake) == 1:
            return self.handshake * n
        if len(self.handshake) != n:
            raise ValueError(f"{len(self.handshake)} handshake lengths for {intervals} interval"
                             f"{'s' * (intervals != 1)}: give one for all transitions or one per transition ({n})")
        return self.handshake


def parse_handshakes(text: str) -> tuple[int, ...]:
    """``--handshake``'s value: frames, or seconds with an ``s`` ("1s" = 20 frames), one for all transitions or one
    per transition separated by commas ("20,30,15"). Clear one-line errors; the count is checked against the
    intervals by :meth:`DoubleTakeConfig.handshakes`."""
    info = option_info(DoubleTakeConfig, "handshake")
    lo, hi = info.bounds
    items = [s.strip() for s in str(text).split(",")]
    if not items or any(not s for s in items):
        raise ValueError(f"--handshake: expected frames like 20 or 20,30,15 (or seconds like 1s), got {text!r}")
    out = []
    for s in items:
        seconds = s.lower().endswith("s")
        number = s[:-1].strip() if seconds else s
        try:
            value = float(number)
        except ValueError:
            raise ValueError(f"--handshake: {s!r} is not a number of frames (e.g. 20) or seconds (e.g. 1s)") from None
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError(f"--handshake: {s!r} is not a number of frames (e.g. 20) or seconds (e.g. 1s)")
        frames = value * FPS if seconds else value
        if not seconds and frames != int(frames):
            raise ValueError(f"--handshake: {s} is not a whole number of frames (for seconds add an s: {s}s)")
        frames = int(round(frames))
        if not lo <= frames <= hi:
            raise ValueError(f"--handshake: {s} ({frames} frames) is out of range: a handshake lasts {lo:g} to {hi:g} "
                             f"frames ({lo / FPS:g} to {hi / FPS:g} s)")
        out.append(frames)
    return tuple(out)


def handshake_list(handshakes: Sequence[int]) -> str:
    """The per-transition lengths as the CLI writes them ("20,30,15")."""
    return ",".join(str(int(h)) for h in handshakes)
