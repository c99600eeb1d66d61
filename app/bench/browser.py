"""Drive the studio in Debian's Chromium with Playwright: a real ``moattn serve`` on a free port.

Used by the browser tests and by ``moattn bench --app``. Nothing is downloaded: Chromium is
``/usr/bin/chromium`` (WebGL through SwiftShader), Playwright is only the driver.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the project: where `python -m engine.cli` runs

CHROMIUM = os.environ.get("MOATTN_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run",
]
VIEWPORT = {"width": 1500, "height": 1100}

#: JavaScript helpers installed in the page: deep queries through shadow roots, canvas hashes.
PAGE_HELPERS = r"""
(() => {
  if (window.moattnTest) return;
  function deepAll(root, sel, out) {
    out = out || [];
    root.querySelectorAll(sel).forEach(e => out.push(e));
    root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) deepAll(e.shadowRoot, sel, out); });
    return out;
  }
  function canvases(hostSel) {
    const hosts = deepAll(document, hostSel);
    const out = [];
    hosts.forEach(h => deepAll(h.shadowRoot || h, 'canvas', out));
    hosts.forEach(h => { if (h.tagName === 'CANVAS') out.push(h); });
    return out;
  }
  function canvasHash(hostSel) {
    return hashOf(canvases(hostSel));
  }
  function hashOf(list) {
    let hash = 0;
    for (const c of list) {
      if (!c.width || !c.height) continue;
      let ctx; try { ctx = c.getContext('2d'); } catch (e) { continue; }
      if (!ctx) continue;
      const d = ctx.getImageData(0, 0, c.width, c.height).data;
      for (let i = 0; i < d.length; i += 97) hash = (hash * 31 + d[i]) | 0;
    }
    return hash;
  }
  function waitChange(hostSel, before, timeoutMs) {
    return new Promise(resolve => {
      const t0 = performance.now();
      function poll() {
        const h = canvasHash(hostSel);
        if (h !== before) return resolve(performance.now() - t0);
        if (performance.now() - t0 > timeoutMs) return resolve(-1);
        requestAnimationFrame(poll);
      }
      poll();
    });
  }
  function selectOption(hostSel, label) {
    const sel = deepAll(document, hostSel + ' select')[0] || deepAll(deepAll(document, hostSel)[0].shadowRoot, 'select')[0];
    const opt = Array.from(sel.options).find(o => o.textContent.trim() === label);
    if (!opt) throw new Error('no option ' + label + ' in ' + Array.from(sel.options).map(o => o.textContent));
    sel.value = opt.value;
    sel.dispatchEvent(new Event('input', {bubbles: true}));
    sel.dispatchEvent(new Event('change', {bubbles: true}));
  }
  // when each canvas last had an image drawn into it (Bokeh draws its image glyphs with drawImage): lets a
  // timing wait for the redraw without reading pixels back every frame (a read-back is slow under SwiftShader
  // and would be part of what it measures)
  const lastImageDraw = new WeakMap();
  const drawImage = CanvasRenderingContext2D.prototype.drawImage;
  CanvasRenderingContext2D.prototype.drawImage = function (...args) {
    lastImageDraw.set(this.canvas, performance.now());
    return drawImage.apply(this, args);
  };
  function drawnSince(list, t0) {
    return list.some(c => (lastImageDraw.get(c) || -1) > t0);
  }
  async function timedSelect(selectHost, label, canvasHost, timeoutMs) {
    // ms from the change until the canvas shows new pixels: the first frame after an image is drawn into it
    // whose pixels differ from before (-1: no change within timeoutMs). The canvases are looked up once, before
    // the change: a deep query of the page at every frame would take the page's time from what is measured.
    const list = canvases(canvasHost);
    const before = hashOf(list);
    const t0 = performance.now();
    let since = t0;
    selectOption(selectHost, label);
    return await new Promise(resolve => {
      function poll(now) {
        if (drawnSince(list, since)) {
          if (hashOf(list) !== before) return resolve(now - t0);
          since = performance.now();  // redrawn with the same pixels: keep waiting
        }
        if (performance.now() - t0 > (timeoutMs || 5000)) return resolve(-1);
        requestAnimationFrame(poll);
      }
      requestAnimationFrame(poll);
    });
  }
  // when the last button press was handled and when the first move more than 5 px away from it was (page clock):
  // BokehJS takes a press whose first such move comes later than its press threshold for a "press", not a drag
  const pointer = {down: -1, moved: -1, up: -1, x: 0, y: 0};
  document.addEventListener('pointerdown', e => {
    Object.assign(pointer, {down: performance.now(), moved: -1, up: -1, x: e.clientX, y: e.clientY});
  }, true);
  document.addEventListener('pointerup', () => { pointer.up = performance.now(); }, true);
  document.addEventListener('pointermove', e => {
    if (pointer.down < 0 || pointer.moved >= 0 || !e.buttons) return;
    if (Math.hypot(e.clientX - pointer.x, e.clientY - pointer.y) > 5) pointer.moved = performance.now();
  }, true);
  // the data of the first glyph renderer of the Bokeh plot with this css class, as the page holds it (what the
  // server sent last): {column: plain array}; null before the plot exists
  function plotData(cls) {
    const doc = window.Bokeh && Bokeh.documents[0];
    if (!doc) return null;
    const plot = [...doc.all_models].find(m => (m.css_classes || []).includes(cls) && m.renderers);
    const r = plot && plot.renderers.find(r => r.data_source);
    if (!r) return null;
    const data = r.data_source.data, out = {};
    const entries = data instanceof Map ? [...data.entries()] : Object.entries(data);
    for (const [k, v] of entries) out[k] = Array.from(v, x => (x && x.length !== undefined && typeof x !== 'string') ? Array.from(x) : x);
    return out;
  }
  window.moattnTest = {deepAll, canvases, canvasHash, waitChange, selectOption, timedSelect, pointer, plotData};
  window.moattnLastClick = 0;
  window.moattnLastClickWall = 0;
  document.addEventListener('click', () => { window.moattnLastClick = performance.now(); window.moattnLastClickWall = Date.now() / 1000; }, true);
})();
"""


def chromium_available() -> bool:
    return Path(CHROMIUM).exists() or shutil.which(CHROMIUM) is not None


def free_port() -> int:
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def studio_server(model_dir: str | os.PathLike, *, port: int | None = None, log_path: Path | None = None,
                  timeout: float = 300.0, duet_dir: str | os.PathLike | None = None,
                  workspace: str | os.PathLike | None = None, extra_args: tuple[str, ...] = ()) -> Iterator[str]:
    """Run ``moattn serve --model model_dir`` on a free port; yields its URL, stops it afterwards.

    ``workspace``: the motion library's folder; None: a temporary one, removed afterwards (a test or a bench never
    writes into the user's own library). ``timeout``: the longest wait for its first answer (a start on two cores
    busy with a training run took over 90 s: torch, Panel and the model load at the lowest priority)."""
    import tempfile

    port = port or free_port()
    scratch = None
    if workspace is None:
        scratch = tempfile.TemporaryDirectory(prefix="moattn-workspace-")
        workspace = scratch.name
    cmd = [sys.executable, "-m", "engine.cli", "serve", "--port", str(port), "--address", "localhost",
           "--model", str(model_dir), "--workspace", str(workspace), *extra_args] + (
               [] if duet_dir is None else ["--duet-model", str(duet_dir)])
    log = open(log_path, "w") if log_path else subprocess.DEVNULL
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env,
                            cwd=ROOT)
    url = f"http://localhost:{port}/"
    try:
        end = time.monotonic() + timeout
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"moattn serve exited with {proc.returncode}" +
                                   (f"; see {log_path}" if log_path else ""))
            try:
                with urllib.request.urlopen(url + "liveness", timeout=2):
                    break
            except Exception:
                pass
            if time.monotonic() > end:
                raise TimeoutError(f"moattn serve did not answer on {url} within {timeout:.0f} s")
            time.sleep(0.3)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
        if log_path:
            log.close()
        if scratch is not None:
            scratch.cleanup()


#: Compositing modes: "swiftshader" (GPU emulated by SwiftShader, as a GPU-less CI runs Chromium) and
#: "software" (``--disable-gpu``: Chromium's CPU compositor, what a GPU-less desktop falls back to). The
#: studio needs no WebGL (frames are rendered by the server), so both show the same page.
COMPOSITING = {"swiftshader": [], "software": ["--disable-gpu"]}


def launch(playwright, compositing: str = "swiftshader"):
    """Debian's Chromium through Playwright (never a downloaded browser)."""
    if compositing not in COMPOSITING:
        raise ValueError(f"compositing must be one of {sorted(COMPOSITING)}")
    return playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS + COMPOSITING[compositing])


