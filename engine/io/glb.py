"""Write 22-joint motions as animated glTF binaries (``.glb``) that Blender and three.js play.

Structure of the file (glTF 2.0, one buffer in the GLB's BIN chunk):

- one node per joint, named as :data:`engine.skeleton.JOINT_NAMES`, parented as the skeleton's kinematic tree
  (the scene's root node is the pelvis); a duet (several people) gets one such tree per person, node names
  prefixed ``a:``, ``b:``, ...;
- one mesh per joint node, built with trimesh: a sphere at the joint (icosphere, larger for the head) and a
  capsule bone from the joint to each child along the child's rest offset, so the bone turns with the joint;
  three materials (centre grey, left blue, right red; left is the body's +X side);
- one animation ("motion") at ``fps`` (20): per joint a LINEAR ``rotation`` channel (unit quaternions,
  x y z w) and a LINEAR ``translation`` channel, all sharing one time accessor (0, 1/fps, ..., (T-1)/fps).

Rest pose: our T-pose (facing +Z, left = +X) with the motion's median bone lengths, as the BVH export.
Rotations come from :meth:`engine.skeleton.Skeleton.inverse`: a joint with one child gets the shortest-arc
swing that aims its rest offset at the child (no twist, which positions cannot reveal), the pelvis and spine3
the best-fit (Kabsch) rotation of their three children, leaves the identity. Translations: the root's is the
pelvis position; every other joint's is its observed offset from its parent in the parent's rotated frame, so
the node world positions reproduce the input joints to float32 precision (bone-length changes over time and the
non-rigid pelvis / spine3 children included), where constant rest offsets would miss them by up to a few
centimetres. The meshes use the rest offsets, so a bone can be off its child by the change of its length.

The node transforms of frame 0 are also the nodes' static TRS, so a viewer that ignores animations shows the
first pose.
"""
from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np

from engine.io.errors import MotionIOError
from engine.rotations import matrix_to_quat
from engine.skeleton import CHILDREN, JOINT_NAMES, NUM_JOINTS, PARENTS, Skeleton, measure_bone_lengths

GLB_MAGIC = b"glTF"
GLB_VERSION = 2
CHUNK_JSON = 0x4E4F534A  # "JSON"
CHUNK_BIN = 0x004E4942  # "BIN\0"

JOINT_RADIUS = 0.03  # metres, the sphere at each joint
TORSO_RADIUS = 0.04  # pelvis and spine
HEAD_RADIUS = 0.07
BONE_RADIUS = 0.015
BONE_SECTIONS = 8

_FLOAT, _USHORT, _UINT = 5126, 5123, 5125  # accessor componentTypes
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_MATERIALS = (("centre", (0.78, 0.78, 0.80, 1.0)), ("left", (0.25, 0.50, 0.90, 1.0)),
              ("right", (0.90, 0.35, 0.30, 1.0)))


def _side(name: str) -> int:
    return 1 if name.startswith("left_") else 2 if name.startswith("right_") else 0


def _check(joints: np.ndarray, fps: float) -> np.ndarray:
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim == 3:
        joints = joints[None]
    if joints.ndim != 4 or joints.shape[2:] != (NUM_JOINTS, 3):
        raise MotionIOError(f"joints must have shape (T, {NUM_JOINTS}, 3) or (people, T, {NUM_JOINTS}, 3), "
                            f"got {np.shape(joints)}")
    if joints.shape[0] == 0 or joints.shape[1] == 0:
        raise MotionIOError("cannot write a GLB file with zero frames")
    if not np.isfinite(joints).all():
        raise MotionIOError("joints contain NaN or infinite values")
    if not (np.isfinite(fps) and fps > 0):
        raise MotionIOError(f"fps must be positive, got {fps}")
    return joints


def glb_pose_channels(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rest offsets (22, 3), local rotations (T, 22, 4) as glTF quaternions (x, y, z, w) and local translations
    (T, 22, 3) of joints (T, 22, 3) (see the module docstring); world positions from these reproduce ``joints``."""
    joints = np.asarray(joints, dtype=np.float64)
    skeleton = Skeleton.with_lengths(np.median(measure_bone_lengths(joints), axis=0))
    local, root = skeleton.inverse(joints)  # (T, 22, 3, 3), (T, 3)
    glob = skeleton.global_rotations(local)
    parents = np.array(PARENTS[1:])
    translations = np.empty_like(joints)
    translations[:, 0] = root
    bones = joints[:, 1:] - joints[:, parents]  # (T, 21, 3) in world
    translations[:, 1:] = np.einsum("tjki,tjk->tji", glob[:, parents], bones)  # R_parent^T @ bone
    quats = matrix_to_quat(local)  # (T, 22, 4) w x y z, w >= 0
    # keep each joint's quaternions on one hemisphere over time so LINEAR (slerp) keys never take the long way
    flips = np.einsum("tjq,tjq->tj", quats[1:], quats[:-1]) < 0
    sign = np.cumprod(np.where(flips, -1.0, 1.0), axis=0)
    quats[1:] *= sign[..., None]
    return skeleton.offsets, quats[..., [1, 2, 3, 0]], translations


def _joint_mesh(j: int, offsets: np.ndarray):
    """trimesh mesh of joint j in its own frame: its sphere and a capsule to each child's rest offset."""
    import trimesh
    from trimesh import creation

    name = JOINT_NAMES[j]
    radius = HEAD_RADIUS if name == "head" else TORSO_RADIUS if name.startswith(("pelvis", "spine")) else JOINT_RADIUS
    parts = [creation.icosphere(subdivisions=1, radius=radius)]
    for c in CHILDREN[j]:
        offset = offsets[c]
        length = float(np.linalg.norm(offset))
        if length < 1e-6:
            continue
        transform = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], offset / length)
        transform[:3, 3] = offset / 2.0
        parts.append(creation.capsule(height=length, radius=BONE_RADIUS, count=[BONE_SECTIONS, BONE_SECTIONS],
                                      transform=transform))
    return trimesh.util.concatenate(parts)


