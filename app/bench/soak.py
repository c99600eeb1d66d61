"""The soak benchmark (``moattn bench --soak``): several real browser sessions against one real server for minutes.

``moattn bench --soak [--sessions 5] [--minutes 10] [--model DIR] [--log FILE] [--json]`` starts ``moattn serve``
on a free port and opens one Debian Chromium with one page per session. Each session, over and over until the
minutes are up (a cycle under way is finished, and every session does at least one):

- generates its own prompt (a distinct one per session, 10 steps) and checks that the Motion list shows it;
- emphasises its prompt's action word on the Edit tab and checks the result is its own;
- plays the motion for a second (at least two frames must be drawn);
- reloads the page (a new server session: the Motion list is the motion library, so its motion must still be
  listed) and closes it (the next cycle opens a new page).

The server keeps its motions in a scratch workspace (never the user's library), bounded by ``--library-mb`` when
given. Afterwards the library is read from disk (one generated motion per generation, each with its whole recipe,
its size against the bound), and the server is started again on that workspace: its Motion list must show every
motion kept.

The sessions run round-robin in one thread (Playwright's sync API is not thread-safe): each does one step and
hands over, and its waits are polls, so the server works on several sessions' jobs at once.

Reported: the server log's errors (``server_errors``: tracebacks, ERROR / Error: / Exception lines, deduplicated
with counts) and, apart, its warnings (``server_warnings``, not failing) and Bokeh's and Tornado's errors on a page already gone (``closed_page_errors``: a message for a session discarded, a socket closed mid-send; not failing), the server's resident memory (its children included) and thread count before the pages, once every
session finished its first cycle (``warm``), at the end after closed sessions had time to be discarded
(``after``) and the peak; each session's worst time to result (click -> first frame of the generated or edited
motion, page clock); ``page_loads`` and ``rss_growth_per_load_mb`` (memory after minus warm, per page load after
the first ones); ``burst_get_s`` (as many concurrent ``GET /`` as sessions, at the start: each builds a page on the
server); cross-talk (a session listing a motion of another prompt); failures (a step that raised or
timed out); page errors in the browser. ``ok``: no server error, no cross-talk, no failure, no page error, and
every session finished a cycle.

The command line lives in ``engine/cli/bench.py``; this module drives the browsers and prints.
"""
from __future__ import annotations

import json
import math
import os
import re
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

#: one prompt per session and the word its edit emphasises; no prompt is the start of another
PROMPTS = [
    ("a person jumps twice", "jumps"), ("a person waves", "waves"), ("someone kicks", "kicks"),
    ("a person walks forward", "walks"), ("a person claps three times", "claps"), ("a man squats slowly", "squats"),
    ("a woman spins", "spins"), ("a person punches", "punches"), ("someone hops on one foot", "hops"),
    ("a person bows", "bows"), ("a robot dances", "dances"), ("an old man jogs", "jogs"),
]
MAX_SESSIONS = len(PROMPTS)

#: server log lines that are errors; the VTK warning of a machine without an X server is not one
ERROR_PATTERN = re.compile(r"Traceback|ERROR|Error:|Exception")
WARNING_PATTERN = re.compile(r"WARNING|WARN\b|[Ww]arning:")
HARMLESS = ("bad X server connection",)
#: browser console messages that are not the page's errors (the design's font request fails offline)
PAGE_HARMLESS = ("ERR_NAME_NOT_RESOLVED",)
_TIMESTAMP = re.compile(r"^\s*\d{4}-\d\d-\d\d[ T][\d:,.]+\s*")


# ------------------------------------------------------------------ the server process


def _children(pid: int) -> list[int]:
    kids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
            kids.append(int(entry))
    return kids


