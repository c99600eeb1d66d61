"""Sessions queue for the one sampling slot first come, first served; each hears its place; a cancelled (or
closed) session's job leaves the queue at once."""
from __future__ import annotations

import threading
import time

import pytest

from app.generation import Cancelled, sampling_slot
from app.model_cache import SAMPLING_SLOT, SamplingQueue


def test_waiters_are_served_in_order_and_told_their_place():
    queue = SamplingQueue()
    assert queue.acquire(cancelled=lambda: False)  # the running job
    order, places = [], {}
    threads = []
    for name in "abc":
        places[name] = []

        def wait(name=name):
            assert queue.acquire(cancelled=lambda: False, on_place=places[name].append)
            order.append(name)
            time.sleep(0.05)
            queue.release()

        t = threading.Thread(target=wait)
        t.start()
        threads.append(t)
        while queue.waiting < len(threads):  # each joins the queue before the next arrives
            time.sleep(0.01)
    queue.release()
    for t in threads:
        t.join(10)
    assert order == ["a", "b", "c"]
    assert places["a"][0] == 1 and places["b"][0] == 2 and places["c"][0] == 3  # runs ahead, the running one too
    assert places["c"] == sorted(places["c"], reverse=True)  # it only moves forward


def test_a_cancelled_waiter_leaves_the_queue():
    cancel = threading.Event()
    assert SAMPLING_SLOT.acquire(cancelled=lambda: False)
    try:
        seen = []
        out = []

        def wait():
            try:
                with sampling_slot(cancel, seen.append):
                    out.append("ran")
            except Cancelled:
                out.append("cancelled")

        t = threading.Thread(target=wait)
        t.start()
        while not seen:
            time.sleep(0.01)
        cancel.set()
        t.join(5)
        assert out == ["cancelled"] and seen == [1] and SAMPLING_SLOT.waiting == 0
    finally:
        SAMPLING_SLOT.release()
    with sampling_slot():  # the slot is free again
        pass
