"""Every attention plot says how to read it (issue #35), in Debian's Chromium against a real `moattn serve` (tiny
model): under the word curves, the self-attention map and its row (Generate), the counting map (Edit), the Q/K
cluster strips, the correspondences and the attention maps (Transfer) a one-line caption is shown, fully inside the
page at 1280 wide, in a small grey font. Screenshots are saved (``screens``); look at them."""
from __future__ import annotations

import pytest
from playwright.sync_api import expect

from app.bench import browser as br
from viz.reading import HOW_TO_READ

pytestmark = pytest.mark.timeout(400)

SHOWN = {"Attention": ("word_curves", "self_attention", "attention_row"), "Edit": ("counting",),
         "Transfer": ("qk_clusters", "correspondences", "qk_maps")}


def _caption(page, key: str):
    return page.locator(f".how-to-read-{key.replace('_', '-')} .how-to-read")


def test_each_attention_plot_says_how_to_read_it(quick_page, screens):
    page = quick_page
    page.set_viewport_size({"width": 1280, "height": 800})
    br.generate(page, "a person jumps twice", timeout_ms=240000)
    page.locator(".cross-curves").wait_for(state="visible", timeout=60000)
    width = page.evaluate("document.documentElement.clientWidth")
    for tab, keys in SHOWN.items():
        page.locator(".bk-tab", has_text=tab).first.click()
        for key in keys:
            caption = _caption(page, key)
            expect(caption).to_be_visible(timeout=60000)
            expect(caption).to_have_text(f"How to read: {HOW_TO_READ[key]}", timeout=5000)
            caption.scroll_into_view_if_needed()
            box = caption.bounding_box()
            assert box and box["x"] >= 0 and box["x"] + box["width"] <= width, (key, box, width)
            size = caption.evaluate("e => parseFloat(getComputedStyle(e).fontSize)")
            assert size <= 12, (key, size)  # a caption, not a paragraph
        shot = {"Attention": ".attention-plots", "Edit": ".edit-tab", "Transfer": ".transfer-plots"}[tab]
        (screens / f"how_to_read_{tab.lower()}.png").write_bytes(page.locator(shot).screenshot())


def test_the_edit_mode_tooltip_is_fully_on_screen(quick_page, screens):
    """Issue #35: the edit mode's tooltip opened to the right of its buttons and was cut off at the screen edge; it
    now opens below them, inside a 1280 x 800 window."""
    page = quick_page
    page.set_viewport_size({"width": 1280, "height": 800})
    page.locator(".bk-tab", has_text="Edit").first.click()
    button = page.locator(".edit-mode button").last
    button.evaluate("e => e.scrollIntoView({block: 'center'})")  # where a user reads it, not at the window's edge
    button.hover()
    from app.tabs.edit.settings import EditSettings

    tip = page.locator(".bk-Tooltip", has_text=EditSettings.param.mode.doc)  # the engine's declared help
    expect(tip).to_be_visible(timeout=10000)
    box = tip.bounding_box()
    page.screenshot(path=str(screens / "edit_mode_tooltip.png"))
    assert box and box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= 1280 \
        and box["y"] + box["height"] <= 800, box
