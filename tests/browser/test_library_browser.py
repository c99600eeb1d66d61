"""The studio keeps a person's work, in Debian's Chromium against a real `moattn serve` (tiny model): motions
generated survive a page reload and a server restart (same workspace), the Motion list searches them, and a motion
read back from the library says it has no attention and re-records that very motion. Screenshots are saved
(``screens``)."""
from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from app.bench import browser as br
from engine.library import MotionLibrary

pytestmark = pytest.mark.timeout(900)  # two servers start, three pages open: slow on 2 busy cores

WAVES = "a person waves · seed 0"
JUMPS = "a person jumps twice · seed 0"


def _options(page) -> list[str]:
    return [t.strip() for t in page.locator(".motion-select select option").all_inner_texts()]


def _option(page, title: str):
    """The Motion list's option titled ``title`` (a locator: ``expect`` waits on its count)."""
    return page.locator(".motion-select select option").filter(has_text=re.compile(rf"^\s*{re.escape(title)}\s*$"))


def _open(browser, url):
    page = br.open_studio(browser, url, timeout_ms=180000)  # a first page is slow on 2 busy cores
    steps = page.locator(".steps-input input")
    steps.fill("4")
    steps.press("Enter")
    return page


def test_motions_survive_a_reload_and_a_server_restart(browser, tiny_model_dir, tiny_duet_dir, tmp_path, screens):
    workspace = tmp_path / "workspace"
    with br.studio_server(tiny_model_dir, duet_dir=tiny_duet_dir, workspace=workspace,
                          log_path=tmp_path / "serve-1.log") as url:
        page = _open(browser, url)
        br.generate(page, "a person waves")
        br.generate(page, "a person jumps twice")
        assert WAVES in _options(page) and JUMPS in _options(page)
        page.close()
        page = _open(browser, url)  # a reload: a new session
        expect(_option(page, JUMPS)).to_have_count(1, timeout=30000)
        assert {WAVES, JUMPS} <= set(_options(page))
        assert _options(page).count("imported: walk.npy") == 1  # the opening example is one motion, not one per page
        page.close()
    entries = MotionLibrary(workspace=workspace).entries()
    assert [e.title for e in entries if e.kind == "generate"] == [WAVES, JUMPS]

    with br.studio_server(tiny_model_dir, duet_dir=tiny_duet_dir, workspace=workspace,
                          log_path=tmp_path / "serve-2.log") as url:  # the server restarted
        page = _open(browser, url)
        assert {WAVES, JUMPS} <= set(_options(page))
        assert "motions kept" in page.locator(".library-status pre").inner_text()
        # a returning user's page opens on their newest motion, with its prompt, not on the example
        assert page.locator(".motion-select select").input_value() == JUMPS
        assert page.locator(".prompt-input input").input_value() == "a person jumps twice"
        search = page.locator(".motion-search input")
        search.fill("jumps")
        search.press("Enter")
        expect(_option(page, WAVES)).to_have_count(0, timeout=30000)
        assert JUMPS in _options(page)
        page.locator(".attention-info", has_text="not attention maps").wait_for(timeout=15000)
        button = page.locator(".rerecord-button button")
        button.wait_for(state="visible", timeout=5000)
        (screens / "library_after_restart.png").write_bytes(page.screenshot(full_page=True))
        key = br.player_stats(page)["motion_key"]
        button.click()
        br.wait_new_motion(page, key)
        page.locator(".word-buttons button", has_text="jumps").wait_for(timeout=30000)  # its maps again
        assert page.locator(".motion-select select").input_value() == JUMPS  # that motion, not another
        assert _options(page).count(JUMPS) == 1
        (screens / "library_rerecorded.png").write_bytes(page.screenshot(full_page=True))
        page.close()
        log = (tmp_path / "serve-2.log").read_text()
        assert "Traceback" not in log, log[-3000:]
