"""The Duet tab's model (ComMDM, PriorMDM): two people from one prompt, or the completion of a two-person prefix.

Nothing here touches Panel widgets. The engine does the work (``engine.methods.duet``, what ``moattn duet``
calls); this module adds what only the studio needs: the duet model loaded once per server (and only on the
prior it was trained on), prompt checks against the duet's vocabulary, prefix sources (held-out corpus
interactions, duets of the session, an uploaded duet .npy), and the result as two session motions shown in
one scene.
"""
from __future__ import annotations

import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import param

from app.generation import Cancelled, prompt_analysis, sampling_slot
from app.session.duets import DuetPair
from engine.io import seconds_number
from engine.paths import DUET_DIR
from engine.units import FPS

MODES = {"text": "from a prompt", "prefix": "complete a prefix"}
PREFIX_COLOR = "#9a9a9a"  # the given prefix frames of a completion
EXAMPLE = "example: "

_lock = threading.Lock()
_cache: dict[tuple[Path, int], tuple[float, object, str]] = {}  # (folder, id(prior)) -> (mtime, DuetModel, problem)
_examples: dict[str, object] = {}


def duet_model(folder: str | Path, prior) -> tuple[object | None, str]:
    """The duet model in ``folder`` on ``prior`` (loaded once per server and prior), or (None, why not)."""
    from engine.methods.duet import load_duet

    key = Path(folder).expanduser().resolve()
    cfg = key / "config.json"
    mtime = cfg.stat().st_mtime if cfg.exists() else -1.0
    with _lock:
        cached = _cache.get((key, id(prior)))
        if cached is not None and cached[0] == mtime:
            return cached[1], cached[2]
        model, problem = None, ""
        if prior is None:
            problem = "no base model is loaded"
        elif not cfg.exists():
            problem = f"no duet model in {key} (train one with `moattn train --commdm --out {key}`)"
        else:
            try:
                model = load_duet(key, prior)
            except Exception as exc:  # another prior, a broken folder: say so
                problem = f"the duet model in {key} cannot be used: {exc}"
        _cache[(key, id(prior))] = (mtime, model, problem)
        return model, problem


def duet_vocabulary(folder: str | Path, prior_tokenizer):
    """The prior's tokenizer extended by the duet model's words (read from its config, no weights loaded)."""
    import json

    if prior_tokenizer is None:
        return None
    try:
        words = json.loads((Path(folder) / "config.json").read_text()).get("words", [])
    except (OSError, ValueError):
        words = []
    return prior_tokenizer.extended(words)


def example_names() -> list[str]:
    from engine.synth.duet import INTERACTIONS

    return [EXAMPLE + k.replace("_", " ") for k in INTERACTIONS]


def example(name: str):
    """A held-out corpus duet of the named interaction (made once)."""
    from engine.methods.duet_data import few_shot

    with _lock:
        if not _examples:
            for s in few_shot("test", per_interaction=1):
                _examples[EXAMPLE + s.interaction.replace("_", " ")] = s
        if name not in _examples:
            raise ValueError(f"no example {name!r}")
        return _examples[name]


@dataclass
class DuetSummary:
    """The last duet, for the readout."""

    names: tuple[str, str]  # the two session motions
    mode: str
    prompt: str
    communicate: bool
    placement: object  # Pose: person b seen from person a
    contacts: str  # what contact guidance did, in words
    distance_m: float
    facing_each_other: bool
    prefix_frames: int
    n_frames: int
    seconds_taken: float