def process_tree(pid: int) -> list[int]:
    """``pid`` and all its descendants that are alive."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(_children(p))
    return out


def sample_process(pid: int) -> dict:
    """Resident memory (MB) and threads of ``pid`` and its descendants (from /proc)."""
    rss_kb = threads = 0
    for p in process_tree(pid):
        try:
            status = Path(f"/proc/{p}/status").read_text()
        except OSError:
            continue
        fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
        rss_kb += int(fields.get("VmRSS", "0 kB").split()[0])
        threads += int(fields.get("Threads", "0").strip())
    return {"rss_mb": round(rss_kb / 1024, 1), "threads": threads}


def _server_pid(port: int) -> int:
    """The pid of our child ``moattn serve --port port`` (started by ``app.bench.browser.studio_server``)."""
    for p in _children(os.getpid()):
        try:
            cmd = Path(f"/proc/{p}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"serve" in cmd and str(port).encode() in cmd:
            return p
    raise RuntimeError(f"the server on port {port} is not a child of this process")


# ------------------------------------------------------------------ the server log
#: what Bokeh's server and Tornado raise when a message arrives for a page already gone (reloaded or closed while
#: playing): the connection's session was discarded, or the socket closed mid-send. No page sees it; it is counted
#: apart from the server's errors.
CLOSED_PAGE = ("assert self._session is not None", "StreamClosedError", "WebSocketClosedError")


def _traceback_end(lines: list[str], i: int) -> int:
    """The index of a traceback's exception line (the traceback starts at ``i``)."""
    j = i + 1
    while j < len(lines) and (lines[j].startswith((" ", "\t")) or not lines[j].strip()):
        j += 1
    return j


def _closed_page(lines: list[str], i: int, j: int) -> bool:
    """Whether the traceback in lines i..j (and any it was raised while handling) is a page-already-gone one."""
    block = lines[i:j + 1]
    k = j + 1  # "During handling of the above exception, another exception occurred:" chains the next one on
    while k + 2 < len(lines) and not lines[k].strip() and "During handling" in lines[k + 1]:
        start = next((m for m in range(k + 2, min(k + 5, len(lines))) if "Traceback" in lines[m]), None)
        if start is None:
            break
        end = _traceback_end(lines, start)
        block += lines[start:end + 1]
        k = end + 1
    if i >= 2 and "During handling" in lines[i - 2]:
        return _closed_page_before(lines, i)
    return any(marker in line for line in block for marker in CLOSED_PAGE)


def _closed_page_before(lines: list[str], i: int) -> bool:
    """A chained traceback (at ``i``) takes the verdict of the one it was raised while handling."""
    m = i - 3
    while m >= 0 and "Traceback (most recent call last)" not in lines[m]:
        m -= 1
    return m >= 0 and _closed_page(lines, m, _traceback_end(lines, m))


def _closed_page_error(lines: list[str], i: int) -> bool:
    """An error line whose traceback (within the next lines) is a page-already-gone one."""
    for m in range(i + 1, min(i + 4, len(lines))):
        if "Traceback (most recent call last)" in lines[m]:
            return _closed_page(lines, m, _traceback_end(lines, m))
    return False


def scan_log(text: str, *, warnings: bool = False, closed: bool = False) -> list[dict]:
    """Error lines of a server log, deduplicated with counts, in order of first appearance. A traceback counts once,
    as ``Traceback: <its exception line>``. ``warnings``: the warning lines instead (no tracebacks). ``closed``: only
    the errors of Bokeh's server and Tornado on a page already gone (a message arriving for a session it discarded, a
    socket closed mid-send: :data:`CLOSED_PAGE`), which the other calls leave out."""
    found: Counter = Counter()
    pattern = WARNING_PATTERN if warnings else ERROR_PATTERN
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if any(h in line for h in HARMLESS):
            i += 1
            continue
        if "Traceback (most recent call last)" in line:
            j = _traceback_end(lines, i)
            last = lines[j].strip() if j < len(lines) else "(cut off)"
            if not warnings and _closed_page(lines, i, j) == closed:
                found[f"Traceback: {last}"] += 1
            i = j + 1
            continue
        if pattern.search(line) and not (warnings and ERROR_PATTERN.search(line)):
            gone = not warnings and _closed_page_error(lines, i)
            if gone == closed:
                found[_TIMESTAMP.sub("", line).strip()] += 1
        i += 1
    return [{"line": k, "count": v} for k, v in found.items()]


# ------------------------------------------------------------------ one session


