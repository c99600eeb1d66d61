"""The Edit tab's settings (MotionCLR): which edit, the picked word, weights and windows, sources; the last edit.

The edit's options are declared once, on :class:`engine.methods.edit_options.EditOptions` (``moattn edit``'s flags
come from the same fields): their defaults, bounds, labels and help reach the widgets through ``param_for``."""
from __future__ import annotations

from dataclasses import dataclass

import param

from app.components.option_params import param_for
from engine.methods.edit_kinds import INPUTS, REGISTRY, EditKind
from engine.methods.edit_options import DEFAULT_WEIGHTS, MODE_LABELS, EditOptions, default_mode

#: label shown in the tab -> ``moattn edit`` kind, and each kind's help: both from the engine's registry
KIND_LABELS = {k.label: name for name, k in REGISTRY.items()}
KIND_HELP = {name: k.help for name, k in REGISTRY.items()}
PROMPT_SOURCE = "(the prompt)"
#: the inputs this tab shows with widgets of its own: a word clicked in the prompt, a weight whose range follows the
#: mode, frames dragged on a curve, an edited prompt with its alignment, a style source among the motions, the
#: Generate box's seed. Every other input a kind reads (``INPUTS``) is a plain value: its parameter, widget and help
#: come from its declaration on ``EditOptions``, so a new kind's new option needs nothing here.
OWN_WIDGETS = frozenset({"word", "weight", "mode", "frames", "edited", "style", "seed"})
PLAIN_INPUTS: tuple[str, ...] = tuple(f for f in EditOptions.__dataclass_fields__ if f in INPUTS - OWN_WIDGETS)


class EditSettings(param.Parameterized):
    """The Edit tab's settings (one per session, in ``StudioState.tab_settings["edit"]``) and its last edit."""

    kind = param.Selector(default="emphasise", objects=list(KIND_LABELS), label="Edit", doc="which edit")
    # '' = no word picked yet (the engine's None: the tab's text never holds None)
    word = param_for(EditOptions, "word", default="")
    occurrence = param_for(EditOptions, "occurrence")
    # the modes, labelled; a session opens on the mode calibrated for its model (``for_session``)
    mode = param_for(EditOptions, "mode", default="add", objects={label: m for m, label in MODE_LABELS.items()})
    weight = param_for(EditOptions, "weight", default=DEFAULT_WEIGHTS["add"])
    frames = param.Range(default=None, allow_None=True, doc="frame window [start, end) (None = the kind's default)")
    spans = param.List(default=[], item_type=tuple,
                       doc="ground: the frame spans [(start, end), ...] the word is grounded to, dragged on its "
                           "attention curve or typed ([] = the whole motion)")
    step_window = param_for(EditOptions, "step_window")  # None: the method's window
    layers = param_for(EditOptions, "layers", default=[])  # [] = the kind's default (the engine's None)
    edited = param_for(EditOptions, "edited", default="")  # '' = none typed yet
    source = param.String(default=PROMPT_SOURCE, doc="example / content source: the prompt or a session motion")
    style_source = param.String(default=PROMPT_SOURCE, doc="style source: a prompt or a session motion")
    style_prompt = param.String(default="a person walks", label="Style prompt", doc="style source when it is a prompt")
    last_edit = param.Parameter(default=None, doc="EditSummary of the last finished edit")

    @classmethod
    def for_session(cls, session) -> "EditSettings":
        """Settings opening on the emphasis mode calibrated for the session's model, at that mode's weight."""
        mode = default_mode("emphasize", session.model.config if session.has_model else None)
        return cls(mode=mode, weight=DEFAULT_WEIGHTS[mode])

    @property
    def engine_kind(self) -> str:
        return KIND_LABELS[self.kind]

    @property
    def entry(self) -> EditKind:
        """The chosen kind's entry in the engine's registry: what it reads, how it is described, what it makes."""
        return REGISTRY[self.engine_kind]

    def plain_values(self) -> dict:
        """The plain inputs' values, by their ``EditOptions`` names."""
        return {name: getattr(self, name) for name in PLAIN_INPUTS}


for _name in PLAIN_INPUTS:  # e.g. fraction, count, chunk_frames: each from its declaration
    EditSettings.param.add_parameter(_name, param_for(EditOptions, _name))


@dataclass
class EditSummary:
    kind: str
    description: str
    before: str  # item names
    after: list[str]
    seconds_taken: float
    max_difference: float  # max joint distance (m) between before and the first after, frame-wise
    size: str = ""  # emphasis / erasure: the word's action size before and after (engine.analysis.action_size)
