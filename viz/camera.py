"""Camera placement for skeleton scenes: facing direction, view direction, framing."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.skeleton import FACE_JOINTS

UP = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class CameraPose:
    """Where a camera sits and what it looks at (world coordinates, Y up)."""

    position: np.ndarray
    focal_point: np.ndarray


def facing_azimuth(pose: np.ndarray) -> float:
    """Heading of a pose (22, 3) in degrees, measured in XZ from +Z towards +X.

    The facing direction is ``up x (right - left)`` summed over hips and shoulders; 0 means
    the body faces +Z (HumanML3D's canonical start).
    """
    r_hip, l_hip, r_sho, l_sho = FACE_JOINTS
    across = (pose[r_hip] - pose[l_hip]) + (pose[r_sho] - pose[l_sho])
    face = np.cross(UP, across)
    if np.hypot(face[0], face[2]) < 1e-9:
        return 0.0
    return float(np.degrees(np.arctan2(face[0], face[2])))


def view_direction(*, azimuth: float, elevation: float) -> np.ndarray:
    """Unit vector from the focal point towards the camera (degrees; azimuth from +Z to +X)."""
    az, el = np.radians(azimuth), np.radians(elevation)
    return np.array([np.sin(az) * np.cos(el), np.sin(el), np.cos(az) * np.cos(el)])


def fit_points(
    points: np.ndarray,
    *,
    direction: np.ndarray,
    view_angle: float = 30.0,
    aspect: float = 4 / 3,
    margin: float = 1.12,
    pad: float = 0.1,
) -> CameraPose:
    """Place a perspective camera along ``direction`` so that all ``points`` (N, 3) fit in view.

    The focal point is the centre of the points' bounding box; the distance is the smallest
    that keeps every point inside the vertical ``view_angle`` (degrees) and the horizontal
    angle implied by ``aspect`` (width / height), with ``margin`` extra room (a factor) and
    ``pad`` metres around each point (for the joint spheres and the head).
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    back = direction / np.linalg.norm(direction)
    right = np.cross(-back, UP)
    right /= np.linalg.norm(right)
    up = np.cross(right, -back)
    rel = pts - centre
    x, y, depth = rel @ right, rel @ up, rel @ back
    tan_v = np.tan(np.radians(view_angle) / 2.0)
    tan_h = tan_v * aspect
    needed = np.maximum(
        depth + pad + margin * (np.abs(y) + pad) / tan_v,
        depth + pad + margin * (np.abs(x) + pad) / tan_h,
    )
    distance = max(float(needed.max()), 0.5)
    return CameraPose(position=centre + distance * back, focal_point=centre)
