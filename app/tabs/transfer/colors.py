"""The colours the Transfer tab's analysis views and the skeletons share: Q/K cluster ids, frame indices."""
from __future__ import annotations

import numpy as np
from bokeh.palettes import Category10_10, Category20_20, Turbo256

ROLES = ("leader", "follower", "out")


def cluster_palette(n: int) -> list[str]:
    """One colour per cluster id (K-Means ids 0..n-1; the paper's m = 10 fits Category10)."""
    return list(Category10_10 if n <= 10 else Category20_20)


def cluster_names(which: str, n: int) -> dict[str, str]:
    """'#rrggbb' -> "Q cluster k" (``which``: "Q" or "K") for the palette of ``n`` clusters: the viewer's legend."""
    return {c.lower(): f"{which} cluster {k}" for k, c in enumerate(cluster_palette(n))}


def cluster_colors(labels: np.ndarray, n_clusters: int) -> list[str]:
    palette = cluster_palette(n_clusters)
    return [palette[int(k) % len(palette)] for k in labels]


def index_colors(n: int) -> list[str]:
    """A colour per frame index (follower frames in the correspondence view)."""
    return [Turbo256[int(round(20 + 215 * i / max(n - 1, 1)))] for i in range(n)]


def hex_rgb(colors: list[str]) -> np.ndarray:
    return np.array([[int(c[i : i + 2], 16) for i in (1, 3, 5)] for c in colors], dtype=np.uint8)


def cluster_paint(view, color_by: str) -> tuple[dict, dict, dict]:
    """How a transfer (a ``TransferView`` seen through one follower) paints its skeletons for ``color_by``:
    (motion name -> per-frame colours, motion name -> what they mean, '#rrggbb' -> its legend name); all empty
    for the role colours."""
    if view is None or color_by == "roles":
        return {}, {}, {}
    labels = view.analysis.q_labels if color_by == "Q cluster" else view.analysis.k_labels
    n = n_clusters(view)
    colors = {view.names[r]: hex_rgb(cluster_colors(labels[r], n)) for r in ROLES if r in view.names}
    note = f"colour: {color_by} (legend in the Transfer tab)"
    return colors, {name: note for name in colors}, cluster_names("Q" if color_by == "Q cluster" else "K", n)


def paint_clusters(state, cfg) -> None:
    """Skeleton colours per frame from the last transfer's Q or K clusters in ``cfg`` (the session's transfer
    settings), or none: the role colours."""
    colors, notes, names = cluster_paint(focused(cfg), cfg.color_by)
    if colors or state.frame_colors:
        state.param.update(frame_colors=colors, color_notes=notes, color_names={**state.color_names, **names})


def focused(settings):
    """The last transfer (a ``TransferView``) of ``settings`` (the session's transfer settings) seen through the
    follower the analysis shows (None before the first transfer)."""
    view = settings.result
    return None if view is None else view.focus(settings.analysed)


def n_clusters(view) -> int:
    """The number of cluster ids to colour (at least the paper's 10, so colours stay put between transfers)."""
    a = view.analysis
    return int(max(10, *(v.max() + 1 for v in (*a.q_labels.values(), *a.k_labels.values()))))
