"""Import a BVH file as a 22-joint HumanML3D motion (metres, Y up, 20 fps by default).

Pipeline: parse (strict) -> forward kinematics of every BVH joint -> match joint names
(:mod:`engine.io.joint_names`) -> turn the file's up axis onto +Y -> derive missing joints
(:mod:`engine.io.joint_fill`) -> unit from the body's size -> resample -> optionally give the
body our bone lengths -> optionally canonicalise (floor at y=0 under the clip's standing feet,
root at the XZ origin, facing +Z at the first frame).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from engine.io.bvh_parse import BVHData, read_bvh
from engine.io.errors import DEFAULT_MAX_BYTES, BVHError
from engine.io.joint_fill import assemble_joints
from engine.io.joint_names import ESSENTIAL, match_joint_names, missing_essentials
from engine.io.retarget import (
    UNITS,
    canonical_placement,
    detect_unit,
    detect_up_axis,
    resample,
    retarget_bone_lengths,
    snap_fps,
    standing_height,
    stature_chain,
    up_axis_rotation,
)
from engine.skeleton import JOINT_INDEX

_EXAMPLES = {  # names the matcher accepts, for error messages (left side; the right is mirrored)
    "hip": "LeftUpLeg / LeftHip / L_Hip / left_hip / Bip01 L Thigh",
    "knee": "LeftLeg / LeftKnee / L_Knee / Bip01 L Calf",
    "ankle": "LeftFoot / LeftAnkle / L_Ankle / left_ankle",
    "shoulder": "LeftArm / LeftUpArm / L_Shoulder / Bip01 L UpperArm",
    "elbow": "LeftForeArm / LeftElbow / L_Elbow / Bip01 L Forearm",
    "wrist": "LeftHand / LeftWrist / L_Wrist / left_wrist",
    "head": "Head",
}


def _example_names(our_name: str) -> str:
    side, _, part = our_name.rpartition("_")
    text = _EXAMPLES[part]
    if side == "right":
        for left, right in (("Left", "Right"), ("L_", "R_"), ("left_", "right_"), (" L ", " R ")):
            text = text.replace(left, right)
    return text


@dataclass(frozen=True)
class BVHImport:
    """An imported motion and what was found out on the way.

    joints:        (T, 22, 3) float32 positions in metres, Y up, at ``fps``
    fps:           frame rate of ``joints``
    source_fps:    frame rate of the file (snapped to a whole number when within 0.05 %)
    source_frames: number of frames in the file
    unit:          detected (or given) unit of the file: "m", "cm", "mm", "in", "ft", "cmu", or
                   "custom" when a scale was passed
    scale:         metres per file unit
    up_axis:       the file's up axis ("+Y" for almost every BVH)
    mapping:       our joint name -> the BVH joint it came from, or "derived: ..." how it was made
    retargeted:    whether the bones were given our skeleton's lengths
    canonical:     whether the motion was put on the floor, at the origin, facing +Z
    source:        the file name
    """

    joints: np.ndarray
    fps: float
    source_fps: float
    source_frames: int
    unit: str
    scale: float
    up_axis: str
    mapping: dict[str, str] = field(default_factory=dict)
    retargeted: bool = True
    canonical: bool = True
    source: str | None = None

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return (len(self.joints) - 1) / self.fps

    @property
    def height(self) -> float:
        """Head-joint height (m) of this body standing straight (see :func:`standing_height`)."""
        return standing_height(self.joints)


def import_bvh(
    path: str | os.PathLike[str],
    *,
    fps: float = 20.0,
    retarget: bool = True,
    canonical: bool = True,
    unit: str | float | None = None,
    max_bytes: int = DEFAULT_MAX_BYTES,
) -> BVHImport:
    """Read a BVH file and turn it into a 22-joint motion; see :class:`BVHImport`.

    fps:       output frame rate (linear interpolation of positions).
    retarget:  give the body our skeleton's bone lengths (directions kept, root path scaled by
               the leg-length ratio) so it matches the model's body; False keeps the file's body.
    canonical: floor at y=0 under the standing feet (:func:`contact_floor`), root starting at
               the XZ origin, facing +Z; False keeps the file's placement (only units and up
               axis are changed).
    unit:      None to detect from the body's size, a unit name ("m", "cm", "in", ...) or metres
               per file unit.
    """
    data = read_bvh(path, max_bytes=max_bytes)
    return import_bvh_data(data, fps=fps, retarget=retarget, canonical=canonical, unit=unit)


def load_bvh(
    path: str | os.PathLike[str],
    *,
    fps: float = 20.0,
    retarget: bool = True,
    canonical: bool = True,
    unit: str | float | None = None,
) -> np.ndarray:
    """Joint positions (T, 22, 3) float32 of a BVH file; :func:`import_bvh` gives the metadata too."""
    return import_bvh(path, fps=fps, retarget=retarget, canonical=canonical, unit=unit).joints


def import_bvh_data(
    data: BVHData,
    *,
    fps: float = 20.0,
    retarget: bool = True,
    canonical: bool = True,
    unit: str | float | None = None,
) -> BVHImport:
    """:func:`import_bvh` for an already parsed file.

    Whatever the file's values, the result is finite joints or a :class:`BVHError` (values so large that the
    positions overflow are refused, not returned as inf/NaN); ``fps`` and ``unit`` errors are ``ValueError``.
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if isinstance(unit, str) and unit not in UNITS:
        raise ValueError(f"unknown unit {unit!r}; use one of {', '.join(UNITS)} or metres per unit")
    found = match_joint_names(data)
    missing = missing_essentials(found)
    if missing:
        hints = "; ".join(f"{name} (e.g. {_example_names(name)})" for name in missing)
        present = ", ".join(n for n, e in zip(data.names, data.end_site) if not e)
        raise BVHError(
            f"cannot map this skeleton onto the 22 joints: no joint found for {hints}. "
            f"Essential joints are {', '.join(ESSENTIAL)}. Joints in the file: {present}",
            source=data.source,
        )
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            return _import(data, found, fps=fps, retarget=retarget, canonical=canonical, unit=unit)
    except BVHError:
        raise
    except ValueError as exc:  # the file's content (e.g. a degenerate body) failed a later step
        raise BVHError(f"cannot import this motion: {exc}", source=data.source) from None


