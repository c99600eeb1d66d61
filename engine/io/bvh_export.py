"""Write 22-joint motions as BVH files that Blender and other tools open.

The hierarchy uses Mixamo-style names (Hips, LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase, Spine,
Spine1, Spine2, Neck, Head, LeftShoulder (collar), LeftArm, LeftForeArm, LeftHand) plus a
zero-length joint in front of every child of the two branch joints, as CMU's LHipJoint:

    Hips -> LHipJoint -> LeftUpLeg ...      Spine2 -> LowerNeck -> Neck -> Head
         -> RHipJoint -> RightUpLeg ...            -> LCollarJoint -> LeftShoulder -> LeftArm ...
         -> LowerBack -> Spine -> ...              -> RCollarJoint -> RightShoulder -> ...

Our joints (HumanML3D data, decoded model output) do not keep the pelvis's three children or
spine3's three children rigid relative to each other, so one rotation at the pelvis cannot
place them all; the zero-length joints give every bone a rotation of its own and the file
reproduces the joints exactly (up to bone-length changes over time, which no BVH can hold).
Hips and Spine2 get the best-fit (Kabsch) rotation of their three children, so they carry the
body's overall orientation in tools that only look at them.

Rest pose: our T-pose (facing +Z, left = +X) with the motion's median bone lengths; rotations
are shortest-arc swings from the parent's frame (positions cannot reveal twist); channels are
Zrotation Yrotation Xrotation (degrees), unwrapped over time; units are metres.
"""
from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from engine.io.errors import MotionIOError
from engine.rotations import kabsch, matrix_to_euler, qbetween, quat_to_matrix
from engine.skeleton import JOINT_INDEX, NUM_JOINTS, Skeleton, measure_bone_lengths

EULER_ORDER = "ZYX"
_ROT_CHANNELS = " ".join(f"{axis}rotation" for axis in EULER_ORDER)

# (BVH name, our joint it sits on, BVH parent name, whether it is a zero-length branch joint)
EXPORT_JOINTS: tuple[tuple[str, str, str | None, bool], ...] = (
    ("Hips", "pelvis", None, False),
    ("LHipJoint", "pelvis", "Hips", True),
    ("LeftUpLeg", "left_hip", "LHipJoint", False),
    ("LeftLeg", "left_knee", "LeftUpLeg", False),
    ("LeftFoot", "left_ankle", "LeftLeg", False),
    ("LeftToeBase", "left_foot", "LeftFoot", False),
    ("RHipJoint", "pelvis", "Hips", True),
    ("RightUpLeg", "right_hip", "RHipJoint", False),
    ("RightLeg", "right_knee", "RightUpLeg", False),
    ("RightFoot", "right_ankle", "RightLeg", False),
    ("RightToeBase", "right_foot", "RightFoot", False),
    ("LowerBack", "pelvis", "Hips", True),
    ("Spine", "spine1", "LowerBack", False),
    ("Spine1", "spine2", "Spine", False),
    ("Spine2", "spine3", "Spine1", False),
    ("LowerNeck", "spine3", "Spine2", True),
    ("Neck", "neck", "LowerNeck", False),
    ("Head", "head", "Neck", False),
    ("LCollarJoint", "spine3", "Spine2", True),
    ("LeftShoulder", "left_collar", "LCollarJoint", False),
    ("LeftArm", "left_shoulder", "LeftShoulder", False),
    ("LeftForeArm", "left_elbow", "LeftArm", False),
    ("LeftHand", "left_wrist", "LeftForeArm", False),
    ("RCollarJoint", "spine3", "Spine2", True),
    ("RightShoulder", "right_collar", "RCollarJoint", False),
    ("RightArm", "right_shoulder", "RightShoulder", False),
    ("RightForeArm", "right_elbow", "RightArm", False),
    ("RightHand", "right_wrist", "RightForeArm", False),
)
END_SITE_FRACTION = 0.5  # a leaf's End Site continues its bone by half its length


