"""User paths -> control features: a root path on the floor, a wrist path in the body frame.

A root path is 2-D floor points (x, z in metres, world frame, Y up) with optional times; the
character walks along it facing its direction of travel, starting at the first point. Its
control features (root rotation velocity and XZ linear velocity) are computed by running a
rigid rest-pose body along the path through the representation itself, so the conventions are
the model's by construction (one extraction quirk that throws a full circle off its path is undone,
see :func:`_onto_path`). A wrist path is 3-D points in the body frame (x to the person's
left, y height above the floor, z forward: the representation's root-relative "ric" frame).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.generate import FPS
from engine.representation import canonicalize, hml_inverse_kinematics, joints_to_features
from engine.rotations import qinv, qmul
from engine.skeleton import Skeleton

MAX_ROOT_SPEED = 4.5  # m/s: a fast run
MAX_WRIST_SPEED = 8.0  # m/s relative to the body
MAX_REACH = 1.0  # m from the body's vertical axis


def _checked(points, *, dims: int, what: str) -> np.ndarray:
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: points must be numbers") from None
    if p.ndim != 2 or p.shape[1] != dims:
        raise ValueError(f"{what}: expected a list of {dims}-D points, got shape {p.shape}")
    if not np.isfinite(p).all():
        bad = int(np.argwhere(~np.isfinite(p).all(1))[0, 0])
        raise ValueError(f"{what}: point {bad} is not a finite number (NaN or infinite)")
    if len(p) < 2:
        raise ValueError(f"{what}: needs at least 2 points, got {len(p)}")
    return p


def _times(times, n_points: int, seconds: float, arc: np.ndarray, what: str) -> np.ndarray:
    if times is None:
        total = arc[-1]
        return arc / total * seconds if total > 1e-9 else np.linspace(0.0, seconds, n_points)
    t = np.asarray(times, dtype=np.float64)
    if t.shape != (n_points,) or not np.isfinite(t).all():
        raise ValueError(f"{what}: one finite time per point is needed")
    if (np.diff(t) <= 0).any():
        raise ValueError(f"{what}: times must increase")
    return t - t[0]


def resample(points: np.ndarray, times: np.ndarray, frames: int) -> np.ndarray:
    """Positions at each frame k/FPS (k < frames); the last point is held after the path ends."""
    tk = np.arange(frames) / FPS
    return np.stack([np.interp(tk, times, points[:, d]) for d in range(points.shape[1])], -1)


@dataclass(frozen=True)
class RootPath:
    points: tuple[tuple[float, float], ...]  # (x, z) metres
    times: tuple[float, ...] | None = None  # seconds per point; None = constant speed over the motion

    def frames(self, seconds: float) -> np.ndarray:
        """Root (x, z) at each of the motion's poses: (T + 1, 2) for T feature frames."""
        p = _checked(self.points, dims=2, what="root path")
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        if arc[-1] < 1e-6:
            raise ValueError("root path: the points do not move (draw a path on the floor)")
        t = _times(self.times, len(p), seconds, arc, "root path")
        n = int(round(seconds * FPS))
        xz = resample(p, t, n + 1)
        speed = np.linalg.norm(np.diff(xz, axis=0), axis=1) * FPS
        if speed.max() > MAX_ROOT_SPEED:
            raise ValueError(f"root path: {speed.max():.1f} m/s is faster than a person runs ({MAX_ROOT_SPEED} m/s "
                             f"at most): make the path shorter or the motion longer")
        return xz

    def start_heading(self, xz: np.ndarray) -> float:
        """Yaw (rad) of the first direction of travel (the body faces (sin h, 0, cos h))."""
        d = xz[np.argmax(np.linalg.norm(xz - xz[0], axis=1) > 0.05)] - xz[0]
        return float(np.arctan2(d[0], d[1]))


def headings(xz: np.ndarray, *, min_step: float = 0.005) -> np.ndarray:
    """Facing yaw per pose along the direction of travel; held while standing still."""
    d = np.gradient(xz, axis=0)
    out = np.zeros(len(xz))
    moving = np.linalg.norm(d, axis=1) > min_step
    h = np.arctan2(d[moving][0, 0], d[moving][0, 1]) if moving.any() else 0.0
    for i in range(len(xz)):
        if moving[i]:
            h = np.arctan2(d[i, 0], d[i, 1])
        out[i] = h
    return np.unwrap(out)


