"""Animated GLB export (engine.io.glb): the container, the node tree, the keyframes, the meshes, `moattn convert
IN OUT.glb` and the studio's GLB export. The file is parsed back here by hand (no glTF library), and world positions
are recomputed from the node TRS keyframes with a small forward kinematics of our own."""
from __future__ import annotations

import asyncio
import json
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from engine.io import MotionIOError, format_glb, load_motion, save_glb, save_motion
from engine.io.glb import glb_pose_channels
from engine.skeleton import CHILDREN, JOINT_NAMES
from engine.units import FPS
from tests.conftest import real_file

TOLERANCE_M = 1e-4  # world positions from the keyframes vs the input joints (float32 keys: ~1e-7 m in practice)
COMPONENTS = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}
WIDTH = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}


def parse_glb(data: bytes) -> tuple[dict, bytes]:
    """Check the GLB container (header, JSON chunk, BIN chunk) and return (JSON, BIN)."""
    magic, version, total = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and total == len(data) and total % 4 == 0
    json_len, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A and json_len % 4 == 0
    gltf = json.loads(data[20:20 + json_len].decode("utf-8"))
    bin_len, bin_type = struct.unpack_from("<II", data, 20 + json_len)
    assert bin_type == 0x004E4942 and bin_len % 4 == 0
    assert 28 + json_len + bin_len == total
    blob = data[28 + json_len:28 + json_len + bin_len]
    assert gltf["buffers"] == [{"byteLength": gltf["buffers"][0]["byteLength"]}]
    assert len(blob) - 3 <= gltf["buffers"][0]["byteLength"] <= len(blob)
    return gltf, blob


def accessor(gltf: dict, blob: bytes, index: int) -> np.ndarray:
    acc = gltf["accessors"][index]
    view = gltf["bufferViews"][acc["bufferView"]]
    dtype = COMPONENTS[acc["componentType"]]
    width = WIDTH[acc["type"]]
    start = view["byteOffset"] + acc.get("byteOffset", 0)
    assert start % 4 == 0 and view["byteOffset"] + view["byteLength"] <= len(blob)
    values = np.frombuffer(blob, dtype=dtype, count=acc["count"] * width, offset=start)
    return values.reshape(acc["count"], width) if width > 1 else values


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """glTF quaternions (..., 4) x y z w -> rotation matrices (..., 3, 3)."""
    x, y, z, w = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def keyframe_positions(gltf: dict, blob: bytes, *, rest: np.ndarray | None = None) -> np.ndarray:
    """World positions (T, nodes, 3) of every node from the animation's TRS keys (forward kinematics); with
    ``rest`` (nodes, 3) the non-root nodes use these constant offsets instead of their translation keys."""
    nodes = gltf["nodes"]
    keys: dict[tuple[int, str], np.ndarray] = {}
    animation = gltf["animations"][0]
    for channel in animation["channels"]:
        sampler = animation["samplers"][channel["sampler"]]
        keys[channel["target"]["node"], channel["target"]["path"]] = accessor(gltf, blob, sampler["output"])
    frames = len(next(iter(keys.values())))
    parent = {c: p for p, node in enumerate(nodes) for c in node.get("children", [])}
    rot = np.empty((frames, len(nodes), 3, 3))
    pos = np.empty((frames, len(nodes), 3))
    for n in range(len(nodes)):  # our files list every parent before its children
        local_r = _quat_matrix(keys[n, "rotation"])
        local_t = keys[n, "translation"].astype(np.float64)
        if rest is not None and n in parent:
            local_t = np.broadcast_to(rest[n], local_t.shape)
        if n not in parent:
            rot[:, n], pos[:, n] = local_r, local_t
        else:
            p = parent[n]
            assert p < n
            rot[:, n] = rot[:, p] @ local_r
            pos[:, n] = pos[:, p] + np.einsum("tij,tj->ti", rot[:, p], local_t)
    return pos


