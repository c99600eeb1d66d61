"""engine.synth: API, determinism, kinematic consistency, canonical frame."""
from __future__ import annotations

import numpy as np
import pytest

from engine.representation import canonicalize, joints_to_features
from engine.skeleton import Skeleton, measure_bone_lengths
from engine.synth import ACTIONS, STYLES, Corpus, Program, Segment, make_sample, synthesize


def test_api_shapes_and_types():
    s = Corpus(split="train").sample(3)
    T = s.joints.shape[0]
    assert s.joints.dtype == np.float32 and s.joints.shape == (T, 22, 3)
    assert s.features.dtype == np.float32 and s.features.shape == (T - 1, 263)
    assert 40 <= T <= 196
    assert len(s.captions) >= 3 and len(set(s.captions)) == len(s.captions)
    assert isinstance(s.labels.to_json(), dict)
    assert isinstance(s.program, Program)


def test_features_equal_representation_of_joints():
    s = Corpus(split="test").sample(5)
    np.testing.assert_array_equal(s.features, joints_to_features(s.joints))


def test_same_seed_same_bytes_and_different_seeds_differ():
    a = Corpus("train", seed=0).sample(11)
    b = Corpus("train", seed=0).sample(11)
    assert a.joints.tobytes() == b.joints.tobytes()
    assert a.features.tobytes() == b.features.tobytes()
    assert a.captions == b.captions
    c = Corpus("train", seed=1).sample(11)
    d = Corpus("train", seed=0).sample(12)
    e = Corpus("test", seed=0).sample(11)
    for other in (c, d, e):
        assert other.joints.shape != a.joints.shape or not np.array_equal(other.joints, a.joints)


def test_canonical_frame():
    for i in range(5):
        s = Corpus("train").sample(i)
        j = s.joints.astype(np.float64)
        assert abs(j[..., 1].min()) < 1e-6
        assert np.allclose(j[0, 0, [0, 2]], 0.0, atol=1e-6)
        np.testing.assert_allclose(j, canonicalize(j), atol=1e-5)


def test_local_rotations_reproduce_joints_by_fk():
    syn = synthesize(Program(segments=(Segment("walk", 60, direction="forward"),
                                       Segment("wave", 50, count=2, side="right")), style="happy"))
    local = syn.local_rotations
    joints = Skeleton.default().forward(local, syn.joints[:, 0])
    np.testing.assert_allclose(joints, syn.joints, atol=1e-6)
    R = local.reshape(-1, 3, 3)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-6)


def test_bone_lengths_constant_and_equal_to_skeleton():
    s = Corpus("train").sample(7)
    lengths = measure_bone_lengths(s.joints.astype(np.float64))
    ref = Skeleton.default().bone_lengths
    np.testing.assert_allclose(lengths, np.broadcast_to(ref, lengths.shape), atol=1e-5)


@pytest.mark.parametrize("action", ACTIONS)
def test_every_action_synthesises(action):
    seg = Segment(action=action, frames=70, count=2, side="left" if action in ("kick", "punch", "wave", "hop") else "none",
                  direction={"walk_backward": "backward", "side_step": "left"}.get(action, "forward"),
                  turn=np.pi if action == "turn" else 0.0)
    s = make_sample(Program(segments=(seg,)))
    assert np.isfinite(s.joints).all() and np.isfinite(s.features).all()


def test_every_style_synthesises():
    for style in STYLES:
        s = make_sample(Program(segments=(Segment("walk", 60, direction="forward"),), style=style))
        assert np.isfinite(s.joints).all()


def test_stats_returns_normalizer():
    norm = Corpus("train").stats(n=8)
    assert norm.mean.shape == (263,) and norm.std.shape == (263,) and (norm.std > 0).all()


def test_gait_heading_follows_path():
    s = make_sample(Program(segments=(Segment("walk", 120, direction="circle_left"),)))
    root = s.labels.root_path
    vel = np.diff(root, axis=0)
    moving = np.linalg.norm(vel, axis=1) > 0.02
    travel = np.arctan2(vel[moving, 0], vel[moving, 1])
    heading = s.labels.heading[:-1][moving]
    err = np.angle(np.exp(1j * (travel - heading)))
    assert np.abs(err).mean() < 0.2


def test_arm_swing_opposes_legs_in_walking():
    s = make_sample(Program(segments=(Segment("walk", 120, direction="forward"),)))
    j = s.joints.astype(np.float64)[30:90]
    leg = (j[:, 7, 2] - j[:, 8, 2])  # left ankle ahead of right (facing +Z)
    arm = (j[:, 20, 2] - j[:, 21, 2])  # left wrist ahead of right
    assert np.corrcoef(leg, arm)[0, 1] < -0.5
