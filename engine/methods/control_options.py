"""PriorMDM control's options, declared once: read by ``moattn control``'s flags, the studio's Control tab and the
engine (:mod:`engine.methods.control`). Torch-free, so a command line's parser and the studio read it without
loading torch.

- :class:`ControlOptions`: the method and one blend weight per control model, each field with its default,
  bounds and help (:func:`option_info`).
- :func:`blend_shares`: THE blend-weight rule (DiffusionBlending's Σ sₙ = 1): weights are finite, never negative,
  not all 0, and are scaled to sum to 1 over the controls in use. The engine applies it; the CLI and the studio
  show its one-line message and never clamp or re-normalise on their own.
- :func:`bench_verdict`: which method the control bench has ahead on drawn root + wrist paths, read from the record
  ``moattn bench --control --write`` keeps beside the control models (``assets/control/bench.json``). The studio
  opens on blending only when that record has blending ahead of inpainting on one of its figures (foot skate and
  the prompted action) and behind on neither; until then it says which one is ahead.
"""
from __future__ import annotations

import hashlib
import json
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from engine.options import option as declared
from engine.units import MAX_SECONDS, MIN_SECONDS

CONTROLS = ("root", "left_wrist", "right_wrist")
LABELS = {"root": "root path", "left_wrist": "left wrist", "right_wrist": "right wrist"}
METHODS = ("blending", "inpainting")
METHOD_HELP = {"blending": "the fine-tuned control models, one per control, blended (DiffusionBlending)",
               "inpainting": "the base model with the controls inpainted (the paper's baseline)"}


def option(default, *, help: str, bounds: tuple[float, float] | None = None,  # noqa: A002 (help, as argparse)
           soft: tuple[float, float] | None = None, step: float | None = None, choices: tuple[str, ...] | None = None,
           unit: str = "", metavar: str | None = None, label: str | None = None):
    """A field with its declared ``bounds`` (inclusive; the rule that checks them names them), the range a widget
    offers (``soft``, default the bounds), a widget ``step``, ``choices`` for a word option, ``help``, ``unit`` and
    the studio's ``label`` (an :func:`engine.options.option`: the command line's flag is generated from it)."""
    return declared(default, help=help, bounds=bounds, soft=soft, step=step, choices=choices, unit=unit,
                    metavar=metavar, label=label)


@dataclass(frozen=True)
class OptionInfo:
    name: str
    default: Any
    help: str
    bounds: tuple[float, float] | None
    soft: tuple[float, float] | None
    step: float | None
    choices: tuple[str, ...] | None
    unit: str

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


def option_info(cls, name: str) -> OptionInfo:
    """The declared default, bounds, widget range, help and unit of one option of ``cls``."""
    for f in fields(cls):
        if f.name == name and f.metadata.get("option"):
            m = f.metadata
            return OptionInfo(name, f.default, m["help"], m["bounds"], m["soft"], m["step"], m["choices"], m["unit"])
    raise KeyError(f"{cls.__name__} has no option {name!r}")


def options(cls) -> list[OptionInfo]:
    """Every declared option of ``cls``, in declaration order."""
    return [option_info(cls, f.name) for f in fields(cls) if f.metadata.get("option")]


# ----------------------------------------------------------------------------- blend weights: the one rule
WEIGHT_BOUNDS = (0.0, math.inf)
WRIST_WEIGHT = 0.25  # a wrist model's default blend weight, the root's being 1 (see ControlOptions)


def blend_shares(weights: Mapping[str, float] | Sequence[float] | None, names: Sequence[str]) -> list[float]:
    """Each control's share of the blend, in the order of ``names`` (sums to 1).

    ``weights``: None (equal shares), one number per name in that order, or name -> weight (a name missing from
    it weighs 1). Refused, with one line naming the weight: a weight that is not a finite number, a negative one,
    and weights that are all 0 (nothing to blend). Names not in use are ignored (a mapping may hold them all).
    """
    names = list(names)
    if not names:
        raise ValueError("no control to blend: turn on the root path or a wrist")
    if weights is None:
        return [1.0 / len(names)] * len(names)
    if isinstance(weights, Mapping):
        raw = [weights.get(n, 1.0) for n in names]
    else:
        raw = list(weights)
        if len(raw) != len(names):
            raise ValueError(f"{len(raw)} blend weight{'s' * (len(raw) != 1)} for {len(names)} control"
                             f"{'s' * (len(names) != 1)} ({', '.join(LABELS.get(n, n) for n in names)}): give one each")
    values = []
    for name, w in zip(names, raw):
        label = LABELS.get(name, name)
        if isinstance(w, bool) or not isinstance(w, numbers.Real) or not math.isfinite(w):
            raise ValueError(f"the blend weight of the {label} must be a finite number, got {w!r}")
        if w < 0:
            raise ValueError(f"blend weights must not be negative: the {label} has {w:g}")
        values.append(float(w))
    total = math.fsum(values)
    if total <= 0:
        raise ValueError("blend weights are all 0: give at least one control a weight above 0")
    return [v / total for v in values]


