"""HumanML3D-style metrics on evaluator embeddings, and physical metrics on joints."""
from __future__ import annotations

import numpy as np
from scipy import linalg

from engine.skeleton import FOOT_JOINTS
from engine.units import FPS



def fid(a: np.ndarray, b: np.ndarray) -> float:
    """Frechet distance between Gaussians fitted to two embedding sets (N, D)."""
    mu_a, mu_b = a.mean(0), b.mean(0)
    cov_a, cov_b = np.cov(a, rowvar=False), np.cov(b, rowvar=False)
    covmean = linalg.sqrtm(cov_a @ cov_b)
    if not np.isfinite(covmean).all():
        eps = np.eye(len(cov_a)) * 1e-6
        covmean = linalg.sqrtm((cov_a + eps) @ (cov_b + eps))
    covmean = covmean.real
    value = float(((mu_a - mu_b) ** 2).sum() + np.trace(cov_a + cov_b - 2 * covmean))
    return max(value, 0.0)  # a distance: identical sets can come out a hair below 0 from the matrix square root


def _pairwise(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sqrt(np.maximum((a**2).sum(1)[:, None] + (b**2).sum(1)[None] - 2 * a @ b.T, 0.0))


def r_precision(text: np.ndarray, motion: np.ndarray, *, pool: int = 32, top: int = 3,
                rng: np.random.Generator | None = None) -> list[float]:
    """Share of texts whose own motion ranks in the top-k among ``pool`` motions (itself + pool-1 others).

    HumanML3D way: the data is shuffled into groups of ``pool``; within a group each text ranks
    the group's motions by Euclidean distance.
    """
    rng = rng or np.random.default_rng(0)
    n = len(text) - len(text) % pool
    if n < pool:
        raise ValueError(f"R-precision needs at least {pool} samples, got {len(text)}")
    order = rng.permutation(len(text))[:n]
    hits = np.zeros(top)
    for g in range(0, n, pool):
        idx = order[g : g + pool]
        d = _pairwise(text[idx], motion[idx])
        rank = (d < np.diag(d)[:, None]).sum(1)  # how many motions are closer than the true one
        for k in range(top):
            hits[k] += (rank <= k).sum()
    return (hits / n).tolist()


def mm_dist(text: np.ndarray, motion: np.ndarray) -> float:
    return float(np.linalg.norm(text - motion, axis=1).mean())


def diversity(motion: np.ndarray, *, pairs: int = 300, rng: np.random.Generator | None = None) -> float:
    rng = rng or np.random.default_rng(0)
    pairs = min(pairs, len(motion))
    a = rng.choice(len(motion), pairs, replace=False)
    b = rng.choice(len(motion), pairs, replace=False)
    return float(np.linalg.norm(motion[a] - motion[b], axis=1).mean())


def multimodality(groups: list[np.ndarray], *, pairs: int = 10, rng: np.random.Generator | None = None) -> float:
    """Mean distance between motions generated for the same text (groups: (R, D) per text)."""
    rng = rng or np.random.default_rng(0)
    dists = []
    for g in groups:
        if len(g) < 2:
            continue
        for _ in range(pairs):
            i, j = rng.choice(len(g), 2, replace=False)
            dists.append(np.linalg.norm(g[i] - g[j]))
    return float(np.mean(dists)) if dists else float("nan")


def foot_skate(joints: np.ndarray, *, height: float = 0.05, speed: float = 0.025) -> float:
    """Share of foot-on-ground frame pairs where the foot slides more than ``speed`` m per frame.

    A foot joint (ankle or toe) is on the ground when it is lower than ``height`` above the
    motion's floor in both frames. joints (T, 22, 3) with the floor at y = 0.
    """
    feet = [*FOOT_JOINTS["left"], *FOOT_JOINTS["right"]]
    p = joints[:, feet]
    low = (p[1:, :, 1] < height) & (p[:-1, :, 1] < height)
    slide = np.linalg.norm(p[1:, :, [0, 2]] - p[:-1, :, [0, 2]], axis=-1)
    if not low.any():
        return 0.0
    return float((slide[low] > speed).mean())


def root_speed(joints: np.ndarray, *, fps: float = FPS) -> float:
    """Mean speed (m/s) of the root on the floor (x, z) over the motion; joints (T, 22, 3)."""
    xz = np.asarray(joints)[:, 0, [0, 2]]
    return float(np.linalg.norm(np.diff(xz, axis=0), axis=1).mean() * fps) if len(xz) > 1 else 0.0


def jerk(joints: np.ndarray, *, fps: float = FPS) -> float:
    """Mean magnitude of the third time derivative of joint positions (m/s³); joints (T, 22, 3)."""
    d3 = np.diff(joints, n=3, axis=0) * fps**3
    return float(np.linalg.norm(d3, axis=-1).mean())


def penetration_cm(joints: np.ndarray) -> float:
    """Mean over frames of how far the lowest joint is below the floor (y = 0), in cm."""
    return float(np.maximum(-joints[..., 1].min(-1), 0.0).mean() * 100)