def synthetic_walk(frames: int = 200) -> np.ndarray:
    """A procedural motion (engine.synth): a walk of ``frames`` frames (200 = 10 s at 20 fps)."""
    from engine.synth.compose import synthesize
    from engine.synth.program import Program, Segment

    program = Program(segments=(Segment(action="walk", direction="forward", frames=frames),), style="none", seed=1)
    return synthesize(program).joints.astype(np.float32)


@pytest.fixture(scope="module")
def real_glb():
    joints = load_motion(real_file("humanml3d_012314_joints.npy"))
    return joints, format_glb(joints)


def test_glb_structure_node_tree_meshes_and_keyframes(real_glb):
    joints, data = real_glb
    gltf, blob = parse_glb(data)
    frames = len(joints)
    assert gltf["asset"]["version"] == "2.0"
    nodes = gltf["nodes"]
    assert [n["name"] for n in nodes] == list(JOINT_NAMES)
    assert gltf["scenes"][gltf["scene"]]["nodes"] == [0]  # the pelvis is the root
    for j, node in enumerate(nodes):
        assert node.get("children", []) == list(CHILDREN[j])
        assert "matrix" not in node and len(node["translation"]) == 3 and len(node["rotation"]) == 4
        prim = gltf["meshes"][node["mesh"]]["primitives"][0]
        position = accessor(gltf, blob, prim["attributes"]["POSITION"])
        normal = accessor(gltf, blob, prim["attributes"]["NORMAL"])
        faces = accessor(gltf, blob, prim["indices"])
        acc = gltf["accessors"][prim["attributes"]["POSITION"]]
        np.testing.assert_array_equal(acc["min"], position.min(0))
        np.testing.assert_array_equal(acc["max"], position.max(0))
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-5)
        assert len(faces) % 3 == 0 and faces.max() < len(position)
        assert prim["material"] < len(gltf["materials"])
        # a bone reaches each child's rest position: the mesh spans at least the longest child offset
        reach = np.linalg.norm(position, axis=1).max()
        assert reach >= max([np.linalg.norm(nodes[c]["translation"]) * 0.9 for c in CHILDREN[j]] + [0.03])
    # the bones hang off the parent: the pelvis mesh reaches both hips and spine1 (three capsules + a sphere)
    assert len(accessor(gltf, blob, gltf["meshes"][0]["primitives"][0]["attributes"]["POSITION"])) > 3 * 60
    (animation,) = gltf["animations"]
    assert len(animation["channels"]) == 2 * len(JOINT_NAMES)
    targets = {(c["target"]["node"], c["target"]["path"]) for c in animation["channels"]}
    assert targets == {(j, p) for j in range(len(JOINT_NAMES)) for p in ("rotation", "translation")}
    for sampler in animation["samplers"]:
        assert sampler["interpolation"] == "LINEAR"
        times = accessor(gltf, blob, sampler["input"])
        acc = gltf["accessors"][sampler["input"]]
        assert acc["type"] == "SCALAR" and acc["min"] == [0.0] and acc["max"][0] == pytest.approx((frames - 1) / FPS)
        np.testing.assert_allclose(times, np.arange(frames) / FPS, atol=1e-6)
        out = gltf["accessors"][sampler["output"]]
        assert out["count"] == frames and out["type"] in ("VEC3", "VEC4") and out["componentType"] == 5126
    rotations = [accessor(gltf, blob, animation["samplers"][c["sampler"]]["output"])
                 for c in animation["channels"] if c["target"]["path"] == "rotation"]
    for q in rotations:
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
        assert (np.einsum("ti,ti->t", q[1:], q[:-1]) >= 0).all()  # keys on one hemisphere: slerp takes the short way
    for j in range(len(JOINT_NAMES)):
        if not CHILDREN[j]:  # a leaf keeps its parent's rotation
            np.testing.assert_allclose(np.abs(rotations[j][:, 3]), 1.0, atol=1e-6)