@dataclass(frozen=True, kw_only=True)
class ControlOptions:
    """A controlled generation's length, method, blend weights and planted feet (besides the prompt and the paths).

    ``method``: "blending" (the paper's method: every control's fine-tuned model, blended) or "inpainting" (the
    baseline). The weights are raw: :meth:`shares` scales those of the controls in use to sum to 1
    (:func:`blend_shares`); they apply to blending only.
    """

    seconds: float = option(6.0, bounds=(MIN_SECONDS, MAX_SECONDS), step=0.5, unit="s",
                            help="length of the motion (the paths are resampled to it; checked by the engine's "
                                 "frames_for)")
    method: str = option("blending", choices=METHODS, label="Method",
                         help="blending: the fine-tuned control models blended (DiffusionBlending); inpainting: the "
                              "base model with the controls inpainted (the baseline)")
    # Blending's default shares: the root's model carries the walk, a wrist's model the arm. Drawn root + left wrist
    # paths (runs/s38/drawn_blend.py, 27 paths, 50 steps, two sets of noises: the bench's seeds and seeds + 100):
    # foot skate 0.047 / 0.056 with root 0.8 / wrist 0.2 against 0.055 / 0.072 with equal shares (inpainting 0.29 /
    # 0.28); the prompted action in 23 + 20 of 54 motions against 19 + 21 (inpainting 21 + 19), a difference inside
    # the noise (root 0.7 / 0.3: 21, 0.9 / 0.1: 23, the root's model alone: 23 on the first set). So a wrist weighs
    # 1/4 of the root: 0.8 / 0.2 with one wrist, 2/3 and 1/6 each with both; a wrist alone has the whole blend.
    root_weight: float = option(1.0, bounds=WEIGHT_BOUNDS, soft=(0.0, 1.0), step=0.05, metavar="W",
                                help="blend weight of the root path's control model (scaled with the others to sum 1)")
    left_wrist_weight: float = option(WRIST_WEIGHT, bounds=WEIGHT_BOUNDS, soft=(0.0, 1.0), step=0.05, metavar="W",
                                      help="blend weight of the left wrist's control model (a quarter of the root's: "
                                           "an equal share cost the walk on drawn paths)")
    right_wrist_weight: float = option(WRIST_WEIGHT, bounds=WEIGHT_BOUNDS, soft=(0.0, 1.0), step=0.05, metavar="W",
                                       help="blend weight of the right wrist's control model (a quarter of the "
                                            "root's)")
    planted_feet: bool = option(True, label="Keep planted feet still",
                                help="at the last denoising steps, move the knees and feet so that a foot on the floor "
                                     "stays put while the root follows its path (engine.diffusion.feet); off: the "
                                     "paper's sampling, where feet slide along drawn paths")

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"unknown control method {self.method!r}: choose {' or '.join(METHODS)}")

    @staticmethod
    def weight_field(name: str) -> str:
        """The option holding control ``name``'s blend weight (``root`` -> ``root_weight``)."""
        if name not in CONTROLS:
            raise ValueError(f"unknown control {name!r}: choose from {', '.join(CONTROLS)}")
        return f"{name}_weight"

    def weights(self) -> dict[str, float]:
        """Control -> raw blend weight."""
        return {n: getattr(self, self.weight_field(n)) for n in CONTROLS}

    def shares(self, names: Sequence[str]) -> list[float]:
        """The blend shares of the controls ``names`` in use (the one rule, :func:`blend_shares`)."""
        return blend_shares(self.weights(), names)


# ----------------------------------------------------------------------------- which method the bench has ahead
BENCH_RECORD = "bench.json"  # beside the control models: written by `moattn bench --control --write`
BENCH_TASK = "root+left_wrist"  # the bench's drawn root + wrist task, where issue #33 sets the target
BENCH_WHAT = "drawn root + left wrist paths"
WRITE_COMMAND = "moattn bench --control --write"
# figure -> (label, True when higher is better)
FIGURES = {"skate": ("foot skate", False), "action_match": ("prompted action", True)}


def models_fingerprint(folder) -> dict[str, str]:
    """Control -> a short hash of its ``weights.pt`` in ``folder`` (the controls found there): a bench record
    speaks for these exact models only."""
    out = {}
    for name in CONTROLS:
        weights = Path(folder) / name / "weights.pt"
        if weights.is_file():
            h = hashlib.sha256()
            with weights.open("rb") as fh:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
            out[name] = h.hexdigest()[:16]
    return out


