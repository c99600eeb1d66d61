"""Visualisation: pyvista skeleton scenes (built once, updated in place) and renders.

Submodules: ``scene`` (``SkeletonScene``), ``render`` (PNG/GIF/MP4, frame lists), ``flat`` (``FlatRenderer``:
the same picture drawn in 2D without VTK, for the studio's fast GIF/MP4 exports),
``sheet`` (contact sheets), ``colors``, ``geometry``, ``camera``. The names below are
imported lazily so that ``import viz`` does not load VTK.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "SkeletonScene": "viz.scene",
    "render_png": "viz.render",
    "render_gif": "viz.render",
    "render_mp4": "viz.render",
    "render_file": "viz.render",
    "render_frames": "viz.render",
    "contact_sheet": "viz.sheet",
    "FlatRenderer": "viz.flat",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'viz' has no attribute {name!r}")
