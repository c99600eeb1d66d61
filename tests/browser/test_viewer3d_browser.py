"""The 3-D viewer drawn in the browser, in Debian's Chromium against a real `moattn serve` (tiny model): the live
x̂0 motion before sampling ends, orbit / zoom / reset with the mouse, the denoising steps scrubbed afterwards, and
the attention cursor moved by the page while it plays. Screenshots are saved (``screens``); look at them."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect

from app.bench import browser as br

pytestmark = pytest.mark.timeout(300)


def _img(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _blue(img: np.ndarray) -> int:
    r, b = img[..., 0], img[..., 2]
    return int(((b - r > 60) & (b > 120)).sum())


@pytest.fixture(scope="module")
def page(browser, server_url):
    page = br.open_studio(browser, server_url)
    yield page
    page.close()


def test_the_first_denoising_step_shows_before_sampling_ends(page, screens):
    steps = page.locator(".steps-input input")
    steps.fill("400")  # long enough to watch: the tiny model takes a few ms a step
    steps.press("Enter")
    # the server has the 400 steps: the memory line under "Attention recording" counts them
    expect(page.locator(".record-memory p")).to_contain_text("of 400 steps", timeout=30000)
    key = br.player_stats(page)["motion_key"]
    page.locator(".prompt-input input").fill("a person jumps twice")
    page.locator(".generate-button button").click()
    page.wait_for_function(f"window.moattnPlayer.previews > 0 && window.moattnPlayer.preview_step > 0", timeout=60000)
    live = page.locator(".skeleton-view canvas").screenshot()
    (screens / "viewer_live_denoising.png").write_bytes(live)
    during = br.player_stats(page)
    page.wait_for_function(f"window.moattnPlayer.motion_key > {key} && "
                           "(window.moattnPlayer.motion_key in window.moattnPlayer.first_draw)", timeout=120000)
    after = br.player_stats(page)
    new = str(after["motion_key"])
    # the live motion came first, from an early step, and was drawn (a body, not a blank canvas)
    assert new in after["preview_first"], after["preview_first"]
    assert after["preview_first"][new] < after["first_draw"][new]
    assert during["preview_step"] < 400 and _blue(_img(live)) > 100
    assert after["previews"] >= 2
    steps.fill("50")
    steps.press("Enter")


def test_orbit_zoom_and_reset_change_the_view(page, screens):
    before_png = page.locator(".skeleton-view canvas").screenshot()
    orbit = br.measure_orbit(page)
    assert orbit["changed"], orbit
    br.painted(page)
    after_png = page.locator(".skeleton-view canvas").screenshot()
    (screens / "viewer_orbited.png").write_bytes(after_png)
    assert np.abs(_img(after_png) - _img(before_png)).mean() > 1.0
    assert _blue(_img(after_png)) > 100  # still the body, from another side
    # the wheel zooms in (the camera comes closer), a double click puts the default view back
    dist = br.player_stats(page)["camera"]["dist"]
    box = br.stable_box(page.locator(".skeleton-view canvas"))
    page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.mouse.wheel(0, -400)
    page.wait_for_function(f"window.moattnPlayer.camera.dist < {dist * 0.9}", timeout=5000)
    page.mouse.dblclick(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    page.wait_for_function(f"Math.abs(window.moattnPlayer.camera.dist - {dist}) < 1e-6", timeout=5000)
    assert abs(br.player_stats(page)["camera"]["az"] - orbit["camera"][0]["az"]) < 1e-6


def test_the_denoising_steps_can_be_scrubbed_after_sampling(page, screens):
    bar = page.locator(".moattn-step-bar")
    assert bar.is_visible()
    label = page.locator(".moattn-step-label").inner_text()
    assert label.startswith("400 / 400 (final)") and "attention recorded at steps" in label, label
    final = page.locator(".skeleton-view canvas").screenshot()
    slider = page.locator(".moattn-step-scrub")
    slider.focus()
    slider.press("Home")  # the first step kept: the model's first guess of the clean motion
    page.wait_for_function("window.moattnPlayer.step_index === 0", timeout=5000)
    br.painted(page)  # the viewer has drawn that step
    first = page.locator(".skeleton-view canvas").screenshot()
    (screens / "viewer_denoising_step1.png").write_bytes(first)
    assert page.locator(".moattn-step-label").inner_text().startswith("1 / 400")
    assert np.abs(_img(first) - _img(final)).mean() > 0.5
    slider.press("End")
    page.wait_for_function("window.moattnPlayer.step_index === -1", timeout=5000)


def test_playback_moves_the_attention_cursor_in_the_page(page):
    before = br.player_stats(page)["cursor_moves"]
    result = br.measure_draw_rate(page, 1.5)
    assert result["draws"] >= 10, result
    assert br.player_stats(page)["cursor_moves"] - before >= 5  # no server round trip per frame
