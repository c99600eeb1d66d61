"""The session core's one job runner. Every piece of work a session does (Generate, Re-record, each tab's method) is
a ``Job``, started with ``StudioState.launch(job)`` and ended the same way: the job says how its result becomes
motion items (a ``Delivery``) and the runner adds them, shows them and frees the controls. No job ends itself.

A job has four parts:

- ``prepare(loaded)`` checks the inputs before anything runs (a ``ValueError`` becomes the notice "<refused>: <why>");
- ``describe()`` says what the progress bar and the status line show (a ``JobDescription``);
- ``run(loaded, worker)`` calls the engine on the worker thread, reporting progress through the ``Worker``;
- ``deliver(result)`` turns the result into a ``Delivery`` on the session's thread: the new motions, what the viewer
  shows, the status line, and what the tab keeps of it (its readout).

``JobRun`` is one run of one job (the worker thread, its progress, its end); ``JobRunner`` is the part of
``StudioState`` that starts runs, cancels them and applies their deliveries.
"""
from __future__ import annotations

import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import param

from app.generation import Cancelled
from app.session.items import MotionItem


@runtime_checkable
class Worker(Protocol):
    """What a job's ``run`` gets: the cancel flag and three ways to report (``JobRun`` is one)."""

    cancel: threading.Event

    def step(self, done: int, total: int) -> None:
        """``done`` of ``total`` steps made; raises ``Cancelled`` once the run is cancelled."""

    def waiting(self, place: int = 1) -> None:
        """Queued behind ``place`` runs of other sessions for the sampling slot."""

    def note(self, text: str) -> None:
        """A status line for a phase without steps (e.g. inversion)."""


@dataclass(frozen=True)
class JobDescription:
    """How a prepared job shows while it runs."""

    what: str  # the job's name: the tabs' job bars report on the names they list ('generation', 'edit', ...)
    status: str  # the status line when it starts
    verb: str  # the status line's lead while it runs ("<verb>: step 3 / 50")
    total: int  # steps of the progress bar


@dataclass
class Delivery:
    """How a finished job's result becomes session motions, and what shows then (applied by the job runner).

    The runner adds ``items`` (in order; kept in the motion library together, linked to what they were made from),
    paints ``frame_colors``, shows ``show`` with ``compare`` and ``also`` beside it, ends the job with ``status``,
    sets ``readout`` and says ``notices``."""

    status: str  # the status line once done
    items: list[MotionItem] = field(default_factory=list)  # new motions (named with ``session.unique_name``)
    show: str = ""  # the motion shown ('' = the viewer stays as it is)
    compare: str = ""  # shown beside it
    also: list[str] = field(default_factory=list)  # shown after the compared one
    frame_colors: dict = field(default_factory=dict)  # motion name -> (T, 22, 3) uint8 colours, painted as shown
    color_names: dict = field(default_factory=dict)  # '#rrggbb' -> what that colour stands for (the legend)
    color_notes: dict = field(default_factory=dict)  # motion name -> what its colours mean (the viewer's title)
    renewed: str = ""  # an existing motion whose data the job replaced (Re-record): every view reads it again
    readout: tuple[param.Parameterized, dict] | None = None  # (owner, {parameter: value}): the tab's result
    notices: list[tuple[str, str]] = field(default_factory=list)  # (level, text) said once it is shown


@runtime_checkable
class Job(Protocol):
    """One run of a method, launched with ``StudioState.launch(job)``."""

    refused: str  # the lead of a refusal notice ("cannot compose")

    def prepare(self, loaded) -> None:
        """Check everything before any work starts (``loaded``: the session's model); raise ValueError to refuse."""

    def describe(self) -> JobDescription:
        """What the progress bar and the status line show (called once prepared)."""

    def run(self, loaded, worker: Worker) -> object:
        """The engine call, on the worker thread: report with ``worker.step``, stop when ``worker.cancel`` is set."""

    def deliver(self, result) -> Delivery:
        """How the result becomes motion items (on the session's thread)."""


