"""The denoiser's training loss, shared by the base trainer (engine.train) and the duet block's (engine.methods.duet_losses)."""
from __future__ import annotations

from collections.abc import Sequence

import torch

from engine.representation import SLICES, features_to_joints
from engine.skeleton import FOOT_JOINTS

ROOT_DIMS = SLICES["root_height"].stop  # the root's rotation velocity, linear velocity and height: features 0-3
FEET = (*FOOT_JOINTS["left"], *FOOT_JOINTS["right"])  # the joints the foot contact term reads: ankles and toes


def masked_losses(x0_hat: torch.Tensor, x0: torch.Tensor, mask: torch.Tensor,
                  weights: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean squared error over real frames, and of the frame-to-frame differences; ``weights`` (B,) weigh each
    sample's frames (per-timestep loss weights)."""
    m = mask.float()  # (B, T)
    mv = m[:, 1:] * m[:, :-1]  # (B, T-1): both frames real
    if weights is not None:  # each sample's weight counts once in either term
        w = weights.to(m.device, m.dtype)[:, None]
        m, mv = m * w, mv * w
    # the frame-to-frame differences of the error are those of the prediction less the target's; each term is summed
    # over the features first, so the masks weigh (B, T) sums, not (B, T, 263) values
    err = x0_hat - x0
    mse = (err.square().sum(-1) * m).sum() / (m.sum() * x0.shape[-1]).clamp_min(1)
    dv = err[:, 1:] - err[:, :-1]
    vel = (dv.square().sum(-1) * mv).sum() / (mv.sum() * x0.shape[-1]).clamp_min(1)
    return mse, vel


#: a target foot joint is planted where it is this low (m above the floor) in both frames of a pair and moves less than
#: FOOT_PLANTED_SPEED (m per frame): the bounds of ``engine.evaluation.metrics.foot_skate``, the figure this term moves
FOOT_PLANTED_HEIGHT, FOOT_PLANTED_SPEED = 0.05, 0.025


def foot_contact_loss(joints_hat: torch.Tensor, joints: torch.Tensor, mask: torch.Tensor,
                      fps: float = 20.0, samples: torch.Tensor | None = None,
                      feet: Sequence[int] = FEET) -> torch.Tensor:
    """MDM's foot contact term (Tevet et al. 2023, L_foot): the predicted motion's foot joints (ankles and toes) should
    not move across the floor where the target's are planted. joints_hat, joints (B, T, 22, 3) in metres (the target's
    floor at y = 0), mask (B, T) real frames, ``samples`` (B,) bool: the samples the term counts (None: all). The mean
    over planted foot frame pairs of the predicted horizontal foot speed squared, in (m/s)^2; 0 where nothing is
    planted. ``feet``: where the foot joints are among the given joints (default: the skeleton's 22)."""
    p, q = joints[:, :, feet], joints_hat[:, :, feet]  # (B, T, 4, 3)
    low = (p[:, 1:, :, 1] < FOOT_PLANTED_HEIGHT) & (p[:, :-1, :, 1] < FOOT_PLANTED_HEIGHT)
    still = (p[:, 1:, :, [0, 2]] - p[:, :-1, :, [0, 2]]).norm(dim=-1) < FOOT_PLANTED_SPEED
    real = (mask[:, 1:] & mask[:, :-1])[..., None]
    if samples is not None:
        real = real & samples.to(real.device)[:, None, None]
    planted = (low & still & real).float()  # (B, T-1, 4)
    speed2 = ((q[:, 1:, :, [0, 2]] - q[:, :-1, :, [0, 2]]) * fps).pow(2).sum(-1)
    return (speed2 * planted).sum() / planted.sum().clamp_min(1.0)


def foot_term(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor, *,
              samples: torch.Tensor | None = None) -> torch.Tensor:
    """The foot contact loss of de-normalised features (B, T, 263): predicted x0 against the target. The predicted
    root's motion (heading, velocity, height) enters detached, so the term moves the legs to agree with the root the
    model chose. With the root in it, it slowed the root instead (walks at 0.36 m/s instead of 0.94 with the term at
    every timestep, 0.63 below t = 400): the x0 error weighs the 3 root dims among 263, so a slower root was the
    cheapest way to still a planted foot."""
    legs = torch.cat([pred[..., :ROOT_DIMS].detach(), pred[..., ROOT_DIMS:]], dim=-1)
    # only the foot joints are rebuilt (the loss reads nothing else), as foot_contact_loss's joints 0..3
    feet = list(range(len(FEET)))
    return foot_contact_loss(features_to_joints(legs, only=FEET), features_to_joints(target, only=FEET), mask,
                             samples=samples, feet=feet)