class _Builder:
    """The glTF JSON lists and the binary buffer they point into."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, kind: str, *, target: int | None = None, bounds: bool = False) -> int:
        """Append ``array`` (float32 or uint16/uint32, rows of ``kind``) as a bufferView + accessor; its index."""
        array = np.ascontiguousarray(array)
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": array.nbytes}
        if target is not None:
            view["target"] = target
        self.blob.extend(array.tobytes())
        self.views.append(view)
        component = {np.float32: _FLOAT, np.uint16: _USHORT, np.uint32: _UINT}[array.dtype.type]
        accessor = {"bufferView": len(self.views) - 1, "componentType": component, "count": len(array),
                    "type": kind}
        if bounds:
            rows = array.reshape(len(array), -1)
            accessor["min"] = [float(v) for v in rows.min(axis=0)]
            accessor["max"] = [float(v) for v in rows.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def motion_gltf(joints: np.ndarray, *, fps: float = 20.0, name: str = "motion") -> tuple[dict, bytes]:
    """The glTF JSON (a dict) and binary buffer of joints (T, 22, 3), or (people, T, 22, 3) for a duet."""
    people = _check(joints, fps)
    frames = people.shape[1]
    b = _Builder()
    times = b.add((np.arange(frames, dtype=np.float64) / fps).astype(np.float32), "SCALAR", bounds=True)
    nodes: list[dict] = []
    meshes: list[dict] = []
    roots: list[int] = []
    channels: list[dict] = []
    samplers: list[dict] = []
    for p, person in enumerate(people):
        prefix = f"{chr(ord('a') + p)}:" if len(people) > 1 else ""
        offsets, rotations, translations = glb_pose_channels(person)
        rotations = rotations.astype(np.float32)
        translations = translations.astype(np.float32)
        base = len(nodes)
        roots.append(base)
        for j in range(NUM_JOINTS):
            mesh = _joint_mesh(j, offsets)
            vertex_count = len(mesh.vertices)
            index_type = np.uint16 if vertex_count < 2**16 else np.uint32
            position = b.add(np.asarray(mesh.vertices, dtype=np.float32), "VEC3", target=_ARRAY_BUFFER, bounds=True)
            normal = b.add(np.asarray(mesh.vertex_normals, dtype=np.float32), "VEC3", target=_ARRAY_BUFFER)
            indices = b.add(np.asarray(mesh.faces, dtype=index_type).reshape(-1), "SCALAR",
                            target=_ELEMENT_ARRAY_BUFFER)
            meshes.append({"name": f"{prefix}{JOINT_NAMES[j]}",
                           "primitives": [{"attributes": {"POSITION": position, "NORMAL": normal},
                                           "indices": indices, "material": _side(JOINT_NAMES[j]), "mode": 4}]})
            node = {"name": f"{prefix}{JOINT_NAMES[j]}", "mesh": len(meshes) - 1,
                    "translation": [float(v) for v in translations[0, j]],
                    "rotation": [float(v) for v in rotations[0, j]]}
            if CHILDREN[j]:
                node["children"] = [base + c for c in CHILDREN[j]]
            nodes.append(node)
            for path, values, kind in (("rotation", rotations[:, j], "VEC4"),
                                       ("translation", translations[:, j], "VEC3")):
                output = b.add(values, kind)
                samplers.append({"input": times, "output": output, "interpolation": "LINEAR"})
                channels.append({"sampler": len(samplers) - 1, "target": {"node": base + j, "path": path}})
    gltf = {
        "asset": {"version": "2.0", "generator": "Motion Attention Studio (moattn)"},
        "scene": 0,
        "scenes": [{"name": name, "nodes": roots}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": [{"name": n, "pbrMetallicRoughness": {"baseColorFactor": list(c), "metallicFactor": 0.0,
                                                           "roughnessFactor": 0.8}} for n, c in _MATERIALS],
        "animations": [{"name": name, "channels": channels, "samplers": samplers}],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": len(b.blob)}],
        "extras": {"fps": float(fps), "frames": int(frames), "people": len(people), "units": "metres",
                   "up": "+Y", "skeleton": "HumanML3D 22 joints"},
    }
    return gltf, bytes(b.blob)


def pack_glb(gltf: dict, blob: bytes) -> bytes:
    """A GLB container: 12-byte header, the JSON chunk (padded with spaces) and the BIN chunk (padded with zeros)."""
    text = json.dumps(gltf, separators=(",", ":"), allow_nan=False).encode("utf-8")
    text += b" " * (-len(text) % 4)
    blob = bytes(blob) + b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    return b"".join([struct.pack("<4sII", GLB_MAGIC, GLB_VERSION, total),
                     struct.pack("<II", len(text), CHUNK_JSON), text,
                     struct.pack("<II", len(blob), CHUNK_BIN), blob])


def format_glb(joints: np.ndarray, *, fps: float = 20.0, name: str = "motion") -> bytes:
    """GLB bytes of joints (T, 22, 3) (metres, Y up), or (people, T, 22, 3) for a duet (see the module docstring)."""
    return pack_glb(*motion_gltf(joints, fps=fps, name=name))


def save_glb(joints: np.ndarray, path: str | os.PathLike[str], *, fps: float = 20.0) -> Path:
    """Write joints (T, 22, 3) as an animated ``.glb`` at ``fps``; returns the path."""
    path = Path(path)
    path.write_bytes(format_glb(joints, fps=fps, name=path.stem or "motion"))
    return path
