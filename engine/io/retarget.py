"""Post-processing of imported 22-joint motions: up axis, units, frame rate, bone lengths.

All functions take and return joint positions (T, 22, 3) as float64 numpy arrays.

- :func:`detect_up_axis` / :func:`up_axis_rotation`: the axis from the feet to the head.
- :func:`detect_unit`: metres, centimetres, millimetres, inches, feet or CMU's ASF unit,
  from the body's head-to-ankle bone chain (pose independent), which is about 1.6 m in
  metres for an adult (our skeleton: 1.58 m).
- :func:`resample`: linear interpolation of positions to a new frame rate.
- :func:`retarget_bone_lengths`: every bone keeps its direction and gets our length, the
  root trajectory is scaled by the ratio of leg lengths (as HumanML3D's own retargeting).
- :func:`contact_floor` / :func:`canonical_placement`: the floor under the standing feet, the
  root at the XZ origin, facing +Z.
"""
from __future__ import annotations

import math

import numpy as np

from engine.representation import canonicalize
from engine.rotations import axis_rotation
from engine.skeleton import FOOT_JOINTS, JOINT_INDEX, NUM_JOINTS, PARENTS, Skeleton, measure_bone_lengths

# unit name -> metres per unit
UNITS: dict[str, float] = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "in": 0.0254,
    "ft": 0.3048,
    "cmu": 0.0254 / 0.45,  # CMU ASF length unit ("inches" times 1/0.45), kept by some BVH conversions
}
UNIT_WORDS = {"m": "metres", "cm": "centimetres", "mm": "millimetres", "in": "inches", "ft": "feet",
              "cmu": "CMU ASF units"}

_STATURE_CHAIN = (
    ("left_ankle", "left_knee"), ("left_knee", "left_hip"), ("left_hip", "pelvis"),
    ("pelvis", "spine1"), ("spine1", "spine2"), ("spine2", "spine3"), ("spine3", "neck"), ("neck", "head"),
)


def _pairs(names: tuple[tuple[str, str], ...]) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([JOINT_INDEX[a] for a, _ in names]), np.array([JOINT_INDEX[b] for _, b in names]))


def stature_chain(joints: np.ndarray) -> float:
    """Median over frames of the bone-chain length ankle -> knee -> hip -> pelvis -> spine -> neck -> head.

    Averaged over both legs; independent of the pose (unlike standing height).
    """
    total = np.zeros(len(joints))
    for side in ("left", "right"):
        chain = tuple((a.replace("left", side), b.replace("left", side)) for a, b in _STATURE_CHAIN)
        a, b = _pairs(chain)
        total += 0.5 * np.linalg.norm(joints[:, a] - joints[:, b], axis=-1).sum(axis=-1)
    return float(np.median(total))


REFERENCE_STATURE_CHAIN = stature_chain(Skeleton.default().rest_pose()[None])


def detect_unit(chain_length: float) -> tuple[str, float]:
    """The unit whose scale makes ``chain_length`` closest (in ratio) to an adult's 1.58 m."""
    if not (chain_length > 0 and math.isfinite(chain_length)):
        raise ValueError(f"cannot work out the unit: the body's bone chain has length {chain_length}")
    best = min(UNITS, key=lambda u: abs(math.log(chain_length * UNITS[u] / REFERENCE_STATURE_CHAIN)))
    return best, UNITS[best]


_AXES = {
    "+Y": np.eye(3),
    "-Y": axis_rotation("x", np.pi),
    "+Z": axis_rotation("x", -np.pi / 2),
    "-Z": axis_rotation("x", np.pi / 2),
    "+X": axis_rotation("z", np.pi / 2),
    "-X": axis_rotation("z", -np.pi / 2),
}


def detect_up_axis(joints: np.ndarray) -> str:
    """"+Y", "-Y", "+Z", ... : the principal axis closest to the mean ankles -> head direction."""
    ankles = 0.5 * (joints[:, JOINT_INDEX["left_ankle"]] + joints[:, JOINT_INDEX["right_ankle"]])
    up = (joints[:, JOINT_INDEX["head"]] - ankles).mean(axis=0)
    axis = int(np.argmax(np.abs(up)))
    return ("+" if up[axis] >= 0 else "-") + "XYZ"[axis]


def up_axis_rotation(axis: str) -> np.ndarray:
    """Rotation (3, 3) taking the given up axis onto +Y."""
    return _AXES[axis].copy()


def snap_fps(fps: float) -> float:
    """1/0.008333 -> 120: frame rates within 0.05 % of a whole number are taken as that number."""
    nearest = round(fps)
    return float(nearest) if nearest > 0 and abs(fps - nearest) <= 5e-4 * nearest else float(fps)


