"""The Control tab's settings (PriorMDM control, DiffusionBlending): the prompt and length, the drawn paths (the root
and both wrists, any of them at once), the method and the blend weights; which methods this server offers and which
one the control bench has ahead.

The method and the weights are the engine's options (:class:`engine.methods.control_options.ControlOptions`): the
blend-weight rule is the engine's (:func:`~engine.methods.control_options.blend_shares`); this class neither clamps
nor re-normalises, it shows the engine's message.
"""
from __future__ import annotations

from collections.abc import Callable

import param

from app.components.option_params import param_for
from app.generation import PromptReading, prompt_analysis
from app.tabs.control.models import control_models, control_setup
from app.tabs.control.paths import DEFAULT_ROOT, LABELS, WRIST_DEPTH, WRISTS, thin
from engine.methods.control_options import BenchVerdict, ControlOptions, bench_verdict, blend_shares, option_info
from engine.paths import CONTROL_DIR

METHOD_LABELS = {"blending (fine-tuned models)": "blending", "inpainting (base model)": "inpainting"}


class ControlSettings(param.Parameterized):
    """The Control tab's settings (one per session, in ``StudioState.tab_settings["control"]``) and its last result."""

    prompt = param.String(default="a person walks", label="Prompt",
                          doc="what the person does while following the paths")
    # no hard bounds: a length out of range reaches the engine, whose frames_for refuses it with its own message
    seconds = param_for(ControlOptions, "seconds", bounds=None)
    use_root = param.Boolean(default=True, label="follow the root path", doc="follow the root path drawn top-down")
    root_points = param.List(default=list(DEFAULT_ROOT), doc="(x, z) metres on the floor; the motion starts at "
                                                            "the first point, facing the direction of travel")
    use_left_wrist = param.Boolean(default=False, label="follow the left wrist path",
                                   doc="the left wrist follows its path drawn in front view")
    use_right_wrist = param.Boolean(default=False, label="follow the right wrist path",
                                    doc="the right wrist follows its path drawn in front view")
    left_wrist_points = param.List(default=[], doc="(x, y) metres in the body frame: x the person's left, y height")
    right_wrist_points = param.List(default=[], doc="(x, y) metres in the body frame: x the person's left, y height")
    drawing = param.Selector(default="left_wrist", objects={LABELS[w]: w for w in WRISTS}, label="Draw",
                             doc="which wrist's path the front view draws and edits")
    wrist_depth = param.Number(default=WRIST_DEPTH, bounds=(-0.9, 0.9), softbounds=(0.0, 0.8), step=0.05,
                               label="Wrist plane, forward of the body (m)", doc="z (forward) of the wrist paths")
    weights = param.Dict(default=ControlOptions().weights(),
                         doc="raw blend weight per control; the engine scales those in use to sum 1 and refuses "
                             "negative or all-zero weights")
    # the methods, labelled; "inpainting" until :meth:`discover` opens on the one the control bench has ahead
    method = param_for(ControlOptions, "method", objects=METHOD_LABELS, default="inpainting")
    planted_feet = param_for(ControlOptions, "planted_feet")
    controls_dir = param.Parameter(default=CONTROL_DIR, doc="folder of the fine-tuned control models")
    available = param.List(default=[], doc="controls with a fine-tuned model in controls_dir")
    problem = param.String(default="", doc="why blending is not offered ('' when it is)")
    base_note = param.String(default="", doc="one line when control runs on the control models' own base model "
                                             "(not the loaded one); '' otherwise")
    verdict = param.ClassSelector(class_=BenchVerdict, default=None, allow_None=True,
                                  doc="which method the control bench has ahead (read from controls_dir/bench.json)")
    reading = param.ClassSelector(class_=PromptReading, default=PromptReading(),
                                  doc="the prompt as the engine control runs on will read it (notes, or a refusal)")
    result = param.Parameter(default=None, doc="ControlSummary of the last controlled generation")

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, base: Callable[[], object] | None = None,
                 **params):
        super().__init__(**params)
        self.tokenizer = tokenizer or (lambda: None)
        self._base = base or (lambda: None)  # the loaded base model (None: none loaded)
        self.run_base = None  # ControlBase: the base control runs on and its control models (None: no model loaded)
        self.param.watch(self._analyse, "prompt")
        self.discover(opening=True)

    @classmethod
    def for_session(cls, session, *, controls_dir=None) -> "ControlSettings":
        extra = {} if controls_dir is None else {"controls_dir": controls_dir}
        return cls(tokenizer=session.tokenizer, base=lambda: session.model if session.has_model else None, **extra)

    def prompt_tokenizer(self):
        """The tokenizer of the model control runs on (the control models' own base when it is not the loaded one)."""
        if self.run_base is not None and self.run_base.on_prior:
            return self.run_base.loaded.tokenizer
        return self.tokenizer()

    def _analyse(self, *_) -> None:
        self.reading = prompt_analysis(self.prompt_tokenizer(), self.prompt)

    def discover(self, *, opening: bool = False) -> None:
        """Which methods this server offers (blending only where fine-tuned models exist), on which base model, and
        which one the control bench has ahead. ``opening``: also choose the method the tab opens on, blending only
        when the bench has it ahead of inpainting (:meth:`BenchVerdict.opening_method`)."""
        run, problem = control_setup(self.controls_dir, base=self._base())
        self.run_base = run
        models = control_models(self.controls_dir)[0] if run is None else run.models  # no base: all found
        verdict = bench_verdict(self.controls_dir)
        method = (verdict.opening_method(blending_offered=bool(models)) if opening
                  else self.method if models else "inpainting")
        self.param.update(available=sorted(models), problem=problem, base_note="" if run is None else run.note,
                          verdict=verdict, method=method)
        self._analyse()

    @property
    def active(self) -> list[str]:
        """The controls in use, in the order root, left wrist, right wrist."""
        on = {"root": self.use_root, "left_wrist": self.use_left_wrist, "right_wrist": self.use_right_wrist}
        return [n for n, used in on.items() if used]

    def wrist_points(self, name: str) -> list:
        return getattr(self, f"{name}_points")

    def typed_weights(self) -> dict[str, float]:
        """Active control -> its blend weight as typed (the engine's rule judges it; nothing is clamped here)."""
        return {n: self.weights.get(n, option_info(ControlOptions, ControlOptions.weight_field(n)).default)
                for n in self.active}

    def shares(self) -> dict[str, float]:
        """Active control -> its share of the blend, by the engine's rule (a ValueError with the engine's one-line
        message for negative or all-zero weights; nothing is clamped here)."""
        names = self.active
        return dict(zip(names, blend_shares(self.typed_weights(), names))) if names else {}

    def set_stroke(self, kind: str, xs, ys) -> None:
        """A stroke drawn on a canvas (root: x, z; a wrist: x, y) becomes that path's points."""
        setattr(self, f"{kind}_points", thin(list(zip(xs, ys))))
