"""Paths as the Control tab draws them: the controls' names, a freehand stroke thinned to points, its length."""
from __future__ import annotations

import numpy as np

LABELS = {"root": "root path", "left_wrist": "left wrist", "right_wrist": "right wrist"}
WRISTS = ("none", "left_wrist", "right_wrist")
WRIST_DEPTH = 0.35  # m in front of the body: the front-view canvas draws on this plane
MIN_SPACING = 0.15  # m between kept points of a freehand stroke
MAX_POINTS = 80
ROOT_COLOR, WRIST_COLOR = "#d62728", "#9467bd"
DEFAULT_ROOT = ((0.0, 0.0), (0.8, 1.5), (0.0, 3.0), (-0.8, 4.5))  # an S on the floor, 4.5 m ahead


def thin(points, *, spacing: float = MIN_SPACING, limit: int = MAX_POINTS) -> list[tuple[float, ...]]:
    """A drawn stroke as path points: consecutive points at least ``spacing`` apart, at most ``limit`` of them.

    Non-finite points are kept (the engine names them); the last point is always kept.
    """
    p = [tuple(float(v) for v in q) for q in points]
    if len(p) <= 2:
        return p
    out = [p[0]]
    for q in p[1:-1]:
        if not all(np.isfinite(q)) or not all(np.isfinite(out[-1])) or \
                np.linalg.norm(np.subtract(q, out[-1])) >= spacing:
            out.append(q)
    if np.linalg.norm(np.subtract(p[-1], out[-1])) > 1e-9 or len(out) == 1:
        out.append(p[-1])
    if len(out) > limit:
        keep = np.unique(np.linspace(0, len(out) - 1, limit).round().astype(int))
        out = [out[k] for k in keep]
    return out


def path_length(points) -> float:
    """Metres along a path (0 for fewer than 2 points)."""
    p = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if p.ndim == 2 and len(p) > 1 else 0.0
