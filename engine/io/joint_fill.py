"""Assemble the 22 HumanML3D joints from a BVH skeleton's world positions.

Joints matched by name (:mod:`engine.io.joint_names`) are copied; the others are derived,
per frame, from the ones that exist (positions must already be Y-up):

- pelvis: midpoint of the hips;
- neck: halfway between the shoulders' midpoint and the head;
- spine1/2/3: SMPL names if present; else, when exactly three non-zero-length joints lie on
  the hierarchy path between pelvis and neck (Mixamo's Spine, Spine1, Spine2), those; else
  points at our skeleton's arc-length fractions along the polyline pelvis -> path joints ->
  neck (one "Spine" joint as in pymo_walk.bvh, or CMU's Chest, Chest2);
- collars: 64 % of the way from each shoulder to the shoulders' midpoint (where our rest pose
  has them); also used when the file's left and right collars coincide (one chest point);
- toes (feet): the ankle plus our rest ankle->toe offset, turned to the body's facing and
  scaled by the leg length.
"""
from __future__ import annotations

import numpy as np

from engine.io.bvh_parse import BVHData
from engine.io.joint_names import zero_offset_joints
from engine.representation import facing_direction
from engine.skeleton import BONE_LENGTHS, JOINT_INDEX, JOINT_NAMES, NUM_JOINTS, Skeleton

# fractions of the pelvis -> neck arc at which our spine1, spine2, spine3 sit
_SPINE_ARC = np.cumsum([BONE_LENGTHS[3], BONE_LENGTHS[6], BONE_LENGTHS[9], BONE_LENGTHS[12]])
SPINE_FRACTIONS: tuple[float, float, float] = tuple(float(x) for x in _SPINE_ARC[:3] / _SPINE_ARC[3])
COLLAR_FRACTION = 0.64  # collar = shoulder + f * (shoulders' midpoint - shoulder)
_LEG = BONE_LENGTHS[4] + BONE_LENGTHS[7]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _path_between(data: BVHData, top: int, bottom: int | None) -> list[int] | None:
    """BVH joints strictly between ancestor ``bottom`` (None: above the root) and ``top``, root side first."""
    path = []
    j = data.parents[top]
    while j >= 0 and j != bottom:
        path.append(j)
        j = data.parents[j]
    if bottom is not None and j != bottom:
        return None
    return path[::-1]


def _polyline_points(points: np.ndarray, fractions: tuple[float, ...]) -> np.ndarray:
    """Points at arc-length fractions along per-frame polylines: (F, K, 3) -> (F, len(fractions), 3)."""
    seg = np.linalg.norm(np.diff(points, axis=1), axis=-1)  # (F, K-1)
    cum = np.concatenate([np.zeros((len(points), 1)), np.cumsum(seg, axis=1)], axis=1)
    total = np.maximum(cum[:, -1:], 1e-12)
    out = np.empty((len(points), len(fractions), 3))
    for i, frac in enumerate(fractions):
        target = frac * total[:, 0]
        k = np.clip((cum[:, 1:] < target[:, None]).sum(axis=1), 0, points.shape[1] - 2)
        rows = np.arange(len(points))
        length = np.maximum(seg[rows, k], 1e-12)
        w = np.clip((target - cum[rows, k]) / length, 0.0, 1.0)[:, None]
        out[:, i] = points[rows, k] * (1 - w) + points[rows, k + 1] * w
    return out


