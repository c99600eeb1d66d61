"""Paths a person would draw (engine/methods/drawn_paths.py): walking speed, start, shape, letters in reach."""
from __future__ import annotations

import numpy as np
import pytest

from engine.generate import FPS, MAX_SECONDS
from engine.methods.drawn_paths import (
    LETTER_HEIGHT, LETTER_ORDER, LETTERS, WALK_SPEED, circle, drawn_letters, drawn_root_paths, letter, s_curve,
    shoulder_height, walk_times, zigzag,
)
from engine.methods.paths import MAX_WRIST_SPEED
from engine.representation import features_to_joints
from engine.skeleton import JOINT_INDEX, Skeleton


def _walked(p):
    """Root xz per pose, per-frame speeds (m/s) and the path length (m)."""
    xz = p.path().frames(p.seconds)
    speed = np.linalg.norm(np.diff(xz, axis=0), axis=1) * FPS
    pts = np.asarray(p.points)
    return xz, speed, float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


@pytest.mark.parametrize("n", [1, 3, 7])
def test_root_paths_walk_from_the_origin_at_walking_speed(n):
    from engine.synth.primitives.locomotion import GAITS

    assert WALK_SPEED == GAITS["walk"].speed  # the corpus walk
    paths = drawn_root_paths(n)
    assert len(paths) == n and len({p.name for p in paths}) == n
    assert [p.shape for p in paths[:3]] == ["s_curve", "circle", "zigzag"][:n]
    for p in paths:
        xz, speed, length = _walked(p)
        assert p.control == "root" and np.allclose(xz[0], 0.0)
        assert abs(np.degrees(p.path().start_heading(xz))) < 3  # heading +Z at the start
        # walking: cruising at 1.2-1.4 m/s (the corpus walk is 1.3), never faster, starting and ending at rest
        cruise = np.median(speed)
        assert 1.19 <= cruise <= 1.41 and speed.max() <= 1.41, (p.name, cruise, speed.max())
        assert speed[0] < 0.2 and speed[-1] < 0.2
        assert 3.0 <= length <= 10.0 and 3.0 <= p.seconds <= MAX_SECONDS
        assert abs(p.seconds - length / cruise) < 1.0  # the ramps cost well under a second
        values, frame = p.controls()  # the path editor's route: RootPath -> control features
        assert values.shape == (round(p.seconds * FPS), 3) and np.isfinite(values).all()


def test_root_shapes():
    c = circle(radius=1.2, turn="left")
    xz, _, length = _walked(c)
    assert abs(length - 2 * np.pi * 1.2) < 0.05 and np.linalg.norm(xz[-1]) < 0.05  # back where it started
    centre = np.array([1.2, 0.0])  # turning left = toward +X, the person's left
    assert np.abs(np.linalg.norm(xz - centre, axis=1) - 1.2).max() < 0.03
    assert (_walked(circle(turn="right"))[0][:, 0] <= 1e-6).all()
    s = np.asarray(s_curve(first="left").points)
    tail = s[-1] - s[-3]
    assert s[-1, 0] > 1.0 and abs(tail[0]) < 0.01 * np.linalg.norm(tail)  # shifted left, heading +Z again
    assert np.allclose(np.asarray(s_curve(first="right").points) * [-1, 1], s, atol=1e-3)
    z = np.asarray(zigzag(legs=4, first="left").points)
    heading = np.degrees(np.arctan2(*np.diff(z, axis=0).T))
    sign_changes = np.count_nonzero(np.diff(np.sign(np.round(heading[np.abs(heading) > 20]))))
    assert sign_changes == 3 and np.abs(heading).max() <= 45.5  # four legs alternating ±45°


def test_walk_times_never_exceed_the_speed():
    pts = np.stack([np.zeros(101), np.linspace(0, 4, 101)], -1)
    t = walk_times(pts, 1.3, 0.6)
    assert t[0] == 0 and (np.diff(t) > 0).all()
    assert abs(t[-1] - (4 / 1.3 + 0.6)) < 0.02  # each smoothstep ramp costs half its time
    assert (0.04 / np.diff(t)).max() <= 1.3 + 1e-6


