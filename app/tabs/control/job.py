"""The Control tab's model (PriorMDM control + DiffusionBlending): drawn paths, checks with user-facing messages,
the job, the measured error and the target paths shown in 3-D.

Nothing here touches Panel widgets. The engine does the work (``engine.methods.paths`` turns paths into control
features, ``engine.methods.control.controlled`` samples; the same functions ``moattn control`` calls); this
module adds what only the studio needs: paths as drawn on the canvases (a freehand stroke thinned to points),
which methods this server can offer (the fine-tuned control models found, loaded once per server), blend
weights per active control, and the result placed in the path's world with its error measured.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import param

from app.generation import Cancelled, checked_frames, prompt_analysis, sampling_slot
from engine.methods.control import same_base
from engine.paths import CONTROL_DIR
from engine.units import MAX_SECONDS, MIN_SECONDS

LABELS = {"root": "root path", "left_wrist": "left wrist", "right_wrist": "right wrist"}
WRISTS = ("none", "left_wrist", "right_wrist")
METHODS = ("inpainting", "blending")
WRIST_DEPTH = 0.35  # m in front of the body: the front-view canvas draws on this plane
MIN_SPACING = 0.15  # m between kept points of a freehand stroke
MAX_POINTS = 80
ROOT_COLOR, WRIST_COLOR = "#d62728", "#9467bd"
DEFAULT_ROOT = ((0.0, 0.0), (0.8, 1.5), (0.0, 3.0), (-0.8, 4.5))  # an S on the floor, 4.5 m ahead

_models_lock = threading.Lock()
_models: dict[Path, tuple[float, dict, str]] = {}  # folder -> (mtime, name -> LoadedModel, problem)


def control_models(folder: str | Path, *, base=None) -> tuple[dict, str]:
    """The fine-tuned control models in ``folder`` (loaded once per server) that can be blended with ``base`` (the
    loaded base model: same vocabulary and feature statistics), and, if none, why."""
    models, problem = _load(folder)
    if base is None or not models:
        return models, problem
    fits = {n: m for n, m in models.items() if same_base(base, m)}
    if len(fits) < len(models):
        odd = ", ".join(LABELS[n] for n in models if n not in fits)
        problem = (f"the control models for {odd} in {Path(folder)} were fine-tuned from another base model "
                   "(other vocabulary or feature statistics) and cannot be blended with this one")
    return fits, problem


def _load(folder: str | Path) -> tuple[dict, str]:
    from app.model_cache import runtime
    from engine.methods.control import load_controls

    key = Path(folder).expanduser().resolve()
    mtime = key.stat().st_mtime if key.exists() else -1.0
    with _models_lock:
        cached = _models.get(key)
        if cached is not None and cached[0] == mtime:
            return cached[1], cached[2]
        problem = ""
        try:
            models = load_controls(key, runtime=runtime()) if key.exists() else {}
        except Exception as exc:  # a broken folder: say so, offer inpainting
            models, problem = {}, f"the control models in {key} could not be loaded ({exc})"
        if not models and not problem:
            problem = (f"no fine-tuned control models in {key} (train one with `moattn train --control root "
                       "--init-from assets/model --out assets/control/root`)")
        _models[key] = (mtime, models, problem)
        return models, problem


def thin(points, *, spacing: float = MIN_SPACING, limit: int = MAX_POINTS) -> list[tuple[float, ...]]:
    """A drawn stroke as path points: consecutive points at least ``spacing`` apart, at most ``limit`` of them.

    Non-finite points are kept (the engine names them); the last point is always kept.
    """
    p = [tuple(float(v) for v in q) for q in points]
    if len(p) <= 2:
        return p
    out = [p[0]]
    for q in p[1:-1]:
        if not all(np.isfinite(q)) or not all(np.isfinite(out[-1])) or \
                np.linalg.norm(np.subtract(q, out[-1])) >= spacing:
            out.append(q)
    if np.linalg.norm(np.subtract(p[-1], out[-1])) > 1e-9 or len(out) == 1:
        out.append(p[-1])
    if len(out) > limit:
        keep = np.unique(np.linspace(0, len(out) - 1, limit).round().astype(int))
        out = [out[k] for k in keep]
    return out


def path_length(points) -> float:
    """Metres along a path (0 for fewer than 2 points)."""
    p = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if p.ndim == 2 and len(p) > 1 else 0.0


class ControlSettings(param.Parameterized):
    """The Control tab's state (one per session, owned by the tab)."""

    prompt = param.String(default="a person walks", doc="what the person does while following the paths")
    seconds = param.Number(default=6.0, doc=f"duration ({MIN_SECONDS:g} to {MAX_SECONDS:g} s)")
    use_root = param.Boolean(default=True, doc="follow the root path drawn top-down")
    root_points = param.List(default=list(DEFAULT_ROOT), doc="(x, z) metres on the floor; the motion starts at "
                                                            "the first point, facing the direction of travel")
    wrist = param.Selector(default="none", objects=list(WRISTS), doc="which wrist follows the front-view path")
    wrist_points = param.List(default=[], doc="(x, y) metres in the body frame: x the person's left, y height")
    wrist_depth = param.Number(default=WRIST_DEPTH, bounds=(-0.9, 0.9), doc="z (forward) of the wrist path")
    weights = param.Dict(default={"root": 1.0, "left_wrist": 1.0, "right_wrist": 1.0},
                         doc="raw blend weight per control (scaled to sum 1 over the active ones)")
    method = param.Selector(default="inpainting", objects=list(METHODS),
                            doc="blending: fine-tuned control models (DiffusionBlending); inpainting: the base model")
    controls_dir = param.Parameter(default=CONTROL_DIR, doc="folder of the fine-tuned control models")
    available = param.List(default=[], doc="controls with a fine-tuned model in controls_dir")
    problem = param.String(default="", doc="why blending is not offered ('' when it is)")
    unknown_words = param.List(default=[], doc="words of the prompt the model does not know")
    result = param.Parameter(default=None, doc="ControlSummary of the last controlled generation")

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, base: Callable[[], object] | None = None,
                 **params):
        super().__init__(**params)
        self.tokenizer = tokenizer or (lambda: None)
        self._base = base or (lambda: None)  # the loaded base model (None: none loaded)
        self.param.watch(self._analyse, "prompt")
        self._analyse()
        self.discover()

    def _analyse(self, *_) -> None:
        self.unknown_words = prompt_analysis(self.tokenizer(), self.prompt)[1]

    def discover(self) -> None:
        """Which methods this server offers: blending only where fine-tuned models exist."""
        models, problem = control_models(self.controls_dir, base=self._base())
        self.param.update(available=sorted(models), problem=problem,
                          method=self.method if models else "inpainting")

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


