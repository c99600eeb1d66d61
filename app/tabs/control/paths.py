"""Paths as the Control tab draws them: the controls' names and colours, a freehand stroke thinned to points, its
length, and the example paths (an S on the floor; a letter per wrist, from engine.methods.drawn_paths)."""
from __future__ import annotations

import numpy as np

from engine.methods.control_options import CONTROLS, LABELS  # noqa: F401 (the engine's names, re-exported)
from engine.methods.drawn_paths import LETTER_DEPTH

WRISTS = ("left_wrist", "right_wrist")
WRIST_DEPTH = LETTER_DEPTH  # m in front of the body: the front-view canvas draws on this plane
MIN_SPACING = 0.15  # m between kept points of a freehand stroke
MAX_POINTS = 80
COLORS = {"root": "#d62728", "left_wrist": "#9467bd", "right_wrist": "#e377c2"}  # red, purple, pink
ROOT_COLOR = COLORS["root"]
COLOR_NAMES = {"root": "red", "left_wrist": "purple", "right_wrist": "pink"}
DEFAULT_ROOT = ((0.0, 0.0), (0.8, 1.5), (0.0, 3.0), (-0.8, 4.5))  # an S on the floor, 4.5 m ahead
EXAMPLE_LETTERS = {"left_wrist": "L", "right_wrist": "O"}  # the front view's example: a letter per hand


def example_wrist(name: str) -> list[tuple[float, float]]:
    """The example path of a wrist in the front view: its letter, as engine.methods.drawn_paths writes it."""
    from engine.methods.drawn_paths import letter_outline

    xy = letter_outline(EXAMPLE_LETTERS[name], side=name.split("_")[0])
    return [(round(float(x), 4), round(float(y), 4)) for x, y in xy]


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
