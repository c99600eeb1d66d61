"""HumanML3D's 263-dim motion features, both directions, plus Mean/Std normalisation.

Layout per frame (T-1 frames for T poses):
  [0]        root angular velocity about Y (HumanML3D stores half the yaw step: asin of the
             quaternion's y part)
  [1:3]      root linear velocity on XZ, in the root's heading frame
  [3]        root height
  [4:67]     21 x 3 root-relative joint positions with the heading removed ("ric")
  [67:193]   21 x 6 continuous 6D rotations (HumanML3D's per-chain IK over its raw offsets)
  [193:259]  22 x 3 joint velocities in the heading frame
  [259:263]  foot contacts: left ankle, left foot, right ankle, right foot
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d

from engine.rotations import cross, qbetween, qinv, qmul
from engine.skeleton import CHAINS, FACE_JOINTS, FOOT_JOINTS, NUM_JOINTS

FEATURE_DIM = 263
SLICES = {
    "root_rot_vel": slice(0, 1),
    "root_lin_vel": slice(1, 3),
    "root_height": slice(3, 4),
    "ric": slice(4, 4 + (NUM_JOINTS - 1) * 3),
    "rot6d": slice(67, 67 + (NUM_JOINTS - 1) * 6),
    "local_vel": slice(193, 193 + NUM_JOINTS * 3),
    "contacts": slice(259, 263),
}
FOOT_CONTACT_THRESHOLD = 0.002  # squared displacement per frame (m^2), as HumanML3D

# HumanML3D's raw bone directions ("t2m_raw_offsets"), used only by its per-chain IK, which
# defines the 6D rotation features.
HML_RAW_OFFSETS = np.array(
    [[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, -1, 0], [0, 1, 0], [0, -1, 0],
     [0, -1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [0, 1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1],
     [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, -1, 0]],
    dtype=np.float64,
)
_UP = np.array([0.0, 1.0, 0.0])


def _ik_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per bone along HumanML3D's chains: child joint, parent joint, previous bone (-1 = root)."""
    child, parent, prev = [], [], []
    for chain in CHAINS:
        for j, (a, b) in enumerate(zip(chain[:-1], chain[1:])):
            child.append(b)
            parent.append(a)
            prev.append(len(child) - 2 if j > 0 else -1)
    return np.array(child), np.array(parent), np.array(prev)


_IK_CHILD, _IK_PARENT, _IK_PREV = _ik_tables()
_FORWARD = np.array([0.0, 0.0, 1.0])


def _check_joints(joints: np.ndarray) -> np.ndarray:
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if joints.shape[0] < 2:
        raise ValueError(f"a motion needs at least 2 frames, got {joints.shape[0]}")
    if not np.isfinite(joints).all():
        raise ValueError("joints contain NaN or infinite values")
    return joints


def facing_direction(joints: np.ndarray) -> np.ndarray:
    """Unit horizontal facing direction per pose: up x (right - left across hips + shoulders)."""
    r_hip, l_hip, r_sdr, l_sdr = FACE_JOINTS
    across = (joints[..., r_hip, :] - joints[..., l_hip, :]) + (joints[..., r_sdr, :] - joints[..., l_sdr, :])
    across = across / np.linalg.norm(across, axis=-1, keepdims=True)
    forward = cross(_UP, across)
    return forward / np.linalg.norm(forward, axis=-1, keepdims=True)


def yaw_quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by pure-yaw quaternions q = (w, 0, y, 0) (..., 4): a cheap qrot."""
    w, y = q[..., 0], q[..., 2]
    c, s = 1.0 - 2.0 * y * y, 2.0 * w * y
    out = np.empty(np.broadcast_shapes(q.shape[:-1], v.shape[:-1]) + (3,))
    out[..., 0] = c * v[..., 0] + s * v[..., 2]
    out[..., 1] = v[..., 1]
    out[..., 2] = -s * v[..., 0] + c * v[..., 2]
    return out


def quat_to_cont6d(q: np.ndarray) -> np.ndarray:
    """The first two columns of a unit quaternion's rotation matrix, (..., 4) -> (..., 6)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (6,))
    out[..., 0] = 1 - 2 * (y * y + z * z)
    out[..., 1] = 2 * (x * y + w * z)
    out[..., 2] = 2 * (x * z - w * y)
    out[..., 3] = 2 * (x * y - w * z)
    out[..., 4] = 1 - 2 * (x * x + z * z)
    out[..., 5] = 2 * (y * z + w * x)
    return out


def canonicalize(joints: np.ndarray) -> np.ndarray:
    """Floor at y=0, the root's first position at the XZ origin, first pose facing +Z."""
    joints = _check_joints(joints).copy()
    joints[..., 1] -= joints[..., 1].min()
    joints -= joints[0, 0] * np.array([1.0, 0.0, 1.0])
    turn = qbetween(facing_direction(joints[0]), _FORWARD)  # a pure yaw: the facing is horizontal
    return yaw_quat_rotate(turn, joints)