def open_studio(browser, url: str, *, timeout_ms: float = 180000, opening_motion: bool = True,
                viewport: dict | None = None):
    """A page with the studio loaded (player mounted) and the helpers installed.

    ``opening_motion``: the server opens every page on a motion (``moattn serve`` shows the example
    walk); wait until it is drawn, so that it cannot arrive after the first generated one. ``timeout_ms``: the
    longest wait for each of these (the server builds a first page in over 60 s on two cores busy with a training
    run). ``viewport``: the page's size (default ``VIEWPORT``).
    """
    page = browser.new_page(viewport=viewport or VIEWPORT)
    page.console_messages = []
    page.on("console", lambda m: page.console_messages.append(f"{m.type}: {m.text}"))
    page.on("pageerror", lambda e: page.console_messages.append(f"pageerror: {e}"))
    page.requests_seen = []  # every URL the page asked for (the studio must not need the network)
    page.on("request", lambda r: page.requests_seen.append(r.url))
    page.goto(url, timeout=timeout_ms)
    page.wait_for_function("window.moattnPlayer !== undefined", timeout=timeout_ms)
    page.evaluate(PAGE_HELPERS)
    if opening_motion:
        page.wait_for_function("window.moattnPlayer.motion_key >= 0 && "
                               "(window.moattnPlayer.motion_key in window.moattnPlayer.first_draw)", timeout=timeout_ms)
    return page