@dataclass
class Session:
    index: int
    prompt: str
    word: str
    page: object = None
    cycles: int = 0
    generations: int = 0
    edits: int = 0
    plays: int = 0
    reloads: int = 0
    closes: int = 0
    generate_s: list = field(default_factory=list)
    edit_s: list = field(default_factory=list)
    cross_talk: list = field(default_factory=list)
    failures: list = field(default_factory=list)
    page_errors: Counter = field(default_factory=Counter)

    @property
    def name(self) -> str:
        return f"{self.index}: {self.prompt}"


def _is_navigation_error(exc: Exception) -> bool:
    text = str(exc)
    return any(s in text for s in ("Execution context was destroyed", "navigation", "Target closed",
                                   "Cannot find context"))


def _until(page, js: str, timeout_s: float, what: str):
    """Yield until ``js`` is true in the page (polled once per round); a TimeoutError after ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while True:
        try:
            if page.evaluate(js):
                return
        except Exception as exc:  # the page is being (re)loaded
            if not _is_navigation_error(exc):
                raise
        if time.monotonic() > end:
            raise TimeoutError(f"{what}: not within {timeout_s:.0f} s")
        yield


def _until_text(page, css: str, text: str, timeout_s: float, what: str):
    """Yield until an element ``css`` shows ``text`` (its shadow root included)."""
    end = time.monotonic() + timeout_s
    locator = page.locator(css, has_text=text)
    while True:
        if locator.count():
            return
        if time.monotonic() > end:
            raise TimeoutError(f"{what}: not within {timeout_s:.0f} s")
        yield


def _pause(seconds: float):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        yield


_DRAWN = "window.moattnPlayer.motion_key in window.moattnPlayer.first_draw"
_NEW_DRAWN = ("window.moattnPlayer && window.moattnPlayer.motion_key !== {key} && "
              "window.moattnPlayer.motion_key >= 0 && " + _DRAWN)


def _ready(page, timeout_s: float):
    """After a goto or reload: the player is mounted, the helpers are installed, the opening motion is drawn."""
    from app.bench import browser as br

    yield from _until(page, "window.moattnPlayer !== undefined", timeout_s, "the player to mount")
    page.evaluate(br.PAGE_HELPERS)
    yield from _until(page, f"window.moattnPlayer.motion_key >= 0 && {_DRAWN}", timeout_s, "the opening motion")


def _open(session: Session, browser, url: str, timeout_s: float):
    from app.bench import browser as br

    page = browser.new_page(viewport=br.VIEWPORT)
    page.set_default_timeout(timeout_s * 1000)
    session.page = page

    def console(m):
        if m.type == "error" and not any(h in m.text for h in PAGE_HARMLESS):
            session.page_errors[f"console error: {m.text[:300]}"] += 1

    def pageerror(e):
        session.page_errors[f"pageerror: {str(e)[:300]}"] += 1

    page.on("console", console)
    page.on("pageerror", pageerror)
    page.goto(url, wait_until="commit")
    yield from _ready(page, timeout_s)


def _close(session: Session) -> None:
    page, session.page = session.page, None
    if page is not None:
        try:
            page.close()
        except Exception:
            pass


def _motion_names(page) -> list[str]:
    return [t.strip() for t in page.locator(".motion-select select option").all_inner_texts()]


def _check_shown(session: Session, cycle: int, step: str) -> None:
    """The Motion list's current entry is this session's prompt."""
    shown = session.page.locator(".motion-select select").input_value()
    if not shown.startswith(session.prompt + " ·"):
        session.cross_talk.append({"session": session.name, "cycle": cycle, "step": step,
                                   "expected": session.prompt, "shown": shown})


def _click_to_first_frame_s(page, key) -> float:
    t = page.evaluate(f"window.moattnPlayer.first_draw[{int(key)}] - window.moattnLastClick")
    return round(float(t) / 1000.0, 3)


def run_session(session: Session, browser, url: str, *, keep_going, steps: int,
                close_every: int, timeout_s: float):
    """One session's cycles as a generator: each ``next`` does one step (or one poll) and returns."""
    while keep_going(session):
        cycle, step = session.cycles, "open"
        try:
            if session.page is None:
                yield from _open(session, browser, url, timeout_s)
            page = session.page
            step = "settings"
            box = page.locator(".steps-input input")
            box.fill(str(steps))
            box.press("Enter")
            yield

            step = "generate"
            key = page.evaluate("window.moattnPlayer.motion_key")
            page.locator(".prompt-input input").fill(session.prompt)
            page.locator(".generate-button button").click()
            yield from _until(page, _NEW_DRAWN.format(key=key), timeout_s, "the generated motion")
            session.generate_s.append(_click_to_first_frame_s(page, page.evaluate("window.moattnPlayer.motion_key")))
            session.generations += 1
            _check_shown(session, cycle, "generate")
            yield

            step = "edit"
            page.locator(".bk-tab", has_text="Edit").click()
            page.locator(".edit-kind button", has_text="emphasise").click()
            page.locator(".edit-words button", has_text=session.word).first.click()
            active = page.locator(".edit-words button.bk-active", has_text=session.word)
            end = time.monotonic() + 30
            while not active.count():
                if time.monotonic() > end:
                    raise TimeoutError(f"the word {session.word!r} was not picked")
                yield
            yield from _pause(0.3)  # the word travels to the server before the click
            key = page.evaluate("window.moattnPlayer.motion_key")
            page.locator(".edit-run button").click()
            yield from _until_text(page, ".edit-result", f"emphasise '{session.word}'", timeout_s, "the edit's result")
            yield from _until(page, _NEW_DRAWN.format(key=key), timeout_s, "the edited motion")
            session.edit_s.append(_click_to_first_frame_s(page, page.evaluate("window.moattnPlayer.motion_key")))
            session.edits += 1
            _check_shown(session, cycle, "edit")
            yield

            step = "play"  # once every frame has arrived (the player never shows a frame early)
            yield from _until(page, "window.moattnPlayer.n_frames > 0 && "
                              "window.moattnPlayer.loaded >= window.moattnPlayer.n_frames", timeout_s, "all frames")
            play = page.locator(".skeleton-view .moattn-play")
            before = page.evaluate("window.moattnPlayer.distinct")
            play.click()
            yield from _until(page, "window.moattnPlayer.playing", 10, "playing")
            yield from _pause(1.0)
            played = page.evaluate("window.moattnPlayer.distinct") - before
            play.click()
            if played < 2:
                raise RuntimeError(f"playing for a second drew {played} frames")
            session.plays += 1

            step = "reload"
            page.reload(wait_until="commit")
            yield from _ready(page, timeout_s)
            session.reloads += 1
            names = _motion_names(page)  # the Motion list is the motion library: a reload loses nothing
            if not any(n.startswith(session.prompt + " ·") for n in names):
                session.failures.append({"session": session.name, "cycle": cycle, "step": "reload",
                                         "error": "the motion made before the reload is not in the Motion list"})

            step = "close"
            if (cycle + 1) % close_every == 0:
                _close(session)
                session.closes += 1
            session.cycles += 1
            yield
        except Exception as exc:
            session.failures.append({"session": session.name, "cycle": cycle, "step": step,
                                     "error": f"{type(exc).__name__}: {str(exc).splitlines()[0][:300] if str(exc) else ''}"})
            _close(session)
            session.cycles += 1  # a failed cycle counts, so a broken session cannot loop forever
            yield


