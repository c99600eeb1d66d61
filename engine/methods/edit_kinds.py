"""The one registry of MotionCLR edit kinds: name, label, help, the inputs it reads, its config and its run.

``moattn edit`` (its kind choices and help), the studio's Edit tab (its buttons, help text and which fields show)
and the benches read this table; :mod:`engine.methods.edit_options` builds and runs an edit through it. Adding an
edit kind means adding one ``EditKind`` here and its method in :mod:`engine.methods.edits`.

Counting is listed last as a kind the CLI and the tab offer; it is not an edit (no config, no run).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine.methods.emphasis_modes import MODES

#: the fields of ``EditOptions`` an edit kind can read besides the prompt, the step window and the layers
INPUTS = frozenset({"word", "weight", "mode", "frames", "edited", "copy_self", "swapped", "fraction", "style", "count",
                    "chunk_frames", "seed"})


def _whole(frames: int) -> tuple[int, int]:
    return (0, frames)


def _one_output(options) -> int:
    return 1


@dataclass(frozen=True)
class EditKind:
    """One edit: ``build(options, frames=, steps=) -> config`` and ``run(loaded, options, config, **common)``.

    ``inputs``: what the kind reads (the tab shows those fields, the CLI's help names them). ``window``: the
    method's default step/layer window as ``(model_config) -> Window`` (None: the whole run, every layer).
    ``calibrated``: its default layers come from the model's emphasis calibration. ``source``: the prompt box
    may also name a session motion (example, style), offered under ``source_label``.

    What a front end needs besides: ``default_frames(frames)``, the frame span it touches when none is given;
    ``spans``: it takes several frame spans (ground); ``positive_weight``: only the weight's size counts;
    ``describe(options, frames=)``, the edit in a few words; ``outputs(options)``, how many edited motions it makes;
    ``before_title``, what the motion it starts from is called beside them; ``sized``: the CLI and the tab report
    the word's action size before and after (:mod:`engine.analysis.action_size`).
    """

    name: str
    label: str
    help: str
    inputs: frozenset[str] = frozenset()
    build: Callable[..., Any] | None = None
    run: Callable[..., Any] | None = None
    window: Callable[[dict | None], Any] | None = None
    calibrated: bool = False
    source: bool = False
    source_label: str = "Content"
    default_frames: Callable[[int], tuple[int, int]] = _whole
    spans: bool = False
    positive_weight: bool = False
    describe: Callable[..., str] | None = None
    outputs: Callable[[Any], int] = _one_output
    before_title: str = "reference"
    sized: bool = False

    def __post_init__(self) -> None:
        unknown = set(self.inputs) - INPUTS
        if unknown:
            raise ValueError(f"edit kind {self.name!r} reads unknown inputs {sorted(unknown)}")

    @property
    def is_edit(self) -> bool:
        return self.run is not None

    def batch_slots(self, options) -> int:
        """Streams in the edit's batch: the motion it starts from, each output, and a style source if it reads one."""
        return 1 + self.outputs(options) + ("style" in self.inputs)


# ------------------------------------------------------------------------------------------- the edits
def _need(value, what: str, kind: str):
    if value is None or (isinstance(value, str) and not value.strip()):
        raise ValueError(f"the {kind} edit needs {what}")
    return value


def _spans(options, frames: int) -> tuple[tuple[int, int], ...]:
    """The options' frame spans, checked against a motion of ``frames`` frames (() = none given)."""
    from engine.methods.spans import check_spans

    return check_spans(options.spans, frames=frames)


def _span(options, frames: int) -> tuple[int, int] | None:
    """The one frame span of an edit that takes a single span (None = none given)."""
    spans = _spans(options, frames)
    if len(spans) > 1:
        raise ValueError(f"{options.kind} takes one frame span, got {len(spans)} (several spans are for ground)")
    return spans[0] if spans else None


def _emphasize_config(o, *, frames, steps):
    from engine.methods.motionclr import ReweightConfig

    return ReweightConfig(word=_need(o.word, "a word", o.kind), weight=float(o.weight), mode=o.mode,
                          frames=_span(o, frames), window=steps, occurrence=int(o.occurrence))


def _last_half(frames: int) -> tuple[int, int]:
    return (frames // 2, frames)


def _erase_config(o, *, frames, steps):
    from dataclasses import replace

    from engine.methods.motionclr import erase_config

    cfg = erase_config(_need(o.word, "a word", o.kind), frames=_span(o, frames) or _last_half(frames), window=steps)
    return replace(cfg, occurrence=int(o.occurrence))


def _ground_config(o, *, frames, steps):
    from engine.methods.motionclr import GroundingConfig

    return GroundingConfig.from_spans(_need(o.word, "a word", o.kind), _spans(o, frames) or ((0, frames),),
                                      frames=frames, weight=abs(float(o.weight)), window=steps)


def _replace_config(o, *, frames, steps):
    from dataclasses import replace

    from engine.methods.motionclr import ReplaceConfig

    return replace(ReplaceConfig(), window=steps, self_attention=bool(o.copy_self), swapped=o.swapped)


def _shift_config(o, *, frames, steps):
    from engine.methods.motionclr import ShiftConfig

    return ShiftConfig(fraction=float(o.fraction), window=steps)


def _example_config(o, *, frames, steps):
    from dataclasses import replace

    from engine.methods.motionclr import ExampleConfig

    return replace(ExampleConfig(seed=int(o.seed), chunk_frames=int(o.chunk_frames)), window=steps)


def _style_config(o, *, frames, steps):
    from dataclasses import replace

    from engine.methods.motionclr import StyleTransferConfig

    return replace(StyleTransferConfig(), window=steps)


# ------------------------------------------------------------------------------------------- in a few words
def _describe_weighted(what: str):
    def describe(o, *, frames: int) -> str:
        sign = "+" if o.mode != "mul" and o.weight >= 0 else ""
        w = f"×{o.weight:.2f}" if o.mode == "mul" else f"{sign}{o.weight:.2f}" + (MODES[o.mode].suffix if o.mode in MODES else "")
        if o.mode == "intensity" and isinstance(o.prompt, str) and o.word:  # the prompt it is guided towards
            from engine.methods.intensity import with_intensity

            try:
                toward = with_intensity(o.prompt, o.word, level="high" if o.weight >= 0 else "a little",
                                        occurrence=o.occurrence)
                w = f"{sign}{o.weight:.2f} towards '{toward}'"
            except ValueError:  # a word the corpus does not scale: the run says so
                pass
        spans = ", ".join(f"{a}–{min(b, frames)}" for a, b in o.spans)
        return f"{what} '{o.word}' {w}" + (f" frames {spans}" if spans else "")
    return describe


def _describe_replace(o, *, frames: int) -> str:
    from engine.methods.word_alignment import align_words
    from engine.text import split_words

    return "replace " + ", ".join(align_words(split_words(o.prompt), split_words(o.edited)).changes()) + (
        "" if o.swapped == "own" else " (the reference's whole map)")


def _describe_example(o, *, frames: int) -> str:
    from engine.methods.edit_options import option_spec

    default = option_spec("chunk_frames").default
    return "example-based" + ("" if o.chunk_frames == default else f" ({o.chunk_frames}-frame chunks)")


def _method_window(config_name: str) -> Callable[[dict | None], Any]:
    def window(model_config: dict | None):
        from engine.methods import motionclr

        return getattr(motionclr, config_name)().window
    return window


def _run(method: str, *, prompt_what: str = "a prompt", extra: Callable[[Any], dict] | None = None):
    """A run function calling ``engine.methods.edits.<method>(loaded, prompt, config, **common)``."""
    def run(loaded, options, config, **common):
        from engine.methods import edits

        kwargs = extra(options) if extra is not None else {}
        return getattr(edits, method)(loaded, _need(options.prompt, prompt_what, options.kind), config,
                                      **kwargs, **common)
    return run


def _run_replace(loaded, options, config, **common):
    from engine.methods import edits

    return edits.replace(loaded, _need(options.prompt, "the reference prompt", options.kind),
                         _need(options.edited, "an edited prompt", options.kind), config, **common)


def _run_style(loaded, options, config, **common):
    from engine.methods import edits

    return edits.style_transfer(loaded, style=_need(options.style, "a style source", options.kind),
                                content=_need(options.prompt, "a content prompt or motion", options.kind),
                                config=config, **common)


REGISTRY: dict[str, EditKind] = {k.name: k for k in (
    EditKind("emphasize", "emphasise",
             "Weight the picked word's cross-attention column: multiplied (×w: over 1 = more of that action) or "
             "added (+w, the paper's form, ±0.5); or guide (+w): away from the motion with the word erased; or "
             "intensity (±w): towards the prompt said with the action's intensity word (+1 = 'jumps high', -1 = "
             "'jumps a little'). It opens on the form and layers measured to grow the action on this model.",
             inputs=frozenset({"word", "weight", "mode", "frames"}), build=_emphasize_config,
             run=_run("reweight"), calibrated=True, sized=True, describe=_describe_weighted("emphasise")),
    EditKind("erase", "erase",
             "Multiply the picked word's cross-attention by 0.1 inside the frame window (default: last half).",
             inputs=frozenset({"word", "frames"}), build=_erase_config, run=_run("reweight"),
             default_frames=_last_half, sized=True, describe=lambda o, *, frames: f"erase '{o.word}'"),
    EditKind("replace", "replace",
             "Generate the prompt and the edited prompt together; the edited one takes the reference's "
             "cross-attention maps in the first steps (its swapped words keep their own, unless 'reference' is "
             "chosen), so its new action lands in the reference's time slots. The words are aligned as "
             "prompt-to-prompt aligns them: words may be added (they keep their own attention) or dropped.",
             inputs=frozenset({"edited", "copy_self", "swapped"}), build=_replace_config, run=_run_replace,
             window=_method_window("ReplaceConfig"), describe=_describe_replace),
    EditKind("shift", "shift", "Roll the reference's Q, K, V in time: the first part of the motion moves to the end.",
             inputs=frozenset({"fraction"}), build=_shift_config, run=_run("shift"),
             window=_method_window("ShiftConfig"), describe=lambda o, *, frames: f"shift {o.fraction:.0%}"),
    EditKind("example", "example-based",
             "Several new motions whose self-attention queries are the example's, shuffled in chunks (default 1 s).",
             inputs=frozenset({"count", "chunk_frames", "seed"}), build=_example_config,
             run=_run("example_based", prompt_what="an example prompt or motion",
                      extra=lambda o: {"count": int(o.count)}),
             window=_method_window("ExampleConfig"), source=True, source_label="Example",
             describe=_describe_example, outputs=lambda o: int(o.count), before_title="example"),
    EditKind("style", "style transfer", "Q of the output from the style motion, K and V from the content motion.",
             inputs=frozenset({"style"}), build=_style_config, run=_run_style,
             window=_method_window("StyleTransferConfig"), source=True,
             describe=lambda o, *, frames: "style transfer", before_title="content"),
    EditKind("ground", "ground",
             "Emphasise the picked word inside the frame span(s) and de-emphasise it outside (when it happens): "
             "several spans ground it several times, e.g. four jumps at chosen times.",
             inputs=frozenset({"word", "weight", "frames"}), build=_ground_config, run=_run("ground"),
             spans=True, positive_weight=True, describe=_describe_weighted("ground")),
    # (grounding acts in every layer, as in the paper: on the shipped model the emphasis-calibrated layers put the
    # jumps in 0.55 of four chosen spans, below the 0.68 of no grounding; every layer 0.80; moattn bench --edits)
    EditKind("count", "count", "Count repetitions from the self-attention map (the project's lag profile, or "
             "MotionCLR's row peaks as published), beside the root-height baseline."),
)}

#: every kind ``moattn edit`` takes; all but "count" are edits
KINDS: tuple[str, ...] = tuple(REGISTRY)
EDIT_KINDS: tuple[str, ...] = tuple(k for k, v in REGISTRY.items() if v.is_edit)


def kind(name: str) -> EditKind:
    try:
        return REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown edit kind {name!r}; one of {', '.join(KINDS)}") from None


def kinds_reading(field: str) -> tuple[str, ...]:
    """The kinds whose settings include ``field`` (the tab shows it for those)."""
    if field not in INPUTS:
        raise ValueError(f"{field!r} is not an edit input")
    return tuple(k for k, v in REGISTRY.items() if field in v.inputs)
