"""What the in-browser 3-D viewer draws: a ``SceneSpec`` (motions by role and how to show them), and the
compact message the browser receives for it.

The browser draws the skeletons itself (``app/components/viewer3d/``), so the server sends a
scene once per change, never per frame: joints as little-endian float32 (offsets applied), colours
as uint8 per joint or per frame, the drawn guides, and optionally the denoising history (the x̂0
motion of every sampling step, int16 millimetres). A 10-s motion is ~70 KB; three are ~200 KB.
Every message also describes what the page cannot know by itself (:func:`skeleton_payload`): the skeleton (its
parents, which joints are the pelvis and the head, the sizes of joints and bones), the floor's tile and colours and
the field of view; the page's JavaScript holds no copy of them.

Colours and layout come from ``viz`` (the same palette, left/right shading, plasma word colours and
side-by-side offsets as the exported pictures), so the browser and the files agree.
"""
from __future__ import annotations

import base64
import time
from dataclasses import dataclass

import numpy as np

from app.generation import Denoising
from engine.skeleton import JOINT_INDEX, JOINT_NAMES, PARENTS
from engine.units import FPS

SPACING = 0.6  # metres between side-by-side skeletons (as in the exported pictures)
JOINT_RADIUS = 0.032
HEAD_RADIUS = 0.07
BONE_RADIUS = 0.02
ELEVATION = 18.0  # degrees above the horizon of the default view
AZIMUTH_FROM_FACING = 30.0  # the default 3/4 front view, degrees from the body's facing
FLOOR_TILE = 0.5  # metres: the checker floor's tiles (as in the exported pictures)


@dataclass(frozen=True, eq=False)
class SceneSpec:
    """What the viewer shows: roles -> joints, and how to draw them."""

    motions: tuple[tuple[str, np.ndarray], ...]
    frame_values: np.ndarray | None = None  # (T,) colours for the first role (e.g. a word's attention)
    role_colors: tuple[tuple[str, np.ndarray], ...] = ()  # role -> (T, 3) uint8 per-frame colours (wins over values)
    title: str = ""
    guides: tuple[tuple[str, str, np.ndarray], ...] = ()  # (role, colour, (N, 3) points): target paths drawn in 3-D
    together: bool = False  # every role in one shared space (a duet), not side by side
    denoising: Denoising | None = None  # of the first role
    legend: dict | None = None  # what the colours mean (app.viewer.legend.scene_legend), drawn in the view's corner

    @property
    def roles(self) -> tuple[str, ...]:
        return tuple(r for r, _ in self.motions)

    @property
    def n_frames(self) -> int:
        return max(len(j) for _, j in self.motions)

    def same_motions(self, other: "SceneSpec | None") -> bool:
        return other is not None and other.together == self.together and len(other.motions) == len(self.motions) and all(
            ra == rb and ja is jb for (ra, ja), (rb, jb) in zip(self.motions, other.motions))


