"""Metrics with known answers."""
from __future__ import annotations

import numpy as np
import pytest

from engine.evaluation.metrics import diversity, fid, foot_skate, mm_dist, multimodality, penetration_cm, r_precision


def test_fid_is_zero_for_the_same_set_and_grows_with_shift():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(500, 8))
    assert abs(fid(a, a)) < 1e-6
    b = a + np.array([1.0] + [0] * 7)
    assert abs(fid(a, b) - 1.0) < 1e-6
    assert fid(a, rng.normal(size=(500, 8)) * 2) > fid(a, rng.normal(size=(500, 8)))


def test_r_precision_perfect_and_chance():
    rng = np.random.default_rng(1)
    motion = rng.normal(size=(64, 16))
    top = r_precision(motion, motion)
    assert top == [1.0, 1.0, 1.0]
    chance = r_precision(rng.normal(size=(640, 16)), rng.normal(size=(640, 16)))
    assert abs(chance[0] - 1 / 32) < 0.03 and chance[0] <= chance[1] <= chance[2]
    with pytest.raises(ValueError):
        r_precision(motion[:10], motion[:10])


def test_distances():
    a = np.zeros((4, 2))
    b = np.array([[3.0, 4.0]] * 4)
    assert mm_dist(a, b) == 5.0
    assert diversity(np.array([[0.0, 0.0], [0.0, 0.0]]), pairs=2) == 0.0
    assert multimodality([np.array([[0.0, 0], [3, 4]])], pairs=5) == 5.0


def _walker(slide_per_frame: float, frames: int = 20) -> np.ndarray:
    joints = np.zeros((frames, 22, 3))
    joints[:, :, 1] = 1.0
    for j in (7, 8, 10, 11):
        joints[:, j, 1] = 0.02
        joints[:, j, 0] = np.arange(frames) * slide_per_frame
    return joints


def test_foot_skate_and_penetration():
    assert foot_skate(_walker(0.0)) == 0.0
    assert foot_skate(_walker(0.05)) == 1.0
    sunk = _walker(0.0)
    sunk[:, 10, 1] = -0.03
    assert abs(penetration_cm(sunk) - 3.0) < 1e-9
    assert penetration_cm(_walker(0.0)) == 0.0