def _shortest_arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) turning directions a onto b (..., 3); safe when they are opposite."""
    a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
    q = qbetween(a, b)
    opposite = (a * b).sum(-1) < -1 + 1e-9
    if np.any(opposite):
        # half turn about any axis perpendicular to a
        helper = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        axis = np.cross(a, helper)
        axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
        half_turn = np.concatenate([np.zeros(axis.shape[:-1] + (1,)), axis], axis=-1)
        q = np.where(opposite[..., None], half_turn, q)
    return quat_to_matrix(q)


def _check(joints: np.ndarray, fps: float) -> np.ndarray:
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise MotionIOError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if len(joints) == 0:
        raise MotionIOError("cannot write a BVH file with zero frames")
    if not np.isfinite(joints).all():
        raise MotionIOError("joints contain NaN or infinite values")
    if not fps > 0:
        raise MotionIOError(f"fps must be positive, got {fps}")
    return joints


def bvh_pose_channels(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rest offsets (E, 3), end-site offsets (E, 3) (zero where none) and motion (T, 3 + 3E).

    E = len(EXPORT_JOINTS); the motion holds the root position then each joint's Euler angles
    in :data:`EULER_ORDER`, degrees.
    """
    lengths = np.median(measure_bone_lengths(joints), axis=0)
    rest = Skeleton.with_lengths(lengths).offsets
    names = [e[0] for e in EXPORT_JOINTS]
    parent = [names.index(e[2]) if e[2] else -1 for e in EXPORT_JOINTS]
    at = [JOINT_INDEX[e[1]] for e in EXPORT_JOINTS]
    zero = [e[3] for e in EXPORT_JOINTS]
    count = len(EXPORT_JOINTS)
    offsets = np.array([np.zeros(3) if zero[e] or parent[e] < 0 else rest[at[e]] for e in range(count)])
    kids = [[c for c in range(count) if parent[c] == e] for e in range(count)]
    end_sites = np.zeros((count, 3))
    for e in range(count):
        if not kids[e]:
            end_sites[e] = END_SITE_FRACTION * rest[at[e]]

    frames = len(joints)
    eye = np.broadcast_to(np.eye(3), (frames, 3, 3))
    glob = np.empty((count, frames, 3, 3))
    local = np.empty((count, frames, 3, 3))
    for e in range(count):
        parent_glob = eye if parent[e] < 0 else glob[parent[e]]
        if not kids[e]:
            glob[e] = parent_glob
        elif len(kids[e]) == 1:
            c = kids[e][0]
            rest_dir = parent_glob @ offsets[c]
            glob[e] = _shortest_arc(rest_dir, joints[:, at[c]] - joints[:, at[e]]) @ parent_glob
        else:  # a branch: its children are zero-length joints, aim at their children
            targets = [kids[c][0] for c in kids[e]]
            src = np.broadcast_to(offsets[targets], (frames, len(targets), 3))
            dst = joints[:, [at[t] for t in targets]] - joints[:, at[e]][:, None]
            glob[e] = kabsch(src, dst)
        local[e] = np.swapaxes(parent_glob, -1, -2) @ glob[e]
    angles = matrix_to_euler(local, EULER_ORDER)  # (E, T, 3)
    angles = np.unwrap(angles, period=360.0, axis=1)
    motion = np.concatenate([joints[:, JOINT_INDEX["pelvis"]], angles.transpose(1, 0, 2).reshape(frames, -1)], axis=1)
    return offsets, end_sites, motion


def format_bvh(joints: np.ndarray, *, fps: float = 20.0) -> str:
    """BVH text for joint positions (T, 22, 3) in metres, Y up (see the module docstring)."""
    joints = _check(joints, fps)
    offsets, end_sites, motion = bvh_pose_channels(joints)
    names = [e[0] for e in EXPORT_JOINTS]
    parent = [names.index(e[2]) if e[2] else -1 for e in EXPORT_JOINTS]
    out = ["HIERARCHY"]

    def write(e: int, depth: int) -> None:
        pad = "\t" * depth
        out.append(f"{pad}{'ROOT' if parent[e] < 0 else 'JOINT'} {names[e]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET {offsets[e][0]:.6f} {offsets[e][1]:.6f} {offsets[e][2]:.6f}")
        if parent[e] < 0:
            out.append(f"{pad}\tCHANNELS 6 Xposition Yposition Zposition {_ROT_CHANNELS}")
        else:
            out.append(f"{pad}\tCHANNELS 3 {_ROT_CHANNELS}")
        children = [c for c in range(len(names)) if parent[c] == e]
        for c in children:
            write(c, depth + 1)
        if not children:
            site = end_sites[e]
            out.append(f"{pad}\tEnd Site")
            out.append(f"{pad}\t{{")
            out.append(f"{pad}\t\tOFFSET {site[0]:.6f} {site[1]:.6f} {site[2]:.6f}")
            out.append(f"{pad}\t}}")
        out.append(f"{pad}}}")

    write(0, 0)
    out.append("MOTION")
    out.append(f"Frames: {len(motion)}")
    out.append(f"Frame Time: {1.0 / fps:.8f}")
    buffer = io.StringIO()
    np.savetxt(buffer, motion + 0.0, fmt="%.6f")  # + 0.0 turns -0.0 into 0.0
    return "\n".join(out) + "\n" + buffer.getvalue()


def save_bvh(joints: np.ndarray, path: str | os.PathLike[str], *, fps: float = 20.0) -> Path:
    """Write joint positions (T, 22, 3) (metres, Y up) as a BVH file at ``fps``; returns the path."""
    path = Path(path)
    text = format_bvh(joints, fps=fps)
    path.write_text(text, encoding="utf-8")
    return path