def resample(joints: np.ndarray, source_fps: float, fps: float) -> np.ndarray:
    """Linear interpolation of positions (T, ...) from ``source_fps`` to ``fps``, same start and span."""
    if source_fps <= 0 or fps <= 0:
        raise ValueError(f"frame rates must be positive, got {source_fps} and {fps}")
    count = len(joints)
    if count < 2 or abs(source_fps - fps) < 1e-9:
        return np.array(joints, dtype=np.float64)
    duration = (count - 1) / source_fps
    out_count = int(math.floor(duration * fps + 1e-6)) + 1
    where = np.arange(out_count) * (source_fps / fps)
    lo = np.clip(np.floor(where).astype(int), 0, count - 1)
    hi = np.minimum(lo + 1, count - 1)
    w = (where - lo).reshape((-1,) + (1,) * (joints.ndim - 1))
    return joints[lo] * (1.0 - w) + joints[hi] * w


def leg_length(joints: np.ndarray) -> float:
    """Median over frames of hip -> knee -> ankle length, averaged over both legs."""
    total = np.zeros(len(joints))
    for side in ("left", "right"):
        hip, knee, ankle = (JOINT_INDEX[f"{side}_{n}"] for n in ("hip", "knee", "ankle"))
        total += 0.5 * (
            np.linalg.norm(joints[:, knee] - joints[:, hip], axis=-1)
            + np.linalg.norm(joints[:, ankle] - joints[:, knee], axis=-1)
        )
    return float(np.median(total))


def retarget_bone_lengths(joints: np.ndarray, skeleton: Skeleton | None = None) -> np.ndarray:
    """Give the motion ``skeleton``'s bone lengths (default: ours), keeping every bone's direction.

    The root trajectory is scaled by the ratio of leg lengths so steps stay in proportion.
    A zero-length source bone takes the skeleton's rest direction.
    """
    skeleton = skeleton or Skeleton.default()
    joints = np.asarray(joints, dtype=np.float64)
    lengths = skeleton.bone_lengths
    ratio = leg_length(skeleton.rest_pose()[None]) / max(leg_length(joints), 1e-12)
    out = np.empty_like(joints)
    out[:, 0] = joints[:, 0] * ratio
    rest_dirs = skeleton.offsets / np.maximum(lengths[:, None], 1e-12)
    for j in range(1, NUM_JOINTS):
        bone = joints[:, j] - joints[:, PARENTS[j]]
        norm = np.linalg.norm(bone, axis=-1, keepdims=True)
        direction = np.where(norm > 1e-9, bone / np.maximum(norm, 1e-12), rest_dirs[j])
        out[:, j] = out[:, PARENTS[j]] + lengths[j] * direction
    return out


def standing_height(joints: np.ndarray) -> float:
    """Head-joint height (m) of the clip's body standing straight: our rest pose with its median bone lengths.

    Independent of what the person does; the top of the head is some 10-20 cm higher.
    """
    lengths = np.median(measure_bone_lengths(np.asarray(joints, dtype=np.float64)), axis=0)
    rest = Skeleton.with_lengths(lengths).rest_pose()
    return float(rest[JOINT_INDEX["head"], 1] - rest[:, 1].min())


_FEET = list(FOOT_JOINTS["left"]) + list(FOOT_JOINTS["right"])
STANCE_CLEARANCE = 0.01  # HumanML3D's stance feet sit ~1 cm above its floor (the lowest joint)


def contact_floor(
    joints: np.ndarray, *, fps: float, clearance: float = STANCE_CLEARANCE, max_speed: float = 0.3
) -> float:
    """Floor height under the standing feet.

    Per frame, the lowest foot joint (ankles, toes) is in contact when it moves slower than
    ``max_speed`` m/s horizontally; the floor is the median height of those contact points
    minus ``clearance``, but never below the lowest foot point of the clip (so a clip whose
    stance feet are the lowest points gets HumanML3D's floor, the lowest point). Clips with
    almost no contact frames (under 5 %) use the lowest foot point.
    """
    feet = np.asarray(joints, dtype=np.float64)[:, _FEET]
    heights = feet[..., 1]
    lowest = heights.argmin(axis=1)
    low = heights.min(axis=1)
    floor_min = float(low.min())
    if len(feet) < 2:
        return floor_min
    step = np.linalg.norm(np.diff(feet[..., [0, 2]], axis=0), axis=-1) * fps  # (T-1, 4) m/s
    step = np.concatenate([step, step[-1:]], axis=0)
    speed = step[np.arange(len(feet)), lowest]
    contact = speed < max_speed
    if contact.sum() < max(3, 0.05 * len(feet)):
        return floor_min
    return max(float(np.median(low[contact])) - clearance, floor_min)


def canonical_placement(joints: np.ndarray, *, fps: float) -> np.ndarray:
    """Floor (:func:`contact_floor`) at y=0, root starting at the XZ origin, first pose facing +Z."""
    joints = np.asarray(joints, dtype=np.float64)
    floor = contact_floor(joints, fps=fps)
    if len(joints) < 2:  # canonicalize needs two frames
        out = canonicalize(np.concatenate([joints, joints]))[:1]
    else:
        out = canonicalize(joints)
    out[..., 1] += joints[..., 1].min() - floor  # canonicalize floors at the lowest joint
    return out
