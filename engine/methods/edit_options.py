"""One mapping from user-level edit options to MotionCLR configs and calls, shared by ``moattn edit`` and the
studio's Edit tab (so the two never disagree on defaults, windows or frame spans).

``EditOptions`` holds what a user picks (kind, word, weight, frame span, step window, layers...);
:func:`build_config` turns it into the method's typed config and :func:`run_edit` runs the edit
through :mod:`engine.methods.edits`. Counting is not an edit (see ``edits.count_generated`` /
``edits.count_motion``).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported lazily below: the CLI reads KINDS without loading torch
    from engine.methods.windows import Window

#: every kind ``moattn edit`` takes; all but "count" are edits run by :func:`run_edit`
KINDS = ("emphasize", "erase", "replace", "shift", "example", "style", "count", "ground")
EDIT_KINDS = tuple(k for k in KINDS if k != "count")

Source = Any  # a prompt (str), or joints (T, 22, 3) of a real motion (DDIM-inverted by the edit)


@dataclass(frozen=True)
class EditOptions:
    """What the user chose, before it becomes a method config.

    ``prompt``: the prompt (the reference prompt for replace; the example / content source for
    example / style, where it may also be joints). ``frames``: the frame span [start, end) the
    edit touches (None = the kind's default: all frames, erase the last half). ``step_window``:
    fractions of the sampling run (None = the method's default window). ``layers``: None = the kind's default
    (all layers; emphasize and ground: the layers calibrated for the model, see :func:`default_window`).
    """

    kind: str
    prompt: Source | None = None
    word: str | None = None
    occurrence: int = 0
    weight: float = 0.3
    mode: str = "add"
    frames: tuple[int, int] | None = None
    edited: str | None = None
    fraction: float = 0.5
    style: Source | None = None
    count: int = 4
    step_window: tuple[float, float] | None = None
    layers: tuple[int, ...] | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown edit kind {self.kind!r}; one of {', '.join(KINDS)}")


def _need(value, what: str, kind: str):
    if value is None or (isinstance(value, str) and not value.strip()):
        raise ValueError(f"the {kind} edit needs {what}")
    return value


#: edit kinds whose default layers come from the model's calibration (``config.json`` "edits")
CALIBRATED_KINDS = ("emphasize", "ground")


def calibrated_layers(model_config: dict | None) -> tuple[int, ...] | None:
    """The layers where emphasis measurably grows the action, as calibrated for this model (None = all)."""
    layers = ((model_config or {}).get("edits") or {}).get("emphasize_layers")
    return tuple(int(i) for i in layers) if layers else None


def default_window(kind: str, model_config: dict | None = None) -> Window:
    """The method's own step/layer window for an edit kind (what ``--step-window`` / ``--layers`` override).

    ``model_config`` (a loaded model's config) supplies calibrated emphasis layers, see
    :mod:`engine.evaluation.calibrate_edits`.
    """
    from engine.methods.motionclr import ExampleConfig, ReplaceConfig, ShiftConfig, StyleTransferConfig
    from engine.methods.windows import Window

    defaults = {"replace": ReplaceConfig().window, "shift": ShiftConfig().window, "example": ExampleConfig().window,
                "style": StyleTransferConfig().window}
    if kind in CALIBRATED_KINDS:
        return Window(layers=calibrated_layers(model_config))
    return defaults.get(kind, Window())


def window(options: EditOptions, default: Window) -> Window:
    """The step/layer window: the method's default unless the user set steps or layers."""
    from engine.methods.windows import Window

    start, end = options.step_window if options.step_window is not None else (default.start, default.end)
    layers = tuple(sorted(options.layers)) if options.layers else default.layers
    return Window(float(start), float(end), layers)


def build_config(options: EditOptions, *, frames: int, model_config: dict | None = None):
    """The typed method config for ``options`` (a motion of ``frames`` frames; ``model_config``: see default_window)."""
    from engine.methods.motionclr import (
        ExampleConfig, GroundingConfig, ReplaceConfig, ReweightConfig, ShiftConfig, StyleTransferConfig, erase_config,
    )

    o, kind = options, options.kind
    span = None
    if o.frames is not None:
        lo, hi = int(o.frames[0]), int(o.frames[1])
        if not 0 <= lo < hi:
            raise ValueError(f"the frame window must satisfy 0 <= start < end, got ({lo}, {hi})")
        span = (lo, min(hi, frames))
    steps = window(o, default_window(kind, model_config))
    if kind == "emphasize":
        return ReweightConfig(word=_need(o.word, "a word", kind), weight=float(o.weight), mode=o.mode, frames=span,
                              window=steps, occurrence=int(o.occurrence))
    if kind == "erase":
        cfg = erase_config(_need(o.word, "a word", kind), frames=span or (frames // 2, frames), window=steps)
        return replace(cfg, occurrence=int(o.occurrence))
    if kind == "ground":
        lo, hi = span or (0, frames)
        return GroundingConfig(word=_need(o.word, "a word", kind), mask=tuple(lo <= i < hi for i in range(frames)),
                               weight=abs(float(o.weight)), window=steps)
    if kind == "replace":
        return replace(ReplaceConfig(), window=steps)
    if kind == "shift":
        return ShiftConfig(fraction=float(o.fraction), window=steps)
    if kind == "example":
        return replace(ExampleConfig(seed=int(o.seed)), window=steps)
    if kind == "style":
        return replace(StyleTransferConfig(), window=steps)
    raise ValueError(f"{kind!r} is not an edit (counting is edits.count_generated / count_motion)")


def run_edit(loaded, options: EditOptions, *, frames: int, sample, record: bool = False,
             on_step: Callable | None = None):
    """Build the config and run the edit -> ``edits.EditOutput`` (``on_step(StepState)`` after every step)."""
    from engine.methods import edits

    o, kind = options, options.kind
    cfg = build_config(o, frames=frames, model_config=loaded.config)
    cfg.window.check_layers(loaded.model.num_layers)  # the user's layers, or the calibrated ones
    common = dict(frames=frames, sample=sample, record=record, on_step=on_step)
    if kind in ("emphasize", "erase"):
        return edits.reweight(loaded, _need(o.prompt, "a prompt", kind), cfg, **common)
    if kind == "ground":
        return edits.ground(loaded, _need(o.prompt, "a prompt", kind), cfg, **common)
    if kind == "replace":
        return edits.replace(loaded, _need(o.prompt, "the reference prompt", kind), _need(o.edited, "an edited prompt",
                                                                                          kind), cfg, **common)
    if kind == "shift":
        return edits.shift(loaded, _need(o.prompt, "a prompt", kind), cfg, **common)
    if kind == "example":
        return edits.example_based(loaded, _need(o.prompt, "an example prompt or motion", kind), cfg,
                                   count=int(o.count), **common)
    return edits.style_transfer(loaded, style=_need(o.style, "a style source", kind),
                                content=_need(o.prompt, "a content prompt or motion", kind), config=cfg, **common)
