"""The user guide's pictures (app/GUIDE.md), made by the studio itself so that they cannot go stale: the shipped
model (with its control models and duet block, as `moattn serve` opens them) in Debian's Chromium; each test does
what the guide's section says to try first, waits until the page shows its result, and saves the picture (256
colours, under 150 KB) to the ``screens`` folder, or to app/guide/<section>.png with MOATTN_WRITE_GUIDE=1
(`make guide`). The full screenshots go to the ``screens`` folder too; look at them.
"""
from __future__ import annotations

import io
import os
import re

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect

from app.bench import browser as br
from engine.paths import ASSETS, MODEL_DIR, PROJECT_ROOT

pytestmark = pytest.mark.timeout(900)  # each section samples on the shipped model: minutes on 2 busy cores

GUIDE = PROJECT_ROOT / "app" / "guide"
# the committed pictures are rewritten only when asked (`make guide`); otherwise they go beside the other screenshots,
# so a test run leaves the working tree as it was (each run's pictures differ in timings and temporary paths)
WRITE_GUIDE = os.environ.get("MOATTN_WRITE_GUIDE") == "1"
VIEWPORT = {"width": 1500, "height": 1000}  # the sidebar, the viewer and a tab side by side
STEPS = 10  # sampling steps: enough for a recognisable motion, quick on a CPU
MAX_BYTES = 150 * 1024
RUN = 600_000  # ms: the longest wait for a run (a generation, an edit, a transfer ...) on a loaded machine
SHOWN = 120_000  # ms: the longest wait for a tab to be built or a server's answer to arrive


@pytest.fixture(scope="module")
def page(browser, tmp_path_factory):
    """The studio on the shipped model, sampling with ``STEPS`` steps."""
    assert (MODEL_DIR / "weights.pt").exists(), f"the shipped model is missing: {MODEL_DIR}"
    log = tmp_path_factory.getbasetemp() / "serve-guide.log"
    # the shipped model, its four control models and its duet block load before the first page: minutes when busy
    with br.studio_server(MODEL_DIR, log_path=log, timeout=900) as url:
        page = br.open_studio(browser, url, viewport=VIEWPORT)
        steps = page.locator(".steps-input input")
        steps.fill(str(STEPS))
        steps.press("Enter")
        # the server has the steps: the memory line under "Attention recording" counts them
        expect(page.locator(".record-memory p")).to_contain_text(f"of {STEPS} steps", timeout=SHOWN)
        yield page
        errors = [m for m in page.console_messages if m.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in m]
        page.close()
    assert "Traceback" not in log.read_text(), log.read_text()[-3000:]
    assert not errors, errors


# ------------------------------------------------------------------------------------------ helpers
def _picture(page, screens, name: str, *, clip: dict | None = None) -> Image.Image:
    """Save what the page shows (``clip``: that part of it) as the guide's ``name``.png, in 256 colours."""
    br.painted(page)
    br.animations_done(page)
    png = page.screenshot(clip=clip)
    img = Image.open(io.BytesIO(png)).convert("RGB")
    pixels = np.asarray(img).astype(int)
    assert pixels.std() > 20, f"{name}: the picture is nearly uniform (a blank page?)"
    # max coverage + k-means keeps the small coloured parts (skeletons, legends) in their own colours
    small = img.quantize(colors=256, method=Image.Quantize.MAXCOVERAGE, kmeans=3)
    target = (GUIDE if WRITE_GUIDE else screens) / f"{name}.png"
    target.parent.mkdir(parents=True, exist_ok=True)
    small.save(target, optimize=True)
    (screens / f"guide_{name}.png").write_bytes(png)
    size = target.stat().st_size
    assert size < MAX_BYTES, f"{name}.png is {size / 1024:.0f} KB"
    return img


def _left(page) -> dict:
    """The sidebar and the viewer (under the title bar)."""
    viewer = page.locator(".viewer-column").bounding_box()
    return {"x": 0, "y": 64, "width": viewer["x"] + viewer["width"] + 8, "height": VIEWPORT["height"] - 64}


def _right(page) -> dict:
    """The viewer and the tabs (under the title bar)."""
    viewer = page.locator(".viewer-column").bounding_box()
    x = max(0, viewer["x"] - 12)
    return {"x": x, "y": 64, "width": VIEWPORT["width"] - x, "height": VIEWPORT["height"] - 64}


def _tab(page, title: str, ready: str) -> None:
    """Open the tab ``title`` and wait until it is built (``ready``: a selector in it)."""
    page.locator(".bk-tab", has_text=title).click()
    expect(page.locator(ready).first).to_be_visible(timeout=SHOWN)


def _to_top(page, selector: str, *, above: int = 0) -> None:
    """Scroll the page's main area at once so that ``selector`` is ``above`` px below its top, or as far as it goes
    (the viewer stays in sight: it is sticky)."""
    page.locator(selector).first.evaluate(
        "(e, above) => { e.scrollIntoView({block: 'start', behavior: 'instant'});"
        " window.moattnTest.deepAll(document, '#main')[0].scrollBy({top: -above, behavior: 'instant'}); }", above)


