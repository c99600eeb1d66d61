"""One mapping from user-level edit options to MotionCLR configs and calls, shared by ``moattn edit`` and the
studio's Edit tab (so the two never disagree on defaults, windows or frame spans).

``EditOptions`` holds what a user picks (kind, word, weight, frame span, step window, layers...);
:func:`build_config` turns it into the method's typed config and :func:`run_edit` runs the edit
through :mod:`engine.methods.edits`. Counting is not an edit (see ``edits.count_generated`` /
``edits.count_motion``).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported lazily below: the CLI reads KINDS without loading torch
    from engine.methods.windows import Window

from engine.methods.edit_kinds import EDIT_KINDS, KINDS, REGISTRY  # noqa: F401 (the registry's names, re-exported)
from engine.methods.spans import Span, as_spans, check_spans

Source = Any  # a prompt (str), or joints (T, 22, 3) of a real motion (DDIM-inverted by the edit)


def _option(default, *, bounds: tuple[int, int] | None = None, label: str, help: str):
    """A user option declared once: its default, bounds, label and help (the CLI's flag and the tab's widget read
    them through :func:`option_spec`)."""
    return field(default=default, metadata={"bounds": bounds, "label": label, "help": help})


@dataclass(frozen=True)
class OptionSpec:
    name: str
    default: Any
    bounds: tuple[int, int] | None
    label: str
    help: str

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    def check(self, value) -> None:
        if self.bounds is not None and not self.bounds[0] <= value <= self.bounds[1]:
            raise ValueError(f"{self.label.lower()} must be between {self.bounds[0]} and {self.bounds[1]}, got {value}")


@dataclass(frozen=True)
class EditOptions:
    """What the user chose, before it becomes a method config.

    ``prompt``: the prompt (the reference prompt for replace; the example / content source for
    example / style, where it may also be joints). ``frames``: the frame span [start, end) the
    edit touches, or for grounding several spans ``((start, end), ...)`` (None = the kind's default: all
    frames, erase the last half); several spans are kept sorted and must not overlap. ``step_window``:
    fractions of the sampling run (None = the method's default window). ``layers``: None = the kind's default
    (all layers; emphasize: the layers calibrated for the model, see :func:`default_window`).
    """

    kind: str
    prompt: Source | None = None
    word: str | None = None
    occurrence: int = 0
    weight: float = 0.3
    mode: str = "add"
    frames: Span | tuple[Span, ...] | None = None
    edited: str | None = None
    fraction: float = 0.5
    style: Source | None = None
    count: int = 4
    chunk_frames: int = _option(
        20, bounds=(4, 100), label="Chunk size (frames)",
        help="example-based: the example's self-attention queries are cut into chunks of this many frames and "
             "shuffled per output (paper: 1 s = 20 frames). Shorter chunks give more varied outputs, longer ones "
             "keep more of the example's order; a chunk as long as the motion copies it")
    step_window: tuple[float, float] | None = None
    layers: tuple[int, ...] | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown edit kind {self.kind!r}; one of {', '.join(KINDS)}")
        if self.frames is not None:
            spans = check_spans(as_spans(self.frames))  # sorted; overlapping or reversed spans refused here
            if not spans:
                raise ValueError("no frame span given")
            object.__setattr__(self, "frames", spans[0] if len(spans) == 1 else spans)
        option_spec("chunk_frames").check(self.chunk_frames)

    @property
    def spans(self) -> tuple[Span, ...]:
        """The frame span(s) as a tuple of spans (() = the kind's default)."""
        return as_spans(self.frames)


def option_spec(name: str) -> OptionSpec:
    """The declaration of an ``EditOptions`` field: default, bounds, label, help."""
    found = {f.name: f for f in fields(EditOptions)}.get(name)
    if found is None or "help" not in found.metadata:
        raise KeyError(f"{name!r} is not a declared edit option")
    m = found.metadata
    return OptionSpec(name=name, default=found.default, bounds=m["bounds"], label=m["label"], help=m["help"])


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
             on_step: Callable | None = None, config=None):
    """Run the edit -> ``edits.EditOutput`` (``on_step(StepState)`` after every step). ``config``: the edit's
    config when it was already built (:func:`build_config`, e.g. to check it before the run); None: built here."""
    cfg = config if config is not None else build_config(options, frames=frames, model_config=loaded.config)
    cfg.window.check_layers(loaded.model.num_layers)  # the user's layers, or the calibrated ones
    return REGISTRY[options.kind].run(loaded, options, cfg, frames=frames, sample=sample, record=record,
                                      on_step=on_step)