@dataclass
class ControlJob:
    prompt: str
    controls: list  # engine Controls
    frame: dict | None  # the root path's world frame (None: no root control)
    wrist_target: np.ndarray | None  # (T, 3) body-frame values of the controlled wrist
    models: dict | None  # None: plain inpainting
    weights: list[float]
    sample: object
    seconds: float
    method: str
    description: str


@dataclass
class ControlSummary:
    name: str  # the session motion
    method: str
    controls: list[str]
    weights: dict[str, float]
    root_error: dict | None  # path_error: mean_m, max_m, off_0_5m
    wrist_error: dict | None  # mean_m, max_m of the wrist in the body frame
    seconds_taken: float
    guides: list[tuple[str, np.ndarray]] = field(default_factory=list)  # colour, (N, 3) world points
    joints: np.ndarray | None = None  # (T, 22, 3) in the path's world


def prepare(state, settings: ControlSettings) -> ControlJob:
    """Every check before any work starts; raises ValueError with a message for the user."""
    from engine.generate import SampleConfig
    from engine.methods.control import Control
    from engine.methods.paths import RootPath, WristPath, root_controls

    loaded = state.model
    if not settings.prompt.strip():
        raise ValueError("type what the person does (e.g. 'a person walks')")
    loaded.tokenizer.encode(settings.prompt)
    frames = checked_frames(loaded, settings.seconds)
    seconds = frames / 20
    names = settings.active
    if not names:
        raise ValueError("turn on at least one control: the root path or a wrist")
    controls, frame, wrist_target = [], None, None
    if "root" in names:
        if len(settings.root_points) < 2:
            raise ValueError("root path: draw it on the top-down canvas (at least 2 points)")
        values, frame = root_controls(RootPath(points=tuple(map(tuple, settings.root_points))), seconds)
        controls.append(Control("root", values))
    if settings.wrist != "none":
        label = LABELS[settings.wrist]
        if len(settings.wrist_points) < 2:
            raise ValueError(f"{label} path: draw it on the front-view canvas (at least 2 points)")
        pts = tuple((float(x), float(y), float(settings.wrist_depth)) for x, y in settings.wrist_points)
        try:
            wrist_target = WristPath(points=pts).controls(seconds)
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
        controls.append(Control(settings.wrist, wrist_target))
    models = None
    if settings.method == "blending":
        found, problem = control_models(settings.controls_dir, base=loaded)
        missing = [n for n in names if n not in found]
        if missing:
            raise ValueError(f"no fine-tuned model for the {', '.join(LABELS[n] for n in missing)}: "
                             f"{problem or 'choose inpainting'}")
        models = {n: found[n] for n in names}
    shares = settings.normalized_weights()
    sample = SampleConfig(steps=int(state.steps), guidance=float(state.guidance), seed=int(state.seed))
    what = " + ".join(LABELS[n] for n in names)
    return ControlJob(prompt=settings.prompt.strip(), controls=controls, frame=frame, wrist_target=wrist_target,
                      models=models, weights=[shares[n] for n in names], sample=sample, seconds=seconds,
                      method=settings.method, description=f"{what} by {settings.method}")


