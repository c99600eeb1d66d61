"""The Edit tab's jobs: checks of its settings with user-facing messages, the edit (``EditJob``) and the counting
of an imported motion (``CountJob``), both launched on the session.

Nothing here touches Panel widgets. The option -> config mapping is the engine's
(``engine.methods.edit_options``, shared with ``moattn edit``); this module adds what only the
studio needs: the picked word as (word, occurrence), sources among the session's motions,
the replacement's word alignment shown as text (prompt-to-prompt's, see ``engine.methods.word_alignment``), recording the edited motions' attention into
``AttentionRecord``s, and counting a session motion (recorded maps, or inversion for an imported one).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from app.attention_record import AttentionRecord, estimate_bytes, plan_steps
from app.generation import Cancelled, sampling_slot
from app.session.items import MotionItem
from app.session.jobs import Delivery, JobDescription, Worker
from app.session.counting import CountReadout, auto_count, count_imported
from app.tabs.edit.settings import PROMPT_SOURCE, EditSettings, EditSummary
from engine.analysis.action_size import size_change
from engine.methods.edit_kinds import EditKind
from engine.methods.word_alignment import SWAPPED_DEFAULT

RECORD_BUDGET = 400 * 1024 * 1024  # the edit's AttentionStore keeps 512 MB at most: stay below it


def word_choice(words: list[str] | tuple[str, ...], position: int) -> tuple[str, int]:
    """The word at ``position`` of a prompt as (word, occurrence): edits name words, never token indices."""
    word = words[position]
    return word, list(words[:position]).count(word)


def alignment(tokenizer, reference: str, edited: str, *, swapped: str = SWAPPED_DEFAULT) -> tuple[bool, str]:
    """How in-place replacement will align the two prompts' words: (ok, the alignment or why not, for the user).

    The words are aligned as prompt-to-prompt aligns them (``engine.methods.word_alignment``): word by word when the
    prompts have as many words, otherwise the shared words are matched, swapped words take the attention of the
    words they replace, added words keep their own and dropped words are said. Both prompts are read as the engine
    reads them (``Tokenizer.encode``): a prompt it refuses is refused with its message, and a swapped-in word it
    leaves out cannot replace anything (words it reads by meaning or as a typo can; words left out of both prompts
    alike do not matter). ``swapped``: what a swapped word attends with (``EditOptions.swapped``)."""
    from engine.methods.word_alignment import align_words
    from engine.text import PromptError, split_words

    ref, new = split_words(reference), split_words(edited)
    if not new:
        return False, "type the edited prompt: the prompt with the action swapped (words may be added or dropped)"
    if not ref:
        return False, "type the prompt first: the edited prompt replaces its action"
    tokens = {}
    if tokenizer is not None:
        for role, text in (("prompt", reference), ("edited prompt", edited)):
            try:
                tokens[role] = tokenizer.encode(text)
            except PromptError as exc:
                return False, f"the {role} cannot be read: {exc}"
    if ref == new:
        return False, "the edited prompt is the same as the prompt: change a word (e.g. the verb)"
    typed = align_words(ref, new)
    if not tokens:
        return True, typed.describe(swapped=swapped)
    gone_ref, gone_new = set(tokens["prompt"].left_out), set(tokens["edited prompt"].left_out)
    for src, dst in typed.groups:
        a = " ".join(ref[i] for i in src)
        for b in (new[j] for j in dst):
            if b in gone_new and b not in (ref[i] for i in src):
                return False, (f"'{b}' is left out of the edited prompt (the model does not know it), so it cannot "
                               + (f"replace '{a}'" if src else "be added") + ": pick a word the model reads")
        for w in (ref[i] for i in src):
            if dst and w in gone_ref and w not in (new[j] for j in dst):
                return False, f"'{w}' is left out of the prompt (the model does not know it), so it cannot be replaced"
    read = align_words(tokens["prompt"].words, tokens["edited prompt"].words)  # what the engine will align
    if not read.changed:
        left_out = ", ".join(dict.fromkeys([*gone_ref, *gone_new])) or "none"
        return False, f"the model reads both prompts alike (words left out: {left_out}): nothing to replace"
    notes = list(dict.fromkeys(n for t in tokens.values() for n in t.notes()))
    return True, read.describe(swapped=swapped) + (f" ({'; '.join(notes)})" if notes else "")


def swap_example(words: list[str]) -> list[str]:
    verbs = {"jumps": "kicks", "walks": "runs", "runs": "walks", "kicks": "jumps", "waves": "claps"}
    out = list(words)
    for i, w in enumerate(out):
        if w in verbs:
            out[i] = verbs[w]
            return out
    return out


@dataclass
class EditPlan:
    """A checked edit, ready for the worker."""

    kind: EditKind  # the engine's registry entry of the edit
    options: object  # engine.methods.edit_options.EditOptions
    config: object  # the edit's method config, built (and checked) once
    sample: object  # engine.generate.SampleConfig
    frames: int
    record_steps: int
    label: str
    description: str
    prompt: str
    record: bool


@dataclass
class EditedMotion:
    role: str
    joints: np.ndarray
    prompt: str
    words: tuple[str, ...]
    attention: AttentionRecord | None
    title: str


@dataclass
class EditResult:
    job: EditPlan
    before: EditedMotion
    after: list[EditedMotion] = field(default_factory=list)
    seconds_taken: float = 0.0


# ---------------------------------------------------------------------------------------------- checks
def prepare(state, settings: EditSettings) -> EditPlan:
    """Check the tab's settings against the session (prompt, model, sources); raises ValueError with a message.
    What each kind reads and how it is described is the engine's registry (``engine.methods.edit_kinds``)."""
    from engine.generate import frames_for
    from engine.methods.edit_options import EditOptions, acts_in_layers, build_config

    cfg = settings
    entry = cfg.entry
    if not entry.is_edit:
        raise ValueError("counting is not an edit: use Count")
    loaded = state.model
    prompt = state.prompt
    frames = frames_for(state.duration())
    if frames > loaded.model.config.max_frames:
        raise ValueError(f"this model handles at most {loaded.model.config.max_frames / 20:.1f} s")
    sample = state.sample_config()
    word = cfg.word or None
    if "word" in entry.inputs:
        if word is None:
            raise ValueError("pick a word: click it in the prompt")
        words = state.prompt_words
        if words.count(word) <= cfg.occurrence:
            raise ValueError(f"the word '{word}' is not in the prompt any more: pick a word again")
        # a word the engine leaves out has no token to point at: its PromptError says so, naming the word
        loaded.tokenizer.encode(prompt).word_index(word, cfg.occurrence)
    source = resolve_source(state, cfg.source) if entry.source else prompt
    style = resolve_source(state, cfg.style_source, prompt=cfg.style_prompt) if "style" in entry.inputs else None
    for text in (s for s in (source, style) if isinstance(s, str)):
        loaded.tokenizer.encode(text)  # PromptError (a ValueError) with the unknown words
    if "edited" in entry.inputs:
        ok, message = alignment(loaded.tokenizer, prompt, cfg.edited, swapped=cfg.swapped)
        if not ok:
            raise ValueError(message)
    span = tuple(int(f) for f in cfg.frames) if cfg.frames is not None else None
    if span is not None and entry.default_frames(frames) == (0, frames) and span[0] <= 0 and span[1] >= frames:
        span = None  # the whole motion (a kind whose default is less, e.g. the last half, keeps its span)
    if entry.spans:  # the spans dragged on the word's curve (none: the whole motion)
        from engine.methods.spans import check_spans

        span = check_spans([tuple(int(v) for v in s) for s in cfg.spans], frames=frames) or None
    options = EditOptions(
        kind=entry.name, prompt=source, word=word, occurrence=cfg.occurrence, weight=float(cfg.weight),
        mode=cfg.mode, frames=span, edited=cfg.edited, style=style, **cfg.plain_values(),
        step_window=tuple(cfg.step_window) if cfg.step_window is not None else None,
        layers=tuple(cfg.layers) or None if acts_in_layers(entry.name, cfg.mode) else None, seed=int(state.seed))
    # built once, here: the config's own checks (weight ranges, windows) before any work; the worker runs it
    config = build_config(options, frames=frames, model_config=loaded.config)
    description = entry.describe(options, frames=frames)
    m = loaded.config["model"]
    size = entry.batch_slots(options) * estimate_bytes(num_steps=sample.steps, record_steps=sample.steps,
                                                       layers=m["layers"], heads=m["heads"], frames=frames, words=16)
    return EditPlan(kind=entry, options=options, config=config, sample=sample, frames=frames,
                    record_steps=int(state.record_steps), label=cfg.kind, description=description,
                    prompt=prompt if isinstance(prompt, str) else "",
                    record=state.record_steps > 0 and size < RECORD_BUDGET)


