"""Action counting from a self-attention map (MotionCLR) and the root-height baseline."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter, gaussian_filter1d
from scipy.signal import find_peaks


@dataclass(frozen=True)
class CountingConfig:
    sigma: float = 0.8  # Gaussian filter on the map
    downsample: int = 4  # average pooling factor
    height_factor: float = 3.0  # a peak must exceed this times the row mean
    distance: int = 1


@dataclass(frozen=True)
class CountResult:
    count: float  # total peaks / rows with at least one peak
    peaks: list[tuple[int, int]]  # (row, column) in original frame units
    processed: np.ndarray  # the filtered, downsampled, normalised map

    @property
    def rounded(self) -> int:
        return int(round(self.count))


def count_from_attention(attn: np.ndarray, config: CountingConfig = CountingConfig()) -> CountResult:
    """attn (T, T) self-attention (mean over heads) -> count of repeated actions."""
    attn = np.asarray(attn, dtype=np.float64)
    if attn.ndim != 2 or attn.shape[0] != attn.shape[1]:
        raise ValueError(f"a self-attention map must be square (T, T), got {attn.shape}")
    smooth = gaussian_filter(attn, config.sigma)
    f = config.downsample
    n = (len(smooth) // f) * f
    if n < f:
        raise ValueError("the motion is too short to count on")
    pooled = smooth[:n, :n].reshape(n // f, f, n // f, f).mean(axis=(1, 3))
    lo, hi = pooled.min(), pooled.max()
    norm = (pooled - lo) / (hi - lo) if hi > lo else np.zeros_like(pooled)
    peaks, rows_with_peaks = [], 0
    for r, row in enumerate(norm):
        found, _ = find_peaks(row, height=config.height_factor * row.mean(), distance=config.distance)
        if len(found):
            rows_with_peaks += 1
            peaks.extend((r * f + f // 2, int(c) * f + f // 2) for c in found)
    count = len(peaks) / rows_with_peaks if rows_with_peaks else 0.0
    return CountResult(count=count, peaks=peaks, processed=norm)


def count_from_root_height(root_height: np.ndarray, *, sigma: float = 2.0, prominence: float = 0.03) -> int:
    """Baseline: peaks of the Gaussian-smoothed root height (metres)."""
    smooth = gaussian_filter1d(np.asarray(root_height, dtype=np.float64), sigma)
    found, _ = find_peaks(smooth, prominence=prominence)
    return int(len(found))
