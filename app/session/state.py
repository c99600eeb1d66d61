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
from app.session.items import MAX_ITEMS, MAX_ITEMS_WITH_ATTENTION, MotionItem  # the session core's motions
from app.session.jobs import Job, Worker
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
    items = param.Dict(default={}, doc="name -> MotionItem, in creation order")
    current = param.String(default="", doc="name of the motion shown (and whose attention is explored)")
    compare = param.String(default="", doc="name of a second motion shown side by side ('' = none)")
    also = param.List(default=[], item_type=str, doc="more motions shown side by side after the compared one "
                                                       "(e.g. a transfer's output); cleared when another is shown")
    frame_colors = param.Dict(default={}, doc="motion name -> (T, 3) uint8 colour per frame (e.g. Q/K clusters)")
    color_notes = param.Dict(default={}, doc="motion name -> what its frame colours mean (the viewer's title while "
                                             "it is shown with them)")
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

    def __init__(self, *, model_dir: str | Path | None = None, tabs: Mapping[str, SettingsFactory] | None = None,
                 **params):
        """``tabs``: name -> a factory of that tab's settings for this session; each becomes ``self.<name>`` (the
        session holds every tab's settings, built or not; the core never imports a tab)."""
        super().__init__(**params)
        self.model_dir = Path(model_dir) if model_dir is not None else None
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
        self._analyse_prompt()
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
        attention anew; False (and a notification) when it has no settings to repeat."""
        item = self.item
        if item is None or item.settings is None:
            self.error("only a motion generated in the Generate box can be re-recorded")
            return False
        s = item.settings
        self.param.update(prompt=s.prompt, seconds=s.seconds, seed=s.seed, steps=s.steps, guidance=s.guidance,
                          record_steps=max(1, s.record_steps))
        return self.generate()

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
                try:
                    on_done(result)
                except Exception as exc:  # never leave the controls locked
                    traceback.print_exc()
                    self._finish(None, f"{what} failed: {exc}", "error")
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
        """Add a motion to the session's list (oldest dropped past MAX_ITEMS) and show it."""
        items = dict(self.items)
        items[item.name] = item
        while len(items) > MAX_ITEMS:
            oldest = next(n for n in items if n not in (item.name, self.compare))
            del items[oldest]
        with_attention = [n for n, it in items.items() if it.attention is not None]
        for name in with_attention[:-MAX_ITEMS_WITH_ATTENTION]:
            items[name].attention = None  # keep memory bounded: old motions lose their maps (and say so)
            items[name].evicted = True
        with_denoising = [n for n, it in items.items() if it.denoising is not None]
        for name in with_denoising[:-MAX_ITEMS_WITH_ATTENTION]:
            items[name].denoising = None  # as bounded: the step slider is there for the newest motions
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            if self.compare and self.compare not in items:
                self.compare = ""
            if any(n not in items for n in self.also):
                self.also = [n for n in self.also if n in items]
            if show:
                self.show(item.name)

    def show(self, name: str) -> None:
        if name not in self.items:
            raise KeyError(f"no motion named {name!r}")
        item = self.items[name]
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
        """Add a plain motion (file import, example) and show it."""
        joints = np.asarray(joints, dtype=np.float32)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3) or len(joints) < 1:
            raise ValueError(f"a motion must have shape (T, 22, 3), got {joints.shape}")
        if not np.isfinite(joints).all():
            raise ValueError("the motion contains NaN or infinite values")
        item = MotionItem(name=self.unique_name(title), joints=joints, source=source)
        self.add_item(item)
        return item

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


def _content_word(words: tuple[str, ...]) -> int | None:
    """The first word that carries meaning (a verb, usually): the default highlighted word."""
    for i, w in enumerate(words):
        if w not in _FUNCTION_WORDS:
            return i
    return 0 if words else None