@dataclass(frozen=True)
class BenchVerdict:
    """What the control bench says of blending vs inpainting on drawn root + wrist paths.

    ``leader``: the method ahead on a figure (less foot skate, or the prompted action more often) and behind on none,
    or None (no record, a record of other control models, a figure not measured, each method ahead on one figure,
    or even on both). ``message``: one line saying so.
    """

    leader: str | None
    message: str
    figures: dict = field(default_factory=dict)  # method -> {"skate": ..., "action_match": ...}
    record: dict | None = None

    def opening_method(self, *, blending_offered: bool) -> str:
        """The method the studio opens on: blending only when the bench has it ahead and the models are there."""
        return "blending" if self.leader == "blending" and blending_offered else "inpainting"


def _number(value) -> float | None:
    return float(value) if isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value) \
        else None


def judge(figures: Mapping[str, Mapping[str, float]]) -> tuple[str | None, str]:
    """(leader, what the figures say) for blending vs inpainting; the leader is ahead on a figure and behind on none
    (even on the other: on drawn root + wrist paths the v11 control models keep the prompted action in 21 of 27
    motions with either method, and blending's foot skate is a quarter of inpainting's)."""
    blend, inpaint = figures.get("blending", {}), figures.get("inpainting", {})
    ahead: dict[str, str | None] = {}
    parts = []
    measured = True
    for key, (label, higher) in FIGURES.items():
        b, i = _number(blend.get(key)), _number(inpaint.get(key))
        if b is None or i is None:
            ahead[key], measured = None, False
            parts.append(f"{label} not measured")
            continue
        ahead[key] = None if b == i else ("blending" if (b > i) == higher else "inpainting")
        parts.append(f"{label} {b:.2f} vs {i:.2f}" + (" (even)" if ahead[key] is None else f" ({ahead[key]} ahead)"))
    winners = {w for w in ahead.values() if w is not None}
    leader = winners.pop() if measured and len(winners) == 1 else None
    return leader, ", ".join(parts)


def bench_verdict(folder) -> BenchVerdict:
    """The verdict of the bench record in ``folder`` (the control models' folder), checked against the models there."""
    folder = Path(folder)
    path = folder / BENCH_RECORD
    if not path.is_file():
        return BenchVerdict(None, f"No control bench is recorded for these control models (`{WRITE_COMMAND}` "
                                  "records one).")
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        figures = {m: dict(record["figures"][m]) for m in METHODS}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return BenchVerdict(None, f"The control bench record {path.name} cannot be read ({type(exc).__name__}; "
                                  f"`{WRITE_COMMAND}` rewrites it).")
    recorded, present = record.get("models") or {}, models_fingerprint(folder)
    if recorded != present:
        return BenchVerdict(None, f"The control bench record in {folder.name}/ is of other control models than "
                                  f"those there (retrained since?); `{WRITE_COMMAND}` measures these.", figures, record)
    leader, said = judge(figures)
    where = f"on {record.get('what', BENCH_WHAT)}"
    run = record.get("run") or {}
    paths = run.get("drawn_paths")
    how = ", ".join(filter(None, [f"{paths} drawn path{'s' * (paths != 1)}" if paths is not None else "",
                                  f"{run['steps']} steps" if "steps" in run else "",
                                  {True: "planted feet on", False: "planted feet off"}.get(run.get("planted_feet"), "")]))
    source = f" ({WRITE_COMMAND.removesuffix(' --write')}" + (f", {how})" if how else ")")
    if leader is not None:
        other = "inpainting" if leader == "blending" else "blending"
        text = f"The control bench has {leader} ahead of {other} {where}, blending vs inpainting: {said}{source}."
    else:
        text = (f"The control bench has neither method ahead {where}, blending vs inpainting: "
                f"{said}{source}.")
    return BenchVerdict(leader, text, figures, record)


def bench_record(result: Mapping, *, folder) -> dict:
    """The record ``moattn bench --control --write`` keeps in ``folder``: the drawn root + wrist task's figures per
    method from a :func:`engine.evaluation.bench_control.bench_control` result, how it ran, and which models."""
    drawn = (result.get("drawn") or {}).get("tasks", {}).get(BENCH_TASK)
    if not drawn or not all(m in drawn for m in METHODS):
        raise ValueError(f"the bench result has no drawn {BENCH_TASK} row for both blending and inpainting (it needs "
                         "the control models for the root and the left wrist, and drawn paths: --drawn > 0)")
    figures = {m: {k: drawn[m].get(k) for k in ("skate", "action_match", "error_m", "off_0_5m")} for m in METHODS}
    return {"what": BENCH_WHAT, "task": BENCH_TASK, "figures": figures, "truth_skate": result.get("truth_skate"),
            "run": {"drawn_paths": drawn["blending"].get("paths"), "steps": result.get("steps"),
                    "motions": result.get("motions"), "planted_feet": result.get("planted_feet")},
            "base": result.get("base"), "models": models_fingerprint(folder), "source": WRITE_COMMAND}


def write_bench_record(result: Mapping, *, folder) -> Path:
    """Write :func:`bench_record` to ``folder/bench.json``."""
    path = Path(folder) / BENCH_RECORD
    path.write_text(json.dumps(bench_record(result, folder=folder), indent=2) + "\n", encoding="utf-8")
    return path
