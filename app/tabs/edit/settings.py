"""The Edit tab's settings (MotionCLR): which edit, the picked word, weights and windows, sources; the last edit."""
from __future__ import annotations

from dataclasses import dataclass

import param

from engine.methods.edit_kinds import REGISTRY, EditKind
from engine.methods.edit_options import option_spec
from engine.methods.motionclr import WEIGHT_RANGES, weight_range_text

_CHUNK = option_spec("chunk_frames")  # declared once, with the edit options (the CLI's --chunk-frames reads it too)
_COUNT = option_spec("count")  # the number of example-based outputs: one default for the tab and `moattn edit --count`

#: label shown in the tab -> ``moattn edit`` kind, and each kind's help: both from the engine's registry
KIND_LABELS = {k.label: name for name, k in REGISTRY.items()}
KIND_HELP = {name: k.help for name, k in REGISTRY.items()}
PROMPT_SOURCE = "(the prompt)"


class EditSettings(param.Parameterized):
    """The Edit tab's settings (one per session, in ``StudioState.tab_settings["edit"]``) and its last edit."""

    kind = param.Selector(default="emphasise", objects=list(KIND_LABELS), label="Edit", doc="which edit")
    word = param.String(default="", doc="the picked word ('' = none picked yet)")
    occurrence = param.Integer(default=0, bounds=(0, None), doc="which appearance of the word in the prompt")
    mode = param.Selector(default="add", objects={"add +w": "add", "multiply ×w": "mul"}, label="Mode",
                          doc="add the weight, or multiply by it")
    weight = param.Number(default=0.3, bounds=(min(lo for lo, _ in WEIGHT_RANGES.values()),
                                               max(hi for _, hi in WEIGHT_RANGES.values())), step=0.05,
                          label="Weight", doc=f"{weight_range_text()} (mul > 1 emphasises)")
    frames = param.Range(default=None, allow_None=True, doc="frame window [start, end) (None = the kind's default)")
    spans = param.List(default=[], item_type=tuple,
                       doc="ground: the frame spans [(start, end), ...] the word is grounded to, dragged on its "
                           "attention curve or typed ([] = the whole motion)")
    step_window = param.Range(default=None, allow_None=True, doc="fractions of the sampling run (None = the method's)")
    layers = param.List(default=[], item_type=int, doc="layers the edit acts in ([] = all)")
    fraction = param.Number(default=0.5, bounds=(0.05, 0.95), step=0.05, label="Shift: part moved to the end",
                            doc="shift: the part moved to the end")
    count = param.Integer(default=_COUNT.default, bounds=_COUNT.bounds, label=_COUNT.label, doc=_COUNT.help)
    chunk_frames = param.Integer(default=_CHUNK.default, bounds=_CHUNK.bounds, label=_CHUNK.label, doc=_CHUNK.help)
    edited = param.String(default="", label="Edited prompt (the action swapped; words may be added or dropped)",
                          doc="replace: the edited prompt, its words aligned to the prompt's as prompt-to-prompt "
                              "aligns them")
    source = param.String(default=PROMPT_SOURCE, doc="example / content source: the prompt or a session motion")
    style_source = param.String(default=PROMPT_SOURCE, doc="style source: a prompt or a session motion")
    style_prompt = param.String(default="a person walks", label="Style prompt", doc="style source when it is a prompt")
    last_edit = param.Parameter(default=None, doc="EditSummary of the last finished edit")

    @classmethod
    def for_session(cls, session) -> "EditSettings":
        return cls()

    @property
    def engine_kind(self) -> str:
        return KIND_LABELS[self.kind]

    @property
    def entry(self) -> EditKind:
        """The chosen kind's entry in the engine's registry: what it reads, how it is described, what it makes."""
        return REGISTRY[self.engine_kind]


@dataclass
class EditSummary:
    kind: str
    description: str
    before: str  # item names
    after: list[str]
    seconds_taken: float
    max_difference: float  # max joint distance (m) between before and the first after, frame-wise
