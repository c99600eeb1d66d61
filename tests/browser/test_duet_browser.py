"""The Duet tab in Debian's Chromium against a real `moattn serve` (tiny model, tiny ComMDM block): make a duet
from a prompt, see both people in one scene in two colours, play it, then complete an example prefix. Screenshots
are saved (``screens``)."""
from __future__ import annotations

import io
import re

import numpy as np
import pytest
from PIL import Image

from app.bench import browser as br

pytestmark = pytest.mark.timeout(300)


def _colours(png: bytes) -> tuple[int, int]:
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    blue = (b - r > 60) & (b > 120)  # person a
    orange = (r > 150) & (r - b > 70)  # person b
    return int(blue.sum()), int(orange.sum())


def test_duet_tab_makes_and_plays_two_people(browser, server_url, screens):
    page = br.open_studio(browser, server_url)
    try:
        page.locator(".bk-tab", has_text="Duet").click()
        prompt = page.locator(".duet-prompt input")
        prompt.wait_for(timeout=10000)
        page.locator(".duet-model-note .note", has_text="ComMDM block after layer").wait_for(timeout=10000)
        # an unknown word is flagged and blocks the button
        prompt.fill("two people smooch")
        prompt.press("Enter")
        try:
            page.locator(".duet-flag .prompt-refused", has_text="smooch").wait_for(timeout=30000)
        finally:
            (screens / "duet_unknown_word.png").write_bytes(page.screenshot(full_page=True))
        br_expect_disabled(page, ".duet-run button")
        prompt.fill("two people shake hands")
        prompt.press("Enter")
        seconds = page.locator(".duet-seconds input")
        seconds.fill("3")
        seconds.press("Enter")
        key = br.player_stats(page)["motion_key"]
        page.locator(".duet-run button").click()
        page.locator(".duet-readout .duet-box", has_text="person b from person a").wait_for(timeout=180000)
        # the prompt read as a handshake: contact guidance names its span
        page.locator(".duet-readout .duet-box", has_text="handshake: right hands").wait_for(timeout=5000)
        # the people never start inside each other, and the readout says how far apart they start (#35)
        spacing = page.locator(".duet-readout .duet-box", has_text="apart in the first 1 s").inner_text()
        start = float(re.search(r"torsos at least ([0-9.]+) m apart", spacing).group(1))
        least = float(re.search(r"the corpus keeps ([0-9.]+) m", spacing).group(1))
        assert start >= least - 0.01, spacing
        br.wait_new_motion(page, key)
        assert page.evaluate("window.moattnPlayer.n_frames") == 60
        br.painted(page)
        (screens / "duet_tab.png").write_bytes(page.screenshot(full_page=True))
        canvas = page.locator(".skeleton-view canvas").screenshot()
        (screens / "duet_viewer.png").write_bytes(canvas)
        blue, orange = _colours(canvas)
        assert blue > 150 and orange > 150, (blue, orange)  # both people, in two colours
        # the viewer's playback plays the duet (speed is `moattn bench --app`'s business, not a test's)
        page.locator(".skeleton-view .moattn-play").click()
        page.wait_for_function("window.moattnPlayer.frame >= 10", timeout=30000)
        page.locator(".skeleton-view .moattn-play").click()

        # complete an example interaction's first second
        page.locator(".duet-mode button", has_text="complete a prefix").click()
        page.locator(".duet-prefix select").wait_for(timeout=10000)
        page.locator(".duet-prefix select").select_option(label="example: hug")
        prompt.fill("")
        prompt.press("Enter")
        key = br.player_stats(page)["motion_key"]
        from playwright.sync_api import expect

        expect(page.locator(".duet-run button")).to_be_enabled(timeout=60000)
        page.locator(".duet-run button").click()
        page.locator(".duet-readout .duet-box", has_text="first 20 given").wait_for(timeout=180000)
        br.wait_new_motion(page, key)
        assert page.evaluate("window.moattnPlayer.n_frames") == 80
        br.painted(page)
        (screens / "duet_completion.png").write_bytes(page.locator(".skeleton-view canvas").screenshot())
        errors = [m for m in page.console_messages if m.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in m]
        assert not errors, errors
        assert not br.external_requests(page)
    finally:
        page.close()


def br_expect_disabled(page, selector: str) -> None:
    from playwright.sync_api import expect

    expect(page.locator(selector)).to_be_disabled(timeout=10000)
