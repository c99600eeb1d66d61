"""The studio shows what just happened: no comparison carried over to another job's motion, evicted attention
said and re-recordable, a finished tab's lines cleared, an idle progress bar empty (no server, a tiny model)."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from app.main import Studio
from app.session.items import MAX_ITEMS_WITH_ATTENTION
from app.tabs.edit.job import run_edit


@pytest.fixture(scope="module")
def studio(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    yield st
    st.close()


def _generate(st, prompt: str, seed: int) -> None:
    s = st.state
    s.param.update(prompt=prompt, seconds=2.0, steps=6, record_steps=3, seed=seed)
    assert s.generate() and s.wait(120), s.notices[-1:]


def test_a_new_result_is_not_compared_with_an_older_jobs_motion(studio):
    s = studio.state
    _generate(studio, "a person walks forward", 1)
    first = s.current
    _generate(studio, "a person jumps twice", 2)
    s.compare = first  # the user compares the two
    assert len(studio.viewer.spec().motions) == 2
    _generate(studio, "a person waves", 3)  # a new result: shown alone
    assert s.compare == "" and s.also == [] and len(studio.viewer.spec().motions) == 1
    s.compare = first
    s.show(first)  # the user picks another motion: nothing is carried over either
    assert s.compare == ""


def test_evicted_attention_is_said_and_re_recorded_with_the_same_motion(studio):
    s, view = studio.state, studio.attention
    _generate(studio, "a person kicks", 11)
    oldest = s.current
    joints = s.item.joints.copy()
    for k in range(MAX_ITEMS_WITH_ATTENTION):
        _generate(studio, "a person claps", 20 + k)
    s.show(oldest)
    item = s.item
    assert item.attention is None and item.evicted
    assert "dropped to keep memory bounded" in view.info.object and view.rerecord.visible
    s.param.update(seed=99, steps=8)  # other settings in the boxes: Re-record restores the motion's own
    view.rerecord.clicks += 1
    assert s.wait(120)
    assert studio.controls.seed.value == 11 and studio.controls.steps.value == 6  # the boxes show what ran
    again = s.item
    assert again.attention is not None and again.prompt == "a person kicks"
    np.testing.assert_allclose(again.joints, joints, atol=1e-5)  # the same settings and seed: the same motion
    assert not view.rerecord.visible and "dropped" not in view.info.object


def test_imported_motions_say_why_they_have_no_attention(studio, real_joints):
    s, view = studio.state, studio.attention
    s.show_motion(real_joints[:60], title="imported: walk")
    assert "it was imported" in view.info.object and not view.rerecord.visible


def test_idle_bars_are_empty_and_a_kind_switch_clears_the_last_edit(studio):
    s, edit = studio.state, studio.edit
    _generate(studio, "a person jumps twice", 5)
    assert studio.controls.progress.value == 0 and studio.controls.progress.max == 6 * s.tries  # steps x tries
    edit.kind.value = "emphasise"
    edit.words.value = 2
    assert run_edit(s, edit.settings) and s.wait(120)
    assert edit.result.object and edit.status.object
    edit.kind.value = "replace"
    assert edit.result.object == "" and edit.status.object == ""
    assert edit.progress.value == 0


class _Doc:
    """A served document's stand-in: it records the thread each callback is added from, and runs it."""

    class session_context:  # noqa: N801 - the attribute Bokeh's Document has
        session = None

    def __init__(self):
        self.added_from: list[int] = []

    def add_next_tick_callback(self, callback):
        self.added_from.append(threading.get_ident())
        callback()


def test_work_posted_from_a_worker_thread_reaches_the_document_on_its_loop():
    """Bokeh's document is not thread-safe while held (its held events are read and cleared without a lock), so a
    result posted from a worker thread must be added to it on the server's loop thread, never from the worker."""
    import asyncio

    from app.session.state import StudioState

    state, doc, ready, ran = StudioState(), _Doc(), threading.Event(), threading.Event()
    server: dict = {}

    async def serve():  # the server's loop: the page (and its state) is built on it
        server["loop"], server["stop"] = asyncio.get_running_loop(), asyncio.Event()
        server["thread"] = threading.get_ident()
        state.attach_document(doc)
        ready.set()
        await server["stop"].wait()

    loop_thread = threading.Thread(target=lambda: asyncio.run(serve()), daemon=True)
    loop_thread.start()
    assert ready.wait(10)
    try:
        worker = threading.Thread(target=lambda: state.post(ran.set))
        worker.start()
        worker.join(10)
        assert ran.wait(10), "the posted work never ran"
        assert doc.added_from == [server["thread"]]
        state.post(lambda: None)  # from yet another thread (the test's): also through the loop
        deadline = time.monotonic() + 10
        while len(doc.added_from) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert doc.added_from == [server["thread"]] * 2
    finally:
        server["loop"].call_soon_threadsafe(server["stop"].set)
        loop_thread.join(10)