#: the page has drawn everything it holds: every Bokeh view has finished its layout and rendering, and the 3-D
#: viewer has drawn the frame it shows
DRAWN_JS = """() => {
  const p = window.moattnPlayer;
  return !!p && p.last_drawn === p.frame && [...Bokeh.index].every(v => v.has_finished());
}"""


def painted(page, *, timeout_ms: float = 30000) -> None:
    """Wait until the page has drawn what it holds (``DRAWN_JS``) and two animation frames more have passed (the
    viewer redraws a changed view at its next frame, and a frame is painted before the next one starts): what a
    screenshot then shows is what the page holds, not a half-drawn picture. What the page should hold (a new
    motion, a server's answer) is each test's own condition, waited on before this."""
    page.wait_for_function(DRAWN_JS, timeout=timeout_ms)
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r())))")


def animations_done(page, *, timeout_ms: float = 10000) -> None:
    """Wait until no finite CSS animation or transition runs in the page (e.g. notifications have slid in)."""
    page.wait_for_function("() => document.getAnimations().every(a => a.playState !== 'running' || "
                           "a.effect.getComputedTiming().endTime === Infinity)", timeout=timeout_ms)


def external_requests(page) -> list[str]:
    """URLs the page requested from anywhere but this machine."""
    from urllib.parse import urlparse

    local = {"localhost", "127.0.0.1", "::1"}
    return [u for u in page.requests_seen
            if not u.startswith(("data:", "blob:")) and urlparse(u).hostname not in local]


def player_stats(page) -> dict:
    return page.evaluate("JSON.parse(JSON.stringify(window.moattnPlayer))")


def generate(page, prompt: str, *, timeout_ms: float = 120000) -> dict:
    """Type a prompt, press Generate, wait for the progress to finish and the first frame of the new motion.

    Returns timings: ``click_to_first_frame_ms`` (page clock) and the player stats.
    """
    before = player_stats(page)["motion_key"]
    box = page.locator(".prompt-input input")
    box.fill(prompt)
    page.locator(".generate-button button").click()
    key = page.wait_for_function(
        f"window.moattnPlayer.motion_key !== {before} && (window.moattnPlayer.motion_key in window.moattnPlayer.first_draw)"
        " && window.moattnPlayer.motion_key", timeout=timeout_ms).json_value()
    stats = player_stats(page)
    first = stats["first_draw"][str(key)]
    click = page.evaluate("window.moattnLastClick")
    return {"click_to_first_frame_ms": first - click, "stats": stats}


def wait_new_motion(page, key_before: int, *, timeout_ms: float = 180000) -> None:
    """Wait until the viewer shows another motion than ``key_before`` (a tab's run finished), all its frames have
    arrived and it has been drawn (``timeout_ms`` for each: a run on a busy machine takes minutes)."""
    page.wait_for_function(f"window.moattnPlayer.motion_key !== {int(key_before)}", timeout=timeout_ms)
    wait_all_frames(page, timeout_ms=timeout_ms)
    page.wait_for_function("window.moattnPlayer.motion_key in window.moattnPlayer.first_draw", timeout=timeout_ms)