def body_along(xz: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """A rigid rest-pose body at each root position, facing ``yaw``: (T + 1, 22, 3)."""
    rest = Skeleton().rest_pose()
    rest = rest - np.array([0.0, rest[:, 1].min(), 0.0])
    c, s = np.cos(yaw), np.sin(yaw)
    x = c[:, None] * rest[None, :, 0] + s[:, None] * rest[None, :, 2]
    z = -s[:, None] * rest[None, :, 0] + c[:, None] * rest[None, :, 2]
    y = np.broadcast_to(rest[None, :, 1], x.shape)
    return np.stack([x + xz[:, :1], y, z + xz[:, 1:]], -1)


def root_controls(path: RootPath, seconds: float) -> tuple[np.ndarray, dict]:
    """(T, 3) raw control features (dims 0-2) and the frame transform back to the path's world.

    The generated motion starts at the origin facing +Z; ``frame`` = {"origin", "yaw"} places it
    on the path (see :func:`to_world`).
    """
    xz = path.frames(seconds)
    yaw = headings(xz)
    body = body_along(xz, yaw)
    values = _onto_path(joints_to_features(body)[:, :3].astype(np.float64), canonicalize(body))
    return values, {"origin": xz[0].tolist(), "yaw": float(yaw[0]), "target": xz}


def _onto_path(values: np.ndarray, body: np.ndarray) -> np.ndarray:
    """Root features (T, 3) of the canonical ``body`` (T + 1, 22, 3), made to decode onto its root path.

    HumanML3D's extraction (kept as it is for the reference data) stores the turn per frame as the asin
    of the relative quaternion's y part, with no sign fix: on the frame where the heading passes 180
    degrees from the start, the quaternion's double cover flips that frame's turn, so a drawn circle
    decoded about 0.1 rad off its heading from there on and up to 0.3 m off the path. Here the turn takes
    the sign of the quaternion's w; ``features_to_joints`` then puts the root on every pose of the path.
    """
    q = hml_inverse_kinematics(body)[:, 0]  # (T + 1, 4) w, x, y, z: the representation's own (smoothed) heading
    rel = qmul(q[1:], qinv(q[:-1]))
    values = values.copy()
    values[:, 0] = np.arcsin(np.clip(np.where(rel[:, 0] < 0, -rel[:, 2], rel[:, 2]), -1.0, 1.0))
    return values


def to_world(joints: np.ndarray, frame: dict) -> np.ndarray:
    """Canonical joints (start at the origin facing +Z) -> the path's world frame."""
    c, s = np.cos(frame["yaw"]), np.sin(frame["yaw"])
    x = c * joints[..., 0] + s * joints[..., 2]
    z = -s * joints[..., 0] + c * joints[..., 2]
    ox, oz = frame["origin"]
    return np.stack([x + ox, joints[..., 1], z + oz], -1)


@dataclass(frozen=True)
class WristPath:
    points: tuple[tuple[float, float, float], ...]  # (x left, y up, z forward) metres, body frame
    times: tuple[float, ...] | None = None

    def controls(self, seconds: float) -> np.ndarray:
        """(T, 3) raw ric values of the wrist for T feature frames."""
        p = _checked(self.points, dims=3, what="wrist path")
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        t = _times(self.times, len(p), seconds, arc, "wrist path")
        n = int(round(seconds * FPS))
        v = resample(p, t, n)
        reach = np.linalg.norm(v[:, [0, 2]], axis=1)
        if reach.max() > MAX_REACH or v[:, 1].min() < 0.0 or v[:, 1].max() > 2.3:
            raise ValueError(f"wrist path: points must stay within {MAX_REACH} m of the body and between the floor "
                             "and 2.3 m high")
        speed = np.linalg.norm(np.diff(v, axis=0), axis=1) * FPS
        if len(speed) and speed.max() > MAX_WRIST_SPEED:
            raise ValueError(f"wrist path: {speed.max():.1f} m/s is too fast for a hand (at most {MAX_WRIST_SPEED} m/s)")
        return v


def path_error(joints_world: np.ndarray, target_xz: np.ndarray) -> dict:
    """Root error on the floor (m): mean and the share of frames more than 0.5 m off."""
    n = min(len(joints_world), len(target_xz))
    d = np.linalg.norm(joints_world[:n, 0, [0, 2]] - target_xz[:n], axis=1)
    return {"mean_m": float(d.mean()), "max_m": float(d.max()), "off_0_5m": float((d > 0.5).mean())}
