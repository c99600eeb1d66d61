"""The Compose tab in Debian's Chromium against a real `moattn serve` (tiny model): build two intervals, generate
the long motion, see its length and transitions, jump to a transition (the skeleton turns the transition colour).
Screenshots are saved (``screens``)."""
from __future__ import annotations

import io
import re

import numpy as np
import pytest
from PIL import Image

from app.bench import browser as br

pytestmark = pytest.mark.timeout(300)


def _img(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_compose_two_intervals(browser, server_url, screens):
    page = br.open_studio(browser, server_url)
    try:
        key_before = br.player_stats(page)["motion_key"]
        page.locator(".bk-tab", has_text="Compose").click()
        prompts = page.locator(".compose-prompt input")
        seconds = page.locator(".compose-seconds input")
        prompts.first.wait_for(timeout=10000)
        assert prompts.count() == 2
        prompts.nth(0).fill("a person walks forward")
        prompts.nth(0).press("Enter")
        seconds.nth(0).fill("3")
        seconds.nth(0).press("Enter")
        prompts.nth(1).fill("a person jumps")
        prompts.nth(1).press("Enter")
        seconds.nth(1).fill("3")
        seconds.nth(1).press("Enter")
        # 60 + 60 frames minus one 20-frame handshake
        page.locator(".compose-length", has_text="100 frames (5.0 s)").wait_for(timeout=10000)
        page.locator(".compose-run button").click()
        page.locator(".compose-result .compose-frames", has_text="100 frames").wait_for(timeout=180000)
        br.wait_new_motion(page, key_before)
        result = page.locator(".compose-result .compose-box").inner_text()
        assert "transitions (handshake 20 frames): 40–59" in result, result
        wall = float(re.search(r"wall time ([\d.]+) s", result).group(1))
        assert wall > 0
        assert page.evaluate("window.moattnPlayer.n_frames") == 100
        br.painted(page)
        (screens / "compose_tab.png").write_bytes(page.screenshot(full_page=True))

        # jump to the transition: the viewer moves there and the skeleton is drawn in the transition colour
        page.locator(".compose-jump button").first.click()
        page.wait_for_function("window.moattnPlayer.frame === 40", timeout=20000)
        br.painted(page)  # the viewer has drawn frame 40
        canvas = page.locator(".skeleton-view canvas").screenshot()
        (screens / "compose_viewer_transition.png").write_bytes(canvas)
        img = _img(canvas)
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        orange = (r > 180) & (r - b > 90) & (g < 150)
        blue = (b - r > 60) & (b > 120)
        assert orange.sum() > 150, orange.sum()
        assert blue.sum() < orange.sum(), (blue.sum(), orange.sum())
        # a click on the timeline strip moves the viewer there
        strip = page.locator(".compose-timeline").first
        assert page.evaluate("window.moattnTest.canvases('.compose-timeline').length") >= 1
        clicked = br.tap(strip, 0.3, 0.4)
        assert clicked["box"]["width"] > 300, clicked
        page.wait_for_function("window.moattnPlayer.frame !== 40", timeout=20000)
        frame = page.evaluate("window.moattnPlayer.frame")
        assert 5 < frame < 40, frame
        errors = [m for m in page.console_messages if m.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in m]
        assert not errors, errors
    finally:
        page.close()
