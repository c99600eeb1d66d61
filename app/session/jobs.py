"""What the session's one job runner (``StudioState.launch``) runs: a ``Job``, and what its work gets (``Worker``).

Every tab's work (generate, edit, count, transfer, compose, control, duet) is a ``Job``: ``prepare`` checks the
inputs before anything runs (a ``ValueError`` becomes the notice "<refused>: <why>"), ``describe`` says what the
progress bar shows, ``run`` does the work on the worker thread, ``finish`` takes its result on the session's thread.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable


@dataclass(frozen=True)
class Worker:
    """What a job's ``run`` gets: the cancel flag, a progress callback (raises Cancelled once cancelled), a queue
    note."""

    cancel: threading.Event
    step: Callable[[int, int], None]
    waiting: Callable[[int], None]  # called with the number of runs ahead while queued
    note: Callable[[str], None] = lambda text: None  # a status line for a phase without steps (e.g. inversion)


@dataclass(frozen=True)
class JobDescription:
    """How a prepared job shows while it runs."""

    what: str  # the job's name: the tabs' job bars report on the names they list ('generation', 'edit', ...)
    status: str  # the status line when it starts
    verb: str  # the status line's lead while it runs ("<verb>: step 3 / 50")
    total: int  # steps of the progress bar


@runtime_checkable
class Job(Protocol):
    """One run of a tab's work, launched with ``StudioState.launch(job)``."""

    refused: str  # the lead of a refusal notice ("cannot compose")

    def prepare(self, loaded) -> None:
        """Check everything before any work starts (``loaded``: the session's model); raise ValueError to refuse."""

    def describe(self) -> JobDescription:
        """What the progress bar and the status line show (called once prepared)."""

    def run(self, loaded, worker: Worker) -> object:
        """The work, on the worker thread: report with ``worker.step``, stop when ``worker.cancel`` is set."""

    def finish(self, result) -> None:
        """Take the result on the session's thread (end the job: ``StudioState.end_job``)."""
