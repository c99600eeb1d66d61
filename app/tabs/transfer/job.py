"""The Transfer tab's job (MoMo, leader -> follower): checks with user-facing messages, the job (``TransferJob``,
launched on the session) and its result.

Nothing here touches Panel widgets. The engine does the work (``engine.methods.momo.transfer`` and ``analyze``);
this module adds what only the studio needs: sources picked among the session's motions, the Q/K clusters
fitted once per server and sampling-step count, three session motions per transfer (leader, follower, out)
shown side by side, and skeletons coloured by their Q or K cluster.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
import param

from app.generation import Cancelled, sampling_slot
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.tabs.transfer.colors import cluster_paint
from app.tabs.transfer.settings import SourceSettings, TransferSettings

MIN_MOTION_FRAMES = 20  # 1 s


@dataclass(frozen=True)
class TransferPlan:
    """A checked transfer, ready for the worker."""

    leader: object  # engine.methods.momo.Source
    follower: object
    extra: tuple  # Sources of followers 2, 3, ... (prompts from ``more_followers``)
    config: object  # engine.methods.momo.TransferConfig
    sample: object  # engine.generate.SampleConfig
    labels: dict  # role -> label for names and titles ("follower 2" ... for the extra followers)
    description: str


@dataclass
class TransferView:
    """A finished transfer as the views need it: the session motions (role -> item name), the analysis (of the
    first follower). Roles: ``leader``, ``follower``, ``out``, then ``follower 2``, ``out 2``, ... for extra
    followers."""

    names: dict[str, str]
    frames: dict[str, int]
    analysis: object  # engine.analysis.qk.TransferAnalysis of the first follower
    inversion: dict[str, dict | None]  # role -> {"mean_m", "max_m"} for an inverted source, else None
    joints: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    description: str = ""
    seconds_taken: float = 0.0
    analyses: list = field(repr=False, default_factory=list)  # one per follower (the first is ``analysis``)

    @property
    def followers(self) -> int:
        return max(1, len(self.analyses))

    def focus(self, k: int) -> "TransferView":
        """Follower ``k`` (1-based) and its out under the roles ``follower`` and ``out``, with their analysis:
        what the analysis views and the cluster colours read."""
        if len(self.analyses) < 2 or not 1 <= k <= len(self.analyses):
            return self
        n = "" if k == 1 else f" {k}"
        roles = {"leader": "leader", "follower": f"follower{n}", "out": f"out{n}"}
        pick = lambda d: {r: d[src] for r, src in roles.items() if src in d}  # noqa: E731
        return replace(self, names=pick(self.names), frames=pick(self.frames), joints=pick(self.joints),
                       inversion=pick(self.inversion), analysis=self.analyses[k - 1])


# ---------------------------------------------------------------------------------------------- checks
def _source(state, settings: SourceSettings, loaded):
    from engine.generate import frames_for
    from engine.methods.momo import Source

    who = settings.role
    text = settings.prompt.strip()
    if settings.kind == "prompt":
        if not text:
            raise ValueError(f"type a prompt for the {who}")
        try:
            loaded.tokenizer.encode(text)
        except ValueError as exc:
            raise ValueError(f"the {who}'s prompt: {exc}") from None
        try:
            frames = frames_for(float(settings.seconds))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"the {who}'s duration: {exc}") from None
        if frames > loaded.model.config.max_frames:
            raise ValueError(f"the {who} is too long: this model handles at most "
                             f"{loaded.model.config.max_frames / 20:.1f} s")
        return Source(prompt=text, seconds=float(settings.seconds), name=text), text
    item = state.items.get(settings.motion)
    if item is None:
        raise ValueError(f"pick a motion for the {who} (import one: BVH or .npy)" if not settings.motion else
                         f"the motion {settings.motion!r} is no longer in the session: pick another {who}")
    if item.n_frames < MIN_MOTION_FRAMES:
        raise ValueError(f"{item.name!r} is too short for the {who} (at least 1 s)")
    if text:
        try:
            loaded.tokenizer.encode(text)
        except ValueError as exc:
            raise ValueError(f"the {who}'s description: {exc}") from None
    joints = np.asarray(item.joints[: loaded.model.config.max_frames], dtype=np.float32)
    return Source(prompt=text or None, joints=joints, name=item.name), item.name


def prepare(state, settings: TransferSettings) -> TransferPlan:
    """Check the tab's settings against the session and the model; raises ValueError with a message."""
    from engine.methods.momo import MAX_FOLLOWER_STREAMS, TransferConfig

    cfg = settings
    loaded = state.model
    leader, leader_label = _source(state, cfg.leader, loaded)
    follower, follower_label = _source(state, cfg.follower, loaded)
    extra = more_followers(cfg.more_followers, seconds=cfg.follower.seconds, loaded=loaded)
    layers = None if cfg.layers is None else tuple(range(int(cfg.layers[0]), int(cfg.layers[1]) + 1))
    config = TransferConfig(start=float(cfg.steps[0]), end=float(cfg.steps[1]), layers=layers, root=cfg.root,
                            feet=bool(cfg.feet), flights=bool(cfg.flights), directions=int(cfg.directions))
    window = config.window(loaded.model.config.layers)  # layers outside the model fail here, with the range
    streams = (1 + len(extra)) * config.directions
    if streams > MAX_FOLLOWER_STREAMS:
        raise ValueError(f"{1 + len(extra)} followers x {config.directions} directions make {streams} follower "
                         f"streams, at most {MAX_FOLLOWER_STREAMS}: use fewer followers or directions")
    sample = state.sample_config()
    lay = window.layers
    more = f" + {len(extra)} more" if extra else ""
    feet = ", leader's footwork" if config.feet else ""
    directions = f", {config.directions} directions" if config.directions > 1 else ""
    description = (f"{_short(leader_label)} → {_short(follower_label)}{more} (layers {lay[0]}–{lay[-1]}, steps "
                   f"{config.start:.0%}–{config.end:.0%}, root: {config.root}{directions}{feet})")
    labels = {"leader": leader_label, "follower": follower_label}
    labels.update({f"follower {k}": src.prompt for k, src in enumerate(extra, start=2)})
    return TransferPlan(leader=leader, follower=follower, extra=tuple(extra), config=config, sample=sample,
                       labels=labels, description=description)