def resolve_source(state, name: str, *, prompt: str | None = None):
    """A source for example-based / style transfer: a prompt (generated in the batch) or an imported motion's joints
    (DDIM-inverted by the engine). A generated session motion is used through its prompt."""
    if not name or name == PROMPT_SOURCE:
        text = state.prompt if prompt is None else prompt
        if not text.strip():
            raise ValueError("type a prompt for the source")
        return text
    item = state.items.get(name)
    if item is None:
        raise ValueError(f"the motion {name!r} is no longer in the session: pick another source")
    if item.source == "generated" and item.prompt:
        return item.prompt
    if item.n_frames < 20:
        raise ValueError(f"{name!r} is too short to use as a source (at least 1 s)")
    return np.asarray(item.joints[: 196])


# ---------------------------------------------------------------------------------------------- the worker
def run_edit_job(loaded, job: EditPlan, *, on_step=None, cancel=None, on_wait=None) -> EditResult:
    """Run one edit (waits for the sampling slot); ``on_step(done, total)`` after every step."""
    from engine.methods.edit_options import run_edit as run_engine_edit

    timesteps: dict[int, int] = {}

    def step(state) -> None:
        timesteps[state.step] = int(state.t)
        if cancel is not None and cancel.is_set():
            raise Cancelled()
        if on_step is not None:
            on_step(state.step + 1, state.num_steps)

    with sampling_slot(cancel, on_wait):
        start = time.perf_counter()
        out = run_engine_edit(loaded, job.options, frames=job.frames, sample=job.sample, record=job.record,
                              on_step=step, config=job.config)
    gen = out.generation
    keep = plan_steps(job.sample.steps, job.record_steps) if job.record_steps else []

    def motion(role: str, index: int, title: str) -> EditedMotion:
        slots = [i for i, r in enumerate(gen.roles.names) if r == role]
        slot = slots[index]
        joints = np.asarray(gen.joints[slot], dtype=np.float32)
        if not np.isfinite(joints).all():
            raise ValueError("the model produced non-finite joints")
        tokens = gen.tokens[slot]
        words = tuple(tokens.words) if tokens is not None else ()
        prompt = tokens.prompt if tokens is not None else ""
        record = _record(out.store, role, index, words, job.sample.steps, keep, timesteps)
        return EditedMotion(role=role, joints=joints, prompt=prompt or "", words=words, attention=record, title=title)

    n_after = job.kind.outputs(job.options)
    before = motion(out.before_role, 0, job.kind.before_title)
    after = [motion(out.after_role, i, job.description + (f" #{i + 1}" if n_after > 1 else ""))
             for i in range(n_after)]
    return EditResult(job=job, before=before, after=after, seconds_taken=time.perf_counter() - start)


