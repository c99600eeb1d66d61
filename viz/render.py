"""Frames of the pyvista skeleton scene as images, for the corpus's contact sheet (``moattn corpus --gallery
--renderer pyvista``, ``viz.sheet.pyvista_gallery``).

Pictures of a motion as files (GIF, MP4, PNG) are the studio's exporter's, ``viz.export.write_picture`` (drawn by
``viz.flat``, no VTK): the studio's Export buttons, ``moattn generate --out``, ``moattn render`` and every
command's ``--render`` write through it.

One ``SkeletonScene`` is built and reused for all frames (points updated in place). ``joints`` is one motion
(T, 22, 3) or a mapping role -> motion (several skeletons side by side); extra keyword options go to
``SkeletonScene`` (``follow``, ``azimuth``, ``colors``, ``title``, ``frame_label``, ...).
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np

from viz.scene import SkeletonScene

__all__ = ["render_frames"]

Motion = np.ndarray | Mapping[str, np.ndarray]


@contextmanager
def _scene(joints: Motion, *, size: tuple[int, int], options: Mapping[str, Any]) -> Iterator[SkeletonScene]:
    scene = SkeletonScene(joints, size=size, **options)
    try:
        yield scene
    finally:
        scene.close()


def _frame_indices(n_frames: int, *, every: int, frames: Sequence[int] | None) -> list[int]:
    if frames is not None:
        idx = [int(k) for k in frames]
        bad = [k for k in idx if not 0 <= k < n_frames]
        if bad:
            raise IndexError(f"frames {bad} out of range 0..{n_frames - 1}")
        return idx
    if every < 1:
        raise ValueError(f"every must be >= 1, got {every}")
    return list(range(0, n_frames, every))


def render_frames(
    joints: Motion,
    *,
    every: int = 1,
    frames: Sequence[int] | None = None,
    size: tuple[int, int] = (320, 240),
    **scene_options: Any,
) -> list[np.ndarray]:
    """Images (H, W, 3) uint8 of frames 0, every, 2*every, ... (or exactly ``frames``)."""
    with _scene(joints, size=size, options=scene_options) as scene:
        images = []
        for k in _frame_indices(scene.n_frames, every=every, frames=frames):
            scene.set_frame(k)
            images.append(scene.screenshot())
        return images
