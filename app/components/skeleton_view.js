// The studio's 3-D skeleton viewer: drawn in the browser on a 2-D canvas (no WebGL, no library, no network).
// The server sends a scene once per change (app/viewer/scene.py); every frame, orbit and zoom is drawn here.
// Perspective projection, painter's order (far to near) for bones and joints, a checker floor, root paths and
// drawn guides. Poses are interpolated between the motion's 20-fps frames, so playback is as smooth as the display.

function bytesOf(b64) {
  const bin = atob(b64);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}
function float32Of(b64) { const u = bytesOf(b64); return new Float32Array(u.buffer, 0, u.byteLength >> 2); }
function metresOfMm(b64) {
  const u = bytesOf(b64);
  const mm = new Int16Array(u.buffer, 0, u.byteLength >> 1);
  const out = new Float32Array(mm.length);
  for (let i = 0; i < mm.length; i++) out[i] = mm[i] / 1000;
  return out;
}
const J = 22, TILE = 0.5, FOV = 30 * Math.PI / 180, NEAR = 0.05;
// the camera's limits: above the floor (never level with it: the floor would vanish edge-on), and between a fifth of
// and 3.5 times the distance that frames the motion (zoomed out further the body is a dot)
const LIMITS = {minEl: 5, maxEl: 85, zoomIn: 0.2, zoomOut: 3.5, minDist: 0.3, maxTargetY: 2.5};
const clamp = (x, lo, hi) => Math.max(lo, Math.min(hi, x));
const FLOOR = ["rgb(232,232,228)", "rgb(206,208,204)"];
const LEFT = [1, 4, 7, 10, 13, 16, 18, 20], RIGHT = [2, 5, 8, 11, 14, 17, 19, 21];
const PELVIS = 0, HEAD = 15;

function rgb(c, k) { return `rgb(${Math.round(c[0] * k)},${Math.round(c[1] * k)},${Math.round(c[2] * k)})`; }
function lighten(c, a) { return [c[0] + (255 - c[0]) * a, c[1] + (255 - c[1]) * a, c[2] + (255 - c[2]) * a]; }

function decodeScene(msg) {
  const roles = (msg.roles || []).map((r) => ({
    name: r.name, T: r.n_frames, joints: float32Of(r.joints),
    jointColors: Array.from({length: J}, (_, j) => r.joint_colors.slice(3 * j, 3 * j + 3)),
    frameColors: r.frame_colors ? bytesOf(r.frame_colors) : null,
  }));
  const guides = (msg.guides || []).map((g) => ({color: g.color, n: g.n, points: float32Of(g.points)}));
  let denoising = null;
  if (msg.denoising) {
    const d = msg.denoising;
    denoising = {steps: d.steps, numSteps: d.num_steps, recorded: d.recorded, T: d.n_frames, joints: metresOfMm(d.joints_mm)};
  }
  return {key: msg.key, title: msg.title || "", T: msg.n_frames || 0, fps: msg.fps || 20, parents: msg.parents || [],
          radii: msg.radii || {joint: 0.032, head: 0.07, bone: 0.02}, azimuth: msg.azimuth || 0,
          elevation: msg.elevation || 18, roles, guides, denoising, preview: null, job: msg.job || null,
          sentAt: msg.sent_at || null, legend: msg.legend || null};
}

function previewScene(msg) {
  // one live x̂0 motion while sampling: drawn like a scene of one role, with the step in its title
  const joints = metresOfMm(msg.joints_mm);
  const base = [58, 111, 216];
  const jointColors = Array.from({length: J}, (_, j) => LEFT.includes(j) ? lighten(base, 0.35) :
    RIGHT.includes(j) ? base.map((x) => x * 0.75) : base);
  return {key: msg.key, title: msg.title || "", T: msg.n_frames, fps: msg.fps || 20, parents: msg.parents,
          radii: msg.radii, azimuth: msg.azimuth, elevation: msg.elevation,
          roles: [{name: "x\u03020", T: msg.n_frames, joints, jointColors, frameColors: null}], guides: [],
          denoising: null, preview: {step: msg.step, numSteps: msg.num_steps}};
}

