"""Motion files in and out: one entry point each for the CLI (``moattn convert``) and the app.

- :func:`load_motion` reads ``.bvh`` (imported, retargeted to our skeleton, 20 fps, canonical)
  or ``.npy`` (joints (T, 22, 3) as they are, or HumanML3D features (T, 263) recovered to
  joints) and always returns joints (T, 22, 3) float32 in metres.
- :func:`save_motion` writes joints as ``.npy`` (joints, or features with ``to="vecs"``), as ``.bvh``
  or as an animated glTF binary ``.glb`` (:mod:`engine.io.glb`; written only, never read).
- :func:`pick_window` keeps the window ``start`` / ``seconds`` of a longer motion (``engine.io.window``: the
  one rule for the CLI's ``--start`` / ``--seconds``, the app's import and the model's length limit).

Errors are :class:`MotionIOError` (a ``ValueError``); BVH problems are :class:`BVHError`. What a file may
declare (frames, duration, frame time, joints, depth) is limited and checked before anything is allocated;
the limits are stated in :mod:`engine.io.errors` (a file holds at most MAX_IMPORT_SECONDS of motion).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

import numpy as np

from engine.io.bvh import BVHData, BVHImport, format_bvh, import_bvh, load_bvh, read_bvh, save_bvh
from engine.io.errors import DEFAULT_MAX_BYTES, MAX_IMPORT_SECONDS, BVHError, MotionIOError
from engine.io.glb import format_glb, save_glb
from engine.io.npy import classify_motion_array, load_npy, save_npy
from engine.io.window import pick_window, seconds_of, seconds_number, window_slice
from engine.representation import features_to_joints, joints_to_features

SUPPORTED_SUFFIXES: tuple[str, ...] = (".bvh", ".npy")  # what load_motion reads
SAVE_SUFFIXES: tuple[str, ...] = SUPPORTED_SUFFIXES + (".glb",)  # what save_motion writes


def _suffix(path: Path, allowed: tuple[str, ...] = SUPPORTED_SUFFIXES) -> str:
    suffix = path.suffix.lower()
    if suffix not in allowed:
        raise MotionIOError(
            f"unsupported motion file type {path.suffix or '(no extension)'!r} for {path.name}; "
            f"use one of {', '.join(allowed)}"
        )
    return suffix


def load_motion(path: str | os.PathLike[str], *, fps: float = 20.0, retarget: bool = True) -> np.ndarray:
    """Joints (T, 22, 3) float32 from a ``.bvh`` or ``.npy`` file (dispatch on the extension).

    ``fps`` and ``retarget`` apply to BVH files (see :func:`import_bvh`); ``.npy`` files are
    taken to be at 20 fps already.
    """
    path = Path(path)
    if _suffix(path) == ".bvh":
        return load_bvh(path, fps=fps, retarget=retarget)
    kind, array = load_npy(path)
    if kind == "vecs":
        array = features_to_joints(array.astype(np.float32))
    return np.ascontiguousarray(array, dtype=np.float32)


def save_motion(
    joints: np.ndarray,
    path: str | os.PathLike[str],
    *,
    to: Literal["joints", "vecs"] = "joints",
    fps: float = 20.0,
) -> Path:
    """Write joints (T, 22, 3) to ``.npy`` (``to="joints"``, or ``"vecs"`` for (T-1, 263) features), ``.bvh``
    or ``.glb`` (an animated glTF binary, :func:`engine.io.glb.save_glb`)."""
    path = Path(path)
    suffix = _suffix(path, SAVE_SUFFIXES)
    if to not in ("joints", "vecs"):
        raise MotionIOError(f"to must be 'joints' or 'vecs', got {to!r}")
    kind, checked = classify_motion_array(joints, name="the motion to save")
    if kind != "joints":
        raise MotionIOError(f"save_motion takes joints (T, 22, 3), got shape {np.shape(joints)}")
    if suffix == ".bvh":
        if to != "joints":
            raise MotionIOError("a .bvh file holds joints; to='vecs' is only for .npy")
        return save_bvh(checked, path, fps=fps)
    if suffix == ".glb":
        if to != "joints":
            raise MotionIOError("a .glb file holds joints; to='vecs' is only for .npy")
        return save_glb(checked, path, fps=fps)
    if to == "vecs":
        if len(checked) < 2:
            raise MotionIOError("features need at least 2 frames of joints")
        return save_npy(path, joints_to_features(checked), kind="vecs")
    return save_npy(path, checked, kind="joints")


__all__ = [
    "BVHData", "BVHError", "BVHImport", "DEFAULT_MAX_BYTES", "MAX_IMPORT_SECONDS", "MotionIOError",
    "SAVE_SUFFIXES", "SUPPORTED_SUFFIXES",
    "format_bvh", "format_glb", "import_bvh", "load_bvh", "load_motion", "load_npy", "pick_window", "read_bvh",
    "save_bvh", "save_glb",
    "save_motion", "save_npy", "seconds_number", "seconds_of", "window_slice",
]
