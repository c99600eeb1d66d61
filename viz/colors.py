"""Colours for skeleton scenes: role palette, default per-joint colours, colormaps.

Every colour that reaches a mesh is an ``uint8`` RGB array; this module turns the
user-facing forms (names, hex strings, float tuples in 0..1, arrays) into that.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import to_rgb

from engine.skeleton import JOINT_NAMES

ColorLike = str | Sequence[float] | np.ndarray

#: Base colours given to roles in order of appearance (blue, orange, green, purple, red, teal).
ROLE_PALETTE: tuple[str, ...] = ("#3a6fd8", "#e8772e", "#2f9e5a", "#8e5bd1", "#d64545", "#1f9fa8")

FLOOR_COLORS: tuple[tuple[int, int, int], tuple[int, int, int]] = ((232, 232, 228), (206, 208, 204))

_LEFT = np.array([name.startswith("left_") for name in JOINT_NAMES])
_RIGHT = np.array([name.startswith("right_") for name in JOINT_NAMES])


def color_to_rgb(color: ColorLike) -> np.ndarray:
    """One colour (name, hex, floats in 0..1 or ints in 0..255) as an ``uint8`` array of 3."""
    if isinstance(color, str):
        return np.round(np.asarray(to_rgb(color)) * 255).astype(np.uint8)
    arr = np.asarray(color)
    if arr.shape != (3,):
        raise ValueError(f"expected one RGB colour, got shape {arr.shape}")
    return rgb_array(arr)


def rgb_array(colors: np.ndarray) -> np.ndarray:
    """An array of RGB colours (..., 3) as ``uint8``.

    Float arrays are read as 0..1 (clipped); integer arrays as 0..255.
    """
    arr = np.asarray(colors)
    if arr.shape[-1:] != (3,):
        raise ValueError(f"colours must end in a dimension of 3 (RGB), got shape {arr.shape}")
    if np.issubdtype(arr.dtype, np.floating):
        if not np.all(np.isfinite(arr)):
            raise ValueError("colours contain NaN or inf")
        return np.round(np.clip(arr, 0.0, 1.0) * 255).astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer) or arr.dtype == bool:
        return np.clip(arr, 0, 255).astype(np.uint8)
    raise ValueError(f"unsupported colour dtype {arr.dtype}")


def mix(rgb: np.ndarray, other: ColorLike, amount: float) -> np.ndarray:
    """Blend ``uint8`` colours towards ``other`` by ``amount`` (0 = unchanged, 1 = other)."""
    target = color_to_rgb(other).astype(np.float64)
    out = rgb.astype(np.float64) * (1.0 - amount) + target * amount
    return np.round(out).astype(np.uint8)


def default_joint_colors(base: ColorLike) -> np.ndarray:
    """Per-joint colours (22, 3) from a base colour: left limbs lighter, right limbs darker.

    The shading lets a viewer tell the body's left from its right at a glance.
    """
    rgb = np.repeat(color_to_rgb(base)[None], len(JOINT_NAMES), axis=0)
    rgb[_LEFT] = mix(rgb[_LEFT], "white", 0.35)
    rgb[_RIGHT] = mix(rgb[_RIGHT], "black", 0.25)
    return rgb


def values_to_rgb(
    values: np.ndarray, *, cmap: str = "viridis", clim: tuple[float, float] | None = None
) -> np.ndarray:
    """Map scalars (any shape) through a matplotlib colormap to ``uint8`` RGB (shape + (3,)).

    ``clim`` defaults to the values' min and max; a constant array maps to the colormap's middle.
    """
    vals = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(vals)):
        raise ValueError("values contain NaN or inf")
    lo, hi = (float(vals.min()), float(vals.max())) if clim is None else map(float, clim)
    scaled = np.full_like(vals, 0.5) if hi <= lo else (vals - lo) / (hi - lo)
    rgba = colormaps[cmap](np.clip(scaled, 0.0, 1.0))
    return rgb_array(rgba[..., :3])
