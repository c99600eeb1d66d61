"""The Control tab's job (PriorMDM control + DiffusionBlending): checks with user-facing messages, the job
(``ControlJob``, launched on the session), the measured error and the target paths shown in 3-D.

Nothing here touches Panel widgets. The engine does the work (``engine.methods.paths`` turns paths into control
features, ``engine.methods.control.controlled`` samples; the same functions ``moattn control`` calls); this
module adds what only the studio needs: the drawn paths (the root and both wrists, any of them at once) and blend
weights of ``ControlSettings`` as controls, and the result placed in the path's world with its errors measured.
The blend weights reach the engine as the user typed them; the engine's rule (``control_options.blend_shares``)
scales or refuses them, and a refusal is its one-line message (checked before the run starts, by the same rule).
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from app.generation import Cancelled, checked_frames, sampling_slot
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.tabs.control.models import control_setup
from app.tabs.control.paths import COLORS, LABELS, ROOT_COLOR, WRISTS
from app.tabs.control.settings import ControlSettings
from engine.methods.control_options import ControlOptions, option_info


@dataclass
class ControlPlan:
    """A checked controlled generation, ready for the worker."""

    prompt: str
    controls: list  # engine Controls
    frame: dict | None  # the root path's world frame (None: no root control)
    wrist_targets: dict[str, np.ndarray]  # controlled wrist -> (T, 3) body-frame values
    models: dict | None  # None: plain inpainting
    base: object  # the LoadedModel that runs it: the session's, or the control models' own base (issue #32)
    weights: dict[str, float] | None  # control -> its blend weight as typed (the engine scales it); None: inpainting
    shares: dict[str, float] | None  # control -> its share of the blend, by the engine's rule (the readout)
    sample: object
    seconds: float
    method: str
    description: str
    base_note: str = ""  # one line when ``base`` is the control models' own base, not the session's
    # feet on the floor kept still (engine.diffusion.feet)
    planted_feet: bool = option_info(ControlOptions, "planted_feet").default


@dataclass
class ControlSummary:
    name: str  # the session motion
    method: str
    controls: list[str]
    weights: dict[str, float]  # the blend's shares ({} for inpainting)
    root_error: dict | None  # path_error: mean_m, max_m, off_0_5m
    wrist_errors: dict[str, dict]  # controlled wrist -> mean_m, max_m in the body frame
    seconds_taken: float
    guides: list[tuple[str, np.ndarray]] = field(default_factory=list)  # colour, (N, 3) world points
    joints: np.ndarray | None = None  # (T, 22, 3) in the path's world
    base_note: str = ""  # one line when it ran on the control models' own base, not the session's
    skate: float | None = None  # share of floor foot frame pairs that slide (engine.evaluation.metrics.foot_skate)
    planted_feet: bool = False  # sampled with the planted-feet correction


def prepare(state, settings: ControlSettings) -> ControlPlan:
    """Every check before any work starts; raises ValueError with a message for the user."""
    from engine.methods.control import Control
    from engine.methods.paths import RootPath, WristPath, root_controls

    if not settings.prompt.strip():
        raise ValueError("type what the person does (e.g. 'a person walks')")
    # the base control runs on, inpainting and blending alike: the session's, or (when the control models were
    # fine-tuned on another vocabulary) the base shipped beside them; it reads the prompt
    run, problem = control_setup(settings.controls_dir, base=state.model)
    loaded = run.loaded
    loaded.tokenizer.encode(settings.prompt)
    frames = checked_frames(loaded, settings.seconds)
    seconds = frames / 20
    names = settings.active
    if not names:
        raise ValueError("turn on at least one control: the root path or a wrist")
    models, weights, shares = None, None, None
    if settings.method == "blending":
        weights = settings.typed_weights()  # as typed: the engine's rule scales them, or refuses with one line
        shares = settings.shares()  # the same rule, here: a refusal comes before any work starts
        found = run.models
        missing = [n for n in names if n not in found]
        if missing:
            raise ValueError(f"no fine-tuned model for the {', '.join(LABELS[n] for n in missing)}: "
                             f"{problem or 'choose inpainting'}")
        models = {n: found[n] for n in names}
    controls, frame, wrist_targets = [], None, {}
    if "root" in names:
        if len(settings.root_points) < 2:
            raise ValueError("root path: draw it on the top-down canvas (at least 2 points)")
        values, frame = root_controls(RootPath(points=tuple(map(tuple, settings.root_points))), seconds)
        controls.append(Control("root", values))
    for name in (n for n in WRISTS if n in names):
        label = LABELS[name]
        points = settings.wrist_points(name)
        if len(points) < 2:
            raise ValueError(f"{label} path: draw it on the front-view canvas (at least 2 points)")
        pts = tuple((float(x), float(y), float(settings.wrist_depth)) for x, y in points)
        try:
            wrist_targets[name] = WristPath(points=pts).controls(seconds)
        except ValueError as exc:
            raise ValueError(f"{label}: {exc}") from None
        controls.append(Control(name, wrist_targets[name]))
    sample = state.sample_config()
    what = " + ".join(LABELS[n] for n in names)
    return ControlPlan(prompt=settings.prompt.strip(), controls=controls, frame=frame, wrist_targets=wrist_targets,
                      models=models, weights=weights, shares=shares, sample=sample, seconds=seconds,
                      method=settings.method, description=f"{what} by {settings.method}", base=loaded,
                      base_note=run.note, planted_feet=settings.planted_feet)


def run_job(loaded, job: ControlPlan, *, on_step: Callable[[int, int], None], cancel: threading.Event,
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
        gen = controlled(job.base if job.base is not None else loaded, job.prompt, job.controls, seconds=job.seconds,
                         models=job.models, weights=job.weights, sample=job.sample, on_step=step,
                         planted_feet=job.planted_feet)
    joints = np.asarray(gen.joints[0], dtype=np.float32)
    if not np.isfinite(joints).all():
        raise ValueError("the model produced non-finite joints")
    summary = measure(job, joints, features=np.asarray(gen.features[0]))
    summary.seconds_taken = time.perf_counter() - t0
    summary.base_note = job.base_note
    summary.joints = joints if job.frame is None else _world(joints, job.frame)
    return summary


def _world(joints: np.ndarray, frame: dict) -> np.ndarray:
    from engine.methods.paths import to_world

    return np.asarray(to_world(joints, frame), dtype=np.float32)


def measure(job: ControlPlan, joints: np.ndarray, *, features: np.ndarray) -> ControlSummary:
    """Root error on the floor (path_error, world frame), each wrist's error in the body frame, and the 3-D guides."""
    from engine.methods.control import control_dims
    from engine.methods.paths import path_error
    from engine.representation import features_to_joints, joints_to_features
    from engine.skeleton import JOINT_INDEX

    names = [c.name for c in job.controls]
    world = joints if job.frame is None else _world(joints, job.frame)
    guides, root_error, wrist_errors = [], None, {}
    if job.frame is not None:
        root_error = path_error(world, job.frame["target"])
        xz = np.asarray(job.frame["target"], dtype=np.float64)
        guides.append((ROOT_COLOR, np.stack([xz[:, 0], np.full(len(xz), 0.012), xz[:, 1]], -1)))
    measured_all = joints_to_features(joints) if job.wrist_targets else None
    for name, wanted in job.wrist_targets.items():
        dims = control_dims(name)
        measured = measured_all[:, dims]
        n = min(len(measured), len(wanted))
        d = np.linalg.norm(measured[:n] - wanted[:n], axis=1)
        wrist_errors[name] = {"mean_m": float(d.mean()), "max_m": float(d.max())}
        # the target in the world: the generated body carrying the target wrist instead of its own
        feats = np.array(features[: len(wanted)], dtype=np.float64)
        feats[:, dims] = wanted[: len(feats)]
        target = features_to_joints(feats)[:, JOINT_INDEX[name]]
        if job.frame is not None:
            target = _world(target[:, None], job.frame)[:, 0]
        guides.append((COLORS[name], np.asarray(target, dtype=np.float64)))
    from engine.evaluation.metrics import foot_skate

    return ControlSummary(name="", method=job.method, controls=names, weights=dict(job.shares or {}),
                          root_error=root_error, wrist_errors=wrist_errors, seconds_taken=0.0, guides=guides,
                          skate=foot_skate(joints), planted_feet=job.planted_feet)


