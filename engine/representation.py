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

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.ndimage import correlate1d

from engine.rotations import components, cross, dot, expand, new_vectors, qbetween, qinv, qmul
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


def ric_dims(joint: int) -> list[int]:
    """The 3 feature dims of a joint's root-relative position (ric holds joints 1..21; the pelvis has none)."""
    if not 1 <= joint < NUM_JOINTS:
        raise ValueError(f"joint {joint} has no ric dims (joints 1..{NUM_JOINTS - 1})")
    start = SLICES["ric"].start + 3 * (joint - 1)
    return [start, start + 1, start + 2]


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
_IK_RAW_DIRS = HML_RAW_OFFSETS[_IK_CHILD].T[:, None, :].copy()  # (3, 1, 21) components first
_FORWARD = np.array([0.0, 0.0, 1.0])
_XZ = np.array([1.0, 0.0, 1.0])
_FEET = np.array(list(FOOT_JOINTS["left"]) + list(FOOT_JOINTS["right"]))


def _gaussian_kernel(sigma: float, truncate: float = 4.0) -> np.ndarray:
    """The weights scipy's ``gaussian_filter1d(x, sigma)`` correlates with (computed once here)."""
    radius = int(truncate * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (sigma * sigma) * x**2)
    return (phi / phi.sum())[::-1].copy()


_HEADING_SMOOTHING = _gaussian_kernel(20.0)  # HumanML3D smooths the IK's facing direction with sigma 20


def _check_joints(joints: np.ndarray) -> np.ndarray:
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if joints.shape[0] < 2:
        raise ValueError(f"a motion needs at least 2 frames, got {joints.shape[0]}")
    if not np.isfinite(joints).all():
        raise ValueError("joints contain NaN or infinite values")
    return joints


def _unit(v: np.ndarray, axis: int = -1) -> np.ndarray:
    return v / expand(np.sqrt(dot(v, v, axis=axis)), axis)


def facing_direction(joints: np.ndarray) -> np.ndarray:
    """Unit horizontal facing direction per pose: up x (right - left across hips + shoulders)."""
    r_hip, l_hip, r_sdr, l_sdr = FACE_JOINTS
    across = (joints[..., r_hip, :] - joints[..., l_hip, :]) + (joints[..., r_sdr, :] - joints[..., l_sdr, :])
    return _unit(cross(_UP, _unit(across)))


