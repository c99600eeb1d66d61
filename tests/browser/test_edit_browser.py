"""The Edit tab in Debian's Chromium against a real `moattn serve` (tiny model): click a word, set a weight, run
emphasis, see before / after side by side and the counting readout. Screenshots are saved (``screens``)."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from app.bench import browser as br

pytestmark = pytest.mark.timeout(300)


def _img(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_emphasis_from_the_edit_tab(browser, server_url, screens):
    page = br.open_studio(browser, server_url)
    try:
        key_before = br.player_stats(page)["motion_key"]
        page.locator(".bk-tab", has_text="Edit").click()
        page.locator(".edit-kind button", has_text="emphasise").click()
        # the word is picked by clicking it in the prompt
        jumps = page.locator(".edit-words button", has_text="jumps")
        jumps.click()
        page.locator(".edit-words button.bk-active", has_text="jumps").wait_for(timeout=10000)
        # weight 0.30 -> 0.50 (the top of the add range) with the keyboard on the slider's handle (steps of 0.05)
        handle = page.locator(".edit-weight .noUi-handle")
        handle.focus()
        for _ in range(6):
            handle.press("ArrowRight")  # two presses past the end stay at the end
        page.locator(".edit-weight", has_text="0.5").wait_for(timeout=10000)
        # the slider has sent its 0.5 (its label shows the value it sent); Panel handles the click only after the
        # changes sent before it (panel.reactive: a click first runs the page's pending changes), and the result
        # line below names the weight the edit used
        page.locator(".edit-run button").click()
        # progress, then the result: both motions in the viewer, every frame delivered
        page.locator(".edit-result", has_text="emphasise 'jumps' +0.50").wait_for(timeout=180000)
        # at once the viewer shows the new motions (the browser draws them: no frames to wait for)
        page.wait_for_function(
            f"window.moattnPlayer.motion_key !== {key_before} && window.moattnPlayer.motion_key in "
            "window.moattnPlayer.first_draw && window.moattnPlayer.roles[window.moattnPlayer.motion_key] === 2",
            timeout=3000)
        br.wait_new_motion(page, key_before)
        br.painted(page)
        _save = lambda name, png: (screens / name).write_bytes(png)  # noqa: E731
        _save("edit_tab_emphasis.png", page.screenshot(full_page=True))
        canvas = page.locator(".skeleton-view canvas").screenshot()
        _save("edit_viewer_compare.png", canvas)

        # two skeletons side by side: the edited one (blue, left) and the reference (orange, right)
        img = _img(canvas)
        assert img.shape[1] >= 400, f"the viewer is narrower than its column: {img.shape}"
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        blue = (b - r > 60) & (b > 120)
        orange = (r - b > 80) & (r > 180) & (g > 80)
        assert blue.sum() > 200 and orange.sum() > 200, (blue.sum(), orange.sum())
        columns = np.arange(img.shape[1])[None, :].repeat(img.shape[0], 0)
        assert columns[blue].mean() < columns[orange].mean()  # edited on the left, reference on the right
        compare = page.locator(".compare-select select").input_value()
        assert "reference" in compare, compare

        # the counting readout of the edited (now shown) motion
        readout = page.locator(".count-readout .count-box").inner_text()
        assert "attention count" in readout and "rounded" in readout and "root-height baseline" in readout, readout
        assert "emphasise 'jumps' +0.50" in readout
        _save("edit_counting.png", page.locator(".edit-tab").screenshot())
        # (the Fast design still asks fonts.googleapis.com for Open Sans -- with or without this tab -- and that
        # fails offline as ERR_NAME_NOT_RESOLVED; anything else is an error of the page)
        errors = [m for m in page.console_messages if m.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in m]
        assert not errors, errors
    finally:
        page.close()
