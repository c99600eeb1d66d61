"""The studio shows what just happened, in Debian's Chromium against a real `moattn serve` (tiny model):
no comparison carried over to a new result, evicted attention said with a re-record button, the viewer in
sight while a long tab scrolls. Screenshots are saved (``screens``)."""
from __future__ import annotations

import pytest
from playwright.sync_api import expect

from app.bench import browser as br
from app.main import SIDE_BY_SIDE_PX
from app.session.items import MAX_ITEMS_WITH_ATTENTION

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def page(quick_page):
    return quick_page


#: the page's scroll box (the template's main area) scrolled to its end: its scrollTop then (else false)
SCROLLED_TO_END = """() => {
  const main = window.moattnTest.deepAll(document, '#main')[0];
  return main.scrollTop > 0 && main.scrollHeight - main.clientHeight - main.scrollTop <= 1 && main.scrollTop;
}"""


def _select(page, css: str):
    return page.locator(f"{css} select")


def test_a_new_result_is_shown_alone(page, screens):
    br.generate(page, "a person walks forward")
    first = _select(page, ".motion-select").input_value()
    br.generate(page, "a person jumps twice")
    _select(page, ".compare-select").select_option(first)
    page.wait_for_function("window.moattnPlayer.n_frames > 0")
    br.generate(page, "a person waves")
    expect(_select(page, ".compare-select")).to_have_value("(none)", timeout=10000)
    assert br.player_stats(page)["n_frames"] > 0
    (screens / "session_new_result_alone.png").write_bytes(page.screenshot(full_page=True))


def test_evicted_attention_is_said_and_can_be_re_recorded(page, screens):
    oldest = _select(page, ".motion-select").input_value()  # "a person waves"
    for k in range(MAX_ITEMS_WITH_ATTENTION):
        br.generate(page, f"a person claps {('once', 'twice', 'three times')[k]}")
    _select(page, ".motion-select").select_option(oldest)
    info = page.locator(".attention-info", has_text="dropped to keep memory bounded")
    info.wait_for(timeout=15000)
    button = page.locator(".rerecord-button button")
    button.wait_for(state="visible", timeout=5000)
    (screens / "session_evicted.png").write_bytes(page.screenshot(full_page=True))
    key = br.player_stats(page)["motion_key"]
    button.click()
    br.wait_new_motion(page, key)
    page.locator(".word-buttons button", has_text="waves").wait_for(timeout=30000)  # maps again


def test_the_viewer_stays_in_sight_while_a_long_tab_scrolls(page, screens):
    page.locator(".bk-tab", has_text="Transfer").click()
    expect(page.locator(".transfer-run button")).to_be_visible(timeout=30000)  # the tab is built
    page.mouse.move(1100, 600)
    for _ in range(10):
        page.mouse.wheel(0, 400)
    # the page's scroll box has scrolled to its end (4000 px of wheel: far more than the tab is longer than the page)
    scrolled = page.wait_for_function(SCROLLED_TO_END, timeout=30000).json_value()
    assert scrolled > 200, scrolled  # the tab is longer than the page: it did scroll
    box = page.locator(".skeleton-view canvas").bounding_box()
    viewport = page.viewport_size
    (screens / "session_sticky_viewer.png").write_bytes(page.screenshot())
    assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= viewport["height"], box


@pytest.mark.parametrize("width, height", [(1280, 800), (1500, 1100)])
def test_nothing_is_cut_off_in_a_laptop_window(browser, server_url, screens, width, height):
    """At 1280 x 800 the viewer (>= 500 px) and the tabs (600 px) do not fit beside the 340-px sidebar: the tabs wrap
    below the viewer instead of running past the right edge, and the viewer is not sticky there (it would cover the
    tabs as they scroll). Wide enough, they stand side by side with the viewer sticky."""
    small = br.open_studio(browser, server_url, viewport={"width": width, "height": height})
    try:
        small.locator(".bk-tab", has_text="Duet").first.click()
        expect(small.locator(".right-tabs")).to_contain_text("communication block", timeout=30000)
        viewer, tabs = small.locator(".viewer-column").bounding_box(), small.locator(".right-tabs").bounding_box()
        sticky = small.locator(".viewer-column").evaluate("e => getComputedStyle(e).position") == "sticky"
        (screens / f"studio_{width}x{height}.png").write_bytes(small.screenshot())
        assert tabs["x"] + tabs["width"] <= width and viewer["x"] + viewer["width"] <= width, (viewer, tabs)
        beside = tabs["x"] >= viewer["x"] + viewer["width"]
        if width < SIDE_BY_SIDE_PX:
            assert not beside and tabs["y"] >= viewer["y"] + viewer["height"] and not sticky, (viewer, tabs)
        else:
            assert beside and sticky, (viewer, tabs)
    finally:
        small.close()
