"""A session of 40 generations keeps all 40, in Debian's Chromium against a real `moattn serve` (tiny model):
past the Motion list's old silent limit of 24, through a page reload and a server restart on the same workspace,
each with its recipe; and the Edit tab shows one "Count this motion" button at a time."""
from __future__ import annotations

from collections import Counter

import pytest
from playwright.sync_api import expect

from app.bench import browser as br
from engine.library import MotionLibrary

pytestmark = pytest.mark.timeout(1200)  # 40 generations and two server starts on 2 busy cores

PROMPTS = ["a person waves", "a person jumps", "someone kicks", "a person claps", "a man squats",
           "a woman spins", "a person punches", "a person bows"]
MADE = 40


def _options(page) -> list[str]:
    return [t.strip() for t in page.locator(".motion-select select option").all_inner_texts()]


def _open(browser, url):
    page = br.open_studio(browser, url, timeout_ms=180000)
    steps = page.locator(".steps-input input")
    steps.fill("2")
    steps.press("Enter")
    return page


def test_forty_generations_survive_a_reload_and_a_restart_with_their_recipes(browser, tiny_model_dir, tmp_path,
                                                                               screens):
    workspace = tmp_path / "workspace"
    with br.studio_server(tiny_model_dir, workspace=workspace, log_path=tmp_path / "serve-1.log") as url:
        page = _open(browser, url)
        for k in range(MADE):
            br.generate(page, PROMPTS[k % len(PROMPTS)])
        made = [o for o in _options(page) if not o.startswith("imported:")]
        assert len(made) == MADE, made  # the oldest is still listed: nothing dropped at 24
        assert made[0].startswith(PROMPTS[0] + " · seed 0"), made[:3]
        page.reload()
        page.wait_for_function("window.moattnPlayer !== undefined", timeout=180000)
        expect(page.locator(".motion-select select option")).to_have_count(MADE + 1, timeout=60000)
        assert [o for o in _options(page) if not o.startswith("imported:")] == made
        page.close()

    entries = [e for e in MotionLibrary(workspace=workspace).entries() if e.kind == "generate"]
    assert len(entries) == MADE
    lib = MotionLibrary(workspace=workspace)
    for e in entries:
        recipe = lib.recipe(e.id)
        assert recipe["prompt"] in PROMPTS and recipe["seed"] == 0 and recipe["steps"] == 2, recipe
        assert recipe["guidance"] is not None and recipe["model"], recipe
    assert Counter(lib.recipe(e.id)["prompt"] for e in entries) == Counter(PROMPTS[k % len(PROMPTS)]
                                                                         for k in range(MADE))

    with br.studio_server(tiny_model_dir, workspace=workspace, log_path=tmp_path / "serve-2.log") as url:
        page = _open(browser, url)  # the server restarted
        expect(page.locator(".motion-select select option")).to_have_count(MADE + 1, timeout=60000)
        assert [o for o in _options(page) if not o.startswith("imported:")] == made
        assert f"{MADE + 1} motions kept" in page.locator(".library-status pre").inner_text()
        (screens / "library_forty_after_restart.png").write_bytes(page.screenshot(full_page=True))
        page.close()
    for n in (1, 2):
        log = (tmp_path / f"serve-{n}.log").read_text()
        assert "Traceback" not in log, log[-3000:]


def test_the_edit_tab_shows_one_count_button_at_a_time(quick_page, screens):
    page = quick_page
    page.locator(".bk-tab", has_text="Edit").click()
    count_buttons = page.locator("button:visible", has_text="Count this motion")
    expect(count_buttons).to_have_count(1, timeout=30000)  # the counting section's, beside another kind
    page.locator(".edit-kind button", has_text="count").click()
    expect(page.locator(".edit-run button")).to_have_text("Count this motion", timeout=30000)
    expect(count_buttons).to_have_count(1, timeout=30000)  # the Run button is it: never two
    (screens / "edit_count_one_button.png").write_bytes(page.screenshot(full_page=True))
    page.locator(".edit-kind button", has_text="emphasise").click()