@pytest.mark.parametrize("source", ["humanml3d_012314_joints.npy", "cmu_131_01_walk.bvh", "synthetic"])
def test_glb_keyframes_reproduce_the_joints(source, tmp_path):
    joints = synthetic_walk(120) if source == "synthetic" else load_motion(real_file(source))
    path = save_glb(joints, tmp_path / "m.glb")
    gltf, blob = parse_glb(path.read_bytes())
    error = np.linalg.norm(keyframe_positions(gltf, blob) - joints, axis=-1).max()
    # measured: ~1e-7 m on all three (float32 keys)
    assert error < TOLERANCE_M, f"{source}: {error * 1000:.3f} mm"
    # the translation keys matter: the pelvis's and spine3's three children are not rigid relative to each other
    # (and retargeted BVH bones change length), so constant rest offsets would miss by centimetres (measured:
    # 2.9 cm HumanML3D, 6.6 cm CMU walk)
    rest = glb_pose_channels(joints)[0]
    constant = np.linalg.norm(keyframe_positions(gltf, blob, rest=rest) - joints, axis=-1).max()
    if source != "synthetic":
        assert constant > 0.01, f"{source}: {constant * 1000:.1f} mm"
    # frame 0 is also the nodes' static pose (viewers that ignore animations)
    nodes = gltf["nodes"]
    parent = {c: p for p, node in enumerate(nodes) for c in node.get("children", [])}
    world: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for n, node in enumerate(nodes):
        r, t = _quat_matrix(np.asarray(node["rotation"])), np.asarray(node["translation"])
        if n in parent:
            pr, pt = world[parent[n]]
            r, t = pr @ r, pt + pr @ t
        world[n] = (r, t)
    np.testing.assert_allclose(np.array([world[n][1] for n in range(len(nodes))]), joints[0], atol=TOLERANCE_M)


VALIDATOR = Path(__file__).resolve().parents[1] / ".tools" / "node" / "node_modules" / "gltf-validator"