def _show_frame(page, frame: int) -> None:
    """Move the viewer to ``frame`` with its own slider (the page and the server follow, as for a hand)."""
    page.locator(".moattn-scrub").evaluate(
        "(s, k) => { s.value = k; s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change')); }",
        frame)
    page.wait_for_function(f"window.moattnPlayer.frame === {frame}", timeout=SHOWN)


def _middle(page) -> int:
    return int(br.player_stats(page)["n_frames"]) // 2


def _run(page, button: str, done, key_before: int) -> None:
    """Press a tab's Run button, wait for its result line (``done``: a locator) and the new motion in the viewer."""
    page.locator(button).click()
    expect(done).to_be_visible(timeout=RUN)
    br.wait_new_motion(page, key_before, timeout_ms=RUN)


#: the Bokeh plot with this css class has this title (the server's answer to a picked frame)
TITLE_JS = """([cls, pattern]) => {
  const plot = [...Bokeh.documents[0].all_models].find(m => (m.css_classes || []).includes(cls) && m.renderers);
  return !!plot && new RegExp(pattern).test(plot.title.text);
}"""


#: the row plot under the heatmap names the frame the viewer shows
ROW_OF_SHOWN_FRAME_JS = """() => {
  const plot = [...Bokeh.documents[0].all_models].find(m => (m.css_classes || []).includes('row-profile') && m.renderers);
  return !!plot && plot.title.text.startsWith(`Row of frame ${window.moattnPlayer.frame}:`);
}"""


# ------------------------------------------------------------------------------------------ the guide's sections
PROMPT = "a person jumps three times"


@pytest.fixture(scope="module")
def generated(page):
    """Generate: the guide's first prompt, with its attention on the Attention tab."""
    key = br.player_stats(page)["motion_key"]
    prompt = page.locator(".prompt-input input")
    prompt.fill(PROMPT)
    # the server reads the prompt as it is typed: its words and what it asks for show under the box
    expect(page.locator(".prompt-intent")).to_contain_text("jump (×3)", timeout=SHOWN)
    page.locator(".generate-button button").click()
    br.wait_new_motion(page, key, timeout_ms=RUN)
    expect(page.locator(".generation-status")).to_contain_text(f"'{PROMPT}'", timeout=SHOWN)
    expect(page.locator(".followed-report .followed")).to_contain_text("asked: jump", timeout=SHOWN)
    # the Attention tab shows this motion's maps (they follow the new scene by a message)
    expect(page.locator(".attention-info")).to_contain_text(PROMPT, timeout=SHOWN)
    expect(page.locator(".word-buttons button", has_text="jumps")).to_be_visible(timeout=SHOWN)
    page.wait_for_function("window.moattnTest.plotData('cross-curves').word.length === 5", timeout=SHOWN)
    return br.player_stats(page)["motion_key"]


def test_generate(page, generated, screens):
    _show_frame(page, _middle(page))
    _picture(page, screens, "generate", clip=_left(page))


def test_attention(page, generated, screens):
    page.locator(".word-buttons button", has_text="jumps").click()
    page.wait_for_function(br.WORD_PICKED_JS, arg="jumps", timeout=SHOWN)  # the server highlights its curve
    _show_frame(page, 0)  # the guide's earlier picture left the viewer mid-motion: the tap must be what moves it
    heat = page.locator(".self-heatmap")
    box = br.stable_box(heat)
    br.tap(heat, 200 / box["width"], (30 + 0.5 * 290) / box["height"])  # a row half-way down: a frame mid-motion
    page.wait_for_function("window.moattnPlayer.frame > 0", timeout=SHOWN)
    # the server has the frame the viewer shows: the row plot under the heatmap is that frame's row
    page.wait_for_function(ROW_OF_SHOWN_FRAME_JS, timeout=SHOWN)
    _to_top(page, ".word-buttons", above=16)  # the word curves, the heatmap and the row under it
    _picture(page, screens, "attention", clip=_right(page))


def test_edit(page, generated, screens):
    key = br.player_stats(page)["motion_key"]
    _tab(page, "Edit", ".edit-kind")
    page.locator(".edit-kind button", has_text="emphasise").click()
    page.locator(".edit-words button", has_text="jumps").click()
    expect(page.locator(".edit-words button.bk-active", has_text="jumps")).to_be_visible(timeout=SHOWN)
    _run(page, ".edit-run button", page.locator(".edit-result", has_text="emphasise 'jumps'"), key)
    assert br.player_stats(page)["roles"][str(br.player_stats(page)["motion_key"])] == 2  # after | before
    _show_frame(page, _middle(page))
    _picture(page, screens, "edit", clip=_right(page))