class DuetSettings(param.Parameterized):
    """The Duet tab's state (one per session, owned by the tab)."""

    mode = param.Selector(default="text", objects=list(MODES))
    prompt = param.String(default="two people shake hands", doc="what the two people do (both read it)")
    seconds = param.Number(default=5.0, doc="length (from a prompt) or seconds completed after the prefix")
    prefix = param.String(default=EXAMPLE + "handshake", doc="where the prefix comes from: an example or a duet")
    prefix_seconds = param.Number(default=1.0, doc="seconds of the prefix given")
    communicate = param.Boolean(default=True, doc="ComMDM (the block); off: the prior twice, fixed placement")
    contact = param.Boolean(default=True, doc="guide the hands to touch when the training examples do (text only)")
    duet_dir = param.Parameter(default=DUET_DIR, doc="folder of the trained ComMDM block")
    uploads = param.Dict(default={}, doc="name -> (2, T, 22, 3) duets uploaded in this session")
    unknown_words = param.List(default=[])
    suggestions = param.Dict(default={})
    result = param.Parameter(default=None, doc="DuetSummary of the last duet")

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, **params):
        super().__init__(**params)
        self._prior_tokenizer = tokenizer or (lambda: None)
        self.param.watch(self._analyse, ["prompt", "mode"])
        self._analyse()

    def tokenizer(self):
        """The duet's vocabulary (read from its config once per duet folder and prior, not per keystroke)."""
        prior = self._prior_tokenizer()
        key = (str(self.duet_dir), id(prior))
        if getattr(self, "_vocab_key", None) != key:
            self._vocab, self._vocab_key = duet_vocabulary(self.duet_dir, prior), key
        return self._vocab

    def _analyse(self, *_) -> None:
        _, unknown, suggestions = prompt_analysis(self.tokenizer(), self.prompt)
        self.param.update(unknown_words=unknown, suggestions=suggestions)

    def prefix_options(self, items: dict) -> list[str]:
        """Examples, then uploaded duets, then duets of the session (their person-a motions)."""
        made = [n for n, it in items.items() if isinstance(it.info.get("duet"), DuetPair) and it.info["duet"].first == n]
        return [*example_names(), *self.uploads, *made]

    def add_upload(self, data: bytes, filename: str) -> str:
        """An uploaded duet .npy (2, T, 22, 3), parsed as data; its name in the prefix list."""
        from app.session.items import MAX_UPLOAD_BYTES, upload_limit_text
        from engine.io.npy import load_duet_npy

        if not data:
            raise ValueError(f"{filename} is empty")
        if len(data) > MAX_UPLOAD_BYTES:
            raise ValueError(f"{filename} is {len(data) / 2**20:.1f} MiB; uploads are limited to {upload_limit_text()}")
        if Path(filename).suffix.lower() != ".npy":
            raise ValueError(f"{filename}: a duet is a .npy of joints (2, T, 22, 3), as `moattn duet` writes")
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "duet.npy"
            path.write_bytes(data)
            joints = load_duet_npy(path)
        name = f"upload: {filename}"
        self.uploads = {**self.uploads, name: joints}
        self.prefix = name
        return name


@dataclass
class DuetJob:
    mode: str
    prompt: str | None
    seconds: float
    prefix: tuple[np.ndarray, np.ndarray] | None
    prefix_seconds: float
    communicate: bool
    sample: object  # SampleConfig
    description: str
    contact: bool = False  # contact guidance (text only)


def prepare(state, settings: DuetSettings) -> DuetJob:
    """Every check before any work starts; raises ValueError with a message for the user."""
    from engine.generate import MAX_SECONDS, MIN_SECONDS, SampleConfig

    loaded = state.model
    model, problem = duet_model(settings.duet_dir, loaded)
    if model is None:
        raise ValueError(problem)
    prompt = settings.prompt.strip()
    seconds = seconds_number(settings.seconds, "the length")
    if settings.mode == "text":
        if not prompt:
            raise ValueError("type what the two people do, e.g. 'two people shake hands'")
        model.tokenizer.encode(prompt)  # unknown words: a PromptError naming them
        if not MIN_SECONDS <= seconds <= MAX_SECONDS:
            raise ValueError(f"the length must be between {MIN_SECONDS:g} and {MAX_SECONDS:g} s")
        sample = SampleConfig(steps=int(state.steps), guidance=float(state.guidance), seed=int(state.seed))
        return DuetJob(mode="text", prompt=prompt, seconds=seconds, prefix=None, prefix_seconds=0.0,
                       communicate=settings.communicate, sample=sample, description="duet", contact=settings.contact)
    given = seconds_number(settings.prefix_seconds, "the prefix")
    if prompt:
        model.tokenizer.encode(prompt)
    a, b = prefix_joints(state, settings)
    need = int(round(given * FPS)) + 1
    if len(a) < need:
        raise ValueError(f"the prefix {settings.prefix!r} has {len(a)} frames; {given:g} s needs {need}")
    total = given + seconds
    limit = loaded.model.config.max_frames / FPS
    if given < 0.1 or seconds < MIN_SECONDS or total > limit:
        raise ValueError(f"prefix ({given:g} s) + completion ({seconds:g} s) must fit in {limit:g} s, "
                         f"with at least {MIN_SECONDS:g} s completed")
    sample = SampleConfig(steps=int(state.steps), guidance=float(state.guidance) if prompt else 1.0,
                          seed=int(state.seed))
    return DuetJob(mode="prefix", prompt=prompt or None, seconds=seconds, prefix=(a, b), prefix_seconds=given,
                   communicate=settings.communicate, sample=sample, description="duet completion")


def prefix_joints(state, settings: DuetSettings) -> tuple[np.ndarray, np.ndarray]:
    name = settings.prefix
    if name.startswith(EXAMPLE):
        s = example(name)
        return s.joints_a, s.joints_b
    if name in settings.uploads:
        j = settings.uploads[name]
        return j[0], j[1]
    item = state.items.get(name)
    if item is not None and isinstance(item.info.get("duet"), DuetPair):
        j = item.info["duet"].joints
        return j[0], j[1]
    raise ValueError(f"no duet named {name!r} (pick an example, upload a duet .npy, or make a duet first)")