def foot_contacts(joints: np.ndarray, threshold: float = FOOT_CONTACT_THRESHOLD) -> np.ndarray:
    """(T, 22, 3) -> (T-1, 4) contacts [L ankle, L foot, R ankle, R foot] as 0/1 floats."""
    feet = list(FOOT_JOINTS["left"]) + list(FOOT_JOINTS["right"])
    step = joints[1:, feet] - joints[:-1, feet]
    return ((step**2).sum(-1) < threshold).astype(np.float64)


def hml_inverse_kinematics(joints: np.ndarray, *, smooth_forward: bool = True) -> np.ndarray:
    """HumanML3D's IK: per-frame quaternions (T, 22, 4).

    The root quaternion turns the (smoothed) facing direction onto +Z (identity on frame 0); along every chain the
    quaternion stored at a child joint is the shortest arc from its raw offset direction to
    the observed bone, relative to the accumulated chain rotation (each chain restarts at the
    root rotation, as in HumanML3D).
    """
    forward = cross(_UP, _hml_ik_across(joints))
    if smooth_forward:
        forward = gaussian_filter1d(forward, 20, axis=0, mode="nearest")
    forward = forward / np.linalg.norm(forward, axis=-1, keepdims=True)
    root_quat = qbetween(forward, np.broadcast_to(_FORWARD, forward.shape))
    # HumanML3D pins the first frame's root rotation to the identity (the canonical pose already
    # faces +Z), so the first root angular velocity absorbs the smoothing offset.
    root_quat[0] = (1.0, 0.0, 0.0, 0.0)
    # Along a chain the accumulated rotation after bone b equals b's shortest arc, so each
    # stored quaternion is inv(arc of the previous bone in the chain, or the root) * arc(b).
    bones = joints[:, _IK_CHILD] - joints[:, _IK_PARENT]
    bones = bones / np.linalg.norm(bones, axis=-1, keepdims=True)
    arcs = qbetween(np.broadcast_to(HML_RAW_OFFSETS[_IK_CHILD], bones.shape), bones)  # (T, 21, 4)
    prev = np.concatenate([root_quat[:, None], arcs], axis=1)[:, _IK_PREV + 1]
    quats = np.empty(joints.shape[:-1] + (4,))
    quats[:, 0] = root_quat
    quats[:, _IK_CHILD] = qmul(qinv(prev), arcs)
    return quats


def _hml_ik_across(joints: np.ndarray) -> np.ndarray:
    """The "across" vector of HumanML3D's IK, reproduced as the reference data demands.

    HumanML3D's IK unpacks the face joints (2, 1, 17, 16) as (l_hip, r_hip, sdr_r, sdr_l), so its
    across vector is (left hip - right hip) + (right shoulder - left shoulder): the hip term
    points the opposite way to the canonicalisation's. The shoulders are wider than the hips, so
    the sum still points to the body's right. Measured on the real sample: this matches the
    reference heading to 0.015 rad where the consistent version is off by 0.6 rad.
    """
    r_hip, l_hip, r_sdr, l_sdr = FACE_JOINTS
    across = (joints[:, l_hip] - joints[:, r_hip]) + (joints[:, r_sdr] - joints[:, l_sdr])
    return across / np.linalg.norm(across, axis=-1, keepdims=True)


def joints_to_features(joints: np.ndarray, *, canonical: bool = True) -> np.ndarray:
    """Joint positions (T, 22, 3) in metres -> HumanML3D features (T-1, 263), float32.

    With ``canonical`` (default) the motion is first put on the floor, at the origin and
    facing +Z (HumanML3D's processing; its skeleton retargeting is the importer's job).
    """
    positions = canonicalize(joints) if canonical else _check_joints(joints)
    contacts = foot_contacts(positions)
    quats = hml_inverse_kinematics(positions)
    root_quat = quats[:, 0]  # (T, 4) heading: world -> root frame

    # root: yaw velocity (HumanML3D keeps asin of the relative quaternion's y part), velocity, height
    rel = qmul(root_quat[1:], qinv(root_quat[:-1]))
    root_rot_vel = np.arcsin(np.clip(rel[:, 2:3], -1.0, 1.0))
    # the root quaternions turn a horizontal direction onto +Z: pure yaw, so the cheap rotation applies
    root_vel = yaw_quat_rotate(root_quat[1:], positions[1:, 0] - positions[:-1, 0])[:, [0, 2]]
    root_height = positions[:-1, 0, 1:2]

    # ric: positions relative to the root's XZ, heading removed
    ric = positions.copy()
    ric[..., 0] -= positions[:, 0:1, 0]
    ric[..., 2] -= positions[:, 0:1, 2]
    ric = yaw_quat_rotate(root_quat[:-1, None], ric[:-1, 1:]).reshape(len(ric) - 1, -1)

    rot6d = quat_to_cont6d(quats[:-1, 1:]).reshape(len(quats) - 1, -1)
    local_vel = yaw_quat_rotate(root_quat[:-1, None], positions[1:] - positions[:-1]).reshape(len(positions) - 1, -1)

    features = np.concatenate([root_rot_vel, root_vel, root_height, ric, rot6d, local_vel, contacts], -1)
    return features.astype(np.float32)


