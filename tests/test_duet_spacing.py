"""Duet spacing (engine.methods.duet_spacing): people who start inside each other are moved apart, others are not
touched; the rule's numbers are the corpus duets' own."""
from __future__ import annotations

import numpy as np
import pytest

from engine.analysis.duet_pose import interpenetrate, torso_distance, torso_gap
from engine.methods.commdm import Pose
from engine.methods.duet_spacing import (FLOOR, PUSH_SPEED, TRUTH, SpacingRule, keep_apart, push_profile,
                                         truth_minimums)
from engine.units import FPS


@pytest.fixture(scope="module")
def standing():
    """A person standing 3 s, in its canonical frame (facing +Z)."""
    from engine.synth.compose import synthesize
    from engine.synth.corpus import to_canonical
    from engine.synth.program import Program, Segment

    joints, _, _ = to_canonical(synthesize(Program(segments=(Segment("stand", 60),), seed=5)).joints)
    return joints.astype(np.float32)


def facing_pair(joints: np.ndarray, gap: float) -> np.ndarray:
    """Person a at the origin facing +Z, person b ``gap`` metres ahead facing a."""
    return np.stack([joints, Pose(0.0, gap, np.pi).place(joints)]).astype(np.float32)


def test_people_who_overlap_are_moved_apart(standing):
    joints = facing_pair(standing, 0.15)
    assert interpenetrate(joints).all()
    out, spacing = keep_apart(joints, "handshake")
    assert spacing.moved and spacing.rule == SpacingRule("handshake", TRUTH["handshake"][0], FLOOR)
    d = torso_distance(out)
    assert d[:FPS].min() >= TRUTH["handshake"][0] - 1e-5  # the first second keeps the handshake's distance
    assert d.min() >= FLOOR - 1e-5 and not interpenetrate(out).any()
    np.testing.assert_array_equal(out[0], joints[0])  # person a stays
    assert spacing.direction[1] > 0.99  # b moves along the line between the torsos, away from a
    moved = out[1] - joints[1]
    np.testing.assert_array_equal(moved[..., 1], 0.0)
    np.testing.assert_allclose(moved, np.broadcast_to(spacing.offset[:, None], moved.shape), atol=1e-6)
    # a contact interaction drifts back after its first second (so hands can meet), never faster than PUSH_SPEED
    assert spacing.push[-1] < spacing.push[0]
    assert np.abs(np.diff(spacing.push)).max() <= PUSH_SPEED / FPS + 1e-9


def test_people_far_enough_apart_are_left_alone_bit_for_bit(standing):
    joints = facing_pair(standing, 1.6)
    before = joints.copy()
    for interaction in (*TRUTH, None):
        out, spacing = keep_apart(joints, interaction)
        assert out is joints and not spacing.moved
        np.testing.assert_array_equal(joints, before)


def test_without_contact_the_minimum_holds_all_clip(standing):
    joints = facing_pair(standing, 1.6)
    # person b walks in through the second half: at the end their torsos meet
    joints[1, 30:, :, 2] -= np.linspace(0.0, 1.5, 30, dtype=np.float32)[:, None]
    out, spacing = keep_apart(joints, "sparring")
    assert torso_distance(out).min() >= TRUTH["sparring"][1] - 1e-5
    assert np.abs(np.diff(spacing.push)).max() <= PUSH_SPEED / FPS + 1e-9
    assert spacing.push[:5].max() == 0.0  # the first frames were fine and stay as they were (the push eases in)
    np.testing.assert_array_equal(out[1, :5], joints[1, :5])
    # a prompt that reads as no interaction keeps the floor only
    out, spacing = keep_apart(joints, None)
    assert spacing.rule == SpacingRule(None, FLOOR, FLOOR)
    assert torso_distance(out).min() >= FLOOR - 1e-5


def test_people_side_by_side_need_their_shoulders_room(standing):
    joints = np.stack([standing, Pose(-0.38, 0.0, 0.0).place(standing)]).astype(np.float32)  # b to a's right
    assert torso_distance(joints).min() > FLOOR and interpenetrate(joints).any()  # shoulders overlap
    out, spacing = keep_apart(joints, None)
    assert spacing.moved and spacing.direction[0] < -0.99
    assert torso_gap(out).min() >= 0.0


def test_a_push_never_carries_b_into_a(standing):
    joints = facing_pair(standing, 0.3)
    # person b walks straight through person a after the first second, out to 0.8 m behind a
    joints[1, 20:, :, 2] -= np.linspace(0.0, 1.1, 40, dtype=np.float32)[:, None]
    assert interpenetrate(joints).any()
    out, spacing = keep_apart(joints, "handshake")
    assert spacing.moved and torso_gap(out).min() >= 0.0
    assert torso_distance(out)[:FPS].min() >= TRUTH["handshake"][0] - 1e-5


def test_people_on_top_of_each_other_are_moved_out_in_front_of_a(standing):
    joints = np.stack([standing, standing])
    out, spacing = keep_apart(joints, None)
    np.testing.assert_allclose(spacing.direction, [0.0, 1.0], atol=0.05)  # a faces +Z
    assert torso_distance(out)[:FPS].min() >= FLOOR - 1e-5 and not interpenetrate(out).any()


def test_the_push_is_the_least_slow_envelope():
    required = np.zeros(60)
    required[30] = 0.3
    push = push_profile(required)
    assert push[30] >= 0.3 and np.all(push >= required)
    assert np.abs(np.diff(push)).max() <= PUSH_SPEED / FPS + 1e-9
    assert push[0] == 0.0 and push[-1] == 0.0
    np.testing.assert_array_equal(push_profile(np.zeros(8)), 0.0)


def test_an_unknown_interaction_is_refused():
    with pytest.raises(ValueError, match="unknown interaction"):
        SpacingRule.of("waltz")


def test_the_rule_is_the_truths_own():
    from engine.methods.duet_data import few_shot

    samples = few_shot("test", per_interaction=1, seed=3)
    measured = truth_minimums(samples)
    assert set(measured) == set(TRUTH)
    for interaction, (start, anywhere) in measured.items():
        assert start >= TRUTH[interaction][0] and anywhere >= TRUTH[interaction][1], interaction
        if interaction not in ("side_by_side", "following"):  # (their distance is drawn at random)
            assert start - TRUTH[interaction][0] < 0.03, interaction
    for s in samples:  # the truth's people never interpenetrate, and keep their own rule untouched
        joints = np.stack([s.joints_a, s.joints_b])
        assert torso_gap(joints).min() > 0.05
        assert not keep_apart(joints, s.interaction)[1].moved, s.interaction
