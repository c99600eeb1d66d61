"""Browser-test fixtures: a tiny trained model, a real `moattn serve` on a free port, Debian's Chromium."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from app.bench import browser as br


@pytest.fixture(scope="session", autouse=True)
def chromium_installed():
    """Browser tests need Debian's chromium; `make test` installs it. Missing is a failure, not a skip."""
    assert br.chromium_available(), f"{br.CHROMIUM} is not installed: run `make test` (it installs Debian's chromium)"


@pytest.fixture(scope="session")
def screens(tmp_path_factory) -> Path:
    """Where screenshots go (MOATTN_SCREENSHOTS to keep them somewhere known); look at them."""
    folder = Path(os.environ.get("MOATTN_SCREENSHOTS") or tmp_path_factory.mktemp("screens"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="session")
def server_url(tiny_model_dir, tiny_duet_dir, tmp_path_factory):
    log = tmp_path_factory.getbasetemp() / "serve.log"
    with br.studio_server(tiny_model_dir, log_path=log, duet_dir=tiny_duet_dir) as url:
        yield url


@pytest.fixture(scope="session")
def playwright_instance():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        yield pw


@pytest.fixture(scope="session")
def browser(playwright_instance):
    b = br.launch(playwright_instance)
    yield b
    b.close()


@pytest.fixture(scope="module")
def quick_page(browser, server_url):
    """One studio page per test module, sampling with 10 steps in one try (quick on the tiny model, which follows no
    prompt: with the default tries every generation would be made three times over)."""
    page = br.open_studio(browser, server_url)
    for box, value in ((".steps-input input", "10"), (".tries-input input", "1")):
        field = page.locator(box)
        field.fill(value)
        field.press("Enter")
    yield page
    page.close()