def wait_all_frames(page, timeout_ms: float = 120000) -> None:
    page.wait_for_function("window.moattnPlayer.n_frames > 0 && window.moattnPlayer.loaded >= window.moattnPlayer.n_frames",
                           timeout=timeout_ms)


def measure_draw_rate(page, seconds: float = 3.0) -> dict:
    """Press Play and count the pictures the viewer draws per second (poses are interpolated between the motion's
    frames, so the rate is the display's when the page keeps up); ``frames``: the motion's frames shown meanwhile,
    ``draw_ms``: the median cost of one picture. Pauses again."""
    read = "[window.moattnPlayer.draws, performance.now(), window.moattnPlayer.distinct]"
    page.locator(".skeleton-view .moattn-play").click()
    page.wait_for_function("window.moattnPlayer.playing", timeout=5000)
    page.wait_for_timeout(300)
    a = page.evaluate(read)
    page.wait_for_timeout(seconds * 1000)
    b = page.evaluate(read)
    cost = page.evaluate("(() => { const d = [...window.moattnPlayer.draw_ms].sort((x, y) => x - y);"
                         " return d.length ? d[d.length >> 1] : null; })()")
    page.locator(".skeleton-view .moattn-play").click()
    page.wait_for_function("!window.moattnPlayer.playing", timeout=5000)
    elapsed = (b[1] - a[1]) / 1000.0
    return {"fps": (b[0] - a[0]) / elapsed if elapsed > 0 else 0.0, "draws": b[0] - a[0], "frames": b[2] - a[2],
            "draw_ms": cost}


def measure_orbit(page, *, moves: int = 40) -> dict:
    """Drag across the viewer (orbit): ``frame_ms`` is the page's time per picture while the mouse moves, and
    ``changed`` whether the camera turned."""
    canvas = page.locator(".skeleton-view canvas")
    box = stable_box(canvas)
    before = page.evaluate("({...window.moattnPlayer.camera})")
    x, y = box["x"] + box["width"] * 0.3, box["y"] + box["height"] * 0.5
    page.mouse.move(x, y)
    page.mouse.down()
    a = page.evaluate("[window.moattnPlayer.draws, performance.now()]")
    for i in range(1, moves + 1):
        page.mouse.move(x + i * box["width"] * 0.4 / moves, y + i * 0.5)
    page.wait_for_function(f"window.moattnPlayer.draws > {a[0]}", timeout=5000)
    b = page.evaluate("[window.moattnPlayer.draws, performance.now()]")
    page.mouse.up()
    after = page.evaluate("({...window.moattnPlayer.camera})")
    draws = max(1, b[0] - a[0])
    return {"frame_ms": (b[1] - a[1]) / draws, "draws": draws,
            "changed": abs(after["az"] - before["az"]) > 5, "camera": (before, after)}


def run_transfer(page, *, leader: str, follower: str, timeout_ms: float = 300000) -> dict:
    """Run the Transfer tab on two prompts; ``playable_s``: from the job's end (server clock) until the page drew
    the leader / follower / out scene (page clock; one machine, one wall clock)."""
    from playwright.sync_api import expect

    key = player_stats(page)["motion_key"]
    page.locator(".bk-tab", has_text="Transfer").click()
    for role, prompt in (("leader", leader), ("follower", follower)):
        page.locator(f".transfer-{role} .source-prompt input").fill(prompt)
    for role, prompt in (("leader", leader), ("follower", follower)):
        # the server has each prompt: it shows the prompt's words under its box
        expect(page.locator(f".transfer-{role} .source-words .prompt-chips")).to_have_text(prompt, timeout=30000)
    page.locator(".transfer-run button").click()
    new = page.wait_for_function(
        f"window.moattnPlayer.motion_key > {key} && (window.moattnPlayer.motion_key in window.moattnPlayer.first_draw)"
        " && window.moattnPlayer.roles[window.moattnPlayer.motion_key] >= 3 && window.moattnPlayer.motion_key",
        timeout=timeout_ms).json_value()
    stats = player_stats(page)
    job = stats["job"].get(str(new)) or {}
    drawn = stats["first_draw_wall"][str(new)]
    return {"playable_s": drawn - job["ended"] if job else None, "roles": stats["roles"][str(new)]}


