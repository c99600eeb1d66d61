"""The 22-joint skeleton: constants, bone lengths from the real sample, FK and IK."""
from __future__ import annotations

import numpy as np

from engine.rotations import (
    axis_angle_to_matrix,
    euler_to_matrix,
    kabsch,
    matrix_to_euler,
    matrix_to_quat,
    quat_to_matrix,
)
from engine.skeleton import (
    BONE_LENGTHS,
    CHAINS,
    JOINT_NAMES,
    MIRROR,
    NUM_JOINTS,
    PARENTS,
    Skeleton,
    measure_bone_lengths,
)


def test_constants_are_consistent():
    assert NUM_JOINTS == 22 == len(JOINT_NAMES) == len(PARENTS)
    for chain in CHAINS:
        for parent, child in zip(chain[:-1], chain[1:]):
            assert PARENTS[child] == parent
    for j, m in enumerate(MIRROR):
        assert MIRROR[m] == j
        name = JOINT_NAMES[j]
        other = JOINT_NAMES[m]
        assert other == name.replace("left", "X").replace("right", "left").replace("X", "right")


def test_bone_lengths_come_from_the_real_sample(real_joints):
    measured = measure_bone_lengths(real_joints[0].astype(np.float64))
    for j, length in BONE_LENGTHS.items():
        partner = MIRROR[j]
        assert abs(length - (measured[j] + measured[partner]) / 2) < 1e-4
    assert np.allclose(Skeleton.default().bone_lengths[1:], [BONE_LENGTHS[j] for j in range(1, 22)])


def test_fk_ik_round_trip_random_poses():
    rng = np.random.default_rng(0)
    skeleton = Skeleton.default()
    local = axis_angle_to_matrix(rng.normal(0, 0.6, (40, 22, 3)))
    root = rng.normal(0, 1, (40, 3))
    joints = skeleton.forward(local, root)
    assert np.allclose(measure_bone_lengths(joints)[:, 1:], skeleton.bone_lengths[1:])
    local2, root2 = skeleton.inverse(joints)
    assert np.abs(skeleton.forward(local2, root2) - joints).max() < 1e-9
    # rotations are proper
    assert np.allclose(np.linalg.det(local2), 1.0)


def test_rest_pose_is_a_standing_body_facing_forward():
    rest = Skeleton.default().rest_pose()
    height = rest[:, 1].max() - rest[:, 1].min()
    assert 1.5 < height < 2.0
    assert rest[1, 0] > 0 > rest[2, 0]  # left is +X
    assert rest[10, 2] > rest[7, 2]  # toes point +Z


def test_rotation_helpers():
    rng = np.random.default_rng(1)
    m = axis_angle_to_matrix(rng.normal(0, 1.0, (200, 3)))
    assert np.abs(quat_to_matrix(matrix_to_quat(m)) - m).max() < 1e-9
    for order in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"):
        angles = rng.uniform(-80, 80, (50, 3))
        mat = euler_to_matrix(angles, order)
        assert np.abs(matrix_to_euler(mat, order) - angles).max() < 1e-8
    pts = rng.normal(size=(6, 3))
    assert np.abs(kabsch(pts, pts @ m[0].T) - m[0]).max() < 1e-9


def test_qbetween_handles_opposite_directions():
    from engine.rotations import qbetween, qrot

    down = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.3, 0.4, 0.5]])
    up = -down
    q = qbetween(down, up)
    assert np.isfinite(q).all() and np.allclose(np.linalg.norm(q, axis=-1), 1.0)
    assert np.allclose(qrot(q, down), up, atol=1e-9)
    # component-first layout too
    q0 = qbetween(down.T, up.T, axis=0)
    assert np.allclose(q0.T, q)


def test_features_of_arms_straight_up_are_finite():
    from engine.representation import joints_to_features

    skeleton = Skeleton.default()
    local = np.broadcast_to(np.eye(3), (10, 22, 3, 3)).copy()
    # T-pose arms rotated to point straight up: exactly opposite HumanML3D's raw "down" direction
    from engine.rotations import axis_rotation

    local[:, 16] = axis_rotation("z", np.full(10, np.pi / 2))
    local[:, 17] = axis_rotation("z", np.full(10, -np.pi / 2))
    joints = skeleton.forward(local, np.tile([0.0, 0.95, 0.0], (10, 1)) + np.linspace(0, 0.1, 10)[:, None])
    assert np.allclose(joints[0, 20] - joints[0, 16], [0, np.linalg.norm(joints[0, 20] - joints[0, 16]), 0], atol=1e-9)
    assert np.isfinite(joints_to_features(joints)).all()
