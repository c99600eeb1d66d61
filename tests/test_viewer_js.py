"""The 3-D viewer's JavaScript (app/components/viewer3d/, #34 item 4): one file a job, joined in a fixed order into the
one ES module Panel sends to the page; the skeleton, floor and field of view come in the scene payload, and no joint
table is written in the JavaScript. Run in node (installed by `make test`): the modules draw a payload the server made."""
from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np

from app.components.skeleton_view import JS_FOLDER, MODULES, SkeletonView, viewer_source
from app.viewer.scene import FLOOR_TILE, SceneSpec, preview_message, scene_message
from engine.skeleton import JOINT_INDEX, PARENTS
from viz.colors import FLOOR_COLORS, ROLE_PALETTE, default_joint_colors
from viz.flat import VIEW_ANGLE

NAMESPACES = {name: name.capitalize() for name in MODULES if name != "main"}


def _walk(n: int = 6) -> np.ndarray:
    rng = np.random.default_rng(0)
    return np.asarray(rng.normal(0, 0.3, (n, len(PARENTS), 3)) + [0, 1, 0], dtype=np.float64)


def _sources() -> dict[str, str]:
    return {name: (JS_FOLDER / f"{name}.js").read_text(encoding="utf-8") for name in MODULES}


def test_every_message_describes_the_skeleton_floor_and_view():
    joints = _walk()
    messages = [scene_message(SceneSpec(motions=(("a", joints), ("b", joints))), key=1), scene_message(None, key=0),
                preview_message(joints, key=2, step=1, num_steps=5, title="x")]
    for m in messages:
        sk = m["skeleton"]
        assert sk["parents"] == list(PARENTS)
        assert (sk["pelvis"], sk["head"]) == (JOINT_INDEX["pelvis"], JOINT_INDEX["head"])
        assert set(sk["radii"]) == {"joint", "head", "bone"} and all(r > 0 for r in sk["radii"].values())
        assert m["floor"] == {"tile": FLOOR_TILE, "colors": [list(c) for c in FLOOR_COLORS]}
        assert m["fov"] == VIEW_ANGLE and m["fps"] > 0
        json.dumps(m)  # what the page receives
    # the live preview is coloured as the first role of a scene (left lighter, right darker), by the server
    assert messages[2]["joint_colors"] == default_joint_colors(ROLE_PALETTE[0]).reshape(-1).tolist()
    assert messages[2]["joint_colors"] == messages[0]["roles"][0]["joint_colors"]


def test_no_joint_table_or_skeleton_constant_is_written_in_the_javascript():
    """The parents, the left/right joint lists, the joint count, the pelvis/head indices, the sizes and the floor's
    colours are the server's (engine.skeleton, viz.colors): none is copied into the page's code."""
    code = {name: re.sub(r"//[^\n]*", "", text) for name, text in _sources().items()}  # comments may name numbers
    parents = r"\[\s*" + r"\s*,\s*".join(str(p) for p in PARENTS[:6])  # the parents array, however spaced
    for name, text in code.items():
        assert not re.search(parents, text), f"{name}.js holds the parents array"
        # a table of joint indices: five or more small integers in a row
        tables = re.findall(r"\[\s*\d{1,2}(?:\s*,\s*\d{1,2}){4,}\s*\]", text)
        assert not tables, f"{name}.js holds a joint table: {tables}"
        # the joint count as a constant, an array's length or a stride (22 is also a text's baseline, in pixels)
        assert not re.search(r"(=|length:|\*)\s*22\b|\b22\s*\*", text), f"{name}.js names the joint count"
        assert not re.search(r"\b(PELVIS|HEAD|LEFT|RIGHT|TILE|FLOOR|FOV)\s*=", text), f"{name}.js defines a constant"
        for value in ("0.032", "0.07", "232", "206", "58, 111, 216"):  # radii, floor colours, the first role's blue
            assert value not in text, f"{name}.js holds {value}"
    assert "skeleton.parents" in code["decode"] or "s.parents" in code["decode"]


