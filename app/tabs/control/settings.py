"""The Control tab's settings (PriorMDM control, DiffusionBlending): the prompt and length, the drawn paths, the
method and the blend weights; which methods this server offers."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import param

from app.generation import PromptReading, prompt_analysis
from app.tabs.control.models import control_models, control_setup
from app.tabs.control.paths import DEFAULT_ROOT, LABELS, WRIST_DEPTH, WRISTS, thin
from engine.paths import CONTROL_DIR
from engine.units import MAX_SECONDS, MIN_SECONDS

METHOD_LABELS = {"blending (fine-tuned models)": "blending", "inpainting (base model)": "inpainting"}


class ControlSettings(param.Parameterized):
    """The Control tab's settings (one per session, on ``StudioState.control``) and its last result."""

    prompt = param.String(default="a person walks", label="Prompt",
                          doc="what the person does while following the paths")
    seconds = param.Number(default=6.0, softbounds=(MIN_SECONDS, MAX_SECONDS), step=0.5,
                           label="Seconds", doc=f"duration ({MIN_SECONDS:g} to {MAX_SECONDS:g} s)")
    use_root = param.Boolean(default=True, label="follow the root path", doc="follow the root path drawn top-down")
    root_points = param.List(default=list(DEFAULT_ROOT), doc="(x, z) metres on the floor; the motion starts at "
                                                            "the first point, facing the direction of travel")
    wrist = param.Selector(default="none", objects={"no wrist" if w == "none" else LABELS[w]: w for w in WRISTS},
                           label="Wrist", doc="which wrist follows the front-view path")
    wrist_points = param.List(default=[], doc="(x, y) metres in the body frame: x the person's left, y height")
    wrist_depth = param.Number(default=WRIST_DEPTH, bounds=(-0.9, 0.9), softbounds=(0.0, 0.8), step=0.05,
                               label="Wrist plane, forward of the body (m)", doc="z (forward) of the wrist path")
    weights = param.Dict(default={"root": 1.0, "left_wrist": 1.0, "right_wrist": 1.0},
                         doc="raw blend weight per control (scaled to sum 1 over the active ones)")
    method = param.Selector(default="inpainting", objects=METHOD_LABELS, label="Method",
                            doc="blending: fine-tuned control models (DiffusionBlending); inpainting: the base model")
    controls_dir = param.Parameter(default=CONTROL_DIR, doc="folder of the fine-tuned control models")
    available = param.List(default=[], doc="controls with a fine-tuned model in controls_dir")
    problem = param.String(default="", doc="why blending is not offered ('' when it is)")
    base_note = param.String(default="", doc="one line when control runs on the control models' own base model "
                                             "(not the loaded one); '' otherwise")
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
        self.discover()

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

    def discover(self) -> None:
        """Which methods this server offers (blending only where fine-tuned models exist) and on which base model."""
        run, problem = control_setup(self.controls_dir, base=self._base())
        self.run_base = run
        models = control_models(self.controls_dir)[0] if run is None else run.models  # no base: all found
        self.param.update(available=sorted(models), problem=problem, base_note="" if run is None else run.note,
                          method=self.method if models else "inpainting")
        self._analyse()

    @property
    def active(self) -> list[str]:
        """The controls in use, in the order root, wrist."""
        return (["root"] if self.use_root else []) + ([self.wrist] if self.wrist != "none" else [])

    def normalized_weights(self) -> dict[str, float]:
        """Active control -> its share of the blend (sums to 1; equal when all are 0)."""
        names = self.active
        raw = np.array([max(0.0, float(self.weights.get(n, 1.0))) for n in names], dtype=np.float64)
        if not names:
            return {}
        raw = raw if raw.sum() > 0 else np.ones(len(names))
        return dict(zip(names, (raw / raw.sum()).tolist()))

    def set_stroke(self, kind: str, xs, ys) -> None:
        """A stroke drawn on a canvas (root: x, z; wrist: x, y) becomes that path's points."""
        pts = thin(list(zip(xs, ys)))
        if kind == "root":
            self.root_points = pts
        else:
            self.wrist_points = pts