def _overflow(array: np.ndarray, data: BVHData, what: str) -> None:
    if not np.isfinite(array).all():
        raise BVHError(f"the {what} overflow (NaN or infinite): the file's OFFSET or channel values are too large",
                       source=data.source)


def _import(data: BVHData, found: dict, *, fps: float, retarget: bool, canonical: bool,
            unit: str | float | None) -> BVHImport:
    positions = data.world_positions()
    _overflow(positions, data, "joint positions")
    # up axis from the joints found by name, before anything assumes Y up
    probe = np.zeros((len(positions), len(JOINT_INDEX), 3))
    for name in ("head", "left_ankle", "right_ankle"):
        probe[:, JOINT_INDEX[name]] = positions[:, found[name]]
    up_axis = detect_up_axis(probe)
    if up_axis != "+Y":
        positions = positions @ up_axis_rotation(up_axis).T
    joints, mapping = assemble_joints(data, positions, found)
    _overflow(joints, data, "joint positions")

    if unit is None:
        try:
            unit_name, scale = detect_unit(stature_chain(joints))
        except ValueError as exc:
            raise BVHError(str(exc), source=data.source) from None
    elif isinstance(unit, str):
        unit_name, scale = unit, UNITS[unit]
    else:
        unit_name, scale = "custom", float(unit)
    joints = joints * scale

    source_fps = snap_fps(data.fps)
    joints = resample(joints, source_fps, fps)
    if retarget:
        joints = retarget_bone_lengths(joints)
    if canonical:
        joints = canonical_placement(joints, fps=fps)
    joints = joints.astype(np.float32)
    _overflow(joints, data, "joint positions in metres")
    return BVHImport(
        joints=joints,
        fps=float(fps),
        source_fps=source_fps,
        source_frames=data.num_frames,
        unit=unit_name,
        scale=scale,
        up_axis=up_axis,
        mapping=mapping,
        retargeted=retarget,
        canonical=canonical,
        source=data.source,
    )
