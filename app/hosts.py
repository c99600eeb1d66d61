"""Only the configured host names reach the studio: a guard against DNS rebinding.

A page on another site whose name is made to resolve to 127.0.0.1 sends ``Host: evil.example:PORT`` (and, for
the websocket, the same ``Origin``); Bokeh's origin list alone let that websocket through when Origin equalled
Host. Every response, the websocket handshake included (Tornado finishes it through the same transforms), is
replaced by 403 when the request's Host is not one the server was started for.
"""
from __future__ import annotations

from tornado.web import OutputTransform


def allowed_hosts(address: str, port: int) -> frozenset[str]:
    """The Host headers a studio on ``address``:``port`` answers (lower case, with the port)."""
    names = {address.strip().lower(), "localhost", "127.0.0.1", "[::1]"}
    if ":" in address and not address.startswith("["):
        names.add(f"[{address.strip().lower()}]")  # an IPv6 literal is bracketed in a Host header
    return frozenset(f"{name}:{port}" for name in names)


def host_guard(hosts: frozenset[str]) -> type[OutputTransform]:
    """A Tornado output transform that answers 403 to any request whose Host is not in ``hosts``."""

    class HostGuard(OutputTransform):
        def __init__(self, request):
            super().__init__(request)
            self.allowed = (request.headers.get("Host") or "").strip().lower() in hosts

        def transform_first_chunk(self, status_code, headers, chunk, finishing):
            if self.allowed:
                return status_code, headers, chunk
            headers.clear()
            headers["Content-Type"] = "text/plain; charset=UTF-8"
            body = b"403: this studio answers only to the host names it was started for\n"
            headers["Content-Length"] = str(len(body))
            return 403, headers, body

        def transform_chunk(self, chunk, finishing):
            return chunk if self.allowed else b""

    return HostGuard
