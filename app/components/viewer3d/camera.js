// camera: an orbit camera around a point (azimuth, elevation, distance), following the pelvis or fixed; the
// perspective projection; the limits that keep the floor in sight and the body within reach.
const Camera = (() => {
  const NEAR = 0.05;  // metres: anything closer to the eye is not drawn
  // the camera's limits: above the floor (never level with it: the floor would vanish edge-on), and between a fifth of
  // and 3.5 times the distance that frames the motion (zoomed out further the body is a dot)
  const LIMITS = {minEl: 5, maxEl: 85, zoomIn: 0.2, zoomOut: 3.5, minDist: 0.3, maxTargetY: 2.5};
  const clamp = (x, lo, hi) => Math.max(lo, Math.min(hi, x));

  function create() { return {az: 0, el: LIMITS.minEl, dist: 4, target: [0, 1, 0], rel: true, fitDist: null}; }

  function track(sc) {
    // the mean pelvis XZ of all roles per frame (what "camera follows" follows); y = 0
    const T = sc.T, J = sc.skeleton.J, P = sc.skeleton.pelvis, out = new Float32Array(T * 3);
    for (let k = 0; k < T; k++) {
      let x = 0, z = 0;
      for (const r of sc.roles) { const f = Math.min(k, r.T - 1); x += r.joints[(f * J + P) * 3]; z += r.joints[(f * J + P) * 3 + 2]; }
      out[3 * k] = x / sc.roles.length; out[3 * k + 2] = z / sc.roles.length;
    }
    return out;
  }
  function prepare(sc) {
    // what the camera needs of a decoded scene: the pelvis track and the floor's extent in tiles (all motions + 0.8 m)
    sc.track = track(sc);
    sc.floor = null;
    if (!sc.floorStyle) return sc;
    let lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
    const grow = (x, y, z) => { lo = [Math.min(lo[0], x), Math.min(lo[1], y), Math.min(lo[2], z)]; hi = [Math.max(hi[0], x), Math.max(hi[1], y), Math.max(hi[2], z)]; };
    for (const r of sc.roles) for (let i = 0; i < r.joints.length; i += 3) grow(r.joints[i], r.joints[i + 1], r.joints[i + 2]);
    for (const g of sc.guides) for (let i = 0; i < g.points.length; i += 3) grow(g.points[i], g.points[i + 1], g.points[i + 2]);
    const pad = 0.8, tile = sc.floorStyle.tile;
    sc.floor = [Math.floor((lo[0] - pad) / tile), Math.ceil((hi[0] + pad) / tile), Math.floor((lo[2] - pad) / tile), Math.ceil((hi[2] + pad) / tile)];
    return sc;
  }
  function currentTarget(cam, sc, pos) {
    if (!sc || !cam.rel) return cam.target;
    const T = sc.T, k0 = Math.max(0, Math.min(Math.floor(pos), T - 1)), k1 = Math.min(k0 + 1, T - 1), a = Math.min(1, Math.max(0, pos - k0));
    const tr = sc.track;
    return [cam.target[0] + tr[3 * k0] * (1 - a) + tr[3 * k1] * a, cam.target[1], cam.target[2] + tr[3 * k0 + 2] * (1 - a) + tr[3 * k1 + 2] * a];
  }
  function basis(cam, sc, pos) {
    const a = cam.az * Math.PI / 180, e = cam.el * Math.PI / 180;
    const back = [Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e)];
    const target = currentTarget(cam, sc, pos);
    const eye = [target[0] + back[0] * cam.dist, target[1] + back[1] * cam.dist, target[2] + back[2] * cam.dist];
    const fwd = [-back[0], -back[1], -back[2]];
    let right = [fwd[1] * 0 - fwd[2] * 1, fwd[2] * 0 - fwd[0] * 0, fwd[0] * 1 - fwd[1] * 0];  // fwd x up
    const rl = Math.hypot(right[0], right[1], right[2]) || 1; right = right.map((x) => x / rl);
    const up = [right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2], right[0] * fwd[1] - right[1] * fwd[0]];
    return {eye, fwd, right, up};
  }
  function projector(cam, sc, pos, W, H) {
    // world -> camera coordinates (cx: right, up, depth) and camera -> canvas pixels (scr); f: the focal length
    const B = basis(cam, sc, pos), f = (H / 2) / Math.tan(sc.fov / 2);
    const cx = (x, y, z) => {
      const dx = x - B.eye[0], dy = y - B.eye[1], dz = z - B.eye[2];
      return [dx * B.right[0] + dy * B.right[1] + dz * B.right[2], dx * B.up[0] + dy * B.up[1] + dz * B.up[2],
              dx * B.fwd[0] + dy * B.fwd[1] + dz * B.fwd[2]];
    };
    const scr = (c) => [W / 2 + f * c[0] / c[2], H / 2 - f * c[1] / c[2]];
    return {B, f, cx, scr, near: NEAR};
  }
  function fit(cam, sc, follow, aspect) {
    // frame the body: all of it (fixed camera) or everything it does around its pelvis (camera follows)
    cam.az = sc.azimuth; cam.el = sc.elevation; cam.rel = !!follow;
    const J = sc.skeleton.J;
    let lo = [1e9, 1e9, 1e9], hi = [-1e9, -1e9, -1e9];
    for (const r of sc.roles) for (let k = 0; k < r.T; k++) {
      const tk = Math.min(k, sc.T - 1);
      for (let j = 0; j < J; j++) {
        const i = (k * J + j) * 3;
        const p = cam.rel ? [r.joints[i] - sc.track[3 * tk], r.joints[i + 1], r.joints[i + 2] - sc.track[3 * tk + 2]] : [r.joints[i], r.joints[i + 1], r.joints[i + 2]];
        for (let c = 0; c < 3; c++) { lo[c] = Math.min(lo[c], p[c]); hi[c] = Math.max(hi[c], p[c]); }
      }
    }
    cam.target = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    const radius = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) + 0.1;
    const half = Math.min(sc.fov / 2, Math.atan(Math.tan(sc.fov / 2) * aspect));
    cam.dist = Math.max(0.5, radius / Math.sin(half) * 1.0);
    cam.fitDist = cam.dist;
    cam.el = clamp(cam.el, LIMITS.minEl, LIMITS.maxEl);
  }
  function distLimits(cam) {
    const fitDist = cam.fitDist || 4;
    return [Math.max(LIMITS.minDist, fitDist * LIMITS.zoomIn), Math.max(LIMITS.minDist, fitDist * LIMITS.zoomOut)];
  }
  function keepTargetOnFloor(cam, sc, pos) {
    // a pan moves the point looked at, never off the floor's tiles nor under them or far above the body
    if (!sc || !sc.floor) return;
    const t = currentTarget(cam, sc, pos), [x0, x1, z0, z1] = sc.floor, tile = sc.floorStyle.tile;
    cam.target[0] += clamp(t[0], x0 * tile, x1 * tile) - t[0];
    cam.target[2] += clamp(t[2], z0 * tile, z1 * tile) - t[2];
    cam.target[1] = clamp(cam.target[1], 0, LIMITS.maxTargetY);
  }
  function orbit(cam, dx, dy) {
    cam.az -= dx * 0.4; cam.el = clamp(cam.el + dy * 0.3, LIMITS.minEl, LIMITS.maxEl);
  }
  function pan(cam, sc, pos, dx, dy) {
    const B = basis(cam, sc, pos), s = cam.dist * 0.0018;
    for (let c = 0; c < 3; c++) cam.target[c] += (-dx * B.right[c] + dy * B.up[c]) * s;
    keepTargetOnFloor(cam, sc, pos);
  }
  function zoom(cam, deltaY) {
    const [minDist, maxDist] = distLimits(cam);
    cam.dist = clamp(cam.dist * Math.exp(deltaY * 0.001), minDist, maxDist);
  }
  function snapshot(cam, eyeY) {
    // what window.moattnPlayer.camera shows (tests and the bench read it)
    const [minDist, maxDist] = distLimits(cam);
    return {az: cam.az, el: cam.el, dist: cam.dist, eye_y: eyeY, min_dist: minDist, max_dist: maxDist,
            fit_dist: cam.fitDist || null};
  }
  return {create, prepare, projector, fit, orbit, pan, zoom, snapshot};
})();
