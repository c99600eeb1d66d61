"""Grounding to several spans in Debian's Chromium against a real `moattn serve` (tiny model): drag spans across the
picked word's attention curve in the Edit tab, clear them, drag again and run the grounding edit."""
from __future__ import annotations

import re

import pytest

from app.bench import browser as br

pytestmark = pytest.mark.timeout(300)


def test_drag_grounding_spans_on_the_word_curve(browser, server_url, screens):
    page = br.open_studio(browser, server_url)
    try:
        page.locator(".bk-tab", has_text="Edit").click()
        page.locator(".edit-kind button", has_text="ground").click()
        page.locator(".edit-words button", has_text="jumps").click()
        page.locator(".edit-words button.bk-active", has_text="jumps").wait_for(timeout=10000)
        curve = page.locator(".span-curve").first
        curve.scroll_into_view_if_needed()
        spans_input = page.locator(".edit-spans input")
        listing = page.locator(".edit-span-list")

        def drag_spans():
            br.drag(curve, [(0.25, 0.5), (0.32, 0.5), (0.40, 0.5)])
            listing.locator(".span-count", has_text="1 span").wait_for(timeout=15000)
            br.drag(curve, [(0.60, 0.5), (0.67, 0.5), (0.75, 0.5)])
            listing.locator(".span-count", has_text="2 spans").wait_for(timeout=15000)

        drag_spans()
        text = spans_input.input_value()
        m = re.fullmatch(r"(\d+):(\d+),(\d+):(\d+)", text)
        assert m, text
        a, b, c, d = map(int, m.groups())
        assert a < b < c < d, text
        br.painted(page)
        (screens / "edit_ground_spans.png").write_bytes(page.locator(".edit-tab").screenshot())

        page.locator(".edit-clear-spans button").click()
        listing.locator(".span-none").wait_for(timeout=10000)
        assert spans_input.input_value() == ""

        drag_spans()  # the server has the spans: it lists them (".span-count")
        page.locator(".edit-run button").click()
        done = re.compile(r"ground 'jumps' \+0\.30 frames \d+–\d+, \d+–\d+")
        page.locator(".edit-result", has_text=done).wait_for(timeout=180000)
        errors = [msg for msg in page.console_messages if msg.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in msg]
        assert not errors, errors
    finally:
        page.close()