def test_transfer(page, generated, screens):
    key = br.player_stats(page)["motion_key"]
    _tab(page, "Transfer", ".transfer-run")
    sources = {"leader": "a person walks forward", "follower": "a person jumps like a chicken"}
    for role, text in sources.items():
        page.locator(f".transfer-{role} .source-prompt input").fill(text)
    for role, text in sources.items():  # the server has both prompts: it shows their words
        expect(page.locator(f".transfer-{role} .source-words .prompt-chips")).to_have_text(text, timeout=SHOWN)
    _run(page, ".transfer-run button", page.locator(".transfer-result", has_text="out: "), key)
    assert br.player_stats(page)["roles"][str(br.player_stats(page)["motion_key"])] == 3  # leader, follower, out
    _show_frame(page, _middle(page))
    _picture(page, screens, "transfer", clip=_right(page))

    expect(page.locator(".cluster-legend")).to_contain_text("Clusters:", timeout=SHOWN)
    _to_top(page, ".cluster-legend", above=48)  # from the "Q vs K clusters" heading
    _picture(page, screens, "transfer_clusters", clip=_right(page))

    mixed = page.locator(".map-mixed")
    _to_top(page, ".map-mixed")
    br.tap(mixed, 0.5, 0.6)  # a leader frame (a row of the mixed map) as the query
    expect(page.locator(".per-query")).to_be_visible(timeout=SHOWN)
    page.wait_for_function(TITLE_JS, arg=["per-query", "^Per-query maps: leader frame \\d+ as the query"],
                           timeout=SHOWN)
    _to_top(page, ".map-mixed")
    _picture(page, screens, "transfer_maps", clip=_right(page))


def test_compose(page, generated, screens):
    key = br.player_stats(page)["motion_key"]
    _tab(page, "Compose", ".compose-prompt input")
    prompts, seconds = page.locator(".compose-prompt input"), page.locator(".compose-seconds input")
    for k, text in enumerate(("a person walks forward", "a person jumps twice")):
        prompts.nth(k).fill(text)
        prompts.nth(k).press("Enter")
        seconds.nth(k).fill("3")
        seconds.nth(k).press("Enter")
    # the server has both rows: 60 + 60 frames less one 20-frame handshake
    expect(page.locator(".compose-length")).to_contain_text("100 frames (5.0 s)", timeout=SHOWN)
    _run(page, ".compose-run button", page.locator(".compose-result .compose-frames", has_text="100 frames"), key)
    page.locator(".compose-jump button").first.click()  # to the transition: the skeleton in its colour
    page.wait_for_function("window.moattnPlayer.frame === 40", timeout=SHOWN)
    page.wait_for_function(TITLE_JS, arg=["compose-timeline", "^frame 40 — in transition 1"], timeout=SHOWN)
    _picture(page, screens, "compose", clip=_right(page))


def test_control(page, generated, screens):
    key = br.player_stats(page)["motion_key"]
    _tab(page, "Control", ".control-method-note .note")
    page.locator(".control-prompt input").fill("a person walks forward")
    expect(page.locator(".control-flag")).not_to_contain_text("refuse", timeout=SHOWN)
    page.locator(".control-clear-root button").click()
    expect(page.locator(".control-root-info .bad")).to_contain_text("no root path", timeout=SHOWN)
    canvas = page.locator(".control-topdown").first
    canvas.scroll_into_view_if_needed()
    # forward (up the screen), bending to the person's left: as a hand draws it
    stroke = [(0.50 - 0.15 * np.sin(np.pi * t), 0.74 - 0.55 * t) for t in np.linspace(0, 1, 30)]
    br.drag(canvas, stroke)
    expect(page.locator(".control-root-info span", has_text=re.compile(r"\d+ points"))).to_be_visible(timeout=SHOWN)
    _run(page, ".control-run button", page.locator(".control-readout .control-box"), key)
    _show_frame(page, _middle(page))
    _to_top(page, ".control-topdown", above=110)  # from the "Root path" heading
    _picture(page, screens, "control", clip=_right(page))


def test_duet(page, generated, screens):
    key = br.player_stats(page)["motion_key"]
    _tab(page, "Duet", ".duet-prompt input")
    expect(page.locator(".duet-model-note .note")).to_contain_text("ComMDM block", timeout=SHOWN)
    page.locator(".duet-prompt input").fill("two people shake hands")
    _run(page, ".duet-run button", page.locator(".duet-readout .duet-box", has_text="person b from person a"), key)
    _show_frame(page, _middle(page))
    _picture(page, screens, "duet", clip=_right(page))


def test_files(page, generated, screens, tmp_path):
    key = br.player_stats(page)["motion_key"]
    example = ASSETS / "examples" / "walk.npy"
    page.locator(".import-input input[type=file]").set_input_files(str(example))
    toast = page.locator(".notyf__message", has_text="imported walk.npy").last
    expect(toast).to_be_visible(timeout=SHOWN)
    br.wait_new_motion(page, key)
    with page.expect_download(timeout=SHOWN) as info:
        page.locator(".export-bvh button, .export-bvh a").first.click()
    assert info.value.suggested_filename.endswith(".bvh"), info.value.suggested_filename
    info.value.save_as(tmp_path / info.value.suggested_filename)
    assert (tmp_path / info.value.suggested_filename).read_text().startswith("HIERARCHY")
    page.locator(".export-bvh").first.evaluate("e => e.scrollIntoView({block: 'center', behavior: 'instant'})")
    _picture(page, screens, "files")
