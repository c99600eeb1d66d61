// draw: one picture of a scene on a 2-D canvas: the sky, the checker floor, root paths and drawn guides, then the
// bodies' bones and joints in painter's order (far to near), and the title and frame texts. Poses are interpolated
// between the motion's frames. Sizes, colours, the skeleton's bones and the floor come from the scene (its payload).
const Draw = (() => {
  function rgb(c, k) { return `rgb(${Math.round(c[0] * k)},${Math.round(c[1] * k)},${Math.round(c[2] * k)})`; }

  function pose(sc, r, p, stepIndex) {
    // (J*3) joints of role r at fractional frame p (a motion past its end holds its last pose); the first role shows
    // denoising step stepIndex when one is chosen
    const J = sc.skeleton.J;
    let src = r.joints, T = r.T;
    if (stepIndex >= 0 && sc.denoising && r === sc.roles[0]) {
      const d = sc.denoising; T = d.T;
      src = d.joints.subarray(stepIndex * T * J * 3, (stepIndex + 1) * T * J * 3);
    }
    const k0 = Math.max(0, Math.min(Math.floor(p), T - 1)), k1 = Math.min(k0 + 1, T - 1), a = Math.max(0, Math.min(1, p - k0));
    const out = new Float32Array(J * 3);
    const o0 = k0 * J * 3, o1 = k1 * J * 3;
    for (let i = 0; i < J * 3; i++) out[i] = src[o0 + i] * (1 - a) + src[o1 + i] * a;
    return out;
  }
  function sky(ctx, W, H) {
    const g = ctx.createLinearGradient(0, 0, 0, H);
    g.addColorStop(0, "#f4f6fa"); g.addColorStop(1, "#dfe5ee");
    ctx.fillStyle = g; ctx.fillRect(0, 0, W, H);
  }
  function empty(ctx, H, hasScene) {
    ctx.fillStyle = "#667"; ctx.font = "16px sans-serif";
    ctx.fillText(hasScene ? "nothing to show" : "no motion yet: type a prompt and press Generate", 24, H / 2);
  }
  function floor(ctx, sc, V) {
    // a checkerboard under the motions (the camera is kept above it: see Camera's limits)
    if (!sc.floor || V.B.eye[1] <= 0) return;
    const [x0, x1, z0, z1] = sc.floor, tile = sc.floorStyle.tile;
    for (let a = 0; a < 2; a++) {
      ctx.fillStyle = sc.floorStyle.colors[a]; ctx.beginPath();
      for (let i = x0; i < x1; i++) for (let k = z0; k < z1; k++) {
        if (((i + k) & 1) !== a) continue;
        const cs = [V.cx(i * tile, 0, k * tile), V.cx((i + 1) * tile, 0, k * tile), V.cx((i + 1) * tile, 0, (k + 1) * tile), V.cx(i * tile, 0, (k + 1) * tile)];
        if (cs.some((c) => c[2] < V.near)) continue;
        const ps = cs.map(V.scr);
        ctx.moveTo(ps[0][0], ps[0][1]); for (let q = 1; q < 4; q++) ctx.lineTo(ps[q][0], ps[q][1]); ctx.closePath();
      }
      ctx.fill();
    }
  }
  function paths(ctx, sc, V) {
    // each role's pelvis path just above the floor, and the drawn guides in 3-D
    const polyline = (pts, count, stride, color, width, y) => {
      ctx.strokeStyle = color; ctx.lineWidth = width; ctx.lineJoin = "round"; ctx.beginPath();
      let open = false;
      for (let k = 0; k < count; k++) {
        const c = V.cx(pts[k * stride], y === undefined ? pts[k * stride + 1] : y, pts[k * stride + 2]);
        if (c[2] < V.near) { open = false; continue; }
        const s = V.scr(c);
        if (open) ctx.lineTo(s[0], s[1]); else { ctx.moveTo(s[0], s[1]); open = true; }
      }
      ctx.stroke();
    };
    const {J, pelvis} = sc.skeleton;
    for (const r of sc.roles) polyline(r.joints.subarray(pelvis * 3), r.T, J * 3, rgb(r.jointColors[pelvis], 0.85), 2, 0.006);
    for (const gd of sc.guides) polyline(gd.points, gd.n, 3, `rgba(${gd.color[0]},${gd.color[1]},${gd.color[2]},0.85)`, 3);
  }
  function primitives(sc, V, pos, k, stepIndex) {
    // every bone (joint -> its parent) and joint of every role, in camera coordinates, with its colour
    const {J, parents, head, radii} = sc.skeleton, prims = [];
    for (const r of sc.roles) {
      const P = pose(sc, r, pos, stepIndex), C = [];
      for (let j = 0; j < J; j++) C.push(V.cx(P[3 * j], P[3 * j + 1], P[3 * j + 2]));
      let colors = r.jointColors;
      if (r.frameColors) {  // (T, J, 3) per frame and joint
        const o = Math.min(k, r.T - 1) * J * 3, fc = r.frameColors;
        colors = Array.from({length: J}, (_, j) => [fc[o + 3 * j], fc[o + 3 * j + 1], fc[o + 3 * j + 2]]);
      }
      for (let j = 0; j < J; j++) {
        const p = parents[j];
        if (p < 0) continue;
        const a = C[p], b = C[j];
        if (a[2] < V.near || b[2] < V.near) continue;
        prims.push({z: (a[2] + b[2]) / 2, bone: true, a, b, color: colors[j]});
      }
      for (let j = 0; j < J; j++) {
        if (C[j][2] < V.near) continue;
        prims.push({z: C[j][2], bone: false, a: C[j], color: colors[j], radius: j === head ? radii.head : radii.joint});
      }
    }
    return prims;
  }
  function bodies(ctx, sc, V, pos, k, stepIndex) {
    const prims = primitives(sc, V, pos, k, stepIndex);
    prims.sort((p, q) => q.z - p.z);
    ctx.lineCap = "round";
    for (const p of prims) {
      if (p.bone) {
        const s0 = V.scr(p.a), s1 = V.scr(p.b);
        ctx.strokeStyle = rgb(p.color, 0.82); ctx.lineWidth = Math.max(1, 2 * sc.skeleton.radii.bone * V.f / p.z);
        ctx.beginPath(); ctx.moveTo(s0[0], s0[1]); ctx.lineTo(s1[0], s1[1]); ctx.stroke();
      } else {
        const s = V.scr(p.a), rad = Math.max(1.5, p.radius * V.f / p.z);
        ctx.fillStyle = rgb(p.color, 1); ctx.beginPath(); ctx.arc(s[0], s[1], rad, 0, 2 * Math.PI); ctx.fill();
        ctx.fillStyle = "rgba(255,255,255,0.35)"; ctx.beginPath(); ctx.arc(s[0] - rad * 0.3, s[1] - rad * 0.3, rad * 0.45, 0, 2 * Math.PI); ctx.fill();
      }
    }
  }
  function texts(ctx, sc, k, stepIndex, W) {
    // title (left), frame (right), denoising step (below the title)
    ctx.font = "15px sans-serif"; ctx.fillStyle = "#223";
    const frameText = `frame ${k} / ${Math.max(0, sc.T - 1)}`;
    const fw = ctx.measureText(frameText).width;
    let title = sc.title || sc.roles.map((r) => r.name).join(" | ");
    while (title.length > 4 && ctx.measureText(title).width > W - fw - 40) title = title.slice(0, -2) + "\u2026";
    ctx.fillText(title, 12, 22);
    ctx.fillText(frameText, W - fw - 12, 22);
    if (sc.preview) {
      ctx.fillStyle = "#a33"; ctx.fillText(`denoising: step ${sc.preview.step} / ${sc.preview.numSteps} (x\u03020, live)`, 12, 44);
    } else if (stepIndex >= 0 && sc.denoising) {
      ctx.fillStyle = "#a33"; ctx.fillText(`x\u03020 after step ${sc.denoising.steps[stepIndex]} / ${sc.denoising.numSteps}`, 12, 44);
    }
  }
  function picture(ctx, sc, V, {pos, stepIndex, showPath, W, H}) {
    // the whole picture of sc at playhead pos; returns the frame drawn (-1: nothing drawn but the message)
    sky(ctx, W, H);
    if (!sc || !sc.roles.length) { empty(ctx, H, !!sc); return -1; }
    const k = Math.max(0, Math.min(Math.round(pos), sc.T - 1));
    floor(ctx, sc, V);
    if (showPath) paths(ctx, sc, V);
    bodies(ctx, sc, V, pos, k, stepIndex);
    texts(ctx, sc, k, stepIndex, W);
    return k;
  }
  return {picture};
})();
