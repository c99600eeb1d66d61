"""The Transfer tab's settings (MoMo): the leader and the follower (a prompt or a session motion), the layer and
step windows, the root, the colouring; the last transfer."""
from __future__ import annotations

from collections.abc import Callable

import param

from app.components.option_params import param_for
from app.generation import PromptReading, prompt_analysis
from app.tabs.transfer.colors import paint_clusters
from engine.methods.transfer_config import ROOT_CHOICES, TransferConfig, option_info

SOURCE_KINDS = {"prompt": "prompt", "imported motion": "motion"}  # label -> kind
ROOT_LABELS = {label: mode for mode, (label, _) in ROOT_CHOICES.items()}  # label -> mode, declared with the config
COLOR_BY = ("roles", "Q cluster", "K cluster")
_ENGINE = TransferConfig()  # the engine's defaults (``moattn transfer`` runs the same)


class SourceSettings(param.Parameterized):
    """A leader or a follower: a prompt to generate, or a session motion to DDIM-invert."""

    role = param.String(default="leader", doc="'leader' or 'follower'")
    kind = param.Selector(default="prompt", objects=SOURCE_KINDS, label="Source",
                          doc="generate from text or invert a motion")
    prompt = param.String(default="", label="Prompt", doc="what to generate; for a motion, an optional description")
    motion = param.String(default="", doc="name of a session motion (kind 'motion')")
    seconds = param.Number(default=4.0, step=0.5, label="Seconds",
                           doc="duration of a generated stream")
    reading = param.ClassSelector(class_=PromptReading, default=PromptReading(),
                                  doc="the prompt as the engine will read it (its notes, or why it refuses it)")

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, **params):
        super().__init__(**params)
        self.tokenizer = tokenizer or (lambda: None)
        self.param.watch(self.analyse, "prompt")
        self.analyse()

    def analyse(self, *_) -> None:
        self.reading = prompt_analysis(self.tokenizer(), self.prompt)

    @property
    def blocked(self) -> bool:
        """A prompt source whose prompt the engine refuses (an inverted motion's description is optional)."""
        return self.kind == "prompt" and self.reading.blocked


class TransferSettings(param.Parameterized):
    """The Transfer tab's settings (one per session, in ``StudioState.tab_settings["transfer"]``), its last transfer
    and what the analysis shows."""

    leader = param.ClassSelector(class_=SourceSettings)
    follower = param.ClassSelector(class_=SourceSettings)
    layers = param.Range(default=None, allow_None=True, doc="first and last 0-based layer that mix (None = all but "
                                                             "the first)")
    steps = param.Range(default=(_ENGINE.start, _ENGINE.end), bounds=option_info("start").bounds, step=0.05,
                        label="Steps that mix (fraction of the run)",
                        doc=f"{option_info('start').help}; {option_info('end').help}")
    root = param_for(TransferConfig, "root", objects=ROOT_LABELS)  # the modes, labelled as declared with them
    directions = param_for(TransferConfig, "directions")
    color_by = param.Selector(default="roles", objects=list(COLOR_BY), label="Skeleton colours",
                              doc="skeleton colours in the viewer")
    feet = param_for(TransferConfig, "feet")
    flights = param_for(TransferConfig, "flights")
    more_followers = param.String(default="", label="More followers (optional): one prompt per line, each gets its "
                                                    "own out",
                                  doc="more follower prompts, one per line: the leader drives each of them too (one "
                                      "out per follower, in the same batch)")
    result = param.Parameter(default=None, doc="TransferView of the last finished transfer")
    analysed = param.Integer(default=1, bounds=(1, None), doc="which follower (1-based) the analysis views and "
                                                              "the cluster colours show")

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, **params):
        super().__init__(**params)
        if self.leader is None:
            self.leader = SourceSettings(role="leader", prompt="a person walks forward", tokenizer=tokenizer)
        if self.follower is None:
            self.follower = SourceSettings(role="follower", prompt="a person jumps twice", seconds=3.0,
                                           tokenizer=tokenizer)

    @classmethod
    def for_session(cls, session) -> "TransferSettings":
        """The session's transfer settings; the skeletons take the chosen cluster colours as they change."""
        settings = cls(tokenizer=session.tokenizer)
        settings.param.watch(lambda *_: paint_clusters(session, settings), ["color_by", "result", "analysed"])
        return settings
