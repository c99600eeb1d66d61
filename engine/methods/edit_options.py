"""One mapping from user-level edit options to MotionCLR configs and calls, shared by ``moattn edit`` and the
studio's Edit tab (so the two never disagree on defaults, windows or frame spans).

``EditOptions`` holds what a user picks (kind, word, weight, frame span, step window, layers...);
:func:`build_config` turns it into the method's typed config and :func:`run_edit` runs the edit
through :mod:`engine.methods.edits`. Counting is not an edit (see ``edits.count_generated`` /
``edits.count_motion``).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported lazily below: the CLI reads KINDS without loading torch
    from engine.methods.windows import Window

from engine.methods.edit_kinds import EDIT_KINDS, KINDS, REGISTRY  # noqa: F401 (the registry's names, re-exported)

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


#: edit kinds whose default layers come from the model's calibration (``config.json`` "edits")
CALIBRATED_KINDS = tuple(k for k, v in REGISTRY.items() if v.calibrated)


def calibrated_layers(model_config: dict | None) -> tuple[int, ...] | None:
    """The layers where emphasis measurably grows the action, as calibrated for this model (None = all)."""
    layers = ((model_config or {}).get("edits") or {}).get("emphasize_layers")
    return tuple(int(i) for i in layers) if layers else None


def default_window(kind: str, model_config: dict | None = None) -> Window:
    """The method's own step/layer window for an edit kind (what ``--step-window`` / ``--layers`` override).

    ``model_config`` (a loaded model's config) supplies calibrated emphasis layers, see
    :mod:`engine.evaluation.calibrate_edits`.
    """
    from engine.methods.windows import Window

    entry = REGISTRY.get(kind)
    if kind in CALIBRATED_KINDS:
        return Window(layers=calibrated_layers(model_config))
    if entry is not None and entry.window is not None:
        return entry.window(model_config)
    return Window()


def window(options: EditOptions, default: Window) -> Window:
    """The step/layer window: the method's default unless the user set steps or layers."""
    from engine.methods.windows import Window

    start, end = options.step_window if options.step_window is not None else (default.start, default.end)
    layers = tuple(sorted(options.layers)) if options.layers else default.layers
    return Window(float(start), float(end), layers)


def build_config(options: EditOptions, *, frames: int, model_config: dict | None = None):
    """The typed method config for ``options`` (a motion of ``frames`` frames; ``model_config``: see default_window)."""
    entry = REGISTRY[options.kind]
    if not entry.is_edit:
        raise ValueError(f"{options.kind!r} is not an edit (counting is edits.count_generated / count_motion)")
    return entry.build(options, frames=frames, steps=window(options, default_window(options.kind, model_config)))


def run_edit(loaded, options: EditOptions, *, frames: int, sample, record: bool = False,
             on_step: Callable | None = None):
    """Build the config and run the edit -> ``edits.EditOutput`` (``on_step(StepState)`` after every step)."""
    cfg = build_config(options, frames=frames, model_config=loaded.config)
    cfg.window.check_layers(loaded.model.num_layers)  # the user's layers, or the calibrated ones
    return REGISTRY[options.kind].run(loaded, options, cfg, frames=frames, sample=sample, record=record,
                                      on_step=on_step)