def more_followers(text: str, *, seconds: float, loaded) -> list:
    """The extra followers typed one prompt per line (blank lines skipped), each checked against the vocabulary;
    each generated as long as the follower's Seconds setting (4 s when that is not a valid duration)."""
    from engine.generate import frames_for
    from engine.methods.momo import MAX_FOLLOWERS, Source

    prompts = [line.strip() for line in (text or "").splitlines() if line.strip()]
    if len(prompts) + 1 > MAX_FOLLOWERS:
        raise ValueError(f"at most {MAX_FOLLOWERS} followers in one transfer: remove "
                         f"{len(prompts) + 1 - MAX_FOLLOWERS} of the extra prompts")
    try:
        seconds = float(seconds)
        frames_for(seconds)
    except (TypeError, ValueError):
        seconds = 4.0
    seconds = min(seconds, loaded.model.config.max_frames / 20)
    out = []
    for k, prompt in enumerate(prompts, start=2):
        try:
            loaded.tokenizer.encode(prompt)
        except ValueError as exc:
            raise ValueError(f"follower {k} ({_short(prompt)!r}): {exc}") from None
        out.append(Source(prompt=prompt, seconds=seconds, name=prompt))
    return out


def _short(text: str, limit: int = 28) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"


# ---------------------------------------------------------------------------------------------- clusters
_clusters: dict[tuple, object] = {}
_clusters_lock = threading.Lock()


def clusters_for(loaded, sample, *, note: Callable[[str], None] = lambda text: None):
    """The Q/K clusters of ``loaded`` at this step count (fitted on the first call per server, then cached)."""
    from engine.analysis.qk import FIT_PROMPTS, cluster_site, fit_clusters
    from engine.generate import SampleConfig

    key = (id(loaded), int(sample.steps))
    with _clusters_lock:
        if key not in _clusters:
            note(f"fitting the Q/K clusters for {sample.steps} steps (once per server)…")
            site = cluster_site(loaded.model.config.layers, sample.steps)
            _clusters[key] = fit_clusters(loaded, FIT_PROMPTS, site=site, sample=SampleConfig(steps=sample.steps))
        return _clusters[key]


def record_for(loaded, steps: int):
    """Record Q and K only where the analysis reads them (three sites), not at every layer and step."""
    from engine.analysis.qk import analysis_sites
    from engine.analysis.qk import qk_record

    sites = analysis_sites(loaded.model.config.layers, steps)
    return qk_record(steps=sorted({s.step for s in sites}), layers=sorted({s.layer for s in sites}))


# ---------------------------------------------------------------------------------------------- the worker
def run_job(loaded, job: TransferPlan, *, on_step=None, cancel=None, on_wait=None,
            note: Callable[[str], None] = lambda text: None) -> TransferView:
    """Fit (or reuse) the clusters, run the transfer, analyse it; ``on_step(done, total)`` after every step."""
    from engine.methods.momo import analyze, transfer

    cancel = cancel or threading.Event()

    def step(state) -> None:
        if cancel.is_set():
            raise Cancelled()
        if on_step is not None:
            on_step(state.step + 1, state.num_steps)

    with sampling_slot(cancel, on_wait):
        start = time.perf_counter()
        clusters = clusters_for(loaded, job.sample, note=note)
        if cancel.is_set():
            raise Cancelled()
        inverted = [r for r, s in (("leader", job.leader), ("follower", job.follower)) if s.joints is not None]
        if inverted:
            note(f"inverting the {' and the '.join(inverted)} ({job.sample.steps} DDIM steps)…")
        result = transfer(loaded, job.leader, [job.follower, *job.extra], job.config, sample=job.sample,
                          record=record_for(loaded, job.sample.steps), on_step=step)
        joints = {"leader": result.leader_joints(), "follower": result.follower(0), "out": result.out(0)}
        for k in range(1, 1 + len(job.extra)):
            joints.update({f"follower {k + 1}": result.follower(k), f"out {k + 1}": result.out(k)})
        joints = {r: np.asarray(j, dtype=np.float32) for r, j in joints.items()}
        bad = [r for r, j in joints.items() if not np.isfinite(j).all()]
        if bad:
            raise ValueError(f"the model produced non-finite joints for the {' and the '.join(bad)}")
        analyses = [analyze(loaded, result, clusters=clusters, follower=k, sample=job.sample)
                    for k in range(len(result.followers))]
    inversion = {"leader": result.leader.inversion, "follower": result.followers[0].inversion}
    inversion.update({f"follower {k + 1}": f.inversion for k, f in enumerate(result.followers) if k})
    return TransferView(names={}, frames={r: len(j) for r, j in joints.items()}, analysis=analyses[0],
                        inversion=inversion, joints=joints, description=job.description,
                        seconds_taken=time.perf_counter() - start, analyses=analyses)


