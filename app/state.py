"""One session's state: the motion being shown, the playhead, and user-facing messages."""
from __future__ import annotations

import numpy as np
import param


class StudioState(param.Parameterized):
    """Everything a session's views read; each browser session gets its own instance."""

    joints = param.Array(default=None, doc="the current motion (T, 22, 3), metres, 20 fps")
    title = param.String(default="", doc="what the motion is (file name or prompt)")
    frame = param.Integer(default=0, bounds=(0, None), doc="the playhead")
    message = param.String(default="", doc="last status message for the user")
    error = param.String(default="", doc="last error for the user (shown as a notification)")

    @property
    def n_frames(self) -> int:
        return 0 if self.joints is None else len(self.joints)

    def show_motion(self, joints: np.ndarray, *, title: str) -> None:
        joints = np.asarray(joints, dtype=np.float32)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3) or len(joints) < 1:
            raise ValueError(f"a motion must have shape (T, 22, 3), got {joints.shape}")
        with param.parameterized.batch_call_watchers(self):
            self.frame = 0
            self.joints = joints
            self.title = title
            self.message = f"{title}: {len(joints)} frames ({len(joints) / 20:.1f} s)"