@dataclass
class ControlJob:
    """One generation following the drawn paths: the motion in the path's world, its guides and errors, when done."""

    session: object  # StudioState
    settings: ControlSettings
    plan: ControlPlan | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot generate with control"

    def prepare(self, loaded) -> None:
        self.plan = prepare(self.session, self.settings)

    def describe(self) -> JobDescription:
        p = self.plan
        return JobDescription(what="controlled generation", status=f"{p.description}: step 0 / {p.sample.steps}",
                              verb=p.description, total=p.sample.steps)

    def run(self, loaded, worker: Worker) -> ControlSummary:
        return run_job(loaded, self.plan, on_step=worker.step, cancel=worker.cancel, on_wait=worker.waiting)

    def deliver(self, summary: ControlSummary) -> Delivery:
        """The motion (in the path's world) becomes a session motion with its target paths as guides; shown."""
        job = self.plan
        title = f"control · {job.prompt} · {' + '.join(LABELS[n] for n in summary.controls)} · {job.method}"
        item = MotionItem(name=self.session.unique_name(title), joints=summary.joints, source="generated",
                          prompt=job.prompt, info={"control": summary, "guides": summary.guides})
        summary.name = item.name
        return Delivery(items=[item], show=item.name, readout=(self.settings, {"result": summary}),
                        status=f"{job.description}: done in {summary.seconds_taken:.1f} s ({job.sample.steps} steps)"
                               + (f", root error {summary.root_error['mean_m']:.3f} m" if summary.root_error else ""))


def describe(summary: ControlSummary) -> list[tuple[str, str]]:
    """(label, value) rows of the measured errors for the readout."""
    rows = []
    if summary.root_error is not None:
        e = summary.root_error
        rows += [("root error, mean", f"{e['mean_m']:.3f} m"), ("root error, max", f"{e['max_m']:.3f} m"),
                 ("frames > 0.5 m off", f"{100 * e['off_0_5m']:.0f} %")]
    for name, e in summary.wrist_errors.items():
        rows += [(f"{LABELS[name]} error, mean", f"{e['mean_m']:.3f} m"),
                 (f"{LABELS[name]} error, max", f"{e['max_m']:.3f} m")]
    if summary.weights:
        rows.append(("blend", " + ".join(f"{s:.2f} × {LABELS[n]}" for n, s in summary.weights.items())))
    if summary.skate is not None:
        rows.append(("feet sliding on the floor", f"{100 * summary.skate:.0f} % of floor frames"
                     + (" (planted feet on)" if summary.planted_feet else " (planted feet off)")))
    return rows
