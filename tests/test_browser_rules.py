"""Rules for the tests themselves (issue #34 item 5): a browser test waits on a condition, never for a fixed time.

A fixed sleep (``page.wait_for_timeout``, ``time.sleep``) is too short on a loaded machine and too long on an idle
one; Playwright's ``expect(locator)...`` and ``page.wait_for_function`` wait for what the test needs (a status text,
the viewer having drawn, a server's answer). ``app.bench.browser`` has helpers for the common cases: ``painted``
(the page has drawn what it holds), ``animations_done`` (notifications have slid in), ``wait_new_motion``.
"""
from __future__ import annotations

import re
from pathlib import Path

TESTS = Path(__file__).resolve().parent
FIXED_SLEEPS = re.compile(r"\bwait_for_timeout\s*\(|\btime\.sleep\s*\(|\basyncio\.sleep\s*\(")


def _sleeps(folder: Path) -> list[str]:
    found = []
    for path in sorted(folder.rglob("*.py")):
        if path.resolve() == Path(__file__).resolve():
            continue  # this file names what it looks for
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if FIXED_SLEEPS.search(line):
                found.append(f"{path.relative_to(TESTS.parent)}:{number}: {line.strip()}")
    return found


def test_no_test_waits_a_fixed_time_in_the_browser():
    """No ``wait_for_timeout`` anywhere in tests/: wait on a condition (see the module's docstring)."""
    found = [line for line in _sleeps(TESTS) if "wait_for_timeout" in line]
    assert not found, "fixed waits in tests (wait on a condition instead):\n" + "\n".join(found)


def test_no_browser_test_sleeps():
    """No ``time.sleep`` / ``asyncio.sleep`` in the browser tests either (the same fixed wait by another name)."""
    found = _sleeps(TESTS / "browser")
    assert not found, "fixed sleeps in browser tests (wait on a condition instead):\n" + "\n".join(found)


def test_the_rule_sees_a_fixed_wait(tmp_path):
    """The rule finds what it forbids (a test that could never fail would guard nothing)."""
    (tmp_path / "test_x.py").write_text("def test_x(page):\n    page.wait_for_timeout(500)\n    page.click('b')\n")
    assert FIXED_SLEEPS.search((tmp_path / "test_x.py").read_text())
    assert not FIXED_SLEEPS.search("expect(page.locator('.x')).to_have_text('done', timeout=5000)")