def yaw_quat_rotate(q: np.ndarray, v: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Rotate vectors v (..., 3) by pure-yaw quaternions q = (w, 0, y, 0) (..., 4): a cheap qrot.
    ``axis`` (0 or -1) is where both hold their components."""
    qw, _, qy, _ = components(q, axis)
    vx, vy, vz = components(v, axis)
    c, s = 1.0 - 2.0 * qy * qy, 2.0 * qw * qy
    out, o = new_vectors(c * vx + s * vz, 3, axis)
    o[1] = vy
    o[2] = -s * vx + c * vz
    return out


def quat_to_cont6d(q: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """The first two columns of a unit quaternion's rotation matrix, (..., 4) -> (..., 6).
    ``axis`` (0 or -1) holds the components of both."""
    w, x, y, z = components(_unit(q, axis), axis)
    out, o = new_vectors(1 - 2 * (y * y + z * z), 6, axis)
    o[1] = 2 * (x * y + w * z)
    o[2] = 2 * (x * z - w * y)
    o[3] = 2 * (x * y - w * z)
    o[4] = 1 - 2 * (x * x + z * z)
    o[5] = 2 * (y * z + w * x)
    return out


def canonicalize(joints: np.ndarray) -> np.ndarray:
    """Floor at y=0, the root's first position at the XZ origin, first pose facing +Z."""
    return np.ascontiguousarray(_canonical_parts(joints).transpose(1, 2, 0))


def _canonical_parts(joints: np.ndarray) -> np.ndarray:
    """:func:`canonicalize` with the components first: (T, 22, 3) -> (3, T, 22), C-contiguous."""
    joints = _check_joints(joints)
    shift = np.array([joints[0, 0, 0], joints[..., 1].min(), joints[0, 0, 2]])
    turn = qbetween(facing_direction(joints[0] - shift), _FORWARD)  # a pure yaw: the facing is horizontal
    return yaw_quat_rotate(turn, components(joints) - shift[:, None, None], axis=0)


def foot_contacts(joints: np.ndarray, threshold: float = FOOT_CONTACT_THRESHOLD) -> np.ndarray:
    """(T, 22, 3) -> (T-1, 4) contacts [L ankle, L foot, R ankle, R foot] as 0/1 floats."""
    return _foot_contacts(components(joints), threshold)


def _foot_contacts(p: np.ndarray, threshold: float = FOOT_CONTACT_THRESHOLD) -> np.ndarray:
    """:func:`foot_contacts` of component-first joints (3, T, 22)."""
    feet = p[:, :, _FEET]
    step = feet[:, 1:] - feet[:, :-1]
    return (dot(step, step, axis=0) < threshold).astype(np.float64)


def hml_inverse_kinematics(joints: np.ndarray, *, smooth_forward: bool = True) -> np.ndarray:
    """HumanML3D's IK: per-frame quaternions (T, 22, 4).

    The root quaternion turns the (smoothed) facing direction onto +Z (identity on frame 0); along every chain the
    quaternion stored at a child joint is the shortest arc from its raw offset direction to
    the observed bone, relative to the accumulated chain rotation (each chain restarts at the
    root rotation, as in HumanML3D).
    """
    quats = _hml_ik(components(joints), smooth_forward=smooth_forward)
    return np.ascontiguousarray(quats.transpose(1, 2, 0))


def _hml_ik(p: np.ndarray, *, smooth_forward: bool = True) -> np.ndarray:
    """:func:`hml_inverse_kinematics` with the components first: (3, T, 22) -> (4, T, 22)."""
    forward = cross(_UP[:, None], _hml_ik_across(p), axis=0)  # (3, T)
    if smooth_forward:
        forward = correlate1d(forward, _HEADING_SMOOTHING, axis=1, mode="nearest")
    quats = np.empty((4,) + p.shape[1:])
    # (qbetween is scale-invariant: the directions need no normalising)
    root_quat = qbetween(forward, _FORWARD[:, None], axis=0)
    # HumanML3D pins the first frame's root rotation to the identity (the canonical pose already
    # faces +Z), so the first root angular velocity absorbs the smoothing offset.
    root_quat[:, 0] = (1.0, 0.0, 0.0, 0.0)
    # Along a chain the accumulated rotation after bone b equals b's shortest arc, so each
    # stored quaternion is inv(arc of the previous bone in the chain, or the root) * arc(b).
    arcs = qbetween(_IK_RAW_DIRS, p[:, :, _IK_CHILD] - p[:, :, _IK_PARENT], axis=0)  # (4, T, 21)
    prev = np.concatenate([root_quat[:, :, None], arcs], axis=2)[:, :, _IK_PREV + 1]
    quats[:, :, 0] = root_quat
    quats[:, :, _IK_CHILD] = qmul(qinv(prev, axis=0), arcs, axis=0)
    return quats


def _hml_ik_across(p: np.ndarray) -> np.ndarray:
    """The "across" vector (3, T) of HumanML3D's IK for component-first joints (3, T, 22),
    reproduced as the reference data demands.

    HumanML3D's IK unpacks the face joints (2, 1, 17, 16) as (l_hip, r_hip, sdr_r, sdr_l), so its
    across vector is (left hip - right hip) + (right shoulder - left shoulder): the hip term
    points the opposite way to the canonicalisation's. The shoulders are wider than the hips, so
    the sum still points to the body's right. Measured on the real sample: this matches the
    reference heading to 0.015 rad where the consistent version is off by 0.6 rad.
    """
    r_hip, l_hip, r_sdr, l_sdr = FACE_JOINTS
    across = (p[:, :, l_hip] - p[:, :, r_hip]) + (p[:, :, r_sdr] - p[:, :, l_sdr])
    return _unit(across, 0)


def _put(features: np.ndarray, key: str, parts: np.ndarray) -> None:
    """Write component-first values (n, T-1, J) into a feature group laid out (J, n) per frame."""
    features[:, SLICES[key]] = parts.transpose(1, 2, 0).reshape(len(features), -1)


def joints_to_features(joints: np.ndarray, *, canonical: bool = True) -> np.ndarray:
    """Joint positions (T, 22, 3) in metres -> HumanML3D features (T-1, 263), float32.

    With ``canonical`` (default) the motion is first put on the floor, at the origin and
    facing +Z (HumanML3D's processing; its skeleton retargeting is the importer's job).
    """
    # (3, T, 22): components first
    p = _canonical_parts(joints) if canonical else np.ascontiguousarray(components(_check_joints(joints)))
    quats = _hml_ik(p)
    root_quat = quats[:, :, 0]  # (4, T) heading: world -> root frame
    features = np.empty((p.shape[1] - 1, FEATURE_DIM), dtype=np.float32)

    # root: yaw velocity (HumanML3D keeps asin of the relative quaternion's y part), velocity, height
    rel = qmul(root_quat[:, 1:], qinv(root_quat[:, :-1], axis=0), axis=0)
    features[:, 0] = np.arcsin(np.clip(rel[2], -1.0, 1.0))
    # the root quaternions turn a horizontal direction onto +Z: pure yaw, so the cheap rotation applies
    root_vel = yaw_quat_rotate(root_quat[:, 1:], p[:, 1:, 0] - p[:, :-1, 0], axis=0)
    features[:, 1] = root_vel[0]
    features[:, 2] = root_vel[2]
    features[:, 3] = p[1, :-1, 0]

    # ric: positions relative to the root's XZ, heading removed
    heading = root_quat[:, :-1, None]
    ric = p[:, :-1, 1:] - p[:, :-1, :1] * _XZ[:, None, None]
    _put(features, "ric", yaw_quat_rotate(heading, ric, axis=0))
    _put(features, "rot6d", quat_to_cont6d(quats[:, :-1, 1:], axis=0))
    _put(features, "local_vel", yaw_quat_rotate(heading, p[:, 1:] - p[:, :-1], axis=0))
    features[:, SLICES["contacts"]] = _foot_contacts(p)
    return features


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


def features_to_joints(features: np.ndarray | torch.Tensor, *,
                       only: Sequence[int] | None = None) -> np.ndarray | torch.Tensor:
    """HumanML3D features (..., T, 263) -> joint positions (..., T, 22, 3) (the "ric" path); ``only``: just these
    joints (none of them the root), (..., T, len(only), 3), in that order (the training's foot term reads 4 of 22).

    Accepts numpy or torch; returns the same kind.
    """
    as_numpy = isinstance(features, np.ndarray)
    x = torch.from_numpy(features) if as_numpy else features
    if x.shape[-1] != FEATURE_DIM:
        raise ValueError(f"features must end in {FEATURE_DIM} dims, got shape {tuple(x.shape)}")
    heading, root = recover_root(x)
    ric = x[..., SLICES["ric"]].reshape(x.shape[:-1] + (NUM_JOINTS - 1, 3))
    if only is not None:
        if not all(0 < j < NUM_JOINTS for j in only):
            raise ValueError(f"only: joints 1..{NUM_JOINTS - 1} (the root is not a ric joint), got {list(only)}")
        ric = ric[..., [j - 1 for j in only], :]
    ric = _yaw_rotate(ric, -heading[..., None])
    ric = ric + torch.stack([root[..., 0], torch.zeros_like(root[..., 0]), root[..., 2]], -1)[..., None, :]
    joints = ric if only is not None else torch.cat([root[..., None, :], ric], dim=-2)
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
