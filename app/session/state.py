"""One browser session's state: the sampling settings every tab uses, the one job runner (``launch``), the motions
and what the viewer shows (current / compare / also), the attention selection, and each tab's settings.

Every session gets its own ``StudioState``; only the loaded model (read-only) is shared between
sessions. Work that takes time (sampling) runs on a worker thread and *posts* its results back
with :meth:`StudioState.post`, which runs them on the session's document thread when served (or
directly in tests), so parameters are only ever changed from one thread at a time.
"""
from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import param

from app.attention_record import AttentionRecord
from app.generation import Cancelled, GenerationResult, GenerationSettings, PromptReading, prompt_analysis
from app.session.counting import auto_count
from app.session.generation import GenerateJob
from app.session.items import MAX_ITEMS_WITH_ATTENTION, MAX_LOADED_ITEMS, MotionItem  # the session core's motions
from app.session.library import KIND_LABELS, item_from_entry, item_kind, job_parents, recipe_of
from app.session.jobs import Job, Worker
from engine.analysis.counting import COUNTING_LABELS, COUNTING_METHODS, CountingConfig
from engine.duration import resolve_seconds
from engine.units import DEFAULT_GUIDANCE, MAX_SECONDS, MIN_SECONDS

#: a tab's settings made for one session (``StudioState(tabs={"compose": ComposeSettings.for_session, ...})``)
SettingsFactory = Callable[["StudioState"], param.Parameterized]


@dataclass(frozen=True, eq=False)
class Preview:
    """The running generation's current x̂0 motion (what the viewer shows live while sampling)."""

    step: int  # sampling steps done
    num_steps: int
    joints: np.ndarray  # (T, 22, 3)
    title: str


