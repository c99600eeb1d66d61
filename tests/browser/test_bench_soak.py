"""`moattn bench --soak` for one short cycle: one browser session against a real server (tiny model) generates,
edits, plays, reloads and closes; the report says so, with finite numbers and no cross-talk."""
from __future__ import annotations

import json
import math

import pytest

from app.bench.soak import PROMPTS, bench_soak, format_table, library_ok, not_listed, scan_log

pytestmark = pytest.mark.timeout(300)


def test_scan_log_counts_errors_and_tracebacks_once():
    log = "\n".join([
        "Launching server at http://localhost:5006",
        "\x1b[33m2026-11-25 08:11:54.212 (4.487s) [7F0F]vtkXOpenGLRenderWindow.:1452  WARN| bad X server connection.",
        "WARNING:bokeh.server.views.ws:Failed sending message as connection was closed",
        "2026-11-25 08:12:00,001 ERROR:app.main:callback failed",
        "Traceback (most recent call last):",
        '  File "x.py", line 1, in <module>',
        "    raise ValueError('boom')",
        "ValueError: boom",
        "2026-11-25 08:12:05,002 ERROR:app.main:callback failed",
        "Traceback (most recent call last):",
        '  File "x.py", line 1, in <module>',
        "ValueError: boom",
    ])
    assert scan_log(log) == [{"line": "ERROR:app.main:callback failed", "count": 2},
                             {"line": "Traceback: ValueError: boom", "count": 2}]
    assert scan_log(log, warnings=True) == [
        {"line": "WARNING:bokeh.server.views.ws:Failed sending message as connection was closed", "count": 1}]


def test_one_short_soak_cycle(tiny_model_dir, tmp_path):
    r = bench_soak(tiny_model_dir, sessions=1, minutes=0.05, log_path=tmp_path / "serve.log", settle_s=0,
                   timeout_s=120)
    json.dumps(r)  # the --json output
    name = f"0: {PROMPTS[0][0]}"
    assert r["sessions"] == 1 and r["cycles"] == 1, r
    assert r["failures"] == [] and r["cross_talk"] == [] and r["page_errors"] == [], r
    assert r["server_errors"] == [], r["server_errors"]
    s = r["per_session"][name]
    assert (s["generations"], s["edits"], s["plays"], s["reloads"], s["closes"]) == (1, 1, 1, 1, 1), s
    worst = r["worst_time_to_result_s"][name]
    assert math.isfinite(worst) and 0 < worst < 120, worst
    for key in ("rss_mb", "threads"):
        for when in ("before", "warm", "after", "peak"):
            assert math.isfinite(r[key][when]) and r[key][when] > 0, (key, r[key])
        assert r[key]["peak"] >= max(r[key]["before"], r[key]["after"])
    lib = r["library"]  # read from disk, then listed by a restarted server
    assert lib["generations"] == 1 and lib["generated_kept"] == 1 and lib["by_kind"].get("edit", 0) >= 1, lib
    assert lib["recipes_missing"] == [] and lib["not_listed_after_restart"] == [], lib
    assert lib["listed_after_restart"] == lib["entries"] and 0 < lib["bytes"] <= lib["limit_bytes"], lib
    assert r["ok"] is True
    table = format_table(r)
    assert "cross-talk: none" in table and table.endswith("OK")
    assert "generated kept 1 of 1" in table and "kept but not listed: none" in table, table


def _lib(**over):
    lib = {"generations": 40, "edits": 40, "entries": 81, "by_kind": {}, "generated_kept": 40, "recipes_missing": [],
           "bytes": 10 * 2**20, "limit_bytes": 500 * 2**20, "largest_bytes": 2**20, "listed_after_restart": 81,
           "not_listed_after_restart": []}
    return {**lib, **over}


def test_the_library_is_ok_only_when_nothing_is_lost_below_its_bound():
    assert library_ok(_lib()) and library_ok(None)
    assert not library_ok(_lib(generated_kept=39))  # lost one, far below the bound
    assert library_ok(_lib(generated_kept=30, bytes=int(499.5 * 2**20)))  # the bound removed the oldest
    assert not library_ok(_lib(bytes=501 * 2**20))  # past its bound
    assert not library_ok(_lib(recipes_missing=[{"title": "x", "lacking": ["seed"]}]))
    assert not library_ok(_lib(not_listed_after_restart=["a person waves · seed 0"]))


def test_soak_flags_go_with_soak_only():
    from engine.cli.bench import add_parser, run
    from engine.cli.common import Parser

    parser = Parser(prog="moattn")  # the CLI's own: no abbreviated flags
    add_parser(parser.add_subparsers())
    for flag, value in (("--sessions", "2"), ("--library-mb", "5")):
        with pytest.raises(ValueError, match="go with --soak"):
            run(parser.parse_args(["bench", "--edits", flag, value]))
    with pytest.raises(ValueError, match="--sessions must be between"):
        run(parser.parse_args(["bench", "--soak", "--sessions", "0"]))
    with pytest.raises(ValueError, match="--library-mb must be above 0"):
        run(parser.parse_args(["bench", "--soak", "--library-mb", "0"]))


def test_kept_titles_are_matched_to_the_list_without_their_repeat_numbers():
    kept = ["a person waves · seed 0", "a person waves · seed 0 (2)", "emphasise 'waves' +0.30 (2)",
            "emphasise 'waves' +0.30"]
    listed = ["a person waves · seed 0", "a person waves · seed 0 (2)", "emphasise 'waves' +0.30",
              "emphasise 'waves' +0.30 (2)"]
    assert not_listed(kept, listed) == []
    assert not_listed(kept, listed[:3]) == ["emphasise 'waves' +0.30"]  # one of the two repeats is missing
    assert not_listed(kept + ["a person jumps · seed 0 (3)"], listed) == ["a person jumps · seed 0"]


CLOSED_PAGE_LOG = """\
ERROR:bokeh.server.protocol_handler:error handling message
 message: Message 'PATCH-DOC' content: {'events': [{'kind': 'ModelChanged', 'attr': 'frame', 'new': 38}]}
 error: AssertionError()
Traceback (most recent call last):
  File "bokeh/server/protocol_handler.py", line 94, in handle
    work = await handler(message, connection)
  File "bokeh/server/connection.py", line 65, in session
    assert self._session is not None
AssertionError
Task exception was never retrieved
Traceback (most recent call last):
  File "tornado/websocket.py", line 1086, in wrapper
    await fut
tornado.iostream.StreamClosedError: Stream is closed

During handling of the above exception, another exception occurred:

Traceback (most recent call last):
  File "tornado/websocket.py", line 1088, in wrapper
    raise WebSocketClosedError()
tornado.websocket.WebSocketClosedError
ERROR:app.main:callback failed
Traceback (most recent call last):
  File "x.py", line 1, in <module>
ValueError: boom
"""


def test_errors_on_a_page_already_gone_are_counted_apart():
    assert scan_log(CLOSED_PAGE_LOG) == [{"line": "ERROR:app.main:callback failed", "count": 1},
                                         {"line": "Traceback: ValueError: boom", "count": 1}]
    assert scan_log(CLOSED_PAGE_LOG, closed=True) == [
        {"line": "ERROR:bokeh.server.protocol_handler:error handling message", "count": 1},
        {"line": "Traceback: AssertionError", "count": 1},
        {"line": "Traceback: tornado.iostream.StreamClosedError: Stream is closed", "count": 1},
        {"line": "Traceback: tornado.websocket.WebSocketClosedError", "count": 1}]