# ------------------------------------------------------------------ the soak


def page_load_burst(url: str, n: int) -> dict:
    """``n`` concurrent ``GET /`` (each builds a session's page on the server): seconds until all are served."""
    import concurrent.futures
    import urllib.request

    def get(_):
        t0 = time.perf_counter()
        with urllib.request.urlopen(url, timeout=120) as response:
            response.read()
        return time.perf_counter() - t0

    t0 = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(n) as pool:
        each = list(pool.map(get, range(n)))
    return {"all_s": round(time.perf_counter() - t0, 2), "slowest_s": round(max(each), 2),
            "each_s": [round(x, 2) for x in each]}


@dataclass
class ServerMemory:
    """The server's resident memory and threads: ``before`` the pages, once every session finished its first cycle
    (``warm``), ``after`` the closed sessions had time to be discarded, and the ``peak`` over every sample."""
    pid: int
    before: dict
    peak: dict
    warm: dict | None = None
    after: dict | None = None

    @classmethod
    def start(cls, pid: int) -> ServerMemory:
        before = sample_process(pid)
        return cls(pid, before, dict(before))

    def sample(self) -> dict:
        current = sample_process(self.pid)
        self.peak = {k: max(self.peak[k], current[k]) for k in self.peak}
        return current


def _check_soak(model_dir: Path, sessions: int, minutes: float, br) -> None:
    if not 1 <= sessions <= MAX_SESSIONS:
        raise ValueError(f"--sessions must be between 1 and {MAX_SESSIONS}, got {sessions}")
    if not minutes > 0:
        raise ValueError(f"--minutes must be more than 0, got {minutes}")
    if not Path(model_dir).exists():
        raise FileNotFoundError(f"no model at {model_dir}")
    if not br.chromium_available():
        raise FileNotFoundError(f"{br.CHROMIUM} not found: apt-get install chromium")


