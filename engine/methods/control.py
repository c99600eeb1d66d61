"""Control features (PriorMDM): which feature dims a control model receives noise-free.

- ``root``: the root trajectory, dims 0-2 (rotation velocity and the XZ linear velocity, no height);
- ``left_wrist`` / ``right_wrist``: that wrist's root-relative position (its 3 ric dims).
"""
from __future__ import annotations

import numpy as np

from engine.representation import SLICES
from engine.skeleton import JOINT_INDEX

CONTROLS = ("root", "left_wrist", "right_wrist")


def control_dims(name: str) -> np.ndarray:
    if name == "root":
        return np.arange(SLICES["root_lin_vel"].stop)
    if name in ("left_wrist", "right_wrist"):
        j = JOINT_INDEX[name]
        start = SLICES["ric"].start + 3 * (j - 1)
        return np.arange(start, start + 3)
    raise ValueError(f"unknown control {name!r}: choose from {', '.join(CONTROLS)}")
