"""Figures of MoMo's analysis (matplotlib, written to PNG): Q/K clusters, correspondences, maps.

Skeleton strips draw every k-th frame in profile, each pose in its own heading frame (facing
right), spaced along the strip, coloured per frame.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from engine.representation import SLICES, joints_to_features  # noqa: E402
from engine.skeleton import PARENTS  # noqa: E402

CLUSTER_CMAP = "tab10"
INDEX_CMAP = "viridis"


def cluster_colors(labels: np.ndarray) -> np.ndarray:
    """Cluster ids -> RGB (N, 3) from the categorical palette the app uses too."""
    cmap = plt.get_cmap(CLUSTER_CMAP)
    return np.array([cmap(int(l) % 10)[:3] for l in labels])


def index_colors(n: int) -> np.ndarray:
    """Frame index -> RGB (n, 3) along a sequential palette."""
    cmap = plt.get_cmap(INDEX_CMAP)
    return np.array([cmap(i / max(n - 1, 1))[:3] for i in range(n)])


def local_poses(joints: np.ndarray) -> np.ndarray:
    """(T, 22, 3) -> (T-1, 22, 3): root-relative joints in each frame's heading frame (root height kept)."""
    f = joints_to_features(joints)
    ric = f[:, SLICES["ric"]].reshape(len(f), -1, 3)
    root = np.zeros((len(f), 1, 3))
    root[:, 0, 1] = f[:, SLICES["root_height"]][:, 0]
    return np.concatenate([root, ric], axis=1)


def draw_strip(ax, poses: np.ndarray, colors: np.ndarray, *, frames: Sequence[int], spacing: float = 0.55,
               title: str = "") -> None:
    """Profile skeletons of ``frames`` of ``poses`` (local, from :func:`local_poses`) side by side."""
    for slot, i in enumerate(frames):
        p = poses[i]
        x, y = p[:, 2] + slot * spacing, p[:, 1]
        for j, parent in enumerate(PARENTS):
            if parent >= 0:
                ax.plot([x[parent], x[j]], [y[parent], y[j]], color=colors[i], lw=1.6, solid_capstyle="round")
    ax.set_xlim(-0.5, len(frames) * spacing)
    ax.set_ylim(-0.05, 2.0)
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=9, loc="left")


def draw_cells(ax, colors: np.ndarray, *, title: str = "") -> None:
    """One coloured cell per frame."""
    ax.imshow(colors[None], aspect="auto", interpolation="nearest")
    ax.set_yticks([])
    ax.set_xlabel("frame", fontsize=8)
    ax.tick_params(labelsize=7)
    if title:
        ax.set_title(title, fontsize=9, loc="left")


def _frames(n: int, count: int) -> list[int]:
    return sorted(set(np.linspace(0, n - 1, min(count, n)).round().astype(int).tolist()))


def cluster_figure(motions: Mapping[str, np.ndarray], q_labels: Mapping[str, np.ndarray],
                   k_labels: Mapping[str, np.ndarray], path: str | Path, *, poses_per_row: int = 16) -> Path:
    """Per motion: Q clusters (left) and K clusters (right) as frame cells and as coloured skeletons."""
    names = list(motions)
    fig, axes = plt.subplots(2 * len(names), 2, figsize=(16, 3.2 * len(names)),
                             gridspec_kw={"height_ratios": [1, 4] * len(names)})
    axes = np.atleast_2d(axes)
    for r, name in enumerate(names):
        poses = local_poses(motions[name])
        for c, (what, labels) in enumerate((("Q", q_labels[name]), ("K", k_labels[name]))):
            n = min(len(poses), len(labels))
            colors = cluster_colors(labels[:n])
            draw_cells(axes[2 * r, c], colors, title=f"{name}: {what} clusters")
            draw_strip(axes[2 * r + 1, c], poses[:n], colors, frames=_frames(n, poses_per_row))
    fig.tight_layout()
    return _save(fig, path)


def correspondence_figure(leader: np.ndarray, follower: np.ndarray, nearest: np.ndarray, path: str | Path, *,
                          poses_per_row: int = 16) -> Path:
    """Follower coloured by frame index; the leader coloured by its nearest follower frame; the leader
    replaced frame by frame by its nearest follower frame."""
    lp, fp = local_poses(leader), local_poses(follower)
    n = min(len(lp), len(nearest))
    nearest = np.clip(nearest[:n], 0, len(fp) - 1)
    f_colors = index_colors(len(fp))
    fig, axes = plt.subplots(3, 1, figsize=(16, 9))
    draw_strip(axes[0], fp, f_colors, frames=_frames(len(fp), poses_per_row), title="follower (colour = frame index)")
    draw_strip(axes[1], lp[:n], f_colors[nearest], frames=_frames(n, poses_per_row),
               title="leader (colour = its nearest follower frame, argmax q_leader · k_follower)")
    draw_strip(axes[2], fp[nearest], f_colors[nearest], frames=_frames(n, poses_per_row),
               title="leader replaced by its nearest follower frames")
    fig.tight_layout()
    return _save(fig, path)


def maps_figure(maps: Mapping[str, np.ndarray], path: str | Path, *, per_query: Mapping[int, Mapping[str, np.ndarray]] = {}) -> Path:
    """Full maps side by side (rows = query frames) and, below, per-query rows for chosen leader frames."""
    rows = 1 + (1 if per_query else 0)
    fig, axes = plt.subplots(rows, max(len(maps), len(per_query) or 1), figsize=(5 * len(maps), 4.5 * rows), squeeze=False)
    for c, (name, m) in enumerate(maps.items()):
        ax = axes[0, c]
        ax.imshow(m, cmap="magma", aspect="auto", interpolation="nearest", origin="upper")
        ax.set_title(f"{name} ({m.shape[0]}×{m.shape[1]})", fontsize=10)
        ax.set_xlabel("key frame", fontsize=8)
        ax.set_ylabel("query frame", fontsize=8)
    for c, (frame, rows_of) in enumerate(per_query.items()):
        ax = axes[1, c]
        for name, row in rows_of.items():
            ax.plot(np.arange(len(row)), row, label=f"{name} map, leader frame {frame}")
        ax.legend(fontsize=7)
        ax.set_xlabel("key frame", fontsize=8)
    for ax in axes.flat:
        if not ax.has_data():
            ax.axis("off")
    fig.tight_layout()
    return _save(fig, path)


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