def _record(store, role: str, index: int, words, num_steps: int, keep: list[int], timesteps) -> AttentionRecord | None:
    """The recorded maps of one role's slot, at the session's recording plan (None if not recorded)."""
    if store is None or not keep or not store.records or store.skipped_sites:
        return None
    try:
        first = store.records[store.sites(kind="self")[0]]
        positions = [i for i, r in enumerate(first.roles) if r == role]
        record = AttentionRecord.from_store(store, words=words, num_steps=num_steps, timesteps=timesteps,
                                            slot=positions[index], steps=keep)
        # the batch pads every prompt to its longest: keep this prompt's words only
        record.cross_maps = np.ascontiguousarray(record.cross_maps[..., : len(words)])
        return record
    except (IndexError, KeyError, ValueError):
        return None  # e.g. a text-less (inverted) slot has no cross-attention


# ---------------------------------------------------------------------------------------------- the jobs
@dataclass
class EditJob:
    """One MotionCLR edit of the session's prompt (or sources): before and after side by side when done."""

    session: object  # StudioState
    settings: EditSettings
    plan: EditPlan | None = field(default=None, init=False)

    @property
    def refused(self) -> str:
        return f"cannot {self.settings.kind}"

    def prepare(self, loaded) -> None:
        self.plan = prepare(self.session, self.settings)

    def describe(self) -> JobDescription:
        p = self.plan
        return JobDescription(what="edit", status=f"{p.description}: step 0 / {p.sample.steps}", verb=p.description,
                              total=p.sample.steps)

    def run(self, loaded, worker: Worker) -> EditResult:
        return run_edit_job(loaded, self.plan, on_step=worker.step, cancel=worker.cancel, on_wait=worker.waiting)

    def deliver(self, result: EditResult) -> Delivery:
        """The reference (re-used when the session has it already) and the edited motions, side by side."""
        session, job = self.session, result.job
        seed = job.sample.seed

        def item(m: EditedMotion, title: str) -> MotionItem:
            return MotionItem(name=session.unique_name(title), joints=m.joints, source="generated", prompt=m.prompt,
                              words=m.words, attention=m.attention,
                              info={"edit": job.description, "role": m.role, "seed": seed})

        base = (result.before.prompt or "imported") if job.kind.source else job.prompt
        title = f"{base} · seed {seed} · {result.before.title}"
        before = same_motion(session, title, result.before.joints)
        new = [] if before is not None else [item(result.before, title)]
        before = before or new[0]
        afters = [item(m, f"{m.prompt or base} · {m.title}") for m in result.after]
        first = afters[0]
        n = min(len(first.joints), len(before.joints))
        diff = float(np.linalg.norm(first.joints[:n] - before.joints[:n], axis=-1).max()) if n else 0.0
        size = (size_change(job.options.word, before=before.joints, after=first.joints)
                if job.kind.sized and job.options.word else None)
        summary = EditSummary(kind=job.label, description=job.description, before=before.name,
                              after=[a.name for a in afters], seconds_taken=result.seconds_taken, max_difference=diff,
                              size="" if size is None else size.describe())
        return Delivery(items=[*new, *afters], show=first.name, compare=before.name,
                        status=f"{job.description}: done in {result.seconds_taken:.1f} s ({job.sample.steps} steps)",
                        readout=(self.settings, {"last_edit": summary}))


