"""Pose channels and the solver that turns them into joint positions and local rotations.

A motion is synthesised as a set of per-frame *channels* (root path, heading, trunk angles,
world-space foot targets, hand targets, contact flags). :func:`solve` runs the trunk forward
kinematics, analytic two-bone IK for both legs and both arms, and returns joint positions
(T, 22, 3) that are exactly what :meth:`engine.skeleton.Skeleton.forward` gives for the local
rotations returned by :func:`local_rotations` (bone lengths constant by construction).

Angle convention (radians) for every trunk joint: ``(pitch, yaw, roll)`` about the parent
frame's (X, Y, Z) axes, composed ``R = Ry(yaw) @ Rx(pitch) @ Rz(roll)``. With the body facing
+Z and its left at +X: positive pitch bends forward, positive yaw turns toward the left,
positive roll tilts toward the right (the top moves to -X).

Hands: ``hand`` is the wrist target relative to the shoulder joint, in a frame that blends
the heading frame (yaw only; ``hand_frame`` = 0, arms hang with gravity when the trunk leans)
and the chest frame (spine3; ``hand_frame`` = 1, gestures move with the trunk).
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from engine.rotations import dot
from engine.skeleton import PARENTS, Skeleton

SKELETON = Skeleton.default()
OFFSETS = SKELETON.offsets
LEN = SKELETON.bone_lengths
THIGH = float(LEN[4])
SHIN = float(LEN[7])
LEG = THIGH + SHIN
UPPER_ARM = float(LEN[18])
FOREARM = float(LEN[20])
ARM = UPPER_ARM + FOREARM
TOE_OFFSET = OFFSETS[10].copy()  # ankle -> toe in the flat foot frame
ANKLE_HEIGHT = float(-TOE_OFFSET[1])  # ankle height when the foot is flat and the toe on the floor
TOE_ANGLE = float(np.arctan2(-TOE_OFFSET[1], TOE_OFFSET[2]))  # toe below the ankle (rad)
TOE_LENGTH = float(np.linalg.norm(TOE_OFFSET))
HIP_DROP = float(-OFFSETS[1][1])  # hips sit this far below the pelvis joint
HIP_HALF_WIDTH = float(OFFSETS[1][0])
SHOULDER_HALF_WIDTH = float(OFFSETS[13][0] + OFFSETS[16][0])
LEG_REACH = 0.985 * LEG  # longest hip-ankle distance used for planted feet
FLAT_MAX_PELVIS = ANKLE_HEIGHT + HIP_DROP + 0.975 * LEG  # highest pelvis over a flat foot
STAND_PELVIS = FLAT_MAX_PELVIS - 0.012  # relaxed standing height (knees nearly straight)
SIDES = (0, 1)  # 0 = left, 1 = right
SIDE_SIGN = np.array([1.0, -1.0])  # +X is the body's left


# --------------------------------------------------------------------------- rotations
def euler(angles: np.ndarray) -> np.ndarray:
    """(..., 3) (pitch, yaw, roll) -> (..., 3, 3) = Ry(yaw) @ Rx(pitch) @ Rz(roll)."""
    x, y, z = angles[..., 0], angles[..., 1], angles[..., 2]
    cx, sx, cy, sy, cz, sz = np.cos(x), np.sin(x), np.cos(y), np.sin(y), np.cos(z), np.sin(z)
    sysx, cysx = sy * sx, cy * sx
    out = np.empty(angles.shape[:-1] + (3, 3))
    out[..., 0, 0] = cy * cz + sysx * sz
    out[..., 0, 1] = -cy * sz + sysx * cz
    out[..., 0, 2] = sy * cx
    out[..., 1, 0] = cx * sz
    out[..., 1, 1] = cx * cz
    out[..., 1, 2] = -sx
    out[..., 2, 0] = -sy * cz + cysx * sz
    out[..., 2, 1] = sy * sz + cysx * cz
    out[..., 2, 2] = cy * cx
    return out


def yaw_rotation(angle: np.ndarray) -> np.ndarray:
    """(...,) -> (..., 3, 3) rotation about +Y (positive turns +Z toward +X, the body's left)."""
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(np.shape(angle) + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 2] = s
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = -s
    out[..., 2, 2] = c
    return out


def vector3(x: np.ndarray | float, y: np.ndarray | float, z: np.ndarray | float) -> np.ndarray:
    """Vectors (..., 3) from broadcastable components (cheaper than np.stack on small arrays)."""
    out = np.empty(np.broadcast(x, y, z).shape + (3,))
    out[..., 0] = x
    out[..., 1] = y
    out[..., 2] = z
    return out


def floor_vector(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Vectors on the floor plane from their x and z parts: (...,) -> (..., 3)."""
    return vector3(x, 0.0, z)


def forward_vector(heading: np.ndarray) -> np.ndarray:
    """Facing direction on the floor for a heading angle: (...,) -> (..., 3)."""
    h = np.asarray(heading, dtype=np.float64)
    return floor_vector(np.sin(h), np.cos(h))


def left_vector(heading: np.ndarray) -> np.ndarray:
    """The body's left on the floor for a heading angle: (...,) -> (..., 3)."""
    h = np.asarray(heading, dtype=np.float64)
    return floor_vector(np.cos(h), -np.sin(h))


def foot_rotation(yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """World rotation of an ankle: yaw about +Y then pitch (positive = toe down, heel up)."""
    return yaw_rotation(yaw) @ euler(np.stack([pitch, np.zeros_like(pitch), np.zeros_like(pitch)], -1))


def toe_from_ankle(ankle: np.ndarray, yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Toe position for an ankle position and foot orientation (closed form)."""
    ang = TOE_ANGLE + pitch
    horiz = TOE_LENGTH * np.cos(ang)
    out = np.empty(np.shape(ankle))
    out[..., 0] = ankle[..., 0] + horiz * np.sin(yaw)
    out[..., 1] = ankle[..., 1] - TOE_LENGTH * np.sin(ang)
    out[..., 2] = ankle[..., 2] + horiz * np.cos(yaw)
    return out


def ankle_from_toe(toe: np.ndarray, yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Ankle position that puts the toe at ``toe`` for a foot orientation (pivot on the toe)."""
    ang = TOE_ANGLE + pitch
    horiz = TOE_LENGTH * np.cos(ang)
    out = np.empty(np.shape(toe))
    out[..., 0] = toe[..., 0] - horiz * np.sin(yaw)
    out[..., 1] = toe[..., 1] + TOE_LENGTH * np.sin(ang)
    out[..., 2] = toe[..., 2] - horiz * np.cos(yaw)
    return out


def pitch_for_ankle_height(height: np.ndarray) -> np.ndarray:
    """Foot pitch that lifts the ankle to ``height`` with the toe on the floor (heel rise)."""
    ratio = np.minimum(np.maximum(np.asarray(height) / TOE_LENGTH, np.sin(TOE_ANGLE)), 0.995)
    return np.arcsin(ratio) - TOE_ANGLE


# --------------------------------------------------------------------------- channels
@dataclass
class Channels:
    """Per-frame control signals of one person; all arrays share the leading length T."""

    root: np.ndarray  # (T, 3) pelvis position, world
    heading: np.ndarray  # (T,) yaw of the facing direction
    pelvis: np.ndarray  # (T, 3) pelvis angles relative to the heading
    spine: np.ndarray  # (T, 3, 3) spine1, spine2, spine3 angles
    neck: np.ndarray  # (T, 3) neck angles (moves the head)
    collar: np.ndarray  # (T, 2, 3) left, right collar angles
    ankle: np.ndarray  # (T, 2, 3) ankle targets, world
    foot_yaw: np.ndarray  # (T, 2) world yaw of each foot
    foot_pitch: np.ndarray  # (T, 2) foot pitch (positive = heel up)
    knee_out: np.ndarray  # (T, 2) outward splay of the knee pole (rad)
    hand: np.ndarray  # (T, 2, 3) wrist target relative to the shoulder
    elbow_pole: np.ndarray  # (T, 2, 3) direction the elbow points to (same frame as hand)
    hand_frame: np.ndarray  # (T, 2) 0 = heading frame, 1 = chest frame
    contact: np.ndarray  # (T, 2, 2) bool [side, (ankle, toe)]

    @property
    def frames(self) -> int:
        return int(self.root.shape[0])

    def slice(self, start: int, stop: int) -> "Channels":
        return Channels(**{name: getattr(self, name)[start:stop] for name in _CHANNELS})

    def copy(self) -> "Channels":
        return Channels(**{name: getattr(self, name).copy() for name in _CHANNELS})

    @staticmethod
    def concat(parts: list["Channels"]) -> "Channels":
        return Channels(**{name: np.concatenate([getattr(p, name) for p in parts], 0) for name in _CHANNELS})


_CHANNELS = tuple(f.name for f in fields(Channels))


def neutral_hands(frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Relaxed hanging arms: wrist targets and elbow poles (T, 2, 3), heading frame."""
    hand = np.empty((frames, 2, 3))
    hand[:, :, 0] = SIDE_SIGN * 0.045
    hand[:, :, 1] = -0.505
    hand[:, :, 2] = 0.035
    pole = np.empty((frames, 2, 3))
    pole[:, :, 0] = SIDE_SIGN * 0.35
    pole[:, :, 1] = 0.0
    pole[:, :, 2] = -1.0
    return hand, pole


def _repeat(value: np.ndarray, frames: int) -> np.ndarray:
    """``value`` repeated over a new leading axis of ``frames`` (a writable copy)."""
    out = np.empty((frames,) + np.shape(value))
    out[:] = value
    return out


def standing_channels(frames: int, *, root_xz: np.ndarray, heading: float, feet: np.ndarray,
                      feet_yaw: np.ndarray) -> Channels:
    """A still, relaxed standing pose held for ``frames`` frames with the feet at ``feet`` (2, 3)."""
    hand, pole = neutral_hands(frames)
    root = np.empty((frames, 3))
    root[:, 0] = root_xz[0]
    root[:, 1] = STAND_PELVIS
    root[:, 2] = root_xz[1]
    contact = np.ones((frames, 2, 2), dtype=bool)
    return Channels(
        root=root,
        heading=np.full(frames, float(heading)),
        pelvis=np.zeros((frames, 3)),
        spine=np.zeros((frames, 3, 3)),
        neck=np.zeros((frames, 3)),
        collar=np.zeros((frames, 2, 3)),
        ankle=_repeat(feet, frames),
        foot_yaw=_repeat(feet_yaw, frames),
        foot_pitch=np.zeros((frames, 2)),
        knee_out=np.zeros((frames, 2)),
        hand=hand,
        elbow_pole=pole,
        hand_frame=np.zeros((frames, 2)),
        contact=contact,
    )


# --------------------------------------------------------------------------- two-bone IK
def two_bone(base: np.ndarray, target: np.ndarray, pole: np.ndarray, l1: float, l2: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Analytic two-bone IK (vectorised). Returns (mid, end, d1, d2): joint positions and unit
    bone directions. The mid joint bends toward ``pole``; unreachable targets are clamped."""
    d = target - base
    dist = np.sqrt(dot(d, d))[..., None]
    u = d / np.maximum(dist, 1e-9)
    dist = np.minimum(np.maximum(dist, abs(l1 - l2) + 1e-3), (l1 + l2) * 0.9999)
    p = pole - dot(pole, u)[..., None] * u
    p = p / np.maximum(np.sqrt(dot(p, p)), 1e-9)[..., None]
    cos_a = np.minimum(np.maximum((l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist), -1.0), 1.0)
    sin_a = np.sqrt(1.0 - cos_a * cos_a)
    d1 = cos_a * u + sin_a * p
    mid = base + l1 * d1
    end = base + dist * u
    d2 = (end - mid) / l2
    return mid, end, d1, d2


# --------------------------------------------------------------------------- solver
@dataclass
class Solved:
    """Joint positions plus the global frames needed to build local rotations later."""

    joints: np.ndarray  # (T, 22, 3)
    trunk: dict[int, np.ndarray]  # joint -> global rotation (T, 3, 3) for pelvis/spine/neck/collars
    limb_dirs: dict[int, tuple[np.ndarray, np.ndarray]]  # joint -> (bone dir, bend normal) (T, 3)
    foot_yaw: np.ndarray  # (T, 2) world yaw of each foot
    foot_pitch: np.ndarray  # (T, 2)

    @property
    def foot_rot(self) -> np.ndarray:
        """Ankle world rotations (T, 2, 3, 3) (built on demand: only local rotations need them)."""
        return foot_rotation(self.foot_yaw, self.foot_pitch)


def fit_pelvis_height(root: np.ndarray, hip_offset: np.ndarray, ankle: np.ndarray,
                      contact: np.ndarray, *, softness: float = 0.01) -> np.ndarray:
    """Lower the pelvis (smooth minimum) wherever a planted foot could not be reached.

    root (T, 3), hip_offset (T, 2, 3) (world offsets of the hips from the pelvis joint), ankle (T, 2, 3), contact (T, 2) bool
    -> new root y (T,).
    """
    hips = root[:, None, :] + hip_offset
    dxz2 = (hips[..., 0] - ankle[..., 0]) ** 2 + (hips[..., 2] - ankle[..., 2]) ** 2
    reach = np.sqrt(np.maximum(LEG_REACH**2 - dxz2, 0.05))
    limit = ankle[..., 1] + reach - hip_offset[..., 1]  # (T, 2) max root y
    # smooth minimum of (desired, limits): -k log sum exp(-v / k), always <= the true minimum
    values = np.empty((len(root), 3))
    values[:, 0] = root[:, 1]
    values[:, 1:] = np.where(contact, limit, np.inf)
    lo = values.min(1)
    e = np.exp((values - lo[:, None]) / -softness)
    return lo - softness * np.log(e[:, 0] + e[:, 1] + e[:, 2])


def fit_pelvis_reach(root: np.ndarray, hip_offset: np.ndarray, ankle: np.ndarray, contact: np.ndarray,
                     *, limit: float = 0.55, softness: float = 0.02) -> np.ndarray:
    """Pull the pelvis (on the floor plane) toward planted feet that are too far away to reach.

    A smooth hinge: feet within ``limit`` metres (horizontally, from their hip) are untouched.
    Returns the new root x, z (T, 2).
    """
    root_xz = root[:, ::2]
    d = ankle[..., ::2] - (root_xz[:, None] + hip_offset[..., ::2])  # (T, 2 feet, xz)
    dist = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2)
    x = dist - limit
    excess = 0.5 * (x + np.sqrt(x * x + softness * softness)) * contact
    pull = d * (excess / np.maximum(dist, 1e-9))[..., None]
    return root_xz + (pull[:, 0] + pull[:, 1])


# trunk forward kinematics in order: (joint, parent joint, index of the parent's global frame)
_TRUNK_FK = ((3, 0, 0), (6, 3, 1), (9, 6, 2), (12, 9, 3), (15, 12, 4), (13, 9, 3), (14, 9, 3),
             (16, 13, 5), (17, 14, 6), (1, 0, 0), (2, 0, 0))
_TRUNK_JOINTS = (0, 3, 6, 9, 12, 13, 14)  # joints whose global frames the trunk angles set


def trunk_frames(heading_rot: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Global frames (T, 7, 3, 3) of :data:`_TRUNK_JOINTS` for the heading rotations (T, 3, 3)
    and trunk angles (T, 7, 3): pelvis, spine1, spine2, spine3, neck, collar L, collar R."""
    E = euler(angles)
    G = np.empty_like(E)
    G[:, 0] = heading_rot @ E[:, 0]
    for k in (1, 2, 3):
        G[:, k] = G[:, k - 1] @ E[:, k]
    G[:, 4:] = G[:, 3, None] @ E[:, 4:]
    return G


def solve(ch: Channels) -> Solved:
    """Channels -> joint positions (T, 22, 3) and the frames for local rotations."""
    T = ch.frames
    heading_rot = yaw_rotation(ch.heading)
    G = trunk_frames(heading_rot, np.concatenate([ch.pelvis[:, None], ch.spine, ch.neck[:, None], ch.collar], 1))
    # every trunk frame applied to every rest offset in one matrix product: (T, 7 frames, 3, 22 offsets)
    rotated = (G.reshape(-1, 3) @ OFFSETS.T).reshape(T, 7, 3, 22)
    hip_offset = np.swapaxes(rotated[:, 0, :, 1:3], 1, 2)  # (T, 2, 3)
    root = ch.root.copy()
    contact_any = ch.contact[..., 0] | ch.contact[..., 1]
    root[:, ::2] = fit_pelvis_reach(root, hip_offset, ch.ankle, contact_any)
    root[:, 1] = fit_pelvis_height(root, hip_offset, ch.ankle, contact_any)

    J = np.empty((T, 22, 3))
    J[:, 0] = root
    for joint, parent, frame in _TRUNK_FK:
        J[:, joint] = J[:, parent] + rotated[:, frame, :, joint]

    # legs
    sin_yaw, cos_yaw = np.sin(ch.foot_yaw), np.cos(ch.foot_yaw)
    fwd = floor_vector(sin_yaw, cos_yaw)  # (T, 2, 3), as forward_vector(ch.foot_yaw)
    lat = floor_vector(cos_yaw, -sin_yaw) * SIDE_SIGN[None, :, None]  # left_vector, outward
    knee_pole = fwd * np.cos(ch.knee_out)[..., None] + lat * np.sin(ch.knee_out)[..., None]
    knee_pole = knee_pole + 0.15 * lat
    hips = J[:, 1:3]
    # a leg raised forward (kick, high knee) bends its knee upward, not into the pole's line
    leg = ch.ankle - hips
    ahead = np.maximum(dot(leg, fwd) / np.maximum(np.sqrt(dot(leg, leg)), 1e-9), 0.0)
    knee_pole[..., 1] += 2.0 * ahead
    # never put a toe or heel under the floor (planted feet sit exactly on it already)
    target = ch.ankle.copy()
    floor = np.where(ch.foot_pitch < 0, ANKLE_HEIGHT, TOE_LENGTH * np.sin(TOE_ANGLE + ch.foot_pitch))
    target[..., 1] = np.maximum(target[..., 1], floor - 1e-9)
    knee, ankle, d_thigh, d_shin = two_bone(hips, target, knee_pole, THIGH, SHIN)
    J[:, 4:6] = knee
    J[:, 7:9] = ankle
    J[:, 10:12] = toe_from_ankle(ankle, ch.foot_yaw, ch.foot_pitch)

    # arms
    shoulders = J[:, 16:18]
    w = ch.hand_frame[..., None, None]
    frame = (1.0 - w) * heading_rot[:, None] + w * G[:, None, 3]  # (T, 2, 3, 3)
    target = shoulders + (frame @ ch.hand[..., None])[..., 0]
    pole = (frame @ ch.elbow_pole[..., None])[..., 0]
    elbow, wrist, d_upper, d_fore = two_bone(shoulders, target, pole, UPPER_ARM, FOREARM)
    J[:, 18:20] = elbow
    J[:, 20:22] = wrist

    trunk = {j: G[:, k] for k, j in enumerate(_TRUNK_JOINTS)}
    limb = {
        1: (d_thigh[:, 0], knee_pole[:, 0]), 2: (d_thigh[:, 1], knee_pole[:, 1]),
        4: (d_shin[:, 0], knee_pole[:, 0]), 5: (d_shin[:, 1], knee_pole[:, 1]),
        16: (d_upper[:, 0], pole[:, 0]), 17: (d_upper[:, 1], pole[:, 1]),
        18: (d_fore[:, 0], pole[:, 0]), 19: (d_fore[:, 1], pole[:, 1]),
    }
    return Solved(joints=J, trunk=trunk, limb_dirs=limb, foot_yaw=ch.foot_yaw, foot_pitch=ch.foot_pitch)


def _frame_from(direction: np.ndarray, hint: np.ndarray) -> np.ndarray:
    """Orthonormal frame (..., 3, 3) with columns (direction, n, direction x n); n ⟂ direction from hint."""
    d = direction / np.linalg.norm(direction, axis=-1, keepdims=True)
    n = hint - (hint * d).sum(-1, keepdims=True) * d
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-9)
    return np.stack([d, n, np.cross(d, n)], -1)


# rest frames of the limb joints: (child offset direction, pole direction in the rest pose)
_REST_POLE = {1: (0, 0, 1), 2: (0, 0, 1), 4: (0, 0, 1), 5: (0, 0, 1),
              16: (0, 1, -1), 17: (0, 1, -1), 18: (0, 1, -1), 19: (0, 1, -1)}
_LIMB_CHILD = {1: 4, 2: 5, 4: 7, 5: 8, 16: 18, 17: 19, 18: 20, 19: 21}


def local_rotations(solved: Solved) -> np.ndarray:
    """Local joint rotations (T, 22, 3, 3) such that ``Skeleton.forward(local, joints[:, 0])``
    reproduces ``solved.joints`` (leaves: identity relative to their parent)."""
    T = solved.joints.shape[0]
    glob = np.broadcast_to(np.eye(3), (T, 22, 3, 3)).copy()
    for j, g in solved.trunk.items():
        glob[:, j] = g
    for j, (direction, pole) in solved.limb_dirs.items():
        child = _LIMB_CHILD[j]
        rest = _frame_from(OFFSETS[child], np.asarray(_REST_POLE[j], dtype=np.float64))
        glob[:, j] = _frame_from(direction, pole) @ rest.T
    glob[:, 7] = solved.foot_rot[:, 0]
    glob[:, 8] = solved.foot_rot[:, 1]
    for j in (10, 11, 15, 20, 21):
        glob[:, j] = glob[:, PARENTS[j]]
    local = np.empty_like(glob)
    local[:, 0] = glob[:, 0]
    parents = np.array(PARENTS[1:])
    local[:, 1:] = np.swapaxes(glob[:, parents], -1, -2) @ glob[:, 1:]
    return local