def assemble_joints(
    data: BVHData, positions: np.ndarray, found: dict[str, int]
) -> tuple[np.ndarray, dict[str, str]]:
    """(F, J, 3) BVH world positions (Y up) -> (F, 22, 3) joints and how each joint was obtained.

    ``found`` maps our joint names to BVH joint indices (must contain the essential joints).
    The description per joint is the BVH joint name, or "derived: ..." for derived joints.
    """
    frames = positions.shape[0]
    joints = np.full((frames, NUM_JOINTS, 3), np.nan)
    how: dict[str, str] = {}
    for name, j in found.items():
        joints[:, JOINT_INDEX[name]] = positions[:, j]
        how[name] = data.names[j]

    def have(name: str) -> bool:
        return name in how

    def put(name: str, value: np.ndarray, description: str, *, derived: bool = True) -> None:
        joints[:, JOINT_INDEX[name]] = value
        how[name] = ("derived: " if derived else "") + description

    idx = JOINT_INDEX
    if not have("pelvis"):
        put("pelvis", 0.5 * (joints[:, idx["left_hip"]] + joints[:, idx["right_hip"]]), "midpoint of the hips")
    shoulders_mid = 0.5 * (joints[:, idx["left_shoulder"]] + joints[:, idx["right_shoulder"]])
    if not have("neck"):
        put("neck", 0.5 * (shoulders_mid + joints[:, idx["head"]]), "halfway between the shoulders' midpoint and the head")

    # collars: drop a pair that coincides (one chest point for both sides)
    if have("left_collar") and have("right_collar"):
        width = np.linalg.norm(joints[:, idx["left_shoulder"]] - joints[:, idx["right_shoulder"]], axis=-1)
        gap = np.linalg.norm(joints[:, idx["left_collar"]] - joints[:, idx["right_collar"]], axis=-1)
        if np.median(gap) < 0.1 * np.median(width):
            how.pop("left_collar")
            how.pop("right_collar")
    for side in ("left", "right"):
        if not have(f"{side}_collar"):
            sh = joints[:, idx[f"{side}_shoulder"]]
            put(f"{side}_collar", sh + COLLAR_FRACTION * (shoulders_mid - sh),
                f"{COLLAR_FRACTION:.0%} of the way from the {side} shoulder to the shoulders' midpoint")

    if not all(have(s) for s in ("spine1", "spine2", "spine3")):
        _fill_spine(data, positions, found, joints, put)

    # toes from the ankles, the facing direction and the leg length
    missing_toes = [s for s in ("left", "right") if not have(f"{s}_foot")]
    if missing_toes:
        facing = facing_direction(joints)  # (F, 3), horizontal
        left = np.cross(np.array([0.0, 1.0, 0.0]), facing)  # body's left (+X when facing +Z)
        rest = Skeleton.default().offsets
        for side in missing_toes:
            leg = np.median(
                np.linalg.norm(joints[:, idx[f"{side}_knee"]] - joints[:, idx[f"{side}_hip"]], axis=-1)
                + np.linalg.norm(joints[:, idx[f"{side}_ankle"]] - joints[:, idx[f"{side}_knee"]], axis=-1)
            )
            off = rest[idx[f"{side}_foot"]] * (leg / _LEG)
            toe = off[0] * left + off[1] * np.array([0.0, 1.0, 0.0]) + off[2] * facing
            put(f"{side}_foot", joints[:, idx[f"{side}_ankle"]] + toe, f"{side} ankle plus a rest foot, turned to the facing")

    assert not np.isnan(joints).any(), [n for n in JOINT_NAMES if n not in how]
    return joints, {name: how[name] for name in JOINT_NAMES}


def _fill_spine(data: BVHData, positions: np.ndarray, found: dict[str, int], joints: np.ndarray, put) -> None:
    idx = JOINT_INDEX
    zero = zero_offset_joints(data)
    top = found.get("neck", found["head"])
    path = _path_between(data, top, found.get("pelvis"))
    if path is None:  # neck/head not below the pelvis in the hierarchy: use a straight line
        path = []
    path = [j for j in path if not zero[j] and not data.end_site[j]]
    if "neck" not in found:
        # the derived neck sits below the head; drop path joints above it
        neck_y = joints[:, idx["neck"], 1]
        path = [j for j in path if np.median(positions[:, j, 1] - neck_y) < 0]
    names = ("spine1", "spine2", "spine3")
    if len(path) == 3:
        for name, j in zip(names, path):
            put(name, positions[:, j], f"{data.names[j]} (torso joint {names.index(name) + 1} of 3)", derived=False)
        return
    points = np.concatenate(
        [joints[:, idx["pelvis"]][:, None], positions[:, path], joints[:, idx["neck"]][:, None]], axis=1
    )
    along = " -> ".join(["pelvis", *(data.names[j] for j in path), "neck"])
    spine = _polyline_points(points, SPINE_FRACTIONS)
    for i, name in enumerate(names):
        put(name, spine[:, i], f"{SPINE_FRACTIONS[i]:.2f} of the way along {along}")
