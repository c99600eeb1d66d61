"""How two people of a duet stand to each other (read by the Duet tab's summary, the duet bench and the spacing
rule of ``engine.methods.duet_spacing``)."""
from __future__ import annotations

import numpy as np

from engine.representation import facing_direction
from engine.skeleton import JOINT_INDEX

# a person's torso centre: the horizontal mean of these joints (pelvis and spine)
TORSO = tuple(JOINT_INDEX[n] for n in ("pelvis", "spine1", "spine2", "spine3"))
SHOULDERS = (JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"])
# the torso seen from above, for telling interpenetration: an ellipse around the torso centre, half as wide as
# the shoulder joints are apart (+ the deltoids) and TORSO_HALF_DEPTH from chest to back
TORSO_HALF_DEPTH, DELTOID = 0.11, 0.03


def face_each_other(joints: np.ndarray, *, frame: int | None = None, within_deg: float = 45.0) -> bool:
    """Whether each person faces the other (facing within ``within_deg`` of the direction to them)."""
    k = joints.shape[1] // 2 if frame is None else frame
    ok = True
    for me, other in ((0, 1), (1, 0)):
        face = facing_direction(joints[me, k])
        to = joints[other, k, 0] - joints[me, k, 0]
        to[1] = 0.0
        to = to / max(np.linalg.norm(to), 1e-9)
        ok &= float(np.degrees(np.arccos(np.clip(face @ to, -1, 1)))) < within_deg
    return bool(ok)


def torso_centres(joints: np.ndarray) -> np.ndarray:
    """(..., T, 22, 3) -> (..., T, 2): each frame's torso centre on the floor (x, z)."""
    return np.asarray(joints, dtype=np.float64)[..., list(TORSO), :][..., [0, 2]].mean(-2)


def torso_distance(joints: np.ndarray) -> np.ndarray:
    """(2, T, 22, 3) -> (T,): horizontal distance (m) between the two people's torso centres."""
    c = torso_centres(joints)
    return np.hypot(*(c[1] - c[0]).T)


def torso_reach(joints: np.ndarray) -> np.ndarray:
    """(2, T, 22, 3) -> (T,): how far the two torsos reach towards each other (m), summed: each torso an ellipse
    seen from above, ``TORSO_HALF_DEPTH`` from chest to back and as wide as its shoulders, measured along the line
    between the torso centres. Torso centres closer than this interpenetrate."""
    joints = np.asarray(joints, dtype=np.float64)
    v = np.diff(torso_centres(joints), axis=0)[0]  # (T, 2) a -> b
    u = v / np.maximum(np.hypot(*v.T), 1e-9)[:, None]
    reach = np.zeros(len(v))
    for p, sign in ((0, 1.0), (1, -1.0)):
        face = facing_direction(joints[p])[:, [0, 2]]
        face = face / np.maximum(np.hypot(*face.T), 1e-9)[:, None]
        along = np.clip(np.abs((sign * u * face).sum(-1)), 0.0, 1.0)  # cos(facing, towards the other)
        half_width = 0.5 * np.linalg.norm(joints[p, :, SHOULDERS[0]] - joints[p, :, SHOULDERS[1]], axis=-1) + DELTOID
        reach += np.sqrt((TORSO_HALF_DEPTH * along) ** 2 + half_width ** 2 * (1.0 - along ** 2))
    return reach


def torso_gap(joints: np.ndarray) -> np.ndarray:
    """(2, T, 22, 3) -> (T,): room (m) left between the two torsos along the line between their centres
    (``torso_distance`` - ``torso_reach``); below 0 the torsos interpenetrate."""
    return torso_distance(joints) - torso_reach(joints)


def interpenetrate(joints: np.ndarray) -> np.ndarray:
    """(2, T, 22, 3) -> (T,) bool: the two torsos overlap (``torso_gap`` below 0)."""
    return torso_gap(joints) < 0.0
