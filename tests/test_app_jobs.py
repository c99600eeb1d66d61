"""The session core's one job runner and the lazy tabs: every job is an object launched the same way (checks, then
the worker, then its result on the session's thread), and a page builds a tab's view only when it is selected."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import pytest

from app.main import TAB_VIEWS, Studio
from app.session.jobs import Delivery, Job, JobDescription, Worker
from app.session.state import StudioState
from app.tabs.compose.job import ComposeJob


@dataclass
class Counting:
    """A job that counts to ``total`` on the worker; refuses a negative total."""

    total: int
    finished: list = field(default_factory=list)
    refused: ClassVar[str] = "cannot count"

    def prepare(self, loaded) -> None:
        if self.total < 0:
            raise ValueError("a negative total")

    def describe(self) -> JobDescription:
        return JobDescription(what="counting", status="counting: 0", verb="counting", total=self.total)

    def run(self, loaded, worker: Worker) -> int:
        for k in range(self.total):
            worker.step(k + 1, self.total)
        return self.total

    def deliver(self, result) -> Delivery:
        self.finished.append(result)
        return Delivery(status=f"counted to {result}")


@pytest.fixture()
def state(tiny_model_dir):
    s = StudioState(model_dir=tiny_model_dir)
    yield s
    s.close()


def test_a_job_runs_on_the_worker_and_is_ended_by_the_runner(state):
    job = Counting(total=3)
    assert isinstance(job, Job)
    assert state.launch(job) and state.wait(30)
    assert job.finished == [3]
    # the runner ends every job the same way: its delivery's status, progress full, the controls free
    assert state.job == "counting" and state.progress == 3 and state.progress_total == 3
    assert not state.running and state.status == "counted to 3"


def test_a_refused_job_is_a_notice_and_never_runs(state):
    job = Counting(total=-1)
    assert not state.launch(job)
    assert state.notices[-1] == ("error", "cannot count: a negative total") and not state.running and not job.finished


def test_a_failing_job_says_so_and_frees_the_controls(state):
    class Broken(Counting):
        def run(self, loaded, worker):
            raise RuntimeError("disk full")

    assert state.launch(Broken(total=1)) and state.wait(30)
    assert state.notices[-1] == ("error", "counting failed: disk full") and not state.running


def test_a_page_builds_its_first_tab_and_each_other_when_selected(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        assert st.tabs.built == ["Attention"]
        # every tab's settings live on the session before (and without) its view
        assert {"edit", "transfer", "compose", "control", "duet"} <= set(st.state.tab_settings)
        compose = [title for title, _, _ in TAB_VIEWS].index("Compose")
        st.tabs.tabs.active = compose
        assert st.tabs.built == ["Attention", "Compose"]
        shown = [box.objects[0].css_classes for box in st.tabs.tabs]  # a placeholder until the view is built
        assert shown[compose] == ["compose-tab"] and shown.count(["tab-placeholder"]) == len(TAB_VIEWS) - 2
        assert st.compose.settings is st.state.tab_settings["compose"]
    finally:
        st.close()


def test_a_tabs_job_runs_without_its_view(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        s.param.update(steps=4, seed=1)
        compose = s.tab_settings["compose"]
        compose.param.update(second_take=False)
        compose.intervals = compose.intervals[:1]
        assert s.launch(ComposeJob(session=s, settings=compose)) and s.wait(120), s.notices[-1:]
        assert compose.result is not None and s.current == compose.result.name
        assert st.tabs.built == ["Attention"]
    finally:
        st.close()