def _drive(group: list[Session], browser, url: str, memory: ServerMemory, *, deadline: float, t_start: float,
           say, **session_options) -> None:
    """Run the sessions round-robin until each is done, sampling the server about once a second (and once when
    every session finished its first cycle: ``warm``)."""
    def keep_going(s: Session) -> bool:
        return s.cycles == 0 or time.monotonic() < deadline

    running = {s.index: run_session(s, browser, url, keep_going=keep_going, **session_options) for s in group}
    last_sample = last_say = 0.0
    while running:
        for s in group:
            gen = running.get(s.index)
            if gen is None:
                continue
            try:
                next(gen)
            except StopIteration:
                del running[s.index]
        now = time.monotonic()
        first_cycles_done = memory.warm is None and all(s.cycles for s in group)
        if now - last_sample > 1.0 or first_cycles_done:
            last_sample = now
            cur = memory.sample()
            if first_cycles_done:
                memory.warm = cur
            if now - last_say > 30:
                last_say = now
                say(f"{now - t_start:5.0f} s: {cur['rss_mb']} MB, {cur['threads']} threads; cycles "
                    + ", ".join(str(s.cycles) for s in group))
        time.sleep(0.05)


def _settle(memory: ServerMemory, settle_s: float, say) -> None:
    """Wait ``settle_s`` for the server to discard the closed sessions (sampling the peak), then sample ``after``."""
    if settle_s > 0:
        say(f"pages closed; {settle_s:.0f} s for the server to discard the sessions")
        end = time.monotonic() + settle_s
        while time.monotonic() < end:
            memory.sample()
            time.sleep(1.0)
    memory.after = memory.sample()