def run_job(loaded, job: ControlJob, *, on_step: Callable[[int, int], None], cancel: threading.Event,
            on_wait: Callable[[], None] | None = None) -> ControlSummary:
    """Sample on the worker (holding the sampling slot), place the motion on the path, measure the errors."""
    import time

    from engine.methods.control import controlled

    def step(state) -> None:
        if cancel.is_set():
            raise Cancelled()
        on_step(state.step + 1, state.num_steps)

    t0 = time.perf_counter()
    with sampling_slot(cancel, on_wait):
        gen = controlled(loaded, job.prompt, job.controls, seconds=job.seconds, models=job.models,
                         weights=job.weights, sample=job.sample, on_step=step)
    joints = np.asarray(gen.joints[0], dtype=np.float32)
    if not np.isfinite(joints).all():
        raise ValueError("the model produced non-finite joints")
    summary = measure(job, joints, features=np.asarray(gen.features[0]))
    summary.seconds_taken = time.perf_counter() - t0
    summary.joints = joints if job.frame is None else _world(joints, job.frame)
    return summary


def _world(joints: np.ndarray, frame: dict) -> np.ndarray:
    from engine.methods.paths import to_world

    return np.asarray(to_world(joints, frame), dtype=np.float32)


def measure(job: ControlJob, joints: np.ndarray, *, features: np.ndarray) -> ControlSummary:
    """Root error on the floor (path_error, world frame), wrist error in the body frame, and the 3-D guides."""
    from engine.methods.control import control_dims
    from engine.methods.paths import path_error
    from engine.representation import features_to_joints, joints_to_features
    from engine.skeleton import JOINT_INDEX

    names = [c.name for c in job.controls]
    world = joints if job.frame is None else _world(joints, job.frame)
    guides, root_error, wrist_error = [], None, None
    if job.frame is not None:
        root_error = path_error(world, job.frame["target"])
        xz = np.asarray(job.frame["target"], dtype=np.float64)
        guides.append((ROOT_COLOR, np.stack([xz[:, 0], np.full(len(xz), 0.012), xz[:, 1]], -1)))
    if job.wrist_target is not None:
        name = names[-1]
        dims = control_dims(name)
        measured = joints_to_features(joints)[:, dims]
        n = min(len(measured), len(job.wrist_target))
        d = np.linalg.norm(measured[:n] - job.wrist_target[:n], axis=1)
        wrist_error = {"mean_m": float(d.mean()), "max_m": float(d.max())}
        # the target in the world: the generated body carrying the target wrist instead of its own
        feats = np.array(features[: len(job.wrist_target)], dtype=np.float64)
        feats[:, dims] = job.wrist_target[: len(feats)]
        target = features_to_joints(feats)[:, JOINT_INDEX[name]]
        if job.frame is not None:
            target = _world(target[:, None], job.frame)[:, 0]
        guides.append((WRIST_COLOR, np.asarray(target, dtype=np.float64)))
    return ControlSummary(name="", method=job.method, controls=names, weights=dict(zip(names, job.weights)),
                          root_error=root_error, wrist_error=wrist_error, seconds_taken=0.0, guides=guides)


def start_control(state, settings: ControlSettings) -> bool:
    """Check, then generate on the session's worker with progress and cancel; False (and a notification) if refused."""
    return state.launch(
        prepare=lambda: prepare(state, settings),
        run=lambda loaded, job, worker: run_job(loaded, job, on_step=worker.step, cancel=worker.cancel,
                                                on_wait=worker.waiting),
        finish=lambda job, summary: finish(state, settings, job, summary), refused="cannot generate with control",
        what="controlled generation", total=lambda job: job.sample.steps,
        status=lambda job: f"{job.description}: step 0 / {job.sample.steps}", verb=lambda job: job.description)


def finish(state, settings: ControlSettings, job: ControlJob, summary: ControlSummary) -> None:
    """The motion (in the path's world) becomes a session motion with its target paths as guides; shown."""
    from app.session.items import MotionItem

    joints = summary.joints
    title = f"control · {job.prompt} · {' + '.join(LABELS[n] for n in summary.controls)} · {job.method}"
    item = MotionItem(name=state.unique_name(title), joints=joints, source="generated", prompt=job.prompt,
                      info={"control": summary, "guides": summary.guides})
    summary.name = item.name
    state.end_job(f"{job.description}: done in {summary.seconds_taken:.1f} s ({job.sample.steps} steps)"
                  + (f", root error {summary.root_error['mean_m']:.3f} m" if summary.root_error else ""))
    state.add_item(item)
    settings.result = summary


def describe(summary: ControlSummary) -> list[tuple[str, str]]:
    """(label, value) rows of the measured errors for the readout."""
    rows = []
    if summary.root_error is not None:
        e = summary.root_error
        rows += [("root error, mean", f"{e['mean_m']:.3f} m"), ("root error, max", f"{e['max_m']:.3f} m"),
                 ("frames > 0.5 m off", f"{100 * e['off_0_5m']:.0f} %")]
    if summary.wrist_error is not None:
        e = summary.wrist_error
        rows += [("wrist error, mean", f"{e['mean_m']:.3f} m"), ("wrist error, max", f"{e['max_m']:.3f} m")]
    return rows
