"""The end of the HumanML3D-folder route: `moattn serve --model RUN` on a tiny model trained on a folder, in
Debian's Chromium. The studio reads that model's own vocabulary (a word only the folder has), not the corpus's."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect

from app.bench import browser as br

pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def page(browser, hml_run, tmp_path_factory):
    log = tmp_path_factory.getbasetemp() / "serve_folder_model.log"
    with br.studio_server(hml_run, log_path=log) as url:
        page = br.open_studio(browser, url)
        yield page
        page.close()
    assert "on cpu, fp32" in log.read_text()  # the device rule's line at start-up


def test_the_studio_generates_with_the_folder_models_own_words(page, screens, hml_rare):
    prompt = f"someone {hml_rare} twice"
    br.generate(page, prompt)
    page.locator(".generate-button button:not([disabled])").wait_for(timeout=60000)
    br.wait_all_frames(page)
    # the word buttons follow the new motion's attention by a message: wait on them, not on the first paint
    expect(page.locator(".word-buttons button")).to_have_text(["someone", hml_rare, "twice"], timeout=60000)
    status = page.locator(".generation-status p").first.inner_text()
    from engine.duration import auto_seconds
    from engine.generate import frames_for

    # the length the engine predicts from the prompt ("pirouettes" is read as a turn by meaning)
    assert f"{frames_for(auto_seconds(prompt))} frames" in status, status
    png = page.screenshot(full_page=True)
    (screens / "folder_model_studio.png").write_bytes(png)
    viewer = np.asarray(Image.open(io.BytesIO(page.locator(".skeleton-view canvas").screenshot())).convert("RGB"))
    r, b = viewer[..., 0].astype(int), viewer[..., 2].astype(int)
    assert int(((b - r > 60) & (b > 120)).sum()) > 300, "no skeleton drawn"