def test_khronos_gltf_validator_finds_no_error_or_warning(tmp_path):
    """Khronos' own validator (npm's gltf-validator, installed by `make test`) on the three kinds of source and a
    duet; what Blender's and three.js's importers read."""
    assert shutil.which("node"), "node is not installed: run `make test` (it installs the glTF validator)"
    assert VALIDATOR.exists(), f"{VALIDATOR} is missing: run `make test` (or `make gltf-validator`)"
    walk = synthetic_walk(60)
    files = [save_glb(load_motion(real_file("humanml3d_012314_joints.npy")), tmp_path / "hml.glb"),
             save_glb(load_motion(real_file("cmu_131_01_walk.bvh")), tmp_path / "cmu.glb"),
             save_glb(walk, tmp_path / "walk.glb"),
             save_glb(np.stack([walk, walk + np.float32([1, 0, 0])]), tmp_path / "duet.glb")]
    script = Path(__file__).with_name("gltf_validate.js")
    done = subprocess.run(["node", str(script), *map(str, files)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    reports = [json.loads(line) for line in done.stdout.splitlines()]
    assert [r["file"] for r in reports] == [str(f) for f in files]
    for r in reports:
        assert r["numErrors"] == 0 and r["numWarnings"] == 0, r


def test_trimesh_reads_the_glb_back(real_glb, tmp_path):
    import trimesh

    joints, data = real_glb
    path = tmp_path / "walk.glb"
    path.write_bytes(data)
    scene = trimesh.load(path)
    assert isinstance(scene, trimesh.Scene)
    assert len(scene.geometry) == len(JOINT_NAMES) and len(scene.graph.nodes_geometry) == len(JOINT_NAMES)
    for j, name in enumerate(JOINT_NAMES):  # trimesh places the nodes at their static TRS: frame 0
        transform, _ = scene.graph.get(name)
        np.testing.assert_allclose(transform[:3, 3], joints[0, j], atol=1e-4)
    assert all(len(g.faces) > 0 for g in scene.geometry.values())


def test_ten_second_glb_is_small_and_a_duet_holds_two_skeletons():
    walk = synthetic_walk(10 * FPS)
    data = format_glb(walk)
    assert len(data) < 2 * 2**20  # measured: 0.24 MB (235 388 bytes) for 200 frames
    gltf, blob = parse_glb(data)
    assert gltf["accessors"][gltf["animations"][0]["samplers"][0]["input"]]["count"] == 200
    pair = np.stack([walk, walk + np.array([1.0, 0.0, 0.0], np.float32)])
    gltf, blob = parse_glb(format_glb(pair))
    assert len(gltf["nodes"]) == 44 and gltf["scenes"][0]["nodes"] == [0, 22]
    assert gltf["nodes"][22]["name"] == "b:pelvis" and gltf["nodes"][0]["name"] == "a:pelvis"
    positions = keyframe_positions(gltf, blob)
    np.testing.assert_allclose(positions[:, 22:], pair[1], atol=TOLERANCE_M)


def test_save_motion_writes_glb_and_refuses_bad_input(tmp_path):
    walk = synthetic_walk(30)
    path = save_motion(walk, tmp_path / "w.GLB")
    assert path.read_bytes()[:4] == b"glTF"
    with pytest.raises(MotionIOError, match="vecs"):
        save_motion(walk, tmp_path / "w.glb", to="vecs")
    bad = walk.copy()
    bad[3, 4, 1] = np.nan
    with pytest.raises(MotionIOError, match="NaN"):
        format_glb(bad)
    with pytest.raises(MotionIOError, match="shape"):
        format_glb(walk[:, :20])
    with pytest.raises(MotionIOError, match="unsupported motion file type '.GLB'"):
        load_motion(path)  # written only
    one = parse_glb(format_glb(walk[:1]))[0]  # a single frame is a one-key animation
    assert one["accessors"][one["animations"][0]["samplers"][0]["input"]]["max"] == [0.0]


def test_convert_writes_glb_and_errors_stay_one_line(tmp_path, capsys):
    from engine.cli import main

    src = real_file("cmu_131_01_walk.bvh")
    out = tmp_path / "walk.glb"
    assert main(["convert", str(src), str(out), "--seconds", "2"]) == 0
    assert "wrote" in capsys.readouterr().out
    gltf, blob = parse_glb(out.read_bytes())
    assert gltf["accessors"][gltf["animations"][0]["samplers"][0]["input"]]["count"] == 2 * FPS
    for argv, message in (([str(src), str(tmp_path / "w.glb"), "--to", "vecs"], "a .glb output holds joints"),
                          ([str(src), str(tmp_path / "w.gltf")], "use .npy, .bvh, .glb"),
                          ([str(src), str(tmp_path / "missing" / "w.glb")], "does not exist"),
                          ([str(out), str(tmp_path / "back.npy")], "unsupported motion file type '.glb'")):
        assert main(["convert", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("moattn convert: error: ") and message in err and err.count("\n") == 1


def test_studio_exports_glb(tmp_path, run_coroutine):
    from app.session.duets import DuetPair
    from app.session.items import MotionItem
    from app.session.state import StudioState
    from app.tabs.files.exports import EXPORTS, export_bytes, export_filename
    from app.tabs.files.view import ExportPanel

    assert EXPORTS["glb"] == "GLB"
    walk = synthetic_walk(40)
    item = MotionItem(name="a person walks", joints=walk, source="imported")
    data = export_bytes(item, "glb")
    assert data.startswith(b"glTF") and export_filename(item, "glb") == "a_person_walks.glb"
    gltf, blob = parse_glb(data)
    np.testing.assert_allclose(keyframe_positions(gltf, blob), walk, atol=TOLERANCE_M)
    pair = DuetPair(first="x · a", second="x · b", joints=np.stack([walk, walk[::-1]]))
    duet = MotionItem(name="x · a", joints=walk, source="generated", info={"duet": pair})
    assert len(parse_glb(export_bytes(duet, "glb"))[0]["nodes"]) == 44  # both people, one scene

    state = StudioState()
    panel = ExportPanel(state=state)
    button = panel.buttons["glb"]
    assert button.label == "GLB" and button.disabled
    state.show_motion(walk, title="imported: walk")
    assert not button.disabled and button.filename.endswith(".glb")
    downloaded = run_coroutine(button.callback())
    assert downloaded.getvalue()[:4] == b"glTF"
