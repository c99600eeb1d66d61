"""Numeric reference tests of the 263-dim representation against the real HumanML3D sample."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from engine.representation import (
    FEATURE_DIM,
    SLICES,
    Normalizer,
    canonicalize,
    features_to_joints,
    joints_to_features,
    recover_root,
    _yaw_rotate,
)
from engine.skeleton import Skeleton
from engine.rotations import axis_angle_to_matrix


def test_recovery_reproduces_reference_joints(real_joints, real_vecs):
    joints = features_to_joints(real_vecs)
    assert joints.shape == real_joints.shape
    assert np.abs(joints - real_joints).max() <= 1e-4


def test_recovery_torch_batched_matches_numpy(real_vecs):
    batch = torch.from_numpy(np.stack([real_vecs, real_vecs]))
    out = features_to_joints(batch)
    assert isinstance(out, torch.Tensor) and out.shape == (2, len(real_vecs), 22, 3)
    assert torch.allclose(out[0], torch.from_numpy(features_to_joints(real_vecs)))


def test_forward_matches_reference_on_shared_frames(real_joints, real_vecs):
    """joints -> features on the 170 reference poses, compared on the frames both define.

    HumanML3D smooths the facing direction with a Gaussian (sigma 20 frames) over the original
    171 poses, of which the joints file keeps 170, so the last ~3 sigma frames see a different
    edge; they are checked exactly in the next test.
    """
    features = joints_to_features(real_joints)
    assert features.shape == (len(real_joints) - 1, FEATURE_DIM)
    ref = real_vecs[: len(features)]
    inner = slice(0, len(features) - 60)
    for key in ("root_rot_vel", "root_lin_vel", "root_height", "ric", "local_vel"):
        diff = np.abs(features[inner, SLICES[key]] - ref[inner, SLICES[key]]).max()
        assert diff <= 1e-3, f"{key}: max diff {diff}"
    contacts_agree = (features[:, SLICES["contacts"]] == ref[:, SLICES["contacts"]]).mean()
    assert contacts_agree >= 0.97
    assert np.abs(features[:, SLICES["rot6d"]] - ref[:, SLICES["rot6d"]]).mean() <= 1e-2


def test_forward_is_exact_given_the_missing_last_pose(real_joints, real_vecs):
    """With the 171st pose rebuilt from the last row's velocities, every dim matches on every row."""
    vecs = torch.from_numpy(real_vecs.astype(np.float64))
    heading, _ = recover_root(vecs)
    last_velocity = vecs[-1, SLICES["local_vel"]].reshape(22, 3)
    last_pose = real_joints[-1] + _yaw_rotate(last_velocity, -heading[-1]).numpy()
    features = joints_to_features(np.concatenate([real_joints, last_pose[None]], axis=0))
    assert features.shape == real_vecs.shape
    assert np.abs(features[:, :259] - real_vecs[:, :259]).max() < 1e-4
    assert (features[:, 259:] == real_vecs[:, 259:]).all()


def test_round_trip_of_a_synthetic_motion():
    rng = np.random.default_rng(3)
    skeleton = Skeleton.default()
    frames = 60
    angles = np.cumsum(rng.normal(0, 0.03, (frames, 22, 3)), axis=0)
    root = np.cumsum(rng.normal(0, 0.02, (frames, 3)), axis=0) + np.array([0.3, 1.0, -0.2])
    joints = skeleton.forward(axis_angle_to_matrix(angles), root)
    features = joints_to_features(joints)
    recovered = features_to_joints(features)
    canon = canonicalize(joints)[:-1]
    assert np.abs(recovered - canon).max() < 1e-4


def test_canonical_form(real_joints):
    moved = real_joints @ np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]).T + np.array([2.0, 0.5, -1.0])
    canon = canonicalize(moved)
    assert abs(canon[..., 1].min()) < 1e-9
    assert np.allclose(canon[0, 0, [0, 2]], 0.0, atol=1e-9)
    # facing +Z: the left hip is on +X
    assert canon[0, 1, 0] > canon[0, 2, 0]
    assert np.abs(canon - canonicalize(real_joints)).max() < 1e-5


def test_bad_inputs_are_named():
    with pytest.raises(ValueError, match="shape"):
        joints_to_features(np.zeros((10, 21, 3)))
    with pytest.raises(ValueError, match="NaN"):
        bad = np.zeros((10, 22, 3))
        bad[3, 4, 1] = np.nan
        joints_to_features(bad)
    with pytest.raises(ValueError, match="at least 2 frames"):
        joints_to_features(np.zeros((1, 22, 3)))
    with pytest.raises(ValueError, match="263"):
        features_to_joints(np.zeros((5, 262), dtype=np.float32))


def test_normalizer_round_trip_and_validation(tmp_path, real_vecs):
    norm = Normalizer.fit(real_vecs)
    z = norm.normalize(real_vecs)
    assert np.allclose(norm.denormalize(z), real_vecs, atol=1e-5)
    zt = norm.normalize(torch.from_numpy(real_vecs))
    assert torch.allclose(zt, torch.from_numpy(z.astype(np.float32)), atol=1e-5)
    norm.save(tmp_path)
    again = Normalizer.load(tmp_path)
    assert np.array_equal(again.mean, norm.mean) and np.array_equal(again.std, norm.std)
    with pytest.raises(ValueError, match="shape"):
        Normalizer(mean=np.zeros(10), std=np.ones(10))
    with pytest.raises(ValueError, match="positive"):
        Normalizer(mean=np.zeros(FEATURE_DIM), std=np.zeros(FEATURE_DIM))


def test_humanml3d_stats_load(real_vecs):
    from tests.conftest import REAL_DATA, real_file

    real_file("humanml3d_Mean.npy")
    norm = Normalizer.load(REAL_DATA, mean_name="humanml3d_Mean.npy", std_name="humanml3d_Std.npy")
    z = norm.normalize(real_vecs)
    assert np.isfinite(z).all() and np.abs(z).mean() < 5