def run_job(loaded, job: DuetJob, *, duet_dir, on_step: Callable[[int, int], None], cancel: threading.Event,
            on_wait: Callable[[], None] | None = None):
    """Sample on the worker (holding the sampling slot)."""
    from engine.methods.duet import complete, text_to_duet
    from engine.methods.duet_contact import ContactConfig

    model, problem = duet_model(duet_dir, loaded)
    if model is None:
        raise ValueError(problem)
    done = [0]

    def step(_state) -> None:
        if cancel.is_set():
            raise Cancelled()
        done[0] += 1
        on_step(min(done[0], job.sample.steps), job.sample.steps)

    t0 = time.perf_counter()
    with sampling_slot(cancel, on_wait):
        if job.mode == "text":
            duet = text_to_duet(model, job.prompt, seconds=job.seconds, sample=job.sample,
                                communicate=job.communicate, contact=ContactConfig() if job.contact else None,
                                on_step=step)
        else:
            duet = complete(model, *job.prefix, prefix_seconds=job.prefix_seconds, seconds=job.seconds,
                            prompt=job.prompt, sample=job.sample, communicate=job.communicate, on_step=step)
    if not np.isfinite(duet.joints).all():
        raise ValueError("the model produced non-finite joints")
    return duet, time.perf_counter() - t0


def start_duet(state, settings: DuetSettings) -> bool:
    """Check, then sample on the session's worker with progress and cancel; False (and a notification) if refused."""
    return state.launch(
        prepare=lambda: prepare(state, settings),
        run=lambda loaded, job, worker: run_job(loaded, job, duet_dir=settings.duet_dir, on_step=worker.step,
                                                cancel=worker.cancel, on_wait=worker.waiting),
        finish=lambda job, result: finish(state, settings, job, *result), refused="cannot make a duet",
        what="duet", total=lambda job: job.sample.steps,
        status=lambda job: f"{job.description}: step 0 / {job.sample.steps}", verb=lambda job: job.description)


def finish(state, settings: DuetSettings, job: DuetJob, duet, seconds_taken: float) -> None:
    """The two people become two session motions shown together in one scene."""
    from app.session.items import MotionItem
    from engine.evaluation.bench_duet import face_each_other
    from viz.colors import ROLE_PALETTE, default_joint_colors

    what = job.prompt or "completion"
    base = f"duet · {what[:40]} · seed {job.sample.seed}" + ("" if job.communicate else " · no block")
    first = state.unique_name(base + " · a")
    second = state.unique_name(base + " · b")
    pair = DuetPair(first=first, second=second, joints=duet.joints)
    items = [MotionItem(name=n, joints=duet.joints[k], source="generated", prompt=job.prompt or "",
                        info={"duet": pair}) for k, n in enumerate((first, second))]
    given = int(round(job.prefix_seconds * FPS)) if job.mode == "prefix" else 0
    p = duet.placement
    summary = DuetSummary(names=(first, second), mode=job.mode, prompt=job.prompt or "", communicate=job.communicate,
                          placement=p, contacts=contact_words(job, duet), distance_m=float(np.hypot(p.x, p.z)),
                          facing_each_other=face_each_other(duet.joints), prefix_frames=given,
                          n_frames=duet.frames, seconds_taken=seconds_taken)
    state.end_job(f"{job.description}: {duet.frames} frames in {seconds_taken:.1f} s")
    for it in items:
        state.add_item(it, show=False)
    colors = {}
    if given:
        for k, it in enumerate(items):
            rgb = np.broadcast_to(default_joint_colors(ROLE_PALETTE[k]), (duet.frames, 22, 3)).copy()
            rgb[:given] = default_joint_colors(PREFIX_COLOR)
            colors[it.name] = rgb
    state.frame_colors = {**{k: v for k, v in state.frame_colors.items() if k in state.items}, **colors}
    state.show(first)
    state.also = [second]
    settings.result = summary


def contact_words(job: DuetJob, duet) -> str:
    """The readout's line on contact guidance."""
    if job.mode != "text":
        return "none (completion)"
    if not job.contact:
        return "off"
    if duet.interaction is None:
        return "none: the prompt reads as no trained interaction"
    if not duet.contacts:
        return f"none: a {duet.interaction.replace('_', ' ')} has no contact"
    spans = ", ".join(f"{c.kind.replace('_', ' ')} {100 * c.start:.0f}–{100 * c.end:.0f} %" for c in duet.contacts)
    return f"{duet.interaction.replace('_', ' ')}: {spans} of the clip"


def describe(summary: DuetSummary) -> list[tuple[str, str]]:
    p = summary.placement
    rows = [("method", "ComMDM" if summary.communicate else "prior twice (no block)"),
            ("person b from person a", f"{summary.distance_m:.2f} m, facing {np.degrees(p.yaw):+.0f}°"),
            ("face each other (mid-clip)", "yes" if summary.facing_each_other else "no"),
            ("contact guidance", summary.contacts),
            ("frames", f"{summary.n_frames} ({summary.n_frames / FPS:.1f} s)"
             + (f", first {summary.prefix_frames} given" if summary.prefix_frames else "")),
            ("time", f"{summary.seconds_taken:.1f} s")]
    return rows
