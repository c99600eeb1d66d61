// main: the component's render(): one viewer's state (the scene shown, the last result, the denoising step), the
// animation loop, the counters in window.moattnPlayer, and the wiring of the model's properties, messages and the
// mouse to the modules above (Decode, Camera, Draw, Legend, Player, Controls).
export function render({ model, el, view }) {
  const ui = Controls.build(model.loop), canvas = ui.canvas, bar = ui.player;
  // a CPU-backed canvas: under SwiftShader's emulated GL a GPU canvas costs the compositor ~60 ms a picture, while
  // drawing a skeleton on the CPU takes under a millisecond
  const ctx = canvas.getContext("2d", {willReadFrequently: true});

  let scene = null;       // what is drawn (a result scene or a live preview)
  let result = null;      // the last result scene (shown again if a preview is dropped)
  let stepIndex = -1;     // denoising step shown (-1: the final motion)
  let lastLabel = 0, dirty = true;
  const cam = Camera.create(), pl = Player.create();
  const stats = {draws: 0, distinct: 0, last_drawn: -1, loaded: 0, n_frames: 0,
                 motion_key: -1, first_draw: {}, frame: 0, playing: false, draw_ms: [], previews: 0,
                 preview_step: -1, preview_first: {}, camera: null,
                 first_draw_wall: {}, job: {}, roles: {}, cursor_moves: 0,
                 scene_sent: {}, scene_received_wall: {}};
  window.moattnPlayer = stats;
  const n = () => scene ? scene.T : 0;

  function fit() {
    if (!scene || !scene.roles.length) return;
    Camera.fit(cam, scene, model.follow, canvas.width / Math.max(1, canvas.height));
    dirty = true;
  }
  function draw() {
    const t_start = performance.now(), W = canvas.width, H = canvas.height;
    const V = scene && scene.roles.length ? Camera.projector(cam, scene, pl.pos, W, H) : null;
    const k = Draw.picture(ctx, scene, V, {pos: pl.pos, stepIndex, showPath: model.show_path, W, H});
    if (k < 0) return;
    stats.draws += 1;
    if (k !== stats.last_drawn) { stats.distinct += 1; stats.last_drawn = k; }
    if (!(stats.motion_key in stats.first_draw) && !scene.preview) {
      stats.first_draw[stats.motion_key] = performance.now(); stats.first_draw_wall[stats.motion_key] = Date.now() / 1000;
      stats.job[stats.motion_key] = scene.job; stats.roles[stats.motion_key] = scene.roles.length;
    }
    stats.draw_ms.push(performance.now() - t_start);
    if (stats.draw_ms.length > 240) stats.draw_ms.splice(0, stats.draw_ms.length - 240);
    stats.legend = Legend.draw(ctx, scene, W, H);
    stats.camera = Camera.snapshot(cam, V.B.eye[1]);
  }
  function updateLabel(force) {
    const now = performance.now();
    stats.frame = Player.frame(pl, n()); stats.n_frames = n(); stats.loaded = n();
    if (pl.playing && !force && now - lastLabel < 200) return;  // text and slider cost layout: 5 times a second
    lastLabel = now;
    bar.slider.max = Math.max(0, n() - 1); bar.slider.value = stats.frame;
    bar.label.textContent = n() ? `${stats.frame} / ${n() - 1}` : "";
  }
  function moveCursors(k) { stats.cursor_moves += Player.moveCursors(model.cursor_ids || [], view, k); }
  function setPlaying(p, sync) {
    Player.setPlaying(pl, p && n() > 1 && !(scene && scene.preview), n(), model.loop, performance.now());
    stats.playing = pl.playing;
    bar.play.textContent = pl.playing ? "\u275A\u275A Pause" : "\u25B6 Play";
    if (sync) { model.playing = pl.playing; model.frame = Math.round(pl.pos); }
    dirty = true; updateLabel(true);
  }
  function tick(now) {
    raf = requestAnimationFrame(tick);
    if (pl.playing && n()) {
      const rate = (scene ? scene.fps : 0) * parseFloat(bar.speed.value);
      if (Player.advance(pl, now, n(), rate, model.loop) === "end") setPlaying(false, true);
      dirty = true;
      const k = Player.crossed(pl);
      if (k >= 0) moveCursors(k);
    }
    if (dirty) { dirty = false; draw(); updateLabel(false); }
  }
  let raf = requestAnimationFrame(tick);

  function setScene(sc, {keepCamera} = {}) {
    const newKey = !scene || sc.key !== scene.key || !!sc.preview !== !!scene.preview;
    scene = Camera.prepare(sc);
    if (!sc.preview) {
      result = sc; stats.motion_key = sc.key;
      stats.scene_sent[sc.key] = sc.sentAt; stats.scene_received_wall[sc.key] = Date.now() / 1000;
    }
    if (newKey && !keepCamera) fit();
    if (pl.pos > n() - 1) pl.pos = 0;
    const d = scene && !scene.preview ? scene.denoising : null;
    Controls.showSteps(ui, d); stepIndex = -1;
    dirty = true; updateLabel(true);
  }
  function fromModel() {
    const msg = model.scene;
    if (!msg || msg.key === undefined) return;
    const sc = Decode.decodeScene(msg);
    const same = result && result.key === sc.key;
    pl.pos = Math.min(model.frame, Math.max(0, (sc.T || 1) - 1));
    setScene(sc, {keepCamera: same && !(scene && scene.preview)});
  }
  function onPreview(msg) {
    if (result && msg.key <= result.key) return;  // a late preview of a job whose result is already shown
    if (pl.playing) setPlaying(false, false);
    const first = !scene || !scene.preview || scene.key !== msg.key;
    const sc = Decode.previewScene(msg);
    if (!first) { sc.azimuth = scene.azimuth; }
    scene = Camera.prepare(sc);
    if (first) { pl.pos = 0; fit(); stats.preview_first[msg.key] = performance.now(); }
    stats.previews += 1; stats.preview_step = msg.step;
    ui.steps.bar.style.display = "none"; stepIndex = -1;
    dirty = true; updateLabel(true);
  }

  // ----------------------------------------------------------------- events
  bar.play.addEventListener("click", () => setPlaying(!pl.playing, true));
  bar.slider.addEventListener("input", () => {
    if (pl.playing) setPlaying(false, false);
    pl.pos = parseInt(bar.slider.value); dirty = true; moveCursors(pl.pos);
  });
  bar.slider.addEventListener("change", () => { model.playing = false; model.frame = Math.round(pl.pos); });
  bar.loopInput.addEventListener("change", () => { model.loop = bar.loopInput.checked; });
  bar.reset.addEventListener("click", () => fit());
  canvas.addEventListener("dblclick", () => fit());
  ui.steps.slider.addEventListener("input", () => {
    const d = scene && scene.denoising; if (!d) return;
    const i = parseInt(ui.steps.slider.value);
    stepIndex = i >= d.steps.length - 1 ? -1 : i;
    ui.steps.label.textContent = Controls.stepText(d, i);
    stats.step_index = stepIndex; dirty = true;
  });
  let drag = null;
  canvas.addEventListener("pointerdown", (e) => {
    drag = {x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey};
    canvas.setPointerCapture(e.pointerId); canvas.style.cursor = "grabbing";
  });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) Camera.pan(cam, scene, pl.pos, dx, dy); else Camera.orbit(cam, dx, dy);
    dirty = true;
  });
  const endDrag = () => { drag = null; canvas.style.cursor = "grab"; };
  canvas.addEventListener("pointerup", endDrag);
  canvas.addEventListener("pointercancel", endDrag);
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("wheel", (e) => { e.preventDefault(); Camera.zoom(cam, e.deltaY); dirty = true; }, {passive: false});
  bar.save.addEventListener("click", () => Controls.savePng(canvas, `motion_frame_${stats.frame}.png`,
    () => { stats.saved_png = (stats.saved_png || 0) + 1; }));

  function resize() {
    const w = Math.max(240, Math.round(ui.root.clientWidth || 480));
    const h = Math.max(240, Math.min(Math.round(w * 0.62), 560));
    if (canvas.width !== w || canvas.height !== h) {
      const refit = !canvas.width || Math.abs(canvas.width / canvas.height - w / h) > 0.01;
      canvas.width = w; canvas.height = h;
      canvas.style.height = `${h}px`;  // its own layer (contain: strict) needs a stated height
      if (refit && scene) fit();
      dirty = true;
    }
  }
  const observer = new ResizeObserver(resize);
  observer.observe(ui.root);

  model.on("scene", fromModel);
  model.on("frame", () => {
    if (Math.round(pl.pos) !== model.frame) {
      Player.seek(pl, Math.max(0, Math.min(model.frame, n() - 1)), performance.now()); moveCursors(Math.round(pl.pos));
      dirty = true; updateLabel(true);
    }
  });
  model.on("playing", () => { if (model.playing !== pl.playing) setPlaying(model.playing, false); });
  model.on("follow", () => fit());  // fit() reads model.follow
  model.on("show_path", () => { dirty = true; });
  model.on("loop", () => { bar.loopInput.checked = model.loop; });
  model.on("msg:custom", (msg) => {
    if (msg.type === "preview") onPreview(msg);
    else if (msg.type === "preview_end") {
      if (scene && scene.preview && result) { setScene(result, {keepCamera: false}); }
      else if (scene && scene.preview) { scene = null; dirty = true; }
    }
  });
  model.on("remove", () => { cancelAnimationFrame(raf); observer.disconnect(); });
  resize();
  fromModel();
  return ui.root;
}
