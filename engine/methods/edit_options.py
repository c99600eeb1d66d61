"""One mapping from user-level edit options to MotionCLR configs and calls, shared by ``moattn edit`` and the
studio's Edit tab (so the two never disagree on defaults, windows or frame spans).

``EditOptions`` holds what a user picks (kind, word, weight, frame span, step window, layers...);
:func:`build_config` turns it into the method's typed config and :func:`run_edit` runs the edit
through :mod:`engine.methods.edits`. Counting is not an edit (see ``edits.count_generated`` /
``edits.count_motion``).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # imported lazily below: the CLI reads KINDS without loading torch
    from engine.methods.windows import Window

from engine.methods.edit_kinds import EDIT_KINDS, KINDS, REGISTRY  # noqa: F401 (the registry's names, re-exported)
from engine.methods.emphasis_modes import MODES
from engine.methods.spans import Span, as_spans, check_spans, parse_spans
from engine.methods.word_alignment import SWAPPED, SWAPPED_DEFAULT
from engine.options import option, spec, validate

Source = Any  # a prompt (str), or joints (T, 22, 3) of a real motion (DDIM-inverted by the edit)

# The emphasis modes' ranges, labels, default weights and sweeps, as the CLI, the Edit tab and the checks read them,
# derived from their one declaration (engine.methods.emphasis_modes.MODES).
WEIGHT_RANGES: dict[str, tuple[float, float]] = {name: m.range for name, m in MODES.items()}
#: how each mode reads in a front end (the Edit tab's mode buttons)
MODE_LABELS: dict[str, str] = {name: m.label for name, m in MODES.items()}
WEIGHT_BOUNDS = (min(lo for lo, _ in WEIGHT_RANGES.values()), max(hi for _, hi in WEIGHT_RANGES.values()))
#: the weight each mode starts from when none is given (the CLI, the Edit tab): add +0.3, multiply x2, guide +0.5,
#: intensity +0.5 (half way to "jumps high")
DEFAULT_WEIGHTS: dict[str, float] = {name: m.default for name, m in MODES.items()}
#: the weights a benchmark or a calibration sweeps per mode, lowest to highest, the unedited weight in the middle
SWEEP_WEIGHTS: dict[str, tuple[float, ...]] = {name: m.sweep for name, m in MODES.items()}


def weight_range_text() -> str:
    return "; ".join(f"{mode}: {lo:g} to {hi:g}" for mode, (lo, hi) in WEIGHT_RANGES.items())


def sweep_weights(mode: str, points: int = 5) -> tuple[float, ...]:
    """The weights swept for ``mode``: all five, or three (lowest, unedited, highest)."""
    weights = SWEEP_WEIGHTS[mode]
    if points == len(weights):
        return weights
    if points == 3:
        return weights[0], weights[len(weights) // 2], weights[-1]
    raise ValueError(f"a sweep has 3 or {len(weights)} weights, not {points}")


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
        spec(EditOptions, self.name).check(value, what=self.label.lower())


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

    kind: str = option(positional=True, choices=lambda: KINDS, help="the edit")
    prompt: Source | None = option(None, positional=True, nargs="?", help="the prompt (the reference prompt for "
                                   "replace); a .bvh/.npy file works as the example/content")
    word: str | None = option(None, help="the word the edit acts on")
    occurrence: int = option(0, bounds=(0, math.inf), whole=True,
                             help="which appearance of the word in the prompt, counted from 0")
    weight: float | None = option(None, bounds=WEIGHT_BOUNDS, step=0.05, label="Weight", help="emphasis weight",
                                  none="the mode's: " + ", ".join(f"{m} {w:g}" for m, w in DEFAULT_WEIGHTS.items()),
                                  note=f"{weight_range_text()}; mul > 1, guide > 0 and intensity > 0 emphasise")
    mode: str | None = option(None, choices=tuple(WEIGHT_RANGES), label="Mode",
                              none="emphasize: the mode calibrated for the model (moattn bench --edits --calibrate); "
                                   "else add",
                              help="how the weight acts: added to or multiplied with the word's attention column, or guide: the "
                                   "prediction moved away from the one with the word erased, x0 + w (x0 - x0 erased), "
                                   "or intensity: moved towards the prompt said with the action's intensity word "
                                   "(jumps high for w > 0, jumps a little for w < 0), by |w|")
    frames: Span | tuple[Span, ...] | None = option(
        None, parse=parse_spans, metavar="START:END[,START:END...]",
        help="the frame span(s) [start, end) the edit touches, e.g. 10:20; ground takes several, e.g. "
             "10:30,50:70,90:110,130:150 (four jumps at chosen times)")
    edited: str | None = option(None, label="Edited prompt (the action swapped; words may be added or dropped)",
                                help="the edited prompt; its words are aligned to the prompt's as prompt-to-prompt "
                                     "aligns them, and the alignment is shown")
    copy_self: bool = option(False, flag="--copy-self-attention", label="Also copy the self-attention (authors' code)",
                             help="replace: also copy the reference's self-attention maps, as the authors' code does "
                                  "(keeps the timing a little closer, lands the new action less often; the paper "
                                  "copies the cross-attention only)")
    swapped: str = option(SWAPPED_DEFAULT, choices=SWAPPED, label="Swapped words attend with",
                          help="replace: what the edited prompt's swapped word attends with while the other words take "
                               "the reference's attention: 'own' its own (the default: on the shipped model 0.88 of "
                               "the edited motions are recognised as the new action against 0.69, with the timing "
                               "kept as well), 'reference' the replaced word's, so the whole map is the reference's "
                               "(the paper)")
    # the range a slider offers: ShiftConfig refuses 0 and 1 themselves (an open interval, which bounds cannot say)
    fraction: float = option(0.5, soft=(0.05, 0.95), step=0.05, label="Shift: part moved to the end",
                             help="the part of the motion moved to the end")
    style: Source | None = option(None, help="the style source, a prompt or .bvh/.npy")
    count: int = option(3, bounds=(1, 6), whole=True, label="Number of examples",
                        help="example-based: how many outputs")
    chunk_frames: int = option(
        20, bounds=(4, 100), whole=True, label="Chunk size (frames)", metavar="FRAMES",
        help="example-based: the example's self-attention queries are cut into chunks of this many frames and "
             "shuffled per output (paper: 1 s = 20 frames). Shorter chunks give more varied outputs, longer ones "
             "keep more of the example's order; a chunk as long as the motion copies it")
    step_window: tuple[float, float] | None = option(
        None, nargs=2, type=float, metavar=("START", "END"), none="the method's",
        help="fractions of the sampling steps the edit acts in")
    layers: tuple[int, ...] | None = option(
        None, nargs="+", type=int, metavar="LAYER",
        help="layers the edit acts in (default: all; emphasize: the layers calibrated for the model, see moattn bench "
             "--edits --calibrate)")
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown edit kind {self.kind!r}; one of {', '.join(KINDS)}")
        if self.frames is not None:
            spans = check_spans(as_spans(self.frames))  # sorted; overlapping or reversed spans refused here
            if not spans:
                raise ValueError("no frame span given")
            object.__setattr__(self, "frames", spans[0] if len(spans) == 1 else spans)
        validate(self, names=lambda s: (s.label or s.name).lower())

    @property
    def spans(self) -> tuple[Span, ...]:
        """The frame span(s) as a tuple of spans (() = the kind's default)."""
        return as_spans(self.frames)


def option_spec(name: str) -> OptionSpec:
    """The declaration of an ``EditOptions`` field: default, bounds, label, help."""
    try:
        found = spec(EditOptions, name)
    except KeyError:
        raise KeyError(f"{name!r} is not a declared edit option") from None
    return OptionSpec(name=name, default=found.default, bounds=found.bounds, label=found.label or name,
                      help=found.help)


#: edit kinds whose default layers come from the model's calibration (``config.json`` "edits")
CALIBRATED_KINDS = tuple(k for k, v in REGISTRY.items() if v.calibrated)


def calibrated_layers(model_config: dict | None, mode: str | None = None, *,
                      word: str | None = None) -> tuple[int, ...] | None:
    """The layers where emphasis measurably grows the action, as calibrated for this model (None = all). They belong
    to the calibrated mode (for ``word``, see :func:`calibrated_mode`). Emphasis in another ``mode`` acts in the
    layers the calibration found best for that mode (its ``calibration.modes``), or in every layer (None) where the
    calibration did not measure it."""
    chosen = calibrated_mode(model_config, word=word)
    edits = (model_config or {}).get("edits") or {}
    if mode is not None and mode != chosen:
        measured = ((edits.get("calibration") or {}).get("modes") or {}).get(mode) or {}
        layers = measured.get("layers")
    elif chosen == edits.get("emphasize_mode", "add"):
        layers = edits.get("emphasize_layers")
    else:
        layers = (edits.get("emphasize_fallback") or {}).get("layers")
    return tuple(int(i) for i in layers) if layers else None


def calibrated_mode(model_config: dict | None, *, word: str | None = None) -> str:
    """How emphasis acts for this model (on the word's attention, added or multiplied; or a guidance), as calibrated;
    "add" (the paper's) where no calibration chose one. Where the calibrated mode is "intensity" and ``word``'s action
    has no intensity word in the corpus ("punches"), the calibration's best other mode (its "emphasize_fallback")."""
    edits = (model_config or {}).get("edits") or {}
    mode = edits.get("emphasize_mode") or "add"
    if mode not in WEIGHT_RANGES:
        raise ValueError(f"the model's config names an unknown emphasis mode {mode!r}")
    if mode == "intensity" and word is not None:
        from engine.methods.intensity import scales

        if not scales(word):
            return (edits.get("emphasize_fallback") or {}).get("mode") or "mul"
    return mode


def default_mode(kind: str, model_config: dict | None = None, *, word: str | None = None) -> str:
    """The mode an edit kind uses when none is given: the calibrated one (for ``word``) for emphasis-like kinds, else
    "add"."""
    return calibrated_mode(model_config, word=word) if kind in CALIBRATED_KINDS else "add"


def with_defaults(options: EditOptions, model_config: dict | None = None) -> EditOptions:
    """``options`` with the mode and weight the user left out filled in: the kind's default mode for this model and
    word (:func:`default_mode`) and that mode's default weight."""
    mode = options.mode or default_mode(options.kind, model_config, word=options.word)
    weight = options.weight if options.weight is not None else DEFAULT_WEIGHTS[mode]
    return options if (mode, weight) == (options.mode, options.weight) else replace(options, mode=mode, weight=weight)


def default_window(kind: str, model_config: dict | None = None, mode: str | None = None, *,
                   word: str | None = None) -> Window:
    """The method's own step/layer window for an edit kind (what ``--step-window`` / ``--layers`` override).

    ``model_config`` (a loaded model's config) supplies calibrated emphasis layers (:func:`calibrated_layers`: the
    calibrated mode's, or another measured mode's own best), see :mod:`engine.evaluation.calibrate_edits`.
    """
    from engine.methods.windows import Window

    entry = REGISTRY.get(kind)
    if kind in CALIBRATED_KINDS:
        return Window(layers=calibrated_layers(model_config, mode, word=word))
    if entry is not None and entry.window is not None:
        return entry.window(model_config)
    return Window()


def window(options: EditOptions, default: Window) -> Window:
    """The step/layer window: the method's default unless the user set steps or layers."""
    from engine.methods.windows import Window

    start, end = options.step_window if options.step_window is not None else (default.start, default.end)
    layers = tuple(sorted(options.layers)) if options.layers else default.layers
    return Window(float(start), float(end), layers)


def acts_in_layers(kind: str, mode: str | None) -> bool:
    """Does an edit of ``kind`` in ``mode`` act in chosen layers (intensity emphasis guides through another prompt
    and has none: the Edit tab hides its Layers box, and given layers are refused)?"""
    entry = REGISTRY[kind]
    return entry.is_edit and not ("mode" in entry.inputs and mode in MODES and not MODES[mode].in_layers)


def build_config(options: EditOptions, *, frames: int, model_config: dict | None = None):
    """The typed method config for ``options`` (a motion of ``frames`` frames; ``model_config``: see default_window)."""
    entry = REGISTRY[options.kind]
    if not entry.is_edit:
        raise ValueError(f"{options.kind!r} is not an edit (counting is edits.count_generated / count_motion)")
    options = with_defaults(options, model_config)
    if options.layers and not acts_in_layers(options.kind, options.mode):
        raise ValueError("intensity mode guides the motion through another prompt and acts in no layer: "
                         "leave out the layers, or choose a mode that weights the attention (add, mul, guide)")
    return entry.build(options, frames=frames,
                       steps=window(options, default_window(options.kind, model_config, options.mode,
                                                            word=options.word)))


def run_edit(loaded, options: EditOptions, *, frames: int, sample, record: bool = False,
             on_step: Callable | None = None, config=None):
    """Run the edit -> ``edits.EditOutput`` (``on_step(StepState)`` after every step). ``config``: the edit's
    config when it was already built (:func:`build_config`, e.g. to check it before the run); None: built here."""
    options = with_defaults(options, loaded.config)
    cfg = config if config is not None else build_config(options, frames=frames, model_config=loaded.config)
    cfg.window.check_layers(loaded.model.num_layers)  # the user's layers, or the calibrated ones
    return REGISTRY[options.kind].run(loaded, options, cfg, frames=frames, sample=sample, record=record,
                                      on_step=on_step)
