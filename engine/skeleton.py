"""The 22-joint HumanML3D ("t2m") skeleton: names, parents, chains, rest offsets, FK and IK.

Conventions: Y up, metres, 20 fps, the body faces +Z in the rest pose and its left is +X.
``local_rot[j]`` is joint j's rotation relative to its parent's frame (BVH style): the world
frame of joint j is ``G[j] = G[parent] @ local_rot[j]`` and a child c sits at
``p[c] = p[j] + G[j] @ offset[c]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from engine.rotations import kabsch, qbetween, quat_to_matrix

JOINT_NAMES: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2",
    "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot", "neck", "left_collar",
    "right_collar", "head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist",
)
NUM_JOINTS = len(JOINT_NAMES)
JOINT_INDEX: dict[str, int] = {name: i for i, name in enumerate(JOINT_NAMES)}
PARENTS: tuple[int, ...] = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)
CHAINS: tuple[tuple[int, ...], ...] = (
    (0, 2, 5, 8, 11),
    (0, 1, 4, 7, 10),
    (0, 3, 6, 9, 12, 15),
    (9, 14, 17, 19, 21),
    (9, 13, 16, 18, 20),
)
CHILDREN: tuple[tuple[int, ...], ...] = tuple(
    tuple(c for c, p in enumerate(PARENTS) if p == j) for j in range(NUM_JOINTS)
)
# right hip, left hip, right shoulder, left shoulder: the facing direction is up x (r - l)
FACE_JOINTS: tuple[int, int, int, int] = (2, 1, 17, 16)
FOOT_JOINTS = {"left": (7, 10), "right": (8, 11)}  # (ankle, toe) per side
# left <-> right joint swap, for mirroring
MIRROR: tuple[int, ...] = (0, 2, 1, 3, 5, 4, 6, 8, 7, 9, 11, 10, 12, 14, 13, 15, 17, 16, 19, 18, 21, 20)


def mirror_joints(joints: np.ndarray) -> np.ndarray:
    """Joints (..., 22, 3) mirrored left <-> right: reflected in the YZ plane (x -> -x) with each left joint and its
    right partner swapped, so the result is again a body (its left hand where the right one was, reflected).
    Reflect several people in one frame together and the scene stays consistent."""
    joints = np.asarray(joints)
    if joints.shape[-2:] != (NUM_JOINTS, 3):
        raise ValueError(f"expected joints (..., {NUM_JOINTS}, 3), got {joints.shape}")
    out = joints[..., list(MIRROR), :].copy()
    out[..., 0] *= -1
    return out

# Bone lengths (metres) of HumanML3D's target skeleton, measured on frame 0 of the real sample
# humanml3d_012314_joints.npy and averaged over left/right (tests re-measure them from the file).
BONE_LENGTHS: dict[int, float] = {
    1: 0.10648, 2: 0.10648, 3: 0.13157, 4: 0.39190, 5: 0.39190, 6: 0.14319, 7: 0.42904,
    8: 0.42904, 9: 0.05736, 10: 0.14640, 11: 0.14640, 12: 0.21936, 13: 0.14043, 14: 0.14043,
    15: 0.10304, 16: 0.12730, 17: 0.12730, 18: 0.25996, 19: 0.25996, 20: 0.26794, 21: 0.26794,
}

# Rest-pose bone directions (T-pose, facing +Z, left = +X); scaled by BONE_LENGTHS.
_REST_DIRECTIONS: dict[int, tuple[float, float, float]] = {
    1: (0.75, -0.65, 0.0), 2: (-0.75, -0.65, 0.0), 3: (0.0, 1.0, -0.15),
    4: (0.0, -1.0, 0.0), 5: (0.0, -1.0, 0.0), 6: (0.0, 1.0, 0.1),
    7: (0.0, -1.0, -0.04), 8: (0.0, -1.0, -0.04), 9: (0.0, 1.0, 0.2),
    10: (0.0, -0.4, 1.0), 11: (0.0, -0.4, 1.0), 12: (0.0, 1.0, 0.15),
    13: (0.6, 1.0, 0.1), 14: (-0.6, 1.0, 0.1), 15: (0.0, 1.0, 0.45),
    16: (1.0, -0.05, 0.0), 17: (-1.0, -0.05, 0.0), 18: (1.0, 0.0, 0.0),
    19: (-1.0, 0.0, 0.0), 20: (1.0, 0.0, 0.0), 21: (-1.0, 0.0, 0.0),
}


def measure_bone_lengths(joints: np.ndarray) -> np.ndarray:
    """Bone length per joint (length of the bone ending at it; 0 for the root): (..., 22, 3) -> (..., 22)."""
    parents = np.array(PARENTS[1:])
    lengths = np.linalg.norm(joints[..., 1:, :] - joints[..., parents, :], axis=-1)
    return np.concatenate([np.zeros(lengths.shape[:-1] + (1,)), lengths], axis=-1)


def _default_offsets() -> np.ndarray:
    offsets = np.zeros((NUM_JOINTS, 3))
    for j, direction in _REST_DIRECTIONS.items():
        d = np.asarray(direction, dtype=np.float64)
        offsets[j] = d / np.linalg.norm(d) * BONE_LENGTHS[j]
    return offsets


@dataclass(frozen=True)
class Skeleton:
    """A 22-joint skeleton with rest offsets (22, 3); offsets[j] is joint j relative to its parent."""

    offsets: np.ndarray = field(default_factory=_default_offsets)

    @classmethod
    def default(cls) -> "Skeleton":
        return cls()

    @classmethod
    def with_lengths(cls, lengths: np.ndarray) -> "Skeleton":
        """The default rest directions with other bone lengths (22,), e.g. a retargeted body."""
        base = _default_offsets()
        norms = np.linalg.norm(base, axis=-1, keepdims=True)
        unit = np.divide(base, norms, out=np.zeros_like(base), where=norms > 0)
        return cls(offsets=unit * np.asarray(lengths, dtype=np.float64)[:, None])

    @property
    def bone_lengths(self) -> np.ndarray:
        return np.linalg.norm(self.offsets, axis=-1)

    def rest_pose(self) -> np.ndarray:
        """Joint positions (22, 3) of the rest pose with the pelvis at the origin."""
        joints = np.zeros((NUM_JOINTS, 3))
        for j in range(1, NUM_JOINTS):
            joints[j] = joints[PARENTS[j]] + self.offsets[j]
        return joints

    def floor_offset(self) -> float:
        """Height of the pelvis above the floor in the rest pose."""
        return float(-self.rest_pose()[:, 1].min())

    # ------------------------------------------------------------------ kinematics
    def forward(self, local_rot: np.ndarray, root_pos: np.ndarray) -> np.ndarray:
        """Forward kinematics.

        local_rot: (..., 22, 3, 3) rotations relative to the parent frame (root: world).
        root_pos:  (..., 3) pelvis positions.
        returns joints (..., 22, 3).
        """
        local_rot = np.asarray(local_rot, dtype=np.float64)
        glob = np.empty_like(local_rot)
        joints = np.empty(local_rot.shape[:-2] + (3,))
        glob[..., 0, :, :] = local_rot[..., 0, :, :]
        joints[..., 0, :] = root_pos
        for j in range(1, NUM_JOINTS):
            p = PARENTS[j]
            glob[..., j, :, :] = glob[..., p, :, :] @ local_rot[..., j, :, :]
            joints[..., j, :] = joints[..., p, :] + glob[..., p, :, :] @ self.offsets[j]
        return joints

    def global_rotations(self, local_rot: np.ndarray) -> np.ndarray:
        glob = np.empty_like(np.asarray(local_rot, dtype=np.float64))
        glob[..., 0, :, :] = local_rot[..., 0, :, :]
        for j in range(1, NUM_JOINTS):
            glob[..., j, :, :] = glob[..., PARENTS[j], :, :] @ local_rot[..., j, :, :]
        return glob

    def inverse(self, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inverse kinematics from positions (..., 22, 3) to (local_rot (..., 22, 3, 3), root_pos (..., 3)).

        A joint with several children (pelvis, spine3) gets the best-fit (Kabsch) rotation of its
        rest child offsets onto the observed child bones; a joint with one child gets the
        shortest-arc swing from its parent's frame (no twist, which positions cannot reveal).
        Leaves keep the identity. Exact for poses made by :meth:`forward` with this skeleton
        up to twist; bone lengths of the input are not changed by the rotations.
        """
        joints = np.asarray(joints, dtype=np.float64)
        lead = joints.shape[:-2]
        eye = np.broadcast_to(np.eye(3), lead + (3, 3))
        glob = np.empty(lead + (NUM_JOINTS, 3, 3))
        local = np.empty(lead + (NUM_JOINTS, 3, 3))
        for j in range(NUM_JOINTS):
            parent_glob = eye if PARENTS[j] < 0 else glob[..., PARENTS[j], :, :]
            kids = CHILDREN[j]
            if not kids:
                glob[..., j, :, :] = parent_glob
            elif len(kids) == 1:
                c = kids[0]
                rest_dir = parent_glob @ self.offsets[c]
                bone = joints[..., c, :] - joints[..., j, :]
                swing = quat_to_matrix(qbetween(rest_dir, bone))
                glob[..., j, :, :] = swing @ parent_glob
            else:
                src = np.broadcast_to(self.offsets[list(kids)], lead + (len(kids), 3))
                dst = joints[..., list(kids), :] - joints[..., j : j + 1, :]
                glob[..., j, :, :] = kabsch(src, dst)
            local[..., j, :, :] = np.swapaxes(parent_glob, -1, -2) @ glob[..., j, :, :]
        return local, joints[..., 0, :].copy()