#: BokehJS's default UIGestures.press_threshold (ms): a button held this long before the pointer moves is a press,
#: not a drag (the studio raises it: app.views.control_canvas.allow_hold_then_draw)
BOKEH_PRESS_MS = 300


def press_threshold(page) -> float:
    """The page's BokehJS press threshold (ms); Bokeh's default where it cannot be read."""
    return float(page.evaluate(
        "(() => { try { return Bokeh.require('core/ui_gestures').UIGestures.press_threshold; }"
        f" catch (e) {{ return {BOKEH_PRESS_MS}; }} }})()"))


def stable_box(locator, *, timeout_ms: float = 10000, interval_ms: float = 150) -> dict:
    """The element's bounding box once it has stopped moving (two reads ``interval_ms`` apart agree)."""
    page = locator.page
    t0 = time.monotonic()
    box = locator.bounding_box()
    while True:
        page.wait_for_timeout(interval_ms)
        again = locator.bounding_box()
        if box and again == box:
            return box
        if (time.monotonic() - t0) * 1000 > timeout_ms:
            raise TimeoutError(f"the element kept moving for {timeout_ms:.0f} ms: {box} -> {again}")
        box = again


def _at(box: dict, u: float, v: float) -> tuple[float, float]:
    return box["x"] + u * box["width"], box["y"] + v * box["height"]


def _gesture(locator, act, gap, *, attempts: int) -> dict:
    """Run a mouse gesture (``act(box)``) on the element until Bokeh cannot have taken it for a press.

    Playwright sends each mouse event once the page has handled the one before, so on a loaded machine the next
    event can come later than Bokeh's press threshold after the button went down; Bokeh then takes the gesture for
    a press (a drag's moves and a click's tap are ignored; a hand is quicker). Only such a gesture, measured on the
    page clock (``gap(pointer)``, ms), is done again, up to ``attempts`` times. Returns the box and the gaps seen.
    """
    page = locator.page
    box = stable_box(locator)
    threshold = press_threshold(page)
    gaps = []
    for _ in range(attempts):
        act(box)
        ptr = page.evaluate("({...window.moattnTest.pointer})")
        gaps.append(gap(ptr))
        if gaps[-1] < threshold * 0.8:
            break
        page.wait_for_timeout(400)
    return {"box": box, "gaps_ms": gaps}


def drag(locator, path: list[tuple[float, float]], *, hold_ms: float = 0, attempts: int = 3) -> dict:
    """Drag the mouse along ``path`` (fractions of the element's box, x right, y down) as one stroke, the button
    held still for ``hold_ms`` first; a stroke that Bokeh may have taken for a press is drawn again (``_gesture``)."""
    page = locator.page

    def act(box):
        page.mouse.move(*_at(box, *path[0]))
        page.wait_for_timeout(100)
        page.mouse.down()
        if hold_ms:
            page.wait_for_timeout(hold_ms)
        for u, v in path[1:]:
            page.mouse.move(*_at(box, u, v))
        page.mouse.up()

    return _gesture(locator, act, lambda p: p["moved"] - p["down"] if p["moved"] >= 0 else float("inf"),
                    attempts=attempts)


def tap(locator, u: float, v: float, *, attempts: int = 3) -> dict:
    """Click at (u, v), fractions of the element's box; a click that Bokeh may have taken for a press is made again
    (``_gesture``), so what it does must not depend on how often it is done (pick a frame, select)."""
    page = locator.page

    def act(box):
        page.mouse.move(*_at(box, u, v))
        page.wait_for_timeout(50)
        page.mouse.click(*_at(box, u, v))

    return _gesture(locator, act, lambda p: p["up"] - p["down"] if p["up"] >= 0 else float("inf"), attempts=attempts)


def switch_timings(page, changes: list[tuple[str, str]], *, timeout_ms: float = 5000) -> list[float]:
    """For each (select host class, option label): ms from the change until the heatmap canvas is redrawn."""
    out = []
    for host, label in changes:
        dt = page.evaluate(f"window.moattnTest.timedSelect({host!r}, {label!r}, '.self-heatmap', {timeout_ms})")
        out.append(float(dt))
        page.wait_for_timeout(150)
    return out


#: the word curves (as the page holds them) draw ``word`` thicker than every other word
WORD_PICKED_JS = """(word) => {
  const d = window.moattnTest.plotData('cross-curves');
  if (!d || !d.word) return false;
  const i = d.word.indexOf(word);
  return i >= 0 && d.width.every((w, k) => k === i || w < d.width[i]);
}"""
