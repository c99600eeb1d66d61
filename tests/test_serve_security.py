"""`moattn serve` off localhost says so, and --token puts a login page in front of the studio."""
from __future__ import annotations

import os
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from app.bench.browser import free_port
from engine.cli.serve import is_loopback
from app.main import MAX_MESSAGE_BYTES
from app.session.items import MAX_UPLOAD_BYTES

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("address, local", [("localhost", True), ("127.0.0.1", True), ("::1", True),
                                            ("0.0.0.0", False), ("192.168.1.7", False), ("studio.example", False)])
def test_which_addresses_stay_on_this_machine(address, local):
    assert is_loopback(address) is local


def test_a_websocket_message_cannot_be_much_larger_than_an_upload():
    assert MAX_UPLOAD_BYTES * 4 / 3 < MAX_MESSAGE_BYTES < 2 * MAX_UPLOAD_BYTES


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):
        return None


def _serve(*extra: str):
    port = free_port()
    cmd = [sys.executable, "-m", "engine.cli", "serve", "--port", str(port), "--model", str(ROOT / "no-model-here"),
           *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    url = f"http://localhost:{port}/"
    end = time.monotonic() + 90
    while time.monotonic() < end:
        try:
            with urllib.request.urlopen(url + "liveness", timeout=2):
                break
        except Exception:
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.3)
    return proc, url


def _stop(proc) -> str:
    proc.terminate()
    try:
        _, err = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err


def test_a_network_address_without_a_token_is_warned_about():
    proc, _ = _serve("--address", "0.0.0.0")
    err = _stop(proc)
    assert "warning: the studio listens on 0.0.0.0" in err and "--token" in err


def test_a_token_puts_a_login_page_in_front_of_the_studio():
    proc, url = _serve("--token", "s3cret")
    try:
        opener = urllib.request.build_opener(_NoRedirect)
        with pytest.raises(urllib.error.HTTPError) as info:
            opener.open(url, timeout=10)
        assert info.value.code == 302 and "/login" in info.value.headers["Location"]
        with urllib.request.urlopen(url + "login", timeout=10) as page:
            assert b"password" in page.read().lower()
    finally:
        _stop(proc)


def test_only_the_configured_host_names_reach_the_studio(run_coroutine):
    """DNS rebinding: a page on evil.example resolving to 127.0.0.1 sends that Host (and Origin) -- refused."""
    import asyncio

    from tornado.httpclient import HTTPRequest
    from tornado.websocket import websocket_connect

    proc, url = _serve()
    port = url.rsplit(":", 1)[1].strip("/")

    def get(host: str) -> int:
        req = urllib.request.Request(f"http://127.0.0.1:{port}/liveness", headers={"Host": host})
        try:
            with urllib.request.urlopen(req, timeout=20) as r:
                return r.status
        except urllib.error.HTTPError as exc:
            return exc.code

    async def websocket(host: str) -> str:
        req = HTTPRequest(f"ws://127.0.0.1:{port}/ws", headers={"Origin": f"http://{host}", "Host": host})
        try:
            conn = await websocket_connect(req)
            conn.close()
            return "open"
        except Exception as exc:  # noqa: BLE001 - the refusal is the point
            return str(exc)

    try:
        assert get(f"localhost:{port}") == 200 and get(f"127.0.0.1:{port}") == 200
        assert get(f"evil.example:{port}") == 403 and get("localhost:1") == 403
        assert "403" in run_coroutine(websocket(f"evil.example:{port}"))
        assert run_coroutine(websocket(f"localhost:{port}")) == "open"
    finally:
        _stop(proc)
