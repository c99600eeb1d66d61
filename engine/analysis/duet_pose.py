"""How two people of a duet stand to each other (read by the Duet tab's summary and the duet bench)."""
from __future__ import annotations

import numpy as np

from engine.representation import facing_direction


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