def bench_soak(model_dir: Path, *, sessions: int = 5, minutes: float = 10.0, log_path: Path | None = None,
               steps: int = 10, close_every: int = 1, settle_s: float = 40.0, timeout_s: float = 300.0,
               library_mb: float | None = None, restart: bool = True, log=None) -> dict:
    """Drive ``sessions`` browser sessions against one server for ``minutes``; see the module's docstring.

    ``settle_s``: after the last page is closed, wait this long before the final memory sample (Bokeh discards a
    closed session after about 15-30 s). ``timeout_s``: the longest wait for one result. ``library_mb``: the
    motion library's bound (``moattn serve --library-mb``; None: the default). ``restart``: afterwards, start the
    server again on the same workspace and check that its Motion list lists every motion the library kept.
    """
    from playwright.sync_api import sync_playwright

    from app.bench import browser as br

    _check_soak(model_dir, sessions, minutes, br)
    say = log or (lambda line: None)
    if log_path is None:
        log_path = Path(tempfile.mkdtemp(prefix="moattn-soak-")) / "serve.log"
    log_path = Path(log_path)
    group = [Session(i, *PROMPTS[i]) for i in range(sessions)]
    scratch = tempfile.TemporaryDirectory(prefix="moattn-soak-workspace-")  # never the user's own library
    workspace = Path(scratch.name)
    serve_args = () if library_mb is None else ("--library-mb", f"{library_mb:g}")

    port = br.free_port()
    t_start = time.monotonic()
    with br.studio_server(model_dir, port=port, log_path=log_path, workspace=workspace,
                          extra_args=serve_args) as url, sync_playwright() as pw:
        pid = _server_pid(port)
        memory = ServerMemory.start(pid)
        say(f"server {url} (pid {pid}): {memory.before['rss_mb']} MB, {memory.before['threads']} threads; "
            f"{sessions} sessions for {minutes:g} min")
        burst = page_load_burst(url, sessions)
        say(f"{sessions} concurrent GET /: all served in {burst['all_s']} s (slowest {burst['slowest_s']} s)")
        deadline = time.monotonic() + minutes * 60
        browser = br.launch(pw)
        try:
            _drive(group, browser, url, memory, deadline=deadline, t_start=t_start, say=say, steps=steps,
                   close_every=close_every, timeout_s=timeout_s)
        finally:
            for s in group:
                _close(s)
            browser.close()
        soak_s = time.monotonic() - t_start
        _settle(memory, settle_s, say)
    with scratch:
        library = library_report(group, workspace, model_dir=model_dir, restart=restart, timeout_s=timeout_s,
                                 serve_args=serve_args, log_path=log_path.with_name(log_path.stem + "-restart.log"),
                                 say=say)
    settings = {"sessions": sessions, "minutes": minutes, "model": str(model_dir), "steps": steps,
                "library_mb": library_mb}
    return _soak_report(group, memory, burst, log_path, settings, soak_s=soak_s, settle_s=settle_s, library=library)


def library_report(group: list[Session], workspace: Path, *, model_dir: Path, restart: bool, timeout_s: float,
                   serve_args: tuple = (), log_path: Path | None = None, say=lambda line: None) -> dict:
    """What the motion library holds after the soak, read from disk: one generated entry per generation, each
    with its whole recipe (prompt, seed, steps, guidance, model), its size against its bound; with ``restart``,
    a server started again on the same workspace and the titles its Motion list shows, beside the entries."""
    from engine.library import MotionLibrary

    lib = MotionLibrary(workspace=workspace)
    entries = lib.entries()
    kinds = Counter(e.kind for e in entries)
    generated = [e for e in entries if e.kind == "generate"]
    missing_recipe = []
    for e in generated:
        recipe = lib.recipe(e.id)
        lacking = [k for k in ("prompt", "seed", "steps", "guidance", "model") if recipe.get(k) in (None, "")]
        if lacking:
            missing_recipe.append({"title": e.title, "lacking": lacking})
    report = {"generations": sum(s.generations for s in group), "edits": sum(s.edits for s in group),
              "entries": len(entries), "by_kind": dict(sorted(kinds.items())), "generated_kept": len(generated),
              "recipes_missing": missing_recipe, "bytes": lib.total_bytes(), "limit_bytes": lib.limit_bytes,
              "largest_bytes": max((e.bytes for e in entries), default=0),
              "listed_after_restart": None, "not_listed_after_restart": []}
    if restart:
        listed = _listed_after_restart(model_dir, workspace, serve_args=serve_args, timeout_s=timeout_s,
                                       log_path=log_path)
        report["listed_after_restart"] = len(listed)
        report["not_listed_after_restart"] = not_listed([e.title for e in entries], listed)
        say(f"server restarted on the same workspace: its Motion list shows {len(listed)} of {len(entries)} "
            f"motions kept")
    return report


def not_listed(titles: list[str], listed: list[str]) -> list[str]:
    """The kept titles a Motion list does not show, compared without the "(2)" that tells repeated titles apart (a
    kept title may carry the session's own, and the list numbers its repeats again when it reads them back)."""
    shown = Counter(_base_title(n) for n in listed)
    kept = Counter(_base_title(t) for t in titles)
    return sorted((kept - shown).elements())


def _base_title(name: str) -> str:
    """A Motion list name without the ``(2)`` a repeated title gets."""
    return re.sub(r"\s+\(\d+\)$", "", name)


