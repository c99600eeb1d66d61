"""``FramePlayer``: a small in-browser player for server-rendered JPEG frames (no CDN, no network).

The browser keeps every frame it has received as a decoded ``ImageBitmap`` and draws them on a
canvas from a ``requestAnimationFrame`` loop at ``fps`` (20 by default), so playback never waits
on the server. Frames arrive progressively as custom messages (``{motion_key, version,
n_frames, frames: {index: base64 JPEG}}``); a new ``motion_key`` clears the cache, a new
``version`` of the same motion replaces frames as they come (the old ones stay until then).

The page tells the server ``{"type": "hello"}`` when it (re)renders, so the server resends what
it has, and ``{"type": "need", "frame": k}`` when the user scrubs to a frame it does not have.
``frame`` and ``playing`` sync both ways. While playing, the page reports the playhead with a
``{"type": "frame"}`` message at most every ``sync_ms`` (changing a property 4 times a second costs
Bokeh a relayout of the page and halves the frame rate under software rendering).

``window.moattnPlayer`` exposes counters for tests and ``moattn bench --app``: ``draws``,
``distinct`` (distinct frames drawn), ``loaded``, ``n_frames``, ``motion_key``, ``first_draw``
(performance.now() of the first frame drawn per motion_key).
"""
from __future__ import annotations

import base64
from collections.abc import Callable

import panel as pn
import param

from app.frames import FrameBatch