@dataclass
class CountJob:
    """Count a motion without recorded maps: DDIM-invert it and record its self-attention while it is rebuilt."""

    session: object  # StudioState
    item: MotionItem
    refused: ClassVar[str] = "cannot count"

    def prepare(self, loaded) -> None:
        if self.item.n_frames < 8:
            raise ValueError("the motion is too short to count on")

    def describe(self) -> JobDescription:
        return JobDescription(what="counting", status=f"counting {self.item.name!r}: inverting the motion…",
                              verb="counting", total=1)

    def run(self, loaded, worker: Worker) -> CountReadout:
        with sampling_slot(worker.cancel, worker.waiting):
            return count_imported(loaded, self.item.joints[:196], item=self.item.name, prompt=self.item.prompt,
                                  method=self.session.count_method)

    def deliver(self, readout: CountReadout) -> Delivery:
        return Delivery(status=f"counted {self.item.name!r}: {readout.count:.2f} (baseline {readout.baseline})",
                        readout=(self.session, {"count_result": readout}))


def run_edit(session, settings: EditSettings) -> bool:
    """The Edit tab's Run: the edit (or counting) on the worker; False (and a notification) if refused."""
    if not settings.entry.is_edit:
        return count_current(session)
    return session.launch(EditJob(session=session, settings=settings))


def count_current(session) -> bool:
    """The counting readout for the shown motion: from its recorded maps (at once) or by inversion (worker)."""
    item = session.item
    if item is None:
        session.error("nothing to count: generate or import a motion first")
        return False
    if item.attention is not None:
        auto_count(session)
        return True
    return session.launch(CountJob(session=session, item=item))


def same_motion(session, title: str, joints: np.ndarray) -> MotionItem | None:
    """An item already in the list with this title and these joints (a reference re-made by another edit)."""
    for name, it in session.items.items():
        if (name == title or name.startswith(title + " (")) and it.joints.shape == joints.shape \
                and np.allclose(it.joints, joints, atol=1e-5):
            return it
    return None
