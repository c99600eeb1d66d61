"""Visualisation: pyvista skeleton scenes (built once, updated in place) and renders.

Submodules: ``scene`` (``SkeletonScene``), ``render`` (the scene's frames as images, for contact sheets),
``flat`` (``FlatRenderer``: the same picture drawn in 2D without VTK), ``export`` (``write_picture``: the one
exporter of GIF/MP4/PNG pictures, the studio's Export and every command's picture), ``sheet`` (contact sheets),
``colors``, ``geometry``, ``camera``. The names below are imported lazily so that ``import viz`` does not load VTK.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

_EXPORTS = {
    "SkeletonScene": "viz.scene",
    "render_frames": "viz.render",
    "write_picture": "viz.export",
    "contact_sheet": "viz.sheet",
    "FlatRenderer": "viz.flat",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'viz' has no attribute {name!r}")