export function render({ model, el, view }) {
  const root = document.createElement("div");
  root.className = "moattn-viewer3d";
  const canvas = document.createElement("canvas");
  canvas.className = "moattn-viewer3d-canvas";
  canvas.tabIndex = 0;
  canvas.style.width = "100%"; canvas.style.display = "block"; canvas.style.cursor = "grab";
  canvas.style.touchAction = "none";
  // a CPU-backed canvas: under SwiftShader's emulated GL a GPU canvas costs the compositor ~60 ms a picture, while
  // drawing a skeleton on the CPU takes under a millisecond
  const ctx = canvas.getContext("2d", {willReadFrequently: true});

  const bar = document.createElement("div");
  bar.className = "moattn-player-bar";
  const mk = (tag, cls, text, title) => {
    const e = document.createElement(tag); e.className = cls;
    if (tag === "button") e.type = "button";
    if (text !== undefined) e.textContent = text;
    if (title) e.title = title;
    return e;
  };
  const play = mk("button", "moattn-play", "\u25B6 Play");
  const slider = mk("input", "moattn-scrub"); slider.type = "range"; slider.min = 0; slider.step = 1; slider.value = 0;
  const label = mk("span", "moattn-frame-label");
  const speed = mk("select", "moattn-speed", undefined, "playback speed");
  for (const s of [0.25, 0.5, 1, 2]) { const o = document.createElement("option"); o.value = s; o.textContent = `${s}\u00D7`; speed.append(o); }
  speed.value = "1";
  const loopBox = mk("label", "moattn-loop", undefined, "loop playback");
  const loopInput = document.createElement("input"); loopInput.type = "checkbox"; loopInput.checked = model.loop;
  loopBox.append(loopInput, document.createTextNode(" loop"));
  const reset = mk("button", "moattn-reset-view", "\u21BA view", "reset the camera (or double-click the picture)");
  const save = mk("button", "moattn-save-png", "\u2913 PNG", "save the current view as a PNG (in the browser, nothing is sent to the server)");
  bar.append(play, slider, label, speed, loopBox, reset, save);
  const stepBar = mk("div", "moattn-step-bar");
  stepBar.style.display = "none";
  const stepLabel = mk("span", "moattn-step-label");
  const stepSlider = mk("input", "moattn-step-scrub", undefined, "denoising step: the model's clean-motion estimate x\u03020 after that step");
  stepSlider.type = "range"; stepSlider.min = 0; stepSlider.step = 1;
  const ticks = document.createElement("datalist"); ticks.id = `moattn-steps-${Math.random().toString(36).slice(2)}`;
  stepSlider.setAttribute("list", ticks.id);
  stepBar.append(mk("span", "moattn-step-name", "denoising step"), stepSlider, stepLabel, ticks);
  const hint = mk("div", "moattn-viewer-hint", "drag: orbit \u00B7 shift/right-drag: pan \u00B7 wheel: zoom \u00B7 double-click: reset");
  root.append(canvas, bar, stepBar, hint);

  // ----------------------------------------------------------------- state
  let scene = null;       // what is drawn (a result scene or a live preview)
  let result = null;      // the last result scene (shown again if a preview is dropped)
  let pos = 0;            // playhead, in frames (fractional while playing)
  let playing = false, t0 = 0, p0 = 0, lastLabel = 0, dirty = true, lastInt = -1;
  let stepIndex = -1;     // denoising step shown (-1: the final motion)
  const cam = {az: 0, el: 18, dist: 4, target: [0, 1, 0], rel: true};
  const stats = {draws: 0, distinct: 0, last_drawn: -1, loaded: 0, n_frames: 0,
                 motion_key: -1, first_draw: {}, frame: 0, playing: false, draw_ms: [], previews: 0,
                 preview_step: -1, preview_first: {}, camera: null,
                 first_draw_wall: {}, job: {}, roles: {}, cursor_moves: 0,
                 scene_sent: {}, scene_received_wall: {}};
  window.moattnPlayer = stats;

  const n = () => scene ? scene.T : 0;

  // ----------------------------------------------------------------- geometry of a scene
  function track(sc) {
    // the mean pelvis XZ of all roles per frame (what "camera follows" follows); y = 0
    const T = sc.T, out = new Float32Array(T * 3);
    for (let k = 0; k < T; k++) {
      let x = 0, z = 0;
      for (const r of sc.roles) { const f = Math.min(k, r.T - 1); x += r.joints[(f * J + PELVIS) * 3]; z += r.joints[(f * J + PELVIS) * 3 + 2]; }
      out[3 * k] = x / sc.roles.length; out[3 * k + 2] = z / sc.roles.length;
    }
    return out;
  }
  function prepare(sc) {
    sc.track = track(sc);
    let lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
    const grow = (x, y, z) => { lo = [Math.min(lo[0], x), Math.min(lo[1], y), Math.min(lo[2], z)]; hi = [Math.max(hi[0], x), Math.max(hi[1], y), Math.max(hi[2], z)]; };
    for (const r of sc.roles) for (let i = 0; i < r.joints.length; i += 3) grow(r.joints[i], r.joints[i + 1], r.joints[i + 2]);
    for (const g of sc.guides) for (let i = 0; i < g.points.length; i += 3) grow(g.points[i], g.points[i + 1], g.points[i + 2]);
    const pad = 0.8;
    sc.floor = [Math.floor((lo[0] - pad) / TILE), Math.ceil((hi[0] + pad) / TILE), Math.floor((lo[2] - pad) / TILE), Math.ceil((hi[2] + pad) / TILE)];
    return sc;
  }
  function basis() {
    const a = cam.az * Math.PI / 180, e = cam.el * Math.PI / 180;
    const back = [Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e)];
    const target = currentTarget();
    const eye = [target[0] + back[0] * cam.dist, target[1] + back[1] * cam.dist, target[2] + back[2] * cam.dist];
    const fwd = [-back[0], -back[1], -back[2]];
    let right = [fwd[1] * 0 - fwd[2] * 1, fwd[2] * 0 - fwd[0] * 0, fwd[0] * 1 - fwd[1] * 0];  // fwd x up
    const rl = Math.hypot(right[0], right[1], right[2]) || 1; right = right.map((x) => x / rl);
    const up = [right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2], right[0] * fwd[1] - right[1] * fwd[0]];
    return {eye, fwd, right, up};
  }
  function currentTarget() {
    if (!scene || !cam.rel) return cam.target;
    const T = scene.T, k0 = Math.max(0, Math.min(Math.floor(pos), T - 1)), k1 = Math.min(k0 + 1, T - 1), a = Math.min(1, Math.max(0, pos - k0));
    const tr = scene.track;
    return [cam.target[0] + tr[3 * k0] * (1 - a) + tr[3 * k1] * a, cam.target[1], cam.target[2] + tr[3 * k0 + 2] * (1 - a) + tr[3 * k1 + 2] * a];
  }
  function fit() {
    // frame the body: all of it (fixed camera) or everything it does around its pelvis (camera follows)
    if (!scene) return;
    cam.az = scene.azimuth; cam.el = scene.elevation; cam.rel = !!model.follow;
    let lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
    for (const r of scene.roles) for (let k = 0; k < r.T; k++) {
      const tk = Math.min(k, scene.T - 1);
      for (let j = 0; j < J; j++) {
        const i = (k * J + j) * 3;
        const p = cam.rel ? [r.joints[i] - scene.track[3 * tk], r.joints[i + 1], r.joints[i + 2] - scene.track[3 * tk + 2]] : [r.joints[i], r.joints[i + 1], r.joints[i + 2]];
        for (let c = 0; c < 3; c++) { lo[c] = Math.min(lo[c], p[c]); hi[c] = Math.max(hi[c], p[c]); }
      }
    }
    cam.target = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    const radius = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) + 0.1;
    const aspect = canvas.width / Math.max(1, canvas.height);
    const half = Math.min(FOV / 2, Math.atan(Math.tan(FOV / 2) * aspect));
    cam.dist = Math.max(0.5, radius / Math.sin(half) * 1.0);
    cam.fitDist = cam.dist;
    cam.el = clamp(cam.el, LIMITS.minEl, LIMITS.maxEl);
    dirty = true;
  }
  function distLimits() {
    const fitDist = cam.fitDist || 4;
    return [Math.max(LIMITS.minDist, fitDist * LIMITS.zoomIn), Math.max(LIMITS.minDist, fitDist * LIMITS.zoomOut)];
  }
  function keepTargetOnFloor() {
    // a pan moves the point looked at, never off the floor's tiles nor under them or far above the body
    if (!scene || !scene.floor) return;
    const t = currentTarget(), [x0, x1, z0, z1] = scene.floor;
    cam.target[0] += clamp(t[0], x0 * TILE, x1 * TILE) - t[0];
    cam.target[2] += clamp(t[2], z0 * TILE, z1 * TILE) - t[2];
    cam.target[1] = clamp(cam.target[1], 0, LIMITS.maxTargetY);
  }

  // ----------------------------------------------------------------- drawing
  function pose(r, p) {
    // (22*3) joints of role r at fractional frame p (a motion past its end holds its last pose)
    let src = r.joints, T = r.T;
    if (stepIndex >= 0 && scene.denoising && r === scene.roles[0]) {
      const d = scene.denoising; T = d.T;
      src = d.joints.subarray(stepIndex * T * J * 3, (stepIndex + 1) * T * J * 3);
    }
    const k0 = Math.max(0, Math.min(Math.floor(p), T - 1)), k1 = Math.min(k0 + 1, T - 1), a = Math.max(0, Math.min(1, p - k0));
    const out = new Float32Array(J * 3);
    const o0 = k0 * J * 3, o1 = k1 * J * 3;
    for (let i = 0; i < J * 3; i++) out[i] = src[o0 + i] * (1 - a) + src[o1 + i] * a;
    return out;
  }
  function draw() {
    const t_start = performance.now();
    const W = canvas.width, H = canvas.height;
    const g = ctx.createLinearGradient(0, 0, 0, H);
    g.addColorStop(0, "#f4f6fa"); g.addColorStop(1, "#dfe5ee");
    ctx.fillStyle = g; ctx.fillRect(0, 0, W, H);
    if (!scene || !scene.roles.length) {
      ctx.fillStyle = "#667"; ctx.font = "16px sans-serif";
      ctx.fillText(scene ? "nothing to show" : "no motion yet: type a prompt and press Generate", 24, H / 2);
      return;
    }
    const B = basis(), f = (H / 2) / Math.tan(FOV / 2);
    const cx = (x, y, z) => {
      const dx = x - B.eye[0], dy = y - B.eye[1], dz = z - B.eye[2];
      return [dx * B.right[0] + dy * B.right[1] + dz * B.right[2], dx * B.up[0] + dy * B.up[1] + dz * B.up[2],
              dx * B.fwd[0] + dy * B.fwd[1] + dz * B.fwd[2]];
    };
    const scr = (c) => [W / 2 + f * c[0] / c[2], H / 2 - f * c[1] / c[2]];
    // floor: a checkerboard under the motions (the camera is kept above it: see LIMITS)
    if (B.eye[1] > 0) {
      const [x0, x1, z0, z1] = scene.floor;
      for (let a = 0; a < 2; a++) {
        ctx.fillStyle = FLOOR[a]; ctx.beginPath();
        for (let i = x0; i < x1; i++) for (let k = z0; k < z1; k++) {
          if (((i + k) & 1) !== a) continue;
          const cs = [cx(i * TILE, 0, k * TILE), cx((i + 1) * TILE, 0, k * TILE), cx((i + 1) * TILE, 0, (k + 1) * TILE), cx(i * TILE, 0, (k + 1) * TILE)];
          if (cs.some((c) => c[2] < NEAR)) continue;
          const ps = cs.map(scr);
          ctx.moveTo(ps[0][0], ps[0][1]); for (let q = 1; q < 4; q++) ctx.lineTo(ps[q][0], ps[q][1]); ctx.closePath();
        }
        ctx.fill();
      }
    }
    const polyline = (pts, count, stride, color, width, y) => {
      ctx.strokeStyle = color; ctx.lineWidth = width; ctx.lineJoin = "round"; ctx.beginPath();
      let open = false;
      for (let k = 0; k < count; k++) {
        const c = cx(pts[k * stride], y === undefined ? pts[k * stride + 1] : y, pts[k * stride + 2]);
        if (c[2] < NEAR) { open = false; continue; }
        const s = scr(c);
        if (open) ctx.lineTo(s[0], s[1]); else { ctx.moveTo(s[0], s[1]); open = true; }
      }
      ctx.stroke();
    };
    if (model.show_path) {
      for (const r of scene.roles) polyline(r.joints.subarray(PELVIS * 3), r.T, J * 3, rgb(r.jointColors[PELVIS], 0.85), 2, 0.006);
      for (const gd of scene.guides) polyline(gd.points, gd.n, 3, `rgba(${gd.color[0]},${gd.color[1]},${gd.color[2]},0.85)`, 3);
    }
    // bodies: bones and joints sorted far to near
    const prims = [];
    const k = Math.max(0, Math.min(Math.round(pos), n() - 1));
    for (const r of scene.roles) {
      const P = pose(r, pos), C = [];
      for (let j = 0; j < J; j++) C.push(cx(P[3 * j], P[3 * j + 1], P[3 * j + 2]));
      let colors = r.jointColors;
      if (r.frameColors) {  // (T, 22, 3) per frame and joint
        const o = Math.min(k, r.T - 1) * J * 3, fc = r.frameColors;
        colors = Array.from({length: J}, (_, j) => [fc[o + 3 * j], fc[o + 3 * j + 1], fc[o + 3 * j + 2]]);
      }
      for (let j = 1; j < J; j++) {
        const p = scene.parents[j], a = C[p], b = C[j];
        if (a[2] < NEAR || b[2] < NEAR) continue;
        prims.push({z: (a[2] + b[2]) / 2, bone: true, a, b, color: colors[j]});
      }
      for (let j = 0; j < J; j++) {
        if (C[j][2] < NEAR) continue;
        prims.push({z: C[j][2], bone: false, a: C[j], color: colors[j], radius: j === HEAD ? scene.radii.head : scene.radii.joint});
      }
    }
    prims.sort((p, q) => q.z - p.z);
    ctx.lineCap = "round";
    for (const p of prims) {
      if (p.bone) {
        const s0 = scr(p.a), s1 = scr(p.b);
        ctx.strokeStyle = rgb(p.color, 0.82); ctx.lineWidth = Math.max(1, 2 * scene.radii.bone * f / p.z);
        ctx.beginPath(); ctx.moveTo(s0[0], s0[1]); ctx.lineTo(s1[0], s1[1]); ctx.stroke();
      } else {
        const s = scr(p.a), rad = Math.max(1.5, p.radius * f / p.z);
        ctx.fillStyle = rgb(p.color, 1); ctx.beginPath(); ctx.arc(s[0], s[1], rad, 0, 2 * Math.PI); ctx.fill();
        ctx.fillStyle = "rgba(255,255,255,0.35)"; ctx.beginPath(); ctx.arc(s[0] - rad * 0.3, s[1] - rad * 0.3, rad * 0.45, 0, 2 * Math.PI); ctx.fill();
      }
    }
    // texts: title (left), frame (right), denoising step (below the title)
    ctx.font = "15px sans-serif"; ctx.fillStyle = "#223";
    const frameText = `frame ${k} / ${Math.max(0, n() - 1)}`;
    const fw = ctx.measureText(frameText).width;
    let title = scene.title || scene.roles.map((r) => r.name).join(" | ");
    while (title.length > 4 && ctx.measureText(title).width > W - fw - 40) title = title.slice(0, -2) + "\u2026";
    ctx.fillText(title, 12, 22);
    ctx.fillText(frameText, W - fw - 12, 22);
    if (scene.preview) {
      ctx.fillStyle = "#a33"; ctx.fillText(`denoising: step ${scene.preview.step} / ${scene.preview.numSteps} (x\u03020, live)`, 12, 44);
    } else if (stepIndex >= 0 && scene.denoising) {
      ctx.fillStyle = "#a33"; ctx.fillText(`x\u03020 after step ${scene.denoising.steps[stepIndex]} / ${scene.denoising.numSteps}`, 12, 44);
    }
    stats.draws += 1;
    if (k !== stats.last_drawn) { stats.distinct += 1; stats.last_drawn = k; }
    if (!(stats.motion_key in stats.first_draw) && !scene.preview) {
      stats.first_draw[stats.motion_key] = performance.now(); stats.first_draw_wall[stats.motion_key] = Date.now() / 1000;
      stats.job[stats.motion_key] = scene.job; stats.roles[stats.motion_key] = scene.roles.length;
    }
    stats.draw_ms.push(performance.now() - t_start);
    if (stats.draw_ms.length > 240) stats.draw_ms.splice(0, stats.draw_ms.length - 240);
    drawLegend(W, H);
    const [minDist, maxDist] = distLimits();
    stats.camera = {az: cam.az, el: cam.el, dist: cam.dist, eye_y: B.eye[1], min_dist: minDist, max_dist: maxDist,
                    fit_dist: cam.fitDist || null};
  }
  function fitText(text, width) {
    let t = text || "";
    while (t.length > 4 && ctx.measureText(t).width > width) t = t.slice(0, -2) + "\u2026";
    return t;
  }
  function drawLegend(W, H) {
    // what the colours mean, in the bottom-left corner (app/viewer/legend.py says what each colour mode shows)
    const lg = scene && !scene.preview ? scene.legend : null;
    if (!lg) { stats.legend = null; return; }
    ctx.save();
    const font = "12px sans-serif", pad = 6, lh = 16, sw = 11, maxW = Math.min(W - 24, Math.max(220, W * 0.62));
    ctx.font = font;
    const rows = [{text: fitText(lg.title, maxW - 2 * pad), bold: true}];
    let boxW = 0;
    if (lg.kind === "gradient") {
      rows.push({gradient: lg.stops, low: lg.low, high: lg.high});
      boxW = ctx.measureText(lg.low).width + ctx.measureText(lg.high).width + 168;
    } else {
      let row = [], w = 0;
      const items = (lg.items || []).map((it) => ({label: fitText(it.label, maxW * 0.8), color: it.color}));
      if (lg.more) items.push({label: `+${lg.more} more`, color: null});
      for (const it of items) {
        const iw = (it.color ? sw + 4 : 0) + ctx.measureText(it.label).width + 12;
        if (row.length && w + iw > maxW - 2 * pad) { rows.push({items: row}); boxW = Math.max(boxW, w); row = []; w = 0; }
        row.push({...it, x: w}); w += iw;
      }
      if (row.length) { rows.push({items: row}); boxW = Math.max(boxW, w); }
    }
    if (lg.note) rows.push({text: fitText(lg.note, maxW - 2 * pad), small: true});
    for (const r of rows) if (r.text !== undefined) {
      ctx.font = r.bold ? "bold " + font : r.small ? "11px sans-serif" : font;
      boxW = Math.max(boxW, ctx.measureText(r.text).width);
    }
    ctx.font = font;
    boxW = Math.min(boxW + 2 * pad, maxW);
    const boxH = rows.length * lh + 2 * pad - 3, x0 = 10, y0 = H - boxH - 10;
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(x0, y0, boxW, boxH);
    ctx.strokeStyle = "rgba(110,120,140,0.55)"; ctx.lineWidth = 1; ctx.strokeRect(x0 + 0.5, y0 + 0.5, boxW - 1, boxH - 1);
    let y = y0 + pad + 11;
    for (const r of rows) {
      if (r.text !== undefined) {
        ctx.font = r.bold ? "bold " + font : r.small ? "11px sans-serif" : font;
        ctx.fillStyle = r.small ? "#556" : "#223"; ctx.fillText(r.text, x0 + pad, y); ctx.font = font;
      } else if (r.gradient) {
        const gx = x0 + pad + ctx.measureText(r.low).width + 5, gw = 150;
        ctx.fillStyle = "#223"; ctx.fillText(r.low, x0 + pad, y);
        const grad = ctx.createLinearGradient(gx, 0, gx + gw, 0);
        r.gradient.forEach((c, i) => grad.addColorStop(i / Math.max(1, r.gradient.length - 1), c));
        ctx.fillStyle = grad; ctx.fillRect(gx, y - 10, gw, 11);
        ctx.fillStyle = "#223"; ctx.fillText(r.high, gx + gw + 5, y);
      } else {
        for (const it of r.items) {
          const sx = x0 + pad + it.x;
          if (it.color) {
            ctx.fillStyle = it.color; ctx.fillRect(sx, y - 10, sw, sw);
            ctx.strokeStyle = "rgba(0,0,0,0.35)"; ctx.strokeRect(sx + 0.5, y - 9.5, sw - 1, sw - 1);
          }
          ctx.fillStyle = "#223"; ctx.fillText(it.label, sx + (it.color ? sw + 4 : 0), y);
        }
      }
      y += lh;
    }
    ctx.restore();
    stats.legend = {kind: lg.kind, title: lg.title, items: (lg.items || []).length, box: [x0, y0, boxW, boxH]};
  }

  // ----------------------------------------------------------------- playback and sync
  function updateLabel(force) {
    const now = performance.now();
    stats.frame = Math.max(0, Math.min(Math.round(pos), n() - 1)); stats.n_frames = n(); stats.loaded = n();
    if (playing && !force && now - lastLabel < 200) return;  // text and slider cost layout: 5 times a second
    lastLabel = now;
    slider.max = Math.max(0, n() - 1); slider.value = stats.frame;
    label.textContent = n() ? `${stats.frame} / ${n() - 1}` : "";
  }
  function moveCursors(k) {
    // the attention views' frame cursors move in the browser: no server round trip per frame
    const ids = model.cursor_ids || [];
    if (!ids.length || !view || !view.model || !view.model.document) return;
    for (const id of ids) {
      const m = view.model.document.get_model_by_id(id);
      if (m && m.location !== k) { m.location = k; stats.cursor_moves += 1; }
    }
  }
  function setPlaying(p, sync) {
    playing = p && n() > 1 && !(scene && scene.preview);
    stats.playing = playing;
    play.textContent = playing ? "\u275A\u275A Pause" : "\u25B6 Play";
    if (playing) {
      if (pos >= n() - 1 && !model.loop) pos = 0;
      t0 = performance.now(); p0 = pos;
    } else pos = Math.round(pos);
    if (sync) { model.playing = playing; model.frame = Math.round(pos); }
    dirty = true; updateLabel(true);
  }
  function tick(now) {
    raf = requestAnimationFrame(tick);
    if (playing && n()) {
      const rate = (scene ? scene.fps : 20) * parseFloat(speed.value);
      let p = p0 + (now - t0) * rate / 1000;
      if (p > n() - 1) {
        if (model.loop) { p = p % n(); t0 = now; p0 = p; }
        else { p = n() - 1; pos = p; setPlaying(false, true); }
      }
      pos = p; dirty = true;
      const ki = Math.round(pos);
      if (ki !== lastInt) { lastInt = ki; moveCursors(ki); }
    }
    if (dirty) { dirty = false; draw(); updateLabel(false); }
  }
  let raf = requestAnimationFrame(tick);

  function showStepBar() {
    const d = scene && !scene.preview ? scene.denoising : null;
    stepBar.style.display = d ? "" : "none";
    if (!d) { stepIndex = -1; return; }
    stepSlider.max = d.steps.length - 1; stepSlider.value = d.steps.length - 1; stepIndex = -1;
    ticks.replaceChildren(...d.steps.map((s, i) => { const o = document.createElement("option"); o.value = i; return o; }));
    stepLabel.textContent = `${d.steps[d.steps.length - 1]} / ${d.numSteps} (final)` +
      (d.recorded.length ? ` \u00B7 attention recorded at steps ${d.recorded.join(", ")}` : "");
  }
  function setScene(sc, {keepCamera} = {}) {
    const newKey = !scene || sc.key !== scene.key || !!sc.preview !== !!scene.preview;
    scene = prepare(sc);
    if (!sc.preview) {
      result = sc; stats.motion_key = sc.key;
      stats.scene_sent[sc.key] = sc.sentAt; stats.scene_received_wall[sc.key] = Date.now() / 1000;
    }
    if (newKey && !keepCamera) fit();
    if (pos > n() - 1) pos = 0;
    showStepBar();
    dirty = true; updateLabel(true);
  }
  function fromModel() {
    const msg = model.scene;
    if (!msg || msg.key === undefined) return;
    const sc = decodeScene(msg);
    const same = result && result.key === sc.key;
    pos = Math.min(model.frame, Math.max(0, (sc.T || 1) - 1));
    setScene(sc, {keepCamera: same && !(scene && scene.preview)});
  }

  // ----------------------------------------------------------------- events
  play.addEventListener("click", () => setPlaying(!playing, true));
  slider.addEventListener("input", () => { if (playing) setPlaying(false, false); pos = parseInt(slider.value); dirty = true; moveCursors(pos); });
  slider.addEventListener("change", () => { model.playing = false; model.frame = Math.round(pos); });
  loopInput.addEventListener("change", () => { model.loop = loopInput.checked; });
  reset.addEventListener("click", () => fit());
  canvas.addEventListener("dblclick", () => fit());
  stepSlider.addEventListener("input", () => {
    const d = scene && scene.denoising; if (!d) return;
    const i = parseInt(stepSlider.value);
    stepIndex = i >= d.steps.length - 1 ? -1 : i;
    stepLabel.textContent = `${d.steps[i]} / ${d.numSteps}` + (i === d.steps.length - 1 ? " (final)" : "") +
      (d.recorded.includes(d.steps[i]) ? " \u00B7 attention recorded at this step" : "");
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
    if (drag.pan) {
      const B = basis(), s = cam.dist * 0.0018;
      for (let c = 0; c < 3; c++) cam.target[c] += (-dx * B.right[c] + dy * B.up[c]) * s;
      keepTargetOnFloor();
    } else {
      cam.az -= dx * 0.4; cam.el = clamp(cam.el + dy * 0.3, LIMITS.minEl, LIMITS.maxEl);
    }
    dirty = true;
  });
  const endDrag = () => { drag = null; canvas.style.cursor = "grab"; };
  canvas.addEventListener("pointerup", endDrag);
  canvas.addEventListener("pointercancel", endDrag);
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const [minDist, maxDist] = distLimits();
    cam.dist = clamp(cam.dist * Math.exp(e.deltaY * 0.001), minDist, maxDist); dirty = true;
  }, {passive: false});
  save.addEventListener("click", () => {
    canvas.toBlob((blob) => {
      if (!blob) return;
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = `motion_frame_${stats.frame}.png`;
      document.body.appendChild(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
      stats.saved_png = (stats.saved_png || 0) + 1;
    }, "image/png");
  });

  function resize() {
    const w = Math.max(240, Math.round(root.clientWidth || 480));
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
  observer.observe(root);

  model.on("scene", fromModel);
  model.on("frame", () => {
    if (Math.round(pos) !== model.frame) {
      pos = Math.max(0, Math.min(model.frame, n() - 1)); moveCursors(Math.round(pos));
      if (playing) { t0 = performance.now(); p0 = pos; }
      dirty = true; updateLabel(true);
    }
  });
  model.on("playing", () => { if (model.playing !== playing) setPlaying(model.playing, false); });
  model.on("follow", () => fit());  // fit() reads model.follow
  model.on("show_path", () => { dirty = true; });
  model.on("loop", () => { loopInput.checked = model.loop; });
  model.on("msg:custom", (msg) => {
    if (msg.type === "preview") {
      if (result && msg.key <= result.key) return;  // a late preview of a job whose result is already shown
      if (playing) setPlaying(false, false);
      const first = !scene || !scene.preview || scene.key !== msg.key;
      const sc = previewScene(msg);
      if (!first) { sc.azimuth = scene.azimuth; }
      scene = prepare(sc);
      if (first) { pos = 0; fit(); stats.preview_first[msg.key] = performance.now(); }
      stats.previews += 1; stats.preview_step = msg.step;
      stepBar.style.display = "none"; stepIndex = -1;
      dirty = true; updateLabel(true);
    } else if (msg.type === "preview_end") {
      if (scene && scene.preview && result) { setScene(result, {keepCamera: false}); }
      else if (scene && scene.preview) { scene = null; dirty = true; }
    }
  });
  model.on("remove", () => { cancelAnimationFrame(raf); observer.disconnect(); });
  resize();
  fromModel();
  return root;
}