def _yaw_rotate(vectors: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """Rotate (..., 3) vectors about +Y by ``angle`` (...)."""
    c, s = torch.cos(angle), torch.sin(angle)
    x, y, z = vectors.unbind(-1)
    return torch.stack([c * x + s * z, y, -s * x + c * z], dim=-1)


def recover_root(features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Integrate the root: (..., T, 263) -> (heading angle (..., T), root position (..., T, 3)).

    The heading angle is the yaw that takes world vectors into the root frame (HumanML3D's
    r_rot_quat is (cos a, 0, sin a, 0), a rotation by 2a).
    """
    rot_vel = features[..., 0]
    half = torch.zeros_like(rot_vel)
    half[..., 1:] = rot_vel[..., :-1]
    half = torch.cumsum(half, dim=-1)
    step = torch.zeros(features.shape[:-1] + (3,), dtype=features.dtype, device=features.device)
    step[..., 1:, 0] = features[..., :-1, 1]
    step[..., 1:, 2] = features[..., :-1, 2]
    step = _yaw_rotate(step, -2.0 * half)  # root frame -> world
    root = torch.cumsum(step, dim=-2)
    root[..., 1] = features[..., 3]
    return 2.0 * half, root


def features_to_joints(features: np.ndarray | torch.Tensor) -> np.ndarray | torch.Tensor:
    """HumanML3D features (..., T, 263) -> joint positions (..., T, 22, 3) (the "ric" path).

    Accepts numpy or torch; returns the same kind.
    """
    as_numpy = isinstance(features, np.ndarray)
    x = torch.from_numpy(features) if as_numpy else features
    if x.shape[-1] != FEATURE_DIM:
        raise ValueError(f"features must end in {FEATURE_DIM} dims, got shape {tuple(x.shape)}")
    heading, root = recover_root(x)
    ric = x[..., SLICES["ric"]].reshape(x.shape[:-1] + (NUM_JOINTS - 1, 3))
    ric = _yaw_rotate(ric, -heading[..., None])
    ric = ric + torch.stack([root[..., 0], torch.zeros_like(root[..., 0]), root[..., 2]], -1)[..., None, :]
    joints = torch.cat([root[..., None, :], ric], dim=-2)
    return joints.numpy() if as_numpy else joints


@dataclass(frozen=True)
class Normalizer:
    """Mean/Std feature normalisation kept beside a checkpoint."""

    mean: np.ndarray  # (263,)
    std: np.ndarray  # (263,)

    def __post_init__(self) -> None:
        for name in ("mean", "std"):
            value = np.asarray(getattr(self, name), dtype=np.float32)
            if value.shape != (FEATURE_DIM,):
                raise ValueError(f"{name} must have shape ({FEATURE_DIM},), got {value.shape}")
            if not np.isfinite(value).all():
                raise ValueError(f"{name} contains NaN or infinite values")
            object.__setattr__(self, name, value)
        if (self.std <= 0).any():
            raise ValueError("std must be positive everywhere")

    @classmethod
    def fit(cls, features: np.ndarray, *, min_std: float = 1e-3) -> "Normalizer":
        """Mean/Std over all frames of (N, 263) features, with HumanML3D's per-group std pooling."""
        features = np.asarray(features, dtype=np.float64).reshape(-1, FEATURE_DIM)
        mean = features.mean(0)
        std = features.std(0)
        for key in ("root_rot_vel", "root_lin_vel", "root_height", "ric", "rot6d", "local_vel", "contacts"):
            sl = SLICES[key]
            std[sl] = std[sl].mean()  # HumanML3D pools std within each group
        return cls(mean=mean, std=np.maximum(std, min_std))

    @classmethod
    def load(cls, folder: str | Path, *, mean_name: str = "Mean.npy", std_name: str = "Std.npy") -> "Normalizer":
        folder = Path(folder)
        return cls(
            mean=np.load(folder / mean_name, allow_pickle=False),
            std=np.load(folder / std_name, allow_pickle=False),
        )

    def save(self, folder: str | Path) -> None:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        np.save(folder / "Mean.npy", self.mean)
        np.save(folder / "Std.npy", self.std)

    def normalize(self, features):
        return (features - self._like(self.mean, features)) / self._like(self.std, features)

    def denormalize(self, features):
        return features * self._like(self.std, features) + self._like(self.mean, features)

    @staticmethod
    def _like(value: np.ndarray, ref):
        if isinstance(ref, torch.Tensor):
            return torch.as_tensor(value, dtype=ref.dtype, device=ref.device)
        return value
