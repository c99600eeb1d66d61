"""The Transfer tab in Debian's Chromium against a real `moattn serve` (tiny model): type a leader and a follower
prompt, run, see leader / follower / out side by side, the Q/K cluster strips, skeletons coloured by cluster,
a click on a strip moving the viewer, and a second follower adding its own out. Screenshots are saved (``screens``)."""
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


#: the server's frame, as the per-query plot's title says it once the server has it (not playing)
QUERY_FRAME_JS = """(frame) => {
  const plot = [...Bokeh.documents[0].all_models].find(m => (m.css_classes || []).includes('per-query') && m.renderers);
  return !!plot && plot.title.text === `Per-query maps: leader frame ${frame} as the query`;
}"""


def _role_pixels(img: np.ndarray) -> dict[str, np.ndarray]:
    """Masks of the three role colours (viz ROLE_PALETTE: blue, orange, green) in a rendered frame."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return {"blue": (b - r > 60) & (b > 120), "orange": (r - b > 80) & (r > 180) & (g > 80),
            "green": (g - r > 60) & (g - b > 30) & (g > 110)}


def test_transfer_from_two_prompts(browser, server_url, screens):
    page = br.open_studio(browser, server_url)
    save = lambda name, png: (screens / name).write_bytes(png)  # noqa: E731
    try:
        key_before = br.player_stats(page)["motion_key"]
        page.locator(".bk-tab", has_text="Transfer").click()
        page.locator(".transfer-leader .source-prompt input").fill("a person walks forward")
        page.locator(".transfer-follower .source-prompt input").fill("a person jumps twice")
        # the server has both prompts: it shows each one's words under its box
        expect(page.locator(".transfer-leader .source-words .prompt-chips")).to_have_text("a person walks forward",
                                                                                           timeout=30000)
        expect(page.locator(".transfer-follower .source-words .prompt-chips")).to_have_text("a person jumps twice",
                                                                                             timeout=30000)
        page.locator(".transfer-run button").click()
        page.locator(".transfer-result", has_text="a person walks forward → a person jumps twice").wait_for(
            timeout=180000)
        br.wait_new_motion(page, key_before)
        br.painted(page)
        save("transfer_tab.png", page.screenshot(full_page=True))
        canvas = page.locator(".skeleton-view canvas").screenshot()
        save("transfer_viewer_roles.png", canvas)

        # three skeletons side by side in role colours: leader (blue), follower (orange), out (green), left to right
        img = _img(canvas)
        assert br.player_stats(page)["roles"][str(br.player_stats(page)["motion_key"])] == 3
        # the three play together, drawn by the page (no frames to wait for)
        played = br.measure_draw_rate(page, 1.0)
        assert played["draws"] >= 10, played
        paused = br.player_stats(page)["frame"]
        if paused:  # the server has the frame playback stopped at (so that it cannot come after the Home below)
            page.wait_for_function(QUERY_FRAME_JS, arg=paused, timeout=30000)
        scrub = page.locator(".moattn-scrub")
        scrub.focus()
        scrub.press("Home")  # back to frame 0 (on the server too) before a click picks a frame below
        page.wait_for_function("window.moattnPlayer.frame === 0", timeout=5000)
        page.wait_for_function(QUERY_FRAME_JS, arg=0, timeout=30000)  # the server has frame 0
        masks = _role_pixels(img)
        counts = {k: int(m.sum()) for k, m in masks.items()}
        assert all(c > 150 for c in counts.values()), counts
        columns = np.arange(img.shape[1])[None, :].repeat(img.shape[0], 0)
        xs = [columns[masks[k]].mean() for k in ("blue", "orange", "green")]
        assert xs[0] < xs[1] < xs[2], xs
        assert "follower" in page.locator(".compare-select select").input_value()
        for text in ("leader: 80 frames", "follower: 60 frames", "out: 80 frames"):  # 4 s and 3 s by default
            page.locator(".transfer-result", has_text=text).wait_for(timeout=5000)

        # the Q / K cluster strips: one cell per frame, several clusters (not one uniform colour)
        strips = page.locator(".cluster-strips")
        strips.scroll_into_view_if_needed()
        shot = strips.screenshot()
        save("transfer_cluster_strips.png", shot)
        s = _img(shot)
        saturated = s[(s.max(-1) - s.min(-1)) > 60]
        colours = {tuple(c) for c in (saturated // 16).tolist()}
        assert len(saturated) > 5000 and len(colours) >= 3, (len(saturated), len(colours))
        page.locator(".cluster-legend", has_text="Clusters:").wait_for(timeout=5000)
        save("transfer_analysis.png", page.locator(".transfer-plots").screenshot())

        # a click on the out's Q strip (past the row labels, about frame 30) moves the viewer there
        clicked = br.tap(strips, 0.4, 0.75)
        try:
            page.wait_for_function("window.moattnPlayer.frame > 5", timeout=10000)
        except Exception as e:
            raise AssertionError(f"the click on the strips did not move the viewer: {clicked}") from e
        frame = br.player_stats(page)["frame"]
        assert 5 < frame < 80, frame

        # skeletons coloured by their Q cluster: the role colours give way to the cluster palette
        before = page.evaluate("window.moattnTest.canvasHash('.skeleton-view')")
        page.locator(".transfer-color button", has_text="Q cluster").click()
        changed = page.evaluate(f"window.moattnTest.waitChange('.skeleton-view', {before}, 30000)")
        assert changed >= 0, "the skeletons were not recoloured"
        br.painted(page)
        coloured = page.locator(".skeleton-view canvas").screenshot()
        save("transfer_viewer_q_clusters.png", coloured)
        masks = _role_pixels(_img(coloured))
        assert masks["green"].sum() < counts["green"] / 2 or masks["orange"].sum() < counts["orange"] / 2, \
            {k: int(m.sum()) for k, m in masks.items()}

        # one leader onto two followers: a second follower prompt gives a fourth skeleton (its out, purple) on the
        # right of the first out
        page.locator(".transfer-color button", has_text="roles").click()
        page.locator(".transfer-more textarea").fill("a person runs forward")
        # (sent as it is typed; Panel handles the click only after the changes sent before it -- panel.reactive: a
        # click first runs the page's pending changes -- and the result names the second follower)
        key_before = br.player_stats(page)["motion_key"]
        page.locator(".transfer-run button").click()
        page.locator(".transfer-result", has_text="+ 1 more").wait_for(timeout=180000)
        page.locator(".transfer-result", has_text="out 2: 80 frames").wait_for(timeout=5000)
        br.wait_new_motion(page, key_before)
        page.locator(".transfer-analysed", has_text="follower 2").wait_for(timeout=5000)  # pick whose analysis
        page.locator(".transfer-analysed").scroll_into_view_if_needed()
        br.painted(page)
        save("transfer_tab_two_followers.png", page.screenshot())
        s = _img(strips.screenshot())  # clicked earlier: a click picks a frame, it does not fade the other cells
        assert int(((s.max(-1) - s.min(-1)) > 60).sum()) > 5000
        four = page.locator(".skeleton-view canvas").screenshot()
        save("transfer_viewer_two_followers.png", four)
        img = _img(four)
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        masks = {**_role_pixels(img), "purple": (b - g > 60) & (r - g > 20) & (b > 150)}
        assert all(int(m.sum()) > 100 for m in masks.values()), {k: int(m.sum()) for k, m in masks.items()}
        columns = np.arange(img.shape[1])[None, :].repeat(img.shape[0], 0)
        xs = [columns[masks[k]].mean() for k in ("blue", "orange", "green", "purple")]
        assert xs[0] < xs[1] < xs[2] < xs[3], xs
        errors = [m for m in page.console_messages if m.startswith(("error", "pageerror"))
                  and "ERR_NAME_NOT_RESOLVED" not in m]
        assert not errors, errors
    finally:
        page.close()


def test_an_imported_leader_never_keeps_the_earlier_prompt(browser, server_url, screens):
    """Issue #35: switching the leader to an imported motion kept the prompt typed before as the inversion's
    description, silently. The leader's own upload now empties the description (a plain import has no prompt) and
    the box says the motion is inverted without one; back to a prompt, the typed prompt returns."""
    page = br.open_studio(browser, server_url)
    try:
        page.locator(".bk-tab", has_text="Transfer").click()
        leader = page.locator(".transfer-leader")
        leader.locator(".source-prompt input").fill("a person walks forward")
        expect(leader.locator(".source-words .prompt-chips")).to_have_text("a person walks forward", timeout=30000)
        joints = np.zeros((40, 22, 3), np.float32)
        joints[:, :, 1] = np.linspace(0.0, 1.7, 22)[None]
        joints[:, :, 2] = np.linspace(0.0, 1.0, 40)[:, None]
        buf = io.BytesIO()
        np.save(buf, joints, allow_pickle=False)
        leader.locator(".source-upload input[type=file]").set_input_files(
            files=[{"name": "walk.npy", "mimeType": "application/octet-stream", "buffer": buf.getvalue()}])
        info = leader.locator(".source-info")
        expect(info).to_contain_text("without a description", timeout=60000)
        expect(leader.locator(".source-prompt input")).to_have_value("", timeout=5000)
        leader.scroll_into_view_if_needed()
        (screens / "transfer_imported_leader.png").write_bytes(page.locator(".transfer-tab").screenshot())
        leader.locator(".source-prompt input").fill("a person walks")
        leader.locator(".source-prompt input").press("Enter")
        expect(info).to_contain_text("with the description “a person walks”", timeout=30000)
        leader.locator(".source-kind button", has_text="prompt").click()
        expect(leader.locator(".source-prompt input")).to_have_value("a person walks forward", timeout=30000)
    finally:
        page.close()