@dataclass
class TransferJob:
    """One transfer, leader -> follower(s): leader / follower / out side by side and the analysis when done."""

    session: object  # StudioState
    settings: TransferSettings
    plan: TransferPlan | None = field(default=None, init=False)
    refused: ClassVar[str] = "cannot transfer"

    def prepare(self, loaded) -> None:
        self.plan = prepare(self.session, self.settings)

    def describe(self) -> JobDescription:
        p = self.plan
        return JobDescription(what="transfer", status=f"transfer {p.description}: starting", verb="transfer",
                              total=p.sample.steps)

    def run(self, loaded, worker: Worker) -> TransferView:
        return run_job(loaded, self.plan, on_step=worker.step, cancel=worker.cancel, on_wait=worker.waiting,
                       note=worker.note)

    def deliver(self, view: TransferView) -> Delivery:
        """Session motions (leader, follower, out, then follower k / out k of any extra follower) side by side in
        the viewer; the analysis on the tab."""
        job = self.plan
        titles = {"leader": f"leader · {job.labels['leader']}"}
        prompts = {"leader": job.leader.prompt or ""}
        for k, src in enumerate((job.follower, *job.extra), start=1):
            n = "" if k == 1 else f" {k}"
            label = job.labels[f"follower{n}"]
            titles.update({f"follower{n}": f"follower{n} · {label}",
                           f"out{n}": f"out{n} · {_short(label)} ← {_short(job.labels['leader'])}"})
            prompts.update({f"follower{n}": src.prompt or "", f"out{n}": src.prompt or ""})
        items = []
        for role in view.joints:
            item = MotionItem(name=self.session.unique_name(titles[role]), joints=view.joints[role],
                              source="generated", prompt=prompts[role],
                              info={"transfer": job.description, "role": role, "inversion": view.inversion.get(role)})
            items.append(item)
            view.names[role] = item.name
        names = view.names
        # painted as they are shown when the tab colours skeletons by clusters (the first follower's analysis)
        colors, notes, legend = cluster_paint(view.focus(1), self.settings.color_by)
        return Delivery(items=items, show=names["leader"], compare=names["follower"], also=_outs(names),
                        frame_colors=colors, color_notes=notes, color_names=legend,
                        status=f"transfer {job.description}: done in {view.seconds_taken:.1f} s "
                               f"({job.sample.steps} steps)",
                        readout=(self.settings, {"analysed": 1, "result": view}))


def _outs(names: dict[str, str]) -> list[str]:
    """The out of the first follower, then the outs of any extra followers."""
    return [names["out"], *(names[r] for r in names if r.startswith("out "))]


def show_roles(state, settings: TransferSettings) -> None:
    """Leader / follower / out side by side and in sync in the viewer (the last transfer), then the outs of any
    extra followers."""
    view = settings.result
    if view is None or any(n not in state.items for n in view.names.values()):
        state.error("the transfer's motions are no longer in the session: run it again")
        return
    with param.parameterized.batch_call_watchers(state):
        state.show(view.names["leader"])
        state.compare = view.names["follower"]
        state.also = _outs(view.names)


def own_description(state, name: str) -> str:
    """The prompt a session motion was made from, as its recipe keeps it ('' when none is known: a plain import):
    what the inversion of that motion is described by when it becomes a source (never an earlier source's prompt)."""
    item = state.items.get(name) if name else None
    if item is None:
        return ""
    text = item.prompt or (item.settings.prompt if item.settings is not None else "")
    library = getattr(state, "library", None)
    if not text and library is not None and item.library_id:
        try:
            text = str(library.recipe(item.library_id).get("prompt") or "")
        except Exception:  # a damaged entry: read without text
            text = ""
    return text.strip()


def describe_inversion(error: dict | None) -> str:
    """The round-trip error of an inverted source in metres ('' for a generated one), and of its pose (the joints
    relative to the root) where it was measured."""
    if not error:
        return ""
    pose = f" (pose {error['pose_mean_m']:.3f} m)" if "pose_mean_m" in error else ""  # library items from before
    return f"inversion error {error['mean_m']:.3f} m mean, {error['max_m']:.3f} m max{pose}"
