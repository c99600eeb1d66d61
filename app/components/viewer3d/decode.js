// decode: the server's scene payload (app/viewer/scene.py) -> a scene of frames. Joints arrive as base64
// little-endian float32 (int16 millimetres for the denoising history and a live preview), colours as uint8.
// The skeleton (parents, pelvis, head, sizes), the floor and the field of view come with the payload too: nothing
// about the skeleton is written down on this side.
const Decode = (() => {
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
  function skeletonOf(msg) {
    // the server's description of the body (app.viewer.scene.skeleton_payload); J joints, one parent each
    const s = msg.skeleton;
    if (!s) return {J: 0, parents: [], pelvis: -1, head: -1, radii: null};
    return {J: s.parents.length, parents: s.parents, pelvis: s.pelvis, head: s.head, radii: s.radii};
  }
  function colorsOf(flat, J) {
    // a flat list of J RGB triples -> J [r, g, b]
    return Array.from({length: J}, (_, j) => flat.slice(3 * j, 3 * j + 3));
  }
  function common(msg) {
    // what every scene and preview carries besides its motions (an empty scene may carry none of it: nothing is drawn)
    const f = msg.floor;
    return {key: msg.key, title: msg.title || "", T: msg.n_frames || 0, fps: msg.fps, skeleton: skeletonOf(msg),
            floorStyle: f ? {tile: f.tile, colors: f.colors.map((c) => `rgb(${c[0]},${c[1]},${c[2]})`)} : null,
            fov: msg.fov * Math.PI / 180, azimuth: msg.azimuth || 0, elevation: msg.elevation || 0};
  }
  function decodeScene(msg) {
    const sc = common(msg), J = sc.skeleton.J;
    sc.roles = (msg.roles || []).map((r) => ({
      name: r.name, T: r.n_frames, joints: float32Of(r.joints), jointColors: colorsOf(r.joint_colors, J),
      frameColors: r.frame_colors ? bytesOf(r.frame_colors) : null,
    }));
    sc.guides = (msg.guides || []).map((g) => ({color: g.color, n: g.n, points: float32Of(g.points)}));
    sc.denoising = null;
    if (msg.denoising) {
      const d = msg.denoising;
      sc.denoising = {steps: d.steps, numSteps: d.num_steps, recorded: d.recorded, T: d.n_frames,
                      joints: metresOfMm(d.joints_mm)};
    }
    Object.assign(sc, {preview: null, job: msg.job || null, sentAt: msg.sent_at || null, legend: msg.legend || null});
    return sc;
  }
  function previewScene(msg) {
    // one live x̂0 motion while sampling: drawn like a scene of one role, with the step in its title
    const sc = common(msg);
    sc.roles = [{name: "x\u03020", T: msg.n_frames, joints: metresOfMm(msg.joints_mm),
                 jointColors: colorsOf(msg.joint_colors, sc.skeleton.J), frameColors: null}];
    Object.assign(sc, {guides: [], denoising: null, preview: {step: msg.step, numSteps: msg.num_steps}});
    return sc;
  }
  return {decodeScene, previewScene};
})();