def b64(array: np.ndarray, dtype: str) -> str:
    """Little-endian bytes of ``array`` as ``dtype``, base64 (what the browser's typed arrays read)."""
    return base64.b64encode(np.ascontiguousarray(array, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()).decode()


def offsets(spec: SceneSpec) -> dict[str, np.ndarray]:
    """Role -> (3,) shift: none in a shared space (a duet), else side by side along X."""
    from viz.layout import side_by_side_offsets

    if spec.together:
        return {r: np.zeros(3) for r in spec.roles}
    return side_by_side_offsets({r: np.asarray(j, dtype=np.float64) for r, j in spec.motions}, spacing=SPACING)


def _frame_colors(spec: SceneSpec, index: int, role: str, n: int) -> np.ndarray | None:
    """(n, 22, 3) uint8 colours per frame and joint for one role, or None (its role colours).

    A role's ``role_colors`` are (T, 3) for the whole skeleton or (T, 22, 3) per joint, resampled to its
    frames; the first role may be coloured by ``frame_values`` (plasma, from 0) instead."""
    from viz.colors import rgb_array, values_to_rgb

    colored = dict(spec.role_colors)
    if role in colored:
        rgb = rgb_array(np.asarray(colored[role]))
        rgb = rgb[np.linspace(0, len(rgb) - 1, n).round().astype(int)]
    elif index == 0 and spec.frame_values is not None:
        values = np.asarray(spec.frame_values, dtype=np.float64)
        if len(values) != n:
            values = np.interp(np.arange(n), np.linspace(0, n - 1, len(values)), values)
        hi = float(values.max()) if values.size and values.max() > 0 else 1.0
        rgb = values_to_rgb(values, cmap="plasma", clim=(0.0, hi))
    else:
        return None
    if rgb.ndim == 2:  # one colour per frame: the whole skeleton
        rgb = np.repeat(rgb[:, None], len(PARENTS), axis=1)
    if rgb.shape != (n, len(PARENTS), 3):
        raise ValueError(f"frame colours for {role!r} must be (T, 3) or (T, {len(PARENTS)}, 3), got {rgb.shape}")
    return rgb


def scene_message(spec: SceneSpec | None, *, key: int, job: tuple[float, float] | None = None) -> dict:
    """The viewer's ``scene`` property for ``spec`` (``key`` grows with every new set of motions); ``job``: when
    the job behind it started and ended (wall clock), which ``moattn bench --app`` compares with the page's clock."""
    from viz.colors import ROLE_PALETTE, color_to_rgb, default_joint_colors

    if spec is None:
        return {"key": key, "roles": [], "n_frames": 0, "title": "", **skeleton_payload()}
    shifts = offsets(spec)
    roles = []
    for i, (role, joints) in enumerate(spec.motions):
        joints = np.asarray(joints, dtype=np.float64) + shifts[role]  # (T, 22, 3)
        base = ROLE_PALETTE[i % len(ROLE_PALETTE)]
        per_frame = _frame_colors(spec, i, role, len(joints))
        roles.append({
            "name": role,
            "n_frames": int(len(joints)),
            "joints": b64(joints, "f4"),
            "joint_colors": default_joint_colors(base).reshape(-1).tolist(),
            "frame_colors": None if per_frame is None else b64(per_frame, "u1"),
        })
    guides = []
    for role, color, points in spec.guides:
        pts = np.asarray(points, dtype=np.float64)
        if role not in shifts or pts.ndim != 2 or len(pts) < 2 or not np.isfinite(pts).all():
            continue
        guides.append({"role": role, "color": color_to_rgb(color).tolist(), "points": b64(pts + shifts[role], "f4"),
                       "n": int(len(pts))})
    message = {
        "key": key,
        "title": spec.title,
        "n_frames": spec.n_frames,
        **_geometry(np.asarray(spec.motions[0][1])[0]),
        "together": spec.together,
        "roles": roles,
        "guides": guides,
        "denoising": None,
        "legend": spec.legend,
        "job": None if job is None else {"started": job[0], "ended": job[1]},
        "sent_at": time.time(),  # wall clock: the bench splits a result's latency into server and page
    }
    d = spec.denoising
    if d is not None and len(d.steps):
        shift = shifts[spec.motions[0][0]]
        mm = np.clip(np.round((np.asarray(d.joints, dtype=np.float64) + shift) * 1000.0), -32767, 32767)
        message["denoising"] = {"steps": list(d.steps), "num_steps": d.num_steps, "recorded": list(d.recorded),
                                "n_frames": int(d.joints.shape[1]), "joints_mm": b64(mm, "i2")}
    return message


def skeleton_payload() -> dict:
    """What the page draws with and cannot know by itself, in every message: the skeleton (``parents``: joint ->
    parent, -1 for the root; ``pelvis`` and ``head``: joint indices; ``radii`` in metres; joint ``names``), the
    frame rate, the checker floor (``tile`` in metres, two RGB ``colors``) and the vertical field of view (degrees)."""
    from viz.colors import FLOOR_COLORS
    from viz.flat import VIEW_ANGLE

    return {"fps": FPS,
            "skeleton": {"parents": list(PARENTS), "names": list(JOINT_NAMES), "pelvis": JOINT_INDEX["pelvis"],
                         "head": JOINT_INDEX["head"],
                         "radii": {"joint": JOINT_RADIUS, "head": HEAD_RADIUS, "bone": BONE_RADIUS}},
            "floor": {"tile": FLOOR_TILE, "colors": [list(c) for c in FLOOR_COLORS]},
            "fov": VIEW_ANGLE}


def _geometry(first_pose: np.ndarray) -> dict:
    """What every message with a motion shares: :func:`skeleton_payload` and the default 3/4 front view of
    ``first_pose`` (22, 3)."""
    from viz.camera import facing_azimuth

    return {**skeleton_payload(),
            "azimuth": facing_azimuth(np.asarray(first_pose, dtype=np.float64)) + AZIMUTH_FROM_FACING,
            "elevation": ELEVATION}


def preview_message(joints: np.ndarray, *, key: int, step: int, num_steps: int, title: str) -> dict:
    """One live x̂0 motion (T, 22, 3) while sampling: a custom message that stands in for the scene until the
    result arrives; coloured as the first role of a scene."""
    from viz.colors import ROLE_PALETTE, default_joint_colors

    joints = np.asarray(joints, dtype=np.float64)
    mm = np.clip(np.round(joints * 1000.0), -32767, 32767)
    return {"type": "preview", "key": key, "step": int(step), "num_steps": int(num_steps), "title": title,
            "n_frames": int(len(joints)), "joints_mm": b64(mm, "i2"),
            "joint_colors": default_joint_colors(ROLE_PALETTE[0]).reshape(-1).tolist(), **_geometry(joints[0])}