@pytest.mark.parametrize("side", ["left", "right"])
def test_letters_in_front_of_the_body_within_reach(side):
    letters = drawn_letters(12, side)
    assert [p.shape for p in letters[:5]] == ["L", "Z", "O", "S", "W"] and len({p.name for p in letters}) == 12
    rest = Skeleton().rest_pose()
    rest = rest - np.array([0.0, rest[:, 1].min(), 0.0])
    shoulder = rest[JOINT_INDEX[f"{side}_shoulder"]]
    arm = sum(np.linalg.norm(rest[JOINT_INDEX[f"{side}_{a}"]] - rest[JOINT_INDEX[f"{side}_{b}"]])
              for a, b in (("shoulder", "elbow"), ("elbow", "wrist")))
    y0 = shoulder_height()
    for p in letters:
        assert p.control == f"{side}_wrist"
        v = p.controls()[0]
        assert v.shape == (round(p.seconds * FPS), 3)
        assert 0.3 - 1e-9 <= v[:, 2].min() and v[:, 2].max() <= 0.5  # 0.3-0.5 m in front of the body
        height = v[:, 1].max() - v[:, 1].min()
        assert 0.35 <= height <= 0.45 and abs(v[:, 1].mean() - y0) < 0.15  # ~0.4 m tall at shoulder height
        assert np.abs(v[:, 1] - y0).max() <= 0.5 * height + 1e-3
        # in front of the writing hand's half of the body, never across to the far shoulder
        toward_hand = v[:, 0] if side == "left" else -v[:, 0]
        assert toward_hand.min() > -0.1 and toward_hand.max() < 0.45
        assert (np.linalg.norm(v - shoulder, axis=1) < arm).all()  # the arm reaches every point
        speed = np.linalg.norm(np.diff(v, axis=0), axis=1) * FPS
        assert speed.max() < min(2.0, MAX_WRIST_SPEED)  # a hand drawing, not flicking
        moving = speed > 0.02
        assert 1.0 <= moving.sum() / FPS <= 5.0 and 2.0 <= p.seconds <= 6.0  # drawn over a couple of seconds
        assert not moving[:5].any() and not moving[-5:].any()  # held still before and after
    # the writer's view: an "L" goes down, then to the writer's right (-X is the person's right)
    L = np.asarray(letter("L", side=side).points)
    corner = L[np.argmin(L[:, 1] + np.abs(L[:, 0] - L[0, 0]))]
    assert np.allclose(corner[0], L[0, 0]) and L[0, 1] - corner[1] == pytest.approx(LETTER_HEIGHT, abs=1e-3)
    assert np.allclose(L[-1, 1], corner[1]) and L[-1, 0] < corner[0] - 0.2


def test_letters_stop_at_corners():
    v = letter("Z", side="right").controls()[0]
    pts = np.asarray(LETTERS["Z"])
    speed = np.linalg.norm(np.diff(v, axis=0), axis=1) * FPS
    corner = np.argmin(np.linalg.norm(v[:, :2] - [v[:, 0].min(), v[:, 1].max()], axis=1))  # top, writer's right
    assert speed[max(corner - 1, 0): corner + 1].min() < 0.15 * speed.max()
    assert len(pts) == 4 and set(LETTER_ORDER) == set(LETTERS)
    with pytest.raises(ValueError, match="no drawn letter"):
        letter("?")


def test_drawn_wrist_paths_reach_the_control_features():
    """A letter's control values are the wrist's ric position: features_to_joints puts the wrist there."""
    from engine.synth import Corpus

    p = letter("W", side="right")
    feats = Corpus(split="test").sample(1).features.copy()
    frames = min(len(feats), round(p.seconds * FPS))
    values = p.controls(frames / FPS)[0]
    feats = feats[:frames]
    feats[:, [0, 1, 2]] = 0.0  # standing still, facing +Z: the body frame is the world frame
    from engine.methods.control import control_dims

    feats[:, control_dims("right_wrist")] = values
    joints = features_to_joints(feats)
    wrist = joints[:, JOINT_INDEX["right_wrist"]]
    assert np.abs(wrist - values).max() < 1e-4  # x left, y height above the floor, z forward


@pytest.mark.parametrize("turn", ["left", "right"])
def test_a_drawn_circle_decodes_onto_its_path(turn):
    """Root controls of a full circle decode onto the circle: the heading passes 180 degrees from the start,
    where HumanML3D's unsigned turn (asin of the relative quaternion) would flip one frame's turn."""
    from engine.methods.paths import path_error, to_world

    p = circle(radius=1.2, turn=turn)
    values, frame = p.controls()
    feats = np.zeros((len(values), 263))
    feats[:, :3], feats[:, 3] = values, 0.9
    err = path_error(to_world(features_to_joints(feats), frame), frame["target"])
    assert err["max_m"] < 1e-4
    turned = 2 * np.sum(values[:, 0])  # the decoded heading change: a full turn, the way the path turns
    assert abs(abs(turned) - 2 * np.pi) < 0.35 and np.sign(turned) == (-1 if turn == "left" else 1)