def _listed_after_restart(model_dir: Path, workspace: Path, *, serve_args: tuple, timeout_s: float,
                          log_path: Path | None) -> list[str]:
    """Start the server again on ``workspace``, open one page and read its Motion list."""
    from playwright.sync_api import sync_playwright

    from app.bench import browser as br

    with br.studio_server(model_dir, workspace=workspace, extra_args=serve_args, log_path=log_path) as url, \
            sync_playwright() as pw:
        browser = br.launch(pw)
        try:
            page = br.open_studio(browser, url, timeout_ms=timeout_s * 1000)
            return _motion_names(page)
        finally:
            browser.close()


def _soak_report(group: list[Session], memory: ServerMemory, burst: dict, log_path: Path, settings: dict, *,
                 soak_s: float, settle_s: float, library: dict | None = None) -> dict:
    """The result of :func:`bench_soak`: the server log's errors and warnings, memory, each session's counts and
    worst times, cross-talk, failures and page errors, and ``ok``."""
    sessions = len(group)
    before, warm, after, peak = memory.before, memory.warm, memory.after, memory.peak
    log_text = log_path.read_text(errors="replace")
    server_errors, server_warnings = scan_log(log_text), scan_log(log_text, warnings=True)
    closed_page = scan_log(log_text, closed=True)

    def worst(xs):
        return max(xs) if xs else None

    page_errors = Counter()
    for s in group:
        page_errors.update(s.page_errors)
    cross_talk = [c for s in group for c in s.cross_talk]
    failures = [f for s in group for f in s.failures]
    per_session = {s.name: {"cycles": s.cycles, "generations": s.generations, "edits": s.edits, "plays": s.plays,
                            "reloads": s.reloads, "closes": s.closes, "worst_generate_s": worst(s.generate_s),
                            "worst_edit_s": worst(s.edit_s)} for s in group}
    loads = sum(s.reloads + s.closes for s in group) + sessions  # every page opened or reloaded
    growth = None if warm is None else round((after["rss_mb"] - warm["rss_mb"]) / max(1, loads - sessions), 3)
    result = {
        **settings,
        "page_loads": loads, "rss_growth_per_load_mb": growth, "burst_get_s": burst,
        "cycles": sum(s.cycles for s in group),
        "soak_s": round(soak_s, 1), "settle_s": settle_s,
        "server_log": str(log_path),
        "server_errors": server_errors,
        "server_warnings": server_warnings,
        "closed_page_errors": closed_page,
        "rss_mb": {"before": before["rss_mb"], "warm": None if warm is None else warm["rss_mb"],
                   "after": after["rss_mb"], "peak": peak["rss_mb"]},
        "threads": {"before": before["threads"], "warm": None if warm is None else warm["threads"],
                    "after": after["threads"], "peak": peak["threads"]},
        "worst_time_to_result_s": {s.name: worst(s.generate_s + s.edit_s) for s in group},
        "per_session": per_session,
        "cross_talk": cross_talk,
        "failures": failures,
        "page_errors": [{"line": k, "count": v} for k, v in page_errors.items()],
        "cpus": os.cpu_count(), "load_average": [round(x, 2) for x in os.getloadavg()],
        "when": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    result["library"] = library
    result["ok"] = (not server_errors and not cross_talk and not failures and not page_errors
                    and all(s.generations and s.edits for s in group) and library_ok(library))
    return result


def library_ok(lib: dict | None) -> bool:
    """Nothing lost and nothing past the bound: every generation kept with its whole recipe (unless the bound
    removed motions, which only happens past it), the library within its bound, and after a restart every kept
    motion listed."""
    if lib is None:
        return True
    within = lib["bytes"] <= lib["limit_bytes"]
    all_kept = lib["generated_kept"] == lib["generations"]
    at_bound = lib["bytes"] + lib["largest_bytes"] > lib["limit_bytes"]  # one more would have gone past it
    return (within and (all_kept or (lib["generated_kept"] < lib["generations"] and at_bound))
            and not lib["recipes_missing"] and not lib["not_listed_after_restart"])


def format_table(r: dict) -> str:
    def num(x, unit=""):
        return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:g}{unit}"

    out = [f"soak: {r['sessions']} sessions, {r['minutes']:g} min ({r['soak_s']:.0f} s), {r['cycles']} cycles, "
           f"{r['steps']} steps; model {r['model']}; load average {r['load_average']}",
           "", f"{'session':34} {'cycles':>6} {'gen':>4} {'edit':>4} {'reload':>6} {'close':>5} "
               f"{'worst gen':>9} {'worst edit':>10} {'worst result':>12}"]
    for name, s in r["per_session"].items():
        out.append(f"{name[:34]:34} {s['cycles']:>6} {s['generations']:>4} {s['edits']:>4} {s['reloads']:>6} "
                   f"{s['closes']:>5} {num(s['worst_generate_s'], ' s'):>9} {num(s['worst_edit_s'], ' s'):>10} "
                   f"{num(r['worst_time_to_result_s'][name], ' s'):>12}")
    m, t = r["rss_mb"], r["threads"]
    out += ["", f"server memory   before {num(m['before'])} MB, warm {num(m['warm'])} MB, after {num(m['after'])} MB "
                f"({r['settle_s']:g} s after the last page closed), peak {num(m['peak'])} MB",
            f"server threads  before {num(t['before'])}, warm {num(t['warm'])}, after {num(t['after'])}, "
            f"peak {num(t['peak'])}",
            f"page loads      {r['page_loads']}; memory after - warm per load after the first: "
            f"{num(r['rss_growth_per_load_mb'])} MB",
            f"{r['sessions']} concurrent GET / at the start: all served in {num(r['burst_get_s']['all_s'])} s "
            f"(slowest {num(r['burst_get_s']['slowest_s'])} s)"]
    for title, rows in (("server errors", r["server_errors"]), ("server warnings (not failing)", r["server_warnings"]),
                        ("Bokeh/Tornado on a page already gone (not failing)", r.get("closed_page_errors", [])),
                        ("page errors", r["page_errors"])):
        out.append(f"{title}: {'none' if not rows else len(rows)}")
        out += [f"  {row['count']:>3} x {row['line']}" for row in rows]
    out.append(f"cross-talk: {'none' if not r['cross_talk'] else len(r['cross_talk'])}")
    out += [f"  {c['session']} cycle {c['cycle']} {c['step']}: shows {c['shown']!r}" for c in r["cross_talk"]]
    out.append(f"failures: {'none' if not r['failures'] else len(r['failures'])}")
    out += [f"  {f['session']} cycle {f['cycle']} {f['step']}: {f['error']}" for f in r["failures"]]
    lib = r.get("library")
    if lib is not None:
        out.append(f"library: {lib['generations']} generations, {lib['edits']} edits -> {lib['entries']} motions kept "
                   f"({', '.join(f'{k} {v}' for k, v in lib['by_kind'].items())}); generated kept "
                   f"{lib['generated_kept']} of {lib['generations']}, recipes missing a field: "
                   f"{len(lib['recipes_missing'])}; {lib['bytes'] / 2**20:.1f} MB of its "
                   f"{lib['limit_bytes'] / 2**20:g} MB bound")
        if lib["listed_after_restart"] is not None:
            out.append(f"after a server restart on the same workspace: the Motion list shows "
                       f"{lib['listed_after_restart']} motions; kept but not listed: "
                       f"{len(lib['not_listed_after_restart']) or 'none'}")
    out.append(f"server log: {r['server_log']}")
    out.append("OK" if r["ok"] else "NOT OK")
    return "\n".join(out)


def run_soak_bench(args) -> int:
    import sys

    sessions = 5 if args.sessions is None else args.sessions
    minutes = 10.0 if args.minutes is None else args.minutes
    steps = 10 if args.steps is None else args.steps
    result = bench_soak(args.model, sessions=sessions, minutes=minutes, log_path=args.log, steps=steps,
                        library_mb=args.library_mb, log=lambda line: print(line, file=sys.stderr, flush=True))
    print(json.dumps(result, indent=2) if args.json else format_table(result))
    return 0 if result["ok"] else 1