class StudioState(param.Parameterized):
    """Everything a session's views read; each browser session gets its own instance."""

    # ---- generation inputs
    prompt = param.String(default="a person jumps twice", doc="what to generate")
    seconds = param.Number(default=None, allow_None=True, step=0.5,
                           doc=f"duration in seconds ({MIN_SECONDS:g} to {MAX_SECONDS:g}); empty: predicted from the prompt (auto)")
    seed = param.Integer(default=0, softbounds=(0, None), doc="noise seed (same seed, same motion)")
    steps = param.Integer(default=50, bounds=(1, 1000), doc="sampling steps (DDIM)")
    guidance = param.Number(default=DEFAULT_GUIDANCE, bounds=(0.0, 20.0), step=0.5,
                            doc="classifier-free guidance scale")
    record_steps = param.Integer(default=10, bounds=(0, 1000), label="Recorded steps",
                                 doc="sampling steps whose attention is recorded (0 = none)")

    # ---- derived from the prompt
    prompt_words = param.List(default=[], doc="words of the prompt")
    reading = param.ClassSelector(class_=PromptReading, default=PromptReading(),
                                  doc="the prompt as the engine will read it (its notes, or why it refuses it)")

    # ---- generation progress
    running = param.Boolean(default=False)
    job = param.String(default="", doc="what the worker does ('generation', 'edit', 'counting')")
    progress = param.Integer(default=0, doc="sampling steps done")
    progress_total = param.Integer(default=1)
    status = param.String(default="", doc="one line on what is happening")
    notice = param.Tuple(default=(0, "", ""), length=3, doc="(serial, level, text) of the last notification")

    # ---- motions
    items = param.Dict(default={}, doc="name -> MotionItem, in creation order (with a library: all its motions)")
    motion_search = param.String(default="", label="Search", doc="the Motion list shows motions whose prompt or "
                                 "name has every word typed here")
    motion_kind = param.Selector(default="", objects={v: k for k, v in KIND_LABELS.items()}, label="Kind",
                                 doc="the Motion list shows motions of this kind")
    library_status = param.String(default="", doc="one line on the motion library (motions, size of its bound, "
                                                  "folder); empty without a library")
    current = param.String(default="", doc="name of the motion shown (and whose attention is explored)")
    compare = param.String(default="", doc="name of a second motion shown side by side ('' = none)")
    also = param.List(default=[], item_type=str, doc="more motions shown side by side after the compared one "
                                                       "(e.g. a transfer's output); cleared when another is shown")
    frame_colors = param.Dict(default={}, doc="motion name -> (T, 3) uint8 colour per frame (e.g. Q/K clusters)")
    color_notes = param.Dict(default={}, doc="motion name -> what its frame colours mean (the viewer's title while "
                                             "it is shown with them)")
    color_names = param.Dict(default={}, doc="'#rrggbb' -> what that frame colour stands for, set by the tab that "
                                             "paints it (the viewer's legend names its swatches by it)")
    preview = param.ClassSelector(class_=Preview, default=None, allow_None=True,
                                  doc="the running generation's x̂0 motion (None: no live preview)")
    frame = param.Integer(default=0, bounds=(0, None), doc="the playhead")
    cursor_ids = param.List(default=[], item_type=str,
                            doc="Bokeh models (frame cursors, e.g. a Span) whose location the page moves with the "
                                "playhead while it plays (see follow_playhead)")
    playing = param.Boolean(default=False, doc="the browser is playing the motion")

    # ---- viewer settings
    follow = param.Boolean(default=True, doc="camera follows the pelvis")
    show_path = param.Boolean(default=True, doc="draw the root path on the floor")

    # ---- attention selection (None = mean)
    layer = param.Integer(default=None, allow_None=True, doc="layer of the self-attention map (None = mean)")
    head = param.Integer(default=None, allow_None=True, doc="head (None = mean of heads)")
    att_step = param.Integer(default=None, allow_None=True, doc="recorded sampling step (None = mean)")
    word = param.Integer(default=None, allow_None=True, doc="highlighted word (token index)")
    color_by_word = param.Boolean(default=False, doc="colour the skeleton by the highlighted word's attention")
    count_result = param.Parameter(default=None, doc="CountReadout of the shown motion (or None): counted from its "
                                                     "recorded maps as it is shown, or by the Edit tab's Count")
    count_method = param.Selector(default=CountingConfig.method,
                                  objects={COUNTING_LABELS[m]: m for m in COUNTING_METHODS}, label="Counting method",
                                  doc="how a self-attention map becomes a count (engine.analysis.counting)")

    def __init__(self, *, model_dir: str | Path | None = None, tabs: Mapping[str, SettingsFactory] | None = None,
                 library=None, **params):
        """``tabs``: name -> a factory of that tab's settings for this session; each becomes ``self.<name>`` (the
        session holds every tab's settings, built or not; the core never imports a tab).

        ``library``: the motion library (an ``engine.library.MotionLibrary``; None: motions live only as long as
        the session): every motion added is kept there, and the session starts with all of its motions."""
        super().__init__(**params)
        self.model_dir = Path(model_dir) if model_dir is not None else None
        self.library = library
        self._job_added: list[str] | None = None  # names added by the finishing job (kept when it is done)
        self._doc = None
        self._worker: threading.Thread | None = None
        self._cancel = threading.Event()
        self._counter = 0
        self.last_job: tuple[float, float] | None = None  # (start, end) of the last job that finished, wall clock
        self.notices: list[tuple[str, str]] = []  # history (level, text), newest last
        self._closed = False
        self._page_seen = False  # a page has been connected to this session (see _page_gone)
        self.param.watch(self._analyse_prompt, "prompt")
        # counted after the new motion has reached the page (served: the next tick), not before its scene
        self.param.watch(lambda *_: self.post(lambda: auto_count(self)), "current")
        self.param.watch(lambda *_: self.post(lambda: auto_count(self)), "count_method")
        self.param.watch(self._check_compared, ["compare", "also"])
        self._analyse_prompt()
        if self.library is not None:
            self.library.report = lambda line: self.post(lambda: self.warning(line))
            for problem in list(self.library.problems):  # found as it opened (an unusable index set aside)
                self.warning(str(problem))
            self.library.check()  # damaged or foreign entries: one line each, skipped
            self.sync_library()
        self.tab_settings: dict[str, param.Parameterized] = {}
        for name, make in (tabs or {}).items():
            if hasattr(self, name):
                raise ValueError(f"a tab's settings cannot be named {name!r}: the session has that name")
            self.tab_settings[name] = make(self)
            setattr(self, name, self.tab_settings[name])

    # ------------------------------------------------------------------ threading
    def attach_document(self, doc) -> None:
        """Bind the session's Bokeh document: posted callbacks then run on its event loop."""
        self._doc = doc

    @property
    def served(self) -> bool:
        """Whether this session has a live document (a browser page), so that work may leave its thread."""
        return self._doc is not None and self._doc.session_context is not None

    def post(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the session's document thread (served) or right away (no server); dropped once the
        session is closed (its document is gone: a late worker result must not touch it)."""
        if self._closed:
            return
        doc = self._doc
        if doc is None or doc.session_context is None:
            fn()
            return
        from panel.io.state import set_curdoc

        def run():
            if self._page_gone(doc):
                return  # its page was closed or reloaded: nobody to show it to (Bokeh would warn on every send)
            with set_curdoc(doc):
                try:
                    fn()
                except Exception as exc:  # never let a UI update kill the loop
                    traceback.print_exc()
                    self._notify("error", f"internal error: {exc}")

        try:
            doc.add_next_tick_callback(run)
        except Exception:  # the session is gone
            pass

    def _page_gone(self, doc) -> bool:
        """Whether the session's page has been connected and is no more (its session lingers until discarded).

        A page being built has no connection yet: what is posted then is part of what it will receive."""
        context = doc.session_context
        session = None if context is None else context.session
        if session is None:
            return False
        if session.connection_count > 0:
            self._page_seen = True
            return False
        return self._page_seen

    # ------------------------------------------------------------------ model
    @property
    def model(self):
        """The shared, read-only loaded model (raises if there is none)."""
        from app.model_cache import get_model

        if self.model_dir is None:
            raise FileNotFoundError("no model folder was given")
        return get_model(self.model_dir)

    @property
    def has_model(self) -> bool:
        try:
            self.model
            return True
        except Exception:
            return False

    @property
    def vocabulary(self) -> tuple[str, ...]:
        try:
            return self.model.tokenizer.words[1:]
        except Exception:
            return ()

    def tokenizer(self):
        try:
            return self.model.tokenizer
        except Exception:
            return None

    def _analyse_prompt(self, *_):
        tokenizer = self.tokenizer()
        reading = prompt_analysis(tokenizer, self.prompt)
        with param.parameterized.batch_call_watchers(self):
            self.prompt_words = list(reading.words)
            self.reading = reading

    def replace_word(self, old: str, new: str) -> None:
        """Swap a left-out word for a suggestion (whole words, case-insensitive); a '~adverb' suggestion moves to
        the end of the word's clause (engine.wordforms.rewrite)."""
        from engine.wordforms import rewrite

        self.prompt = rewrite(self.prompt, old, new)

    # ------------------------------------------------------------------ notifications
    def _notify(self, level: str, text: str) -> None:
        self._counter += 1
        self.notices.append((level, text))
        del self.notices[:-50]
        self.notice = (self._counter, level, text)

    def error(self, text: str) -> None:
        self._notify("error", text)

    def warning(self, text: str) -> None:
        self._notify("warning", text)

    def info(self, text: str) -> None:
        self._notify("info", text)

    # ------------------------------------------------------------------ generation
    def _idle_model(self):
        """The loaded model when no job is running; else None after telling the user why."""
        if self.running:
            self.error(f"a {self.job or 'job'} is already running: wait for it or press Cancel")
            return None
        try:
            return self.model
        except Exception as exc:
            self.error(f"no model loaded: {exc}")
            return None

    def settings(self) -> GenerationSettings:
        return GenerationSettings(prompt=self.prompt, seconds=self.seconds, seed=self.seed, steps=self.steps,
                                  guidance=self.guidance, record_steps=self.record_steps)

    def generate(self) -> bool:
        """Check the inputs and start sampling on a worker thread; False (and a notification) if refused."""
        return self.launch(GenerateJob(settings=self.settings(), deliver=lambda result: self._finish(result, "", ""),
                                       on_preview=self._preview))

    def _preview(self, done: int, total: int, joints: np.ndarray, title: str) -> None:
        """The running generation's x̂0 after ``done`` steps (from its worker): shown live by the viewer."""
        self.post(lambda: setattr(self, "preview", Preview(step=done, num_steps=total, joints=joints, title=title))
                  if self.running else None)

    def duration(self) -> float:
        """The Generate box's length in seconds: as typed, or predicted from the prompt when the box is empty."""
        return resolve_seconds(self.seconds, self.prompt)

    def rerecord(self) -> bool:
        """Generate the shown motion again with its own settings (same seed: the same motion) to record its
        attention anew, and show that motion with it; False (and a notification) when it has no settings to
        repeat."""
        item = self.item
        if item is None or item.settings is None:
            self.error("only a motion generated in the Generate box can be re-recorded")
            return False
        s = item.settings
        self.param.update(prompt=s.prompt, seconds=s.seconds, seed=s.seed, steps=s.steps, guidance=s.guidance,
                          record_steps=max(1, s.record_steps))
        name = item.name
        return self.launch(GenerateJob(settings=self.settings(), on_preview=self._preview,
                                       deliver=lambda result: self._rerecorded(name, result)))

    def _rerecorded(self, name: str, result: GenerationResult) -> None:
        """Re-record's result: the attention goes to the motion it was asked for (which is shown again); if the
        model now makes another motion from the same recipe, that one is added beside it, and said."""
        item = self.items.get(name)
        same = False
        if item is not None:
            try:
                old = item.joints
                same = old.shape == result.joints.shape and float(np.abs(old - result.joints).max()) <= 1e-3
            except ValueError:  # its joints are gone from the library: the new motion takes its place
                same = False
        if not same:
            self._finish(result, "", "")
            if item is not None:
                self.warning(f"{name!r} was re-generated from its recipe, but this model makes another motion from "
                             f"it (another model, or changed weights): shown as a new motion, the kept one is "
                             f"unchanged")
            return
        with param.parameterized.batch_call_watchers(self):
            item.joints = np.asarray(result.joints, dtype=np.float32)
            item.attention = result.attention
            item.denoising = result.denoising
            item.words = result.words
            item.features = result.features
            item.evicted = False
            item.from_library = False
            item.info = {**item.info, "seconds_taken": result.seconds_taken, "followed": result.followed,
                         "notes": tuple(result.notes)}
            self._bound_memory(keep=name)
            self.running = False
            self.preview = None
            self.progress = self.progress_total
            self.status = f"{name!r}: attention re-recorded in {result.seconds_taken:.1f} s ({result.settings.steps} steps)"
            self.show(name)
        self.param.trigger("current")  # the same motion, with maps now: every view reads it again

    def launch(self, job: Job) -> bool:
        """Check, then run on the worker: the one start of every tab's job (app.session.jobs.Job).

        ``job.prepare(loaded)`` checks (a ValueError becomes the notification "<job.refused>: <why>");
        ``job.run(loaded, worker)`` does the work; ``job.finish(result)`` takes its result on the session's
        thread. False when refused (no model, busy, bad input).
        """
        loaded = self._idle_model()
        if loaded is None:
            return False
        try:
            job.prepare(loaded)
        except ValueError as exc:
            self.error(f"{job.refused}: {exc}")
            return False
        shown = job.describe()
        return self.start_job(lambda worker: job.run(loaded, worker), on_done=job.finish, total=shown.total,
                              what=shown.what, status=shown.status, verb=shown.verb)

    def start_job(self, work: Callable[[Worker], object], *, on_done: Callable[[object], None], total: int,
                  what: str, status: str, verb: str) -> bool:
        """Run ``work(job)`` on a worker thread with progress and cancel: the worker half of :meth:`launch`, through
        which every job starts.

        ``work`` reports with ``job.step(done, total)``, checks ``job.cancel`` (or raises
        :class:`Cancelled`) and may call ``job.waiting()`` while it queues for the sampling slot.
        Its result goes to ``on_done`` on the session's thread; a cancel or an error becomes a
        notification ("<what> cancelled" / "<what> failed: ...").
        """
        if self.running:
            self.error(f"a {self.job or 'job'} is already running: wait for it or press Cancel")
            return False
        self._cancel = threading.Event()
        cancel = self._cancel
        with param.parameterized.batch_call_watchers(self):
            self.running = True
            self.job = what
            self.progress = 0
            self.progress_total = max(1, int(total))
            self.status = status

        def on_step(done: int, total: int) -> None:
            if cancel.is_set():
                raise Cancelled()

            def show():
                if cancel is self._cancel and self.running:  # one update: the views refresh once per step
                    self.param.update(progress=done, status=f"{verb}: step {done} / {total}")
            self.post(show)

        def on_wait(place: int = 1) -> None:
            ahead = "another session's run" if place <= 1 else f"{place} runs of other sessions"
            self.post(lambda: setattr(self, "status", f"queued: waiting for {ahead} to finish ({what})"))

        def note(text: str) -> None:
            self.post(lambda: setattr(self, "status", text) if cancel is self._cancel and self.running else None)

        job = Worker(cancel=cancel, step=on_step, waiting=on_wait, note=note)

        def work_thread() -> None:
            started = time.time()
            try:
                result = work(job)
                self.last_job = (started, time.time())  # wall clock (the bench compares it with the page's)
            except Cancelled:
                self.post(lambda: self._finish(None, f"{what} cancelled", "info"))
                return
            except Exception as exc:  # shown to the user, the server keeps running
                traceback.print_exc()
                message = f"{what} failed: {exc}"
                self.post(lambda: self._finish(None, message, "error"))
                return
            def deliver() -> None:
                self._job_added = []
                try:
                    on_done(result)
                except Exception as exc:  # never leave the controls locked
                    traceback.print_exc()
                    self._finish(None, f"{what} failed: {exc}", "error")
                finally:
                    added, self._job_added = self._job_added, None
                    self._keep(added)  # what the job added (even if its finish failed half-way) goes to the library
            self.post(deliver)

        self._worker = threading.Thread(target=work_thread, name=f"moattn-{what.split()[0]}", daemon=True)
        self._worker.start()
        return True

    def cancel(self) -> None:
        if self.running:
            self._cancel.set()
            self.status = "cancelling..."

    def wait(self, timeout: float = 120.0) -> bool:
        """Block until the worker has finished (tests); True if it did."""
        worker = self._worker
        if worker is not None:
            worker.join(timeout)
            return not worker.is_alive()
        return True

    def end_job(self, status: str) -> None:
        """The worker's result has arrived: progress full, the controls free again."""
        with param.parameterized.batch_call_watchers(self):
            self.running = False
            self.progress = self.progress_total
            self.status = status

    def _finish(self, result: GenerationResult | None, message: str, level: str) -> None:
        if result is not None:
            # the motion first: its scene leaves for the page before the status line and the buttons change
            s = result.settings
            self.add_item(MotionItem(name=self.unique_name(f"{s.prompt} · seed {s.seed}"), joints=result.joints,
                                     source="generated", prompt=s.prompt, words=result.words,
                                     attention=result.attention, features=result.features, settings=s,
                                     denoising=result.denoising,
                                     info={"seconds_taken": result.seconds_taken, "followed": result.followed,
                                           "notes": tuple(result.notes)}))
        with param.parameterized.batch_call_watchers(self):
            self.running = False
            self.preview = None
            if result is None:
                self.progress = 0
                self.status = message
            else:
                self.progress = self.progress_total
                s = result.settings
                auto = " (length from the prompt)" if s.seconds is None else ""
                self.status = (f"{s.prompt!r}: {len(result.joints)} frames{auto} in {result.seconds_taken:.1f} s "
                               f"({s.steps} steps)")
        if result is None and level:
            self._notify(level, message)

    # ------------------------------------------------------------------ motions
    def unique_name(self, base: str) -> str:
        name, k = base, 2
        while name in self.items:
            name, k = f"{base} ({k})", k + 1
        return name

    def add_item(self, item: MotionItem, *, show: bool = True) -> None:
        """Add a motion to the session's list and show it; with a library it is kept there too (a job's motions
        once its finish has added them all, so that their links are known; others at once). Nothing is dropped:
        memory stays bounded because old motions let go of their attention maps (and say so) and library motions
        of their joints (read again when used)."""
        items = dict(self.items)
        items[item.name] = item
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            self._bound_memory(keep=item.name)
            if show:
                self.show(item.name)
        if self._job_added is not None:
            self._job_added.append(item.name)
        else:
            self._keep([item.name])

    def _bound_memory(self, *, keep: str = "") -> None:
        """Old motions lose their recorded maps and denoising steps; library motions not shown let go of their
        joints past MAX_LOADED_ITEMS."""
        items = self.items

        def oldest_past_bound(attr: str) -> list[str]:
            """Names holding ``attr`` beyond the newest MAX_ITEMS_WITH_ATTENTION (``keep`` counted first)."""
            have = [n for n, it in items.items() if getattr(it, attr) is not None]
            kept = ([keep] if keep in have else [])
            kept += [n for n in have if n != keep][::-1][:MAX_ITEMS_WITH_ATTENTION - len(kept)]
            return [n for n in have if n not in kept]

        for name in oldest_past_bound("attention"):
            items[name].attention = None  # keep memory bounded: old motions lose their maps (and say so)
            items[name].evicted = True
        for name in oldest_past_bound("denoising"):
            items[name].denoising = None  # as bounded: the step slider is there for the newest motions
        shown = {keep, self.current, self.compare, *self.also}
        loaded = [it for n, it in items.items() if it.loaded and it.loader is not None and n not in shown]
        for it in loaded[:max(0, len(loaded) - MAX_LOADED_ITEMS)]:
            it.release()

    def show(self, name: str) -> None:
        if name not in self.items:
            raise KeyError(f"no motion named {name!r}")
        item = self.items[name]
        if not self._readable(item):
            return
        with param.parameterized.batch_call_watchers(self):
            # another motion shown: nothing is compared with it until its job (or the user) says so
            if name != self.current or self.compare == name:
                self.compare = ""
            self.also = []
            self.frame = 0
            self.word = None
            if item.attention is not None:
                self.att_step = item.attention.steps[-1]
                if self.layer is not None and self.layer >= item.attention.n_layers:
                    self.layer = None
                if self.head is not None and self.head >= item.attention.n_heads:
                    self.head = None
                self.word = _content_word(item.words)
            self.current = name

    def show_motion(self, joints: np.ndarray, *, title: str, source: str = "imported") -> MotionItem:
        """Add a plain motion (file import, example) and show it; the same file imported again (the same joints
        and title) shows the motion the library keeps for it instead of a copy."""
        joints = np.asarray(joints, dtype=np.float32)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3) or len(joints) < 1:
            raise ValueError(f"a motion must have shape (T, 22, 3), got {joints.shape}")
        if not np.isfinite(joints).all():
            raise ValueError("the motion contains NaN or infinite values")
        if self.library is not None and source == "imported":
            known = self._library_twin(joints, title)
            if known is not None:
                self.show(known.name)
                return known
        item = MotionItem(name=self.unique_name(title), joints=joints, source=source)
        self.add_item(item)
        return item

    # ------------------------------------------------------------------ the motion library
    def _library_twin(self, joints: np.ndarray, title: str) -> MotionItem | None:
        """The session motion of the import the library keeps with these joints and this title, if any."""
        try:
            ids = {e.id for e in self.library.find(joints, kind="import") if e.title == title}
        except Exception:
            return None
        if not ids:
            return None
        self.sync_library()
        for item in self.items.values():
            if item.library_id in ids:
                try:
                    self.library.touch(item.library_id)  # re-made: the bound counts it as new
                except Exception:
                    pass
                return item
        return None

    def _keep(self, names: list[str]) -> None:
        """Keep these session motions (added together by one job, or one at a time) in the library, linked to
        the motions they were made from; say when the bound removed older ones."""
        if self.library is None or not names:
            return
        added = [self.items[n] for n in names if n in self.items and self.items[n].library_id is None]
        parents = job_parents(added, self.items, compare=self.compare)
        evicted = []
        for item in added:
            ids = [self.items[p].library_id for p in parents.get(item.name, ()) if p in self.items]
            try:
                done = self.library.add(item.joints, kind=item_kind(item), title=item.name, features=item.features,
                                        recipe=recipe_of(item, model_dir=self.model_dir),
                                        parents=[i for i in ids if i])
            except Exception as exc:  # a full disk, a read-only workspace: the session keeps it, says why
                traceback.print_exc()
                self.error(f"{item.name!r} was not kept in the motion library: {exc}")
                continue
            item.library_id = done.entry.id
            item.kind = done.entry.kind
            item.loader = lambda library=self.library, entry_id=done.entry.id: library.joints(entry_id)
            evicted += done.evicted
            if done.over_limit:
                self.warning(f"the motion library is over its {done.limit_bytes / 2**20:g} MB bound "
                             f"({done.total_bytes / 2**20:.1f} MB): pinned motions are never removed")
        if evicted:
            gone = [e.title for e in evicted]
            self.warning(f"the motion library reached its {self.library.limit_mb:g} MB bound: removed the "
                         f"{len(gone)} least recently made unpinned motion{'s' if len(gone) != 1 else ''} "
                         f"({', '.join(repr(t[:40]) for t in gone[:3])}{' ...' if len(gone) > 3 else ''}). "
                         f"Pin a motion to keep it.")
        self.sync_library()

    def sync_library(self) -> None:
        """Bring the session's motions in line with the library: motions kept by other sessions (or the CLI) are
        added, motions removed there (deleted, or past the bound) are dropped unless shown."""
        if self.library is None:
            return
        try:
            entries = self.library.entries()
            total = self.library.total_bytes()
        except Exception as exc:
            traceback.print_exc()
            self.error(f"the motion library cannot be read: {exc}")
            return
        present = {e.id for e in entries}
        items = dict(self.items)
        shown = {self.current, self.compare, *self.also}
        changed = False
        for name, it in list(items.items()):
            if it.library_id and it.library_id not in present:
                changed = True
                if name in shown and it.loaded:
                    it.library_id, it.loader = None, None  # still shown: it stays, no longer kept
                else:
                    del items[name]
        by_id = {it.library_id: it for it in items.values() if it.library_id}
        for entry in entries:
            it = by_id.get(entry.id)
            if it is None:
                name = _unique(entry.title, items)
                items[name] = item_from_entry(self.library, entry, name)
                changed = True
            elif it.pinned != entry.pinned:
                it.pinned = entry.pinned  # pinned or unpinned elsewhere
                changed = True
        with param.parameterized.batch_call_watchers(self):
            if changed:
                self.items = items
            self.library_status = (f"{len(entries)} motion{'s' if len(entries) != 1 else ''} kept, "
                                   f"{total / 2**20:.1f} of {self.library.limit_mb:g} MB, in "
                                   f"{_home_relative(self.library.root)}")

    def listed_names(self) -> list[str]:
        """The motions the Motion list shows: every motion matching the search words and the kind, oldest first
        (the shown one always)."""
        words = self.motion_search.lower().split()
        kind = self.motion_kind
        out = []
        for name, it in self.items.items():
            if kind and item_kind(it) != kind and name != self.current:
                continue
            text = f"{name} {it.prompt}".lower()
            if any(w not in text for w in words) and name != self.current:
                continue
            out.append(name)
        return out

    def delete_motion(self, name: str) -> bool:
        """Delete a motion from the session and the library; another motion is shown if it was. False (and a
        notification) if there is no such motion."""
        item = self.items.get(name)
        if item is None:
            self.error(f"no motion named {name!r} to delete")
            return False
        if self.library is not None and item.library_id:
            try:
                self.library.remove([item.library_id])
            except Exception as exc:
                self.error(f"{name!r} could not be deleted from the motion library: {exc}")
                return False
        items = {n: it for n, it in self.items.items() if n != name}
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            if self.compare == name:
                self.compare = ""
            if name in self.also:
                self.also = [n for n in self.also if n != name]
            self.frame_colors = {k: v for k, v in self.frame_colors.items() if k != name}
            if self.current == name:
                rest = [n for n in self.listed_names() if n != name] or list(items)
                if rest:
                    self.show(rest[-1])
                else:
                    self.current = ""
        self.info(f"deleted {name!r}")
        self.sync_library()
        return True

    def pin_motion(self, name: str, pinned: bool = True) -> bool:
        """Pin a motion (kept whatever the library's bound) or unpin it."""
        item = self.items.get(name)
        if item is None or self.library is None or not item.library_id:
            self.error("only a motion kept in the library can be pinned")
            return False
        try:
            self.library.pin(item.library_id, pinned)
        except Exception as exc:
            self.error(f"{name!r} could not be {'pinned' if pinned else 'unpinned'}: {exc}")
            return False
        item.pinned = bool(pinned)
        self.param.trigger("items")
        return True

    def _readable(self, item: MotionItem) -> bool:
        """Whether the motion's joints can be had (a library motion is read now); if not, it is reported, taken off
        the list, and False."""
        if item.loaded or item.loader is None:
            return True
        try:
            item.joints
            return True
        except Exception as exc:
            self.error(f"{item.name!r} cannot be shown: {exc}")
            self.items = {n: it for n, it in self.items.items() if it is not item}
            return False

    def _check_compared(self, *_):
        """A motion chosen for comparison is read now (a damaged one is said and not compared)."""
        for name in [self.compare, *self.also]:
            item = self.items.get(name)
            if item is not None and not self._readable(item):
                if self.compare == name:
                    self.compare = ""
                if name in self.also:
                    self.also = [n for n in self.also if n != name]

    @property
    def item(self) -> MotionItem | None:
        return self.items.get(self.current)

    @property
    def compare_item(self) -> MotionItem | None:
        return self.items.get(self.compare) if self.compare else None

    @property
    def joints(self) -> np.ndarray | None:
        item = self.item
        return None if item is None else item.joints

    @property
    def shown_items(self) -> list[MotionItem]:
        """The motions side by side in the viewer: the current one, the compared one, then ``also``."""
        item = self.item
        if item is None:
            return []
        names = [self.compare, *self.also] if self.compare else list(self.also)
        return [item, *(self.items[n] for n in dict.fromkeys(names) if n in self.items and n != item.name)]

    @property
    def n_frames(self) -> int:
        return max((it.n_frames for it in self.shown_items), default=0)

    @property
    def attention(self) -> AttentionRecord | None:
        item = self.item
        return None if item is None else item.attention

    def selection(self) -> dict:
        return {"step": self.att_step, "layer": self.layer, "head": self.head}

    def follow_playhead(self, cursor) -> None:
        """A view's frame cursor (a Bokeh model with a ``location``) follows playback in the page itself; the
        server's ``frame`` changes only when playback stops."""
        if cursor.id not in self.cursor_ids:
            self.cursor_ids = [*self.cursor_ids, cursor.id]

    def pick_frame(self, frame: int) -> None:
        """Move the playhead (from a click in an attention view)."""
        n = self.n_frames
        if n:
            self.frame = int(np.clip(frame, 0, n - 1))

    def word_values(self) -> np.ndarray | None:
        """Per-frame attention of the highlighted word for the current motion, or None."""
        record = self.attention
        if record is None or self.word is None or self.word >= len(record.words):
            return None
        sel = self.selection()
        sel["layer"] = None  # colouring uses the mean over layers (and the chosen step/head)
        return record.word_curve(self.word, **sel)

    def close(self) -> None:
        """The session ended: stop the worker."""
        self._closed = True
        self._cancel.set()


_FUNCTION_WORDS = {"a", "an", "the", "person", "man", "woman", "someone", "is", "and", "then", "while", "his",
                   "her", "their", "with", "in", "on", "of", "to", "at", "by", "like"}


def _home_relative(path: Path) -> str:
    """``path`` with the home folder written ~ (the status line stays short)."""
    try:
        return "~/" + str(Path(path).resolve().relative_to(Path.home().resolve()))
    except (ValueError, OSError, RuntimeError):
        return str(path)


def _unique(base: str, taken) -> str:
    name, k = base, 2
    while name in taken:
        name, k = f"{base} ({k})", k + 1
    return name


def _content_word(words: tuple[str, ...]) -> int | None:
    """The first word that carries meaning (a verb, usually): the default highlighted word."""
    for i, w in enumerate(words):
        if w not in _FUNCTION_WORDS:
            return i
    return 0 if words else None
