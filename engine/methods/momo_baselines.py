"""The baselines MoMo is measured against, on the same prepared leader and follower streams.

- nearest neighbour in motion space: each leader frame becomes the follower frame whose pose is
  nearest (root-relative positions and rotations), on the leader's root trajectory;
- nearest neighbour in latent space: MoMo with the softmax replaced by the arg-max key
  (the follower's V at argmax Q_leader · K_followerᵀ);
- inpainting the upper body: the output (follower's prompt, leader's noise) has its lower body
  and root overwritten after every step by the leader's latent at the same noise level.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from engine.checkpoint import LoadedModel
from engine.generate import Request, SampleConfig, generate
from engine.methods.hooks import KeepDims, PinTrajectory
from engine.methods.momo import LEADER, OUT, Stream, TransferConfig, pad_noise, transfer_streams
from engine.representation import SLICES, features_to_joints, joints_to_features, ric_dims
from engine.skeleton import JOINT_INDEX

LOWER_BODY = ("pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
              "left_foot", "right_foot")


def lower_body_dims() -> np.ndarray:
    """Feature dims of the root and the legs (the part the leader keeps when inpainting)."""
    joints = [JOINT_INDEX[n] for n in LOWER_BODY]
    dims = list(range(0, 4))  # root rotation velocity, linear velocity, height
    rot0, vel0 = SLICES["rot6d"].start, SLICES["local_vel"].start
    for j in joints:
        if j > 0:
            dims += ric_dims(j)
            dims += list(range(rot0 + 6 * (j - 1), rot0 + 6 * j))
        dims += list(range(vel0 + 3 * j, vel0 + 3 * j + 3))
    dims += list(range(SLICES["contacts"].start, SLICES["contacts"].stop))
    return np.array(sorted(dims))


def pose_features(features: np.ndarray) -> np.ndarray:
    """Root-relative positions and joint rotations of each frame: (T, 63 + 126)."""
    return np.concatenate([features[:, SLICES["ric"]], features[:, SLICES["rot6d"]]], axis=1)


def motion_space_nn(leader: np.ndarray, follower: np.ndarray, *, scale: np.ndarray | None = None) -> np.ndarray:
    """Leader joints (T+1, 22, 3), follower joints -> output joints (T+1, 22, 3).

    ``scale`` (per pose dim, e.g. the model's feature std) weighs the distance; default unit.
    """
    lf, ff = joints_to_features(leader), joints_to_features(follower)
    a, b = pose_features(lf), pose_features(ff)
    if scale is not None:
        a, b = a / scale, b / scale
    d = (a**2).sum(1)[:, None] + (b**2).sum(1)[None] - 2 * a @ b.T
    nn = np.argmin(d, axis=1)
    out = ff[nn].copy()
    root = slice(0, 4)
    out[:, root] = lf[:, root]
    return features_to_joints(out)


def latent_nn(loaded: LoadedModel, leader: Stream, follower: Stream, config: TransferConfig, *,
              sample: SampleConfig) -> np.ndarray:
    """MoMo with hard (arg-max) mixed attention."""
    hard = replace(config, hard=True)
    return transfer_streams(loaded, leader, [follower], hard, sample=sample).out(0)


def inpaint_upper_body(loaded: LoadedModel, leader: Stream, follower: Stream, *, sample: SampleConfig) -> np.ndarray:
    """The follower's prompt generates the upper body over the leader's root and legs."""
    frames = leader.frames
    noise = torch.cat([pad_noise(leader.noise, frames), pad_noise(leader.noise, frames)])
    hooks = []
    if leader.inverted:
        hooks.append(PinTrajectory({0: leader.path}))
    hooks.append(KeepDims(source=0, targets=(1,), dims=torch.as_tensor(lower_body_dims()), frames=frames))
    request = Request(prompts=[leader.prompt, follower.prompt], frames=[frames, frames], roles=[LEADER, OUT], noise=noise)
    gen = generate(loaded, request, sample, hooks=hooks)
    return gen.joints[1]