def test_the_modules_are_joined_in_order_each_one_namespace():
    files = {p.stem for p in JS_FOLDER.glob("*.js")}
    assert files == set(MODULES), "every file in viewer3d/ is joined, and only those"
    assert not (JS_FOLDER.parent / "skeleton_view.js").exists()
    src = _sources()
    assert SkeletonView._esm == viewer_source()
    assert viewer_source().count("export ") == 1 and "export function render" in src["main"]
    for i, name in enumerate(MODULES):
        text = src[name]
        if name in NAMESPACES:
            # one namespace object per file, and nothing else at the top level
            assert re.findall(r"^const (\w+) = \(\(\) => \{$", text, re.M) == [NAMESPACES[name]], name
            assert re.findall(r"^\S", re.sub(r"^//[^\n]*", "", text, flags=re.M), re.M) == ["c", "}"], name
        later = [NAMESPACES[m] for m in MODULES[i:] if m in NAMESPACES]
        for ns in later:  # a file uses only the namespaces joined before it
            if ns != NAMESPACES.get(name):
                assert not re.search(rf"\b{ns}\.", text), f"{name}.js uses {ns} before it is declared"


HARNESS = """
const calls = {};
const ctx = new Proxy({}, {
  get: (t, k) => k in t ? t[k] : k === "measureText" ? ((s) => ({width: 7 * s.length}))
    : k.startsWith("create") ? (() => ({addColorStop() {}})) : ((...a) => { calls[k] = (calls[k] || 0) + 1; }),
  set: (t, k, v) => { t[k] = v; return true; }});
const out = [];
for (const [i, msg] of MESSAGES.entries()) {
  for (const k in calls) delete calls[k];
  const sc = Camera.prepare(i === 0 ? Decode.decodeScene(msg) : Decode.previewScene(msg));
  const cam = Camera.create();
  Camera.fit(cam, sc, true, 1.5);
  const fitted = Camera.snapshot(cam, 0);
  Camera.orbit(cam, 0, 1e4); Camera.zoom(cam, 1e6);  // past every limit
  const V = Camera.projector(cam, sc, 1.5, 600, 400);
  const k = Draw.picture(ctx, sc, V, {pos: 1.5, stepIndex: -1, showPath: false, W: 600, H: 400});
  out.push({k, J: sc.skeleton.J, roles: sc.roles.length, floor: sc.floor, fitted, cam: Camera.snapshot(cam, V.B.eye[1]),
            calls: {...calls}});
}
console.log(JSON.stringify(out));
"""


def test_the_modules_draw_the_servers_payload_in_node(tmp_path):
    """Decode -> Camera -> Draw on a scene of two roles and a preview: every bone (a joint with a parent) and every
    joint is drawn, the floor is laid, and the camera stays within its limits (above the floor, zoomed out at most
    3.5 times the framing distance)."""
    assert shutil.which("node"), "node is not installed: run `make test`"
    joints = _walk()
    messages = [scene_message(SceneSpec(motions=(("a", joints), ("b", joints))), key=1),
                preview_message(joints, key=2, step=1, num_steps=5, title="x")]
    body = "\n".join(_sources()[name] for name in MODULES if name in NAMESPACES)
    script = tmp_path / "harness.js"
    script.write_text(f"{body}\nconst MESSAGES = {json.dumps(messages)};\n{HARNESS}", encoding="utf-8")
    done = subprocess.run(["node", str(script)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    bones = sum(p >= 0 for p in PARENTS)
    for result, roles in zip(json.loads(done.stdout), (2, 1)):
        assert (result["k"], result["J"], result["roles"]) == (2, len(PARENTS), roles), result
        assert result["calls"]["arc"] == 2 * len(PARENTS) * roles, result  # a joint: a disc and its highlight
        assert result["calls"]["stroke"] == bones * roles, result  # no paths: only bones are stroked
        x0, x1, z0, z1 = result["floor"]
        assert x1 > x0 and z1 > z0 and result["calls"]["fill"] >= 2 + 2 * len(PARENTS) * roles
        cam = result["cam"]
        assert cam["el"] <= 85 and cam["eye_y"] > 0 and cam["dist"] <= 3.5 * cam["fit_dist"] + 1e-9, cam
        assert abs(cam["dist"] - cam["max_dist"]) < 1e-9 and cam["fit_dist"] == result["fitted"]["dist"]