class JobRun:
    """One run of a job: the worker thread, its progress and status lines, and its end on the session's thread.

    It is the ``Worker`` the job's ``run`` reports to; a run whose session has started another (or was cancelled)
    no longer touches the session's progress."""

    def __init__(self, session: JobRunner, job: Job, loaded, shown: JobDescription):
        self.session = session
        self.job = job
        self.loaded = loaded
        self.shown = shown
        self.cancel = threading.Event()
        self.thread = threading.Thread(target=self._work, name=f"moattn-{shown.what.split()[0]}", daemon=True)

    @property
    def current(self) -> bool:
        """Whether this is the session's running job (not a cancelled or finished one)."""
        return self.session.running and self.session.active_run is self

    # ------------------------------------------------------------------ the Worker (called on the worker thread)
    def step(self, done: int, total: int) -> None:
        if self.cancel.is_set():
            raise Cancelled()
        status = f"{self.shown.verb}: step {done} / {total}"
        # one update: the views refresh once per step
        self.session.post(lambda: self.session.param.update(progress=done, status=status) if self.current else None)

    def waiting(self, place: int = 1) -> None:
        ahead = "another session's run" if place <= 1 else f"{place} runs of other sessions"
        status = f"queued: waiting for {ahead} to finish ({self.shown.what})"
        self.session.post(lambda: setattr(self.session, "status", status))

    def note(self, text: str) -> None:
        self.session.post(lambda: setattr(self.session, "status", text) if self.current else None)

    # ------------------------------------------------------------------ the run
    def start(self) -> None:
        self.thread.start()

    def _work(self) -> None:
        """The worker thread: the job's engine call, then its result (or why there is none) posted to the session."""
        started = time.time()
        try:
            result = self.job.run(self.loaded, self)
            self.session.last_job = (started, time.time())  # wall clock (the bench compares it with the page's)
        except Cancelled:
            self.session.post(lambda: self.session.stop_job(f"{self.shown.what} cancelled", "info"))
        except Exception as exc:  # shown to the user, the server keeps running
            traceback.print_exc()
            message = f"{self.shown.what} failed: {exc}"
            self.session.post(lambda: self.session.stop_job(message, "error"))
        else:
            self.session.post(lambda: self._finish(result))

    def _finish(self, result) -> None:
        """On the session's thread: the job's delivery applied; a job whose delivery fails still frees the
        controls, and what it added is kept."""
        try:
            delivery = self.job.deliver(result)
            self.session.apply(delivery)
        except Exception as exc:  # never leave the controls locked
            traceback.print_exc()
            self.session.stop_job(f"{self.shown.what} failed: {exc}", "error")


class JobRunner(param.Parameterized):
    """The part of the session that runs its jobs, one at a time, off the UI thread (``launch``, ``cancel``,
    ``wait``) and applies what they deliver. Uses the session's ``model``, ``post``, notices, motion list and viewer
    rule."""

    running = param.Boolean(default=False)
    job = param.String(default="", doc="what the worker does ('generation', 'edit', 'counting')")
    progress = param.Integer(default=0, doc="sampling steps done")
    progress_total = param.Integer(default=1)
    status = param.String(default="", doc="one line on what is happening")

    active_run: JobRun | None = None  # the last run started (None: none yet)
    last_job: tuple[float, float] | None = None  # (start, end) of the last job that finished, wall clock

    def launch(self, job: Job) -> bool:
        """Check, then run on the worker: the one start of every job. False when refused (no model, busy, bad
        input), with a notice saying why."""
        loaded = self._idle_model()
        if loaded is None:
            return False
        try:
            job.prepare(loaded)
        except ValueError as exc:
            self.error(f"{job.refused}: {exc}")
            return False
        shown = job.describe()
        run = JobRun(self, job, loaded, shown)
        self.active_run = run
        with param.parameterized.batch_call_watchers(self):
            self.running = True
            self.job = shown.what
            self.progress = 0
            self.progress_total = max(1, int(shown.total))
            self.status = shown.status
        run.start()
        return True

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

    def cancel(self) -> None:
        if self.running and self.active_run is not None:
            self.active_run.cancel.set()
            self.status = "cancelling..."

    def wait(self, timeout: float = 120.0) -> bool:
        """Block until the worker has finished (tests); True if it did."""
        run = self.active_run
        if run is not None:
            run.thread.join(timeout)
            return not run.thread.is_alive()
        return True

    def apply(self, delivery: Delivery) -> None:
        """A finished job's motions into the session (kept in the library together), shown, and the job ended."""
        added = []
        try:
            for item in delivery.items:
                self.add_item(item, show=False, keep=False)
                added.append(item.name)
            if delivery.renewed:
                self._bound_memory(keep=delivery.renewed)
            if delivery.color_names:
                self.color_names = {**self.color_names, **delivery.color_names}
            if delivery.color_notes:
                self.color_notes = {**self.color_notes, **delivery.color_notes}
            if delivery.frame_colors:  # (the colours of motions no longer in the session go)
                self.frame_colors = {**{k: v for k, v in self.frame_colors.items() if k in self.items},
                                     **delivery.frame_colors}
            # the motions first: their scene leaves for the page before the status line, the buttons and the readout
            if delivery.show:
                with param.parameterized.batch_call_watchers(self):
                    self.show(delivery.show)
                    if delivery.compare:
                        self.compare = delivery.compare
                    if delivery.also:
                        self.also = list(delivery.also)
            self.end_job(delivery.status)
            if delivery.readout is not None:
                owner, values = delivery.readout
                owner.param.update(**values)
            for level, text in delivery.notices:
                self._notify(level, text)
            if delivery.renewed:
                self.param.trigger("current")  # the same motion, with new data: every view reads it again
        finally:
            self._keep(added)  # what the job added (even if applying it failed half-way) goes to the library

    def end_job(self, status: str) -> None:
        """The job is done: progress full, the controls free again."""
        with param.parameterized.batch_call_watchers(self):
            self.running = False
            self.preview = None
            self.progress = self.progress_total
            self.status = status

    def stop_job(self, message: str, level: str) -> None:
        """The job ended without a result (cancelled, failed): said, progress empty, the controls free again."""
        with param.parameterized.batch_call_watchers(self):
            self.running = False
            self.preview = None
            self.progress = 0
            self.status = message
        if level:
            self._notify(level, message)