class FramePlayer(pn.custom.JSComponent):
    n_frames = param.Integer(default=0, bounds=(0, None))
    frame = param.Integer(default=0, bounds=(0, None))
    playing = param.Boolean(default=False)
    fps = param.Number(default=20.0, bounds=(1, 120))
    loop = param.Boolean(default=True)
    sync_ms = param.Integer(default=250, bounds=(0, None),
                            doc="while playing, send the frame to the server at most this often (0: only on pause)")

    _esm = r"""
function b64ToBlob(b64) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  return new Blob([bytes], {type: "image/jpeg"});
}

export function render({ model, el }) {
  const root = document.createElement("div");
  root.className = "moattn-player";
  const canvas = document.createElement("canvas");
  canvas.width = 480; canvas.height = 360;
  canvas.className = "moattn-player-canvas";
  // a CPU-backed canvas: a frame is one drawImage of a decoded bitmap, which costs next to nothing on the CPU,
  // while a GPU canvas under SwiftShader's emulated GL cost playback 2-3 fps on a loaded 2-core box
  const ctx = canvas.getContext("2d", {willReadFrequently: true});
  ctx.fillStyle = "#eef2f7"; ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = "#667"; ctx.font = "16px sans-serif";
  ctx.fillText("no motion yet: type a prompt and press Generate", 40, 180);

  const bar = document.createElement("div");
  bar.className = "moattn-player-bar";
  const play = document.createElement("button");
  play.className = "moattn-play"; play.type = "button"; play.textContent = "\u25B6 Play";
  const slider = document.createElement("input");
  slider.type = "range"; slider.min = 0; slider.step = 1; slider.value = 0;
  slider.className = "moattn-scrub";
  const label = document.createElement("span");
  label.className = "moattn-frame-label";
  const save = document.createElement("button");
  save.className = "moattn-save-png"; save.type = "button"; save.textContent = "\u2913 PNG";
  save.title = "save the current view as a PNG (in the browser, nothing is sent to the server)";
  save.addEventListener("click", () => {
    canvas.toBlob((blob) => {
      if (!blob) return;
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = `motion_frame_${current}.png`;
      document.body.appendChild(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
      stats.saved_png = (stats.saved_png || 0) + 1;
    }, "image/png");
  });
  bar.append(play, slider, label, save);
  root.append(canvas, bar);

  const cache = new Map();          // frame -> {bmp, version}
  let motionKey = -1;
  let current = model.frame;
  let playing = false;
  let t0 = 0, f0 = 0, lastSync = 0, raf = 0;
  const stats = {draws: 0, distinct: 0, distinct_at: 0, skipped: 0, last_drawn: -1, loaded: 0, n_frames: model.n_frames,
                 motion_key: -1, version: -1, first_draw: {}, frame: current, playing: false};
  window.moattnPlayer = stats;

  function n() { return Math.max(0, model.n_frames); }
  let lastLabel = 0;
  function updateLabel(force) {
    stats.frame = current; stats.loaded = cache.size; stats.n_frames = n();
    const now = performance.now();
    if (playing && !force && now - lastLabel < 200) return;  // text and slider cost layout: 5 times a second
    lastLabel = now;
    slider.max = Math.max(0, n() - 1);
    slider.value = current;
    label.textContent = n() ? `${current} / ${n() - 1}  (${cache.size}/${n()} ready)` : "";
  }
  function draw(k) {
    const entry = cache.get(k);
    if (!entry) { updateLabel(); return false; }
    if (canvas.width !== entry.bmp.width || canvas.height !== entry.bmp.height) {
      canvas.width = entry.bmp.width; canvas.height = entry.bmp.height;
      canvas.style.maxWidth = `${entry.bmp.width}px`;
      canvas.style.aspectRatio = `${entry.bmp.width} / ${entry.bmp.height}`;
    }
    ctx.drawImage(entry.bmp, 0, 0);
    stats.draws += 1;
    if (k !== stats.last_drawn) { stats.distinct += 1; stats.distinct_at = performance.now(); stats.last_drawn = k; }
    if (!(motionKey in stats.first_draw)) stats.first_draw[motionKey] = performance.now();
    updateLabel();
    return true;
  }
  function show(k) {
    current = Math.max(0, Math.min(k, n() - 1));
    if (!draw(current) && n()) model.send_msg({type: "need", frame: current});
    updateLabel();
  }
  function setPlaying(p, sync) {
    playing = p && n() > 0;
    stats.playing = playing;
    play.textContent = playing ? "\u275A\u275A Pause" : "\u25B6 Play";
    if (playing) {
      if (current >= n() - 1 && !model.loop) current = 0;
      t0 = performance.now(); f0 = current;
    }
    if (sync) { model.playing = playing; model.frame = current; }
    updateLabel(true);
  }
  function tick(now) {
    raf = requestAnimationFrame(tick);
    if (!playing || !n()) return;
    let k = f0 + Math.floor((now - t0) * model.fps / 1000);
    if (k >= n()) {
      if (model.loop) { k = k % n(); t0 = now - (k / model.fps) * 1000; f0 = 0; }
      else { k = n() - 1; setPlaying(false, true); }
    }
    if (k !== current) {
      if (cache.has(k)) {
        if (k > current + 1) stats.skipped += k - current - 1;  // frames the page was too slow to show
        current = k; draw(k);
      }
      else { f0 = current; t0 = now; }   // wait for the frame (rendered progressively)
    }
    if (model.sync_ms > 0 && now - lastSync > model.sync_ms) { lastSync = now; model.send_msg({type: "frame", frame: current}); }
  }

  play.addEventListener("click", () => setPlaying(!playing, true));
  slider.addEventListener("input", () => {
    if (playing) setPlaying(false, false);
    show(parseInt(slider.value));
  });
  slider.addEventListener("change", () => { model.playing = false; model.frame = current; });

  model.on("frame", () => {
    if (model.frame !== current) {
      show(model.frame);
      if (playing) { t0 = performance.now(); f0 = current; }
    }
  });
  model.on("playing", () => { if (model.playing !== playing) setPlaying(model.playing, false); });
  model.on("n_frames", () => { if (current >= n()) current = 0; updateLabel(); });
  function placeholder(title) {
    // a new motion whose frames are still being drawn: never the old motion under the new one's name
    ctx.fillStyle = "#eef2f7"; ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.fillStyle = "#334"; ctx.font = "18px sans-serif";
    ctx.fillText((title || "").slice(0, 44), 16, 30);
    ctx.fillStyle = "#667"; ctx.font = "15px sans-serif";
    ctx.fillText("drawing its frames\u2026", 16, canvas.height / 2);
    stats.placeholder = motionKey;
  }
  model.on("msg:custom", async (msg) => {
    // keys only grow: a late batch of an older motion (the renderer's thread) never replaces a newer one
    if (msg.motion_key < motionKey) return;
    if (msg.motion_key !== motionKey) {
      for (const e of cache.values()) e.bmp.close();
      cache.clear();
      motionKey = msg.motion_key;
      stats.motion_key = motionKey;
      placeholder(msg.title);
    }
    stats.version = msg.version;
    const entries = Object.entries(msg.frames);
    const decoded = await Promise.all(entries.map(([k, b64]) => createImageBitmap(b64ToBlob(b64))));
    if (msg.motion_key !== motionKey) { decoded.forEach(b => b.close()); return; }
    entries.forEach(([k, _], i) => {
      const key = parseInt(k);
      const old = cache.get(key);
      if (old && old.version > msg.version) { decoded[i].close(); return; }
      if (old) old.bmp.close();
      cache.set(key, {bmp: decoded[i], version: msg.version});
    });
    if (!playing || !cache.has(current)) draw(Math.min(current, n() - 1));
    else updateLabel();
  });
  model.on("remove", () => { cancelAnimationFrame(raf); if (window.moattnPlayer === stats) delete window.moattnPlayer; });
  raf = requestAnimationFrame(tick);
  updateLabel();
  model.send_msg({type: "hello"});
  return root;
}
"""

    _stylesheets = ["""
.moattn-player { display: flex; flex-direction: column; gap: 4px; }
.moattn-player-canvas { border: 1px solid #d0d7e2; border-radius: 4px; background: #eef2f7;
  width: 100%; max-width: 480px; aspect-ratio: 480 / 360; height: auto;
  will-change: transform; contain: strict; }
.moattn-player-bar { display: flex; align-items: center; gap: 8px; contain: layout paint; }
.moattn-play { min-width: 84px; padding: 4px 8px; cursor: pointer; }
.moattn-scrub { flex: 1; }
.moattn-frame-label { font: 12px monospace; color: #445; min-width: 170px; }
.moattn-save-png { padding: 4px 8px; cursor: pointer; }
"""]

    def __init__(self, **params):
        super().__init__(**params)
        self.on_hello: Callable[[], None] | None = None
        self.on_need: Callable[[int], None] | None = None
        self.on_frame: Callable[[int], None] | None = None  # the playhead while playing (no property change)
        self.sent_batches = 0
        self.closed = False  # the session ended: late frames from the renderer's thread are dropped

    def push(self, batch: FrameBatch) -> None:
        """Send rendered frames to the browser (safe from any thread: Panel schedules it on the session)."""
        if not batch.frames or self.closed:
            return
        self.sent_batches += 1
        self._send_msg({
            "motion_key": batch.motion_key, "version": batch.version, "n_frames": batch.n_frames,
            "frames": {str(k): base64.b64encode(v).decode("ascii") for k, v in batch.frames.items()},
        })

    def announce(self, *, motion_key: int, version: int, n_frames: int, title: str) -> None:
        """A new motion is on its way: the browser drops the old frames at once and shows ``title`` until the
        first new frame arrives."""
        if self.closed:
            return
        self._send_msg({"motion_key": motion_key, "version": version, "n_frames": n_frames, "frames": {},
                        "title": title})

    def _handle_msg(self, data) -> None:
        if not isinstance(data, dict):
            return
        kind = data.get("type")
        if kind == "hello" and self.on_hello is not None:
            self.on_hello()
        elif kind == "frame" and self.on_frame is not None:
            try:
                self.on_frame(int(data.get("frame", 0)))
            except (TypeError, ValueError):
                pass
        elif kind == "need" and self.on_need is not None:
            try:
                self.on_need(int(data.get("frame", 0)))
            except (TypeError, ValueError):
                pass
